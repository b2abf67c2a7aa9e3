"""MuJoCo as a peer of the rigid analysis: the same drive line in a physics engine, its
constraint forces read back into the operator's named forces (optional extra ``mujoco``).

**Model** (MJCF generated from the scene, :func:`build_mjcf`). The line is one kinematic
tree in chain order: the first shaft body floats (a free joint), each next body hangs
on the one before by the joint the kind of the element between them gives
(:meth:`~.elements.base.EngineJoint.mjcf_joint`): a cross-pin on its driving yoke by a
hinge about ``e1``, the next shaft on the pin by a hinge about ``e2``, a slip joint's
downstream segment on its upstream one by a slide along the axis (frictionless).
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
the first and last shaft bodies, gravity as in the scene.

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
integrates dynamics). Effects that the rigid operator does not model either
(``clearance``, ``compliance``, ``penalty_dynamics``) are ignored, as there.

Why one module this long: the MJCF's bodies and equality rows (:func:`build_mjcf`) and
the reading of their forces into the operator's names (:func:`run`) share one layout of
bodies and rows, which a split would have to pass between two files.
"""

from __future__ import annotations

import time as _time
from dataclasses import dataclass

import numpy as np

from .elements import shaft_segments
from .elements.base import mjcf_numbers as _vec
from .elements.registry import refusals
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
class EngineRun:
    """The engine's forces at the operator's instants, in its column order (N, N m).

    ``q``, ``qd``: the input shaft's angle (rad) and speed (rad/s) in the engine's own
    motion; ``mapping_residual``: per instant, the largest part of an engine wrench
    that the operator's columns of that element cannot carry (N, N m; a floating
    bearing's carrier inertia, a slide's axial force); ``steps`` and ``wall_s`` the
    integration's cost.
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


def check_expressible(scene: Scene) -> None:
    """Raise :class:`EngineUnsupported` naming every element the engine cannot express."""
    problems = refusals(scene, "the engine")
    if scene.has("friction"):
        problems.append("effect 'friction' (Coulomb cones in the joints) has no engine "
                        "counterpart on a hinge")
    if not scene.has("inertia"):
        problems.append("no 'inertia' effect: the scene is quasi-static, the engine "
                        "integrates dynamics")
    if problems:
        raise EngineUnsupported(f"scene {scene.name}: MuJoCo cannot express: "
                                + "; ".join(problems))


@dataclass(frozen=True)
class _Body:
    """One engine body: the operator's body index, its global pose at the start, its
    joint (``free``, ``hinge`` or ``slide``) with the joint's global axis, mass and
    global inertia tensor about its centre of mass ``pos``; ``link``: the contact whose
    kind made the joint (None for the free first body).
    """

    index: int
    pos: np.ndarray
    rot: np.ndarray
    joint: str
    axis: np.ndarray
    joint_pos: np.ndarray
    mass: float
    inertia: np.ndarray
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
    bodies and their moment references ``refs``, the initial ``speed`` (rad/s).
    """

    scene: Scene
    geo: object
    kin: object
    bodies: tuple
    refs: np.ndarray
    speed: float


def _start(op: Operator) -> Start:
    scene = op.scene
    geo = rest_geometry(scene)
    return Start(scene, geo, kinematics(geo, scene.initial_angle_rad), op.bodies,
                 reference_points(op), scene.initial_speed_rad_s)


def _chain(op: Operator) -> list[_Body]:
    """The engine bodies in tree order (each the child of the one before it): a walk
    along the line from its first shaft body (which floats) through the links between
    bodies, each link's kind giving the joint by which the next body hangs on the last
    (and the body itself where the kind made it, a cross-pin).
    """
    start = _start(op)
    joins = [c for c in op.contacts if c.other is not None]
    chain = [_shaft_body(op, start, 0, "free", start.geo.axes[0], start.refs[0], None)]
    seen = {0}
    while True:
        here = chain[-1].index
        link = next((c for c in joins if here in (c.body, c.other)
                     and {c.body, c.other} - seen), None)
        if link is None:
            return chain
        child = link.other if link.body == here else link.body
        seen.add(child)
        kind = link.element_kind
        joint, axis, at = kind.mjcf_joint(link, child, start)
        if op.bodies[child].shaft is not None:
            chain.append(_shaft_body(op, start, child, joint, axis, at, link))
        else:
            pos, rot, mass, inertia = kind.mjcf_body(child, start)
            chain.append(_Body(child, pos, rot, joint, axis, at, mass, inertia, link))


