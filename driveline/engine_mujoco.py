"""MuJoCo as a peer of the rigid analysis: the same drive line in a physics engine, its
constraint forces read back into the operator's named forces (optional extra ``mujoco``).

**Model** (MJCF generated from the scene, :func:`build_mjcf`). The line is one kinematic
tree in chain order: the first shaft body floats (a free joint), each next body hangs
on the one before by the joint the kind of the element between them gives
(:meth:`~.elements.base.EngineJoint.mjcf_steps`): a cross-pin on its driving yoke by a
hinge about ``e1``, the next shaft on the pin by a hinge about ``e2``, a slip joint's
downstream segment on its upstream one by a slide along the axis (frictionless); a kind
that needs several joints (a CV joint's three coupled hinges, a disc coupling's six
sprung ones) gets a nearly massless engine body between two of them
(:data:`ENGINE_BODY_KG`). A link between bodies that are not tree neighbours (a
centring ball) is closed outside the tree (:class:`~.elements.base.EngineLoop`): a
carrier hung on one body, held by a ``connect`` to the other.
Masses and inertias are the scene's (a shaft's transverse moments ``J1``, ``J3`` along
``r1``, ``r2``; a segment takes its length share of all three, as the operator does of
the axial one). Every bearing is an equality constraint to the
ground, as its kind writes it (:meth:`~.elements.bearing.BearingKind.mjcf`): a
locating one a ``connect`` at the bearing point (3 rows), a floating one a ``connect``
to a carrier body that slides along the shaft's axis on the ground (its weight
compensated), so that it carries no axial force but the carrier's inertia. The
bearings close the loop, so the model is redundant exactly as the rigid one is: two
axial splits and, without a slip joint, the loop's self-stress. A hinge has no end-face
split: the end-face pairs of the rigid model are resolved as the package resolves them,
by complementarity on their net axial force. The input torque and the load torque act on
the first and last shaft bodies, or as the forces of the element that takes them (a gear
mesh, :class:`~.elements.base.Loads`, at its point), gravity as in the scene.

**Forward simulation, not inverse dynamics.** MuJoCo's constraint forces come from its
soft-constraint model: each row's force is ``-(J qacc - a_ref) / R`` with ``a_ref``
from the row's violation (``solref``, ``solimp``). Given the package's exact motion,
:func:`mujoco.mj_inverse` sees no violation and returns (up to the neglected ``J'
qvel``) no constraint force; every reaction lands in ``qfrc_inverse`` as if actuators
held the shafts. The engine's answer exists only where it integrates its own motion:
the line sags into its soft constraints until they carry the loads. So the scene's
torques drive a forward simulation from the scene's initial state (RK4, 8 steps per
constraint time constant, shortened so that the output instants fall on steps),
and the forces are read at the scene's instants; the drift of its motion from the
package's is reported beside them (:attr:`EngineRun.q`).

**What MuJoCo cannot express** (refused by :func:`check_expressible`,
:class:`EngineUnsupported`): a slip joint with friction (a joint's ``frictionloss`` is
a constant, not ``mu |T| / r``), the ``friction`` effect (Coulomb cones in the joints),
and a scene without the ``inertia`` effect (a quasi-static analysis: the engine always
integrates dynamics; :meth:`~.scene.Scene.in_motion` gives its dynamic counterpart).
Effects that the rigid operator does not model either
(``clearance``, ``compliance``, ``penalty_dynamics``) are ignored, as there.

Why one module this long: the MJCF's bodies and equality rows (:func:`build_mjcf`) and
the reading of their forces into the operator's names (:func:`run`) share one layout of
bodies and rows, which a split would have to pass between two files.
"""

from __future__ import annotations

import time as _time
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from .elements import segment_of, shaft_segments
from .elements.base import MUJOCO, EngineLoop, EngineStep, Loads
from .elements.base import mjcf_numbers as _vec
from .elements.bodies import frames_of
from .elements.registry import refusals, scene_elements
from .equilibrium import Link, Operator, body_references
from .kinematics import kinematics, rest_geometry
from .scene import Scene


class EngineUnsupported(ValueError):
    """A scene element the engine cannot express, or the engine is not installed."""


