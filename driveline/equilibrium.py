"""The equilibrium operator ``A(t) x = b(t)`` of all bodies (DESIGN §1).

Rows: per body (shaft bodies in chain order, then cross-pins), three force and three
moment equations in the global frame, moments about the body's reference point (a
shaft body's centre of mass, a cross-pin's centre). Row ``i`` reads: sum of contact
forces (moments) on the body = ``b_i`` = inertial (d'Alembert) terms - applied loads -
weight. A shaft with a slip joint is two bodies, ``<shaft>.upstream`` and
``<shaft>.downstream`` (:mod:`cardan_forces.driveline.elements`).

Columns: the contact forces, in N (slip-joint moments in N·m), each acting on one body
and the opposite on the other (a cross-pin's contacts are reported as forces on the
pin). Each element kind makes its own columns and names them (:mod:`.elements`: one
module per kind says what its columns are, e.g. ``bearing.<shaft>.<bearing>.<x|y|z>``
of a locating bearing in :mod:`.elements.locating`, ``<joint>.F1.e2`` ... of a Cardan
joint in :mod:`.elements.cardan`). The operator carries this structure as data
(:attr:`Operator.bodies`, :attr:`Operator.contacts`): formulations never read it from
the names, and ask a contact's kind (:attr:`Link.element_kind`) for its laws.

``b`` is kept as a sum of named terms, one per effect, so that switching an effect
off removes exactly its term: ``applied`` (drive and load torques, always),
``gravity`` (the shafts' weight, and the cross-pins' when ``crosspin_inertia`` gives
them mass), ``inertia`` (shafts), ``crosspin_inertia`` (cross-pins).

The shaft frame of the components named ``r1, r2``: ``r1`` normal to the axis in the
articulation plane (``plane_normal x axis``), ``r2`` the articulation plane's normal
(``-y`` in ``paper``). Fixed directions (a shaft's axis does not move), the same for
every shaft of the line, so the names stay stable when a bearing's kind changes.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .dynamics import Motion, _pin_inertia_global
from .elements import Segment, segment_of, shaft_segments
from .elements.base import Body, FormulationExtras, Layout, Link, Loads
from .elements.bodies import frames_of
from .elements.registry import LINK_KINDS, PAIRED, scene_elements
from .elements.slip import SlipFriction
from .scene import Scene

__all__ = ["AXES", "BearingLoad", "Body", "CONTACT_KINDS", "Link", "Operator", "SlipFriction",
           "body_references", "build_operator", "shaft_frames"]

AXES = "xyz"

CONTACT_KINDS = tuple(LINK_KINDS)
"""What a contact can be: every element kind's :attr:`Link.kind` values."""


@dataclass(frozen=True)
class BearingLoad:
    """One bearing's load on its shaft in the shaft's own frame (N), over instants:
    ``in_plane`` along ``r1`` (normal to the axis, in the articulation plane),
    ``normal`` along ``r2`` (the plane's normal), ``axial`` along the shaft's axis
    (downstream positive; zero for a floating bearing), ``radial`` the length of the
    part normal to the axis.
    """

    element: str
    shaft: int
    label: str
    in_plane: np.ndarray
    normal: np.ndarray
    axial: np.ndarray

    @property
    def radial(self) -> np.ndarray:
        return np.hypot(self.in_plane, self.normal)


