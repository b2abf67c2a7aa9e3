"""Solution sets: how far each force can move inside the rigid model's answers.

For every named component ``x_j`` at one instant, the interval ``[min x_j, max x_j]``
over ``{A x = b, end faces >= 0}`` (and the slip joints' friction bounds): two LPs
per component. An end is ``None`` where
the LP is unbounded (the component can grow without limit along the null space).
Together with the null-space dimension this is the rigid model's whole answer for an
indeterminate force; any single number (least norm, the paper's fsolve, a compliance
model) is a choice inside it.
"""

from __future__ import annotations

import numpy as np
from cardan_forces.driveline.equilibrium import Operator

from .convex import checks, equalities, slip_rows
from .problems import LP


def range_problems(op: Operator, i: int, c: np.ndarray) -> tuple[LP, LP]:
    """The two LPs bounding ``c'x`` over the rigid set: min ``c'x``, min ``-c'x``."""
    A, b = equalities(op, i)
    lb = np.where(op.unilateral, 0.0, -np.inf)
    base = checks(op, i, pairs=False)
    G = slip_rows(op, i)
    bounds = dict(G=G, h=np.zeros(len(G))) if len(G) else {}
    return tuple(
        LP(checks=base, formulation=f"interval.{side}", c=sign * np.asarray(c, float), A=A, b=b,
           lb=lb, **bounds)
        for side, sign in (("min", 1.0), ("max", -1.0))
    )


def interval_problems(op: Operator, i: int) -> dict[str, tuple[LP, LP]]:
    """``{name: (lp_min, lp_max)}`` for every named component."""
    eye = np.eye(len(op.names))
    return {name: range_problems(op, i, eye[j]) for j, name in enumerate(op.names)}
