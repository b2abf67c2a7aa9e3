"""Solution sets: how far each force can move inside the rigid model's answers.

For every named component ``x_j`` at one instant, the interval ``[min x_j, max x_j]``
over ``{A x = b, end faces >= 0}``: two LPs per component. An end is ``None`` where
the LP is unbounded (the component can grow without limit along the null space).
Together with the null-space dimension this is the rigid model's whole answer for an
indeterminate force; any single number (least norm, the paper's fsolve, a compliance
model) is a choice inside it.
"""

from __future__ import annotations

import numpy as np

from driveline.equilibrium import Operator

from .convex import checks, equalities
from .problems import LP


def interval_problems(op: Operator, i: int) -> dict[str, tuple[LP, LP]]:
    """``{name: (lp_min, lp_max)}``; ``lp_max`` minimizes ``-x_j``."""
    A, b = equalities(op, i)
    lb = np.where(op.unilateral, 0.0, -np.inf)
    base = checks(op, i, pairs=False)
    problems = {}
    for j, name in enumerate(op.names):
        c = np.zeros(len(op.names))
        c[j] = 1.0
        problems[name] = tuple(
            LP(checks=base, formulation=f"interval.{side}", c=sign * c, A=A, b=b, lb=lb)
            for side, sign in (("min", 1.0), ("max", -1.0))
        )
    return problems