@dataclass(frozen=True)
class Softness:
    """MuJoCo's softness of every bearing constraint: ``solref = (timeconst_s,
    dampratio)``, ``solimp = (dmin, dmax, width_m)`` (MuJoCo's defaults: 0.02 s, 1;
    0.9, 0.95, 1 mm). ``scaled`` multiplies the time constant of the bearings of the
    named shafts (e.g. ``(("output", 4.0),)``: its bearings softer than the others').
    ``steps_per_timeconst``: integration steps per (smallest) time constant; MuJoCo
    allows 2. The constraints' own fast dynamics set the error: on ``paper`` at
    13 rad/s, RK4 leaves ``||A x - b|| / ||b||`` at 1.1e-3 with 4 steps, 6e-5 with 8,
    4e-6 with 16 (fourth order, one run).
    """

    timeconst_s: float = 0.002
    dampratio: float = 1.0
    dmin: float = 0.9
    dmax: float = 0.95
    width_m: float = 0.001
    scaled: tuple[tuple[str, float], ...] = ()
    steps_per_timeconst: int = 8
    label: str = "default"

    def solref(self, shaft: str = "") -> str:
        factor = dict(self.scaled).get(shaft, 1.0)
        return f"{self.timeconst_s * factor:.9g} {self.dampratio:.9g}"

    @property
    def solimp(self) -> str:
        return f"{self.dmin:.9g} {self.dmax:.9g} {self.width_m:.9g}"

    @property
    def timestep_s(self) -> float:
        """The largest step: the smallest time constant over ``steps_per_timeconst``
        (MuJoCo clamps a time constant below 2 steps).
        """
        smallest = self.timeconst_s * min([1.0] + [f for _, f in self.scaled])
        return smallest / self.steps_per_timeconst


@dataclass(frozen=True)
class Governor:
    """A governor on the input torque that holds the input shaft on the package's own
    motion of the scene (:func:`~.dynamics.simulate`, the same torques and inertia):
    ``inertia (2 e' / tau + e / tau^2)`` (N m) added to the scene's, ``e`` the engine's
    lag behind that motion (its angle ``q`` and speed ``qd`` at instants ``t``, a cubic
    Hermite curve between them), ``inertia`` the line's reduced inertia (kg m^2, eq.
    5's ``I(q)`` at the start), ``tau`` = ``time_s`` (critically damped: no steady lag
    against a steady loss). It holds a quasi-static scene taken in motion
    (:meth:`~.scene.Scene.in_motion`) on the motion the rigid set is read on: with a
    small inertia, the energy the engine's soft constraints dissipate would otherwise
    drift it away (double-cardan's 10 rad/s reversed within 0.4 s), and its forces would
    be read at other angles than the rigid set's.
    """

    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    inertia: float
    time_s: float = 0.005

    @cached_property
    def _motion(self):
        """The reference angle as a curve of time (SciPy's cubic Hermite spline)."""
        from scipy.interpolate import CubicHermiteSpline

        return CubicHermiteSpline(self.t, self.q, self.qd)

    def torque(self, t: float, q: float, qd: float) -> float:
        """The governor's torque (N m) at time ``t`` (s), input angle ``q`` (rad,
        unwrapped) and speed ``qd`` (rad/s).
        """
        lag, lag_rate = self._motion(t) - q, self._motion(t, 1) - qd
        return float(self.inertia * (2.0 * lag_rate / self.time_s + lag / self.time_s ** 2))


@dataclass(frozen=True)
class EngineRun:
    """The engine's forces at the operator's instants, in its column order (N, N m).

    ``q``, ``qd``: the input shaft's angle (rad) and speed (rad/s) in the engine's own
    motion; ``mapping_residual``: per instant, the largest part of an engine wrench
    that the operator's columns of that element cannot carry (N, N m; a floating
    bearing's carrier inertia, a slide's axial force); ``steps`` and ``wall_s`` the
    integration's cost; ``governed_N_m``: the largest governor torque at the instants
    read (0 without a :class:`Governor`).
    """

    t: np.ndarray
    forces: np.ndarray
    names: tuple[str, ...]
    q: np.ndarray
    qd: np.ndarray
    mapping_residual: np.ndarray
    softness: Softness
    timestep_s: float
    steps: int
    wall_s: float
    governed_N_m: float = 0.0


def _mujoco():
    try:
        import mujoco
    except ImportError:
        raise EngineUnsupported(
            "MuJoCo is not installed: pip install 'cardan-forces[mujoco]'") from None
    return mujoco


