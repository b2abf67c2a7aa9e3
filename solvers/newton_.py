"""Backends ``newton``, ``newton-batched``, ``newton-batched-warm``: the contact problems
of the compliance family solved as the physics engines solve contact, by Newton's
method on an unconstrained convex dual (MuJoCo's default solver on the reduced primal,
Drake's SAP), with an exact line search.

Every formulation this family takes is ``min sum_c psi_c(||f_c||)`` over the contact
forces ``f`` (each contact ``c`` a group of columns) on the equilibrium ``E f = e``,
``psi_c`` a contact's complementary energy: ``k r^2 / 2`` (least norm, linear law) or
``(n / (n+1)) k^(-1/n) r^((n+1)/n)`` (Hertz, ``n = 3/2``), plus ``g r`` for a
clearance ``g``; a column that may only push is a group of one with ``f >= 0``. With
``d = E'u`` the contacts' deformations (``u`` the bodies' displacements, one per row,
the multiplier of ``E f = e``), its dual is

    min_u  Phi(u) = sum_c phi_c(d_c) - e'u,   phi_c(d) = (s - g)_+ r(s) / (n + 1),

``s = ||d_c||`` (``max(d, 0)`` for a pushing column), ``r(s) = ((s - g)_+ / k)^n`` the
contact's load and ``f_c = r(s) d_c / s`` its force (``k`` the stiffness of the
linear law, ``n = 1``; ``p c`` for Hertz's ``c r^p`` energy, ``n = 1 / (p - 1)``).
``Phi`` is convex and once (Hertz: twice) continuously differentiable; its gradient
is the equilibrium residual ``E f - e`` and its Hessian ``sum_c E_c H_c E_c'`` with
``H_c = r' u u' + (r / s)(I - u u')`` (``u = d_c / s``).

Newton's method: the step solves ``(H + rho V V' + mu I) du = -(I - V V') grad``, a
Cholesky factor of ``m x m``; ``V`` spans the left null space of ``E`` (the directions
along which no contact does work: the drive line's own motion), found once per instant
from the factor of the nominal Hessian ``H0`` (every contact loaded at the scale of
``e``) and held out of ``u`` explicitly, so a dependent equilibrium row (the operator's
rows are dependent along the motion) never decides a step; ``mu = REG_RTOL rho``
(``rho`` the mean diagonal of ``H0``) keeps the factor defined where no contact does
work along a direction (idle end faces, open clearances), whose step the line search
then bounds. The line search minimizes ``Phi`` along the step exactly (a safeguarded
Newton iteration on the slope, ``O(n)`` an evaluation). A cold start takes its first
step with ``H0``; a warm start fits ``u`` to the deformations ``d`` of a neighbouring
answer; an instant of a batch's chain solves the contacts' law linearized at the
deformations extrapolated by a polynomial through the answers before, and that
Hessian's factor, the only one where the start is close, serves the first step; a
batch is cut into runs of :data:`RUN` instants, each chained from a cold first instant
and solved side by side on numba's threads. The iteration stops when ``||(I - V V')
grad|| <= tol ||e||`` (or at rounding, where no decrease is left, within ``STALL
tol``).

``soften`` (option, >= 0): the equilibrium softened as MuJoCo and SAP soften their
constraints, ``+ soften rho ||u||^2 / 2`` in the dual, i.e. the primal
``min sum psi_c + ||E f - e||^2 / (2 soften rho)``: the answer is unique for any
``soften > 0`` and leaves the rigid set by ``O(soften)``
(:mod:`cardan_forces.experiments.regularization` measures the cost).

The problem's data are read as they are, never trusted: :func:`._newton_layout.parse`
recognizes the structure above in a problem's conic form (zero rows, sign rows, one
second-order cone per contact, a power cone per Hertz contact) and refuses anything
else. The answer is
handed back in the problem's own variable with every multiplier of its conic rows,
derived from ``u`` (``y = -u`` on the equilibrium rows), so the package judges it as
any other backend's. The method runs compiled where numba is installed (extra
``numba``, :mod:`._newton_kernels`); :mod:`._newton_numpy` is its NumPy reference.
"""

from __future__ import annotations

