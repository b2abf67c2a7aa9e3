"""Compiled least norm of ``numpy-batched``, one instant after the other (numba, extra ``numba``).

The same method as the NumPy path of :mod:`.numpy_batched_` — the Gram matrix ``K = B
B' + delta I`` by block elimination along the chain of 6 x 6 body blocks (``D_k = K_kk
- K_k,k-1 D_k-1^{-1} K_k-1,k``, here with a Cholesky factor of each ``D_k``), one step of
iterative refinement where an instant's residual asks for it, the end faces' LCP by the
primal-dual active set — fused into one loop over the instants: each instant's numbers
stay in a few kilobytes of scratch from its scaled rows to its forces, no (T, ...)
intermediate is allocated, and only the nonzero blocks of ``B`` are touched (a contact
column loads at most two bodies). NumPy's batched 6 x 6 products and inverses pay a
loop or LAPACK overhead per matrix larger than their arithmetic.

Sums run in a fixed order (no reassociation), so an instant's answer is the same
whatever else is in its batch.
"""

from __future__ import annotations

import numpy as np
from numba import njit

B = 6
"""Rows per body block."""

TINY = float(np.finfo(float).tiny)
"""Smallest normal double: the floor of ``||b||`` in the refinement test."""

FAST = {"contract"}
"""numba fastmath flags: fused multiply-add only (no reassociation, NaN stays NaN)."""


@njit(cache=True, fastmath=FAST)
def _cholesky(L, o):
    """Lower Cholesky factor of the 6 x 6 positive definite block ``L[o:o+6]`` in place,
    with the reciprocals of its diagonal on the diagonal (one division per row).
    """
    for j in range(B):
        s = L[o + j, j]
        for k in range(j):
            s -= L[o + j, k] * L[o + j, k]
        d = 1.0 / np.sqrt(s)
        L[o + j, j] = d
        for i in range(j + 1, B):
            s = L[o + i, j]
            for k in range(j):
                s -= L[o + i, k] * L[o + j, k]
            L[o + i, j] = s * d


@njit(cache=True, fastmath=FAST)
def _forward(L, o, X, s, nc):
    """``X[s:s+6, :nc] <- L^-1 X[s:s+6, :nc]``, ``L = L[o:o+6]`` from :func:`_cholesky`."""
    for c in range(nc):
        for i in range(B):
            acc = X[s + i, c]
            for k in range(i):
                acc -= L[o + i, k] * X[s + k, c]
            X[s + i, c] = acc * L[o + i, i]


@njit(cache=True, fastmath=FAST)
def _backward(L, o, X, s):
    """``X[s:s+6] <- L^-T X[s:s+6]``, ``L = L[o:o+6]`` from :func:`_cholesky`."""
    for c in range(X.shape[1]):
        for i in range(B - 1, -1, -1):
            acc = X[s + i, c]
            for k in range(i + 1, B):
                acc -= L[o + k, i] * X[s + k, c]
            X[s + i, c] = acc * L[o + i, i]


@njit(cache=True, fastmath=FAST)
def _rows_product(X, xo, Y, yo, n, out, oo):
    """``out[oo+i, j] = sum_p<n X[xo+i, p] Y[yo+j, p]`` for a 6 x 6 block: six running
    sums per row, so that the multiply-adds overlap instead of waiting on each other.
    """
    for i in range(B):
        a0 = a1 = a2 = a3 = a4 = a5 = 0.0
        for p in range(n):
            g = X[xo + i, p]
            a0 += g * Y[yo, p]
            a1 += g * Y[yo + 1, p]
            a2 += g * Y[yo + 2, p]
            a3 += g * Y[yo + 3, p]
            a4 += g * Y[yo + 4, p]
            a5 += g * Y[yo + 5, p]
        out[oo + i, 0] = a0
        out[oo + i, 1] = a1
        out[oo + i, 2] = a2
        out[oo + i, 3] = a3
        out[oo + i, 4] = a4
        out[oo + i, 5] = a5


@njit(cache=True, fastmath=FAST)
def _minus_tn(X, xo, Y, yo, out, oo, nc):
    """``out[oo:oo+6, :nc] -= X[xo:xo+6]' Y[yo:yo+6, :nc]``."""
    for i in range(B):
        for c in range(nc):
            acc = out[oo + i, c]
            for p in range(B):
                acc -= X[xo + p, i] * Y[yo + p, c]
            out[oo + i, c] = acc