def mujoco_version() -> str:
    """The installed MuJoCo's version (:class:`EngineUnsupported` when it is absent)."""
    return _mujoco().__version__


def check_expressible(scene: Scene, engine: str = MUJOCO) -> None:
    """Raise :class:`EngineUnsupported` naming every element ``engine`` (MuJoCo, or Drake
    which reads this module's MJCF) cannot express.
    """
    problems = refusals(scene, engine)
    if scene.has("friction"):
        problems.append("effect 'friction' (Coulomb cones in the joints) has no engine "
                        "counterpart on a hinge")
    if not scene.has("inertia"):
        problems.append("no 'inertia' effect: the scene is quasi-static, the engine "
                        "integrates dynamics")
    if problems:
        raise EngineUnsupported(f"scene {scene.name}: {engine} cannot express: "
                                + "; ".join(problems))


ENGINE_BODY_KG = 1e-6
"""Mass (kg; inertia :data:`ENGINE_BODY_INERTIA`) of an engine body between two joints
of one link (:meth:`~.elements.base.EngineJoint.mjcf_steps`) or of a loop's carrier:
MuJoCo needs a positive one; its weight, 1e-5 N, is far below the loads."""
ENGINE_BODY_INERTIA = 1e-12 * np.eye(3)
"""Its inertia tensor (kg m^2)."""


COUPLING_STEPS, COUPLING_IMPEDANCE = 2, 0.9999
"""A coupling of a kind's joints (a CV joint's homokinetic one) is as hard as MuJoCo's
step allows: time constant two steps (its least), impedance ``0.9999``. It carries the
line's torque between spinning bodies of small polar inertia, so the bearings' softness
would let it stretch (about 9 rad under halfshaft's 1000 N m, a driven shaft turned
away from its driving one); so hard, it stretches about 1 mrad, and a joint's kinematics
stays as exact as the tree's hinges keep a Cardan joint's."""


@dataclass(frozen=True)
class _Body:
    """One engine body: the operator's body index (None for an engine body between two
    joints of a link), its MJCF name, its global pose at the start, mass and global
    inertia tensor about its centre of mass ``pos``; ``step``: the joint it hangs on
    its parent by (None for the free first body) and ``link`` the contact whose kind
    made it.
    """

    index: int | None
    name: str
    pos: np.ndarray
    rot: np.ndarray
    mass: float
    inertia: np.ndarray
    step: EngineStep | None = None
    link: Link | None = None


def _rotation(axis: np.ndarray, angle: float) -> np.ndarray:
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * k @ k


def reference_points(op: Operator) -> np.ndarray:
    """Each operator body's moment reference (m, global): a shaft body's centre of mass,
    a cross-pin's centre (the points the operator's moment rows are taken about).
    """
    return body_references(rest_geometry(op.scene), shaft_segments(op.scene))


@dataclass(frozen=True)
class Start:
    """The line at the scene's start, as the kinds place their MuJoCo joints and bodies:
    the scene, its rest geometry, the kinematics at the initial angle, the operator's
    bodies and their moment references ``refs``, the initial ``speed`` (rad/s), per
    shaft the rows ``r1, r2, axis`` of its frame at rest (``frames``).
    """

    scene: Scene
    geo: object
    kin: object
    bodies: tuple
    refs: np.ndarray
    speed: float
    frames: np.ndarray


def start_of(op: Operator) -> Start:
    """The operator's line at the scene's start (:class:`Start`)."""
    scene = op.scene
    geo = rest_geometry(scene)
    return Start(scene, geo, kinematics(geo, scene.initial_angle_rad), op.bodies,
                 reference_points(op), scene.initial_speed_rad_s, frames_of(geo))


def _loops(op: Operator) -> list[Link]:
    """The links the engine closes outside its tree (:class:`~.elements.base.EngineLoop`)."""
    return [c for c in op.contacts if isinstance(c.element_kind, EngineLoop)]


