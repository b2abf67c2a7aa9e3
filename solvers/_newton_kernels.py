"""Compiled Newton method of the ``newton`` family (numba, extra ``numba``).

The same method as :func:`._newton_numpy.newton_numpy`, its NumPy reference, one instant
after the other (warm-started from the instants before where asked), its state named
(:mod:`._newton_state`) and allocated once per call. Two places differ in how, not
what: the left null space of ``E`` comes from a Cholesky factor with dependent rows
skipped (a pivot below ``NULL_RTOL`` of its diagonal entry marks a row dependent on the
rows before it; its null vector solves the leading block, then the vectors are made
orthonormal) where the reference takes ``H0``'s eigenvectors, and a per-instant fit of
``u`` to given deformations is weighted by ``H0``'s slopes where the reference takes
plain least squares. Both span the same subspace and reach the same optimum. A warm
instant of a chain factors no ``H0``: the factor of its first step's Hessian gives the
null space where that is the instant before's (:func:`_warm`), so a step of the chain
costs one factor.

Nothing raises on numbers: non-finite data end with status 3, a factor that is not
positive definite with status 4 (:data:`._newton_numpy.REASONS`). No fastmath: every
operation rounds as IEEE 754 says, so an instant's answer does not depend on the CPU
numba compiles for beyond the last bits of fused multiply-adds.
"""

from __future__ import annotations

import numpy as np

from cardan_forces.util.compiled import HAVE_NUMBA

from ._newton_state import Data, Scratch

if not HAVE_NUMBA:  # an optional extra: the caller takes the NumPy reference
    raise ImportError("numba is not installed")

from ._newton_linalg import (  # noqa: E402 (numba only)
    _cholesky,
    _finish,
    _norm,
    _null_space,
    _project,
    _solve,
    _sum_terms,
    _term,
    kernel,
)

DENSE = 0.3
"""Share of ``E``'s entries inside the columns' spans from which a Hessian is summed by
one BLAS product rather than by rank-one updates over the spans: the short updates of
the operator's rows (a contact loads two bodies of the line, about half the rows of
``paper``) already take longer than the product of all rows, the conic forms' rotated
rows are dense."""


@kernel
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


@kernel
def _unit(dg, w, signed, norm, out):
    """The contact's direction into ``out`` (``[1]`` for a pushing column)."""
    for j in range(w):
        if signed:
            out[j] = 1.0
        elif norm > 0:
            out[j] = dg[j] / norm
        else:
            out[j] = 0.0


@kernel
def _gather(d, members, mask, out):
    """One contact's deformations ``d[members]`` into ``out``; returns its width."""
    w = 0
    for j in range(len(members)):
        if mask[j] > 0:
            out[j] = d[members[j]]
            w += 1
    return w


@kernel
def _state(x: Data, c, s: Scratch, u):
    """At ``u``: ``s.d = E'u`` and the contacts there (:func:`_contacts`)."""
    _deformations(x.Et, x.span, u, s.d)
    _contacts(x, c, s, s.d)


@kernel
def _deformations(Et, span, u, out):
    """``out = E'u``, each column of ``E`` over the rows ``span`` it can be nonzero in."""
    for j in range(Et.shape[0]):
        acc = 0.0
        for i in range(span[j, 0], span[j, 1]):
            acc += Et[j, i] * u[i]
        out[j] = acc


@kernel
def _contacts(x: Data, c, s: Scratch, d):
    """At deformations ``d``: the forces ``s.f``, per contact ``s.ratio``, ``s.slope``
    and its direction ``s.U[q]``.
    """
    for q in range(c.members.shape[0]):
        w = _gather(d, c.members[q], c.mask[q], s.dg)
        r, s.slope[q], s.ratio[q], _, norm = _contact(s.dg, w, c.signed[q], c.n[q],
                                                      x.k[q], x.g[q])
        _unit(s.dg, w, c.signed[q], norm, s.U[q])
        for j in range(w):
            s.f[c.members[q, j]] = r * s.U[q, j]


