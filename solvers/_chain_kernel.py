"""Compiled block-tridiagonal solve for ``numpy-batched`` (numba, optional extra ``numba``).

The same block elimination as ``numpy_batched_.chain_solve`` — ``D_k = K_kk - K_k,k-1
D_k-1^{-1} K_k-1,k`` along the chain of 6 x 6 body blocks, here with a Cholesky factor
of each ``D_k`` (positive definite for a positive definite ``K``) — written as loops over
the instants that numba compiles: NumPy's batched 6 x 6 inverses and products pay a
LAPACK or loop overhead per matrix that is larger than the arithmetic.
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


@njit(cache=True)
def chain_solve(K, R, starts):
    """``K^{-1} R`` for (T, m, m) ``K`` block tridiagonal along the 6-row blocks that
    start at ``starts`` (chain order); ``R`` (T, m, r)."""
    T, r, nb = K.shape[0], R.shape[2], len(starts)
    out = np.empty_like(R)
    L = np.empty((B, B))
    G = np.empty((nb, B, B))
    Y = np.empty((nb, B, r))
    for t in range(T):
        for k in range(nb):
            s = starts[k]
            for i in range(B):
                for j in range(B):
                    L[i, j] = K[t, s + i, s + j]
                for c in range(r):
                    Y[k, i, c] = R[t, s + i, c]
            if k > 0:
                p = starts[k - 1]
                for i in range(B):
                    for j in range(B):
                        acc = 0.0
                        for q in range(B):
                            acc += K[t, s + i, p + q] * G[k - 1, q, j]
                        L[i, j] -= acc
                    for c in range(r):
                        acc = 0.0
                        for q in range(B):
                            acc += K[t, s + i, p + q] * Y[k - 1, q, c]
                        Y[k, i, c] -= acc
            _cholesky(L)
            _cho_solve(L, Y[k])
            if k < nb - 1:
                n = starts[k + 1]
                for i in range(B):
                    for j in range(B):
                        G[k, i, j] = K[t, s + i, n + j]
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
