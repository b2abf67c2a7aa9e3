"""The equilibrium operator ``A(t) x = b(t)`` of all bodies (DESIGN §1).

Rows: per body (shaft bodies in chain order, then cross-pins), three force and three
moment equations in the global frame, moments about the body's reference point (a
shaft body's centre of mass, a cross-pin's centre). Row ``i`` reads: sum of contact
forces (moments) on the body = ``b_i`` = inertial (d'Alembert) terms - applied loads -
weight. A shaft with a slip joint is two bodies, ``<shaft>.upstream`` and
``<shaft>.downstream`` (:mod:`cardan_forces.driveline.elements`).

Columns: the contact forces, in N (slip-joint moments in N·m), each acting on one body
and the opposite on the other (a cross-pin's contacts are reported as forces on the
pin). The operator carries this structure as data (:attr:`Operator.bodies`,
:attr:`Operator.contacts`): formulations never read it from the names.

- ``bearing.<shaft>.<bearing>.<x|y|z>``: a locating bearing's force on its shaft,
  global frame;
- ``bearing.<shaft>.<bearing>.<r1|r2>``: a floating bearing's force on its shaft, in
  the shaft's frame: ``r1`` normal to the axis in the articulation plane
  (``plane_normal x axis``), ``r2`` the articulation plane's normal (``-y`` in
  ``paper``). Fixed directions (a shaft's axis does not move), the same for every
  shaft of the line, so the names stay stable when a bearing's kind changes;
- ``<slip>.shear.<r1|r2>`` (N), ``<slip>.bending.<r1|r2>``, ``<slip>.torque`` (N·m):
  a slip joint's force and moments on the downstream segment at the joint, ``torque``
  about the shaft axis (downstream positive), in the shaft's frame as above; no axial
  force when frictionless. With friction coefficient ``mu > 0`` also
  ``<slip>.axial`` (N, along the axis), bounded by ``|axial| <= mu |torque| /
  pitch_radius`` (:class:`SlipFriction`);
- ``<joint>.F1.e2``, ``<joint>.F1.e3``: radial force on the driving trunnion at
  ``+hs e1``; ``F2`` the same at ``-hs e1``; ``<joint>.F3`` >= 0 the end-face push
  along ``-e1`` at ``+ht e1``; ``F4`` >= 0 along ``+e1`` at ``-ht e1``;
- ``F5`` (``.e3``, ``.e1``) at ``+hs e2``, ``F6`` at ``-hs e2``, ``F7`` >= 0 along
  ``-e2`` at ``+ht e2``, ``F8`` >= 0 along ``+e2`` at ``-ht e2``: the driven yoke's.

Frame of the joint components: the cross-pin's own ``(e1, e2, e3)``, ``e1`` the
driving trunnion axis, ``e2`` the driven one, ``e3 = e1 x e2``. A radial force acts
through the trunnion axis, so it enters linearly (the paper's contact angle is a
change of variables); in this operator an end-face force acts on the trunnion axis.

``b`` is kept as a sum of named terms, one per effect, so that switching an effect
off removes exactly its term: ``applied`` (drive and load torques, always),
``gravity`` (the shafts' weight, and the cross-pins' when ``crosspin_inertia`` gives
them mass), ``inertia`` (shafts), ``crosspin_inertia`` (cross-pins).

Why one module this long: it is the only place that names forces; the operator's
structure (bodies, links, bearing loads) and the columns and terms it is built from are
one piece of knowledge, read together with the list above.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .dynamics import Motion, _pin_inertia_global
from .elements import Segment, segment_of, shaft_segments
from .scene import Scene

AXES = "xyz"

CONTACT_KINDS = ("bearing-locating", "bearing-floating", "trunnion-radial", "end-face",
                 "slip")
"""What a contact is: a bearing of either kind, a trunnion's radial contact in its bore,
an end face (>= 0), a slip joint's spline."""


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

    ``kind`` is one of :data:`CONTACT_KINDS`; ``element`` the scene element it belongs to
    (``<shaft>.<bearing>``, a joint's or a slip joint's name); ``frame`` the frame of its
    components: ``global``, ``shaft`` (``r1, r2``, axis) or ``pin`` (``e1, e2, e3``);
    ``components`` their directions in it, ``units`` theirs (``N`` or ``N m``).
    ``label``: its name within its element (a bearing's name; ``F1`` ... ``F8`` of a
    joint; empty for a slip joint). Trunnion contacts also carry the joint, the trunnion
    axis (``e1`` driving, ``e2`` driven) and the side (+1 at ``+hs``/``+ht``).
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
class SlipFriction:
    """The axial force of a slip joint with friction: ``|x[axial]| <= ratio |x[torque]|``,
    ``ratio = mu / r`` (1/m).

    A spline of pitch radius ``r`` transmitting a torque ``T`` presses its teeth with a
    total tangential (normal-to-flank, for straight-sided teeth and no pressure angle)
    load ``N = T / r``; Coulomb friction on the flanks resists sliding by at most
    ``mu N = mu T / r``: the handbooks' spline displacement (slip) force (e.g. SAE
    Universal Joint and Driveshaft Design Manual, AE-7, section on slip spline
    friction; Seherr-Thoss et al., *Universal Joints and Driveshafts*, 2nd ed.,
    Springer 2006, on axial displacement forces of splined propshafts). Involute
    flanks at pressure angle ``alpha`` would give ``T / (r cos alpha)``; the model
    takes ``alpha = 0`` (an assumption, the lower bound).
    """

    slip: str
    axial: int
    torque: int
    ratio_per_m: float


