r"""Compiled interior point of ``reduced-ipm`` (numba, extra ``numba``).

The method of :mod:`.reduced_ipm` (its NumPy reference: problem (1), optimality (2),
Nesterov-Todd scaling, Mehrotra's predictor-corrector, the same start, stopping rules,
step rules, best iterate and exit codes), one instant after the other in runs of
:data:`RUN` consecutive instants, the runs side by side on numba's threads. The run cut
does not depend on the thread count, and an instant reads nothing of another unless it
is warm-started, so no answer depends on the threads.

One place differs in how, not what: the Newton system (3)
``[P G'; G -W^2] (dx, dz) = (a, b)`` is solved in its scaled form. With
``G_W = W^-1 G`` (m, k) and ``dz_W = W dz`` it reads ``P dx + G_W' dz_W = a``,
``G_W dx - dz_W = c``, ``c = W^-1 b``: ``dz_W = G_W dx - c`` and

    (P + G_W' G_W) dx = a + G_W' c,                                                 (4)

``k x k`` (7-12 on the built-in scenes) by a Cholesky factor, instead of LU with
partial pivoting of the ``(k + m)``-square system (43-64 rows): on ``paper``'s
``min_max`` (k = 8, m = 56) about 2e3 multiply-adds to form and factor against 1.7e5.
Near the optimum ``W^-2`` spans many decades and (4) alone leaves the first row's
residual ``a - P dx - G'dz`` (the dual residual's step) at the rounding of
``||G_W' G_W|| ||dx||``, which on ``min_max`` stalled the dual residual near 1e-7
(module docstring of :mod:`.reduced_ipm`). Iterative refinement on the scaled system
corrects it (:func:`_reduced_solve`, at most :data:`REFINE` steps): the residual of
both rows, computed from ``P``, ``G_W`` and ``dz_W`` (``G_W' dz_W = G' dz``), solved
again by the same factor. Only the corrector's direction is refined: the predictor's
sets only the centring and the second-order term, and refining it changed no exit
code on ``paper``'s ``min_max`` and ``socp_face``. Without refinement 29 % of
``paper``'s ``min_max`` instants ended short of ``tol``; with at most one step 4 %,
two 0.5 %, three 0.1 %, four none. (4)'s matrix ``P + G'W^-2 G`` is the Schur
complement of ``-W^2`` in (3): a factor that is not positive definite or not finite
ends the instant as the reference's singular ``K`` does (a NaN step:
:data:`.reduced_ipm.STALLED`). The exit codes are the reference's;
on ``socp_face`` the answers are the reference's to 1e-13, on ``min_max`` the optimal
values to 1e-10 while the answers move along its flat tie-break direction as far as
the gap allows (the tests hold both).

Warm start (``warm``): an instant after the first of its run starts from the one before
it when that one was solved: ``x`` its answer, ``s`` and ``z`` its answer moved into
the cones' interior (:func:`_warm_start`); one that this leaves short of solved is
solved again from the cold start (its iterations count both). Then an instant's
answer depends on the instants before it in its run (never on the threads).

The reduction of a formulation's problems into (1) and the lift of (1)'s answers back
(:func:`reduce`, :func:`lift`: the compiled form of :mod:`.conversions` and
:mod:`.reduced_`'s NumPy, which the tests hold them to) run here too, one instant after
the other on numba's threads, where the formulation gives its null-space basis.

Nothing raises on numbers (NumPy's error model, :mod:`cardan_forces.util.compiled`):
non-finite numbers end an instant with a code, as in the reference. No fastmath: every
operation rounds as IEEE 754 says.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from cardan_forces.util.compiled import HAVE_NUMBA, njit

from .reduced_ipm import ALMOST, BROKEN, INFEASIBLE, LIMIT, RUNNING, SOLVED, STALLED

if not HAVE_NUMBA:  # an optional extra: the caller takes the NumPy reference
    raise ImportError("numba is not installed")

import numba  # noqa: E402 (numba only)

RUN = 64
"""Instants per run: the unit of work of a thread, and of a warm start's chain (its
first instant starts cold)."""

REFINE = 4
"""Steps of iterative refinement of a Newton solve, at most (:func:`_reduced_solve`)."""

REFINE_RTOL = 1e-14
"""A Newton solve is refined while its residual is above this relative to its
right-hand side (:func:`_reduced_solve`)."""

WARM_MARGIN = 1e-3
"""A warm start's ``s`` and ``z`` are moved into the cones until their least
eigenvalue is at least this times ``max(1, ||.||_inf)`` (:func:`_warm_start`)."""

kernel = njit(cache=True, depends=("reduced_ipm.py",))
"""The module's ``njit``: cached, compiled again when the reference's codes change."""


class Params(NamedTuple):
    """The method's settings (:mod:`.reduced_ipm`'s constants and the call's options)."""

    tol: float
    max_iter: int
    centrality: float
    backtracks: int
    min_step: float
    step_fraction: float
    reduced: float
    refine: int
    refine_rtol: float
    warm_margin: float


