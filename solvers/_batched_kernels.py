"""Compiled Gram and block-tridiagonal solve for ``numpy-batched`` (numba, extra ``numba``).

The same block elimination as ``numpy_batched_.chain_solve`` — ``D_k = K_kk - K_k,k-1
D_k-1^{-1} K_k-1,k`` along the chain of 6 x 6 body blocks, here with a Cholesky factor
of each ``D_k`` (positive definite for a positive definite ``K``) — written as loops over
the instants that numba compiles: NumPy's batched 6 x 6 inverses and products pay a
LAPACK or loop overhead per matrix that is larger than the arithmetic. Only the nonzero
blocks of ``K = B B'`` are formed (a contact column loads at most two bodies).
"""

from __future__ import annotations

import numpy as np
from numba import njit

B = 6
"""Rows per body block."""


@njit(cache=True)
def _cholesky(D):
    """Lower Cholesky factor of a 6 x 6 positive definite ``D`` (in place)."""
    for j in range(B):
        s = D[j, j]
        for k in range(j):
            s -= D[j, k] * D[j, k]
        D[j, j] = np.sqrt(s)
        for i in range(j + 1, B):
            s = D[i, j]
            for k in range(j):
                s -= D[i, k] * D[j, k]
            D[i, j] = s / D[j, j]


@njit(cache=True)
def _cho_solve(L, X):
    """``X <- (L L')^-1 X`` for a 6 x r right-hand side."""
    for c in range(X.shape[1]):
        for i in range(B):
            s = X[i, c]
            for k in range(i):
                s -= L[i, k] * X[k, c]
            X[i, c] = s / L[i, i]
        for i in range(B - 1, -1, -1):
            s = X[i, c]
            for k in range(i + 1, B):
                s -= L[k, i] * X[k, c]
            X[i, c] = s / L[i, i]


@njit(cache=True, fastmath=True)
def _gram_blocks(Bt, t, starts, own, n_own, shared, n_shared, rtol, Kd, Ko):
    """The nonzero blocks of ``K = B B' + delta I`` at instant ``t``, ``delta = rtol *
    trace(K) / rows``: diagonal ``Kd[k]`` (symmetric) from the columns touching block
    ``k``, off-diagonal ``Ko[k] = K[k, k+1]`` from the columns touching both (a contact
    loads at most two bodies).
    """
    nb = len(starts)
    trace = 0.0
    for k in range(nb):
        s = starts[k]
        for i in range(B):
            for j in range(i, B):
                acc = 0.0
                for q in range(n_own[k]):
                    c = own[k, q]
                    acc += Bt[t, s + i, c] * Bt[t, s + j, c]
                Kd[k, i, j] = acc
                Kd[k, j, i] = acc
            trace += Kd[k, i, i]
        if k < nb - 1:
            n = starts[k + 1]
            for i in range(B):
                for j in range(B):
                    acc = 0.0
                    for q in range(n_shared[k]):
                        c = shared[k, q]
                        acc += Bt[t, s + i, c] * Bt[t, n + j, c]
                    Ko[k, i, j] = acc
    delta = rtol * trace / (nb * B)
    for k in range(nb):
        for i in range(B):
            Kd[k, i, i] += delta


@njit(cache=True, fastmath=True)
def gram_chain_solve(Bt, R, starts, own, n_own, shared, n_shared, rtol):
    """``(B B' + delta I)^{-1} R`` per instant without forming ``B B'``: its blocks from
    the columns each body touches, then the block elimination of :func:`chain_solve`;
    ``delta = rtol * trace(B B') / rows``.
    """
    T, r, nb = Bt.shape[0], R.shape[2], len(starts)
    out = np.empty_like(R)
    Kd = np.empty((nb, B, B))
    Ko = np.empty((max(nb - 1, 1), B, B))
    L = np.empty((B, B))
    G = np.empty((nb, B, B))
    Y = np.empty((nb, B, r))
    for t in range(T):
        _gram_blocks(Bt, t, starts, own, n_own, shared, n_shared, rtol, Kd, Ko)
        for k in range(nb):
            s = starts[k]
            for i in range(B):
                for j in range(B):
                    L[i, j] = Kd[k, i, j]
                for c in range(r):
                    Y[k, i, c] = R[t, s + i, c]
            if k > 0:  # K[k, k-1] = Ko[k-1]'
                for i in range(B):
                    for j in range(B):
                        acc = 0.0
                        for q in range(B):
                            acc += Ko[k - 1, q, i] * G[k - 1, q, j]
                        L[i, j] -= acc
                    for c in range(r):
                        acc = 0.0
                        for q in range(B):
                            acc += Ko[k - 1, q, i] * Y[k - 1, q, c]
                        Y[k, i, c] -= acc
            _cholesky(L)
            _cho_solve(L, Y[k])
            if k < nb - 1:
                for i in range(B):
                    for j in range(B):
                        G[k, i, j] = Ko[k, i, j]
                _cho_solve(L, G[k])
        for k in range(nb - 1, -1, -1):
            s = starts[k]
            for i in range(B):
                for c in range(r):
                    acc = Y[k, i, c]
                    if k < nb - 1:
                        n = starts[k + 1]
                        for q in range(B):
                            acc -= G[k, i, q] * out[t, n + q, c]
                    out[t, s + i, c] = acc
    return out


@njit(cache=True)
def _solve_pinned(M, q, pinned, lam, delta):
    """``lam_P = -(M_PP + delta I)^-1 q_P``, zero elsewhere (Gaussian elimination with
    partial pivoting on the pinned block).
    """
    idx = np.flatnonzero(pinned)
    p = len(idx)
    S = np.empty((p, p + 1))
    for i in range(p):
        for j in range(p):
            S[i, j] = M[idx[i], idx[j]]
        S[i, i] += delta
        S[i, p] = -q[idx[i]]
    for c in range(p):
        piv = c + np.argmax(np.abs(S[c:, c]))
        if piv != c:
            for j in range(p + 1):
                S[c, j], S[piv, j] = S[piv, j], S[c, j]
        for r in range(c + 1, p):
            f = S[r, c] / S[c, c]
            for j in range(c, p + 1):
                S[r, j] -= f * S[c, j]
    lam[:] = 0.0
    for i in range(p - 1, -1, -1):
        acc = S[i, p]
        for j in range(i + 1, p):
            acc -= S[i, j] * lam[idx[j]]
        lam[idx[i]] = acc / S[i, i]


@njit(cache=True)
def active_set(M, q, max_iter, rtol, delta):
    """The primal-dual active-set method of ``numpy_batched_._active_set`` compiled, one
    instant after the other: ``(lam, iterations, settled)``.
    """
    T, k = q.shape
    lam = np.zeros((T, k))
    iterations = np.zeros(T, np.int64)
    settled = np.zeros(T, np.bool_)
    pinned = np.empty(k, np.bool_)
    nxt = np.empty(k, np.bool_)
    for t in range(T):
        eps = rtol * max(1.0, np.abs(q[t]).max())
        for i in range(k):
            pinned[i] = q[t, i] < 0
        for step in range(1, max_iter + 1):
            _solve_pinned(M[t], q[t], pinned, lam[t], delta)
            same = True
            for i in range(k):
                if pinned[i]:
                    nxt[i] = lam[t, i] > -eps
                else:
                    w = q[t, i]
                    for j in range(k):
                        w += M[t, i, j] * lam[t, j]
                    nxt[i] = w < -eps
                same = same and nxt[i] == pinned[i]
            iterations[t] = step
            pinned[:] = nxt
            if same:
                settled[t] = True
                break
    return lam, iterations, settled