@dataclass(frozen=True)
class Operator:
    """``A`` (T, rows, n) and ``b`` (T, rows) over the motion's instants.

    ``terms`` holds ``b``'s parts by effect; ``b`` is their sum. ``unilateral`` marks
    the end-face components (>= 0); ``pairs`` are the index pairs of the two end faces
    of one trunnion pair, complementary in the paper (eqs. 39, 46). ``bodies`` and
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
        return {c.label: c for c in self.contacts
                if c.joint == joint and c.kind in ("trunnion-radial", "end-face")}

    def bearings(self, shaft: int | None = None) -> list[Link]:
        """The bearings (of shaft ``shaft``, scene index; all without), in column order."""
        return [c for c in self.of_kind("bearing-locating", "bearing-floating")
                if shaft is None or c.shaft == shaft]

    def bearing_matrix(self, contact: Link) -> np.ndarray:
        """(3, n): the rows that map the forces ``x`` to the bearing's load on its shaft
        in the shaft's frame ``(r1, r2, axis)`` (N): ``bearing_matrix(c) @ x``.
        """
        out = np.zeros((3, len(self.names)))
        frame = self.shaft_frames[contact.shaft]
        basis = np.eye(3) if contact.frame == "global" else frame[:2]
        out[:, list(contact.columns)] = frame @ basis.T
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
        forces ``x`` (..., n): its x, y, z columns, or its r1, r2 in the shaft's frame.
        """
        values = np.asarray(x)[..., list(contact.columns)]
        if contact.frame == "global":
            return values
        return values @ self.shaft_frames[contact.shaft, :2]

    def body_rows(self, body: int, part: str = "moment") -> slice:
        """Rows of ``body``'s force or moment equations."""
        start = 6 * body + (3 if part == "moment" else 0)
        return slice(start, start + 3)


@dataclass(frozen=True)
class _Column:
    """One column while assembling: a force at ``point`` along ``direction`` (or a pure
    moment about ``direction``) on ``body``, the opposite on ``other``.
    """

    name: str
    body: int
    other: int | None
    point: np.ndarray | None
    direction: np.ndarray
    unilateral: bool = False


def shaft_frames(motion: Motion) -> np.ndarray:
    """Per shaft the rows ``r1, r2, axis``: ``r1 = n x axis`` in the articulation plane,
    ``r2 = n`` its normal (the geometry's ``plane_normal``).
    """
    geo = motion.geometry
    n = np.broadcast_to(geo.plane_normal, geo.axes.shape)
    return np.stack([np.cross(n, geo.axes), n, geo.axes], axis=1)