class Cones(NamedTuple):
    """The rows of (1) by cone: ``nonneg`` (l,) orthant rows; second-order block ``b``
    the ``size[b]`` rows from ``start[b]`` (apex first).
    """

    nonneg: np.ndarray
    start: np.ndarray
    size: np.ndarray


class Scratch(NamedTuple):
    """What one run works in (``m`` rows, ``k`` unknowns), allocated once per run."""

    d: np.ndarray
    """(m,) orthant scaling ``sqrt(s / z)`` on the orthant rows."""
    eta: np.ndarray
    """(p,) each block's ``eta``."""
    w: np.ndarray
    """(m,) each block's NT vector ``w`` on its rows."""
    lam: np.ndarray
    """(m,) ``lambda = W z``."""
    Gw: np.ndarray
    """(m, k) ``W^-1 G``."""
    L: np.ndarray
    """(k, k) lower Cholesky factor of (4)."""
    rx: np.ndarray
    """(k,) ``P x + q + G'z``."""
    rz: np.ndarray
    """(m,) ``G x + s - h``."""
    Gx: np.ndarray
    """(m,) ``G x``."""
    Px: np.ndarray
    """(k,) ``P x``."""
    Gtz: np.ndarray
    """(k,) ``G'z``."""
    dx: np.ndarray
    """(k,) a Newton step's ``dx``."""
    dzw: np.ndarray
    """(m,) a Newton step's ``W dz``."""
    dsw: np.ndarray
    """(m,) a Newton step's ``W^-1 ds``."""
    dsw_a: np.ndarray
    """(m,) the predictor's ``W^-1 ds``."""
    dzw_a: np.ndarray
    """(m,) the predictor's ``W dz``."""
    u: np.ndarray
    """(m,) a scaled right-hand side."""
    c: np.ndarray
    """(m,) ``W^-1 b`` of (4); a refinement's second residual."""
    a: np.ndarray
    """(k,) the first right-hand side of (4), ``-r_x``."""
    ex: np.ndarray
    """(k,) a refinement's first residual, then its correction."""
    t1: np.ndarray
    """(m,) scratch."""
    t2: np.ndarray
    """(m,) scratch."""
    ds: np.ndarray
    """(m,) the step's ``ds``."""
    dz: np.ndarray
    """(m,) the step's ``dz``."""
    best_x: np.ndarray
    """(k,) the best iterate's ``x``."""
    best_s: np.ndarray
    """(m,) the best iterate's ``s``."""
    best_z: np.ndarray
    """(m,) the best iterate's ``z``."""


@kernel
def _scratch(m, k, p):
    """A run's :class:`Scratch`."""
    return Scratch(np.zeros(m), np.zeros(p), np.zeros(m), np.zeros(m), np.zeros((m, k)),
                   np.zeros((k, k)), np.zeros(k), np.zeros(m), np.zeros(m), np.zeros(k),
                   np.zeros(k), np.zeros(k), np.zeros(m), np.zeros(m), np.zeros(m),
                   np.zeros(m), np.zeros(m), np.zeros(m), np.zeros(k), np.zeros(k),
                   np.zeros(m), np.zeros(m), np.zeros(m), np.zeros(m), np.zeros(k),
                   np.zeros(m), np.zeros(m))


# Cone algebra on (m,) vectors.

@kernel
def _dot(u, v):
    total = 0.0
    for i in range(len(u)):
        total += u[i] * v[i]
    return total


@kernel
def _tail_dot(u, v, r0, n):
    """``u1'v1`` of the block of ``n`` rows from ``r0``."""
    total = 0.0
    for j in range(r0 + 1, r0 + n):
        total += u[j] * v[j]
    return total


@kernel
def _jordan(cones, u, v, out):
    """``out = u o v``."""
    for i in cones.nonneg:
        out[i] = u[i] * v[i]
    for b in range(len(cones.start)):
        r0, n = cones.start[b], cones.size[b]
        head = u[r0] * v[r0] + _tail_dot(u, v, r0, n)
        for j in range(r0 + 1, r0 + n):
            out[j] = u[r0] * v[j] + v[r0] * u[j]
        out[r0] = head


@kernel
def _jordan_solve(cones, lam, v, out):
    """``out`` with ``lam o out = v`` (``lam`` in the cone's interior)."""
    for i in cones.nonneg:
        out[i] = v[i] / lam[i]
    for b in range(len(cones.start)):
        r0, n = cones.start[b], cones.size[b]
        l0, v0 = lam[r0], v[r0]
        det = l0 * l0 - _tail_dot(lam, lam, r0, n)
        w0 = (l0 * v0 - _tail_dot(lam, v, r0, n)) / det
        for j in range(r0 + 1, r0 + n):
            out[j] = (v[j] - w0 * lam[j]) / l0
        out[r0] = w0


