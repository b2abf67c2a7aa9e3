"""Compiled Newton method of the ``newton`` family (numba, extra ``numba``).

The same method as :func:`._newton_numpy.newton_numpy`, its NumPy reference, one instant
after the other (warm-started from the instant before where asked), with every array
of an instant in scratch allocated once per call. Two places differ in how, not what:
the left null space of ``E`` comes from the Cholesky factor of the nominal Hessian
``H0`` (a pivot below ``NULL_RTOL`` of its diagonal entry marks a row dependent on the
rows before it; its null vector solves the leading block, then the vectors are made
orthonormal) where the reference takes ``H0``'s eigenvectors, and a warm start's fit
of ``u`` to the deformations is weighted by ``H0``'s slopes where the reference takes
plain least squares. Both span the same subspace and reach the same optimum.

Nothing raises on numbers: non-finite data end with status 3, a factor that is not
positive definite with status 4 (:data:`._newton_numpy.REASONS`). No fastmath: every
operation rounds as IEEE 754 says, so an instant's answer does not depend on the CPU
numba compiles for beyond the last bits of fused multiply-adds.
"""

from __future__ import annotations

import numpy as np

from ..driveline.compiled import HAVE_NUMBA, njit

if not HAVE_NUMBA:  # an optional extra: the caller takes the NumPy reference
    raise ImportError("numba is not installed")


DENSE = 0.6
"""Share of ``E``'s entries inside the columns' spans from which a Hessian is summed by
one BLAS product (the conic forms' rotated rows) rather than by rank-one updates over
the spans (the operator's rows: a contact loads two bodies of the line)."""


@njit(cache=True)
def _contact(dg, w, signed, n, k, g):
    """One contact at deformations ``dg`` (its first ``w`` entries): ``(r, slope, ratio,
    s, norm)`` as :func:`._newton_numpy.evaluate`'s.
    """
    norm = 0.0
    for j in range(w):
        norm += dg[j] * dg[j]
    norm = np.sqrt(norm)
    s = dg[0] if signed else norm
    over = max(s - g, 0.0)
    if not (s > g or (n == 1.0 and s >= g)):
        return 0.0, 0.0, 0.0, s, norm
    x = over / k
    if n == 1.0:  # the linear law and Hertz's 3/2 without a call to pow
        r, slope = x, 1.0 / k
    elif n == 1.5:
        root = np.sqrt(x)
        r, slope = x * root, 1.5 * root / k
    else:
        r, slope = x ** n, n * x ** (n - 1.0) / k
    ratio = r / s if s > 0 else slope
    return r, slope, ratio, s, norm


@njit(cache=True)
def _unit(dg, w, signed, norm, out):
    """The contact's direction into ``out`` (``[1]`` for a pushing column)."""
    for j in range(w):
        if signed:
            out[j] = 1.0
        elif norm > 0:
            out[j] = dg[j] / norm
        else:
            out[j] = 0.0


@njit(cache=True)
def _state(Et, span, u, members, mask, signed, n, k, g, d, f, ratio, slope, Y, U, dg,
           unit):
    """At ``u``: ``d = E'u``, the forces ``f``, per contact ``ratio``, ``slope``, its
    direction ``U_c`` and ``Y_c = E_c U_c`` (G, m).
    """
    nv, m = Et.shape
    for j in range(nv):
        acc = 0.0
        for i in range(span[j, 0], span[j, 1]):
            acc += Et[j, i] * u[i]
        d[j] = acc
    for c in range(members.shape[0]):
        w = 0
        for j in range(members.shape[1]):
            if mask[c, j] > 0:
                dg[j] = d[members[c, j]]
                w += 1
        r, slope[c], ratio[c], s, norm = _contact(dg, w, signed[c], n[c], k[c], g[c])
        _unit(dg, w, signed[c], norm, unit)
        for i in range(m):
            Y[c, i] = 0.0
        for j in range(w):
            col = members[c, j]
            f[col] = r * unit[j]
            U[c, j] = unit[j]
            for i in range(span[col, 0], span[col, 1]):
                Y[c, i] += Et[col, i] * unit[j]