def _layout(motion: Motion):
    """Bodies, contacts (with column indices) and columns of the scene's line."""
    scene, geo, kin = motion.scene, motion.geometry, motion.kin
    segments = shaft_segments(scene)
    frames = shaft_frames(motion)
    bodies = [Body(s.name, "segment" if s.fraction < 1 else "shaft", shaft=s.shaft)
              for s in segments]
    bodies += [Body(f"{j.name}.pin", "pin", joint=k) for k, j in enumerate(scene.joints)]
    cols: list[_Column] = []
    links: list[Link] = []

    def add(link: dict, columns: list[_Column]) -> None:
        first = len(cols)
        cols.extend(columns)
        links.append(Link(columns=tuple(range(first, len(cols))), **link))

    for k, shaft in enumerate(scene.shafts):
        for bearing, point in zip(shaft.bearings, geo.bearing_points[k]):
            g = segment_of(segments, k, bearing.offset_m)
            name = f"bearing.{shaft.name}.{bearing.name}"
            locating = bearing.kind == "locating"
            comps = tuple(AXES) if locating else ("r1", "r2")
            dirs = np.eye(3) if locating else frames[k, :2]
            add(dict(name=name, kind=f"bearing-{bearing.kind}", body=g, other=None,
                     element=f"{shaft.name}.{bearing.name}", label=bearing.name,
                     frame="global" if locating else "shaft", components=comps, shaft=k,
                     units=("N",) * len(comps)),
                [_Column(f"{name}.{c}", g, None, point, d) for c, d in zip(comps, dirs)])
    for slip in scene.slip_joints:
        _slip_columns(slip, scene, segments, geo, frames, add)
    n_seg = len(segments)
    for j, joint in enumerate(scene.joints):
        _joint_columns(j, joint, n_seg + j, segments, geo, kin, add)
    return segments, bodies, links, cols


def _slip_columns(slip, scene, segments, geo, frames, add) -> None:
    k = [s.name for s in scene.shafts].index(slip.shaft)
    up, down = (g for g, s in enumerate(segments) if s.shaft == k)
    point = geo.centres[k] + slip.offset_m * geo.axes[k]
    r1, r2, axis = frames[k]
    columns = [_Column(f"{slip.name}.shear.r1", down, up, point, r1),
               _Column(f"{slip.name}.shear.r2", down, up, point, r2),
               _Column(f"{slip.name}.bending.r1", down, up, None, r1),
               _Column(f"{slip.name}.bending.r2", down, up, None, r2),
               _Column(f"{slip.name}.torque", down, up, None, axis)]
    comps = ["shear.r1", "shear.r2", "bending.r1", "bending.r2", "torque"]
    if slip.friction_coefficient > 0:
        columns.append(_Column(f"{slip.name}.axial", down, up, point, axis))
        comps.append("axial")
    units = tuple("N m" if c.point is None else "N" for c in columns)
    add(dict(name=slip.name, kind="slip", body=down, other=up, element=slip.name,
             frame="shaft", components=tuple(comps), shaft=k, units=units), columns)


def _joint_columns(j, joint, pin, segments, geo, kin, add) -> None:
    centre = geo.joint_centres[j]
    e = {"e1": kin.e1[j], "e2": kin.e2[j], "e3": kin.e3[j]}
    yokes = (max(g for g, s in enumerate(segments) if s.shaft == j),
             min(g for g, s in enumerate(segments) if s.shaft == j + 1))
    sides = ((yokes[0], "e1", ("F1", "F2", "F3", "F4"), ("e2", "e3")),
             (yokes[1], "e2", ("F5", "F6", "F7", "F8"), ("e3", "e1")))
    for yoke, trunnion, (fa, fb, fc, fd), radial in sides:
        axis = e[trunnion]
        common = dict(body=pin, other=yoke, element=joint.name, frame="pin", joint=j,
                      trunnion=trunnion)
        for label, sign in ((fa, 1.0), (fb, -1.0)):
            name = f"{joint.name}.{label}"
            add(dict(name=name, kind="trunnion-radial", components=radial, side=sign,
                     label=label, units=("N", "N"), **common),
                [_Column(f"{name}.{c}", pin, yoke, centre + sign * joint.hs_m * axis, e[c])
                 for c in radial])
        for label, sign in ((fc, 1.0), (fd, -1.0)):
            add(dict(name=f"{joint.name}.{label}", kind="end-face",
                     components=(f"{'-' if sign > 0 else '+'}{trunnion}",), side=sign,
                     label=label, units=("N",), **common),
                [_Column(f"{joint.name}.{label}", pin, yoke,
                         centre + sign * joint.ht_m * axis, -sign * axis, True)])


