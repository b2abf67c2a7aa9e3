"""Contact-force time histories per method, for the paper's Figs. 13-15.

A method is a formulation solved by one backend at every instant; the paper's method
is warm-started from the previous instant's answer, as a careful engineer would run
it, and started again from eqs. 63-74 where the warm start fails. Every instant's
answer is a package-judged record: an instant whose record is not ``solved`` is kept
as NaN in the history (and counted), never drawn as if fine.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from cardan_forces.driveline.equilibrium import Operator
from cardan_forces.driveline.penalty import PenaltyResult, released, simulate_penalty
from cardan_forces.driveline.scene import Scene
from cardan_forces.experiments.study import History, solve_over_time
from cardan_forces.formulations import BASELINE
from cardan_forces.solvers import Status


def history(op: Operator, method: str, solver: str | None = None,
            progress: Callable[[str], None] | None = None) -> History:
    """Solve ``method`` at every instant of ``op`` with ``solver`` (default: the study
    layer's). The paper's method starts each instant from the previous answer and again
    from its own initial-value procedure (eqs. 63-74) where that fails.
    """
    say = None if progress is None else (lambda m: progress(f"repro: {m}"))
    paper = method == BASELINE  # the others need no restart: their checks come at once
    return solve_over_time(op, method, solver, warm=paper, restart=paper, progress=say)


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
    statuses = tuple(Status.SOLVED if np.all(np.isfinite(row)) else Status.FAILED
                     for row in forces)
    return History("penalty", result.integrator, np.asarray(result.t), forces, statuses,
                   result.wall_s)