@njit(cache=True)
def _hessian(Et, span, members, mask, ratio, slope, Y, U, z, shift, V, nk, rho, H, terms):
    """``H = sum_c E_c H_c E_c' + shift I + rho V V'``; ``span[j]``: the rows where
    column ``j`` can be nonzero. ``H_c = slope u u' + ratio (I - u u')`` is ``w``
    rank-one terms: ``Y_c = E_c u`` and ``E_c h`` for the columns ``h`` of the
    Householder reflection that maps ``e_1`` onto ``-+u`` (the rest are an orthonormal
    basis of ``u``'s complement). ``terms``: ``(B, ranges, dense)``, the terms' rows
    scaled by their roots and summed as ``B'B`` (one BLAS product where the columns are
    dense, rank-one updates over their rows where they are not).
    """
    B, ranges, dense = terms
    m, t = Et.shape[1], 0
    for c in range(members.shape[0]):
        w, lo, hi, length = 0, m, 0, 0.0
        for p in range(members.shape[1]):
            if mask[c, p] > 0:
                col = members[c, p]
                lo, hi = min(lo, span[col, 0]), max(hi, span[col, 1])
                length += U[c, p] * U[c, p]
                w += 1
        if length == 0.0:  # no direction (an exactly unloaded linear contact): ratio I
            for p in range(w):
                col = members[c, p]
                t = _term(B, ranges, t, Et[col], ratio[c], span[col, 0], span[col, 1])
            continue
        if slope[c] != 0.0:
            t = _term(B, ranges, t, Y[c], slope[c], lo, hi)
        if ratio[c] != 0.0 and w > 1:
            t = _complement(Et, span, members[c], U[c], w, lo, hi, ratio[c], z, B, ranges, t)
    _sum_terms(B, ranges, t, dense, H)
    _finish(H, shift, V, nk, rho)


@njit(cache=True)
def _term(B, ranges, t, a, scale, lo, hi):
    """Row ``t`` of ``B``: ``sqrt(scale) a`` on rows ``lo:hi`` (0 elsewhere); ``t + 1``."""
    root = np.sqrt(scale)
    for i in range(B.shape[1]):
        B[t, i] = root * a[i] if lo <= i < hi else 0.0
    ranges[t, 0], ranges[t, 1] = lo, hi
    return t + 1


@njit(cache=True)
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


@njit(cache=True)
def _complement(Et, span, cols, u, w, lo, hi, ratio, z, B, ranges, t):
    """The terms of ``ratio E_c (I - u u') E_c'``: the reflection's columns 2..w."""
    v0 = u[0] + (1.0 if u[0] >= 0 else -1.0)
    vv = v0 * v0
    for j in range(1, w):
        vv += u[j] * u[j]
    for q in range(1, w):
        for i in range(lo, hi):
            z[i] = 0.0
        for j in range(w):
            vj = v0 if j == 0 else u[j]
            h = (1.0 if j == q else 0.0) - 2.0 * vj * u[q] / vv
            for i in range(span[cols[j], 0], span[cols[j], 1]):
                z[i] += Et[cols[j], i] * h
        t = _term(B, ranges, t, z, ratio, lo, hi)
    return t


@njit(cache=True)
def _rank_one(H, a, scale, lo, hi):
    """``H += scale a a'`` on the lower triangle of rows and columns ``lo:hi``."""
    for i in range(lo, hi):
        ai = scale * a[i]
        for j in range(lo, i + 1):
            H[i, j] += ai * a[j]


@njit(cache=True)
def _finish(H, shift, V, nk, rho):
    """Add ``shift I + rho V V'`` to the lower triangle of ``H`` and mirror it."""
    m = H.shape[0]
    for i in range(m):
        H[i, i] += shift
        for j in range(i + 1):
            for q in range(nk):
                H[i, j] += rho * V[i, q] * V[j, q]
            H[j, i] = H[i, j]


@njit(cache=True)
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


@njit(cache=True)
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


@njit(cache=True)
def _null_space(H0, L, dependent, V, rhs, x, rtol):
    """Orthonormal null vectors of ``H0`` into ``V``'s first columns; returns their
    count, or -1 where the factor fails. Each dependent row ``p`` gives ``v_p = 1``,
    ``v_I = -H0_II^-1 H0_Ip`` over the independent rows before it.
    """
    m = H0.shape[0]
    if not _cholesky(H0, L, dependent, rtol):
        return -1
    nk = 0
    for p in range(m):
        if not dependent[p]:
            continue
        for i in range(m):
            rhs[i] = -H0[i, p]
        _solve(L, rhs, x, dependent, p)
        for i in range(m):
            V[i, nk] = x[i] if i < p else 0.0
        V[p, nk] = 1.0
        for q in range(nk):  # modified Gram-Schmidt against the vectors before
            dot = 0.0
            for i in range(m):
                dot += V[i, q] * V[i, nk]
            for i in range(m):
                V[i, nk] -= dot * V[i, q]
        dot = 0.0
        for i in range(m):
            dot += V[i, nk] * V[i, nk]
        for i in range(m):
            V[i, nk] /= np.sqrt(dot)
        nk += 1
    return nk