def _chain(op: Operator) -> list[_Body]:
    """The engine bodies in tree order (each the child of the one before it): a walk
    along the line from its first shaft body (which floats) through the links between
    bodies, each link's kind giving the joints by which the next body hangs on the last
    (an engine body between two of them; the body itself where the kind made it, a
    cross-pin).
    """
    start, loops = start_of(op), _loops(op)
    joins = [c for c in op.contacts if c.other is not None and c not in loops]
    chain = [_shaft_body(op, start, 0, None, None)]
    here, seen = 0, {0}
    while True:
        link = next((c for c in joins if here in (c.body, c.other)
                     and {c.body, c.other} - seen), None)
        if link is None:
            return chain
        child = link.other if link.body == here else link.body
        seen.add(child)
        kind = link.element_kind
        steps = kind.mjcf_steps(link, child, start)
        for k, step in enumerate(steps[:-1]):
            chain.append(_Body(None, f"{link.name}.{k}", step.point, chain[-1].rot,
                               ENGINE_BODY_KG, ENGINE_BODY_INERTIA, step, link))
        if op.bodies[child].shaft is not None:
            chain.append(_shaft_body(op, start, child, steps[-1], link))
        else:
            pos, rot, mass, inertia = kind.mjcf_body(child, start)
            chain.append(_Body(child, op.bodies[child].name, pos, rot, mass, inertia,
                               steps[-1], link))
        here = child


def _shaft_body(op: Operator, start: Start, g: int, step, link) -> _Body:
    """Shaft body ``g`` (a shaft or a segment): the shaft's mass and principal moments
    by its length share, turned to the initial angle.
    """
    seg = shaft_segments(op.scene)[g]
    k, shaft = seg.shaft, op.scene.shafts[seg.shaft]
    frame = op.shaft_frames[k]
    j_axes = np.array(shaft.inertia_kg_m2)[[0, 2, 1]] * seg.fraction
    rot = _rotation(start.geo.axes[k], start.kin.phi[k, 0])
    inertia = rot @ np.einsum("i,ia,ib->ab", j_axes, frame, frame) @ rot.T
    return _Body(g, op.bodies[g].name, start.refs[g], rot, seg.fraction * shaft.mass_kg,
                 inertia, step, link)


def _quat(rot: np.ndarray) -> np.ndarray:
    quat = np.zeros(4)
    _mujoco().mju_mat2Quat(quat, np.ascontiguousarray(rot).ravel())
    return quat


def _joint_xml(name: str, step: EngineStep | None, pos, rot) -> str:
    """A body's joint in its own frame (``pos``, ``rot``: the body's global pose):
    named as the body, with its spring-damper where it has one.
    """
    if step is None:
        return "<freejoint/>"
    spring = (f' stiffness="{step.stiffness:.17g}" damping="{step.damping:.17g}"'
              if step.stiffness or step.damping else "")
    return (f'<joint name="{name}" type="{step.type}" pos="{_vec(rot.T @ (step.point - pos))}"'
            f' axis="{_vec(rot.T @ step.axis)}"{spring}/>')


def _body_xml(body: _Body, parent: _Body | None) -> str:
    """A body's opening tag, joint and inertia, relative to its parent's frame."""
    p_rot = np.eye(3) if parent is None else parent.rot
    p_pos = np.zeros(3) if parent is None else parent.pos
    pos = p_rot.T @ (body.pos - p_pos)
    rot = p_rot.T @ body.rot
    inertia = body.rot.T @ body.inertia @ body.rot
    full = inertia[[0, 1, 2, 0, 0, 1], [0, 1, 2, 1, 2, 2]]
    return (f'<body name="{body.name}" pos="{_vec(pos)}" quat="{_vec(_quat(rot))}">'
            f'{_joint_xml(body.name, body.step, body.pos, body.rot)}'
            f'<inertial pos="0 0 0" mass="{body.mass:.17g}" fullinertia="{_vec(full)}"/>')


def _carrier(link: Link, step: EngineStep, host: _Body, names: dict) -> tuple[str, str]:
    """A loop's carrier body (nested in its host, on the joint ``step``) and its
    ``connect`` equality, named as the link (:class:`~.elements.base.EngineLoop`): the
    carrier at the loop's point, held there by the link's other body.
    """
    name = f"carrier.{link.name}"
    other = link.other if host.index == link.body else link.body
    carrier = _Body(None, name, step.point, host.rot, ENGINE_BODY_KG,
                    ENGINE_BODY_INERTIA, step, link)
    return (_body_xml(carrier, host) + "</body>",
            f'<connect name="{link.name}" body1="{name}" body2="{names[other]}" '
            'anchor="0 0 0"')