@njit(cache=True, fastmath=FAST)
def _minus_nn(X, xo, Y, yo, out, oo):
    """``out[oo:oo+6] -= X[xo:xo+6] Y[yo:yo+6]``."""
    for i in range(B):
        for c in range(Y.shape[1]):
            acc = out[oo + i, c]
            for p in range(B):
                acc -= X[xo + i, p] * Y[yo + p, c]
            out[oo + i, c] = acc


@njit(cache=True, fastmath=FAST)
def _factor(G, n_own, sh_a, sh_b, n_sh, rtol, L, H, Sa, Sb):
    """Factor ``K = B B' + delta I = C C'`` of one instant, ``delta = rtol * trace(B B') /
    m``, from its block rows ``G`` (row ``6k + i``: body ``k``'s row ``i`` on the columns
    touching it). ``C`` is block lower bidiagonal along the chain: diagonal blocks
    ``L[6k:6k+6]``, the Cholesky factors of the pivots ``D_k = K_kk - H_k-1' H_k-1``,
    and below them ``H[6k:6k+6]' `` with ``H_k = L_k^-1 K_k,k+1`` (``K_k,k+1`` from the
    columns touching both bodies).
    """
    nb = len(n_own)
    trace = 0.0
    for k in range(nb):
        _rows_product(G, B * k, G, B * k, n_own[k], L, B * k)
        for i in range(B):
            trace += L[B * k + i, i]
        if k < nb - 1:
            for i in range(B):
                for p in range(n_sh[k]):
                    Sa[i, p] = G[B * k + i, sh_a[k, p]]
                    Sb[i, p] = G[B * k + B + i, sh_b[k, p]]
            _rows_product(Sa, 0, Sb, 0, n_sh[k], H, B * k)
    delta = rtol * trace / (nb * B)
    for k in range(nb):
        o = B * k
        for i in range(B):
            L[o + i, i] += delta
        if k > 0:
            _minus_tn(H, o - B, H, o - B, L, o, B)
        _cholesky(L, o)
        if k < nb - 1:
            _forward(L, o, H, o, B)


@njit(cache=True, fastmath=FAST)
def _down(L, H, starts, Z, ncols):
    """``Z <- C^-1 Z`` (m, r) with :func:`_factor`'s ``K = C C'``, in place, where the
    columns from ``ncols[k]`` on are zero down to body ``k`` (and stay zero).
    """
    for k in range(len(starts)):
        if k > 0:
            _minus_tn(H, B * (k - 1), Z, starts[k - 1], Z, starts[k], ncols[k - 1])
        _forward(L, B * k, Z, starts[k], ncols[k])


@njit(cache=True, fastmath=FAST)
def _up(L, H, starts, Z):
    """``Z <- C^-T Z`` (m, r), in place."""
    nb = len(starts)
    for k in range(nb - 1, -1, -1):
        if k < nb - 1:
            _minus_nn(H, B * k, Z, starts[k + 1], Z, starts[k])
        _backward(L, B * k, Z, starts[k])


@njit(cache=True, fastmath=FAST)
def _times_Bt(G, own, n_own, starts, v, out):
    """``out = B' v`` (n) on the nonzero blocks of ``B``."""
    for c in range(len(out)):
        out[c] = 0.0
    for k in range(len(starts)):
        s = starts[k]
        for p in range(n_own[k]):
            acc = 0.0
            for i in range(B):
                acc += G[B * k + i, p] * v[s + i]
            out[own[k, p]] += acc


@njit(cache=True, fastmath=FAST)
def _times_B(G, own, n_own, starts, y, out):
    """``out = B y`` (m) on the nonzero blocks of ``B`` (six running sums per block)."""
    for k in range(len(starts)):
        a0 = a1 = a2 = a3 = a4 = a5 = 0.0
        o = B * k
        for p in range(n_own[k]):
            f = y[own[k, p]]
            a0 += G[o, p] * f
            a1 += G[o + 1, p] * f
            a2 += G[o + 2, p] * f
            a3 += G[o + 3, p] * f
            a4 += G[o + 4, p] * f
            a5 += G[o + 5, p] * f
        s = starts[k]
        out[s] = a0
        out[s + 1] = a1
        out[s + 2] = a2
        out[s + 3] = a3
        out[s + 4] = a4
        out[s + 5] = a5


