"""Backend ``clarabel``: Clarabel's own Python API on a :class:`Conic` (LS, QP, LP converted).

Clarabel wants the upper triangle of ``P`` and ``A`` as CSC matrices and the cones as
objects in row order. Only ``verbose`` is changed from Clarabel's defaults (to keep
output quiet); numerical settings change only when ``tol`` or ``options`` are given.

Every solve builds a new solver from this problem's own data. Clarabel's ``update``
(new numbers in a solver built for another instant) would skip the symbolic setup, but
it scales the new numbers by the equilibration computed from the first instant's, so
the answer, the iterations and even the status (``AlmostSolved`` or ``Solved``) would
depend on which instant was solved before. A new solver per instant costs its
symbolic setup, a modest share of the solver's time on the conic formulations.
"""

from __future__ import annotations

import functools
import time
from typing import NamedTuple

import numpy as np
from cardan_forces.formulations.problems import Conic

from . import settings
from .backend import Backend
from .record import Outcome, Status

EXTRAS: dict[str, str | None] = {"clarabel": None, "clarabel-reduced": None}

UNSCALED = ("soc", "pow")
"""The cone kinds on which ``clarabel-reduced`` runs without equilibration. The reduced
data are the formulation's (in units of the load) seen through an orthonormal basis,
already balanced: on them Clarabel's Ruiz scaling costs iterations and accuracy where
there are second-order or power cones, and saves inaccurate instants where the cones
are linear alone (the measurements: CHANGELOG)."""


STATUS = {
    "Solved": Status.SOLVED,
    "AlmostSolved": Status.INACCURATE,
    "MaxIterations": Status.INACCURATE,
    "MaxTime": Status.INACCURATE,
    "InsufficientProgress": Status.INACCURATE,
    "PrimalInfeasible": Status.INFEASIBLE,
    "AlmostPrimalInfeasible": Status.INFEASIBLE,
    "DualInfeasible": Status.UNBOUNDED,
    "AlmostDualInfeasible": Status.UNBOUNDED,
}
"""Clarabel status name -> ours; anything else (NumericalError, Unsolved, ...) is failed."""


@functools.lru_cache(maxsize=64)
def _cones(cones: tuple) -> tuple:
    """Clarabel's cone objects of a cone list, made once per list (a solver reads them
    into its own; each gets its own list of them).
    """
    import clarabel

    make = {
        "zero": lambda size: clarabel.ZeroConeT(int(size)),
        "nonneg": lambda size: clarabel.NonnegativeConeT(int(size)),
        "soc": lambda size: clarabel.SecondOrderConeT(int(size)),
        "pow": lambda alpha: clarabel.PowerConeT(float(alpha)),
    }
    return tuple(make[kind](size) for kind, size in cones)


class Csc(NamedTuple):
    """A CSC matrix as Clarabel reads one: by these attributes (scipy's ``csc_matrix``
    has them too). Made from a dense matrix directly, without scipy's constructor,
    which checks its input again at a cost that shows in a ``socp_face`` instant.
    """

    data: np.ndarray
    indices: np.ndarray
    indptr: np.ndarray
    nnz: int
    shape: tuple[int, int]
    has_canonical_format: bool = True  # sorted row indices, no duplicates


def _csc(dense: np.ndarray) -> Csc:
    """``dense`` as a CSC matrix of its nonzeros."""
    columns = dense.T
    nonzero = columns != 0
    indptr = np.concatenate(([0], np.cumsum(nonzero.sum(axis=1))))
    return Csc(columns[nonzero], np.nonzero(nonzero)[1], indptr, int(indptr[-1]),
               dense.shape)


def _scipy(matrix: Csc):
    """The same matrix as scipy's ``csc_matrix`` (for a Clarabel that refuses others)."""
    import scipy.sparse as spa

    return spa.csc_matrix((matrix.data, matrix.indices, matrix.indptr), shape=matrix.shape)


@functools.cache
def _takes_light(clarabel) -> bool:
    """Whether this Clarabel takes a :class:`Csc` (asked once, on a 1 x 1 problem)."""
    one = _csc(np.ones((1, 1)))
    settings_ = clarabel.DefaultSettings()
    settings_.verbose = False
    try:
        clarabel.DefaultSolver(one, np.zeros(1), one, np.zeros(1),
                               [clarabel.NonnegativeConeT(1)], settings_)
    except (TypeError, AttributeError):
        return False
    return True


def _solver(clarabel, P: Csc, q, A: Csc, b, cones, opts):
    """Clarabel's solver of these data; scipy's matrices where Clarabel asks for them."""
    if not _takes_light(clarabel):
        P, A = _scipy(P), _scipy(A)
    return clarabel.DefaultSolver(P, q, A, b, cones, opts)


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
    chosen = settings.solver_options("clarabel", tol) | options
    for key, value in chosen.items():
        setattr(opts, key, value)
    data = (_csc(np.triu(P)), np.asarray(problem.q, float), _csc(A),
            np.asarray(problem.b, float), list(_cones(tuple(problem.cones))))
    setup_done = time.perf_counter()
    sol = _solver(clarabel, *data, opts).solve()
    status_name = str(sol.status)
    return Outcome(STATUS.get(status_name, Status.FAILED), np.asarray(sol.x),
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
                    accepts=(Conic,), solve=solve_conic,
                    tolerances=settings.TOLERANCES["clarabel"],
                    qpbenchmark=settings.PROFILES["clarabel"], reducible=True, unscaled=UNSCALED)]