import functools
import importlib
import time
from concurrent.futures import ThreadPoolExecutor

import numpy as np
from cardan_forces.formulations import FORMULATIONS
from cardan_forces.formulations.batch import ConicBatch, LeastNormBatch
from cardan_forces.formulations.problems import LCP, Conic, LastMade
from threadpoolctl import ThreadpoolController

from cardan_forces.util.compiled import compiled_form

from . import settings
from ._newton_layout import answer, numbers, parse_batch, parse_conic
from ._newton_numpy import (
    EXTRAPOLATION,
    LS_MAX,
    LS_RTOL,
    MAX_ITER,
    NULL_RTOL,
    REASONS,
    REG_RTOL,
    STALL,
    STATUS,
    TOL,
    WARM_ITER,
    Groups,
    forces,
    groups_of,
    newton_numpy,
)
from ._newton_state import Contacts, Params
from .backend import Backend
from .record import BatchOutcome, Outcome

EXTRAS: dict[str, str | None] = {"newton": None, "newton-batched": None,
                                 "newton-batched-warm": None}


def solve_duals(E, e, groups: Groups, k, g, d0=None, start=None, chain=False, tol=TOL,
                max_iter=MAX_ITER, soften=0.0, compiled=None):
    """:func:`newton_numpy`'s answer, compiled where numba is installed (``compiled``:
    force one path; ``True`` without numba is an ``ImportError``); a batch is solved in
    runs of :data:`RUN` instants, on numba's threads where compiled (:func:`_runs`).
    """
    kernels = compiled_form(lambda: importlib.import_module(f"{__package__}._newton_kernels"),
                            compiled)
    T, m, nv = E.shape
    d0 = np.zeros((T, nv)) if d0 is None else np.ascontiguousarray(d0, float)
    start = np.zeros(T, np.bool_) if start is None else np.asarray(start, np.bool_)
    if kernels is None:
        return _runs(lambda r: newton_numpy(E[r], e[r], groups, k[r], g[r], d0[r], start[r],
                                            chain, tol, max_iter, soften), T, 1)
    contacts = Contacts(groups.members, groups.mask, groups.signed, groups.n)
    params = Params(float(tol), int(max_iter), float(soften), NULL_RTOL, REG_RTOL, LS_RTOL,
                    int(LS_MAX), STALL, int(EXTRAPOLATION), int(WARM_ITER))
    Et, span = np.ascontiguousarray(np.swapaxes(E, 1, 2), float), spans(E)
    e, k, g = (np.ascontiguousarray(a, float) for a in (e, k, g))
    return _runs(lambda r: kernels.newton(Et[r], span, e[r], contacts, k[r], g[r], d0[r], start[r],
                                  bool(chain), params), T, _threads())


RUN = 128
"""Instants per run: a batch is cut into runs of this many consecutive instants, each a
chain of its own (its first instant cold), solved side by side. The cut does not depend
on the thread count, so neither does any answer."""


def _runs(solve, T: int, threads: int):
    """``solve(slice)``'s ``(u, d, status, iterations)`` over the runs of ``T`` instants,
    joined; on up to ``threads`` threads (the compiled kernel releases the GIL), with
    one BLAS thread (:func:`_blas`) wherever there is more than one run, so that no
    answer depends on the thread count.
    """
    runs = [slice(lo, min(T, lo + RUN)) for lo in range(0, max(T, 1), RUN)]
    if len(runs) == 1:
        return solve(runs[0])
    with _blas().limit(limits=1, user_api="blas"):
        if threads > 1:
            with ThreadPoolExecutor(min(threads, len(runs))) as pool:
                parts = list(pool.map(solve, runs))
        else:
            parts = [solve(r) for r in runs]
    return tuple(np.concatenate(x) for x in zip(*parts))


@functools.cache
def _blas() -> ThreadpoolController:
    """The BLAS libraries loaded by the time a batch is solved. Each run's Hessian
    product is a small BLAS call; a BLAS running threads of its own for it makes the
    runs' threads wait on one another. The kernels' products call SciPy's BLAS,
    imported here so that the controller sees it whatever ran before.
    """
    import scipy.linalg.cython_blas  # noqa: F401 (loaded for the controller to find)
    return ThreadpoolController()


