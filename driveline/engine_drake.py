"""Drake as a second physics engine beside MuJoCo: the same drive line, its joint
reactions read back into the operator's named forces (optional extra ``drake``).

**Model: MuJoCo's MJCF, read by Drake's parser, with a seat at every bearing.** The
scene's engine model is written once, by the element kinds, as MJCF
(:func:`~.engine_mujoco.build_mjcf`); Drake's MJCF parser reads its bodies, hinge and
slide joints, inertias and ``equality/connect`` rows (as SAP ball constraints), so the
Drake model follows every kind without a second writer. Two changes make it run
(:func:`drake_mjcf`): Drake refuses a ``connect`` to the world body, and a ball or weld
constraint to the world stops its SAP solver, so every bearing's ``connect`` is made
to a massless *seat*, a body welded to the world at the bearing point; and the seat's
weld carries exactly the bearing's force (the seat is massless and still), which is
how the force is read (Drake reports joint reactions, not constraint impulses).
MuJoCo-only attributes (integrator, step, solver tolerance, ``solref``/``solimp``)
are dropped: Drake softens the constraints its own way. Building the plant through
pydrake directly would repeat, kind by kind, what the MJCF already says; the text
edit is short and knows no kind.

**Simulation.** Discrete plant, SAP solver (the only one that takes ball
constraints), step :attr:`Stepping.time_step_s`; from the scene's initial state
(the first shaft turning at the initial speed, every other joint at its kinematic
rate as its kind gives it), the input torque on the first shaft and the load torque
on the last, held over each step at its mid-step value (second order in the step),
gravity as in the scene. At each of the operator's instants the reactions are
evaluated for the step from that instant with the torques of that instant
(``use_sampled_output_ports = False``), so that they belong to the instant's loads.

**Reading.** ``get_reaction_forces_output_port()`` gives, per joint, the spatial
force its parent applies to its child at the child's joint frame. A bearing's force
on its shaft is its seat's weld reaction (seat equilibrium: weld + ball = 0, and the
ball pushes the shaft by the opposite of what it pushes the seat); a joint between
two tree neighbours gives the wrench on its child, the parent taking the opposite.
Each wrench is taken to the operator body's moment reference and solved for that
element's columns (least squares, the misfit reported as in
:mod:`~.engine_mujoco`); a unilateral pair is resolved by complementarity on its net
push, as the package resolves it.

**SAP's near-rigid regularisation** (Castro et al. 2022, section V; Drake's
``SapHolonomicConstraint``): a ball constraint has no stiffness of its own; SAP gives
each of its rows the regulariser ``R_i = beta^2 / (4 pi^2) w_i`` with ``beta = 0.1``
(fixed in ``SapBallConstraint``) and ``w_i`` the RMS norm of the constraint's block of
``J diag(M)^-1 J'`` divided by its row count, and a relaxation time of one step. The
member of the rigid set this selects is
:func:`cardan_forces.experiments.engine_member.predicted` with the compliances of
:func:`delassus_estimates`, the line posed at the rigid motion's angle.

**What Drake cannot express here** (:class:`EngineUnsupported`): what MuJoCo cannot
(:func:`~.engine_mujoco.check_expressible`), and a bearing that adds bodies of its
own (a floating bearing's carrier: its weight compensation, MJCF's ``gravcomp``, is not
read by Drake's parser).
"""

from __future__ import annotations

import time as _time
import xml.etree.ElementTree as ET
from dataclasses import dataclass

import numpy as np

from . import engine_mujoco
from .elements import shaft_segments
from .elements.base import DRAKE
from .engine_mujoco import EngineRun, EngineUnsupported, Governor, reference_points, start_of
from .equilibrium import Operator
from .kinematics import rest_geometry

MUJOCO_ONLY = {"option": ("timestep", "integrator", "tolerance", "iterations"),
               "connect": ("solref", "solimp")}
"""MJCF attributes Drake's parser does not read (it warns), dropped by :func:`drake_mjcf`."""

SEAT = "seat."
"""Prefix of a bearing's seat body: ``seat.<bearing contact name>``."""