def _bearings(op: Operator):
    """Per bearing contact of the operator (column order): its point (m, global) and
    the shaft's axis.
    """
    geo = rest_geometry(op.scene)
    points = [(geo.bearing_points[k][b], geo.axes[k])
              for k, shaft in enumerate(op.scene.shafts) for b in range(len(shaft.bearings))]
    return list(zip(op.bearings(), points))


def build_mjcf(op: Operator, softness: Softness = Softness()) -> str:
    """The MJCF model of the operator's scene (module doc): bodies named as the
    operator's bodies, each bearing and loop an equality named as its contact, then the
    couplings of the kinds' joints.
    """
    scene, chain, start = op.scene, _chain(op), start_of(op)
    names = {b.index: b.name for b in chain if b.index is not None}
    shaft_of = {b.index: scene.shafts[op.bodies[b.index].shaft].name for b in chain
                if b.index is not None and op.bodies[b.index].shaft is not None}

    def soft(body: int) -> str:
        return (f'solref="{softness.solref(shaft_of.get(body, ""))}" '
                f'solimp="{softness.solimp}"')

    carriers, equalities, hosted = [], [], {}
    for link, (point, axis) in _bearings(op):
        body = next(b for b in chain if b.index == link.body)
        carrier, equality = link.element_kind.mjcf(
            link, body.name, body.rot.T @ (point - body.pos), point, axis, body.mass,
            soft(link.body))
        carriers.append(carrier)
        equalities.append(equality)
    for link in _loops(op):
        host, step = link.element_kind.mjcf_loop(link, start)
        xml, connect = _carrier(link, step, next(b for b in chain if b.index == host), names)
        hosted[host] = hosted.get(host, "") + xml
        equalities.append(f"{connect} {soft(host)}/>")
    hard = (f'solref="{COUPLING_STEPS * _timestep(op, softness):.9g} 1" '
            f'solimp="{COUPLING_IMPEDANCE} {COUPLING_IMPEDANCE} {softness.width_m:.9g}"')
    for link in {b.link.name: b.link for b in chain if b.link is not None}.values():
        joints = [b.name for b in chain if b.link is link]
        equalities.append(link.element_kind.mjcf_couplings(link, joints, hard))
    tree = "".join(_body_xml(b, chain[i - 1] if i else None) + hosted.get(b.index, "")
                   for i, b in enumerate(chain)) + "</body>" * len(chain)
    gravity = scene.gravity_m_s2 if scene.has("gravity") else (0.0, 0.0, 0.0)
    return (f'<mujoco model="{scene.name}"><compiler angle="radian"/>'
            f'<option timestep="{_timestep(op, softness):.17g}" integrator="RK4" '
            f'gravity="{_vec(gravity)}" tolerance="1e-12" iterations="100"/>'
            f'<worldbody>{tree}{"".join(carriers)}</worldbody>'
            f'<equality>{"".join(equalities)}</equality></mujoco>')


def _timestep(op: Operator, softness: Softness) -> float:
    """The engine's step: the softness's, shortened so that the scene's step is a whole
    number of them.
    """
    step = op.scene.time.step_s
    return step / max(1, int(np.ceil(step / softness.timestep_s - 1e-9)))


SPRING_STEP = 0.5
"""Largest ``omega dt`` of a sprung joint (``omega = sqrt(k / m)``, ``m`` its effective
inertia at the start, ``1 / dof_invweight0``): RK4 is stable to 2.8; at 0.5 a period
takes 12 steps."""


def _sprung_joints(model, dt: float) -> float:
    """Fit the engine to its sprung joints (a disc coupling's, :class:`EngineStep`'s
    stiffness and damping) and return its step (s): ``dt`` divided until every joint has
    ``omega dt <= SPRING_STEP``; each damper capped at ``m / dt``, the most RK4
    integrates at that step (the scene's damping fraction of a stiff disc, 1e-2 s, is
    far more: the cap still leaves a damping ratio ``1 / (2 omega dt) >= 1``).
    """
    mass = 1.0 / model.dof_invweight0[model.jnt_dofadr]
    omega = np.sqrt(model.jnt_stiffness / mass)
    dt /= max(1, int(np.ceil(float(np.max(omega, initial=0.0)) * dt / SPRING_STEP)))
    dofs = model.jnt_dofadr[model.jnt_stiffness > 0]
    model.dof_damping[dofs] = np.minimum(model.dof_damping[dofs],
                                         1.0 / (model.dof_invweight0[dofs] * dt))
    return dt


