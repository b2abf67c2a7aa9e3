"""Backend ``reduced-ipm``: the package's own interior point on the reduced cone programs,
every instant of a batch side by side (NumPy, :mod:`.reduced_ipm`).

A formulation's conic batch (``min_max``, ``socp_face``, ``friction`` and any other with
equality, nonnegative and second-order cones) is solved in the null space of its
equality rows: ``z = z0 + N y`` (:func:`~.conversions.eliminate_equalities`, with the
formulation's own orthonormal basis ``Conic.null_space`` where it gives one), the two-row
cones a nonnegative row makes linear folded (:func:`.reduced_.fold`), so the interior
point iterates on the 7-12 unknowns ``y`` of the built-in scenes with no equality rows;
its answers and multipliers are lifted back (:meth:`~.conversions.Reduced.lift`) and
judged by the package like every backend's.

Degenerate cases end in a fallback, never an exception, and each is said in the
instant's message:

- the equality rows change rank between instants (no common reduced structure): the
  instants are reduced in groups of one rank each;
- an instant the interior point stops short of ``tol`` (iteration limit, a stall,
  non-finite numbers: near the optimum the scaling of a second-order block on its
  boundary loses the precision the next steps need) ends at its best iterate; within
  :data:`.reduced_ipm.REDUCED` times ``tol`` it is "almost solved", reported
  inaccurate (the package's measures then decide, as for every backend);
- one farther from it, or with a primal infeasibility certificate, is solved again
  alone by Clarabel (a core dependency, :data:`FALLBACK`), whose status it then
  carries.

``tol`` is the interior point's relative tolerance (:data:`.reduced_ipm.TOL` by default).
The interior point runs compiled where numba is installed
(:mod:`._reduced_ipm_kernels`, runs of instants on numba's threads; ``compiled``
forces one form), else as its NumPy reference. ``warm`` (compiled only) starts each
instant from the one before it: on ``paper`` it cuts the iterations of ``min_max``
from 11.7 to 6.3 per instant and of ``socp_face`` from 7.1 to 5.5, but an answer then
depends on the instants before it in its run, so the backend starts cold unless asked.
Where the formulation gives its null-space basis (every built-in conic one) the
reduction and the lift run compiled too (:func:`reduced_problem`), the NumPy form the
reference the tests hold them to. The
backend then runs each instant's reduction, interior point and lift in one compiled
pass (:func:`._reduced_ipm_kernels.solve_full`, the same numbers), its ``ipm`` stage
holding all three: one parallel region, not three that each wait for the slower
thread (where other work shared the cores, a short region's end waited for a thread
the system had not yet run).
``stages``: ``reduce`` (elimination and folding), ``ipm``, ``lift`` and ``fallback``.
"""

from __future__ import annotations

import importlib
import time

import numpy as np
from cardan_forces.formulations.batch import ConicBatch

from cardan_forces.util.compiled import compiled_form

from . import reduced_ipm, settings
from .backend import Backend
from .conversions import RANK_RTOL, eliminate_equalities, zero_rows
from .record import BatchOutcome, Status
from .reduced_ import fold, matched
from .reduced_ import plan as fold_plan
from .registry import solve_unchecked

EXTRAS: dict[str, str | None] = {"reduced-ipm": None}

FALLBACK = "clarabel"
"""The backend that solves an instant alone where the interior point leaves it unsolved."""


def supports(batch: ConicBatch) -> bool:
    """Equality rows and second-order cones, with nonnegative rows at most (the least-norm
    family has ``numpy-batched``; a power cone needs another barrier).
    """
    kinds = {kind for kind, _ in batch.cones}
    return "zero" in kinds and "soc" in kinds and kinds <= {"zero", "nonneg", "soc"}


def _groups(batch: ConicBatch) -> list[np.ndarray | slice]:
    """The instants reduced together: all of them (a slice: the batch's arrays are then
    read in place, not copied), unless their equality rows change rank (then one group
    per rank, found from each instant's singular values).
    """
    if batch.null_space is not None:
        return [slice(None)]
    eq = np.array([k for kind, size in batch.cones if kind == "zero"
                   for k in range(int(size))])
    s = np.linalg.svd(batch.A[:, eq], compute_uv=False)
    ranks = np.sum(s > RANK_RTOL * s[:, :1], axis=1)
    if len(np.unique(ranks)) == 1:
        return [slice(None)]
    return [np.flatnonzero(ranks == r) for r in np.unique(ranks)]


def solve_reduced(P, q, G, h, cones, tol: float = reduced_ipm.TOL,
                  max_iter: int = reduced_ipm.MAX_ITER, compiled: bool | None = None,
                  warm: bool = False) -> reduced_ipm.Answer:
    """:func:`.reduced_ipm.solve`'s answer, compiled where numba is installed
    (:func:`._reduced_ipm_kernels.solve`; ``compiled``: force one form, ``True``
    without numba is an ``ImportError``). ``warm`` (compiled only) starts each instant
    from the one before it within runs of :data:`._reduced_ipm_kernels.RUN` instants.
    """
    kernels = _kernels(compiled)
    if kernels is None:
        if warm:
            raise ValueError("the NumPy reference takes no warm start")
        return reduced_ipm.solve(P, q, G, h, cones, tol=tol, max_iter=max_iter)
    x, z, s, iterations, code = kernels.solve(
        *(np.ascontiguousarray(a, float) for a in (P, q, G, h)),
        *_settings(kernels, cones, tol, max_iter), bool(warm))
    return reduced_ipm.Answer(x, z, s, iterations, code)


