"""Dense linear algebra of the ``newton`` family's compiled steps (:mod:`._newton_kernels`):
a Hessian summed from rank-one terms, its Cholesky factor with dependent rows skipped,
triangular solves and the left null space the skipped rows leave.

No fastmath (as :mod:`._newton_kernels`); nothing raises on numbers: a factor that is
not positive definite is a returned ``False``.
"""

from __future__ import annotations

from functools import partial

import numpy as np

from cardan_forces.util import compiled
from cardan_forces.util.compiled import HAVE_NUMBA, njit

from ._newton_state import Scratch

if not HAVE_NUMBA:  # an optional extra: the caller takes the NumPy reference
    raise ImportError("numba is not installed")

FILES = ("_newton_linalg.py", "_newton_kernels.py", "_newton_state.py",
         compiled.__file__)
"""The newton kernels' source files: each kernel's cache is keyed by all of them (a
kernel inlines the functions of the others)."""

kernel = partial(njit, cache=True, depends=FILES)
"""The newton modules' ``njit``: cached, compiled again when any of :data:`FILES`
changes."""


@kernel
def _term(B, ranges, t, a, scale, lo, hi):
    """Row ``t`` of ``B``: ``sqrt(scale) a`` on rows ``lo:hi`` (0 elsewhere); ``t + 1``."""
    root = np.sqrt(scale)
    B[t, :lo] = 0.0
    B[t, hi:] = 0.0
    for i in range(lo, hi):
        B[t, i] = root * a[i]
    ranges[t, 0], ranges[t, 1] = lo, hi
    return t + 1


@kernel
def _sum_terms(B, ranges, count, dense, H):
    """``H = B'B`` over the first ``count`` rows (at least its lower triangle)."""
    if dense and count > 0:
        rows = B[:count]
        np.dot(rows.T, rows, H)
        return
    for i in range(H.shape[0]):
        for j in range(i + 1):
            H[i, j] = 0.0
    for t in range(count):
        _rank_one(H, B[t], 1.0, ranges[t, 0], ranges[t, 1])


@kernel
def _rank_one(H, a, scale, lo, hi):
    """``H += scale a a'`` on the lower triangle of rows and columns ``lo:hi``."""
    for i in range(lo, hi):
        ai = scale * a[i]
        for j in range(lo, i + 1):
            H[i, j] += ai * a[j]


@kernel
def _cholesky(H, L, dependent, rtol):
    """Lower Cholesky factor of ``H`` into ``L``. With ``rtol > 0`` a pivot below ``rtol``
    of its diagonal entry marks the row dependent (``dependent[p]``, its row and column
    of ``L`` zero); with ``rtol = 0`` such a pivot is a failure. Returns whether it
    succeeded (every pivot finite and positive, or marked).
    """
    m = H.shape[0]
    for p in range(m):
        dependent[p] = False
        acc = H[p, p]
        for q in range(p):
            acc -= L[p, q] * L[p, q]
        if rtol > 0 and acc <= rtol * H[p, p]:
            dependent[p] = True
            for j in range(m):
                L[j, p] = 0.0
                L[p, j] = 0.0
            continue
        if not acc > 0 or not np.isfinite(acc):
            return False
        L[p, p] = np.sqrt(acc)
        for j in range(p + 1, m):
            acc = H[j, p]
            for q in range(p):
                acc -= L[j, q] * L[p, q]
            L[j, p] = acc / L[p, p]
        for j in range(p):
            L[j, p] = 0.0
    return True


@kernel
def _solve(L, rhs, x, dependent, upto):
    """``x = (L L')^-1 rhs`` over the rows below ``upto`` not ``dependent``."""
    for i in range(upto):
        if dependent[i]:
            x[i] = 0.0
            continue
        acc = rhs[i]
        for q in range(i):
            acc -= L[i, q] * x[q]
        x[i] = acc / L[i, i]
    for i in range(upto - 1, -1, -1):
        if dependent[i]:
            continue
        acc = x[i]
        for q in range(i + 1, upto):
            acc -= L[q, i] * x[q]
        x[i] = acc / L[i, i]


@kernel
def _project(v, V, nk):
    """``v - V V'v`` in place."""
    for q in range(nk):
        dot = 0.0
        for i in range(len(v)):
            dot += V[i, q] * v[i]
        for i in range(len(v)):
            v[i] -= dot * V[i, q]


@kernel
def _finish(H, shift, V, nk, rho):
    """Add ``shift I + rho V V'`` to the lower triangle of ``H`` and mirror it."""
    m = H.shape[0]
    for i in range(m):
        H[i, i] += shift
        for j in range(i + 1):
            for q in range(nk):
                H[i, j] += rho * V[i, q] * V[j, q]
            H[j, i] = H[i, j]


@kernel
def _norm(v):
    """``max(||v||, 1e-300)``."""
    acc = 0.0
    for x in v:
        acc += x * x
    return max(np.sqrt(acc), 1e-300)


@kernel
def _null_space(M, s: Scratch, rtol):
    """Factor ``M`` into ``s.L``, its rows below ``rtol`` skipped as dependent, and its
    null vectors, orthonormal, into ``s.V``'s first columns; returns their count, or -1
    where the factor fails. Each dependent row ``p`` gives ``v_p = 1``, ``v_I = -M_II^-1
    M_Ip`` over the independent rows before it.
    """
    m = M.shape[0]
    if not _cholesky(M, s.L, s.dependent, rtol):
        return -1
    nk = 0
    for p in range(m):
        if not s.dependent[p]:
            continue
        for i in range(m):
            s.rhs[i] = -M[i, p]
        _solve(s.L, s.rhs, s.du, s.dependent, p)
        for i in range(p):  # one step of iterative refinement: M_II v_I + M_Ip = 0
            acc = M[i, p]
            for j in range(p):
                acc += M[i, j] * s.du[j]
            s.rhs[i] = -acc
        _solve(s.L, s.rhs, s.grad, s.dependent, p)
        for i in range(m):
            s.V[i, nk] = s.du[i] + s.grad[i] if i < p else 0.0
        s.V[p, nk] = 1.0
        for q in range(nk):  # modified Gram-Schmidt against the vectors before
            dot = 0.0
            for i in range(m):
                dot += s.V[i, q] * s.V[i, nk]
            for i in range(m):
                s.V[i, nk] -= dot * s.V[i, q]
        length = _norm(s.V[:, nk])
        for i in range(m):
            s.V[i, nk] /= length
        nk += 1
    return nk