@dataclass(frozen=True)
class Stepping:
    """Drake's one setting that moves its constraint forces: the discrete step (s).
    SAP treats every ball constraint as near-rigid, with a relaxation time of one step
    (module doc), so the step is also the constraints' time constant
    (:attr:`timeconst_s`); ``scaled`` is empty (SAP offers no per-constraint softness
    for ball constraints), kept so that a run reads as MuJoCo's does.
    """

    time_step_s: float = 2.5e-4
    label: str = "step 0.25 ms"
    scaled: tuple = ()

    @property
    def timeconst_s(self) -> float:
        return self.time_step_s


def _pydrake():
    try:
        import pydrake.all as drake
    except ImportError:
        raise EngineUnsupported(
            "Drake is not installed: pip install 'cardan-forces[drake]'") from None
    return drake


def drake_version() -> str:
    """The installed Drake's version (:class:`EngineUnsupported` when it is absent)."""
    from importlib.metadata import PackageNotFoundError, version

    _pydrake()
    try:
        engine_mujoco.mujoco_version()
    except EngineUnsupported:
        raise EngineUnsupported("Drake reads the MJCF that MuJoCo's routines write, and "
                                "MuJoCo is not installed: pip install "
                                "'cardan-forces[drake]'") from None
    try:
        return version("drake")
    except PackageNotFoundError:  # a source build: no distribution metadata
        return "unknown"


def check_expressible(op: Operator) -> None:
    """Raise :class:`EngineUnsupported` naming what Drake cannot express (module doc)."""
    engine_mujoco.check_expressible(op.scene, DRAKE)
    root = ET.fromstring(engine_mujoco.build_mjcf(op))
    added = [b.get("name") for b in root.find("worldbody").findall("body")[1:]]
    if added:
        raise EngineUnsupported(
            f"scene {op.scene.name}: Drake cannot express: bearing bodies "
            f"{', '.join(added)} (their weight compensation, MJCF's gravcomp, is not read "
            "by Drake's parser)")


def _poses(worldbody) -> dict:
    """Each MJCF body's global pose ``(R, p)`` at the start, from the nested ``pos``,
    ``quat`` attributes.
    """
    out = {}

    def walk(element, rot, pos):
        for body in element.findall("body"):
            p = np.array(body.get("pos", "0 0 0").split(), float)
            w, x, y, z = np.array(body.get("quat", "1 0 0 0").split(), float)
            local = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                              [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                              [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])
            out[body.get("name")] = (rot @ local, pos + rot @ p)
            walk(body, *out[body.get("name")])

    walk(worldbody, np.eye(3), np.zeros(3))
    return out


def drake_mjcf(op: Operator) -> str:
    """The operator's MJCF (:func:`~.engine_mujoco.build_mjcf`) as Drake takes it: each
    ``connect`` to the world made to a seat body at the bearing point, MuJoCo-only
    attributes dropped (module doc).
    """
    root = ET.fromstring(engine_mujoco.build_mjcf(op))
    for tag, names in MUJOCO_ONLY.items():
        for element in root.iter(tag):
            for name in names:
                element.attrib.pop(name, None)
    worldbody = root.find("worldbody")
    poses = _poses(worldbody)
    for connect in root.iter("connect"):
        if connect.get("body2") != "world":
            continue
        rot, pos = poses[connect.get("body1")]
        point = pos + rot @ np.array(connect.get("anchor").split(), float)
        seat = SEAT + connect.get("name")
        connect.set("body2", seat)
        ET.SubElement(worldbody, "body",
                      {"name": seat, "pos": " ".join(f"{v:.17g}" for v in point)})
    return ET.tostring(root, encoding="unicode")


def _tree(op: Operator) -> list[tuple[int, int, list]]:
    """The operator's bodies in tree order from the first shaft body: ``(child, parent,
    links)`` per body after the first, ``links`` the contacts joining the two.
    """
    joins: dict[frozenset, list] = {}
    for c in op.contacts:
        if c.other is not None:
            joins.setdefault(frozenset((c.body, c.other)), []).append(c)
    order, seen = [], {0}
    frontier = [0]
    while frontier:
        here = frontier.pop(0)
        for pair, links in joins.items():
            if here in pair and pair - seen:
                (child,) = pair - seen
                seen.add(child)
                order.append((child, here, links))
                frontier.append(child)
    return order