@kernel
def _least_eigenvalue(cones, u):
    """The least eigenvalue of ``u`` (``u0 - ||u1||`` on a block)."""
    low = np.inf
    for i in cones.nonneg:
        low = min(low, u[i])
    for b in range(len(cones.start)):
        r0, n = cones.start[b], cones.size[b]
        low = min(low, u[r0] - np.sqrt(_tail_dot(u, u, r0, n)))
    return low


@kernel
def _shift(cones, u, a):
    """``u += a e``."""
    for i in cones.nonneg:
        u[i] += a
    for b in range(len(cones.start)):
        u[cones.start[b]] += a


@kernel
def _max(a, b):
    """``max(a, b)``, NaN where either is (``np.maximum``; Python's ``max`` drops one)."""
    if a != a or b != b:
        return np.nan
    return a if a >= b else b


@kernel
def _min(a, b):
    """``min(a, b)``, NaN where either is (``np.minimum``)."""
    if a != a or b != b:
        return np.nan
    return a if a <= b else b


@kernel
def _inf(u):
    """``||u||_inf``, NaN where ``u`` holds one."""
    out = 0.0
    for i in range(len(u)):
        out = _max(out, abs(u[i]))
    return out


@kernel
def _into_cone(cones, u):
    """``u + (1 - min(0, lambda_min(u))) e`` where ``u`` is not strictly inside (CVXOPT's
    start, :func:`.reduced_ipm._into_cone`).
    """
    low = _least_eigenvalue(cones, u)
    if low < 1e-8 * max(1.0, _inf(u)):
        _shift(cones, u, 1.0 - min(low, 0.0))


@kernel
def _jsquare(u, r0, n):
    """``u'Ju`` of a block."""
    return u[r0] * u[r0] - _tail_dot(u, u, r0, n)


@kernel
def _scaling(cones, s, z, S):
    """The Nesterov-Todd scaling of ``s``, ``z`` into ``S.d``, ``S.eta``, ``S.w`` and
    ``S.lam = W z`` (:class:`.reduced_ipm.Scaling`).
    """
    for i in cones.nonneg:
        S.d[i] = np.sqrt(s[i] / z[i])
    for b in range(len(cones.start)):
        r0, n = cones.start[b], cones.size[b]
        ns, nz = np.sqrt(_jsquare(s, r0, n)), np.sqrt(_jsquare(z, r0, n))
        dot = 0.0
        for j in range(r0, r0 + n):
            dot += (s[j] / ns) * (z[j] / nz)
        gamma = np.sqrt(0.5 * (1.0 + dot))
        S.w[r0] = (s[r0] / ns + z[r0] / nz) / (2.0 * gamma)
        for j in range(r0 + 1, r0 + n):
            S.w[j] = (s[j] / ns - z[j] / nz) / (2.0 * gamma)
        S.eta[b] = np.sqrt(ns / nz)
    _apply(cones, S.d, S.eta, S.w, z, S.lam, False)


@kernel
def _apply(cones, d, eta, w, v, out, inverse):
    """``out = W v`` (``W^-1 v`` with ``inverse``) of the scaling ``d``, ``eta``, ``w``
    (:class:`Scratch`); ``out`` may be ``v``.
    """
    for i in cones.nonneg:
        out[i] = v[i] / d[i] if inverse else v[i] * d[i]
    sign = -1.0 if inverse else 1.0
    for b in range(len(cones.start)):
        r0, n = cones.start[b], cones.size[b]
        w0, v0 = w[r0], v[r0]
        w1v1 = _tail_dot(w, v, r0, n)
        factor = sign * v0 + w1v1 / (1.0 + w0)
        e = eta[b]
        for j in range(r0 + 1, r0 + n):
            t = v[j] + factor * w[j]
            out[j] = t / e if inverse else t * e
        head = w0 * v0 + sign * w1v1
        out[r0] = head / e if inverse else head * e


@kernel
def _scale_rows(cones, d, eta, w, G, Gw, tail, factor):
    """``Gw = W^-1 G``: :func:`_apply` of each column, row by row (the same numbers);
    ``tail`` and ``factor`` (k,) scratch.
    """
    k = G.shape[1]
    for r in cones.nonneg:
        for i in range(k):
            Gw[r, i] = G[r, i] / d[r]
    for b in range(len(cones.start)):
        r0, n = cones.start[b], cones.size[b]
        w0, e = w[r0], eta[b]
        tail[:] = 0.0
        for j in range(r0 + 1, r0 + n):
            for i in range(k):
                tail[i] += w[j] * G[j, i]
        for i in range(k):
            factor[i] = -G[r0, i] + tail[i] / (1.0 + w0)
        for j in range(r0 + 1, r0 + n):
            for i in range(k):
                Gw[j, i] = (G[j, i] + factor[i] * w[j]) / e
        for i in range(k):
            Gw[r0, i] = (w0 * G[r0, i] - tail[i]) / e


