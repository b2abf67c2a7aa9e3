"""Support check: a scene's line must be held so that it turns with exactly one degree
of freedom, with a motion the integrator can follow.

Decided from the structure, not by counting bearings: at one generic configuration
(the kinematics at the scene's initial angle turned by :data:`GENERIC_TURN_RAD`) the
equilibrium operator ``A`` has 6 rows per body and one column per contact force
component. A left null vector ``y`` of ``A`` (``y^T A = 0``) is a set of body twists
(velocity of each body's reference point on its force rows, angular velocity on its
moment rows) along which no contact does work: a motion the contacts leave free. So

- ``rows - rank(A) == 1``: the line's rotation is the only free motion (held);
- ``> 1``: a mechanism: some body (or bodies) can move besides the rotation; the
  extra left null vectors, mapped back to the rows of ``A``, name the free bodies and
  directions;
- ``0``: locked: the contacts do not let the line turn at all.

Any element kind that adds or removes columns (or bodies, six rows each) of
``build_operator``'s output is covered without change here.

The motion check bounds the input's revolutions over the time span (see
:func:`check_motion`): the integrator resolves every turn, so a line that would spin
up to millions of revolutions is refused at load rather than integrated for hours.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from .determinacy import equilibrated, holding, numerical_rank
from .dynamics import Motion, reduced_inertia
from .elements.registry import kind_of
from .equilibrium import build_operator
from .kinematics import kinematics, rest_geometry
from .scene import MAX_TURNS, Scene, SceneError

GENERIC_TURN_RAD = 0.7
"""Input angle added to the scene's initial angle: a configuration where no yoke lies in
the articulation plane (those are where the paper's eq. 2 has its extremes)."""

FREE_TOL = 1e-6
"""A row of the extra free motions with a weight above this is reported as free."""


@dataclass(frozen=True)
class Support:
    """The free motions of the line at one configuration: ``free`` (rows - rank of A),
    ``rows`` (labels of the rows of A that move in a free motion beyond the line's
    rotation; empty when held or locked).
    """

    free: int
    rows: tuple[str, ...]

    @property
    def held(self) -> bool:
        return self.free == 1


def free_motions(A: np.ndarray, labels: tuple[str, ...]) -> Support:
    """Count the motions ``A`` (rows x columns, 6 rows per body: force x, y, z, then
    moment x, y, z) leaves free, and name the rows that move in the free motions besides
    the line's rotation (the one free motion without translation: every body's reference
    point sits on its fixed axis or joint centre). Translations are named when there are
    any (a body not held in place), else rotations; rows under a tenth of the largest
    weight are left out.
    """
    hold = holding(A)
    null, free = hold.null, hold.free
    if free <= 1:
        return Support(free=free, rows=())
    force_rows = (np.arange(A.shape[0]) % 6) < 3
    _, fs, fvt = np.linalg.svd(null[force_rows])
    moving = int(np.sum(fs > FREE_TOL))
    extra = null @ (fvt[:moving] if free - moving == 1 else fvt).T
    weight = np.linalg.norm(extra, axis=1)
    shown = force_rows if weight[force_rows].max() > FREE_TOL else ~force_rows
    cut = 0.1 * weight[shown].max()
    return Support(free=free, rows=tuple(label for label, w, keep in zip(labels, weight, shown)
                                         if keep and w > cut))


def _describe(rows: tuple[str, ...]) -> str:
    """``input.force.y, input.force.z`` -> ``input (moves along y, z)``; moment rows ->
    ``(turns about x)``.
    """
    bodies: dict[str, dict[str, list[str]]] = {}
    for label in rows:
        body, kind, axis = label.rsplit(".", 2)
        bodies.setdefault(body, {}).setdefault(kind, []).append(axis)
    verbs = {"force": "moves along", "moment": "turns about"}
    parts = []
    for body, kinds in bodies.items():
        moves = "; ".join(f"{verbs[kind]} {', '.join(axes)}" for kind, axes in kinds.items())
        parts.append(f"{body} ({moves})")
    return ", ".join(parts)


def support(scene: Scene) -> Support:
    """The free motions of ``scene``'s line at a generic configuration (contact geometry
    only: the loads ``b`` play no part, so neither do torques, time grid or effects).
    Remembered by the line's structure: variants that change only loads or the grid
    (sweep points, hard cases) reuse the answer.
    """
    key = structure(scene)
    if key not in _KNOWN:
        if len(_KNOWN) >= MAX_KNOWN:
            _KNOWN.pop(next(iter(_KNOWN)))
        op = build_operator(at_rest(scene, scene.initial_angle_rad + GENERIC_TURN_RAD))
        _KNOWN[key] = free_motions(op.A[0], op.rows)
    return _KNOWN[key]


NOT_STRUCTURE = frozenset({"name", "description", "source", "input_torque", "load_torque",
                           "initial_speed_rad_s", "time", "tolerances"})
"""The scene's fields the support cannot depend on (names, loads, the time grid,
tolerances): every other field, present or added later, is part of
:func:`structure`, so a field forgotten here costs a recomputation, never another
scene's answer."""


def structure(scene: Scene) -> tuple:
    """The scene's structural identity: every field but :data:`NOT_STRUCTURE`, as
    ``(name, value)`` pairs (the records are frozen, so the tuple hashes by value).
    """
    return tuple((f.name, getattr(scene, f.name)) for f in dataclasses.fields(scene)
                 if f.name not in NOT_STRUCTURE)


_KNOWN: dict[tuple, Support] = {}
""":func:`support`'s answers by structure, oldest first."""

MAX_KNOWN = 256
"""Structures remembered (a few kB each)."""


def at_rest(scene: Scene, q: float) -> Motion:
    """The line held still at input angle ``q`` (rad), at the scene's start: the contact
    geometry of any motion through ``q``, without integrating the motion there.
    """
    geometry = rest_geometry(scene)
    angle, zero = np.array([q]), np.zeros(1)
    kin = kinematics(geometry, angle)
    t = np.array([scene.time.start_s])
    return Motion(scene=scene, geometry=geometry, t=t, q=angle, qd=zero, qdd=zero, kin=kin,
                  omega=kin.ratio * 0.0, alpha=kin.ratio * 0.0, pin_omega=kin.pin_rate * 0.0,
                  pin_alpha=kin.pin_rate * 0.0,
                  com_acceleration=np.zeros((len(scene.shafts) + sum(kin.pinned), 1, 3)),
                  input_torque=scene.input_torque(t) * 1.0,
                  load_torque=scene.load_torque(t) * 1.0)


def check_support(scene: Scene) -> None:
    """Raise :class:`SceneError` unless the line turns with exactly one degree of freedom
    while its contacts hold it.
    """
    found = support(scene)
    if found.held:
        return
    where = f"scene {scene.source}: field 'shafts'"
    if found.free == 0:
        raise SceneError(f"{where}: the line is locked: its contacts leave no free motion, "
                         "so it cannot turn (one is needed, the line's rotation)")
    raise SceneError(
        f"{where}: the line is not held: its contacts leave {found.free} free motions where "
        f"one (the line's rotation) is wanted; free besides it: {_describe(found.rows)}: "
        "add bearings that hold these bodies")


def turns_bound(scene: Scene) -> float:
    """An upper estimate of the input's revolutions over the scene's time span:
    ``(|w0| T + 1/2 a T^2) / 2 pi`` with ``a`` the largest net torque over the smallest
    reduced inertia ``I(q)``, both sampled over one revolution (the net torque
    ``M_in - M_load dphi_out/dq`` with each law's mean and amplitude at their worst).
    Quasi-static scenes turn at the initial speed.
    """
    span = scene.time.stop_s - scene.time.start_s
    speed = abs(scene.initial_speed_rad_s)
    if not scene.has("inertia"):
        return speed * span / (2 * np.pi)
    kin = kinematics(rest_geometry(scene), np.linspace(0.0, 2 * np.pi, 73))
    inertia, _ = reduced_inertia(scene, kin)
    ratio = kin.ratio[-1]
    m_in, m_load = scene.input_torque, scene.load_torque
    net = (np.abs(m_in.mean_N_m - ratio * m_load.mean_N_m) + abs(m_in.amplitude_N_m)
           + np.abs(ratio) * abs(m_load.amplitude_N_m))
    accel = float(np.max(net) / np.min(inertia))
    return (speed * span + 0.5 * accel * span**2) / (2 * np.pi)


def check_motion(scene: Scene) -> None:
    """Raise :class:`SceneError` when :func:`turns_bound` exceeds :data:`MAX_TURNS`."""
    turns = turns_bound(scene)
    span = scene.time.stop_s - scene.time.start_s
    if turns > MAX_TURNS:
        raise SceneError(
            f"scene {scene.source}: field 'time.stop_s': over {span:g} s "
            f"the line may turn {turns:.3g} revolutions (initial speed "
            f"{scene.initial_speed_rad_s:g} rad/s and the torques); at most {MAX_TURNS:g}: "
            "shorten the time span or lower the speed or torques")


def still(scene: Scene) -> bool:
    """Whether the line stays at rest at its initial angle over the whole grid: no
    initial speed and both torque laws zero (then every instant is one configuration
    with one load, gravity, and every spline carries zero torque).
    """
    laws = (scene.input_torque, scene.load_torque)
    return scene.initial_speed_rad_s == 0 and all(
        law.mean_N_m == 0 and law.amplitude_N_m == 0 for law in laws)


def check_loads(scene: Scene) -> None:
    """Raise :class:`SceneError` for a line that cannot carry its loads at any instant:
    one :func:`still` whose slip joints with friction must carry an axial force. Their
    friction is at most ``mu T / r`` with the spline torque ``T`` zero, so the axial
    force is zero; the line carries its loads iff ``b`` lies in the range of ``A``
    without those columns (end faces come in pairs, so their signs never bind). Exact
    for the whole grid, since every instant is the same; other lines are not judged
    here (their spline torques vary with time).
    """
    if not still(scene):
        return
    op = build_operator(at_rest(scene, scene.initial_angle_rad))
    if not op.slip_friction:
        return
    axial = {f.axial for f in op.slip_friction}
    A = op.A[0][:, [c for c in range(len(op.names)) if c not in axial]]
    b = op.b[0][:, None]
    if numerical_rank(np.linalg.svd(equilibrated(np.hstack([A, b])), compute_uv=False)) \
            <= numerical_rank(np.linalg.svd(equilibrated(A), compute_uv=False)):
        return
    slips = ", ".join(f.slip for f in op.slip_friction)
    table = kind_of(next(e for e in scene.elements if e.name == op.slip_friction[0].slip)).table
    raise SceneError(
        f"scene {scene.source}: field '{table}': the line cannot carry its loads at any "
        f"instant: it stays at rest with no torque, so the friction of slip joint(s) {slips} "
        "(at most mu T / r) is zero, and nothing else holds the part beyond the spline "
        "against its axial load: give the line a torque or that part a locating bearing")


def check_scene(scene: Scene) -> None:
    """Every structural check of a scene built from its file: motion, support, then the
    loads a line at rest can carry.
    """
    check_motion(scene)
    check_support(scene)
    check_loads(scene)
