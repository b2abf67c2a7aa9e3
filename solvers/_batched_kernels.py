"""Compiled least norm of ``numpy-batched``, 64 instants at a time (numba, extra ``numba``).

The same method as the NumPy path of :mod:`.numpy_batched_` — the Gram matrix ``K = B
B' + delta I`` by block elimination along the chain of 6 x 6 body blocks (``D_k = K_kk
- K_k,k-1 D_k-1^{-1} K_k-1,k``, here with a Cholesky factor of each ``D_k``), one step of
iterative refinement where an instant's residual asks for it, the end faces' LCP by the
primal-dual active set — fused into one pass over the instants: each group of
:data:`W` instants keeps its numbers in scratch that stays in cache from its scaled
rows to its forces, no (T, ...) intermediate is allocated, and only the nonzero blocks
of ``B`` are touched (a contact column loads at most two bodies).

Every array of a group has the instants as its last axis (``X[i, j, e]``: entry ``(i,
j)`` of the group's instant ``e``), so that each step's innermost loop runs over the
instants with the same arithmetic in every lane, and LLVM's loop vectorizer turns it
into vector instructions. Eight lanes were too few: such a loop is unrolled into scalar
code (numba leaves LLVM's SLP vectorizer off), and was slower on ``paper``'s
least-norm family. The LCP, whose active set
differs between instants, is solved one instant after the other. A group short of
:data:`W` instants (the batch's last) repeats its last instant in the lanes left over.

No operation mixes lanes, sums run in a fixed order and nothing is fused or
reassociated (no fastmath: every operation rounds as IEEE 754 says, in a vector lane
as in the scalar copy of a loop that LLVM keeps beside it), so an instant's answer is
the same whatever else is in its batch and wherever it sits in its group. Compiling
takes about half a minute, once: numba caches the machine code.
"""

from __future__ import annotations

import numpy as np

from cardan_forces.util.compiled import HAVE_NUMBA, njit

from ._batched_state import ActiveSetScratch, Answers, Group, LcpScratch, Refinement

if not HAVE_NUMBA:  # an optional extra: the callers take their NumPy paths
    raise ImportError("numba is not installed")

B = 6
"""Rows per body block."""

W = 64
"""Instants per group: the lanes of the innermost loops (eight vectors of eight
doubles; a group's arrays, about 0.6 MB on ``paper``, fit a 1 MB second-level cache)."""

TINY = float(np.finfo(float).tiny)
"""Smallest normal double: the floor of ``||b||`` in the refinement test."""



@njit(cache=True)
def _rows(A, root, ts, starts, own, n_own, G, scale):
    """The group's block rows of ``B = A W^-1/2`` (instants ``ts``): ``G[6k + i, p, e] =
    A[ts[e], s_k + i, c] / sqrt(w_c)`` for the columns ``c = own[k, p]`` touching body
    ``k`` (``root`` with no rows: ``W = I``), as a product with the reciprocal (one
    division per column, not per entry); ``scale`` (W) scratch.
    """
    for k in range(len(starts)):
        s = starts[k]
        for p in range(n_own[k]):
            c = own[k, p]
            for e in range(W):
                scale[e] = 1.0 / root[ts[e], c] if root.shape[0] else 1.0
            for i in range(B):
                for e in range(W):
                    G[B * k + i, p, e] = A[ts[e], s + i, c] * scale[e]


@njit(cache=True)
def _gram(G, n_own, sh_a, sh_b, n_sh, L, H):
    """The Gram blocks of the group: the lower triangles of ``K_kk`` into ``L[6k:6k+6]``
    and ``K_k,k+1`` into ``H[6k:6k+6]`` (from the columns touching both bodies).
    """
    nb = len(n_own)
    for k in range(nb):
        o = B * k
        for i in range(B):
            for j in range(i + 1):
                for e in range(W):
                    L[o + i, j, e] = 0.0
                for p in range(n_own[k]):
                    for e in range(W):
                        L[o + i, j, e] += G[o + i, p, e] * G[o + j, p, e]
        if k < nb - 1:
            for i in range(B):
                for j in range(B):
                    for e in range(W):
                        H[o + i, j, e] = 0.0
                    for p in range(n_sh[k]):
                        a, c = sh_a[k, p], sh_b[k, p]
                        for e in range(W):
                            H[o + i, j, e] += G[o + i, a, e] * G[o + B + j, c, e]