@kernel
def _max_step(cones, u, du):
    """The largest ``a`` with ``u + a du`` in the cone (``inf`` where every direction
    stays inside; :func:`.reduced_ipm.max_step`).
    """
    step = np.inf
    for i in cones.nonneg:
        if du[i] < 0:
            step = min(step, -u[i] / du[i])
    for b in range(len(cones.start)):
        r0, n = cones.start[b], cones.size[b]
        v0, d0 = u[r0], du[r0]
        inv = 1.0 / np.sqrt(_jsquare(u, r0, n))
        rho0 = (v0 * d0 - _tail_dot(u, du, r0, n)) * inv * inv
        factor = (rho0 + d0 * inv) / (v0 * inv + 1.0)
        rho1 = 0.0
        for j in range(r0 + 1, r0 + n):
            t = (du[j] - factor * u[j]) * inv
            rho1 += t * t
        sigma = np.sqrt(rho1) - rho0
        if sigma > 0:
            step = min(step, 1.0 / sigma)
    return step


# Dense linear algebra of (4).

@kernel
def _factor(P, Gw, L):
    """``L`` the lower Cholesky factor of ``P + Gw'Gw``: ``False`` where a pivot is not
    positive or not finite.
    """
    m, k = Gw.shape
    L[:, :] = P
    for r in range(m):  # row by row: independent sums, each in row order (all of the
        for i in range(k):  # square: full rows vectorize, a triangle's do not)
            g = Gw[r, i]
            for j in range(k):
                L[i, j] += g * Gw[r, j]
    for j in range(k):
        pivot = L[j, j]
        for c in range(j):
            pivot -= L[j, c] * L[j, c]
        if not (pivot > 0.0 and pivot < np.inf):
            return False
        root = np.sqrt(pivot)
        L[j, j] = root
        for i in range(j + 1, k):
            total = L[i, j]
            for c in range(j):
                total -= L[i, c] * L[j, c]
            L[i, j] = total / root
    return True


@kernel
def _cholesky_solve(L, v):
    """``v = (L L')^-1 v`` in place."""
    k = len(v)
    for i in range(k):
        total = v[i]
        for c in range(i):
            total -= L[i, c] * v[c]
        v[i] = total / L[i, i]
    for i in range(k - 1, -1, -1):
        total = v[i]
        for c in range(i + 1, k):
            total -= L[c, i] * v[c]
        v[i] = total / L[i, i]


@kernel
def _reduced_solve(P, Gw, L, a, c, dx, dzw, refine, refine_rtol, e, f):
    """``dx``, ``dz_W`` of ``P dx + Gw' dz_W = a``, ``Gw dx - dz_W = c`` by (4) with
    ``L`` its factor, refined (module docstring) while the residual of the two rows
    (their correction's right-hand sides: ``f = c - Gw dx + dz_W`` and ``a - P dx -
    Gw' dz_W + Gw' f``) is above ``refine_rtol (1 + ||a||_inf)``, at most ``refine``
    times. ``e`` (k,) and ``f`` (m,) scratch.
    """
    m, k = Gw.shape
    dx[:] = a
    _add_transposed(Gw, c, dx)
    _cholesky_solve(L, dx)
    _row_product(Gw, dx, c, dzw)
    bound = refine_rtol * (1.0 + _inf(a))
    for _ in range(refine):
        for r in range(m):  # f - dz_W = c - Gw dx
            total = c[r]
            for i in range(k):
                total -= Gw[r, i] * dx[i]
            f[r] = total
        for i in range(k):
            total = a[i]
            for j in range(k):
                total -= P[i, j] * dx[j]
            e[i] = total
        _add_transposed(Gw, f, e)
        for r in range(m):
            f[r] += dzw[r]
        error = max(_inf(e), _inf(f))
        if error <= bound:
            break
        _cholesky_solve(L, e)
        for i in range(k):
            dx[i] += e[i]
        for r in range(m):  # dz_W += Gw e - f
            total = -f[r]
            for i in range(k):
                total += Gw[r, i] * e[i]
            dzw[r] += total


@kernel
def _add_transposed(G, v, out):
    """``out += G'v``, row by row (independent sums, each in row order)."""
    m, k = G.shape
    for r in range(m):
        a = v[r]
        for i in range(k):
            out[i] += G[r, i] * a


@kernel
def _row_product(Gw, x, c, out):
    """``out = Gw x - c``."""
    m, k = Gw.shape
    for r in range(m):
        total = -c[r]
        for i in range(k):
            total += Gw[r, i] * x[i]
        out[r] = total