@dataclass(frozen=True)
class Operator:
    """``A`` (T, rows, n) and ``b`` (T, rows) over the motion's instants.

    ``terms`` holds ``b``'s parts by effect; ``b`` is their sum. ``unilateral`` marks
    the pushes (>= 0: end faces, ...); ``pairs`` the index pairs of opposite pushes of
    which only one touches (the two end faces of one trunnion pair, complementary in
    the paper, eqs. 39, 46; each kind says which,
    :meth:`~.elements.base.Paired.pairs`). ``bodies`` and
    ``contacts`` are the structure (what each row block and column is);
    ``pin_frames[j, t]`` the rows ``e1, e2, e3`` of cross-pin ``j``; ``shaft_frames[k]``
    the rows ``r1, r2, axis`` of shaft ``k``; ``slip_friction`` the bounded axial forces.
    ``points[t, c]`` is where column ``c`` acts (m, global; NaN for a pure moment) and
    ``directions[t, c]`` its direction (the moment's axis for a pure moment).
    """

    t: np.ndarray
    A: np.ndarray
    b: np.ndarray
    terms: dict[str, np.ndarray]
    names: tuple[str, ...]
    rows: tuple[str, ...]
    unilateral: np.ndarray
    pairs: tuple[tuple[int, int], ...]
    scene: Scene
    bodies: tuple[Body, ...] = ()
    contacts: tuple[Link, ...] = ()
    pin_frames: np.ndarray | None = None
    shaft_frames: np.ndarray | None = None
    slip_friction: tuple[SlipFriction, ...] = ()
    points: np.ndarray | None = None
    directions: np.ndarray | None = None

    def index(self, name: str) -> int:
        """Column of a named force component."""
        try:
            return self.names.index(name)
        except ValueError:
            raise KeyError(f"no force component {name!r}") from None

    @property
    def moment_rows(self) -> np.ndarray:
        """Boolean mask of the moment rows (N·m), from the body blocks."""
        return np.tile(np.repeat([False, True], 3), len(self.bodies))

    def of_kind(self, *kinds: str) -> list[Link]:
        """The contacts of the given kinds, in column order."""
        return [c for c in self.contacts if c.kind in kinds]

    def joint_contacts(self, joint: int) -> dict[str, Link]:
        """The contacts of joint ``joint`` (scene index) by label, ``F1`` ... ``F8``."""
        return {c.label: c for c in self.contacts if c.joint == joint}

    def bearings(self, shaft: int | None = None) -> list[Link]:
        """The bearings, the contacts with the ground (of shaft ``shaft``, scene index;
        all without), in column order.
        """
        return [c for c in self.contacts if c.other is None
                and (shaft is None or c.shaft == shaft)]

    def bearing_matrix(self, contact: Link) -> np.ndarray:
        """(3, n): the rows that map the forces ``x`` to the bearing's load on its shaft
        in the shaft's frame ``(r1, r2, axis)`` (N): ``bearing_matrix(c) @ x``.
        """
        out = np.zeros((3, len(self.names)))
        cols = list(contact.columns)
        out[:, cols] = self.shaft_frames[contact.shaft] @ self.directions[0, cols].T
        return out

    def bearing_loads(self, x: np.ndarray, shaft: int | None = None) -> dict[str, BearingLoad]:
        """Every bearing's load (of shaft ``shaft`` only, if given) from forces ``x``
        (..., n), in its shaft's frame, by element (``<shaft>.<bearing>``), N.
        """
        out = {}
        for c in self.bearings(shaft):
            r1, r2, axial = np.moveaxis(np.asarray(x) @ self.bearing_matrix(c).T, -1, 0)
            out[c.element] = BearingLoad(c.element, c.shaft, c.label, r1, r2, axial)
        return out

    def contact_magnitudes(self, x: np.ndarray, kinds: tuple[str, ...] = CONTACT_KINDS
                           ) -> dict[str, np.ndarray]:
        """Per contact of ``kinds`` whose components share one unit (every kind but a
        slip joint's, which mixes N and N m), the length of its force, in that unit
        (:attr:`Link.units`): a bearing's total force, a trunnion's radial force, an end
        face's push (N), from the forces ``x`` (..., n).
        """
        x = np.asarray(x)
        return {c.name: np.linalg.norm(x[..., list(c.columns)], axis=-1)
                for c in self.of_kind(*kinds) if len(set(c.units)) == 1}

    def bearing_force(self, contact: Link, x: np.ndarray) -> np.ndarray:
        """A bearing's force on its shaft as a global vector (..., 3), N, from the
        forces ``x`` (..., n): its components along their (fixed) directions.
        """
        cols = list(contact.columns)
        return np.asarray(x)[..., cols] @ self.directions[0, cols]

    def body_rows(self, body: int, part: str = "moment") -> slice:
        """Rows of ``body``'s force or moment equations."""
        start = 6 * body + (3 if part == "moment" else 0)
        return slice(start, start + 3)


def shaft_frames(motion: Motion) -> np.ndarray:
    """Per shaft the rows ``r1, r2, axis``: ``r1 = n x axis`` in the articulation plane,
    ``r2 = n`` its normal (the geometry's ``plane_normal``).
    """
    return frames_of(motion.geometry)


def _layout(motion: Motion) -> Layout:
    """Bodies, contacts (with column indices) and columns of the scene's line: the shaft
    bodies, then what each element's kind adds, in :func:`scene_elements` order.
    """
    scene = motion.scene
    segments = shaft_segments(scene)
    layout = Layout(scene, motion.geometry, motion.kin, segments, shaft_frames(motion),
                    bodies=[Body(s.name, "segment" if s.fraction < 1 else "shaft",
                                 shaft=s.shaft) for s in segments])
    for kind, element, shaft, index in scene_elements(scene):
        kind.add_links(element, shaft, index, layout)
    return layout


def body_references(geo, segments) -> np.ndarray:
    """(bodies, 3): each body's moment reference at rest (m, global), in the operator's
    body order: a shaft segment's centre of mass, then each cross-pin's centre (the
    joints that add one, in chain order).
    """
    return np.concatenate([[geo.centres[s.shaft] + s.middle_m * geo.axes[s.shaft]
                            for s in segments], geo.joint_centres[geo.pinned]]).reshape(-1, 3)


