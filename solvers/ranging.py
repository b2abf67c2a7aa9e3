"""LP ranging: the least and the greatest of several linear forms over one polyhedron.

An interval of the rigid solution set (DESIGN §2, "Solution sets") is two LPs per
force component over the same feasible set ``{A x = b, G x <= h, lb <= x <= ub}``;
only the objective changes between them. HiGHS's simplex kept warm does exactly
that: the model is passed once, a feasible basis found once (the objective 0), and
each bound is the previous optimal basis re-optimised for a new cost vector
(``changeColsCost``, then ``run``): a few pivots instead of a cold solve, and no
record built per LP.

Each answer is judged here, not trusted: an optimum whose primal residuals exceed
:data:`~cardan_forces.solvers.record.ACCEPT` (relative to the problem's scale) is
``failed``, so that the caller solves that bound again cold through the registry
(:func:`~cardan_forces.solvers.registry.solve`). ``highspy`` is a core dependency
(SciPy's bundled HiGHS, presolving an LP with a zero objective, returned a point 4e4 N
off ``A x = b`` on a frictionless slip joint line and called it optimal); an install
without it has :data:`HAVE_HIGHSPY` False and solves every bound cold.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse
from cardan_forces.formulations.problems import LP

from .record import ACCEPT, Status

try:
    import highspy
except ImportError:  # the optional extra ``highs``
    highspy = None

HAVE_HIGHSPY = highspy is not None
"""Whether the warm-started ranging is available (the ``highs`` extra)."""


@dataclass(frozen=True)
class Ranges:
    """``feasible``: the status of the feasibility solve (objective 0); per objective
    row ``k``: ``low[k]``/``high[k]`` the least/greatest value (NaN where that side has
    none) and ``statuses[k]`` = (status of the min, status of the max).
    """

    feasible: Status
    low: np.ndarray
    high: np.ndarray
    statuses: tuple[tuple[Status, Status], ...]


_STATUS = {} if highspy is None else {
    highspy.HighsModelStatus.kOptimal: Status.SOLVED,
    highspy.HighsModelStatus.kUnbounded: Status.UNBOUNDED,
    highspy.HighsModelStatus.kInfeasible: Status.INFEASIBLE,
}
"""HiGHS model statuses this module believes; any other is ``failed``."""


def ranges(lp: LP, objectives: np.ndarray) -> Ranges:
    """Min and max of ``objectives[k] @ z`` over ``lp``'s feasible set (``lp.c`` unused).

    ``objectives``: ``(k, n)``. When the set is empty (or the feasibility solve
    fails) every row is NaN with that status. Needs :data:`HAVE_HIGHSPY`.
    """
    objectives = np.atleast_2d(np.asarray(objectives, float))
    k, n = objectives.shape
    h = _model(lp)
    feasible = _run(h, lp, np.zeros(n))[0]
    low, high = np.full(k, np.nan), np.full(k, np.nan)
    if feasible is not Status.SOLVED:
        return Ranges(feasible, low, high, ((feasible, feasible),) * k)
    statuses = []
    for r, c in enumerate(objectives):
        lo_status, low[r] = _run(h, lp, c)
        hi_status, neg = _run(h, lp, -c)
        high[r] = -neg
        statuses.append((lo_status, hi_status))
    return Ranges(feasible, low, high, tuple(statuses))


def _model(lp: LP):
    """A quiet HiGHS instance holding ``lp``'s constraints (rows: ``A`` equal to ``b``,
    then ``G`` at most ``h``), simplex without presolve so that it tells an unbounded
    objective from an empty set and keeps its basis between runs.
    """
    n = lp.n
    A = np.zeros((0, n)) if lp.A is None else np.asarray(lp.A, float)
    G = np.zeros((0, n)) if lp.G is None else np.asarray(lp.G, float)
    b = np.zeros(0) if lp.b is None else np.asarray(lp.b, float)
    g = np.zeros(0) if lp.h is None else np.asarray(lp.h, float)
    M = np.vstack([A, G])
    model = highspy.HighsLp()
    model.num_col_, model.num_row_ = n, M.shape[0]
    model.col_cost_ = np.zeros(n)
    model.col_lower_ = _finite(np.full(n, -np.inf) if lp.lb is None else lp.lb)
    model.col_upper_ = _finite(np.full(n, np.inf) if lp.ub is None else lp.ub)
    model.row_lower_ = _finite(np.concatenate([b, np.full(len(g), -np.inf)]))
    model.row_upper_ = _finite(np.concatenate([b, g]))
    csc = scipy.sparse.csc_matrix(M)
    model.a_matrix_.format_ = highspy.MatrixFormat.kColwise
    model.a_matrix_.start_ = csc.indptr.astype(np.int32)
    model.a_matrix_.index_ = csc.indices.astype(np.int32)
    model.a_matrix_.value_ = csc.data.astype(float)
    h = highspy.Highs()
    for option, value in OPTIONS.items():
        h.setOptionValue(option, value)
    h.passModel(model)
    return h


OPTIONS = {"output_flag": False, "presolve": "off", "solver": "simplex",
           "simplex_strategy": 4, "threads": 1}
"""HiGHS options of the ranging: quiet; simplex without presolve (it tells an unbounded
objective from an empty set and keeps its basis between runs); primal simplex (a new
cost vector leaves the basis primal feasible); one thread (the LPs are small, and a
thread pool costs more than it saves on them)."""


def _finite(v) -> np.ndarray:
    """``v`` with infinities as HiGHS spells them."""
    return np.clip(np.asarray(v, float), -highspy.kHighsInf, highspy.kHighsInf)


def _run(h, lp: LP, c: np.ndarray) -> tuple[Status, float]:
    """Minimise ``c @ z`` from the basis ``h`` holds: (status, value; NaN unless
    solved). An optimum that does not satisfy the constraints within :data:`ACCEPT`
    of the problem's scale is ``failed``.
    """
    h.changeColsCost(len(c), np.arange(len(c), dtype=np.int32), c)
    if h.run() == highspy.HighsStatus.kError and h.getOptions().threads == 1:
        h.setOptionValue("threads", 0)  # HiGHS's threads already started, at its count
        h.run()
    status = _STATUS.get(h.getModelStatus(), Status.FAILED)
    if status is not Status.SOLVED:
        return status, np.nan
    z = np.asarray(h.getSolution().col_value, float)
    return (Status.SOLVED, float(c @ z)) if _feasible(lp, z) else (Status.FAILED, np.nan)


def _feasible(lp: LP, z: np.ndarray) -> bool:
    """Every constraint of ``lp`` holds at ``z`` within :data:`ACCEPT` times the scale
    ``max(|b|_inf, |z|_inf)`` (times each row's norm).
    """
    scale = max(float(np.abs(z).max(initial=0.0)),
                0.0 if lp.b is None else float(np.abs(lp.b).max(initial=0.0)), 1e-300)
    tol = ACCEPT * scale
    worst = []
    if lp.A is not None and len(lp.A):
        worst.append(np.abs(lp.A @ z - lp.b) / np.maximum(np.abs(lp.A).sum(1), 1e-300))
    if lp.G is not None and len(lp.G):
        worst.append((lp.G @ z - lp.h) / np.maximum(np.abs(lp.G).sum(1), 1e-300))
    if lp.lb is not None:
        worst.append(np.asarray(lp.lb, float) - z)
    if lp.ub is not None:
        worst.append(z - np.asarray(lp.ub, float))
    return all(float(np.max(w, initial=-np.inf)) <= tol for w in worst)