@njit(cache=True)
def _cholesky(L, o):
    """Lower Cholesky factor of the 6 x 6 positive definite blocks ``L[o:o+6]`` in place
    (lower triangles), with the reciprocals of their diagonals on the diagonal.
    """
    for j in range(B):
        for k in range(j):
            for e in range(W):
                L[o + j, j, e] -= L[o + j, k, e] * L[o + j, k, e]
        for e in range(W):
            L[o + j, j, e] = 1.0 / np.sqrt(L[o + j, j, e])
        for i in range(j + 1, B):
            for k in range(j):
                for e in range(W):
                    L[o + i, j, e] -= L[o + i, k, e] * L[o + j, k, e]
            for e in range(W):
                L[o + i, j, e] *= L[o + j, j, e]


@njit(cache=True)
def _factor(G, n_own, sh_a, sh_b, n_sh, rtol, L, H):
    """Factor ``K = B B' + delta I = C C'`` of the group, ``delta = rtol * trace(B B') /
    m`` per instant, from its block rows ``G`` (row ``6k + i``: body ``k``'s row ``i`` on
    the columns touching it). ``C`` is block lower bidiagonal along the chain: diagonal
    blocks ``L[6k:6k+6]``, the Cholesky factors of the pivots ``D_k = K_kk - H_k-1'
    H_k-1``, and below them ``H[6k:6k+6]'`` with ``H_k = L_k^-1 K_k,k+1``.
    """
    nb = len(n_own)
    _gram(G, n_own, sh_a, sh_b, n_sh, L, H)
    delta = np.zeros(W)
    for k in range(nb):
        for i in range(B):
            for e in range(W):
                delta[e] += L[B * k + i, i, e]
    for e in range(W):
        delta[e] *= rtol / (nb * B)
    for k in range(nb):
        o = B * k
        for i in range(B):
            for e in range(W):
                L[o + i, i, e] += delta[e]
        if k > 0:
            for i in range(B):
                for j in range(i + 1):
                    for p in range(B):
                        for e in range(W):
                            L[o + i, j, e] -= H[o - B + p, i, e] * H[o - B + p, j, e]
        _cholesky(L, o)
        if k < nb - 1:
            _forward(L, o, H, o, B)


@njit(cache=True)
def _forward(L, o, X, s, nc):
    """``X[s:s+6, :nc] <- L^-1 X[s:s+6, :nc]``, ``L = L[o:o+6]`` from :func:`_cholesky`."""
    for c in range(nc):
        for i in range(B):
            for k in range(i):
                for e in range(W):
                    X[s + i, c, e] -= L[o + i, k, e] * X[s + k, c, e]
            for e in range(W):
                X[s + i, c, e] *= L[o + i, i, e]


@njit(cache=True)
def _backward(L, o, X, s):
    """``X[s:s+6] <- L^-T X[s:s+6]``, ``L = L[o:o+6]`` from :func:`_cholesky`."""
    for c in range(X.shape[1]):
        for i in range(B - 1, -1, -1):
            for k in range(i + 1, B):
                for e in range(W):
                    X[s + i, c, e] -= L[o + k, i, e] * X[s + k, c, e]
            for e in range(W):
                X[s + i, c, e] *= L[o + i, i, e]


