"""Backend ``moreau``: moreau's ``CompiledSolver`` on a formulation's conic batch.

moreau (Clarabel's interior-point algorithm for batches) compiles one structure — the
sparsity of ``P`` and ``A`` and the cones — and solves every instant with its own
numbers. Two layout facts of its API decide whether a batch is solved right:

- ``moreau.Cones`` gives the cones by count (zero, nonnegative, second-order sizes,
  power ``alpha``s), so the rows of ``A`` must come grouped in that order. The
  package's conic form interleaves the blocks (``compliance_hertz``: a second-order
  cone then a power cone per contact); passed as they are, moreau reads the wrong rows
  as power cones and reports ``PrimalInfeasible``. Here the rows are permuted into
  moreau's order and the multipliers permuted back.
- ``P`` is given as the full symmetric matrix (not its upper triangle as in Clarabel);
  the sparsity is the union of the nonzeros over all instants, so an entry that is
  zero at one instant stays in the structure.

The power cone is the same in both (``x^a y^(1-a) >= |z|``, ``x, y >= 0``). The
compiled solver of a structure is kept and reused: a later batch of the same structure
pays only for its numbers (``setup``) and the solve.
Optional extra ``moreau``; absent when moreau is not installed.
"""

from __future__ import annotations

import dataclasses
import time
import warnings

import numpy as np
from cardan_forces.formulations.batch import ConicBatch

from . import settings
from .backend import Backend
from .record import BatchOutcome, Status

EXTRAS: dict[str, str | None] = {"moreau": "moreau", "moreau-warm": "moreau",
                                 "moreau-reduced": "moreau", "moreau-warm-reduced": "moreau"}

UNSCALED = ("pow",)
"""The cone kinds on which the reduced variants run without equilibration: on power
cones moreau's Ruiz scaling costs iterations, on second-order cones it keeps every
instant solved (the measurements: CHANGELOG)."""

ORDER = ("zero", "nonneg", "soc", "pow")
"""The row order ``moreau.Cones`` implies."""

STATUS = {
    "Solved": Status.SOLVED, "AlmostSolved": Status.INACCURATE,
    "MaxIterations": Status.INACCURATE, "MaxTime": Status.INACCURATE,
    "InsufficientProgress": Status.INACCURATE, "PrimalInfeasible": Status.INFEASIBLE,
    "AlmostPrimalInfeasible": Status.INFEASIBLE, "DualInfeasible": Status.UNBOUNDED,
    "AlmostDualInfeasible": Status.UNBOUNDED,
}
"""moreau status name -> ours; anything else is failed."""


def grouped_rows(cones) -> tuple[np.ndarray, object]:
    """The row permutation that groups the cone blocks in :data:`ORDER` (stable within a
    kind) and the matching ``moreau.Cones``.
    """
    import moreau

    rows = {kind: [] for kind in ORDER}
    start = 0
    for kind, size in cones:
        count = 3 if kind == "pow" else int(size)
        rows[kind].append((np.arange(start, start + count), size))
        start += count
    order = np.concatenate([r for kind in ORDER for r, _ in rows[kind]] or [np.zeros(0, int)])
    spec = moreau.Cones(
        num_zero_cones=sum(len(r) for r, _ in rows["zero"]),
        num_nonneg_cones=sum(len(r) for r, _ in rows["nonneg"]),
        so_cone_dims=[len(r) for r, _ in rows["soc"]],
        power_alphas=[float(size) for _, size in rows["pow"]])
    return order.astype(int), spec