@kernel
def _hessian(x: Data, c, s: Scratch, shift, nk, rho):
    """``s.H = sum_q E_q H_q E_q' + shift I + rho V V'`` (``V``'s first ``nk`` columns).
    ``H_q = slope u u' + ratio (I - u u') = ratio I + (slope - ratio) u u'`` sums as
    rank-one terms: ``ratio`` times each column of ``E_q`` and ``slope - ratio`` times
    ``E_q u``, both >= 0 for every law of the family (``slope / ratio = n s / (s - g)
    >= 1``; rounding clamped), summed by :func:`_sum_terms`.
    """
    m, t = x.Et.shape[1], 0
    for q in range(c.members.shape[0]):
        lo, hi = m, 0
        s.z[:] = 0.0
        for p in range(c.members.shape[1]):
            if c.mask[q, p] > 0:
                col = c.members[q, p]
                a, b = x.span[col, 0], x.span[col, 1]
                lo, hi = min(lo, a), max(hi, b)
                if s.ratio[q] != 0.0:
                    t = _term(s.B, s.ranges, t, x.Et[col], s.ratio[q], a, b)
                for i in range(a, b):
                    s.z[i] += x.Et[col, i] * s.U[q, p]
        extra = s.slope[q] - s.ratio[q]
        if extra > 0.0:
            t = _term(s.B, s.ranges, t, s.z, extra, lo, hi)
    _sum_terms(s.B, s.ranges, t, s.dense, s.H)
    _finish(s.H, shift, s.V, nk, rho)


@kernel
def _nominal_weights(x: Data, c, out):
    """Each column's slope at the load ``F = ||e||`` into ``out`` (nv,): ``c0 = n
    F^(1 - 1/n) / k`` of its contact (:func:`._newton_numpy.nominal`).
    """
    F = _norm(x.e)
    for q in range(c.members.shape[0]):
        c0 = c.n[q] * F ** (1.0 - 1.0 / c.n[q]) / x.k[q]
        for p in range(c.members.shape[1]):
            if c.mask[q, p] > 0:
                out[c.members[q, p]] = c0


@kernel
def _nominal(x: Data, c, s: Scratch):
    """``H0 = sum_j c0_j E_j E_j'`` into ``s.H0`` (summed as :func:`_hessian` sums its
    terms); returns ``rho``, its mean diagonal.
    """
    (nv, m), t = x.Et.shape, 0
    _nominal_weights(x, c, s.weights)
    for j in range(nv):
        t = _term(s.B, s.ranges, t, x.Et[j], s.weights[j], x.span[j, 0], x.span[j, 1])
    _sum_terms(s.B, s.ranges, t, s.dense, s.H0)
    trace = 0.0
    for i in range(m):
        trace += s.H0[i, i]
        for j in range(i):
            s.H0[j, i] = s.H0[i, j]
    return max(trace / m, 1e-300)


@kernel
def _in_left_null_space(x: Data, s: Scratch, nk, rtol):
    """Whether ``V``'s first ``nk`` columns are null vectors of ``E'``: ``||E'v||^2 <=
    rtol ||E||_F^2 / m`` each (a direction only an idle contact would resist is not).
    """
    nv, m = x.Et.shape
    if nk == 0:
        return True
    scale = 0.0
    for j in range(nv):
        for i in range(x.span[j, 0], x.span[j, 1]):
            scale += x.Et[j, i] * x.Et[j, i]
    for q in range(nk):
        acc = 0.0
        for j in range(nv):
            dot = 0.0
            for i in range(x.span[j, 0], x.span[j, 1]):
                dot += x.Et[j, i] * s.V[i, q]
            acc += dot * dot
        if not acc <= rtol * scale / m:
            return False
    return True


@kernel
def _slope(x: Data, c, s: Scratch, t, base, quad):
    """``Phi``'s first and second derivative along the step at length ``t``: ``base +
    t quad`` and ``quad`` from ``-e'du`` and the softening, then each contact's from its
    deformations ``s.Dq + t s.Lq`` (:func:`_line_search` gathers them).
    """
    first, second = base + t * quad, quad
    for q in range(c.members.shape[0]):
        w = 0
        for j in range(c.members.shape[1]):
            if c.mask[q, j] > 0:
                s.dg[j] = s.Dq[q, j] + t * s.Lq[q, j]
                w += 1
        r, slope, ratio, _, norm = _contact(s.dg, w, c.signed[q], c.n[q], x.k[q], x.g[q])
        along = 0.0
        if c.signed[q]:
            along = s.Lq[q, 0]
        elif norm > 0:
            for j in range(w):
                along += s.dg[j] * s.Lq[q, j]
            along /= norm
        first += r * along
        second += ratio * s.lengths[q] + (slope - ratio) * along * along
    return first, second


