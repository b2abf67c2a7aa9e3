"""The simulated selections of ``cardan life``: the penalty-contact simulation's average
and MuJoCo's forces, each on the equilibrium operator's columns at the life's instants,
or a sentence saying why it was not run.

- ``penalty`` (:func:`penalty_history`): the released scene (every joint on penalty
  contacts with its clearances, the paper's eqs. 75-78;
  :func:`~cardan_forces.driveline.penalty.released`) simulated from the scene's start,
  sampled :data:`SUBSTEPS_MIN` or more times per step of the life's instants (at least
  as finely as the scene's own step) and averaged over the stretch each instant stands
  for (from half way to the instant before to half way to the next: the revolutions ISO
  281's duty cycle weights that instant by). The released line rattles in its
  clearances; the average keeps what the bearing carries over the stretch, as
  ``cardan repro`` draws the simulation's moving average. It needs the scene's
  ``inertia`` effect (the simulation is dynamic) and no slip joint with friction.
- ``mujoco`` (:func:`engine_history`): MuJoCo's forward simulation of the scene under its
  default softness (:mod:`cardan_forces.experiments.engine`), read at the life's
  instants; the instants within its settling (the line starts unloaded and sags into
  its soft constraints) are left out. Where MuJoCo is installed and can express the
  scene.

Each gives a :class:`~cardan_forces.experiments.study.History` (NaN where an instant is
left out) and a sentence of what it is, or ``None`` and why not: a scene without the
effect, MuJoCo absent, a failed integration are answers, never exceptions.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from cardan_forces.driveline import engine_mujoco
from cardan_forces.driveline.equilibrium import Operator
from cardan_forces.driveline.penalty import released, simulate_penalty
from cardan_forces.driveline.scene import SceneError
from cardan_forces.experiments import engine
from cardan_forces.experiments.study import History
from cardan_forces.solvers import Status

PENALTY = "penalty"
ENGINE = "mujoco"

SUBSTEPS_MIN = 2
"""Fewest penalty samples per step of the life's instants (an even number: the stretch
of an instant is half a step either side)."""

Outcome = tuple[History | None, str]
"""A simulated selection's history (or ``None``) and the sentence that says what it is
(or why it was not run)."""


def _history(name: str, solver: str, t: np.ndarray, forces: np.ndarray,
             seconds: float) -> History:
    """Forces ``(T, n)`` as a :class:`History`: an instant is solved where all its
    forces are finite.
    """
    statuses = tuple(Status.SOLVED if np.all(np.isfinite(row)) else Status.FAILED
                     for row in forces)
    return History(name, solver, np.asarray(t, float), forces, statuses, seconds)


def substeps(t: np.ndarray, step_s: float) -> int:
    """Penalty samples per step of instants ``t`` (s): even, at least
    :data:`SUBSTEPS_MIN`, and no sample step longer than ``step_s``.
    """
    longest = float(np.max(np.diff(t)))
    return max(SUBSTEPS_MIN, 2 * math.ceil(longest / (2.0 * step_s) - 1e-9))


def dense_times(t: np.ndarray, m: int) -> np.ndarray:
    """``m`` samples per step of ``t`` (s) and ``t``'s last instant: instant ``i`` is
    sample ``i * m``.
    """
    parts = [np.linspace(a, b, m, endpoint=False) for a, b in zip(t[:-1], t[1:])]
    return np.concatenate([*parts, t[-1:]])


def stretch_means(values: np.ndarray, times: np.ndarray, n: int, m: int) -> np.ndarray:
    """``(n, k)``: the trapezoid mean of samples ``values`` ``(N, k)`` at ``times``
    (:func:`dense_times`, ``m`` a step) over the stretch of each of ``n`` instants (half
    a step either side, the ends' halved): the stretches :func:`~cardan_forces.
    driveline.bearing_life.revolutions` weights.
    """
    half, out = m // 2, np.empty((n, values.shape[1]))
    for i in range(n):
        window = slice(max(0, i * m - half), min(len(values), i * m + half + 1))
        steps = np.diff(times[window])
        w = np.concatenate([steps, [0.0]]) / 2 + np.concatenate([[0.0], steps]) / 2
        out[i] = w @ values[window] / w.sum()
    return out


def penalty_history(op: Operator, progress: Callable[[str], None] | None = None
                    ) -> Outcome:
    """The penalty simulation's stretch averages at ``op``'s instants (module doc)."""
    scene = op.scene
    if not scene.has("inertia"):
        return None, (f"not run: the penalty simulation is dynamic and scene {scene.name} "
                      "has no 'inertia' effect")
    t = np.asarray(op.t, float)
    m = substeps(t, scene.time.step_s)
    end = float(t[-1])
    report = None if progress is None else (
        lambda now: progress(f"life: penalty simulation at {now:.2f} of {end:g} s"))
    dense = dense_times(t, m)
    try:
        result = simulate_penalty(released(scene), dense, report,
                                  progress_every_s=max((end - t[0]) / 10, 0.05))
    except (SceneError, ValueError) as err:
        return None, f"not run: {err}"
    if not result.success:
        return None, f"not run: the simulation failed ({result.message})"
    forces = np.column_stack([result.forces[name] for name in op.names])
    words = (f"the released line's penalty-contact simulation ({result.integrator}), "
             f"{m} samples a step averaged over each instant's stretch")
    return _history(PENALTY, result.integrator, t, stretch_means(forces, dense, len(t), m),
                    result.wall_s), words


def engine_history(op: Operator) -> Outcome:
    """MuJoCo's forces at ``op``'s instants after its settling (module doc)."""
    softness = engine.SETTINGS[0]
    try:
        engine_mujoco.check_expressible(op.scene)
        version = engine_mujoco.mujoco_version()
        run = engine_mujoco.run(op, softness)
    except engine_mujoco.EngineUnsupported as err:
        return None, f"not run: {err}"
    settle = engine.settle_s({softness.label: run})
    settled = np.asarray(op.t) - op.t[0] >= settle
    forces = np.where(settled[:, None], run.forces, np.nan)
    if not np.all(np.isfinite(forces[settled])):
        return None, "not run: MuJoCo's forces are not finite (its integration diverged)"
    words = (f"MuJoCo {version}, forward simulation under its default softness; "
             f"{int((~settled).sum())} of {len(settled)} instants left out (within its "
             f"settling, the first {settle:g} s)")
    return _history(ENGINE, f"mujoco-{version}", op.t, forces, run.wall_s), words