def _settings(kernels, cones, tol: float, max_iter: int):
    """The kernels' ``(Cones, Params)`` of (1)'s ``cones`` and the options."""
    lay = reduced_ipm.layout(tuple(cones))
    size = np.sum(lay.soc < lay.m, axis=1).astype(np.int64)
    rows = kernels.Cones(lay.nonneg, np.ascontiguousarray(lay.soc[:, 0]), size)
    params = kernels.Params(float(tol), int(max_iter), reduced_ipm.CENTRALITY,
                            reduced_ipm.BACKTRACKS, reduced_ipm.MIN_STEP,
                            reduced_ipm.STEP_FRACTION, reduced_ipm.REDUCED, kernels.REFINE,
                            kernels.REFINE_RTOL, kernels.WARM_MARGIN)
    return rows, params


def _kernels(compiled: bool | None):
    """The compiled kernels (:mod:`._reduced_ipm_kernels`), or None for the NumPy
    reference (``compiled`` as :func:`~cardan_forces.util.compiled.compiled_form` takes it).
    """
    return compiled_form(lambda: importlib.import_module(f"{__package__}._reduced_ipm_kernels"),
                         compiled)


def reduced_problem(batch: ConicBatch, rows: np.ndarray | slice,
                    compiled: bool | None = None):
    """The instants ``rows`` (indices or a slice) of the batch as problems (1) of
    :mod:`.reduced_ipm`: ``(lift, (P, q, G, h, cones))``, ``lift(x, z)`` the full
    problems' answers and multipliers ``(z, y)`` from (1)'s answers ``x`` and
    multipliers ``z``.

    The reference (NumPy): :func:`~.conversions.eliminate_equalities`, :func:`.reduced_.fold`
    and :meth:`~.conversions.Reduced.lift`. Where the formulation gives its basis
    (``Conic.null_space``) the reduction and the lift run compiled where numba is
    installed (:func:`._reduced_ipm_kernels.reduce` and ``lift``, ``compiled`` as
    :func:`solve_reduced` takes it): the same numbers to rounding in less time (NumPy's
    stacked products of small matrices pass over every instant's arrays several times,
    and the cone rows, a bound on one force each, are mostly zeros).
    """
    kernels = _reduction_kernels(batch, compiled)
    if kernels is None:
        return _reference(batch, rows)
    data, index, (P_r, q_r, G, h, z0, norm, _), cones = _folded(
        batch, rows, lambda data, index, partner, cones: kernels.reduce(*data, *index, partner))

    def lift(x, z):
        return kernels.lift(data[0], data[1], data[2], data[4], z0, norm, *index,
                            np.ascontiguousarray(x, float), np.ascontiguousarray(z, float))

    return lift, (P_r, q_r, G, h, cones)


def _reduction_kernels(batch: ConicBatch, compiled: bool | None):
    """The compiled kernels where the batch's reduction runs compiled (the formulation
    gives its basis, numba is installed and ``compiled`` allows it), else None.
    """
    n, eq = batch.q.shape[1], zero_rows(batch.cones)[0]
    basis = batch.null_space
    if basis is None or basis.shape[1:] != (n, n - len(eq)):
        return None
    return _kernels(compiled)


def _folded(batch: ConicBatch, rows: np.ndarray | slice, call):
    """``call(data, index, partner, cones)`` on the instants ``rows`` with the full
    problems' ``data`` ``(P, q, A, b, N)``, the rows ``index`` ``(eq, rows, member,
    sign)`` and ``partner`` of the compiled reduction (:func:`._reduced_ipm_kernels.reduce`)
    and (1)'s ``cones``; again without the two-row cones whose fold, matched at the
    first instant, fails at another (the last item of ``call``'s result says where):
    ``(data, index, result, cones)``.
    """
    eq, rest, kept = zero_rows(batch.cones)
    n = batch.q.shape[1]
    P = np.zeros((1, n, n)) if batch.P is None else np.asarray(batch.P, float)
    P = P[None] if P.ndim == 2 else P[rows]
    data = [np.ascontiguousarray(a, float) for a in (P, batch.q[rows], batch.A[rows],
                                                     batch.b[rows], batch.null_space[rows])]
    apex, partner, sign = matched(data[2][0, rest], data[3][0, rest], kept)
    while True:
        plan = fold_plan(kept, apex, sign)
        order, member, signs = ((np.arange(len(rest)), np.zeros(0, int), np.zeros(0))
                                if plan is None else (plan.order, plan.member, plan.sign))
        index = (eq, rest[order], rest[member], np.asarray(signs, float))
        cones = kept if plan is None else plan.cones
        result = call(data, index, rest[partner], cones)
        holds = result[-1].all(axis=0)
        if holds.all():
            return data, index, result, cones
        apex, partner, sign = apex[holds], partner[holds], sign[holds]