@njit(cache=True)
def _project(v, V, nk):
    """``v - V V'v`` in place."""
    for q in range(nk):
        dot = 0.0
        for i in range(len(v)):
            dot += V[i, q] * v[i]
        for i in range(len(v)):
            v[i] -= dot * V[i, q]


@njit(cache=True)
def _nominal(Et, span, e, members, mask, n, k, H0, terms):
    """``H0`` (:func:`._newton_numpy.nominal`) into ``H0`` (summed as :func:`_hessian`
    sums its terms); returns ``rho``, its mean diagonal.
    """
    B, ranges, dense = terms
    m, t = Et.shape[1], 0
    F = 0.0
    for i in range(m):
        F += e[i] * e[i]
    F = max(np.sqrt(F), 1e-300)
    for c in range(members.shape[0]):
        c0 = n[c] * F ** (1.0 - 1.0 / n[c]) / k[c]
        for p in range(members.shape[1]):
            if mask[c, p] > 0:
                col = members[c, p]
                t = _term(B, ranges, t, Et[col], c0, span[col, 0], span[col, 1])
    _sum_terms(B, ranges, t, dense, H0)
    trace = 0.0
    for i in range(m):
        trace += H0[i, i]
        for j in range(i):
            H0[j, i] = H0[i, j]
    return max(trace / m, 1e-300)


@njit(cache=True)
def _slope(d, delta, t, u, du, e_du, rho_soft, members, mask, signed, n, k, g, dg, unit):
    """``Phi``'s first and second derivative along ``du`` at ``u + t du``
    (``delta = E'du``, ``e_du = e'du``).
    """
    first = -e_du
    second = 0.0
    for i in range(len(u)):
        first += rho_soft * (u[i] + t * du[i]) * du[i]
        second += rho_soft * du[i] * du[i]
    for c in range(members.shape[0]):
        w = 0
        for j in range(members.shape[1]):
            if mask[c, j] > 0:
                dg[j] = d[members[c, j]] + t * delta[members[c, j]]
                w += 1
        r, slope, ratio, s, norm = _contact(dg, w, signed[c], n[c], k[c], g[c])
        _unit(dg, w, signed[c], norm, unit)
        along, length = 0.0, 0.0
        for j in range(w):
            dj = delta[members[c, j]]
            along += unit[j] * dj
            length += dj * dj
        first += r * along
        second += ratio * length + (slope - ratio) * along * along
    return first, second


@njit(cache=True)
def _line_search(d, delta, u, du, e_du, rho_soft, members, mask, signed, n, k, g, dg,
                 unit, ls_rtol, ls_max):
    """:func:`._newton_numpy.line_search`: the exact step length (0 where the slope at 0 is
    not negative).
    """
    start, _ = _slope(d, delta, 0.0, u, du, e_du, rho_soft, members, mask, signed, n, k,
                      g, dg, unit)
    if not start < 0:
        return 0.0
    lo, hi, t = 0.0, np.inf, 1.0
    for _ in range(ls_max):
        first, second = _slope(d, delta, t, u, du, e_du, rho_soft, members, mask, signed,
                               n, k, g, dg, unit)
        if abs(first) <= ls_rtol * abs(start):
            return t
        if first < 0:
            lo = t
        else:
            hi = t
        guess = t - first / second if second > 0 else np.inf
        if not (lo < guess < hi):
            guess = 2.0 * t if hi == np.inf else 0.5 * (lo + hi)
        t = guess
    return lo if hi == np.inf else 0.5 * (lo + hi)


@njit(cache=True)
def _finite(Et, e, k, g):
    """Whether one instant's data are finite and its stiffnesses positive."""
    for x in Et.ravel():
        if not np.isfinite(x):
            return False
    for x in e:
        if not np.isfinite(x):
            return False
    for c in range(len(k)):
        if not (np.isfinite(k[c]) and np.isfinite(g[c]) and k[c] > 0):
            return False
    return True


