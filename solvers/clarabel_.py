"""Backend ``clarabel``: Clarabel's own Python API on a :class:`Conic` (LS, QP, LP converted).

Clarabel wants the upper triangle of ``P`` and ``A`` as CSC matrices and the cones as
objects in row order. Only ``verbose`` is changed from Clarabel's defaults (to keep
output quiet); numerical settings change only when ``tol`` or ``options`` are given.

Every solve builds a new solver from this problem's own data. Clarabel's ``update``
(new numbers in a solver built for another instant) would skip the symbolic setup, but
it scales the new numbers by the equilibration computed from the first instant's, so
the answer, the iterations and even the status (``AlmostSolved`` or ``Solved``) would
depend on which instant was solved before. A new solver per instant costs its
symbolic setup: 1.1-1.4 times the solver time of an update and solve on the propshaft's
conic formulations (one run).
"""

from __future__ import annotations

import time

import numpy as np
from cardan_forces.formulations.problems import Conic

from . import settings
from .record import Outcome
from .registry import Backend
from .settings_profiles import Profile

EXTRAS: dict[str, str | None] = {"clarabel": None}

TOLERANCES = ("tol_gap_abs", "tol_gap_rel", "tol_feas")
"""Clarabel's settings a requested tolerance sets."""

PROFILE = Profile("clarabel", ("tol_feas", "tol_gap_abs"), ("tol_gap_rel",))
"""How Clarabel takes qpbenchmark's four settings (qpbenchmark 2.7's for ``clarabel``)."""

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


def _csc(dense: np.ndarray):
    """``dense`` as a CSC matrix of its nonzeros."""
    import scipy.sparse as spa

    return spa.csc_matrix(dense)


def solve_conic(problem: Conic, tol=None, initvals=None, **options) -> Outcome:
    """Solve ``min 1/2 z'Pz + q'z s.t. A z + s = b, s in K`` (no warm start in Clarabel).

    ``setup_s`` is the package's side (dense data to Clarabel's settings and
    matrices); ``solve_s`` Clarabel's (its setup and the solve).
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
    data = (_csc(np.triu(P)), np.asarray(problem.q, float), _csc(A),
            np.asarray(problem.b, float), _cones(clarabel, problem))
    setup_done = time.perf_counter()
    sol = clarabel.DefaultSolver(*data, opts).solve()
    status_name = str(sol.status)
    return Outcome(STATUS.get(status_name, "failed"), np.asarray(sol.x),
                   iterations=int(sol.iterations),
                   message="" if status_name == "Solved" else f"Clarabel status {status_name}",
                   objective=sol.obj_val, setup_s=setup_done - start,
                   solve_s=time.perf_counter() - setup_done, y=np.asarray(sol.z))


def backends() -> list[Backend]:
    """The Clarabel backend, if Clarabel is installed."""
    try:
        import clarabel  # noqa: F401
    except ImportError:
        return []
    return [Backend(name="clarabel", family="clarabel", distributions=("clarabel",),
                    accepts=(Conic,), solve=solve_conic, tolerances=TOLERANCES,
                    qpbenchmark=PROFILE)]