@kernel
def _newton(P, G, cones, S, u, dx, dzw, dsw, refine, refine_rtol):
    """The Newton direction (3) for the scaled right-hand side ``u``: ``dx``, ``W dz``,
    ``W^-1 ds`` (:func:`.reduced_ipm._newton`, with the same choice of ``ds`` on a row
    or block far from its bound: ``W^-1 (-r_z - G dx)`` where ``W`` is above 1), with
    ``refine`` and ``refine_rtol`` as :func:`_reduced_solve` takes them.
    """
    m, k = G.shape
    c, t = S.c, S.t1
    _apply(cones, S.d, S.eta, S.w, S.rz, c, True)
    for r in range(m):  # c = W^-1 (-r_z - W u) = -W^-1 r_z - u
        c[r] = -c[r] - u[r]
    for i in range(k):
        S.a[i] = -S.rx[i]
    _reduced_solve(P, S.Gw, S.L, S.a, c, dx, dzw, refine, refine_rtol, S.ex, S.t2)
    for r in range(m):  # t = -r_z - G dx
        total = -S.rz[r]
        for i in range(k):
            total -= G[r, i] * dx[i]
        t[r] = total
    _apply(cones, S.d, S.eta, S.w, t, t, True)
    for i in cones.nonneg:
        dsw[i] = t[i] if S.d[i] > 1 else u[i] - dzw[i]
    for b in range(len(cones.start)):
        r0, n = cones.start[b], cones.size[b]
        far = S.eta[b] > 1
        for j in range(r0, r0 + n):
            dsw[j] = t[j] if far else u[j] - dzw[j]


@kernel
def _step(P, G, cones, s, z, gap, degree, params, S):
    """The predictor-corrector step: ``S.dx``, ``S.ds``, ``S.dz`` and ``alpha`` (NaN
    where the Newton system has no positive definite factor).
    """
    _scaling(cones, s, z, S)
    m, k = G.shape
    _scale_rows(cones, S.d, S.eta, S.w, G, S.Gw, S.ex, S.a)
    if not _factor(P, S.Gw, S.L):
        return np.nan
    lam, u = S.lam, S.u
    for r in range(m):
        u[r] = -lam[r]
    _newton(P, G, cones, S, u, S.dx, S.dzw_a, S.dsw_a, 0, params.refine_rtol)
    alpha_a = min(1.0, min(_max_step(cones, lam, S.dsw_a), _max_step(cones, lam, S.dzw_a)))
    sigma = min(max(1.0 - alpha_a, 0.0), 1.0) ** 3
    _jordan(cones, lam, lam, S.t1)
    _jordan(cones, S.dsw_a, S.dzw_a, S.t2)
    for r in range(m):
        S.t1[r] += S.t2[r]
    _shift(cones, S.t1, -sigma * gap / degree)
    _jordan_solve(cones, lam, S.t1, u)
    for r in range(m):
        u[r] = -u[r]
    _newton(P, G, cones, S, u, S.dx, S.dzw, S.dsw, params.refine, params.refine_rtol)
    alpha = min(1.0, params.step_fraction * min(_max_step(cones, lam, S.dsw),
                                                _max_step(cones, lam, S.dzw)))
    _apply(cones, S.d, S.eta, S.w, S.dsw, S.ds, False)
    _apply(cones, S.d, S.eta, S.w, S.dzw, S.dz, True)
    if not np.isfinite(_dot(S.dx, S.dx) + _dot(S.ds, S.ds) + _dot(S.dz, S.dz)):
        return np.nan
    return _central(cones, s, z, S, alpha, degree, params)


@kernel
def _central(cones, s, z, S, alpha, degree, params):
    """``alpha`` halved until every block of the new point keeps ``sqrt(s'Js z'Jz) >=
    CENTRALITY mu`` (:func:`.reduced_ipm._central`).
    """
    m = len(s)
    sn, zn = S.t1, S.t2
    for _ in range(params.backtracks):
        for r in range(m):
            sn[r] = s[r] + alpha * S.ds[r]
            zn[r] = z[r] + alpha * S.dz[r]
        mu = _dot(sn, zn) / degree
        low = np.inf
        for b in range(len(cones.start)):
            r0, n = cones.start[b], cones.size[b]
            low = min(low, np.sqrt(max(_jsquare(sn, r0, n) * _jsquare(zn, r0, n), 0.0)))
        if low >= params.centrality * mu:
            break
        alpha *= 0.5
    return alpha


@kernel
def _start_x(P, q, G, h, x, H):
    """CVXOPT's start (:func:`.reduced_ipm._start_x`): ``(P + G'G) x = -q + G'h`` by LU
    with partial pivoting of ``H`` (k, k) scratch; NaN where it is singular.
    """
    m, k = G.shape
    trace = 0.0
    for i in range(k):
        total = -q[i]
        for r in range(m):
            total += G[r, i] * h[r]
        x[i] = total
        for j in range(k):
            total = P[i, j]
            for r in range(m):
                total += G[r, i] * G[r, j]
            H[i, j] = total
        trace += H[i, i]
    for i in range(k):
        H[i, i] += 1e-14 * trace
    for j in range(k):
        pivot = j
        for i in range(j + 1, k):
            if abs(H[i, j]) > abs(H[pivot, j]):
                pivot = i
        if not H[pivot, j] != 0.0:
            x[:] = np.nan
            return
        if pivot != j:
            for c in range(k):
                H[j, c], H[pivot, c] = H[pivot, c], H[j, c]
            x[j], x[pivot] = x[pivot], x[j]
        for i in range(j + 1, k):
            f = H[i, j] / H[j, j]
            for c in range(j + 1, k):
                H[i, c] -= f * H[j, c]
            x[i] -= f * x[j]
    for i in range(k - 1, -1, -1):
        total = x[i]
        for c in range(i + 1, k):
            total -= H[i, c] * x[c]
        x[i] = total / H[i, i]


