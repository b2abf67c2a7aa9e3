"""Backend ``qoco``: QOCO (an interior-point solver for second-order cone programs with a
quadratic objective) on a :class:`Conic` without power cones (LS, QP, LP converted).

QOCO's form is ``min 1/2 x'Px + c'x s.t. A x = b, G x <=_C h`` with
``C = R+^l x SOC(q_1) x ...``: the package's zero-cone rows are ``A``, the others ``G``
(nonnegative rows first, then the second-order blocks, each apex first as in the
package's form), so the rows are permuted into that order and the multipliers permuted
back. Its stationarity is ``P x + c + A'y + G'z = 0``, Clarabel's sign convention.

Every solve builds a new solver from this problem's own data (as ``clarabel`` does):
QOCO equilibrates the data it is built with, so reusing a solver across instants would
make an answer depend on which instant came first. Only ``verbose`` is set; numerical
settings change only when ``tol`` or ``options`` are given. Optional extra ``qoco``.
"""

from __future__ import annotations

import time

import numpy as np
from cardan_forces.formulations.batch import ConicBatch
from cardan_forces.formulations.problems import Conic

from . import settings
from .backend import Backend
from .qoco_form import CLAIM_TOL, csc_ones, layout, supports
from .record import BatchOutcome, Outcome, Status

EXTRAS: dict[str, str | None] = {"qoco": "qoco", "qoco-batched": "qoco", "qoco-reduced": "qoco",
                                 "qoco-batched-reduced": "qoco"}

STATUS = {"QOCO_SOLVED": Status.SOLVED, "QOCO_SOLVED_INACCURATE": Status.INACCURATE,
          "QOCO_MAX_ITER": Status.INACCURATE}
"""QOCO status -> ours; anything else (numerical error, unsolved) is failed."""

def _status(sol) -> Status:
    if sol.status == "QOCO_SOLVED" and max(sol.dres, sol.gap) > CLAIM_TOL:
        return Status.INACCURATE
    return STATUS.get(sol.status, Status.FAILED)


def solve_conic(problem: Conic, tol=None, initvals=None, **options) -> Outcome:
    """Solve the conic problem with a new QOCO solver (QOCO has no warm start).

    ``setup_s`` is the package's side (row layout, CSC matrices); ``solve_s`` QOCO's
    (its setup, equilibration and symbolic factorization, and the solve).
    """
    import qoco
    import scipy.sparse as spa

    start = time.perf_counter()
    n = problem.n
    A, b = np.asarray(problem.A, float), np.asarray(problem.b, float)
    eq, cone, nonneg, sizes = layout(problem.cones)
    P = None if problem.P is None else spa.csc_matrix(np.triu(np.asarray(problem.P, float)))
    parts = [spa.csc_matrix(A[rows]) if len(rows) else None for rows in (eq, cone)]
    chosen = {"verbose": 0} | settings.solver_options("qoco", tol) | options
    setup_done = time.perf_counter()
    solver = qoco.QOCO()
    solver.setup(n, len(cone), len(eq), P, np.asarray(problem.q, float), parts[0],
                 b[eq] if len(eq) else None, parts[1], b[cone] if len(cone) else None,
                 nonneg, len(sizes), np.array(sizes, np.int32), **chosen)
    sol = solver.solve()
    solved = time.perf_counter()
    y = np.empty(len(b))
    y[eq], y[cone] = np.asarray(sol.y), np.asarray(sol.z)
    status = _status(sol)
    return Outcome(status, np.asarray(sol.x, float).copy(), iterations=int(sol.iters),
                   message="" if status is Status.SOLVED else
                   f"QOCO status {sol.status} (dual residual {sol.dres:.1e}, gap {sol.gap:.1e})",
                   objective=float(sol.obj), setup_s=setup_done - start,
                   solve_s=solved - setup_done, y=y)


def solve_batch(batch: ConicBatch, tol=None, **options) -> BatchOutcome:
    """Every instant of the batch with one QOCO solver built for the batch's structure
    (the union sparsity of its instants); each instant's numbers replace the last ones.

    The answer does not depend on the order: QOCO starts every solve from its own
    initial point, and its default settings do no equilibration (``ruiz_iters`` 0), so
    nothing of an earlier instant remains. ``stages``: ``setup`` (structure, the solver
    and its symbolic factorization, once) and ``solve`` (updates and solves).
    """
    import qoco

    start = time.perf_counter()
    T, m, n = batch.A.shape
    eq, cone, nonneg, sizes = layout(batch.cones)
    P = np.zeros((n, n)) if batch.P is None else np.asarray(batch.P, float)
    P = np.triu(np.broadcast_to(P, (T, n, n)))
    parts = [csc_ones(np.any(M != 0, axis=0))  # the union of the instants' nonzeros
             for M in (P, batch.A[:, eq], batch.A[:, cone])]
    solver = qoco.QOCO()
    chosen = {"verbose": 0} | settings.solver_options("qoco", tol) | options
    b = np.asarray(batch.b, float)
    solver.setup(n, len(cone), len(eq), parts[0][0], np.zeros(n),
                 parts[1][0] if len(eq) else None, np.zeros(len(eq)) if len(eq) else None,
                 parts[2][0] if len(cone) else None, np.zeros(len(cone)) if len(cone) else None,
                 nonneg, len(sizes), np.array(sizes, np.int32), **chosen)
    values = [M[:, r, c] for M, (_, r, c) in zip((P, batch.A[:, eq], batch.A[:, cone]), parts)]
    built = time.perf_counter()
    z, y = np.zeros((T, n)), np.zeros((T, m))
    status, iterations, messages = np.empty(T, object), np.zeros(T, int), []
    for k in range(T):
        solver.update_matrix_data(*(v[k] if v.shape[1] else None for v in values))
        solver.update_vector_data(batch.q[k], b[k, eq] if len(eq) else None,
                                  b[k, cone] if len(cone) else None)
        sol = solver.solve()
        z[k], y[k, eq], y[k, cone] = sol.x, sol.y, sol.z
        status[k], iterations[k] = _status(sol), sol.iters
        messages.append("" if status[k] == Status.SOLVED else f"QOCO status {sol.status}")
    solved = time.perf_counter()
    return BatchOutcome(status=status, z=z, y=y, iterations=iterations, setup_s=0.0,
                        solve_s=solved - start, messages=tuple(messages),
                        stages={"setup": built - start, "solve": solved - built})


def backends() -> list[Backend]:
    """The QOCO backends (per instant, and over a batch), if QOCO is installed."""
    try:
        import qoco  # noqa: F401
    except ImportError:
        return []
    common = dict(family="qoco", distributions=("qoco",), extra="qoco", supports=supports,
                  tolerances=settings.TOLERANCES["qoco"], reducible=True)
    return [Backend(name="qoco", accepts=(Conic,), solve=solve_conic, **common),
            Backend(name="qoco-batched", batch=solve_batch, batch_accepts=(ConicBatch,),
                    **common)]