def _pattern(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """CSR structure of a (r, c) mask of nonzeros, and its (row, col)."""
    rows, cols = np.nonzero(mask)
    offsets = np.concatenate([[0], np.cumsum(mask.sum(axis=1))])
    return offsets, cols, rows, cols


def _settings(tol, batch_size: int, options: dict):
    """The settings of moreau: ``options`` named as a field of ``moreau.IPMSettings`` (e.g.
    ``equilibrate_enable``) go to the interior-point settings, the others to
    ``moreau.Settings``.
    """
    import moreau

    fields = moreau.IPMSettings.model_fields
    ipm = {k: v for k, v in options.items() if k in fields}
    ipm |= settings.solver_options("moreau", tol)
    return moreau.Settings(device="cpu", batch_size=batch_size,
                           **({"ipm_settings": moreau.IPMSettings(**ipm)} if ipm else {}),
                           **{k: v for k, v in options.items() if k not in fields})


CACHE_SIZE = 8
"""Compiled solvers kept, one per structure (sizes, sparsity, cones, batch size, tol)."""

_COMPILED: dict[tuple, object] = {}


def _compiled(n, m, patterns, cones, T, tol, options):
    """The compiled solver of this structure: built once, then reused (only the numbers
    change between calls: ``setup`` and ``solve``).
    """
    import moreau

    (p_off, p_col), (a_off, a_col) = patterns
    key = (n, m, p_off.tobytes(), p_col.tobytes(), a_off.tobytes(), a_col.tobytes(),
           repr(cones), T, tol, tuple(sorted(options.items())))
    solver = _COMPILED.get(key)
    if solver is None:
        solver = moreau.CompiledSolver(n=n, m=m, P_row_offsets=p_off, P_col_indices=p_col,
                                       A_row_offsets=a_off, A_col_indices=a_col, cones=cones,
                                       settings=_settings(tol, T, options))
        if CACHE_SIZE > 0:
            while len(_COMPILED) >= CACHE_SIZE:
                _COMPILED.pop(next(iter(_COMPILED)))
            _COMPILED[key] = solver
    return solver


def solve_batch(batch: ConicBatch, tol=None, **options) -> BatchOutcome:
    """Every instant of the batch with one compiled structure (compiled on the first
    call for a structure, reused after).
    """
    return _solve(batch, tol, options)[0]


def solve_batch_warm(batch: ConicBatch, tol=None, **options) -> BatchOutcome:
    """The even instants cold, then each odd instant warm-started from the even instant
    before it (moreau's ``BatchedWarmStart``: its primal, dual and slack, which moreau
    smooths towards the central path and retries cold if the warm solve fails). An
    answer depends only on its own data and its neighbour's, never on the batches
    solved before; the stages add up both halves.
    """
    import moreau

    T = len(batch.instants)
    even, odd = np.arange(0, T, 2), np.arange(1, T, 2)
    first, sol = _solve(_subset(batch, even), tol, options)
    if not len(odd):
        return first
    start = moreau.BatchedWarmStart(x=np.asarray(sol.x)[odd // 2],
                                    z=np.asarray(sol.z)[odd // 2],
                                    s=np.asarray(sol.s)[odd // 2])
    second, _ = _solve(_subset(batch, odd), tol, options, start)
    merged = {}
    for name in ("status", "z", "y", "iterations"):
        parts = (getattr(first, name), getattr(second, name))
        merged[name] = np.empty((T, *np.shape(parts[0])[1:]), np.asarray(parts[0]).dtype)
        merged[name][even], merged[name][odd] = parts
    messages = np.empty(T, object)
    messages[even], messages[odd] = first.messages, second.messages
    stages = {k: first.stages[k] + second.stages[k] for k in first.stages}
    return BatchOutcome(**merged, setup_s=first.setup_s + second.setup_s,
                        solve_s=first.solve_s + second.solve_s, stages=stages,
                        messages=tuple(messages))


def _subset(batch: ConicBatch, rows: np.ndarray) -> ConicBatch:
    """The batch at ``rows`` (its numbers only: what the solver reads)."""
    P = batch.P[rows] if np.ndim(batch.P) == 3 else batch.P
    return dataclasses.replace(batch, instants=batch.instants[rows], P=P, q=batch.q[rows],
                               A=batch.A[rows], b=batch.b[rows], problems=(), null_space=None)


def _solve(batch: ConicBatch, tol, options, warm=None):
    """:func:`solve_batch`'s outcome and moreau's raw solution, ``warm`` its start."""
    start = time.perf_counter()
    T, m, n = batch.A.shape
    order, cones = grouped_rows(batch.cones)
    A = np.asarray(batch.A, float)
    P = (np.zeros((n, n)) if batch.P is None else np.asarray(batch.P, float))
    P = P if P.ndim == 3 else P[None]
    p_off, p_col, p_r, p_c = _pattern(np.any(P != 0, axis=0))
    a_off, a_col, a_r, a_c = _pattern(np.any(A != 0, axis=0)[order])
    # entries by np.take on the flattened rows: C-ordered (T, k), where a fancy index
    # (A[:, order][:, rows, cols]) comes out ordered by entry and must be reordered
    A_values = np.take(A.reshape(T, -1), order[a_r] * n + a_c, axis=1)
    b = np.take(batch.b, order, axis=1)
    converted = time.perf_counter()
    solver = _compiled(n, m, ((p_off, p_col), (a_off, a_col)), cones, T, tol, options)
    compiled = time.perf_counter()
    # per-instant values for both (moreau 0.4.1 mishandles a shared P with per-instant A)
    P_values = np.take(P.reshape(len(P), -1), p_r * n + p_c, axis=1)
    P_values = np.ascontiguousarray(np.broadcast_to(P_values, (T, len(p_r))))
    solver.setup(P_values, A_values)
    setup_done = time.perf_counter()
    with warnings.catch_warnings():  # moreau re-solves those instants cold itself, and
        # says so with every index on stderr; the records judge the answers as any other
        warnings.filterwarnings("ignore", message="Warm-started solve failed")
        sol = solver.solve(batch.q, b, warm_start=warm)
    solve_s = time.perf_counter() - setup_done
    names = [s.name for s in solver.info.status]
    duals = np.empty((T, m))
    duals[:, order] = np.asarray(sol.z)
    iterations = np.broadcast_to(np.asarray(solver.info.iterations), (T,)).astype(int)
    messages = tuple("" if s == "Solved" else f"moreau status {s}" for s in names)
    # the package's share is the row layout; compiling, setup and solve are moreau's
    outcome = BatchOutcome(
        status=np.array([STATUS.get(s, Status.FAILED) for s in names], object),
        z=np.asarray(sol.x), y=duals, iterations=iterations, setup_s=converted - start,
        solve_s=time.perf_counter() - converted,
        stages={"layout": converted - start, "compile": compiled - converted,
                "setup": setup_done - compiled, "solve": solve_s}, messages=messages)
    return outcome, sol


def backends() -> list[Backend]:
    """The moreau backends (cold, and warm-started from the neighbouring instant), if
    moreau is installed.
    """
    try:
        import moreau  # noqa: F401
    except ImportError:
        return []
    common = dict(family="moreau", distributions=("moreau",), extra="moreau",
                  tolerances=settings.TOLERANCES["moreau"], batch_accepts=(ConicBatch,),
                  reducible=True, unscaled=UNSCALED)
    return [Backend(name="moreau", batch=solve_batch, **common),
            Backend(name="moreau-warm", batch=solve_batch_warm, **common)]