@njit(cache=True)
def _fit(Et, span, e, hint, members, mask, n, k, L, dependent, rhs, u):
    """``u`` whose deformations fit ``hint`` in ``H0``'s weights: ``(E D0 E') u = E D0
    hint`` through ``L`` (the factor of ``H0 + rho V V' + mu I``).
    """
    m = Et.shape[1]
    F = 0.0
    for i in range(m):
        F += e[i] * e[i]
    F = max(np.sqrt(F), 1e-300)
    for i in range(m):
        rhs[i] = 0.0
    for c in range(members.shape[0]):
        c0 = n[c] * F ** (1.0 - 1.0 / n[c]) / k[c]
        for p in range(members.shape[1]):
            if mask[c, p] > 0:
                col = members[c, p]
                for i in range(span[col, 0], span[col, 1]):
                    rhs[i] += c0 * Et[col, i] * hint[col]
    _solve(L, rhs, u, dependent, m)


@njit(cache=True)
def _gradient(Et, span, e, f, u, rho_soft, V, nk, grad):
    """``(I - V V')(E f - e + rho_soft u)`` into ``grad``; returns its norm."""
    nv, m = Et.shape
    for i in range(m):
        grad[i] = -e[i] + rho_soft * u[i]
    for j in range(nv):
        for i in range(span[j, 0], span[j, 1]):
            grad[i] += Et[j, i] * f[j]
    _project(grad, V, nk)
    norm = 0.0
    for i in range(m):
        norm += grad[i] * grad[i]
    return np.sqrt(norm)


@njit(cache=True)
def _start(Et, span, e, groups, k, g, hints, use_hint, null_rtol, s, terms, u):
    """An instant's start: ``H0``, its null space ``V`` and the first step's factor
    ``L`` (``H0``'s, its dependent rows skipped: a right-hand side orthogonal to ``V``
    has a solution there, which the caller projects out of ``V``) in the scratch ``s``,
    ``u`` cold (0) or fitted to the first of ``hints`` (the deformations to start
    from, and another or ``None``: then the fit of the two with the smaller gradient).
    Returns ``(code, rho, nk)``: a nonzero code ends the instant (3 non-finite data, 4
    no factor).
    """
    members, mask, signed, n = groups
    H0, _, L, V, dependent, rhs, du = s[:7]
    hint, other = hints
    m = Et.shape[1]
    if not _finite(Et, e, k, g):
        return 3, 0.0, 0
    rho = _nominal(Et, span, e, members, mask, n, k, H0, terms)
    nk = _null_space(H0, L, dependent, V, rhs, du, null_rtol)
    if nk < 0:
        return 4, rho, 0
    for i in range(m):
        u[i] = 0.0
    if use_hint:
        _fit(Et, span, e, hint, members, mask, n, k, L, dependent, rhs, u)
        _project(u, V, nk)
    if use_hint and other is not None:
        first = _start_gradient(Et, span, e, groups, k, g, V, nk, s, u)
        _fit(Et, span, e, other, members, mask, n, k, L, dependent, rhs, du)
        _project(du, V, nk)
        if _start_gradient(Et, span, e, groups, k, g, V, nk, s, du) < first:
            for i in range(m):
                u[i] = du[i]
    return 0, rho, nk


@njit(cache=True)
def _start_gradient(Et, span, e, groups, k, g, V, nk, s, u):
    """``||(I - V V')(E f - e)||`` at ``u`` (a start's measure, in the scratch ``s``)."""
    members, mask, signed, n = groups
    _, _, _, _, _, _, _, grad, d, f, _, ratio, slope, Y, U, _, dg, unit = s
    _state(Et, span, u, members, mask, signed, n, k, g, d, f, ratio, slope, Y, U, dg, unit)
    return _gradient(Et, span, e, f, u, 0.0, V, nk, grad)