@kernel
def _cold_start(P, q, G, h, cones, x, s, z, S):
    """The reference's start: ``x`` by :func:`_start_x`, ``s = h - G x`` and ``z = G x -
    h`` moved into the cones.
    """
    _start_x(P, q, G, h, x, S.L)
    m, k = G.shape
    for r in range(m):
        total = -h[r]
        for i in range(k):
            total += G[r, i] * x[i]
        s[r], z[r] = -total, total
    _into_cone(cones, s)
    _into_cone(cones, z)


@kernel
def _warm_start(cones, margin, s, z):
    """``s``, ``z`` (the instant before's answer) moved into the cones along ``e`` until
    their least eigenvalue is at least ``margin max(1, ||.||_inf)``: an answer on the
    cones' boundary is no interior start, and one barely inside gives the first steps
    a scaling of many decades.
    """
    for u in (s, z):
        floor = margin * max(1.0, _inf(u))
        low = _least_eigenvalue(cones, u)
        if not low >= floor:
            _shift(cones, u, floor - low)


@kernel
def _instant(P, q, G, h, cones, params, S, x, s, z):
    """One instant from ``x``, ``s``, ``z`` (strictly inside): ``(code, iterations)``,
    ``x``, ``s``, ``z`` its answer (:func:`.reduced_ipm._solve`, one instant).
    """
    m, k = G.shape
    tol = params.tol
    degree = len(cones.nonneg) + len(cones.start)
    h_norm = _inf(h)
    best = np.inf
    code, iterations = RUNNING, 0
    for it in range(params.max_iter + 1):
        for r in range(m):
            total = 0.0
            for i in range(k):
                total += G[r, i] * x[i]
            S.Gx[r] = total
            S.rz[r] = total + s[r] - h[r]
        primal, quad = 0.0, 0.0
        for i in range(k):
            total = 0.0
            for j in range(k):
                total += P[i, j] * x[j]
            S.Px[i] = total
            quad += x[i] * 0.5 * total
            primal += x[i] * (0.5 * total + q[i])
        S.Gtz[:] = 0.0
        _add_transposed(G, z, S.Gtz)
        for i in range(k):
            S.rx[i] = S.Px[i] + q[i] + S.Gtz[i]
        gap = _dot(s, z)
        hz = _dot(h, z)
        dual = -quad - hz
        scale = 1.0 + _max(_inf(S.Px), _max(_inf(q), _inf(S.Gtz)))
        merit = _max(_inf(S.rz) / (1.0 + _max(h_norm, _max(_inf(S.Gx), _inf(s)))),
                     _max(_inf(S.rx) / scale,
                          gap / _max(1.0, _min(abs(primal), abs(dual))))) / tol
        if merit < best:
            best = merit
            S.best_x[:] = x
            S.best_s[:] = s
            S.best_z[:] = z
        finite = np.isfinite(gap)
        for i in range(k):
            finite = finite and np.isfinite(x[i])
        if not finite:
            code = BROKEN
        elif merit <= 1.0:
            code = SOLVED
        elif hz < 0 and _inf(S.Gtz) <= tol * -hz:
            code = INFEASIBLE
        elif it == params.max_iter:
            code = LIMIT
        if code != RUNNING:
            break
        iterations += 1
        alpha = _step(P, G, cones, s, z, gap, degree, params, S)
        if not alpha >= params.min_step:
            code = STALLED
            break
        for i in range(k):
            x[i] += alpha * S.dx[i]
        for r in range(m):
            s[r] += alpha * S.ds[r]
            z[r] += alpha * S.dz[r]
    if code >= LIMIT:
        x[:] = S.best_x
        s[:] = S.best_s
        z[:] = S.best_z
        if best <= params.reduced:
            code = ALMOST
    return code, iterations


@njit(cache=True, parallel=True, depends=("reduced_ipm.py",))
def solve(P, q, G, h, cones, params, warm):
    """Problems (1) at ``T`` instants (:func:`.reduced_ipm.solve`): ``P`` (T, k, k),
    ``q`` (T, k), ``G`` (T, m, k), ``h`` (T, m), ``cones`` a :class:`Cones`, ``params``
    a :class:`Params`; ``warm`` chains the instants of each run (module docstring).
    Returns ``(x, z, s, iterations, code)``.
    """
    T, m, k = G.shape
    x_out, s_out, z_out = np.zeros((T, k)), np.zeros((T, m)), np.zeros((T, m))
    code, iterations = np.zeros(T, np.int64), np.zeros(T, np.int64)
    runs = (T + RUN - 1) // RUN
    for run in numba.prange(runs):
        S = _scratch(m, k, len(cones.start))
        for t in range(run * RUN, min(T, (run + 1) * RUN)):
            _solve_instant(P[t], q[t], G[t], h[t], cones, params, S, warm and t > run * RUN,
                           x_out, s_out, z_out, code, iterations, t)
    return x_out, z_out, s_out, iterations, code