@dataclass
class _Model:
    """A built Drake simulation: the simulator, plant and its context, the joint
    joining each operator body to its parent (by the child's operator index), each
    bearing's seat weld (by its contact name), the bodies the torques act on, the
    shafts' axes (global, at rest) and the operator bodies' moment references.
    """

    simulator: object
    plant: object
    context: object
    joint_of: dict
    seat_of: dict
    first: object
    last: object
    axes: np.ndarray
    refs: np.ndarray


def _build(op: Operator, stepping: Stepping) -> _Model:
    drake = _pydrake()
    builder = drake.DiagramBuilder()
    config = drake.MultibodyPlantConfig(time_step=stepping.time_step_s,
                                        discrete_contact_approximation="sap",
                                        use_sampled_output_ports=False)
    plant, _ = drake.AddMultibodyPlant(config, builder)
    parser = drake.Parser(plant)
    parser.AddModelsFromString(drake_mjcf(op), "xml")
    plant.Finalize()
    diagram = builder.Build()
    simulator = drake.Simulator(diagram)
    context = plant.GetMyMutableContextFromRoot(simulator.get_mutable_context())
    names = [b.name for b in op.bodies]
    joints = [plant.get_joint(j) for j in plant.GetJointIndices()]
    joint_of = {}
    for child, _, _ in _tree(op):
        joint_of[child] = next(j for j in joints if j.child_body().name() == names[child])
    seat_of = {j.child_body().name()[len(SEAT):]: j for j in joints
               if j.child_body().name().startswith(SEAT)}
    n_seg = len(shaft_segments(op.scene))
    last = [c for c, _, _ in _tree(op) if c < n_seg]
    first = plant.GetBodyByName(names[0])
    return _Model(simulator, plant, context, joint_of, seat_of, first,
                  plant.GetBodyByName(names[last[-1] if last else 0]),
                  rest_geometry(op.scene).axes, reference_points(op))


def _initial_state(op: Operator, model: _Model) -> None:
    """The scene's initial state (module doc): the first shaft turning about its axis,
    each tree joint at the speed its kind gives.
    """
    drake = _pydrake()
    start = start_of(op)
    spin = drake.SpatialVelocity(w=start.speed * start.geo.axes[0], v=np.zeros(3))
    model.plant.SetFreeBodySpatialVelocity(model.context, model.first, spin)
    for child, _, links in _tree(op):
        link = links[0]
        kind = link.element_kind
        _, axis, _ = kind.mjcf_joint(link, child, start)
        speed = kind.mjcf_speed(link, child, axis, start)
        joint = model.joint_of[child]
        v = model.plant.GetVelocities(model.context)
        v[joint.velocity_start()] = speed
        model.plant.SetVelocities(model.context, v)


def _torques(op: Operator, model: _Model, now: float, governed: float = 0.0) -> None:
    """Fix the plant's applied spatial forces to the scene's torques at time ``now``,
    and a governor's torque ``governed`` (N m) on the first shaft.
    """
    drake = _pydrake()
    axes = model.axes
    forces = []
    for body, torque in ((model.first, (op.scene.input_torque(now) + governed) * axes[0]),
                         (model.last, -op.scene.load_torque(now) * axes[-1])):
        applied = drake.ExternallyAppliedSpatialForce()
        applied.body_index = body.index()
        applied.p_BoBq_B = np.zeros(3)
        applied.F_Bq_W = drake.SpatialForce(tau=torque, f=np.zeros(3))
        forces.append(applied)
    model.plant.get_applied_spatial_force_input_port().FixValue(model.context, forces)