@kernel
def _line_search(x: Data, c, s: Scratch, u, du, e_du, rho_soft, p, start):
    """:func:`._newton_numpy.line_search`: the exact step length (0 where the slope at 0,
    ``start``, is not negative); each contact's deformations and step gathered once.
    """
    udu, dudu = 0.0, 0.0
    for i in range(len(u)):
        udu += u[i] * du[i]
        dudu += du[i] * du[i]
    base, quad = -e_du + rho_soft * udu, rho_soft * dudu
    for q in range(c.members.shape[0]):
        s.lengths[q] = 0.0
        for j in range(c.members.shape[1]):
            if c.mask[q, j] > 0:
                col = c.members[q, j]
                s.Dq[q, j], s.Lq[q, j] = s.d[col], s.delta[col]
                s.lengths[q] += s.delta[col] * s.delta[col]
    if not start < 0:
        return 0.0
    lo, hi, t = 0.0, np.inf, 1.0
    for _ in range(p.ls_max):
        first, second = _slope(x, c, s, t, base, quad)
        if abs(first) <= p.ls_rtol * abs(start):
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


@kernel
def _finite(x: Data):
    """Whether one instant's data are finite and its stiffnesses positive (``v * 0`` is
    0 for a finite ``v``, NaN for any other: one sum, no branch per entry).
    """
    acc = 0.0
    for v in x.Et.ravel():
        acc += v * 0.0
    for v in x.e:
        acc += v * 0.0
    if acc != 0.0:
        return False
    for q in range(len(x.k)):
        if not (np.isfinite(x.k[q]) and np.isfinite(x.g[q]) and x.k[q] > 0):
            return False
    return True


@kernel
def _fit(x: Data, c, s: Scratch, hint, u):
    """``u`` whose deformations fit ``hint`` in ``H0``'s weights: ``(E D0 E') u = E D0
    hint`` through ``s.L`` (``H0``'s factor, its dependent rows skipped).
    """
    _nominal_weights(x, c, s.weights)
    s.rhs[:] = 0.0
    for j in range(x.Et.shape[0]):
        a = s.weights[j] * hint[j]
        for i in range(x.span[j, 0], x.span[j, 1]):
            s.rhs[i] += a * x.Et[j, i]
    _solve(s.L, s.rhs, u, s.dependent, x.Et.shape[1])


@kernel
def _gradient(x: Data, s: Scratch, u, rho_soft, nk):
    """``(I - V V')(E f - e + rho_soft u)`` into ``s.grad``; returns its norm."""
    nv, m = x.Et.shape
    for i in range(m):
        s.grad[i] = -x.e[i] + rho_soft * u[i]
    for j in range(nv):
        for i in range(x.span[j, 0], x.span[j, 1]):
            s.grad[i] += x.Et[j, i] * s.f[j]
    _project(s.grad, s.V, nk)
    acc = 0.0
    for i in range(m):
        acc += s.grad[i] * s.grad[i]
    return np.sqrt(acc)


@kernel
def _start(x: Data, c, p, s: Scratch, hint, use_hint, u):
    """A cold start: ``H0``, its null space ``V`` and its factor in ``s.L`` (dependent
    rows skipped: a right-hand side orthogonal to ``V`` has a solution there, which the
    caller projects out of ``V``); ``u`` 0, or fitted to the deformations ``hint``.
    Returns ``(code, rho, nk, factored)``: a nonzero code ends the instant (3
    non-finite data, 4 no factor); ``factored``: ``s.L`` is the first step's factor.
    """
    if not _finite(x):
        return 3, 0.0, 0, False
    rho = _nominal(x, c, s)
    nk = _null_space(s.H0, s, p.null_rtol)
    if nk < 0:
        return 4, rho, 0, False
    u[:] = 0.0
    if use_hint:
        _fit(x, c, s, hint, u)
        _project(u, s.V, nk)
    return 0, rho, nk, not use_hint


