"""Solution sets: how far each force can move inside the rigid model's answers.

For every named component ``x_j`` at one instant, the interval ``[min x_j, max x_j]``
over ``{A x = b, end faces >= 0}`` (and the slip joints' friction bounds): two LPs
per component, all over one feasible set, so the study layer solves an instant's LPs
as one warm model with only the objective changing
(:mod:`cardan_forces.solvers.ranging`). An end is ``None`` where
the LP is unbounded (the component can grow without limit along the null space).
Together with the null-space dimension this is the rigid model's whole answer for an
indeterminate force; any single number (least norm, the paper's fsolve, a compliance
model) is a choice inside it.
"""

from __future__ import annotations

import numpy as np
from cardan_forces.driveline.equilibrium import Operator

from cardan_forces.util.rank import numerical_rank

from .convex import checks, equalities, slip_rows
from .problems import LP


def orthonormal_equalities(op: Operator, i: int) -> tuple[np.ndarray, np.ndarray]:
    """``A x = b`` as ``rank(A)`` orthonormal rows: ``V' x = S^-1 U' b`` from the SVD.
    The same set as :func:`~.convex.equalities` (``S V' x = U' b``), but every row of
    unit length: there a row's scale is its singular value, which spans many decades on
    a line of micrometre lengths (moment rows of 1e-6 m arms), and an LP solver's
    absolute feasibility tolerance then passes the small rows unchecked and calls the
    LP inaccurate. Here each row is held to the same tolerance.
    """
    u, s, vt = np.linalg.svd(op.A[i], full_matrices=False)
    rank = numerical_rank(s)
    return vt[:rank], (u[:, :rank].T @ op.b[i]) / s[:rank]


def range_problems(op: Operator, i: int, c: np.ndarray) -> tuple[LP, LP]:
    """The two LPs bounding ``c'x`` over the rigid set: min ``c'x``, min ``-c'x``
    (its equalities as :func:`orthonormal_equalities`).
    """
    A, b = orthonormal_equalities(op, i)
    lb = np.where(op.unilateral, 0.0, -np.inf)
    base = checks(op, i, pairs=False)
    G = slip_rows(op, i)
    bounds = dict(G=G, h=np.zeros(len(G))) if len(G) else {}
    return tuple(
        LP(checks=base, formulation=f"interval.{side}", c=sign * np.asarray(c, float), A=A, b=b,
           lb=lb, **bounds)
        for side, sign in (("min", 1.0), ("max", -1.0))
    )


def feasibility_problem(op: Operator, i: int) -> LP:
    """The LP ``min 0`` over the rigid set: ``solved`` when the set is not empty."""
    return range_problems(op, i, np.zeros(len(op.names)))[0]


INTERVAL_RTOL = 1e-6
"""Relative tolerance of an interval's ends (the package's acceptance level, ``ACCEPT``):
LP ends of ``c'x`` that cross by less than this times :func:`interval_slack`'s scale are
one value."""


def interval_slack(op: Operator, i: int, c: np.ndarray) -> float:
    """How far two LP ends of ``c'x`` may cross and still be one value: the tolerance
    scaled to the problem, ``INTERVAL_RTOL * ||c||_1 * max(|b|_inf, |x_ln|_inf)`` with
    ``x_ln`` the least-norm forces (N, N m), so it follows the loads' own size.
    """
    A, b = equalities(op, i)
    x = np.linalg.lstsq(A, b, rcond=None)[0]
    scale = max(float(np.abs(b).max(initial=0.0)), float(np.abs(x).max(initial=0.0)), 1e-300)
    return INTERVAL_RTOL * float(np.abs(c).sum()) * scale