@njit(cache=True)
def _down(L, H, starts, Z, ncols):
    """``Z <- C^-1 Z`` (m, r, W) with :func:`_factor`'s ``K = C C'``, in place, where the
    columns from ``ncols[k]`` on are zero down to body ``k`` (and stay zero).
    """
    for k in range(len(starts)):
        if k > 0:  # Z_k -= H_k-1' Z_k-1
            s, o, h = starts[k], starts[k - 1], B * (k - 1)
            for i in range(B):
                for c in range(ncols[k - 1]):
                    for p in range(B):
                        for e in range(W):
                            Z[s + i, c, e] -= H[h + p, i, e] * Z[o + p, c, e]
        _forward(L, B * k, Z, starts[k], ncols[k])


@njit(cache=True)
def _up(L, H, starts, Z):
    """``Z <- C^-T Z`` (m, r, W), in place."""
    nb = len(starts)
    for k in range(nb - 1, -1, -1):
        if k < nb - 1:  # Z_k -= H_k Z_k+1
            s, o = starts[k], starts[k + 1]
            for i in range(B):
                for c in range(Z.shape[1]):
                    for p in range(B):
                        for e in range(W):
                            Z[s + i, c, e] -= H[B * k + i, p, e] * Z[o + p, c, e]
        _backward(L, B * k, Z, starts[k])


@njit(cache=True)
def _times_Bt(G, own, n_own, starts, v, c_in, out):
    """``out = B' v[:, c_in]`` (n, W) on the nonzero blocks of ``B``."""
    out[:] = 0.0
    for k in range(len(starts)):
        s = starts[k]
        for p in range(n_own[k]):
            c = own[k, p]
            for i in range(B):
                for e in range(W):
                    out[c, e] += G[B * k + i, p, e] * v[s + i, c_in, e]


@njit(cache=True)
def _times_B(G, own, n_own, starts, y, out):
    """``out = B y`` (m, W) on the nonzero blocks of ``B``."""
    for k in range(len(starts)):
        s = starts[k]
        for i in range(B):
            for e in range(W):
                out[s + i, e] = 0.0
            for p in range(n_own[k]):
                c = own[k, p]
                for e in range(W):
                    out[s + i, e] += G[B * k + i, p, e] * y[c, e]


@njit(cache=True)
def _rhs(G, b, ts, starts, upos, R):
    """The right-hand sides ``R = [b, U]`` (m, 1 + k, W) of the group, ``U = B[:, u]``."""
    for k in range(len(starts)):
        s = starts[k]
        for i in range(B):
            for e in range(W):
                R[s + i, 0, e] = b[ts[e], s + i]
            for j in range(upos.shape[1]):
                p = upos[k, j]
                for e in range(W):
                    R[s + i, 1 + j, e] = G[B * k + i, p, e] if p >= 0 else 0.0


@njit(cache=True)
def _inexact(G, own, n_own, starts, b, ts, y, v, w, rtol, out):
    """Per instant whether ``K mu = b`` (``mu = y[:, 0]``) leaves ``||b - B B' mu|| > rtol
    ||b||``: the bias of ``delta`` calls for a step of iterative refinement (``v``,
    ``w`` scratch); ``out`` (W) booleans. Whether any does.
    """
    _times_Bt(G, own, n_own, starts, y, 0, v)
    _times_B(G, own, n_own, starts, v, w)
    res, size = np.zeros(W), np.zeros(W)
    for i in range(len(w)):
        for e in range(W):
            bi = b[ts[e], i]
            res[e] += (bi - w[i, e]) ** 2
            size[e] += bi ** 2
    for e in range(W):
        out[e] = np.sqrt(res[e]) > rtol * max(np.sqrt(size[e]), TINY)
    return out.any()