@njit(cache=True)
def _instant(Et, span, e, groups, k, g, hints, use_hint, tol, max_iter, soften, params, s,
             terms, u):
    """One instant into ``u``; returns ``(status, iterations)`` (``groups``: members,
    mask, signed, n; ``s``, ``terms``: the scratch of :func:`newton`).
    """
    members, mask, signed, n = groups
    H0, H, L, V, dependent, rhs, du, grad, d, f, delta, ratio, slope, Y, U, z, dg, unit = s
    null_rtol, reg_rtol, ls_rtol, ls_max, stall = params
    m = Et.shape[1]
    code, rho, nk = _start(Et, span, e, groups, k, g, hints, use_hint, null_rtol, s, terms,
                           u)
    if code:
        return code, 0
    rho_soft, shift = soften * rho, reg_rtol * rho
    scale = 0.0
    for i in range(m):
        scale += e[i] * e[i]
    scale = max(np.sqrt(scale), 1e-300)
    for it in range(max_iter + 1):
        _state(Et, span, u, members, mask, signed, n, k, g, d, f, ratio, slope, Y, U, dg,
               unit)
        norm = _gradient(Et, span, e, f, u, rho_soft, V, nk, grad)
        if not np.isfinite(norm):
            return 3, it
        if norm <= tol * scale:
            return 0, it
        if it == max_iter:
            break
        if it > 0 or use_hint:
            _hessian(Et, span, members, mask, ratio, slope, Y, U, z, shift + rho_soft, V, nk,
                     rho, H, terms)
            if not _cholesky(H, L, dependent, 0.0):
                return 4, it
        for i in range(m):
            rhs[i] = -grad[i]
        _solve(L, rhs, du, dependent, m)
        _project(du, V, nk)  # (H0's factor skips its dependent rows: held out here)
        t = _step(Et, span, e, u, du, d, delta, rho_soft, groups, k, g, dg, unit, ls_rtol,
                  ls_max)
        if t == 0.0:  # no decrease left: rounding, solved if within STALL tol
            return (0 if norm <= stall * tol * scale else 2), it
    return 1, max_iter


@njit(cache=True)
def _step(Et, span, e, u, du, d, delta, rho_soft, groups, k, g, dg, unit, ls_rtol,
          ls_max):
    """The line search along ``du`` from ``u`` and the move; returns the length."""
    members, mask, signed, n = groups
    nv, m = Et.shape
    e_du = 0.0
    for i in range(m):
        e_du += e[i] * du[i]
    for j in range(nv):
        acc = 0.0
        for i in range(span[j, 0], span[j, 1]):
            acc += Et[j, i] * du[i]
        delta[j] = acc
    t = _line_search(d, delta, u, du, e_du, rho_soft, members, mask, signed, n, k, g, dg,
                     unit, ls_rtol, int(ls_max))
    for i in range(m):
        u[i] += t * du[i]
    return t


@njit(cache=True)
def newton(Et, span, e, members, mask, signed, n, k, g, d0, start, chain, tol, max_iter,
           soften, params):
    """:func:`._newton_numpy.newton_numpy` compiled: ``(u, d, status, iterations)``. ``Et``
    (T, nv, m) holds ``E'`` (a column of ``E`` a contiguous row), ``span`` (nv, 2) the
    rows ``[lo, hi)`` where each column can be nonzero at any instant.
    """
    T, nv, m = Et.shape
    G, w = members.shape
    scratch = (np.zeros((m, m)), np.zeros((m, m)), np.zeros((m, m)), np.zeros((m, m)),
               np.zeros(m, np.bool_), np.zeros(m), np.zeros(m), np.zeros(m),
               np.zeros(nv), np.zeros(nv), np.zeros(nv), np.zeros(G), np.zeros(G),
               np.zeros((G, m)), np.zeros((G, w)), np.zeros(m), np.zeros(w), np.zeros(w))
    covered = 0
    for j in range(nv):
        covered += span[j, 1] - span[j, 0]
    terms = (np.zeros((nv, m)), np.zeros((nv, 2), np.int64), covered >= DENSE * nv * m)
    u_out, d_out = np.zeros((T, m)), np.zeros((T, nv))
    status, iters = np.zeros(T, np.int64), np.zeros(T, np.int64)
    groups = (members, mask, signed, n)
    for i in range(T):
        warm = chain and i > 0
        hints = (d0[i], None)
        if warm:  # the answer before, or extrapolated linearly from the two before
            hints = ((2.0 * d_out[i - 1] - d_out[i - 2], d_out[i - 1]) if i > 1 else
                     (d_out[i - 1], None))
        status[i], iters[i] = _instant(Et[i], span, e[i], groups, k[i], g[i], hints,
                                       warm or start[i], tol, max_iter, soften, params,
                                       scratch, terms, u_out[i])
        for j in range(nv):
            acc = 0.0
            for r in range(span[j, 0], span[j, 1]):
                acc += Et[i, j, r] * u_out[i, r]
            d_out[i, j] = acc
    return u_out, d_out, status, iters