@njit(cache=True)
def _solve_pinned(M, q, pinned, lam, delta, S, idx):
    """``lam_P = -(M_PP + delta I)^-1 q_P``, zero elsewhere (Gaussian elimination with
    partial pivoting on the pinned block); ``S`` (k, k + 1) and ``idx`` (k) scratch.
    """
    k = len(q)
    p = 0
    for i in range(k):
        if pinned[i]:
            idx[p] = i
            p += 1
    for i in range(p):
        for j in range(p):
            S[i, j] = M[idx[i], idx[j]]
        S[i, i] += delta
        S[i, p] = -q[idx[i]]
    for c in range(p):
        piv = c
        for r in range(c + 1, p):
            if abs(S[r, c]) > abs(S[piv, c]):
                piv = r
        if piv != c:
            for j in range(p + 1):
                S[c, j], S[piv, j] = S[piv, j], S[c, j]
        for r in range(c + 1, p):
            f = S[r, c] / S[c, c]
            for j in range(c, p + 1):
                S[r, j] -= f * S[c, j]
    for i in range(k):
        lam[i] = 0.0
    for i in range(p - 1, -1, -1):
        acc = S[i, p]
        for j in range(i + 1, p):
            acc -= S[i, j] * lam[idx[j]]
        lam[idx[i]] = acc / S[i, i]


@njit(cache=True)
def _lcp(M, q, params, lam, scratch):
    """``0 <= lam ⟂ M lam + q >= 0`` of one instant by the primal-dual active set of
    ``numpy_batched_._active_set``: ``(steps, settled)``; ``params`` as
    :func:`least_norm`'s (``max_iter``, ``lcp_rtol``, ``lcp_delta`` from the third on).
    """
    max_iter, rtol, delta = params[2], params[3], params[4]
    pinned, nxt, S, idx = scratch
    k = len(q)
    eps = rtol * max(1.0, np.abs(q).max()) if k else 0.0
    for i in range(k):
        pinned[i] = q[i] < 0
    for step in range(1, max_iter + 1):
        _solve_pinned(M, q, pinned, lam, delta, S, idx)
        same = True
        for i in range(k):
            if pinned[i]:
                nxt[i] = lam[i] > -eps
            else:
                w = q[i]
                for j in range(k):
                    w += M[i, j] * lam[j]
                nxt[i] = w < -eps
            same = same and nxt[i] == pinned[i]
        for i in range(k):
            pinned[i] = nxt[i]
        if same:
            return step, True
    return max_iter, False


@njit(cache=True)
def active_set(M, q, max_iter, rtol, delta):
    """:func:`_lcp` at every instant of a stack ``M`` (T, k, k), ``q`` (T, k):
    ``(lam, iterations, settled)``.
    """
    T, k = q.shape
    lam = np.zeros((T, k))
    iterations = np.zeros(T, np.int64)
    settled = np.zeros(T, np.bool_)
    pinned, nxt = np.empty(k, np.bool_), np.empty(k, np.bool_)
    scratch = (pinned, nxt, np.empty((k, k + 1)), np.empty(k, np.int64))
    for t in range(T):
        iterations[t], settled[t] = _lcp(M[t], q[t], (0.0, 0.0, max_iter, rtol, delta),
                                         lam[t], scratch)
    return lam, iterations, settled




@njit(cache=True, fastmath=FAST)
def _rows(A, root, t, starts, own, n_own, G):
    """Instant ``t``'s block rows of ``B = A W^-1/2``: ``G[6k + i, p] = A[t, s_k + i, c] /
    sqrt(w_c)`` for the columns ``c = own[k, p]`` touching body ``k`` (``root`` with no
    rows: ``W = I``).
    """
    for k in range(len(starts)):
        s = starts[k]
        for p in range(n_own[k]):
            c = own[k, p]
            for i in range(B):
                G[B * k + i, p] = A[t, s + i, c] / root[t, c] if root.shape[0] else A[t, s + i, c]


@njit(cache=True)
def _rhs(G, b, starts, upos, R):
    """The right-hand sides ``R = [b, U]`` (m, 1 + k) of one instant, ``U = B[:, u]``."""
    for k in range(len(starts)):
        s = starts[k]
        for i in range(B):
            R[s + i, 0] = b[s + i]
            for j in range(upos.shape[1]):
                R[s + i, 1 + j] = G[B * k + i, upos[k, j]] if upos[k, j] >= 0 else 0.0