@njit(cache=True)
def _refined(g: Group, layout, b, ts):
    """``K^-1 [b, U]`` (m, 1 + nf, W) into ``g.refined.Z`` from ``g.Z = C^-1 [b, U]``,
    with one step of iterative refinement on the exact ``B B'``: ``Z += K^-1 (R - B B'
    Z)``.
    """
    r = g.refined
    Z, R, dZ = r.Z, r.R, r.dZ
    m, nc = Z.shape[0], Z.shape[1]
    _rhs(g.G, b, ts, layout.starts, layout.upos, R)
    Z[:] = g.Z
    _up(g.L, g.H, layout.starts, Z)
    for c in range(nc):
        _times_Bt(g.G, layout.own, layout.n_own, layout.starts, Z, c, r.v)
        _times_B(g.G, layout.own, layout.n_own, layout.starts, r.v, r.w)
        for i in range(m):
            for e in range(W):
                dZ[i, c, e] = R[i, c, e] - r.w[i, e]
    _down(g.L, g.H, layout.starts, dZ, r.every)
    _up(g.L, g.H, layout.starts, dZ)
    for i in range(m):
        for c in range(nc):
            for e in range(W):
                Z[i, c, e] += dZ[i, c, e]


@njit(cache=True)
def _faces_reduced(Y, starts, first, M, q):
    """The end faces' LCP of the group from ``Y = C^-1 [b, U]`` (m, 1 + k, W): ``M = I -
    V'V`` and ``q = V' Y_0`` with ``V = Y[:, 1:]`` (``U' K^-1 U = V'V``, ``U' K^-1 b =
    V' Y_0``), without solving back up for each face. Face ``i``'s column is zero above
    body ``first[i]`` in chain order (the faces sorted by it); the products are summed
    body by body, six rows at a time.
    """
    nf = q.shape[0]
    M[:] = 0.0
    q[:] = 0.0
    for k in range(len(starts)):
        s = starts[k]
        for i in range(nf):
            if first[i] > k:
                break
            for r in range(B):
                for e in range(W):
                    q[i, e] += Y[s + r, 1 + i, e] * Y[s + r, 0, e]
            for j in range(i + 1):
                for r in range(B):
                    for e in range(W):
                        M[i, j, e] -= Y[s + r, 1 + i, e] * Y[s + r, 1 + j, e]
    for i in range(nf):
        for j in range(i):
            for e in range(W):
                M[j, i, e] = M[i, j, e]
        for e in range(W):
            M[i, i, e] += 1.0


@njit(cache=True)
def _faces(G, starts, upos, Z, M, q):
    """The end faces' LCP of the group: ``M = I - U' K^-1 U`` and ``q = U' mu`` with
    ``U = B[:, u]`` (face ``j`` is column ``upos[k, j]`` of body ``k``'s block rows, or
    absent there when negative), ``mu = Z[:, 0]`` and ``K^-1 U = Z[:, 1:]``.
    """
    nf = q.shape[0]
    M[:] = 0.0
    q[:] = 0.0
    for i in range(nf):
        for k in range(len(starts)):
            p = upos[k, i]
            if p < 0:
                continue
            s = starts[k]
            for r in range(B):
                for e in range(W):
                    q[i, e] += G[B * k + r, p, e] * Z[s + r, 0, e]
                for j in range(nf):
                    for e in range(W):
                        M[i, j, e] -= G[B * k + r, p, e] * Z[s + r, 1 + j, e]
        for e in range(W):
            M[i, i, e] += 1.0


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
def _lcp(M, q, max_iter, rtol, delta, lam, a: ActiveSetScratch):
    """``0 <= lam ⟂ M lam + q >= 0`` of one instant by the primal-dual active set of
    ``numpy_batched_._active_set`` (sign tolerance ``rtol`` relative to ``max(1, max
    |q|)``, the pinned block regularized by ``delta``): ``(steps, settled)``.
    """
    k = len(q)
    eps = rtol * max(1.0, np.abs(q).max()) if k else 0.0
    for i in range(k):
        a.pinned[i] = q[i] < 0
    for step in range(1, max_iter + 1):
        _solve_pinned(M, q, a.pinned, lam, delta, a.S, a.idx)
        same = True
        for i in range(k):
            if a.pinned[i]:
                a.nxt[i] = lam[i] > -eps
            else:
                w = q[i]
                for j in range(k):
                    w += M[i, j] * lam[j]
                a.nxt[i] = w < -eps
            same = same and a.nxt[i] == a.pinned[i]
        for i in range(k):
            a.pinned[i] = a.nxt[i]
        if same:
            return step, True
    return max_iter, False


