"""Backend ``clarabel``: Clarabel's own Python API on a :class:`Conic` (LS, QP, LP converted).

Clarabel wants the upper triangle of ``P`` and ``A`` as CSC matrices and the cones as
objects in row order. Only ``verbose`` is changed from Clarabel's defaults (to keep
output quiet); numerical settings change only when ``tol`` or ``options`` are given.
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


def solve_conic(problem: Conic, tol=None, initvals=None, **options) -> Outcome:
    """Solve ``min 1/2 z'Pz + q'z s.t. A z + s = b, s in K`` (no warm start in Clarabel)."""
    import clarabel
    import scipy.sparse as spa

    start = time.perf_counter()
    n = problem.n
    P = np.zeros((n, n)) if problem.P is None else np.asarray(problem.P, float)
    P_upper = spa.triu(spa.csc_matrix(P), format="csc")
    A = spa.csc_matrix(np.asarray(problem.A, float))
    opts = clarabel.DefaultSettings()
    opts.verbose = False
    for key, value in (settings.options_for(TOLERANCES, tol) | options).items():
        setattr(opts, key, value)
    solver = clarabel.DefaultSolver(P_upper, np.asarray(problem.q, float), A,
                                    np.asarray(problem.b, float), _cones(clarabel, problem), opts)
    setup_done = time.perf_counter()
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