def _joint_wrench(model: _Model, joint, reactions, ref: np.ndarray) -> np.ndarray:
    """``[F, M_ref]`` (global) of the reaction on ``joint``'s child, about ``ref``."""
    pose = joint.frame_on_child().CalcPoseInWorld(model.context)
    rot, at = pose.rotation().matrix(), pose.translation()
    spatial = reactions[int(joint.index())]
    force, moment = rot @ spatial.translational(), rot @ spatial.rotational()
    return np.concatenate([force, moment + np.cross(at - ref, force)])


def _read(op: Operator, model: _Model, i: int) -> tuple[np.ndarray, float]:
    """The operator's forces (n,) at instant ``i`` and the largest misfit (module doc)."""
    reactions = model.plant.get_reaction_forces_output_port().Eval(model.context)
    refs = model.refs
    x, misfit = np.zeros(len(op.names)), 0.0
    groups = [(link.body, [link], model.seat_of[link.name], 1.0) for link in op.bearings()]
    for child, parent, links in _tree(op):
        joint = model.joint_of[child]
        groups += [(child, links, joint, 1.0), (parent, links, joint, -1.0)]
    done: set[int] = set()
    for body, links, joint, sign in groups:
        cols = [c for link in links for c in link.columns]
        if done.issuperset(cols):
            continue
        w = sign * _joint_wrench(model, joint, reactions, refs[body])
        block = op.A[i, 6 * body: 6 * body + 6][:, cols]
        y = np.linalg.lstsq(block, w, rcond=None)[0]
        misfit = max(misfit, float(np.max(np.abs(block @ y - w))))
        x[cols] = y
        done.update(cols)
    for a, b in op.pairs:  # a pair (end faces, ...): complementary on its net push
        net = x[b] - x[a]
        x[a], x[b] = max(-net, 0.0), max(net, 0.0)
    return x, misfit


def _angle(op: Operator, model: _Model) -> tuple[float, float]:
    """The first shaft's angle about its axis in (-pi, pi] and its speed (rad/s)."""
    frame, axis = op.shaft_frames[0], model.axes[0]
    pose = model.plant.EvalBodyPoseInWorld(model.context, model.first)
    turned = pose.rotation().matrix() @ frame[0]
    speed = model.plant.EvalBodySpatialVelocityInWorld(model.context, model.first)
    return (float(np.arctan2(turned @ frame[1], turned @ frame[0])),
            float(speed.rotational() @ axis))


def run(op: Operator, stepping: Stepping = Stepping(),
        governor: Governor | None = None) -> EngineRun:
    """Simulate the operator's scene in Drake from its initial state and read the
    forces at the operator's instants (module doc); an :class:`EngineRun` whose
    ``softness`` is the run's :class:`Stepping`; the input speed held by ``governor``
    where one is given.
    """
    check_expressible(op)
    model = _build(op, stepping)
    _initial_state(op, model)
    scene, dt = op.scene, stepping.time_step_s
    steps_per = scene.time.step_s / dt
    if abs(steps_per - round(steps_per)) > 1e-6:
        raise EngineUnsupported(f"Drake's step {dt:g} s does not divide the scene's "
                                f"step {scene.time.step_s:g} s")
    targets = np.rint((op.t - scene.time.start_s) / dt).astype(int)
    if np.any(np.diff(targets) < 0) or targets[0] < 0:
        raise EngineUnsupported("the engine reads instants in time order from the start")
    n = len(op.t)
    forces, q, qd, misfit = np.zeros((n, len(op.names))), np.zeros(n), np.zeros(n), np.zeros(n)
    simulator, step = model.simulator, 0
    simulator.get_mutable_context().SetTime(scene.time.start_s)
    simulator.Initialize()
    prev, _ = _angle(op, model)
    turns = round((scene.initial_angle_rad - prev) / (2 * np.pi))
    began, held = _time.perf_counter(), 0.0

    def governed() -> float:  # the governor's torque on the engine's input motion
        if governor is None:
            return 0.0
        return governor.torque(scene.time.start_s + step * dt, prev + 2 * np.pi * turns,
                               _angle(op, model)[1])

    for i, target in enumerate(targets):
        while step < target:
            _torques(op, model, scene.time.start_s + (step + 0.5) * dt, governed())
            simulator.AdvanceTo(scene.time.start_s + (step + 1) * dt)
            step += 1
            now, _ = _angle(op, model)  # counted every step: a turn is many steps
            turns += round((prev - now) / (2 * np.pi))
            prev = now
        now_governed = governed()
        held = max(held, abs(now_governed))
        _torques(op, model, float(op.t[i]), now_governed)
        forces[i], misfit[i] = _read(op, model, i)
        q[i], qd[i] = prev + 2 * np.pi * turns, _angle(op, model)[1]
    return EngineRun(op.t, forces, op.names, q, qd, misfit, stepping, dt, step,
                     _time.perf_counter() - began, held)