@kernel
def _solve_instant(P, q, G, h, cones, params, S, warm, x_out, s_out, z_out, code,
                   iterations, t):
    """Instant ``t`` of :func:`solve` into row ``t`` of its outputs; ``warm``: from the
    answer of instant ``t - 1`` where that one was solved.
    """
    x, s, z = x_out[t], s_out[t], z_out[t]
    spent = 0
    if warm and code[t - 1] == SOLVED:
        x[:] = x_out[t - 1]
        s[:] = s_out[t - 1]
        z[:] = z_out[t - 1]
        _warm_start(cones, params.warm_margin, s, z)
        code[t], spent = _instant(P, q, G, h, cones, params, S, x, s, z)
    if spent == 0 or code[t] != SOLVED:  # cold, or again cold
        _cold_start(P, q, G, h, cones, x, s, z, S)
        code[t], iterations[t] = _instant(P, q, G, h, cones, params, S, x, s, z)
    iterations[t] += spent


# The reduction (1) of a formulation's problems and the lift of their answers.

@njit(cache=True, parallel=True)
def reduce(P, q, A, b, N, eq, rows, member, sign, partner):
    """The reduced and folded problems (1) of the full ones (the compiled form of
    :func:`~.conversions.eliminate_equalities` with a formulation's basis, then
    :meth:`~.reduced_.Folded.rows`), one instant after the other on numba's threads.

    ``P`` (1 or T, n, n) the full objective's matrix, ``q`` (T, n), ``A`` (T, M, n),
    ``b`` (T, M); ``N`` (T, n, k) an orthonormal basis of the null space of the
    equality rows ``eq`` (r,), which are mutually orthogonal (``Conic.null_space``);
    ``rows`` (m,) the full rows of (1)'s rows, the first ``f = len(member)`` of them
    apexes of two-row cones folded with their ``member`` rows and ``sign``: (1)'s row
    ``i < f`` is ``rows[i] - sign[i] member[i]``. Returns ``(P, q, G, h)`` of (1),
    ``z0`` (T, n) the least-norm solution of the equality rows, ``norm`` (T, r) their
    norms (which :func:`lift` takes) and ``same`` (T, f): whether each folded member
    row equals ``sign`` times its ``partner`` row at each instant, to the bit (where
    one does not, the fold does not hold and the caller reduces again without it).
    """
    T, _, n = A.shape
    k, m, f, r = N.shape[2], len(rows), len(member), len(eq)
    P_out, q_out = np.zeros((T, k, k)), np.zeros((T, k))
    G, h = np.zeros((T, m, k)), np.zeros((T, m))
    z0, norm, same = np.zeros((T, n)), np.zeros((T, r)), np.zeros((T, f), np.bool_)
    for t in numba.prange(T):
        _reduce_instant(P[0] if P.shape[0] == 1 else P[t], q[t], A[t], b[t], N[t], eq, rows,
                        member, sign, partner, P_out[t], q_out[t], G[t], h[t], z0[t],
                        norm[t], same[t])
    return P_out, q_out, G, h, z0, norm, same


@kernel
def _reduce_instant(Pt, qt, At, bt, Nt, eq, rows, member, sign, partner, P_out, q_out, G,
                    h, z, norm, same):
    """One instant of :func:`reduce` into its rows of the outputs (overwritten)."""
    n, k = Nt.shape
    P_out[:] = 0.0
    q_out[:] = 0.0
    G[:] = 0.0
    z[:] = 0.0
    for j in range(len(eq)):  # z0 = sum of the rows over their norms, times b over them
        row, total = At[eq[j]], 0.0
        for i in range(n):
            total += row[i] * row[i]
        norm[j] = np.sqrt(total)
        w = bt[eq[j]] / norm[j] / norm[j]
        for i in range(n):
            z[i] += row[i] * w
    PN, g = np.zeros((n, k)), qt.copy()  # P N and P z0 + q, over P's nonzeros
    for i in range(n):
        for c in range(n):
            p = Pt[i, c]
            if p != 0.0:
                g[i] += p * z[c]
                for a in range(k):
                    PN[i, a] += p * Nt[c, a]
    for i in range(n):
        for a in range(k):
            q_out[a] += Nt[i, a] * g[i]
            for c in range(k):
                P_out[a, c] += Nt[i, a] * PN[i, c]
    for j in range(len(rows)):
        rhs = bt[rows[j]] - _row_times(At[rows[j]], 1.0, Nt, z, G[j])
        if j < len(member):
            same[j] = bt[member[j]] == sign[j] * bt[partner[j]]
            for i in range(n):
                same[j] &= At[member[j], i] == sign[j] * At[partner[j], i]
            rhs -= sign[j] * (bt[member[j]] - _row_times(At[member[j]], -sign[j], Nt, z, G[j]))
        h[j] = rhs


