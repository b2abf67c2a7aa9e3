"""What every element kind is: the required core :class:`ElementKind`, the optional
capabilities a kind mixes in where it has them, and the records the equilibrium
operator is made of (bodies, links, columns).

The model is Drake's SAP constraints (``multibody/contact_solvers/sap/
sap_constraint.h``): each kind of constraint is one class in its own file, and all of
them share one small interface (its constraint function, Jacobian, cost and
projection). Here a kind (a locating bearing, a Cardan joint, ...) owns, for its
elements of a scene:

- the core, which every kind writes (:class:`ElementKind`): its ``name`` and the
  ``link_kinds`` of its contacts, the translations it stops
  (:meth:`ElementKind.holds`), its bodies and columns of ``A``
  (:meth:`ElementKind.add_links`) and, per link, its compliance laws
  (:meth:`ElementKind.laws`), penalty contacts (:meth:`ElementKind.penalty`) and words
  (:meth:`ElementKind.words`); reading its scene table belongs to the base that says
  where its elements sit (:class:`~.bearing.BearingKind`,
  :class:`~.inshaft.InShaftKind`, :class:`~.joint.JointKind`);
- the capabilities, each a class a kind mixes in only where it has it and the
  callers ask for with ``isinstance``: :class:`Paired` (opposite unilateral columns
  that complementarity resolves), :class:`Releasable` (a release the advisor
  offers), :class:`Loads` (the line's end torque applied as its own forces),
  :class:`EngineJoint` (the joints a physics engine's tree hangs a body on),
  :class:`EngineLoop` (a link an engine closes outside its tree) and
  :class:`FormulationExtras` (extra unknowns or bounds of some formulations).

A bearing kind's constraint to the ground in MJCF belongs to every bearing
(:meth:`~.bearing.BearingKind.mjcf`), so it is part of that base, not a capability.
The modules that build and read operators iterate over the links and ask their kind
(:attr:`Link.element_kind`); none of them names a kind.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..scene import Scene


def mjcf_numbers(values) -> str:
    """Numbers as an MJCF attribute: space-separated, every digit kept."""
    return " ".join(f"{float(c):.17g}" for c in np.ravel(values))


LINK_KINDS: dict[str, ElementKind] = {}
"""The kind of each :attr:`Link.kind`, filled by :mod:`.registry` as it registers the
kinds (this module is below them)."""

RELEASES: dict[str, Releasable] = {}
"""The kinds that offer a release, by its name (:attr:`Release.kind`), in the advisor's
order; filled by :mod:`.registry`."""

PENALTY_SIMULATION = "the penalty-contact simulation"
"""The ``engine`` the penalty simulation asks :meth:`ElementKind.refusal` as: a kind
that it models and a physics engine does not refuses every other ``engine``."""

MUJOCO, DRAKE = "MuJoCo", "Drake"
"""The physics engines as they ask :meth:`ElementKind.refusal` (Drake reads the MJCF
MuJoCo's model is written in, so a kind it refuses is one whose MJCF it does not read)."""


@dataclass(frozen=True)
class Segment:
    """A rigid shaft body: shaft ``shaft`` (scene index) from ``lo_m`` to ``hi_m`` along
    its axis (offsets from the shaft's centre, downstream positive); :mod:`.bodies`
    cuts the shafts into them.
    """

    name: str
    shaft: int
    lo_m: float
    hi_m: float
    fraction: float  # its share of the shaft's length, mass and axial inertia

    @property
    def middle_m(self) -> float:
        """Its centre of mass: the middle of its span (m from the shaft's centre)."""
        return 0.5 * (self.lo_m + self.hi_m)


def segment_of(segments: list[Segment], shaft: int, offset_m: float) -> int:
    """Index (into ``segments``) of the segment of shaft ``shaft`` holding ``offset_m``."""
    for g, seg in enumerate(segments):
        if seg.shaft == shaft and seg.lo_m <= offset_m <= seg.hi_m:
            return g
    raise ValueError(f"offset {offset_m} m lies on no segment of shaft {shaft}")


@dataclass(frozen=True)
class Body:
    """A rigid body of the operator, rows ``6 * index .. 6 * index + 6``.

    ``kind``: ``shaft`` (a whole shaft), ``segment`` (part of a shaft cut by a slip
    joint) or ``pin`` (a cross-pin). ``shaft``: the scene's shaft index (shaft bodies),
    ``joint``: the scene's joint index (pins).
    """

    name: str
    kind: str
    shaft: int | None = None
    joint: int | None = None


@dataclass(frozen=True)
class Link:
    """One contact: its force components (``columns`` of ``A``) act on ``body`` and the
    opposite on ``other`` (``None``: the ground).

    ``kind`` names what the contact is (a key of :data:`LINK_KINDS`; its
    :class:`ElementKind` is :attr:`element_kind`); ``element`` the scene element it
    belongs to (``<shaft>.<bearing>``, a joint's or a slip joint's name); ``frame`` the
    frame of its components: ``global``, ``shaft`` (``r1, r2``, axis) or ``pin`` (``e1,
    e2, e3``); ``components`` their directions in it, ``units`` theirs (``N`` or
    ``N m``). ``label``: its name within its element (a bearing's name; ``F1`` ...
    ``F8`` of a joint; empty for a slip joint). Trunnion contacts also carry the joint,
    the trunnion axis (``e1`` driving, ``e2`` driven) and the side (+1 at
    ``+hs``/``+ht``).
    """

    name: str
    kind: str
    columns: tuple[int, ...]
    body: int
    other: int | None
    element: str
    frame: str
    components: tuple[str, ...]
    shaft: int | None = None
    joint: int | None = None
    trunnion: str = ""
    side: float = 0.0
    label: str = ""
    units: tuple[str, ...] = ()

    def column(self, component: str) -> int:
        """Column of ``A`` of one of its components (e.g. ``e2``, ``r1``, ``torque``)."""
        return self.columns[self.components.index(component)]

    @property
    def element_kind(self) -> ElementKind:
        """The kind that made this contact and knows its laws."""
        return LINK_KINDS[self.kind]


@dataclass(frozen=True)
class Column:
    """One column while assembling: a force at ``point`` along ``direction`` (or a pure
    moment about ``direction``, ``point`` None) on ``body``, the opposite on ``other``;
    ``unilateral``: a push, >= 0.
    """

    name: str
    body: int
    other: int | None
    point: np.ndarray | None
    direction: np.ndarray
    unilateral: bool = False


@dataclass
class Layout:
    """The operator while its kinds add to it: the scene, its rest geometry ``geo``,
    kinematics ``kin`` and shaft ``frames`` (rows ``r1, r2, axis`` per shaft), the shaft
    bodies ``segments``; the bodies, links and columns made so far.
    """

    scene: Scene
    geo: object
    kin: object
    segments: list
    frames: np.ndarray
    bodies: list[Body] = field(default_factory=list)
    links: list[Link] = field(default_factory=list)
    columns: list[Column] = field(default_factory=list)

    def add_body(self, body: Body) -> int:
        """Append a body; its index."""
        self.bodies.append(body)
        return len(self.bodies) - 1

    def add(self, columns: list[Column], **link) -> None:
        """Append a link (its fields but ``columns``) and its columns."""
        first = len(self.columns)
        self.columns.extend(columns)
        self.links.append(Link(columns=tuple(range(first, len(self.columns))), **link))

    def segment(self, shaft: int, offset_m: float) -> int:
        """Index of the body of shaft ``shaft`` (scene index) holding ``offset_m``."""
        return segment_of(self.segments, shaft, offset_m)


@dataclass(frozen=True)
class Law:
    """A compliance law of one contact force (``columns``, one vector): stiffness
    ``stiffness`` (N/m^n; N m/rad for a moment), gap ``gap_m`` (m) before it carries;
    ``hertz``: ``f = K d^n`` with the scene's exponent ``n`` (else linear, ``n = 1``).
    """

    columns: tuple[int, ...]
    stiffness: float
    gap_m: float
    hertz: bool = False


@dataclass(frozen=True)
class Release:
    """One release, a design change that removes a redundancy: ``kind`` names it (the
    :attr:`Releasable.release_name` of the kind that offers it), ``shaft`` and
    ``bearing`` where it applies (:mod:`..release`).
    """

    kind: str
    shaft: str
    bearing: str = ""

    @property
    def offered_by(self) -> Releasable:
        return RELEASES[self.kind]

    @property
    def label(self) -> str:
        """The release as typed on the command line (``float:<shaft>.<bearing>``, ...)."""
        return self.offered_by.release_label(self)

    @property
    def words(self) -> str:
        return self.offered_by.release_words(self)

    def to_json(self) -> dict:
        return {"release": self.label, "description": self.words}


@dataclass(frozen=True)
class PairMode:
    """How a pair of opposite unilateral columns is named as a null-space mode."""

    kind: str
    description: str
    release: str


class ElementKind:
    """The core every element kind writes (module doc); a kind adds the capabilities it
    has by mixing in their classes.

    ``name``: the kind's name in a scene (a bearing's or a joint's ``kind``, an in-shaft
    kind's name); ``link_kinds``: the :attr:`Link.kind` values its links take, one per
    kind of contact it makes (none for a kind that makes no contact, a load).

    Three flags are read of every bearing or contact, so each kind has them; ``False``
    is the plain answer, not a missing one: ``locates``: it carries axial force both
    ways (a shaft body with two such has an axial split); ``slides``: its shaft slides
    through it axially; ``paper``: the paper's polar method takes it (eqs. 11-14 for
    bearings, 33-46 for joints).

    The methods that raise ``NotImplementedError`` here are the required core:
    :meth:`holds` and :meth:`add_links` of every kind, and :meth:`laws`,
    :meth:`penalty`, :meth:`words` of every kind that makes links (they are asked per
    link, so a kind without ``link_kinds`` is never asked). :meth:`check` and
    :meth:`refusal` have defaults because their absence is the same answer as an empty
    one: nothing to check beyond the element's own fields, every model takes it.
    """

    name: str = ""
    link_kinds: tuple[str, ...] = ()
    locates: bool = False
    slides: bool = False
    paper: bool = False

    def check(self, element, shaft: int, scene: Scene) -> None:
        """Raise :class:`~.scene.SceneError` where ``element`` cannot be used in
        ``scene`` (beyond its own fields); nothing to check by default.
        """

    def refusal(self, element, engine: str) -> str | None:
        """Why ``engine`` (:data:`PENALTY_SIMULATION`, a physics engine; named in the
        message) cannot model ``element``, None where it can (the default: every model
        takes it).
        """
        return None

    def holds(self, element, shaft: int, segments: list, frames: np.ndarray) -> list:
        """The rigid translations it stops: ``(body, matrix, other)`` rows, ``matrix``
        (3, 3) the directions stopped on ``body`` relative to ``other`` (None: ground);
        ``frames``: per shaft the rows ``r1, r2, axis``. Required: the line's sliding
        check rests on it, and a silent empty answer would pass a line that slides.
        """
        raise NotImplementedError

    def add_links(self, element, shaft: int, index: int, layout: Layout) -> None:
        """Add its bodies, links and columns to ``layout`` (``shaft``: the scene index
        of its shaft, the upstream one for a joint; ``index``: its own in its list).
        """
        raise NotImplementedError

    def laws(self, link: Link, scene: Scene) -> list[Law]:
        """Its contact forces (column groups) with their compliance laws, in column
        order; the groups are also the contact forces ``min_max`` bounds.
        """
        raise NotImplementedError

    def penalty(self, link: Link, rows) -> None:
        """Add its penalty contacts (eqs. 75-78) through ``rows`` (the penalty
        model's :class:`~..penalty.ContactRows`).
        """
        raise NotImplementedError

    def words(self, link: Link) -> str:
        """What the contact is, in words (figure titles, reports)."""
        raise NotImplementedError


class Paired:
    """Capability: some of its links' unilateral columns come in opposite pairs of which
    only one pushes (complementarity resolves them; a Cardan joint's end faces, facing
    angular-contact bearings). Both methods are written.
    """

    def pairs(self, links: list[Link]) -> list[tuple[int, int]]:
        """Pairs of opposite unilateral columns among its ``links``: only one of each
        pushes (complementarity).
        """
        raise NotImplementedError

    def pair_mode(self, link: Link, other: Link) -> PairMode:
        """The null-space mode of one of its pairs (both pushing equally)."""
        raise NotImplementedError


class Releasable:
    """Capability: it offers a release, a design change that removes a redundancy
    (:mod:`..release`). ``release_name`` names it (:attr:`Release.kind`),
    ``release_form`` is how it is typed (``<prefix>:<target>``), ``release_rank`` orders
    the advisor's tries (lower first), ``adds_joint``: the release adds an element, a
    dearer design change than changing one. Every method is written.
    """

    release_name: str
    release_form: str
    release_rank: int
    adds_joint: bool = False

    def releases(self, scene: Scene) -> list[Release]:
        """The single releases it offers on ``scene``, in the advisor's order."""
        raise NotImplementedError

    def parse_release(self, target: str, scene: Scene) -> Release | None:
        """Its release from the text after ``<prefix>:``, None if ``target`` names none."""
        raise NotImplementedError

    def release_label(self, release: Release) -> str:
        """The release as typed on the command line."""
        raise NotImplementedError

    def release_words(self, release: Release) -> str:
        """The release in words (reports, ``sets --release``)."""
        raise NotImplementedError

    def apply_release(self, release: Release, shafts: list, elements: list) -> None:
        """Apply ``release`` to a scene's ``shafts`` and ``elements`` (lists, in place)."""
        raise NotImplementedError


class Loads:
    """Capability: it applies the line's load torque (on the last shaft) or input torque
    (on the first) as forces of its own (a gear mesh) instead of a pure torque; the
    equilibrium operator and the penalty model apply :meth:`load` at its end.
    """

    def load(self, element, torque_N_m: np.ndarray, frame: np.ndarray,
             centre: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Its forces taking the torque ``torque_N_m`` (T,) off its shaft (the load
        torque; minus the input torque on the first shaft): ``(point, force)``, a point
        (3,) and the force (T, 3) there (N), on a shaft of frame rows ``r1, r2, axis``
        and centre ``centre``. The force is ``T lin + |T| abs`` for two vectors fixed
        by the geometry (the penalty model reads them from ``T = +-1``,
        :meth:`~..penalty_model.Model._line_loads`).
        """
        raise NotImplementedError


@dataclass(frozen=True)
class EngineStep:
    """One joint of a physics engine's kinematic tree: its ``type`` (``hinge``,
    ``slide``), global ``axis`` and ``point`` (m) at the scene's start, its ``speed`` in
    the scene's initial state (rad/s or m/s) and a passive spring-damper on it
    (``stiffness`` N m/rad or N/m, ``damping`` N m s/rad or N s/m; 0: none).
    """

    type: str
    axis: np.ndarray
    point: np.ndarray
    speed: float = 0.0
    stiffness: float = 0.0
    damping: float = 0.0


class EngineJoint:
    """Capability: a physics engine (MuJoCo, Drake) hangs one of its links' two bodies
    on the other by joints of its kinematic tree (a Cardan joint's hinges, a slip
    joint's slide, a CV joint's three hinges, a disc coupling's six sprung joints); a
    kind without it that joins two bodies refuses the engines
    (:meth:`ElementKind.refusal`). A kind writes :meth:`mjcf_joint` (one joint;
    :meth:`mjcf_speed` defaults to one that starts still) or :meth:`mjcf_steps` (a
    chain); :meth:`mjcf_body` only a kind that makes a body (a cross-pin) and
    :meth:`mjcf_couplings` one whose joints are coupled.
    """

    def mjcf_joint(self, link: Link, child: int, start) -> tuple[str, np.ndarray, np.ndarray]:
        """The engine joint by which body ``child`` (one of ``link``'s two) hangs on the
        other in MuJoCo's kinematic tree: its type (``hinge``, ``slide``), global axis
        and point at the scene's start (``start``: the engine's
        :class:`~..engine_mujoco.Start`).
        """
        raise NotImplementedError

    def mjcf_speed(self, link: Link, child: int, axis: np.ndarray, start) -> float:
        """That joint's speed in the scene's initial state (rad/s or m/s); 0 here: the
        two bodies start at one speed (a slide).
        """
        return 0.0

    def mjcf_steps(self, link: Link, child: int, start) -> list[EngineStep]:
        """The joints by which body ``child`` hangs on the other, in order from it: the
        engine puts a nearly massless body of its own between two of them. One here,
        :meth:`mjcf_joint` at :meth:`mjcf_speed`.
        """
        joint, axis, point = self.mjcf_joint(link, child, start)
        return [EngineStep(joint, axis, point, self.mjcf_speed(link, child, axis, start))]

    def mjcf_couplings(self, link: Link, joints: list[str], soft: str) -> str:
        """MJCF ``<equality>`` elements among its joints (named ``joints``, in the
        order of :meth:`mjcf_steps`), softness attributes ``soft``; none here.
        """
        return ""

    def mjcf_body(self, body: int, start) -> tuple:
        """``(pos, rot, mass, inertia)`` at the start of a body this kind made (a
        cross-pin): its centre (m), rotation (3, 3), mass (kg) and global inertia tensor
        (kg m^2) about its centre.
        """
        raise NotImplementedError


class EngineLoop:
    """Capability: a physics engine closes its links outside the kinematic tree (a
    centring ball between shafts that are not adjacent): a nearly massless carrier hangs
    on one of the link's bodies by a joint (the freedom the link leaves), and a
    ``connect`` equality, named as the link, holds a point of the other body on it. The
    engine reads the link's force from that equality.
    """

    def mjcf_loop(self, link: Link, start) -> tuple[int, EngineStep]:
        """``(host, step)``: the operator body the carrier hangs on and its joint there;
        the carrier sits at ``step.point``, which the other body of ``link`` holds.
        """
        raise NotImplementedError


class FormulationExtras:
    """Capability: some formulations add unknowns or bounds for its links beyond the
    operator's columns. A kind writes the ones it has; the others keep their empty
    answer, which is exactly what a link without such terms adds (nothing), so the
    formulations ask every kind that mixes this in.
    """

    def friction(self, link: Link, scene: Scene):
        """Its bounded friction force (a slip joint's
        :class:`~.slip.SlipFriction`), None without one.
        """
        return None

    def rim_moments(self, op, i: int, link: Link) -> list:
        """Extra unknowns of ``socp_face`` (moments an end face carries), none here."""
        return []

    def friction_forces(self, op, i: int, link: Link, frameless: np.ndarray, mu: float
                        ) -> list:
        """Extra unknowns of ``friction`` (Coulomb forces in joints), none here."""
        return []