POSE_STEP_RAD = 0.2
"""The largest turn of the first shaft between two poses of :func:`delassus_estimates`'
continuation (each pose starts from the one before, so it stays on the line's branch)."""


def delassus_estimates(op: Operator, angles) -> list[dict[str, float]]:
    """SAP's ``w`` of each bearing's ball constraint (1/kg), by the bearing's contact
    name, with the line posed at each of the first shaft's ``angles`` (rad, increasing,
    the rigid motion's: nothing is simulated): ``||J_c diag(M)^-1 J_c'||_F / 3`` with
    ``J_c`` the constraint's (3, nv) Jacobian (the translational velocity of its point on
    the shaft; the seat does not move) and ``M`` the plant's mass matrix (Drake's
    ``SapModel::CalcDelassusDiagonalApproximation``). Both change as the line turns.

    The pose: the first shaft turned about its axis from the scene's initial angle, every
    other joint's position solved (least squares) so that each bearing's point sits on
    its seat, by continuation in turns of at most :data:`POSE_STEP_RAD`.
    """
    from scipy.optimize import least_squares

    drake = _pydrake()
    check_expressible(op)
    plant = drake.MultibodyPlant(0.0)
    drake.Parser(plant).AddModelsFromString(drake_mjcf(op), "xml")
    plant.Finalize()
    context = plant.CreateDefaultContext()
    world = plant.world_frame()
    axis = rest_geometry(op.scene).axes[0]
    first = plant.GetBodyByName(op.bodies[0].name)
    start = plant.EvalBodyPoseInWorld(context, first)
    held = []  # per bearing: its contact name, shaft body, point on it (body frame), seat
    for link in op.bearings():
        seat = plant.GetBodyByName(SEAT + link.name).EvalPoseInWorld(context).translation()
        body = plant.GetBodyByName(op.bodies[link.body].name)
        held.append((link.name, body, body.EvalPoseInWorld(context).inverse() @ seat, seat))
    free = [plant.get_joint(j).position_start() for j in plant.GetJointIndices()
            if plant.get_joint(j).num_positions() == 1]

    def place(z):
        q = plant.GetPositions(context)
        q[free] = z
        plant.SetPositions(context, q)

    def misfit(z):
        place(z)
        return np.concatenate([body.EvalPoseInWorld(context) @ at - seat
                               for _, body, at, seat in held])

    def turn(angle):
        rot = drake.RotationMatrix(drake.AngleAxis(angle - op.scene.initial_angle_rad, axis))
        plant.SetFreeBodyPose(context, first, drake.RigidTransform(
            rot @ start.rotation(), start.translation()))

    z, now, out = plant.GetPositions(context)[free], op.scene.initial_angle_rad, []
    for angle in angles:
        for a in np.linspace(now, angle, 1 + int(np.ceil(abs(angle - now) / POSE_STEP_RAD)))[1:]:
            turn(a)
            z = least_squares(misfit, z, method="lm", xtol=1e-15, ftol=1e-15).x
        now = angle
        turn(angle)
        place(z)
        inverse = 1.0 / np.diag(plant.CalcMassMatrix(context))
        w = {}
        for name, body, at, _ in held:
            jac = plant.CalcJacobianTranslationalVelocity(
                context, drake.JacobianWrtVariable.kV, body.body_frame(), at, world, world)
            w[name] = float(np.linalg.norm(jac @ (inverse[:, None] * jac.T)) / 3)
        out.append(w)
    return out
