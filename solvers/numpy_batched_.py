"""Backend ``numpy-batched``: the least-norm family for all instants at once (NumPy).

``min_norm``, ``min_norm_scaled``, ``positive``, ``lcp`` and ``compliance`` (linear law,
no gaps) all pick the point of ``A x = b`` that is least in a diagonal norm
``1/2 x'Wx`` (:class:`~cardan_forces.formulations.batch.LeastNormBatch`); the last three
also keep the end faces ``x_u >= 0``. With ``y = W^{1/2} x`` and ``B = A W^{-1/2}``
(T instants stacked):

- least norm: ``y0 = B' mu`` with ``K mu = b``, ``K = B B' + delta I``. The rows of ``A``
  are dependent along the motion (rank 29 of 30), so ``K`` is singular; ``delta =
  GRAM_RTOL * trace(K) / rows`` biases ``y0`` by about ``delta / sigma_min^2`` of the
  range (1e-12 relative in ``paper``, 1e-7 in ``propshaft``, whose scales differ), which
  one step of iterative refinement removes; the left null direction it inflates is
  annihilated by ``B'``. A contact loads at most two bodies and the bodies form a chain
  (shaft, cross-pin, shaft, ...), so ``K`` is block tridiagonal in 6 x 6 body blocks:
  block elimination with one batched 6 x 6 inverse per body (:func:`chain_solve`).
- end faces >= 0: with ``U = B[:, u]`` the KKT conditions reduce to the LCP of the
  formulation ``lcp``, ``0 <= lam ⟂ w = M lam + q >= 0`` with ``M = I - U' K^+ U``
  and ``q = y0_u``, built from the same factorization (right-hand sides ``[b, U]``).
  It is solved for all instants at once by a primal-dual active-set method (semismooth
  Newton on ``min(lam, w) = 0``), started from the faces that pull in ``y0``; an
  instant whose active set has not settled after ``max_iter`` steps is solved by the
  package's Lemke method. Then ``y = B'(K^-1 (b - U lam)) + E_u lam``.

The multipliers come out of the same solve: ``W x = A' mu + E_u nu`` with
``mu = K^-1 (b - U lam)`` and ``nu_u = sqrt(w_u) lam``, so every record has the solver's
duals. A direct method: ``tol`` is ignored. With numba installed the whole method runs
compiled, 64 instants at a time from their rows to their forces
(:mod:`._batched_kernels`): NumPy pays a per-matrix overhead on 6 x 6 blocks larger
than their arithmetic, forms all of ``B B'`` and streams (T, ...) intermediates through
memory between its steps.
"""

from __future__ import annotations

import functools
import time

import numpy as np
from cardan_forces.formulations.batch import LeastNormBatch
from cardan_forces.formulations.problems import LastMade

from ._batched_state import Layout, Params
from .backend import Backend
from .lcp_methods import lemke
from .record import BatchOutcome, Status

EXTRAS: dict[str, str | None] = {"numpy-batched": None}

GRAM_RTOL = 1e-15
"""Regularization of the Gram matrix, relative to its mean diagonal."""

REFINE_RTOL = 1e-13
"""Relative residual of ``B B' mu = b`` above which one step of iterative refinement is
taken."""

LCP_RTOL = 1e-12
"""Sign tolerance of the active-set steps, relative to ``max(1, max |q|)``."""

LCP_DELTA = 1e-14
"""Regularization of the active block of ``M`` (singular when more faces are pinned
than the null space has directions)."""

MAX_ITER = 30
"""Active-set steps before an instant falls back to Lemke."""



def solve_batch(batch: LeastNormBatch, tol=None, max_iter: int = MAX_ITER) -> BatchOutcome:
    """The batch's least norm (with signs where it has them), forces and multipliers."""
    x, mu, nu, iterations, fallback, stages = least_norm(batch.A, batch.b, batch.weights,
                                                         batch.signed, max_iter, _pattern(batch))
    duals = np.concatenate([-mu, nu[:, np.flatnonzero(batch.signed)]], axis=1)
    T = len(x)
    messages = tuple(np.where(fallback, "Lemke fallback", "")) if fallback.any() else ()
    solve_s = sum(stages.values())
    return BatchOutcome(status=np.full(T, Status.SOLVED, object), z=x, y=duals,
                        iterations=iterations, setup_s=0.0, solve_s=solve_s, stages=stages,
                        messages=messages)


