"""Compiled solve of the penalty integrator's Newton systems ``(I - c J) x = b``.

The LU factorization of ``I - c J`` works on what is left after the rows whose structure
is known are eliminated (:func:`_factor`: 30 x 30 on ``paper`` instead of 65 x 65),
block tridiagonal along the chain of bodies (shaft, pin, shaft, ...): factored block by
block, 6 x 6 blocks with pivoting inside each (:func:`_factor_chain`; LAPACK's
``getrf`` where the bodies form no chain), cheaper than ``getrf`` on the whole reduced
matrix; the rounding differs from ``getrf``'s, and over
six runs of each started 1e-15 apart the forces' 0.1 s averages, their spread and peaks
and the step counts did not differ beyond the runs' own spread (the rattle is chaotic).
A hand-written LU of the whole reduced matrix was no faster than ``getrf`` at 30 x 30.
The factors are one :class:`Factors`, made once per run (:func:`new_factors`).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from cardan_forces.util.compiled import HAVE_NUMBA

from .penalty_contact import kernel

if HAVE_NUMBA:
    from numba import types
    from numba.np.linalg import _LAPACK, F_INT_nptype

    _getrf = _LAPACK().numba_xxgetrf(types.float64)
else:  # pragma: no cover - the caller uses SciPy's integrators instead
    F_INT_nptype, _getrf = np.int32, None


class Chain(NamedTuple):
    """:func:`_factor_chain`'s factors: the chain's ``order`` (:func:`_chain_order`;
    empty: no chain, ``getrf`` instead), per block position (nb, 6, 6) the factored
    diagonal block ``diag``, the block ``below`` it and ``right``, ``D^-1`` times the
    block right of it; the diagonal blocks' row swaps ``pivots`` (nb, 6) and a scratch
    ``ys`` (nb, 6) for :func:`_solve_chain`.
    """

    order: np.ndarray
    diag: np.ndarray
    below: np.ndarray
    right: np.ndarray
    pivots: np.ndarray
    ys: np.ndarray


class Factors(NamedTuple):
    """:func:`_factor`'s elimination and factors of ``I - c J``: the reduced matrix's
    LAPACK ``lu`` (m, m), held transposed, and its ``pivots`` (m,) (``m = 6 nb``; unused
    where the bodies form a chain), the quaternion ``blocks`` ``A_k^-1`` (nb, 4, 4),
    the ``coupling`` ``A_k^-1 J_qw`` (nb, 4, 3), the bodies' ``linked``
    (:func:`penalty_jacobian._linked`) and the block factors of the ``chain``.
    """

    lu: np.ndarray
    pivots: np.ndarray
    blocks: np.ndarray
    coupling: np.ndarray
    linked: np.ndarray
    chain: Chain


@kernel()
def new_factors(linked):
    """Zeroed :class:`Factors` for the bodies ``linked`` (:func:`_linked`)."""
    nb = linked.shape[0]
    m = 6 * nb
    return Factors(lu=np.zeros((m, m)), pivots=np.zeros(m, dtype=F_INT_nptype),
                   blocks=np.zeros((nb, 4, 4)), coupling=np.zeros((nb, 4, 3)), linked=linked,
                   chain=_new_chain(linked))


@kernel()
def _factor(jac, c, factors):
    """Factor ``M = I - c J`` for :func:`_solve`, eliminating first what the equations'
    structure gives (state layout of :class:`penalty._Model`): the displacement rows
    read ``x_u - c x_v = b_u`` and each body's quaternion rows involve only its own
    quaternion and rate, ``A_k x_q - c J_qw x_w = b_q`` (``A_k = I - c J_qq``, 4 x 4).
    What is left is the ``6 nb`` rows of the velocities and rates,
    ``M_rr + c M_ru E_v + c M_rq A^-1 J_qw``, factored by LAPACK's ``getrf`` into
    ``factors.lu`` (held transposed: LAPACK's column-major view of it is the matrix);
    ``blocks`` gets the ``A_k^-1``, ``coupling`` the ``A_k^-1 J_qw`` (:class:`Factors`).
    A 30 x 30 factorization on ``paper`` instead of 65 x 65. ``linked``: the bodies
    whose states a body's rows can depend on; the others' columns are zero and skipped.
    ``chain``: where the bodies form a chain, the reduced matrix is block tridiagonal in
    the chain's order and is factored block by block (:func:`_factor_chain`) instead of
    by ``getrf``; ``lu`` and ``pivots`` are then unused. Returns 0, or ``k > 0`` where a
    pivot is zero.
    """
    lu, pivots, blocks = factors.lu, factors.pivots, factors.blocks
    coupling, linked, chain = factors.coupling, factors.linked, factors.chain
    nb = blocks.shape[0]
    r0, m = 7 * nb, 6 * nb
    for k in range(nb):  # J_qq = Omega(w) / 2 is skew with Omega^2 = -|w|^2 I, so
        q = 3 * nb + 4 * k  # (I - c J_qq)^-1 = (I + c J_qq) / (1 + c^2 |w|^2 / 4)
        scale = 1.0 / (1.0 + c * c * (jac[q, q + 1] ** 2 + jac[q, q + 2] ** 2
                                      + jac[q, q + 3] ** 2))
        for i in range(4):
            for j in range(4):
                blocks[k, i, j] = scale * ((1.0 if i == j else 0.0) + c * jac[q + i, q + j])
    for k in range(nb):  # A^-1 J_qw, for every row below
        q, w = 3 * nb + 4 * k, 3 * nb + 3 * k
        for i4 in range(4):
            for e in range(3):
                g = 0.0
                for j4 in range(4):
                    g += blocks[k, i4, j4] * jac[q + j4, r0 + w + e]
                coupling[k, i4, e] = g
    if chain.order.shape[0] > 0:
        return _factor_chain(jac, c, coupling, linked, chain)
    for i in range(m):
        row, body = r0 + i, (i % (3 * nb)) // 3
        for j in range(m):
            lu[j, i] = -c * jac[row, r0 + j]
        lu[i, i] += 1.0
        for k in range(nb):
            if not linked[body, k]:
                continue
            for e in range(3):  # x_u = b_u + c x_v: M_ru's columns onto x_v's
                lu[3 * k + e, i] += -c * jac[row, 3 * k + e] * c
            q, w = 3 * nb + 4 * k, 3 * nb + 3 * k
            for e in range(3):  # x_q = A^-1 (b_q + c J_qw x_w)
                total = 0.0
                for i4 in range(4):
                    total += -c * jac[row, q + i4] * coupling[k, i4, e]
                lu[w + e, i] += total * c
    return _getrf(ord("d"), m, m, lu.ctypes, m, pivots.ctypes)


@kernel(inline="always")
def _six_rows(jac, v, w, vec, lo, hi, shift, t):
    """The six sums ``t`` plus rows ``v..v+2`` and ``w..w+2`` of ``jac`` (a body's) over
    columns ``shift + lo .. shift + hi`` times ``vec[lo:hi]``.
    """
    t0, t1, t2, t3, t4, t5 = t
    for j in range(lo, hi):
        x, col = vec[j], shift + j
        t0 += jac[v, col] * x
        t1 += jac[v + 1, col] * x
        t2 += jac[v + 2, col] * x
        t3 += jac[w, col] * x
        t4 += jac[w + 1, col] * x
        t5 += jac[w + 2, col] * x
    return t0, t1, t2, t3, t4, t5


@kernel(inline="always")
def _solve(jac, c, factors, b, xq, r):
    """``b <- (I - c J)^-1 b`` from :func:`_factor`'s elimination and ``factors``;
    ``xq``, ``r``: scratch vectors as long as ``b``.
    """
    lu, pivots, blocks = factors.lu, factors.pivots, factors.blocks
    coupling, linked, chain = factors.coupling, factors.linked, factors.chain
    nb = blocks.shape[0]
    r0, m = 7 * nb, 6 * nb
    for k in range(nb):  # A^-1 b_q
        q = 3 * nb + 4 * k
        for i in range(4):
            xq[4 * k + i] = (blocks[k, i, 0] * b[q] + blocks[k, i, 1] * b[q + 1]
                             + blocks[k, i, 2] * b[q + 2] + blocks[k, i, 3] * b[q + 3])
    for body in range(nb):  # the body's six rows at once: six independent sums
        v, w = r0 + 3 * body, r0 + 3 * nb + 3 * body
        t = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
        for k in range(nb):
            if linked[body, k]:
                t = _six_rows(jac, v, w, b, 3 * k, 3 * k + 3, 0, t)
        for k in range(nb):
            if linked[body, k]:
                t = _six_rows(jac, v, w, xq, 4 * k, 4 * k + 4, 3 * nb, t)
        t0, t1, t2, t3, t4, t5 = t
        # b_r - M_ru b_u - M_rq A^-1 b_q, M = -c J off the diagonal
        i, e = v - r0, w - r0
        r[i], r[i + 1], r[i + 2] = b[v] + c * t0, b[v + 1] + c * t1, b[v + 2] + c * t2
        r[e], r[e + 1], r[e + 2] = b[w] + c * t3, b[w + 1] + c * t4, b[w + 2] + c * t5
    if chain.order.shape[0] > 0:
        _solve_chain(chain, r)
    else:
        _lu_solve(lu, pivots, r[:m])
    for i in range(m):
        b[r0 + i] = r[i]
    for j in range(3 * nb):
        b[j] += c * r[j]  # x_u = b_u + c x_v
    for k in range(nb):
        q, w = 3 * nb + 4 * k, 3 * nb + 3 * k
        for i in range(4):
            total = xq[4 * k + i]
            for e in range(3):  # x_q = A^-1 (b_q + c J_qw x_w)
                total += c * coupling[k, i, e] * r[w + e]
            b[q + i] = total


@kernel()
def _chain_order(linked):
    """The bodies in the order of the chain their contacts make (a body shares contacts
    with at most two others, and no loop: shaft, pin, shaft, ... ; a body or chain
    linked to none is appended as its own chain), or an empty array where they do not
    form one. In that order the rows of :func:`_factor` that remain are block
    tridiagonal, one 6 x 6 block (velocity, rate) per body.
    """
    nb = linked.shape[0]
    degree = np.zeros(nb, dtype=np.int64)
    for k in range(nb):
        for j in range(nb):
            if j != k and linked[k, j]:
                degree[k] += 1
    order, seen, size = np.zeros(nb, dtype=np.int64), np.zeros(nb, dtype=np.bool_), 0
    for first in range(nb):
        if seen[first] or degree[first] > 1:
            continue  # each chain is walked from one of its ends
        body = first
        while body >= 0:
            order[size], seen[body], size = body, True, size + 1
            nxt = -1
            for j in range(nb):
                if j != body and linked[body, j] and not seen[j]:
                    nxt = j
            body = nxt
    if size < nb or np.any(degree > 2):
        return order[:0]  # a body with three neighbours, or a loop
    return order


@kernel()
def _new_chain(linked):
    """A zeroed :class:`Chain` of the bodies ``linked`` (its order found here)."""
    nb = linked.shape[0]
    blocks = np.zeros((3, nb, 6, 6))
    return Chain(order=_chain_order(linked), diag=blocks[0], below=blocks[1], right=blocks[2],
                 pivots=np.zeros((nb, 6), dtype=np.int64), ys=np.zeros((nb, 6)))


@kernel(inline="always")
def _reduced(nb, body, local):
    """Index in :func:`_factor`'s reduced rows of body ``body``'s velocity (``local``
    0-2) or rate (3-5) component.
    """
    return 3 * body + local if local < 3 else 3 * nb + 3 * body + local - 3


@kernel(inline="always")
def _fill_block(jac, c, coupling, row_body, col_body, out):
    """The 6 x 6 block of :func:`_factor`'s reduced matrix at the rows of ``row_body``
    and the columns of ``col_body`` into ``out``: the same sums, in the same order, as
    the dense path forms.
    """
    nb = coupling.shape[0]
    r0 = 7 * nb
    for a in range(6):
        i = _reduced(nb, row_body, a)
        row = r0 + i
        for e in range(6):
            j = _reduced(nb, col_body, e)
            value = -c * jac[row, r0 + j]
            if i == j:
                value += 1.0
            if e < 3:  # x_u = b_u + c x_v
                value += -c * jac[row, 3 * col_body + e] * c
            else:  # x_q = A^-1 (b_q + c J_qw x_w)
                q, total = 3 * nb + 4 * col_body, 0.0
                for i4 in range(4):
                    total += -c * jac[row, q + i4] * coupling[col_body, i4, e - 3]
                value += total * c
            out[a, e] = value


@kernel(inline="always")
def _lu6(a, pivots):
    """LU factorization with partial pivoting of the 6 x 6 ``a`` in place (unit lower
    and upper triangles), its row swaps into ``pivots``; 0, or ``k + 1`` where the
    ``k``-th pivot is zero.
    """
    info = 0
    for k in range(6):
        p = k
        for i in range(k + 1, 6):
            if abs(a[i, k]) > abs(a[p, k]):
                p = i
        pivots[k] = p
        if p != k:
            for j in range(6):
                a[k, j], a[p, j] = a[p, j], a[k, j]
        if a[k, k] == 0.0:
            info = k + 1 if info == 0 else info
            continue
        for i in range(k + 1, 6):
            a[i, k] /= a[k, k]
            f = a[i, k]
            for j in range(k + 1, 6):
                a[i, j] -= f * a[k, j]
    return info


@kernel(inline="always")
def _lu6_solve(a, pivots, x):
    """``x <- a^-1 x`` from :func:`_lu6`'s factors, for every column of the (6, k)
    ``x``: :func:`_lu6_solve_vector` of each (the columns do not mix).
    """
    for col in range(x.shape[1]):
        _lu6_solve_vector(a, pivots, x[:, col])


@kernel(inline="always")
def _lu6_solve_vector(a, pivots, x):
    """``x <- a^-1 x`` from :func:`_lu6`'s factors for one vector ``x`` (6,)."""
    for k in range(6):
        p = pivots[k]
        if p != k:
            x[k], x[p] = x[p], x[k]
    for i in range(1, 6):
        total = x[i]
        for j in range(i):
            total -= a[i, j] * x[j]
        x[i] = total
    for i in range(5, -1, -1):
        total = x[i]
        for j in range(i + 1, 6):
            total -= a[i, j] * x[j]
        x[i] = total / a[i, i]


@kernel(inline="always")
def _factor_chain(jac, c, coupling, linked, chain):
    """Block LU of :func:`_factor`'s reduced matrix, block tridiagonal in the chain's
    order (:func:`_chain_order`): ``D'_p = D_p - A_p X_{p-1}`` factored with partial
    pivoting inside the block, ``X_p = D'_p^-1 C_p``. About 5 x 700 multiply-adds on
    ``paper`` (five bodies) where ``getrf`` of the dense 30 x 30 spends 9,000 and a
    library call. Pivoting stays within a body's block: the test of the Newton solve
    holds its backward error to round-off at the steps' values of ``c``.
    """
    order, pivots = chain.order, chain.pivots
    nb, info = order.shape[0], 0
    for p in range(nb):
        body, diag, below, right = order[p], chain.diag[p], chain.below[p], chain.right[p]
        _fill_block(jac, c, coupling, body, body, diag)
        if p > 0 and linked[body, order[p - 1]]:
            _fill_block(jac, c, coupling, body, order[p - 1], below)
            ahead = chain.right[p - 1]
            for i in range(6):
                for j in range(6):
                    total = diag[i, j]
                    for k in range(6):
                        total -= below[i, k] * ahead[k, j]
                    diag[i, j] = total
        else:
            below[:] = 0.0
        found = _lu6(diag, pivots[p])
        if found and not info:
            info = 6 * p + found
        if p + 1 < nb and linked[body, order[p + 1]]:
            _fill_block(jac, c, coupling, body, order[p + 1], right)
            _lu6_solve(diag, pivots[p], right)
        else:
            right[:] = 0.0
    return info


@kernel(inline="always")
def _solve_chain(chain, r):
    """``r <- S^-1 r`` for :func:`_factor_chain`'s factors of the reduced matrix ``S``
    (``r`` in the reduced rows' order): forward ``y_p = D'_p^-1 (r_p - A_p y_{p-1})``,
    back ``x_p = y_p - X_p x_{p+1}``.
    """
    order, pivots, ys = chain.order, chain.pivots, chain.ys
    diag, below, right = chain.diag, chain.below, chain.right
    nb = order.shape[0]
    for p in range(nb):
        body, y = order[p], ys[p]
        for a in range(6):
            total = r[_reduced(nb, body, a)]
            if p > 0:
                for k in range(6):
                    total -= below[p, a, k] * ys[p - 1, k]
            y[a] = total
        _lu6_solve_vector(diag[p], pivots[p], y)
    for p in range(nb - 2, -1, -1):
        for a in range(6):
            total = ys[p, a]
            for k in range(6):
                total -= right[p, a, k] * ys[p + 1, k]
            ys[p, a] = total
    for p in range(nb):
        for a in range(6):
            r[_reduced(nb, order[p], a)] = ys[p, a]


@kernel()
def _lu_solve(lu, pivots, b):
    """``b <- M^-1 b`` from LAPACK's ``getrf`` factors of ``M`` (held transposed): row
    swaps, then the unit lower and the upper triangle, column by column.
    """
    n = b.shape[0]
    for k in range(n):
        p = pivots[k] - 1
        if p != k:
            b[k], b[p] = b[p], b[k]
    for j in range(n):
        bj = b[j]
        if bj != 0.0:
            for i in range(j + 1, n):
                b[i] -= lu[j, i] * bj
    for j in range(n - 1, -1, -1):
        b[j] /= lu[j, j]
        bj = b[j]
        for i in range(j):
            b[i] -= lu[j, i] * bj