def _threads() -> int:
    """The thread count numba is set to (``NUMBA_NUM_THREADS``, ``numba.set_num_threads``)."""
    import numba
    return numba.get_num_threads()


def spans(E) -> np.ndarray:
    """Per column of ``E`` (T, m, nv), the rows ``[lo, hi)`` outside which it is zero at
    every instant (a contact loads at most two bodies: the kernel skips the rest).
    """
    nonzero = np.any(E != 0, axis=0)
    lo = np.argmax(nonzero, axis=0)
    hi = len(nonzero) - np.argmax(nonzero[::-1], axis=0)
    empty = ~nonzero.any(axis=0)
    return np.stack([np.where(empty, 0, lo), np.where(empty, 0, hi)], axis=1).astype(np.int64)


def deformations(f, groups: Groups, k, g) -> np.ndarray:
    """Deformations (..., nv) that load the contacts with forces ``f`` (a warm start):
    ``d_c = (g + k r^(1/n)) f_c / r`` where ``r = ||f_c|| > 0``, else 0.
    """
    fg = f[..., groups.members] * groups.mask
    r = np.where(groups.signed, np.maximum(fg[..., 0], 0.0),
                 np.sqrt(np.einsum("...gw,...gw->...g", fg, fg)))
    safe = np.where(r > 0, r, 1.0)
    push = np.where(r > 0, (g + k * safe ** (1.0 / groups.n)) / safe, 0.0)
    d = np.zeros(np.shape(f))
    real = groups.mask > 0
    d[..., groups.members[real]] = (push[..., None] * fg)[..., real]
    return d


_layout_of = LastMade(parse_conic)
_batch_layout = LastMade(parse_batch)
"""A problem's (a batch's) layout, found once for its support check and its solve."""


def _scalars(signed) -> Groups:
    """Every column its own contact, ``signed`` where it may only push."""
    signed = np.asarray(signed, bool)
    return groups_of([[j] for j in range(len(signed))], signed, np.ones(len(signed)))


def supports(problem) -> bool:
    """Whether the family solves ``problem``: the package's LCP (``positive`` as a
    complementarity problem, solved through ``positive`` from its force checks) or a
    conic problem of contact energies (:func:`parse`).
    """
    if isinstance(problem, LCP):
        return (problem.formulation in FORMULATIONS
                and problem.n == int(np.sum(problem.checks.unilateral)))
    return _layout_of(problem) is not None


def _message(code: int) -> str:
    return REASONS[int(code)]


def solve_problem(problem, tol=None, initvals=None, soften: float = 0.0,
                  max_iter: int = MAX_ITER, compiled=None) -> Outcome:
    """One instant: ``initvals`` (the problem's variable) starts it from the contacts'
    deformations under those forces; ``soften`` as in the module's text.
    """
    start = time.perf_counter()
    tol = TOL if tol is None else float(tol)
    if isinstance(problem, LCP):
        return _solve_lcp(problem, tol, soften, max_iter, compiled, start)
    lay = _layout_of(problem)
    n_z = problem.n
    P_diag = (np.zeros((1, n_z)) if problem.P is None else np.diag(problem.P)[None])
    q, A, b = (np.asarray(problem.q, float)[None], np.asarray(problem.A, float)[None],
               np.asarray(problem.b, float)[None])
    E, e, k, g, held = numbers(lay, P_diag, q, A, b)
    d0 = None
    if initvals is not None and np.shape(initvals) == (n_z,):
        d0 = deformations(np.asarray(initvals, float)[lay.force][None], lay.groups, k, g)
    setup = time.perf_counter()
    u, d, status, iters = solve_duals(E, e, lay.groups, k, g, d0, None if d0 is None else
                                      np.ones(1, bool), tol=tol, max_iter=max_iter,
                                      soften=soften, compiled=compiled)
    z, y = answer(lay, A, P_diag, q, u, d, k, g, held)
    objective = 0.5 * float(z[0] @ (P_diag[0] * z[0])) + float(q[0] @ z[0])
    return Outcome(STATUS[status[0]], z[0], iterations=int(iters[0]),
                   message=_message(status[0]), objective=objective,
                   setup_s=setup - start, solve_s=time.perf_counter() - setup, y=y[0])