@kernel
def _warm(x: Data, c, p, s: Scratch, hint, u, nk_before):
    """A chain's start from deformations ``hint`` (:func:`._newton_numpy.linearized`):
    unsoftened, the Hessian at ``hint`` (no ``H0``) gives ``rho`` and the null space ``V`` through
    its factor, dependent rows skipped, where that is ``E'``'s left null space of the
    dimension the instant before had; ``u`` solves the law linearized there
    (:func:`_linearized`) and the factor serves the first step. Else :func:`_start`
    fits ``u`` to ``hint`` in ``H0``'s weights. Returns as :func:`_start`.
    """
    if not _finite(x):
        return 3, 0.0, 0, False
    if p.soften == 0.0:
        _contacts(x, c, s, hint)
        _hessian(x, c, s, 0.0, 0, 0.0)  # unshifted: a shift would hide a dependent row
        rho = _mean_diagonal(s.H)
        nk = _null_space(s.H, s, p.null_rtol)
        if nk == nk_before and _in_left_null_space(x, s, nk, p.null_rtol):
            _linearized(x, c, s, hint, nk, u)
            _project(u, s.V, nk)
            return 0, rho, nk, True
    return _start(x, c, p, s, hint, True, u)


@kernel
def _mean_diagonal(H):
    """``max(trace(H) / m, 1e-300)``: the scale of a chained instant's shift and of its
    ``rho V V'`` (the Hessian at its start stands for ``H0``, as only the optimum, not
    those scales, must not depend on the start).
    """
    trace = 0.0
    for i in range(H.shape[0]):
        trace += H[i, i]
    return max(trace / H.shape[0], 1e-300)


@kernel
def _linearized(x: Data, c, s: Scratch, hint, nk, u):
    """``u`` of the contacts' law linearized at ``hint``: ``H u = e + E (W hint -
    f(hint))`` through ``s.L`` (``H_q d_q = slope_q d_q``; ``s.f``, ``s.slope`` at
    ``hint``).
    """
    m = x.Et.shape[1]
    s.rhs[:] = x.e
    for q in range(c.members.shape[0]):
        for p in range(c.members.shape[1]):
            if c.mask[q, p] > 0:
                col = c.members[q, p]
                a = s.slope[q] * hint[col] - s.f[col]
                for i in range(x.span[col, 0], x.span[col, 1]):
                    s.rhs[i] += x.Et[col, i] * a
    _project(s.rhs, s.V, nk)  # (e's part along V: no force does work there)
    _solve(s.L, s.rhs, u, s.dependent, m)


@kernel
def _iterate(x: Data, c, p, s: Scratch, u, rho, nk, factored, limit):
    """Newton's method from ``u``, at most ``limit`` steps (``factored``: ``s.L`` holds
    the first step's factor); returns ``(status, iterations)``.
    """
    rho_soft, shift = p.soften * rho, p.reg_rtol * rho
    m = x.Et.shape[1]
    scale = _norm(x.e)
    for it in range(limit + 1):
        _state(x, c, s, u)
        norm = _gradient(x, s, u, rho_soft, nk)
        if not np.isfinite(norm):
            return 3, it
        if norm <= p.tol * scale:
            return 0, it
        if it == limit:
            break
        if it > 0 or not factored:
            _hessian(x, c, s, shift + rho_soft, nk, rho)
            if not _cholesky(s.H, s.L, s.dependent, 0.0):
                return 4, it
        for i in range(m):
            s.rhs[i] = -s.grad[i]
        _solve(s.L, s.rhs, s.du, s.dependent, m)
        _project(s.du, s.V, nk)  # (a factor with dependent rows skipped: held out here)
        if _step(x, c, s, u, rho_soft, p) == 0.0:  # no decrease left: rounding
            return (0 if norm <= p.stall * p.tol * scale else 2), it
    return 1, limit


@kernel
def _instant(x: Data, c, p, s: Scratch, hint, use_hint, u, rho, nk, factored, warm):
    """Newton's method from a started ``u`` (:func:`_warm`, :func:`_start`); a chain's
    warm start that has not converged in ``p.warm_iter`` steps (a start across a
    change of the contacts' states, from which the steps crawl) is abandoned for
    :func:`_start`'s. Returns ``(status, iterations)``, both attempts' steps counted.
    """
    if not warm:
        return _iterate(x, c, p, s, u, rho, nk, factored, p.max_iter)
    code, spent = _iterate(x, c, p, s, u, rho, nk, factored, min(p.warm_iter, p.max_iter))
    if code == 0:
        return code, spent
    code, rho, nk, factored = _start(x, c, p, s, hint, use_hint, u)
    if code:
        return code, spent
    code, more = _iterate(x, c, p, s, u, rho, nk, factored, p.max_iter)
    return code, spent + more


