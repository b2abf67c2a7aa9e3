"""Contact-force time histories per method, for the paper's Figs. 13-15.

A method is a formulation solved by one backend at every instant; the paper's method
is warm-started from the previous instant's answer, as a careful engineer would run
it, and started again from eqs. 63-74 where the warm start fails. Every instant's
answer is a package-judged record: an instant whose record is not ``solved`` is kept
as NaN in the history (and counted), never drawn as if fine.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from cardan_forces.driveline.equilibrium import Operator
from cardan_forces.driveline.penalty import PenaltyResult, simulate_penalty
from cardan_forces.driveline.scene import Scene, SceneError
from cardan_forces.formulations import FORMULATIONS
from cardan_forces.solvers import solve

METHODS = {
    "paper": "scipy-fsolve",
    "positive": "qpsolvers-daqp",
    "min_max": "clarabel",
    "compliance": "qpsolvers-daqp",
}
"""Method (formulation) -> the backend that draws it in the figures. ``min_norm`` is
left out: its end faces pull, so it is no contact force."""


@dataclass(frozen=True)
class History:
    """Forces (T, 36) in the operator's names, NaN where an instant was not solved."""

    method: str
    solver: str
    forces: np.ndarray
    statuses: tuple[str, ...]
    seconds: float

    @property
    def solved(self) -> int:
        return sum(s == "solved" for s in self.statuses)


def history(op: Operator, method: str, solver: str | None = None,
            progress: Callable[[str], None] | None = None) -> History:
    """Solve ``method`` at every instant of ``op`` with ``solver`` (default: METHODS)."""
    solver = solver or METHODS[method]
    n = len(op.names)
    forces = np.full((len(op.t), n), np.nan)
    statuses, seconds, warm = [], 0.0, None
    for i in range(len(op.t)):
        problem = FORMULATIONS[method](op, i)
        record = solve(problem, solver, initvals=warm)
        seconds += record.setup_s + record.solve_s
        if record.status != "solved" and warm is not None:
            # a warm start can fall off a branch of the paper's nonsmooth system (the Sgn
            # of eqs. 35-36): start again from its own initial-value procedure
            record = solve(problem, solver)
            seconds += record.setup_s + record.solve_s
        statuses.append(record.status)
        if record.status == "solved":
            forces[i] = record.x[:n]
            warm = record.z if method == "paper" else None
        if progress and (i + 1) % 200 == 0:
            progress(f"repro: {method} ({solver}) {i + 1}/{len(op.t)} instants")
    return History(method, solver, forces, tuple(statuses), seconds)


RELEASED = frozenset({"clearance", "crosspin_inertia", "penalty_dynamics"})
"""Effects that turn a scene into its penalty-contact (ADAMS-style) counterpart."""


def released(scene: Scene) -> Scene:
    """``scene`` with every joint released (``paper`` gives ``paper-penalty``'s model):
    the same bodies, loads and clearances, contacts by penalty forces (eqs. 75-78).
    """
    if scene.has("penalty_dynamics"):
        return scene
    if not scene.has("inertia"):
        raise SceneError(f"scene {scene.name!r}: the penalty simulation is dynamic and needs "
                         "the 'inertia' effect")
    return dataclasses.replace(
        scene, name=f"{scene.name}-penalty", effects=scene.effects | RELEASED,
        description=f"{scene.description}; joints released (penalty contacts)")


def run_penalty(scene: Scene, times, progress: Callable[[str], None] | None = None
                ) -> PenaltyResult:
    """The penalty simulation of ``released(scene)`` sampled at ``times``."""
    scene = released(scene)
    end = float(np.max(times))
    report = None if progress is None else (
        lambda t: progress(f"repro: penalty simulation of {scene.name} at {t:.2f} of {end:g} s"))
    return simulate_penalty(scene, times, report, progress_every_s=max(end / 10, 0.05))


def penalty_history(result: PenaltyResult, names: tuple[str, ...]) -> History:
    """A penalty simulation's forces as a History in the operator's ``names`` (NaN after
    a failed integration).
    """
    forces = np.column_stack([result.forces[n] for n in names])
    statuses = tuple("solved" if np.all(np.isfinite(row)) else "failed" for row in forces)
    return History("penalty", f"scipy-{result.method}", forces, statuses, result.wall_s)