@njit(cache=True, fastmath=FAST)
def _inexact(G, own, n_own, starts, b, mu, v, w, rtol):
    """Whether ``K mu = b`` leaves ``||b - B B' mu|| > rtol ||b||``: the bias of ``delta``
    calls for a step of iterative refinement (``v``, ``w`` scratch).
    """
    _times_Bt(G, own, n_own, starts, mu, v)
    _times_B(G, own, n_own, starts, v, w)
    res, size = 0.0, 0.0
    for i in range(len(b)):
        res += (b[i] - w[i]) ** 2
        size += b[i] ** 2
    return np.sqrt(res) > rtol * max(np.sqrt(size), TINY)


@njit(cache=True, fastmath=FAST)
def _refine(G, own, n_own, starts, R, Z, dZ, L, H, v, w, z, every):
    """One step of iterative refinement of ``K Z = R`` with the exact ``B B'``:
    ``Z += K^-1 (R - B B' Z)`` (``v``, ``w``, ``z`` scratch; ``every`` (nb) the column
    count ``r`` per body).
    """
    m, r = R.shape
    for c in range(r):
        for i in range(m):
            z[i] = Z[i, c]
        _times_Bt(G, own, n_own, starts, z, v)
        _times_B(G, own, n_own, starts, v, w)
        for i in range(m):
            dZ[i, c] = R[i, c] - w[i]
    _down(L, H, starts, dZ, every)
    _up(L, H, starts, dZ)
    for i in range(m):
        for c in range(r):
            Z[i, c] += dZ[i, c]


@njit(cache=True, fastmath=FAST)
def _faces_reduced(Y, starts, first, M, q):
    """The end faces' LCP of one instant from ``Y = C^-1 [b, U]`` (m, 1 + k): ``M = I -
    V'V`` and ``q = V' Y_0`` with ``V = Y[:, 1:]`` (``U' K^-1 U = V'V``, ``U' K^-1 b =
    V' Y_0``), without solving back up for each face. Face ``i``'s column is zero above
    body ``first[i]`` in chain order (the faces sorted by it); the products are summed
    body by body, six rows at a time.
    """
    nf = len(q)
    for i in range(nf):
        q[i] = 0.0
        for j in range(i + 1):
            M[i, j] = 0.0
    for k in range(len(starts)):
        s = starts[k]
        for i in range(nf):
            if first[i] > k:
                break
            acc = 0.0
            for r in range(B):
                acc += Y[s + r, 1 + i] * Y[s + r, 0]
            q[i] += acc
            for j in range(i + 1):
                acc = 0.0
                for r in range(B):
                    acc += Y[s + r, 1 + i] * Y[s + r, 1 + j]
                M[i, j] -= acc
    for i in range(nf):
        for j in range(i):
            M[j, i] = M[i, j]
        M[i, i] += 1.0


@njit(cache=True, fastmath=FAST)
def _faces(G, starts, upos, Z, M, q):
    """The end faces' LCP of one instant: ``M = I - U' K^-1 U`` and ``q = U' mu`` with
    ``U = B[:, u]`` (face ``j`` is column ``upos[k, j]`` of body ``k``'s block rows, or
    absent there when negative), ``mu = Z[:, 0]`` and ``K^-1 U = Z[:, 1:]``.
    """
    nf = len(q)
    for i in range(nf):
        q[i] = 0.0
        for j in range(nf):
            M[i, j] = 0.0
        for k in range(len(starts)):
            p = upos[k, i]
            if p < 0:
                continue
            s = starts[k]
            for r in range(B):
                g = G[B * k + r, p]
                q[i] += g * Z[s + r, 0]
                for j in range(nf):
                    M[i, j] -= g * Z[s + r, 1 + j]
        M[i, i] += 1.0