@njit(cache=True)
def _active_set_scratch(k):
    """An :class:`ActiveSetScratch` for ``k`` faces."""
    return ActiveSetScratch(np.empty(k, np.bool_), np.empty(k, np.bool_),
                            np.empty((k, k + 1)), np.empty(k, np.int64))


@njit(cache=True)
def active_set(M, q, max_iter, rtol, delta):
    """:func:`_lcp` at every instant of a stack ``M`` (T, k, k), ``q`` (T, k):
    ``(lam, iterations, settled)``.
    """
    T, k = q.shape
    lam = np.zeros((T, k))
    iterations = np.zeros(T, np.int64)
    settled = np.zeros(T, np.bool_)
    scratch = _active_set_scratch(k)
    for t in range(T):
        iterations[t], settled[t] = _lcp(M[t], q[t], max_iter, rtol, delta, lam[t], scratch)
    return lam, iterations, settled


@njit(cache=True)
def _lcps(g: Group, params, ts, count, out: Answers):
    """The group's LCPs one instant after the other (their active sets differ):
    ``(g.M, g.q)``, or ``(g.Mr, g.qr)`` where ``g.refine``; their solutions into
    ``g.lam``, their steps into ``out``.
    """
    one = g.lcp
    nf = one.q.shape[0]
    for e in range(count):
        for i in range(nf):
            one.q[i] = g.qr[i, e] if g.refine[e] else g.q[i, e]
            for j in range(nf):
                one.M[i, j] = g.Mr[i, j, e] if g.refine[e] else g.M[i, j, e]
        out.iterations[ts[e]], out.settled[ts[e]] = _lcp(
            one.M, one.q, params.max_iter, params.lcp_rtol, params.lcp_delta, one.lam,
            one.active)
        for i in range(nf):
            g.lam[i, e] = one.lam[i]


@njit(cache=True)
def least_norm(A, b, root, u, layout, params):
    """Least ``1/2 x'Wx`` on ``A x = b`` (``x[u] >= 0``) at every instant, as
    ``numpy_batched_.least_norm``: :class:`Answers`, ``lam`` the end faces' LCP solution
    (``nu_u = sqrt(w_u) lam``); ``root`` (T, n) is ``sqrt(w)``, or has no rows for ``W =
    I``. Where ``settled`` is false the active set did not settle in ``max_iter`` steps
    and ``lam`` is its last step. ``layout``: the rows' structure
    (``numpy_batched_.Layout``); ``params``: the tolerances (``numpy_batched_.Params``).
    """
    T, m, n = A.shape
    out = Answers(np.empty((T, n)), np.empty((T, m)), np.zeros((T, len(u))),
                  np.zeros(T, np.int64), np.ones(T, np.bool_))
    g = _group_scratch(m, n, len(u), layout)
    ts = np.empty(W, np.int64)
    for t0 in range(0, T, W):
        count = min(W, T - t0)
        for e in range(W):
            ts[e] = t0 + min(e, count - 1)
        _group(A, b, root, u, layout, params, ts, count, g, out)
    return out


@njit(cache=True)
def _group_scratch(m, n, nf, layout):
    """The :class:`Group` one group of instants works in."""
    nb = len(layout.starts)
    refined = Refinement(np.empty((m, 1 + nf, W)), np.empty((m, 1 + nf, W)),
                         np.empty((m, 1 + nf, W)), np.empty((n, W)), np.empty((m, W)),
                         np.full(nb, 1 + nf, np.int64))
    lcp = LcpScratch(np.empty((nf, nf)), np.empty(nf), np.empty(nf), _active_set_scratch(nf))
    return Group(np.zeros((B * nb, layout.own.shape[1], W)), np.empty((B * nb, B, W)),
                 np.empty((B * nb, B, W)), np.empty((m, 1 + nf, W)), np.empty((m, 1, W)),
                 np.empty((m, 1, W)), np.empty((n, W)), np.empty((m, W)),
                 np.empty((nf, nf, W)), np.empty((nf, W)), np.empty((nf, nf, W)),
                 np.empty((nf, W)), np.empty(W, np.bool_), np.empty((nf, W)), refined, lcp)