def body_references(geo, segments) -> np.ndarray:
    """(bodies, 3): each body's moment reference at rest (m, global), in the operator's
    body order: a shaft segment's centre of mass, then each cross-pin's centre.
    """
    return np.concatenate([[geo.centres[s.shaft] + s.middle_m * geo.axes[s.shaft]
                            for s in segments], geo.joint_centres]).reshape(-1, 3)


def build_operator(motion: Motion) -> Operator:
    """Assemble ``A`` and ``b`` at every instant of ``motion`` (batched)."""
    scene, geo = motion.scene, motion.geometry
    segments, bodies, links, cols = _layout(motion)
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
    faces = {(c.joint, c.trunnion, c.side): c.columns[0] for c in links if c.kind == "end-face"}
    pairs = tuple((faces[(j, tr, 1.0)], faces[(j, tr, -1.0)])
                  for j in range(len(scene.joints)) for tr in ("e1", "e2"))
    rows = tuple(f"{body.name}.{kind}.{axis}" for body in bodies
                 for kind in ("force", "moment") for axis in AXES)
    terms = _load_terms(motion, segments, A.shape[1])
    return Operator(
        t=motion.t, A=A, b=sum(terms.values()), terms=terms, names=names, rows=rows,
        unilateral=np.array([c.unilateral for c in cols], bool), pairs=pairs, scene=scene,
        bodies=tuple(bodies), contacts=tuple(links),
        pin_frames=np.stack([motion.kin.e1, motion.kin.e2, motion.kin.e3], axis=2),
        shaft_frames=shaft_frames(motion), slip_friction=_slip_friction(scene, links),
        points=points, directions=directions,
    )


def _slip_friction(scene: Scene, links: list[Link]) -> tuple[SlipFriction, ...]:
    mu = {s.name: (s.friction_coefficient, s.pitch_radius_m) for s in scene.slip_joints}
    return tuple(
        SlipFriction(slip=c.name, axial=c.columns[5], torque=c.columns[4],
                     ratio_per_m=mu[c.name][0] / mu[c.name][1])
        for c in links if c.kind == "slip" and len(c.columns) == 6)


def _load_terms(motion: Motion, segments: list[Segment], n_cols: int) -> dict[str, np.ndarray]:
    """``b``'s terms, one per effect the scene calls for (and ``applied``, always)."""
    scene, geo = motion.scene, motion.geometry
    n_seg = len(segments)
    n_rows = 6 * (n_seg + len(scene.joints))
    T = len(motion.t)
    moment = lambda body: slice(6 * body + 3, 6 * body + 6)  # noqa: E731
    force = lambda body: slice(6 * body, 6 * body + 3)  # noqa: E731
    first, last = 0, n_seg - 1  # the input torque acts upstream, the load downstream

    applied = np.zeros((T, n_rows))
    applied[:, moment(first)] -= motion.input_torque[:, None] * geo.axes[0]
    applied[:, moment(last)] += motion.load_torque[:, None] * geo.axes[-1]
    terms = {"applied": applied}

    if scene.has("gravity"):
        g = np.array(scene.gravity_m_s2)
        weight = np.zeros((T, n_rows))
        for b, seg in enumerate(segments):
            weight[:, force(b)] -= seg.fraction * scene.shafts[seg.shaft].mass_kg * g
        if scene.has("crosspin_inertia"):
            for j in range(len(scene.joints)):
                weight[:, force(n_seg + j)] -= scene.crosspin.mass_kg * g
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

    if scene.has("crosspin_inertia") and scene.joints:
        jp = _pin_inertia_global(scene, motion.kin)
        w, dw = motion.pin_omega, motion.pin_alpha
        gyro = np.einsum("jtab,jtb->jta", jp, dw) + np.cross(w, np.einsum("jtab,jtb->jta", jp, w))
        pins = np.zeros((T, n_rows))
        for j in range(len(scene.joints)):
            pins[:, moment(n_seg + j)] += gyro[j]
        terms["crosspin_inertia"] = pins
    return terms