def _initial_velocity(mj, model, data, op: Operator, chain: list[_Body]) -> None:
    """Joint speeds of the scene's initial state: the first shaft turning at the initial
    speed, every other joint at the speed its kind gives (a hinge at its kinematic rate,
    a slide still); a loop's carrier starts still on its host.
    """
    start = start_of(op)
    for body in chain:
        b_id = mj.mj_name2id(model, mj.mjtObj.mjOBJ_BODY, body.name)
        dof = model.jnt_dofadr[model.body_jntadr[b_id]]
        if body.step is None:
            data.qvel[dof + 3: dof + 6] = body.rot.T @ (start.speed * start.geo.axes[0])
        else:
            data.qvel[dof] = body.step.speed


def _groups(mj, model, op: Operator, chain: list[_Body]):
    """What to read for each part of the operator's columns: ``("equality", link, eq)``
    per bearing and loop (equality ``eq``, on the link's body, a loop's through its
    carrier), ``("tree", links, body, child, sign)`` per pair of operator bodies the
    tree joins (a cross-pin side, a slip joint, a CV joint, ...): the engine body
    ``child`` of the two, whose parent's pull is the wrench on ``body`` times ``sign``.
    """
    loops = _loops(op)
    out = [("equality", link, mj.mj_name2id(model, mj.mjtObj.mjOBJ_EQUALITY, link.name))
           for link in [link for link, _ in _bearings(op)] + loops]
    pairs: dict[tuple[int, int | None], list] = {}
    for link in (c for c in op.contacts if c.other is not None and c not in loops):
        pairs.setdefault((link.body, link.other), []).append(link)
    position = {b.index: p for p, b in enumerate(chain) if b.index is not None}
    for (body, other), links in pairs.items():
        child = chain[max(position[body], position[other])]
        b_id = mj.mj_name2id(model, mj.mjtObj.mjOBJ_BODY, child.name)
        out.append(("tree", links, body, b_id, 1.0 if child.index == body else -1.0))
    return out


def _wrench(force, moment_at, point, ref) -> np.ndarray:
    """``[F, M_ref]`` of a force ``F`` with moment ``moment_at`` about ``point``."""
    return np.concatenate([force, moment_at + np.cross(point - ref, force)])


def _read(mj, model, data, op: Operator, i: int, groups, refs):
    """The operator's forces (n,) from the engine's state, and the largest misfit."""
    mj.mj_rnePostConstraint(model, data)
    x = np.zeros(len(op.names))
    misfit = 0.0
    for group in groups:
        if group[0] == "equality":
            _, link, e = group
            rows = np.flatnonzero((data.efc_type[:data.nefc] == 0) & (data.efc_id[:data.nefc] == e))
            body = link.body
            b_id = model.eq_obj1id[e]
            point = data.xpos[b_id] + data.xmat[b_id].reshape(3, 3) @ model.eq_data[e][:3]
            w = _wrench(data.efc_force[rows], np.zeros(3), point, refs[body])
            links = [link]
        else:
            _, links, body, b_id, sign = group
            c = data.subtree_com[model.body_rootid[b_id]]
            raw = sign * data.cfrc_int[b_id]
            w = _wrench(raw[3:], raw[:3], c, refs[body])
        cols = [c for link in links for c in link.columns]
        block = op.A[i, 6 * body: 6 * body + 6][:, cols]
        y = np.linalg.lstsq(block, w, rcond=None)[0]
        misfit = max(misfit, float(np.max(np.abs(block @ y - w))))
        x[cols] = y
    for a, b in op.pairs:  # a pair (end faces, ...): complementary on its net push
        net = x[b] - x[a]
        x[a], x[b] = max(-net, 0.0), max(net, 0.0)
    return x, misfit