@njit(cache=True)
def _group(A, b, root, u, layout, params, ts, count, g: Group, out: Answers):
    """The instants ``ts[:count]`` of :func:`least_norm` into ``out``."""
    starts, own, n_own = layout.starts, layout.own, layout.n_own
    m, n, nf = A.shape[1], A.shape[2], len(u)
    _rows(A, root, ts, starts, own, n_own, g.G, g.v[0])
    _factor(g.G, n_own, layout.sh_a, layout.sh_b, layout.n_sh, params.gram_rtol, g.L, g.H)
    _rhs(g.G, b, ts, starts, layout.upos, g.Z)
    _down(g.L, g.H, starts, g.Z, layout.ncols)
    for i in range(m):
        for e in range(W):
            g.y[i, 0, e] = g.Z[i, 0, e]
    _up(g.L, g.H, starts, g.y)
    any_refine = _inexact(g.G, own, n_own, starts, b, ts, g.y, g.v, g.w, params.refine_rtol,
                          g.refine)
    if nf:
        _faces_reduced(g.Z, starts, layout.first, g.M, g.q)
    if any_refine:
        _refined(g, layout, b, ts)
        if nf:
            _faces(g.G, starts, layout.upos, g.refined.Z, g.Mr, g.qr)
    g.lam[:] = 0.0
    if nf:
        _lcps(g, params, ts, count, out)
    _forces_of(g, starts, any_refine)
    _times_Bt(g.G, own, n_own, starts, g.y, 0, g.v)
    for j in range(nf):
        for e in range(W):
            g.v[u[j], e] += g.lam[j, e]
    for e in range(count):
        t = ts[e]
        for i in range(m):
            out.mu[t, i] = g.y[i, 0, e]
        for j in range(nf):
            out.lam[t, j] = g.lam[j, e]
        for c in range(n):
            out.x[t, c] = g.v[c, e] / root[t, c] if root.shape[0] else g.v[c, e]


@njit(cache=True)
def _forces_of(g: Group, starts, any_refine):
    """``mu = K^-1 (b - U lam)`` into ``g.y`` (m, 1, W): from ``g.Z = C^-1 [b, U]``
    (``g.y`` = ``C^-T Z_0``) as ``y - C^-T (Z_1 lam)``, or where ``g.refine`` from the
    refined ``K^-1 [b, U]`` as ``Z_0 - Z_1 lam``.
    """
    y, y1, refine = g.y, g.y1, g.refine
    m, nf = g.Z.shape[0], g.lam.shape[0]
    if any_refine:
        Z = g.refined.Z
        _times_faces(Z, g.lam, y1)
        for i in range(m):
            for e in range(W):
                if refine[e]:
                    y[i, 0, e] = Z[i, 0, e] - y1[i, 0, e]
    if not nf:  # no faces: Z_1 lam is zero, y stands
        return
    _times_faces(g.Z, g.lam, y1)
    _up(g.L, g.H, starts, y1)
    for i in range(m):
        for e in range(W):
            if not (any_refine and refine[e]):
                y[i, 0, e] -= y1[i, 0, e]


@njit(cache=True)
def _times_faces(X, lam, out):
    """``out = X[:, 1:] lam`` (m, 1, W): the face columns of ``X`` (m, 1 + nf, W) times
    the faces' forces ``lam`` (nf, W), lane by lane.
    """
    for i in range(X.shape[0]):
        for e in range(W):
            out[i, 0, e] = 0.0
        for j in range(lam.shape[0]):
            for e in range(W):
                out[i, 0, e] += X[i, 1 + j, e] * lam[j, e]