def least_norm(A: np.ndarray, b: np.ndarray, w: np.ndarray | None = None,
               signed: np.ndarray | None = None, max_iter: int = MAX_ITER,
               pattern: np.ndarray | None = None):
    """Least ``1/2 x'Wx`` on ``A x = b`` (stacked, ``A`` (T, m, n)), optionally with
    ``x[signed] >= 0``: ``(x, mu, nu, iterations, fallback, stages)``. ``pattern``: where
    ``A`` is nonzero at some instant (:func:`structure`, found from ``A`` if not given).

    Compiled by numba where installed (extra ``numba``, :func:`._batched_kernels.least_norm`:
    one pass over the instants, 64 at a time from their rows to their forces); else
    NumPy, all instants per step. Instants whose active set does not settle are solved again with
    Lemke's method.
    """
    try:
        from ._batched_kernels import least_norm as compiled
    except ImportError:
        return _least_norm_numpy(A, b, w, signed, max_iter)
    clock = time.perf_counter()
    T, m, n = A.shape
    u = _signed(signed, n)
    root = np.sqrt(w) if w is not None else np.zeros((0, n))
    u, layout = _layout(structure(A) if pattern is None else pattern, u)
    x, mu, lam, iterations, settled = compiled(
        np.ascontiguousarray(A, float), np.ascontiguousarray(b, float), root, u,
        layout, Params(GRAM_RTOL, REFINE_RTOL, int(max_iter), LCP_RTOL, LCP_DELTA))
    nu = np.zeros((T, n))
    nu[:, u] = lam if w is None else lam * root[:, u]
    stages = {"compiled": time.perf_counter() - clock}
    fallback = ~settled
    if fallback.any():  # Lemke's method (max_iter 0: no active-set step) at those instants
        clock, i = time.perf_counter(), np.flatnonzero(fallback)
        x[i], mu[i], nu[i] = _least_norm_numpy(A[i], b[i], None if w is None else w[i],
                                               signed, 0)[:3]
        stages["lemke"] = time.perf_counter() - clock
    return x, mu, nu, iterations, fallback, stages


def _least_norm_numpy(A, b, w=None, signed=None, max_iter: int = MAX_ITER):
    """:func:`least_norm` in NumPy (without numba)."""
    stages = {}
    clock = time.perf_counter()
    T, m, n = A.shape
    root = None if w is None else np.sqrt(w)
    B = A if root is None else A / root[:, None, :]
    u = _signed(signed, n)
    U = B[:, :, u]
    R = np.concatenate([b[:, :, None], U], axis=2)
    clock = _lap(stages, "scale", clock)
    blocks = chain(structure(A))
    K = B @ B.transpose(0, 2, 1)
    K[:, np.arange(m), np.arange(m)] += (GRAM_RTOL / m) * np.trace(K, axis1=1,
                                                                 axis2=2)[:, None]
    Z = chain_solve(K, R, blocks)
    # one step of iterative refinement on B B' Z = R removes the bias of delta whatever
    # the scene's scales (1e-7 relative on the propshaft, 1e-15 on paper). The bias is
    # K's (delta / sigma_min^2), the same for every column: the first column's residual
    # says whether an instant needs the step. Decided per instant, so that an instant's
    # answer does not depend on the others in its batch.
    mu0 = Z[:, :, 0]
    r0 = b - np.einsum("tmn,tn->tm", B, np.einsum("tmn,tm->tn", B, mu0))
    scale = np.maximum(np.linalg.norm(b, axis=1), np.finfo(float).tiny)
    refine = np.flatnonzero(np.linalg.norm(r0, axis=1) / scale > REFINE_RTOL)
    if refine.size:
        Bk = B[refine]
        Z[refine] += chain_solve(K[refine],
                                 R[refine] - Bk @ (Bk.transpose(0, 2, 1) @ Z[refine]), blocks)
    clock = _lap(stages, "gram+factor+solve", clock)
    mu = Z[:, :, 0]
    iterations, fallback = np.zeros(T, int), np.zeros(T, bool)
    nu = np.zeros((T, n))
    if u.size:
        M = np.eye(len(u)) - U.transpose(0, 2, 1) @ Z[:, :, 1:]
        q = np.einsum("tmk,tm->tk", U, mu)
        lam, iterations, fallback = _active_set_numpy(M, q, max_iter)
        mu = mu - np.einsum("tmk,tk->tm", Z[:, :, 1:], lam)
        nu[:, u] = lam
        clock = _lap(stages, "lcp", clock)
    y = np.einsum("tmn,tm->tn", B, mu) + nu
    if root is not None:
        nu *= root
    x = y if root is None else y / root
    _lap(stages, "forces", clock)
    return x, mu, nu, iterations, fallback, stages