def _reference(batch: ConicBatch, rows: np.ndarray | slice):
    """:func:`reduced_problem` in NumPy."""
    P = batch.P if batch.P is None or batch.P.ndim == 2 else batch.P[rows]
    red = eliminate_equalities(P, batch.q[rows], batch.A[rows], batch.b[rows], batch.cones,
                               None if batch.null_space is None else batch.null_space[rows])
    plan = fold(red.A_in, batch.b[rows][:, red.rows_in], red.cones)
    G, h, cones = ((red.A, red.b, red.cones) if plan is None
                   else (*plan.rows(red.A, red.b), plan.cones))

    def lift(x, z):
        return red.lift(x, z if plan is None else plan.duals(z))

    return lift, (red.P, red.q, G, h, cones)


def _solve_group(batch: ConicBatch, rows: np.ndarray | slice, tol: float, max_iter: int,
                 compiled: bool | None, warm: bool):
    """One group's reduction, interior point and lift: ``(z, y, answer, seconds)``;
    compiled as one pass over the instants where the reduction runs compiled
    (:func:`._reduced_ipm_kernels.solve_full`: its ``ipm`` stage then holds the
    reduction and the lift).
    """
    kernels = _reduction_kernels(batch, compiled)
    if kernels is not None:
        clock = time.perf_counter()
        _, _, (z, y, *answer, _), _ = _folded(
            batch, rows, lambda data, index, partner, cones: kernels.solve_full(
                *data, *index, partner, *_settings(kernels, cones, tol, max_iter), bool(warm)))
        return z, y, reduced_ipm.Answer(*answer), {
            "reduce": 0.0, "ipm": time.perf_counter() - clock, "lift": 0.0}
    clock = time.perf_counter()
    lift, problem = _reference(batch, rows)  # no compiled reduction here
    reduced = time.perf_counter()
    answer = solve_reduced(*problem, tol=tol, max_iter=max_iter, compiled=compiled,
                           warm=warm)
    solved = time.perf_counter()
    z, y = lift(answer.x, answer.z)
    return z, y, answer, {"reduce": reduced - clock, "ipm": solved - reduced,
                          "lift": time.perf_counter() - solved}


def solve_batch(batch: ConicBatch, tol=None, max_iter: int = reduced_ipm.MAX_ITER,
                compiled: bool | None = None, warm: bool = False) -> BatchOutcome:
    """Every instant of the batch by the reduced interior point, the ones it leaves
    unsolved by :data:`FALLBACK` alone (module docstring; ``compiled`` and ``warm`` as
    :func:`solve_reduced` takes them).
    """
    tol = reduced_ipm.TOL if tol is None else float(tol)
    T, n = batch.q.shape
    m = batch.b.shape[1]
    z, y = np.full((T, n), np.nan), np.full((T, m), np.nan)
    code = np.full(T, reduced_ipm.BROKEN)
    iterations = np.zeros(T, int)
    stages = {"reduce": 0.0, "ipm": 0.0, "lift": 0.0}
    messages = [""] * T
    groups = _groups(batch)
    for rows in groups:
        z[rows], y[rows], answer, seconds = _solve_group(batch, rows, tol, max_iter,
                                                         compiled, warm)
        code[rows], iterations[rows] = answer.code, answer.iterations
        stages = {k: stages[k] + seconds[k] for k in stages}
        if len(groups) > 1:
            for k in rows:
                messages[k] = f"equality rank changes: reduced with {len(rows)} instants"
    status = np.where(code == reduced_ipm.SOLVED, Status.SOLVED, Status.INACCURATE)
    for k in np.flatnonzero(code == reduced_ipm.ALMOST):
        messages[k] = "; ".join(filter(None, (messages[k], "reduced-ipm: almost solved")))
    clock = time.perf_counter()
    for k in np.flatnonzero(code > reduced_ipm.ALMOST):
        out = solve_unchecked(batch.problems[k], FALLBACK, tol=tol).outcome
        why = f"reduced-ipm: {reduced_ipm.CODES[code[k]]}, answered by {FALLBACK}"
        messages[k] = "; ".join(filter(None, (messages[k], why, out.message)))
        status[k] = out.status
        iterations[k] += out.iterations or 0
        z[k] = np.nan if out.z is None else out.z
        y[k] = np.nan if out.y is None else out.y
    stages["fallback"] = time.perf_counter() - clock
    setup = stages["reduce"] + stages["lift"]
    return BatchOutcome(status=status, z=z, y=y, iterations=iterations, setup_s=setup,
                        solve_s=stages["ipm"] + stages["fallback"], stages=stages,
                        messages=tuple(messages))


def backends() -> list[Backend]:
    """The reduced interior point (compiled where numba is installed, always present)."""
    return [Backend(name="reduced-ipm", family="ipm", distributions=("cardan-forces", "numpy"),
                    supports=supports, tolerances=settings.TOLERANCES["reduced-ipm"],
                    batch=solve_batch, batch_accepts=(ConicBatch,))]