@njit(cache=True)
def least_norm(A, b, root, u, layout, params):
    """Least ``1/2 x'Wx`` on ``A x = b`` (``x[u] >= 0``) at every instant, as
    ``numpy_batched_.least_norm``: ``(x, mu, lam, iterations, settled)``, ``lam`` the
    end faces' LCP solution (``nu_u = sqrt(w_u) lam``); ``root`` (T, n) is ``sqrt(w)``,
    or has no rows for ``W = I``. Where ``settled`` is false the active set did not
    settle in ``max_iter`` steps and ``lam`` is its last step. ``params``: ``(gram_rtol,
    refine_rtol, max_iter, lcp_rtol, lcp_delta)``.

    ``layout`` (``numpy_batched_._layout``): body blocks in chain order from row
    ``starts[k]``, the columns ``own[k, :n_own[k]]`` touching body ``k``, the positions
    ``sh_a[k]``, ``sh_b[k]`` (in ``own[k]``, ``own[k+1]``) of the ``n_sh[k]`` columns
    touching bodies ``k`` and ``k+1``, ``upos[k, j]`` the position of face ``u[j]`` in
    ``own[k]`` (-1: absent), ``first[j]`` the first body face ``j`` touches (the faces
    sorted by it) and ``ncols[k]`` one plus the number of faces touching bodies up to
    ``k``.
    """
    T, m, n = A.shape
    x, mu = np.empty((T, n)), np.empty((T, m))
    lam = np.zeros((T, len(u)))
    iterations = np.zeros(T, np.int64)
    settled = np.ones(T, np.bool_)
    _span(0, T, A, b, root, u, layout, params, x, mu, lam, iterations, settled)
    return x, mu, lam, iterations, settled


@njit(cache=True)
def _span(lo, hi, A, b, root, u, layout, params, x, mu, lam, iterations, settled):
    """Instants ``lo`` to ``hi - 1`` of :func:`least_norm`, with their own scratch."""
    starts, own, n_own, sh_a, sh_b, n_sh, upos, first, ncols = layout
    gram_rtol, refine_rtol = params[0], params[1]
    m, n, nb, nf = A.shape[1], A.shape[2], len(starts), len(u)
    G = np.zeros((B * nb, own.shape[1]))
    L, H = np.empty((B * nb, B)), np.empty((B * nb, B))
    Sa, Sb = np.empty((B, sh_a.shape[1])), np.empty((B, sh_a.shape[1]))
    R, Z, dZ = np.empty((m, 1 + nf)), np.empty((m, 1 + nf)), np.empty((m, 1 + nf))
    v, w, z = np.empty(n), np.empty(m), np.empty(m)
    y, y1 = np.empty((m, 1)), np.zeros((m, 1))
    M, q = np.empty((nf, nf)), np.empty(nf)
    lcp = (np.empty(nf, np.bool_), np.empty(nf, np.bool_), np.empty((nf, nf + 1)),
           np.empty(nf, np.int64))
    every = np.empty(nb, np.int64)
    for k in range(nb):
        every[k] = 1 + nf
    for t in range(lo, hi):
        _rows(A, root, t, starts, own, n_own, G)
        _factor(G, n_own, sh_a, sh_b, n_sh, gram_rtol, L, H, Sa, Sb)
        _rhs(G, b[t], starts, upos, Z)
        _down(L, H, starts, Z, ncols)
        _column(Z, 0, y)
        _up(L, H, starts, y)
        for i in range(m):
            z[i] = y[i, 0]
        if _inexact(G, own, n_own, starts, b[t], z, v, w, refine_rtol):
            _rhs(G, b[t], starts, upos, R)
            _up(L, H, starts, Z)
            _refine(G, own, n_own, starts, R, Z, dZ, L, H, v, w, z, every)
            if nf:
                _faces(G, starts, upos, Z, M, q)
                iterations[t], settled[t] = _lcp(M, q, params, lam[t], lcp)
            _column(Z, 0, y)
            _times_Z1(Z, lam[t], y1)
        elif nf:
            _faces_reduced(Z, starts, first, M, q)
            iterations[t], settled[t] = _lcp(M, q, params, lam[t], lcp)
            _times_Z1(Z, lam[t], y1)
            _up(L, H, starts, y1)
        for i in range(m):
            mu[t, i] = y[i, 0] - y1[i, 0]
        _times_Bt(G, own, n_own, starts, mu[t], v)
        for j in range(nf):
            v[u[j]] += lam[t, j]
        for c in range(n):
            x[t, c] = v[c] / root[t, c] if root.shape[0] else v[c]


@njit(cache=True)
def _column(Z, c, out):
    """``out[:, 0] = Z[:, c]``."""
    for i in range(Z.shape[0]):
        out[i, 0] = Z[i, c]


@njit(cache=True, fastmath=FAST)
def _times_Z1(Z, lam, out):
    """``out[:, 0] = Z[:, 1:] lam``."""
    for i in range(Z.shape[0]):
        acc = 0.0
        for j in range(len(lam)):
            acc += Z[i, 1 + j] * lam[j]
        out[i, 0] = acc