def _torques(mj, model, op: Operator, chain: list[_Body]):
    """``apply(data, now, governed)``: add the line's input and load torques at time
    ``now`` (s) to ``data.xfrc_applied``: as torques on the first and last shaft bodies,
    or as the forces of the element that takes one (:class:`~.elements.base.Loads`, at
    its point), as the equilibrium operator applies them; and a governor's torque
    ``governed`` (N m) on the first.
    """
    scene = op.scene
    geo, segments = rest_geometry(scene), shaft_segments(scene)
    ids = {b.index: mj.mj_name2id(model, mj.mjtObj.mjOBJ_BODY, b.name)
           for b in chain if b.index is not None}
    first, last = ids[0], ids[len(segments) - 1]
    takers = [(kind, e, k, ids[segment_of(segments, k, e.offset_m)])
              for kind, e, k, _ in scene_elements(scene) if isinstance(kind, Loads)]
    ends = {k for _, _, k, _ in takers}
    frames = frames_of(geo)

    def apply(data, now: float, governed: float = 0.0) -> None:
        data.xfrc_applied[first, 3:] += governed * geo.axes[0]
        if 0 not in ends:
            data.xfrc_applied[first, 3:] += scene.input_torque(now) * geo.axes[0]
        if len(scene.shafts) - 1 not in ends:
            data.xfrc_applied[last, 3:] -= scene.load_torque(now) * geo.axes[-1]
        for kind, element, k, b_id in takers:
            taken = -scene.input_torque(now) if k == 0 else scene.load_torque(now)
            point, load = kind.load(element, np.array([taken]), frames[k], geo.centres[k])
            data.xfrc_applied[b_id, :3] += load[0]
            data.xfrc_applied[b_id, 3:] += np.cross(point - data.xipos[b_id], load[0])

    return apply


def run(op: Operator, softness: Softness = Softness(),
        governor: Governor | None = None) -> EngineRun:
    """Simulate the operator's scene in MuJoCo from its initial state and read the
    forces at the operator's instants (module doc), its input speed held by
    ``governor`` where one is given.
    """
    check_expressible(op.scene)
    mj = _mujoco()
    scene = op.scene
    model = mj.MjModel.from_xml_string(build_mjcf(op, softness))
    data = mj.MjData(model)
    chain = _chain(op)
    _initial_velocity(mj, model, data, op, chain)
    mj.mj_forward(model, data)  # poses and speeds of the start, read before the first step
    groups, refs = _groups(mj, model, op, chain), reference_points(op)
    apply = _torques(mj, model, op, chain)
    model.opt.timestep = dt = _sprung_joints(model, model.opt.timestep)
    targets = np.rint((op.t - scene.time.start_s) / dt).astype(int)
    if np.any(np.diff(targets) < 0) or targets[0] < 0:
        raise EngineUnsupported("the engine reads instants in time order from the start")
    n, forces = len(op.t), np.zeros((len(op.t), len(op.names)))
    q, qd, misfit = np.zeros(n), np.zeros(n), np.zeros(n)
    frame, axis = op.shaft_frames[0], rest_geometry(scene).axes[0]
    first = mj.mj_name2id(model, mj.mjtObj.mjOBJ_BODY, chain[0].name)
    step, start = 0, _time.perf_counter()

    def angle() -> float:  # the first shaft's angle about its axis, in (-pi, pi]
        turned = data.xmat[first].reshape(3, 3) @ frame[0]
        return float(np.arctan2(turned @ frame[1], turned @ frame[0]))

    def governed() -> float:  # the governor's torque on the engine's input motion
        if governor is None:
            return 0.0
        speed = (data.xmat[first].reshape(3, 3) @ data.qvel[3:6]) @ axis
        return governor.torque(scene.time.start_s + step * dt, prev + 2 * np.pi * turns,
                               float(speed))

    held = 0.0

    prev = angle()
    turns = round((scene.initial_angle_rad - prev) / (2 * np.pi))
    for i, target in enumerate(targets):
        while step < target:
            data.xfrc_applied[:] = 0.0
            apply(data, scene.time.start_s + (step + 0.5) * dt, governed())  # mid-step
            mj.mj_step(model, data)
            step += 1
            now = angle()  # counted every step: a turn is many steps
            turns += round((prev - now) / (2 * np.pi))
            prev = now
        data.xfrc_applied[:] = 0.0
        now_governed = governed()
        held = max(held, abs(now_governed))
        apply(data, scene.time.start_s + step * dt, now_governed)
        mj.mj_forward(model, data)
        forces[i], misfit[i] = _read(mj, model, data, op, i, groups, refs)
        q[i] = prev + 2 * np.pi * turns
        qd[i] = (data.xmat[first].reshape(3, 3) @ data.qvel[3:6]) @ axis
    return EngineRun(op.t, forces, op.names, q, qd, misfit, softness, dt, step,
                     _time.perf_counter() - start, held)