def _signed(signed, n: int) -> np.ndarray:
    return np.flatnonzero(signed) if signed is not None else np.zeros(0, np.int64)


def structure(A: np.ndarray) -> np.ndarray:
    """Where ``A`` (T, m, n) is nonzero at some instant: (m, n) booleans."""
    return np.any(A, axis=0)


_pattern = LastMade(lambda batch: structure(batch.A))
"""A batch's :func:`structure`, found once for its support check and its solve."""


def chain(A: np.ndarray) -> list[slice]:
    """The bodies' row blocks (6 rows each) in order along the chain that their shared
    contact columns form (shaft, cross-pin, shaft, ...), from one instant's ``A``.

    A contact acts on at most two bodies, each with a nonzero force part, so the
    coupling of bodies is structural; ``ValueError`` if it is not a path.
    """
    if A.shape[0] % 6:
        raise ValueError("the rows are not 6 per body")
    touches = np.any(A.reshape(-1, 6, A.shape[1]) != 0, axis=1).astype(int)
    linked = touches @ touches.T > 0
    np.fill_diagonal(linked, False)
    degree = linked.sum(axis=1)
    ends = np.flatnonzero(degree <= 1)
    if len(degree) > 1 and (degree.max() > 2 or len(ends) != 2 or degree.min() == 0):
        raise ValueError("the bodies do not form a chain")
    order = [int(ends[0])]
    while len(order) < len(degree):
        order.append(int(next(k for k in np.flatnonzero(linked[order[-1]]) if k not in order)))
    return [slice(6 * k, 6 * k + 6) for k in order]


def chain_solve(K: np.ndarray, R: np.ndarray, blocks: list[slice]) -> np.ndarray:
    """``K^{-1} R`` for a stack of matrices that are block tridiagonal along ``blocks``:
    block elimination (``D_k = K_kk - K_k,k-1 D_k-1^{-1} K_k-1,k``, positive definite
    for a positive definite ``K``), one batched inverse per block (for 6 x 6 blocks and
    several right-hand sides NumPy inverts faster than it solves).
    """
    inverse = np.linalg.inv(K[:, blocks[0], blocks[0]])
    nxt, rhs = [], [inverse @ R[:, blocks[0]]]
    for prev, rows in zip(blocks, blocks[1:]):
        nxt.append(inverse @ K[:, prev, rows])
        coupling = K[:, rows, prev]
        inverse = np.linalg.inv(K[:, rows, rows] - coupling @ nxt[-1])
        rhs.append(inverse @ (R[:, rows] - coupling @ rhs[-1]))
    out = np.empty_like(R)
    out[:, blocks[-1]] = rhs[-1]
    for k in range(len(blocks) - 2, -1, -1):
        out[:, blocks[k]] = rhs[k] - nxt[k] @ out[:, blocks[k + 1]]
    return out


def _layout(pattern: np.ndarray, u: np.ndarray):
    """:func:`_make_layout` of the pattern and signed columns, made once per structure
    (a batch's structure is the same at every call; finding it is Python work over
    its blocks): ``(u, layout)``.
    """
    return _layout_of(pattern.shape, np.asarray(pattern, bool).tobytes(),
                      np.asarray(u, np.int64).tobytes())


@functools.lru_cache(maxsize=8)
def _layout_of(shape: tuple, pattern: bytes, u: bytes):
    return _make_layout(np.frombuffer(pattern, bool).reshape(shape),
                        np.frombuffer(u, np.int64))