@njit(cache=True, parallel=True)
def lift(P, q, A, N, z0, norm, eq, rows, member, sign, x, u):
    """The full problems' answers ``z`` (T, n) and multipliers ``y`` (T, M) from (1)'s
    answers ``x`` (T, k) and multipliers ``u`` (T, m), of the problems :func:`reduce`
    made (the same arguments; the compiled form of :meth:`~.reduced_.Folded.duals`
    then :meth:`~.conversions.Reduced.lift`): ``z = z0 + N x``; a folded row's ``u``
    is its apex's and ``-sign u`` its member's; the equality rows' multipliers by least
    squares on stationarity ``P z + q + A_eq' l + A_in' y_in = 0``, which the rows'
    orthogonality makes ``l = A_eq g / norm^2`` with ``g = -(P z + q + A_in' y_in)``.
    """
    T, M, n = A.shape
    z, y = np.zeros((T, n)), np.zeros((T, M))
    for t in numba.prange(T):
        _lift_instant(P[0] if P.shape[0] == 1 else P[t], q[t], A[t], N[t], z0[t], norm[t], eq,
                      rows, member, sign, x[t], u[t], z[t], y[t])
    return z, y


@kernel
def _lift_instant(Pt, qt, At, Nt, z0, norm, eq, rows, member, sign, x, u, z, y):
    """One instant of :func:`lift` into its rows ``z``, ``y`` (overwritten)."""
    n, k = Nt.shape
    for i in range(n):
        total = z0[i]
        for a in range(k):
            total += Nt[i, a] * x[a]
        z[i] = total
    for j in range(len(rows)):
        y[rows[j]] = u[j]
    for j in range(len(member)):
        y[member[j]] = -sign[j] * u[j]
    g = -qt
    for i in range(n):
        for c in range(n):
            if Pt[i, c] != 0.0:
                g[i] -= Pt[i, c] * z[c]
    _subtract_rows(At, y, rows, member, g)
    for j in range(len(eq)):
        total = 0.0
        for i in range(n):
            total += At[eq[j], i] * g[i]
        y[eq[j]] = total / norm[j] / norm[j]


@njit(cache=True, parallel=True, depends=("reduced_ipm.py",))
def solve_full(P, q, A, b, N, eq, rows, member, sign, partner, cones, params, warm):
    """:func:`reduce`, :func:`solve` and :func:`lift` instant by instant in one pass
    (the same numbers): an instant's full data is read once and is still in the cache
    for its lift, and the instants share one parallel region, where three regions each
    wait for the slower thread (on a machine whose cores other work shares, a
    region's end waited for a thread the system had not scheduled). Returns ``(z, y)``
    of the full problems, ``(x, z, s, iterations, code)`` of (1) as :func:`solve` and
    ``same`` as :func:`reduce`.
    """
    T, M, n = A.shape
    k, m = N.shape[2], len(rows)
    x_out, s_out, z_out = np.zeros((T, k)), np.zeros((T, m)), np.zeros((T, m))
    code, iterations = np.zeros(T, np.int64), np.zeros(T, np.int64)
    z0, norm = np.zeros((T, n)), np.zeros((T, len(eq)))
    same = np.zeros((T, len(member)), np.bool_)
    z, y = np.zeros((T, n)), np.zeros((T, M))
    runs = (T + RUN - 1) // RUN
    for run in numba.prange(runs):
        S = _scratch(m, k, len(cones.start))
        Pr, qr, G, h = np.zeros((k, k)), np.zeros(k), np.zeros((m, k)), np.zeros(m)
        for t in range(run * RUN, min(T, (run + 1) * RUN)):
            Pt = P[0] if P.shape[0] == 1 else P[t]
            _reduce_instant(Pt, q[t], A[t], b[t], N[t], eq, rows, member, sign, partner, Pr,
                            qr, G, h, z0[t], norm[t], same[t])
            _solve_instant(Pr, qr, G, h, cones, params, S, warm and t > run * RUN, x_out,
                           s_out, z_out, code, iterations, t)
            _lift_instant(Pt, q[t], A[t], N[t], z0[t], norm[t], eq, rows, member, sign,
                          x_out[t], z_out[t], z[t], y[t])
    return z, y, x_out, z_out, s_out, iterations, code, same


@kernel
def _row_times(row, scale, N, z, out):
    """``out += scale row N``; returns ``row z``. Over the row's nonzeros: a cone row
    of the built-in formulations has one or two of its 37-52 (a bound on a force).
    """
    total = 0.0
    for i in range(len(row)):
        if row[i] != 0.0:
            total += row[i] * z[i]
            v = scale * row[i]
            for a in range(len(out)):
                out[a] += v * N[i, a]
    return total


@kernel
def _subtract_rows(A, y, rows, member, g):
    """``g -= A_in' y_in`` over the rows ``rows`` and ``member`` (the cone rows)."""
    for part in (rows, member):
        for r in part:
            for i in range(A.shape[1]):
                g[i] -= A[r, i] * y[r]