@kernel
def _step(x: Data, c, s: Scratch, u, rho_soft, p):
    """The line search along ``s.du`` from ``u`` (its slope at 0 the gradient's along
    the step) and the move; returns the length.
    """
    m = x.Et.shape[1]
    e_du, start = 0.0, 0.0
    for i in range(m):
        e_du += x.e[i] * s.du[i]
        start += s.grad[i] * s.du[i]
    _deformations(x.Et, x.span, s.du, s.delta)
    t = _line_search(x, c, s, u, s.du, e_du, rho_soft, p, start)
    for i in range(m):
        u[i] += t * s.du[i]
    return t


@kernel
def _scratch(nv, m, G, w, dense):
    """A :class:`Scratch` for ``m`` rows, ``nv`` columns and ``G`` contacts of width
    ``w``.
    """
    return Scratch(np.zeros((m, m)), np.zeros((m, m)), np.zeros((m, m)), np.zeros((m, m)),
                   np.zeros(m, np.bool_), np.zeros(m), np.zeros(m), np.zeros(m),
                   np.zeros(nv), np.zeros(nv), np.zeros(nv), np.zeros(nv), np.zeros(G),
                   np.zeros(G), np.zeros((G, w)), np.zeros(m), np.zeros(w),
                   np.zeros((G, w)), np.zeros((G, w)), np.zeros(G),
                   np.zeros((nv + G, m)), np.zeros((nv + G, 2), np.int64), dense)


@kernel
def _extrapolate(d_out, status, i, order, hint):
    """``hint``: the deformations at instant ``i`` extrapolated by the polynomial through
    the last ``p <= order`` solved instants before it, one after the other
    (:func:`._newton_numpy.extrapolate`).
    """
    p = 1
    while p < order and i - p - 1 >= 0 and status[i - p - 1] == 0:
        p += 1
    hint[:] = 0.0
    weight = 1.0
    for j in range(1, p + 1):  # (-1)^(j+1) binomial(p, j)
        weight = weight * (p - j + 1) / j
        sign = 1.0 if j % 2 == 1 else -1.0
        for col in range(len(hint)):
            hint[col] += sign * weight * d_out[i - j, col]


@kernel(nogil=True)
def newton(Et, span, e, contacts, k, g, d0, start, chain, params):
    """:func:`._newton_numpy.newton_numpy` compiled: ``(u, d, status, iterations)``. ``Et``
    (T, nv, m) holds ``E'`` (a column of ``E`` a contiguous row), ``span`` (nv, 2) the
    rows ``[lo, hi)`` where each column can be nonzero at any instant; ``contacts`` a
    :class:`._newton_state.Contacts`, ``params`` a :class:`._newton_state.Params`.
    """
    T, nv, m = Et.shape
    covered = 0
    for j in range(nv):
        covered += span[j, 1] - span[j, 0]
    s = _scratch(nv, m, contacts.members.shape[0], contacts.members.shape[1],
                 covered >= DENSE * nv * m)
    u_out, d_out = np.zeros((T, m)), np.zeros((T, nv))
    status, iters = np.zeros(T, np.int64), np.zeros(T, np.int64)
    hint = np.zeros(nv)
    nk = 0
    for i in range(T):
        x = Data(Et[i], span, e[i], k[i], g[i])
        warm = chain and i > 0 and status[i - 1] == 0
        if warm:
            _extrapolate(d_out, status, i, params.extrapolation, hint)
            code, rho, nk, factored = _warm(x, contacts, params, s, hint, u_out[i], nk)
        else:
            code, rho, nk, factored = _start(x, contacts, params, s, d0[i], start[i],
                                             u_out[i])
        if code:
            status[i] = code
        else:
            status[i], iters[i] = _instant(x, contacts, params, s, d0[i], start[i],
                                           u_out[i], rho, nk, factored, warm)
        _deformations(Et[i], span, u_out[i], d_out[i])
    return u_out, d_out, status, iters