def _shaft_body(op: Operator, start: Start, g: int, joint: str, axis, at, link) -> _Body:
    """Shaft body ``g`` (a shaft or a segment): the shaft's mass and principal moments
    by its length share, turned to the initial angle.
    """
    seg = shaft_segments(op.scene)[g]
    k, shaft = seg.shaft, op.scene.shafts[seg.shaft]
    frame = op.shaft_frames[k]
    j_axes = np.array(shaft.inertia_kg_m2)[[0, 2, 1]] * seg.fraction
    rot = _rotation(start.geo.axes[k], start.kin.phi[k, 0])
    inertia = rot @ np.einsum("i,ia,ib->ab", j_axes, frame, frame) @ rot.T
    return _Body(g, start.refs[g], rot, joint, axis, at, seg.fraction * shaft.mass_kg,
                 inertia, link)


def _quat(rot: np.ndarray) -> np.ndarray:
    quat = np.zeros(4)
    _mujoco().mju_mat2Quat(quat, np.ascontiguousarray(rot).ravel())
    return quat


def _body_xml(body: _Body, name: str, parent: _Body | None) -> str:
    """A body's opening tag, joint and inertia, relative to its parent's frame."""
    p_rot = np.eye(3) if parent is None else parent.rot
    p_pos = np.zeros(3) if parent is None else parent.pos
    pos = p_rot.T @ (body.pos - p_pos)
    rot = p_rot.T @ body.rot
    inertia = body.rot.T @ body.inertia @ body.rot
    full = inertia[[0, 1, 2, 0, 0, 1], [0, 1, 2, 1, 2, 2]]
    joint = ("<freejoint/>" if body.joint == "free" else
             f'<joint type="{body.joint}" pos="{_vec(body.rot.T @ (body.joint_pos - body.pos))}"'
             f' axis="{_vec(body.rot.T @ body.axis)}"/>')
    return (f'<body name="{name}" pos="{_vec(pos)}" quat="{_vec(_quat(rot))}">{joint}'
            f'<inertial pos="0 0 0" mass="{body.mass:.17g}" fullinertia="{_vec(full)}"/>')


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
    operator's bodies, each bearing an equality named as its contact.
    """
    scene, chain = op.scene, _chain(op)
    names = [op.bodies[b.index].name for b in chain]
    tree = "".join(_body_xml(b, n, chain[i - 1] if i else None)
                   for i, (b, n) in enumerate(zip(chain, names))) + "</body>" * len(chain)
    carriers, equalities = [], []
    for link, (point, axis) in _bearings(op):
        shaft = scene.shafts[link.shaft].name
        body = next(b for b in chain if b.index == link.body)
        soft = f'solref="{softness.solref(shaft)}" solimp="{softness.solimp}"'
        carrier, equality = link.element_kind.mjcf(
            link, names[chain.index(body)], body.rot.T @ (point - body.pos), point, axis,
            body.mass, soft)
        carriers.append(carrier)
        equalities.append(equality)
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


def _initial_velocity(model, data, op: Operator, chain: list[_Body]) -> None:
    """Joint speeds of the scene's initial state: the first shaft turning at the initial
    speed, every other joint at the speed its kind gives (a hinge at its kinematic rate,
    a slide still); a body without a joint has no speed of its own to set.
    """
    start = _start(op)
    for pos, body in enumerate(chain):
        if model.body_jntnum[pos + 1] == 0:
            continue  # welded to the body it hangs on: it has no speed of its own
        dof = model.jnt_dofadr[model.body_jntadr[pos + 1]]
        if body.link is None:
            data.qvel[dof + 3: dof + 6] = body.rot.T @ (start.speed * start.geo.axes[0])
        else:
            data.qvel[dof] = body.link.element_kind.mjcf_speed(body.link, body.index,
                                                               body.axis, start)


def _groups(op: Operator, chain: list[_Body]):
    """What to read for each part of the operator's columns: ``("bearing", link, eq)``
    per bearing (equality ``eq``), ``("tree", links, body, other)`` per pair of tree
    neighbours joined by a cross-pin side or a slip joint.
    """
    out = [("bearing", link, e) for e, (link, _) in enumerate(_bearings(op))]
    pairs: dict[tuple[int, int | None], list] = {}
    for link in (c for c in op.contacts if c.other is not None):
        pairs.setdefault((link.body, link.other), []).append(link)
    position = {b.index: p for p, b in enumerate(chain)}
    for (body, other), links in pairs.items():
        out.append(("tree", links, position[body], position[other]))
    return out


def _wrench(force, moment_at, point, ref) -> np.ndarray:
    """``[F, M_ref]`` of a force ``F`` with moment ``moment_at`` about ``point``."""
    return np.concatenate([force, moment_at + np.cross(point - ref, force)])


def _read(mj, model, data, op: Operator, i: int, chain, groups, refs):
    """The operator's forces (n,) from the engine's state, and the largest misfit."""
    mj.mj_rnePostConstraint(model, data)
    x = np.zeros(len(op.names))
    misfit = 0.0
    for group in groups:
        if group[0] == "bearing":
            _, link, e = group
            rows = np.flatnonzero((data.efc_type[:data.nefc] == 0) & (data.efc_id[:data.nefc] == e))
            body = link.body
            b_id = model.eq_obj1id[e]
            point = data.xpos[b_id] + data.xmat[b_id].reshape(3, 3) @ model.eq_data[e][:3]
            w = _wrench(data.efc_force[rows], np.zeros(3), point, refs[body])
            links = [link]
        else:
            _, links, p_body, p_other = group
            body = chain[p_body].index
            child, sign = (p_body, 1.0) if p_other == p_body - 1 else (p_other, -1.0)
            c = data.subtree_com[model.body_rootid[child + 1]]
            raw = sign * data.cfrc_int[child + 1]
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


def run(op: Operator, softness: Softness = Softness()) -> EngineRun:
    """Simulate the operator's scene in MuJoCo from its initial state and read the
    forces at the operator's instants (module doc).
    """
    check_expressible(op.scene)
    mj = _mujoco()
    scene = op.scene
    model = mj.MjModel.from_xml_string(build_mjcf(op, softness))
    data = mj.MjData(model)
    chain = _chain(op)
    _initial_velocity(model, data, op, chain)
    groups, refs = _groups(op, chain), reference_points(op)
    axes = rest_geometry(scene).axes
    n_seg = len(shaft_segments(scene))
    last = 1 + max(p for p, b in enumerate(chain) if b.index < n_seg)
    dt = model.opt.timestep
    targets = np.rint((op.t - scene.time.start_s) / dt).astype(int)
    if np.any(np.diff(targets) < 0) or targets[0] < 0:
        raise EngineUnsupported("the engine reads instants in time order from the start")
    n, forces = len(op.t), np.zeros((len(op.t), len(op.names)))
    q, qd, misfit = np.zeros(n), np.zeros(n), np.zeros(n)
    frame = op.shaft_frames[0]
    step, start = 0, _time.perf_counter()

    def torques(half: float) -> None:  # mid-step torques over a step: 2nd order in dt
        now = scene.time.start_s + (step + half) * dt
        data.xfrc_applied[1, 3:] = scene.input_torque(now) * axes[0]
        data.xfrc_applied[last, 3:] -= scene.load_torque(now) * axes[-1]

    def angle() -> float:  # the first shaft's angle about its axis, in (-pi, pi]
        turned = data.xmat[1].reshape(3, 3) @ frame[0]
        return float(np.arctan2(turned @ frame[1], turned @ frame[0]))

    prev = angle()
    turns = round((scene.initial_angle_rad - prev) / (2 * np.pi))
    for i, target in enumerate(targets):
        while step < target:
            data.xfrc_applied[:] = 0.0
            torques(0.5)
            mj.mj_step(model, data)
            step += 1
            now = angle()  # counted every step: a turn is many steps
            turns += round((prev - now) / (2 * np.pi))
            prev = now
        data.xfrc_applied[:] = 0.0
        torques(0.0)
        mj.mj_forward(model, data)
        forces[i], misfit[i] = _read(mj, model, data, op, i, chain, groups, refs)
        q[i] = prev + 2 * np.pi * turns
        qd[i] = (data.xmat[1].reshape(3, 3) @ data.qvel[3:6]) @ axes[0]
    return EngineRun(op.t, forces, op.names, q, qd, misfit, softness, dt, step,
                     _time.perf_counter() - start)