def _solve_lcp(problem: LCP, tol, soften, max_iter, compiled, start) -> Outcome:
    """The ``lcp`` through ``positive`` on its force checks (the operator's rows): the
    end faces' multipliers ``lam = max(-d_u, 0)``.
    """
    c = problem.checks
    uni = np.asarray(c.unilateral, bool)
    groups = _scalars(uni)
    ones = np.ones((1, len(uni)))
    setup = time.perf_counter()
    u, d, status, iters = solve_duals(np.asarray(c.A, float)[None], np.asarray(c.b, float)[
        None], groups, ones, 0.0 * ones, tol=tol, max_iter=max_iter, soften=soften,
        compiled=compiled)
    return Outcome(STATUS[status[0]], np.maximum(-d[0, uni], 0.0), iterations=int(iters[0]),
                   message=_message(status[0]), setup_s=setup - start,
                   solve_s=time.perf_counter() - setup)


def solve_batch(batch, tol=None, soften: float = 0.0, max_iter: int = MAX_ITER,
                chain: bool = False, compiled=None) -> BatchOutcome:
    """Every instant of a least-norm or conic batch (``chain``: each instant after the
    first warm-started from the one before it).
    """
    clock = time.perf_counter()
    tol = TOL if tol is None else float(tol)
    if isinstance(batch, LeastNormBatch):
        groups = _scalars(batch.signed)
        k = np.ones(batch.A.shape[::2]) if batch.weights is None else batch.weights
        E, e, g = batch.A, batch.b, np.zeros_like(k)
    else:
        lay = _batch_layout(batch)
        T, _, n_z = batch.A.shape
        P = np.zeros((n_z, n_z)) if batch.P is None else np.asarray(batch.P, float)
        P_diag = np.broadcast_to(np.diagonal(P, axis1=-2, axis2=-1), (T, n_z))
        E, e, k, g, held = numbers(lay, P_diag, batch.q, batch.A, batch.b)
        groups = lay.groups
    stages = {"setup": time.perf_counter() - clock}
    clock = time.perf_counter()
    u, d, status, iters = solve_duals(E, e, groups, k, g, chain=chain, tol=tol,
                                      max_iter=max_iter, soften=soften, compiled=compiled)
    stages["newton"] = time.perf_counter() - clock
    clock = time.perf_counter()
    if isinstance(batch, LeastNormBatch):
        z = forces(d, groups, k, g)
        y = np.concatenate([-u, np.maximum(-d[:, batch.signed], 0.0)], axis=1)
    else:
        z, y = answer(lay, batch.A, P_diag, batch.q, u, d, k, g, held)
    stages["answer"] = time.perf_counter() - clock
    messages = tuple(map(_message, status)) if np.any(status) else ()
    return BatchOutcome(status=np.array(STATUS, object)[status], z=z, y=y,
                        iterations=iters, setup_s=stages["setup"],
                        solve_s=stages["newton"] + stages["answer"], stages=stages,
                        messages=messages)


def _batch_supported(batch) -> bool:
    return isinstance(batch, LeastNormBatch) or _batch_layout(batch) is not None


def backends() -> list[Backend]:
    """The family (NumPy is a core dependency; numba, where installed, compiles it)."""
    common = dict(family="newton", distributions=("cardan-forces", "numpy"),
                  tolerances=settings.TOLERANCES["newton"],
                  smallest_tol=settings.SMALLEST["newton"])
    return [Backend(name="newton", accepts=(Conic, LCP), solve=solve_problem,
                    supports=supports, warm_start=True, **common),
            Backend(name="newton-batched", batch=solve_batch, supports=_batch_supported,
                    batch_accepts=(LeastNormBatch, ConicBatch), **common),
            Backend(name="newton-batched-warm", batch=_solve_chained,
                    supports=_batch_supported, batch_accepts=(LeastNormBatch, ConicBatch),
                    **common)]


def _solve_chained(batch, tol=None, **options) -> BatchOutcome:
    """:func:`solve_batch` with each instant warm-started from the one before it."""
    return solve_batch(batch, tol, chain=True, **options)
