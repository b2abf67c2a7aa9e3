"""Backend ``clarabel``: Clarabel's own Python API on a :class:`Conic` (LS, QP, LP converted).

Clarabel wants the upper triangle of ``P`` and ``A`` as CSC matrices and the cones as
objects in row order. Only ``verbose`` is changed from Clarabel's defaults (to keep
output quiet); numerical settings change only when ``tol`` or ``options`` are given.

A formulation has one structure at every instant, so the adapter keeps the solver of
each structure and hands the next instant's numbers to Clarabel's ``update`` (the same
answers as a new solver, without its symbolic setup).
"""

from __future__ import annotations

import time

import numpy as np
from cardan_forces.formulations.problems import Conic

from . import settings
from .record import Outcome
from .registry import Backend

EXTRAS: dict[str, str | None] = {"clarabel": None}

TOLERANCES = ("tol_gap_abs", "tol_gap_rel", "tol_feas")
"""Clarabel's settings a requested tolerance sets."""

STATUS = {
    "Solved": "solved",
    "AlmostSolved": "inaccurate",
    "MaxIterations": "inaccurate",
    "MaxTime": "inaccurate",
    "InsufficientProgress": "inaccurate",
    "PrimalInfeasible": "infeasible",
    "AlmostPrimalInfeasible": "infeasible",
    "DualInfeasible": "unbounded",
    "AlmostDualInfeasible": "unbounded",
}
"""Clarabel status name -> ours; anything else (NumericalError, Unsolved, ...) is failed."""


def _cones(clarabel, problem: Conic) -> list:
    make = {
        "zero": lambda size: clarabel.ZeroConeT(int(size)),
        "nonneg": lambda size: clarabel.NonnegativeConeT(int(size)),
        "soc": lambda size: clarabel.SecondOrderConeT(int(size)),
        "pow": lambda alpha: clarabel.PowerConeT(float(alpha)),
    }
    return [make[kind](size) for kind, size in problem.cones]


CACHE_SIZE = 16
"""Compiled solvers kept, one per structure (sizes, cones, settings)."""

_SOLVERS: dict[tuple, tuple] = {}


def _values(dense: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """The entries of ``dense`` at ``mask`` in CSC (column-major) order."""
    return dense.T[mask.T]


def _csc(dense: np.ndarray, mask: np.ndarray):
    import scipy.sparse as spa

    cols, rows = np.nonzero(mask.T)
    return spa.csc_matrix((dense[rows, cols], (rows, cols)), shape=dense.shape)


def _solver(clarabel, problem: Conic, P: np.ndarray, A: np.ndarray, opts, key: tuple):
    """A Clarabel solver holding this problem's data: the cached one of the same
    structure updated with the new numbers (Clarabel's ``update``: no new symbolic
    factorization) when its sparsity covers this problem's, else a new one on the union
    of both sparsities (an explicit zero keeps a place that another instant fills).
    """
    mask_P, mask_A = np.triu(P) != 0, A != 0
    cached = _SOLVERS.get(key)
    if cached is not None:
        solver, old_P, old_A = cached
        if not (np.any(mask_P & ~old_P) or np.any(mask_A & ~old_A)):
            solver.update(P=_values(P, old_P), q=problem.q, A=_values(A, old_A), b=problem.b)
            return solver
        mask_P, mask_A = mask_P | old_P, mask_A | old_A
    solver = clarabel.DefaultSolver(_csc(P, mask_P), np.asarray(problem.q, float),
                                    _csc(A, mask_A), np.asarray(problem.b, float),
                                    _cones(clarabel, problem), opts)
    if CACHE_SIZE < 1 or not solver.is_data_update_allowed():
        return solver
    while len(_SOLVERS) >= CACHE_SIZE:
        _SOLVERS.pop(next(iter(_SOLVERS)))
    _SOLVERS[key] = (solver, mask_P, mask_A)
    return solver


def solve_conic(problem: Conic, tol=None, initvals=None, **options) -> Outcome:
    """Solve ``min 1/2 z'Pz + q'z s.t. A z + s = b, s in K`` (no warm start in Clarabel).

    ``setup_s`` is the package's side (dense data to Clarabel's settings and
    matrices); ``solve_s`` Clarabel's (its setup or data update, and the solve).
    """
    import clarabel

    start = time.perf_counter()
    n = problem.n
    P = np.zeros((n, n)) if problem.P is None else np.asarray(problem.P, float)
    A = np.asarray(problem.A, float)
    opts = clarabel.DefaultSettings()
    opts.verbose = False
    chosen = settings.options_for(TOLERANCES, tol) | options
    for key, value in chosen.items():
        setattr(opts, key, value)
    key = (n, A.shape[0], problem.cones, tuple(sorted(chosen.items())))
    setup_done = time.perf_counter()
    solver = _solver(clarabel, problem, P, A, opts, key)
    sol = solver.solve()
    status_name = str(sol.status)
    return Outcome(STATUS.get(status_name, "failed"), np.asarray(sol.x),
                   iterations=int(sol.iterations),
                   message="" if status_name == "Solved" else f"Clarabel status {status_name}",
                   objective=sol.obj_val, setup_s=setup_done - start,
                   solve_s=time.perf_counter() - setup_done, duals=np.asarray(sol.z))


def backends() -> list[Backend]:
    """The Clarabel backend, if Clarabel is installed."""
    try:
        import clarabel  # noqa: F401
    except ImportError:
        return []
    return [Backend("clarabel", (Conic,), solve_conic, ("clarabel",), None, "clarabel",
                    tolerances=TOLERANCES)]