def build_operator(motion: Motion) -> Operator:
    """Assemble ``A`` and ``b`` at every instant of ``motion`` (batched)."""
    scene, geo = motion.scene, motion.geometry
    layout = _layout(motion)
    segments, bodies, links, cols = layout.segments, layout.bodies, layout.links, \
        layout.columns
    refs = body_references(geo, segments)
    T = len(motion.t)
    A = np.zeros((T, 6 * len(bodies), len(cols)))
    points = np.full((T, len(cols), 3), np.nan)
    directions = np.empty((T, len(cols), 3))
    for c, col in enumerate(cols):
        direction = np.broadcast_to(col.direction, (T, 3))
        directions[:, c] = direction
        if col.point is not None:
            points[:, c] = col.point
        for target, sign in ((col.body, 1.0), (col.other, -1.0)):
            if target is None:
                continue
            if col.point is None:  # a pure moment
                A[:, 6 * target + 3: 6 * target + 6, c] = sign * direction
                continue
            point = np.broadcast_to(col.point, (T, 3))
            A[:, 6 * target: 6 * target + 3, c] = sign * direction
            A[:, 6 * target + 3: 6 * target + 6, c] = sign * np.cross(point - refs[target],
                                                                       direction)
    names = tuple(c.name for c in cols)
    pairs = tuple(pair for kind in PAIRED
                  for pair in kind.pairs([c for c in links if c.kind in kind.link_kinds]))
    rows = tuple(f"{body.name}.{kind}.{axis}" for body in bodies
                 for kind in ("force", "moment") for axis in AXES)
    terms = _load_terms(motion, segments)
    return Operator(
        t=motion.t, A=A, b=sum(terms.values()), terms=terms, names=names, rows=rows,
        unilateral=np.array([c.unilateral for c in cols], bool), pairs=pairs, scene=scene,
        bodies=tuple(bodies), contacts=tuple(links),
        pin_frames=np.stack([motion.kin.e1, motion.kin.e2, motion.kin.e3], axis=2),
        shaft_frames=shaft_frames(motion), slip_friction=_slip_friction(scene, links),
        points=points, directions=directions,
    )


def _slip_friction(scene: Scene, links: list[Link]) -> tuple[SlipFriction, ...]:
    """The friction bounds of the links that have one (a slip joint with friction)."""
    return tuple(f for c in links if isinstance(c.element_kind, FormulationExtras)
                 and (f := c.element_kind.friction(c, scene)) is not None)


def _load_terms(motion: Motion, segments: list[Segment]) -> dict[str, np.ndarray]:
    """``b``'s terms, one per effect the scene calls for (and ``applied``, always)."""
    scene, geo = motion.scene, motion.geometry
    n_seg = len(segments)
    pins = np.flatnonzero(np.array(motion.kin.pinned, bool))  # their bodies: n_seg + p
    n_rows = 6 * (n_seg + len(pins))
    T = len(motion.t)
    moment = lambda body: slice(6 * body + 3, 6 * body + 6)  # noqa: E731
    force = lambda body: slice(6 * body, 6 * body + 3)  # noqa: E731
    first, last = 0, n_seg - 1  # the input torque acts upstream, the load downstream

    applied = np.zeros((T, n_rows))
    takers = [(kind, e, k) for kind, e, k, _ in scene_elements(scene)
              if isinstance(kind, Loads)]
    ends = {k for _, _, k in takers}
    if 0 not in ends:
        applied[:, moment(first)] -= motion.input_torque[:, None] * geo.axes[0]
    if len(scene.shafts) - 1 not in ends:
        applied[:, moment(last)] += motion.load_torque[:, None] * geo.axes[-1]
    for kind, element, k in takers:  # a torque as the element's forces
        taken = -motion.input_torque if k == 0 else motion.load_torque
        point, load = kind.load(element, taken, frames_of(geo)[k], geo.centres[k])
        body = segment_of(segments, k, element.offset_m)
        reference = body_references(geo, segments)[body]
        applied[:, force(body)] -= load
        applied[:, moment(body)] -= np.cross(point - reference, load)
    terms = {"applied": applied}

    if scene.has("gravity"):
        g = np.array(scene.gravity_m_s2)
        weight = np.zeros((T, n_rows))
        for b, seg in enumerate(segments):
            weight[:, force(b)] -= seg.fraction * scene.shafts[seg.shaft].mass_kg * g
        if scene.has("crosspin_inertia"):
            for p in range(len(pins)):
                weight[:, force(n_seg + p)] -= scene.crosspin.mass_kg * g
        terms["gravity"] = weight

    if scene.has("inertia"):
        inertial = np.zeros((T, n_rows))
        for b, seg in enumerate(segments):
            k, shaft = seg.shaft, scene.shafts[seg.shaft]
            # the shaft axis is principal: J omega' + omega x J omega = J_axial alpha a
            inertial[:, moment(b)] += (seg.fraction * shaft.axial_inertia_kg_m2
                                       * motion.alpha[k])[:, None] * geo.axes[k]
            inertial[:, force(b)] += seg.fraction * shaft.mass_kg * motion.com_acceleration[k]
        terms["inertia"] = inertial

    if scene.has("crosspin_inertia") and len(pins):
        jp = _pin_inertia_global(scene, motion.kin)
        w, dw = motion.pin_omega, motion.pin_alpha
        gyro = np.einsum("jtab,jtb->jta", jp, dw) + np.cross(w, np.einsum("jtab,jtb->jta", jp, w))
        pinned = np.zeros((T, n_rows))
        for p, j in enumerate(pins):
            pinned[:, moment(n_seg + p)] += gyro[j]
        terms["crosspin_inertia"] = pinned
    return terms