def _make_layout(pattern: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, Layout]:
    """The compiled kernel's view of the rows' nonzero ``pattern`` (m, n) (see
    :func:`._batched_kernels.least_norm`): the signed columns ``u`` sorted by the first
    body they touch along the chain, and the :class:`Layout` of the bodies.
    """
    blocks = chain(pattern)
    touch = np.any(pattern.reshape(-1, 6, pattern.shape[1]), axis=1)[
        [k.start // 6 for k in blocks]]
    first = np.argmax(touch[:, u], axis=0) + len(blocks) * ~touch[:, u].any(axis=0)
    u, first = u[np.argsort(first, kind="stable")], np.sort(first)
    own = [np.flatnonzero(row) for row in touch]
    where = [{int(c): p for p, c in enumerate(cols)} for cols in own]
    shared = [np.flatnonzero(a & c) for a, c in zip(touch, touch[1:])] or [[]]
    sh_a = [[where[k][int(c)] for c in cols] for k, cols in enumerate(shared)]
    sh_b = [[where[k + 1][int(c)] for c in cols] for k, cols in enumerate(shared)]
    upos = np.array([[w.get(int(c), -1) for c in u] for w in where], np.int64).reshape(
        len(own), len(u))
    ncols = 1 + np.searchsorted(first, np.arange(len(blocks)), side="right")
    (own, n_own), (sh_b, n_sh) = _padded(own), _padded(sh_b)
    return u, Layout(np.array([k.start for k in blocks], np.int64), own, n_own,
                     _padded(sh_a)[0], sh_b, n_sh, upos, first.astype(np.int64),
                     ncols.astype(np.int64))


def _padded(lists) -> tuple[np.ndarray, np.ndarray]:
    """Integer lists as one zero-padded array (at least one column) and their lengths."""
    out = np.zeros((len(lists), max(max(len(x) for x in lists), 1)), np.int64)
    for i, x in enumerate(lists):
        out[i, :len(x)] = x
    return out, np.array([len(x) for x in lists], np.int64)


def _lap(stages: dict[str, float], name: str, since: float) -> float:
    now = time.perf_counter()
    stages[name] = now - since
    return now


def _active_set(M: np.ndarray, q: np.ndarray, max_iter: int):
    """``0 <= lam ⟂ M lam + q >= 0`` for every instant: primal-dual active set.

    Pinned faces ``P`` solve ``M_PP lam_P = -q_P`` with ``lam = 0`` elsewhere; the next
    set keeps the pinned faces with ``lam > 0`` and adds the free ones with ``w < 0``.
    An instant is done when its set repeats; one that has not after ``max_iter`` steps
    is solved by Lemke's method. Compiled by numba where installed.
    """
    try:
        from ._batched_kernels import active_set
    except ImportError:
        return _active_set_numpy(M, q, max_iter)
    lam, iterations, settled = active_set(np.ascontiguousarray(M), np.ascontiguousarray(q),
                                          max_iter, LCP_RTOL, LCP_DELTA)
    return _lemke_fallback(M, q, lam, iterations, np.flatnonzero(~settled))


def _active_set_numpy(M: np.ndarray, q: np.ndarray, max_iter: int):
    """:func:`_active_set` in NumPy, all instants per step (without numba)."""
    T, k = q.shape
    eps = LCP_RTOL * np.maximum(1.0, np.abs(q).max(axis=1, initial=0.0))[:, None]
    pinned = q < 0
    lam = np.zeros((T, k))
    iterations = np.zeros(T, int)
    todo = np.arange(T)
    eye = np.eye(k)
    for step in range(1, max_iter + 1):
        P = pinned[todo]
        both = P[:, :, None] & P[:, None, :]
        system = np.where(both, M[todo] + LCP_DELTA * eye, 0.0) + eye * ~P[:, None, :]
        lam[todo] = np.linalg.solve(system, np.where(P, -q[todo], 0.0)[:, :, None])[:, :, 0]
        w = np.einsum("tij,tj->ti", M[todo], lam[todo]) + q[todo]
        nxt = np.where(P, lam[todo] > -eps[todo], w < -eps[todo])
        settled = np.all(nxt == P, axis=1)
        iterations[todo] = step
        pinned[todo] = nxt
        todo = todo[~settled]
        if not todo.size:
            break
    return _lemke_fallback(M, q, lam, iterations, todo)


def _lemke_fallback(M, q, lam, iterations, todo):
    """Lemke's method at the instants ``todo`` whose active set did not settle."""
    fallback = np.zeros(len(q), bool)
    fallback[todo] = True
    for i in todo:
        lam[i] = lemke(M[i], q[i]).z
    return lam, iterations, fallback


def _chain_shaped(batch) -> bool:
    """Whether the batch's rows form a chain of bodies over all its instants: the
    pattern the solve uses (:func:`structure`, made once per batch), not one instant's,
    where a column that vanishes at that instant would hide a link. Asked at every
    solve: the layout made from the pattern (:func:`_layout`) is kept for the solve.
    """
    try:
        pattern = _pattern(batch)
        _layout(pattern, _signed(batch.signed, pattern.shape[1]))
    except ValueError:
        return False
    return True


def backends() -> list[Backend]:
    """The batched least-norm backend (NumPy only, always present)."""
    return [Backend(name="numpy-batched", family="numpy",
                    distributions=("cardan-forces", "numpy"), supports=_chain_shaped,
                    batch=solve_batch, batch_accepts=(LeastNormBatch,))]
