"""The Newton method of the ``newton`` family in NumPy: the contacts' energies, their
derivatives, and the iteration (the compiled kernel's reference, :mod:`._newton_kernels`).

The method and its equations: :mod:`.newton_`. Functions take one instant, or a
leading axis of instants where they say ``(..., )``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .record import Status

TOL = 1e-12
"""Default stopping rule: ``||E f - e|| <= TOL ||e||`` (the equilibrium residual, the
only optimality condition the dual iteration leaves inexact)."""
MAX_ITER = 200
"""Newton steps before an instant is left ``inaccurate``: a Hertz contact at its onset
(its slope going to 0) makes the steps crawl (``paper-penalty``'s ``compliance_hertz``
takes up to 75 at an instant where its clearances close)."""
NULL_RTOL = 1e-10
"""A pivot of ``H0``'s Cholesky factor below this, relative to its diagonal entry,
marks a row dependent on the rows before it (a left null direction of ``E``)."""
REG_RTOL = 1e-13
"""``mu / rho``: the shift that keeps a step's factor positive definite."""
LS_RTOL = 1e-3
"""The line search stops at a slope below this fraction of its start's (MuJoCo's
``ls_tolerance`` is 1e-2): near the optimum the full step is there at once, and a
tighter fraction only chases rounding in the slope."""
STALL = 100.0
"""Where the line search finds no decrease left (rounding), the instant counts as
solved if ``||grad|| <= STALL tol ||e||`` (1e-10 at the default ``TOL``: the package's
accuracy level), else it is left ``inaccurate``."""
LS_MAX = 60
"""Line-search evaluations per step."""

EXTRAPOLATION = 4
"""Solved instants a chain's warm start extrapolates from (a cubic through four): on
the built-in grids each order fewer costs about a tenth more Newton steps."""

WARM_ITER = 20
"""Steps a chain's warm start takes before the instant starts again cold: a start
across a change of the contacts' states (a clearance closing, a cone's load passing
zero) can make the steps crawl where a cold start converges in far fewer."""

STATUS = (Status.SOLVED, Status.INACCURATE, Status.INACCURATE, Status.FAILED, Status.FAILED)
"""Status codes of :func:`newton_numpy` and the kernel, by index."""
REASONS = ("", "no convergence in the iteration limit", "the line search made no progress",
           "non-finite numbers or a contact without positive stiffness",
           "a step's factor is not positive definite")
"""Why, by status code."""


@dataclass(frozen=True)
class Groups:
    """The contacts' structure: ``members`` (G, w) columns of ``E`` per contact (padded
    with 0, ``mask`` 1 where real), ``signed`` (G,) a pushing column (a group of one
    with ``f >= 0``), ``n`` (G,) the law's exponent (1 linear).
    """

    members: np.ndarray
    mask: np.ndarray
    signed: np.ndarray
    n: np.ndarray


def groups_of(lists, signed, n) -> Groups:
    """:class:`Groups` of column lists ``lists`` with their ``signed`` flags and ``n``."""
    width = max(len(c) for c in lists)
    members = np.zeros((len(lists), width), np.int64)
    mask = np.zeros((len(lists), width))
    for k, cols in enumerate(lists):
        members[k, :len(cols)] = cols
        mask[k, :len(cols)] = 1.0
    return Groups(members, mask, np.asarray(signed, bool), np.asarray(n, float))


def evaluate(d, groups: Groups, k, g):
    """Per contact at deformations ``d`` (..., nv): load ``r``, slope ``r'``, ``r / s``,
    the unit direction (..., G, w) and the energy; pushing columns are one-sided, an
    exactly touching linear contact counts as loaded (its one-sided slope).
    """
    dg = d[..., groups.members] * groups.mask
    norm = np.sqrt(np.einsum("...gw,...gw->...g", dg, dg))
    s = np.where(groups.signed, dg[..., 0], norm)
    n = groups.n
    over = np.maximum(s - g, 0.0)
    loaded = (s > g) | ((n == 1.0) & (s >= g))
    r = np.where(loaded, (over / k) ** n, 0.0)
    slope = np.where(loaded, n * (over / k) ** (n - 1.0) / k, 0.0)
    ratio = np.where(s > 0, r / np.where(s > 0, s, 1.0), slope)
    unit = np.where(groups.signed[:, None], groups.mask,
                    dg / np.where(norm > 0, norm, 1.0)[..., None])
    return r, slope, ratio, unit, over * r / (n + 1.0)


def forces(d, groups: Groups, k, g) -> np.ndarray:
    """The forces (..., nv) at deformations ``d`` (every column is in one contact)."""
    r, _, _, unit, _ = evaluate(d, groups, k, g)
    return spread(r, unit, groups, np.shape(d))


def spread(r, unit, groups: Groups, shape) -> np.ndarray:
    """The forces (``shape``: (..., nv)) of contacts with loads ``r`` (..., G) along
    their directions ``unit`` (..., G, w).
    """
    f = np.zeros(shape)
    real = groups.mask > 0
    f[..., groups.members[real]] = (r[..., None] * unit)[..., real]
    return f


def _hessian(E, groups: Groups, ratio, slope, unit, rho_soft):
    """``sum_c E_c H_c E_c' + rho_soft I``."""
    beta = np.zeros(E.shape[1])
    np.add.at(beta, groups.members, ratio[:, None] * groups.mask)
    Y = np.einsum("mgw,gw->mg", E[:, groups.members], unit * groups.mask)
    H = (E * beta) @ E.T + (Y * (slope - ratio)) @ Y.T
    return H + rho_soft * np.eye(len(H))


def nominal(E, e, groups: Groups, k):
    """``H0 = sum_c c0 E_c E_c'`` with ``c0 = n F^(1 - 1/n) / k`` the slope at a load
    ``F = ||e||``, and ``rho`` its mean diagonal.
    """
    F = max(float(np.linalg.norm(e)), 1e-300)
    c0 = groups.n * F ** (1.0 - 1.0 / groups.n) / k
    beta = np.zeros(E.shape[1])
    np.add.at(beta, groups.members, c0[:, None] * groups.mask)
    H0 = (E * beta) @ E.T
    return H0, max(float(np.trace(H0)) / len(H0), 1e-300)


def null_basis(H0) -> np.ndarray:
    """An orthonormal basis (m, k) of ``H0``'s null space (the left null space of ``E``):
    the eigenvectors whose eigenvalue is below ``NULL_RTOL`` of the largest diagonal
    entry (the reference of the kernel's pivoted Cholesky).
    """
    w, vecs = np.linalg.eigh(H0)
    return vecs[:, w <= NULL_RTOL * max(float(np.max(np.diag(H0))), 1e-300)]


def line_search(d, delta, u, du, e, groups: Groups, k, g, rho_soft, start) -> float:
    """The step length ``t >= 0`` minimizing ``Phi(u + t du)`` (``delta = E'du``, ``start``
    the slope at 0, the gradient along ``du``): safeguarded Newton on the slope, the
    bracket grown until the slope turns.
    """
    def slope(t):
        r, sl, ratio, unit, _ = evaluate(d + t * delta, groups, k, g)
        dg = delta[groups.members] * groups.mask
        along = np.einsum("gw,gw->g", unit, dg)
        first = r @ along - e @ du + rho_soft * (u + t * du) @ du
        second = (ratio @ np.einsum("gw,gw->g", dg, dg) + (sl - ratio) @ along ** 2
                  + rho_soft * du @ du)
        return first, second

    if not start < 0:
        return 0.0
    lo, hi, t = 0.0, np.inf, 1.0
    for _ in range(LS_MAX):
        first, second = slope(t)
        if abs(first) <= LS_RTOL * abs(start):
            return t
        lo, hi = (t, hi) if first < 0 else (lo, t)
        guess = t - first / second if second > 0 else np.inf
        if not lo < guess < hi:
            guess = 2.0 * t if hi == np.inf else 0.5 * (lo + hi)
        t = guess
    return lo if hi == np.inf else 0.5 * (lo + hi)


def newton_numpy(E, e, groups: Groups, k, g, d0=None, start=None, chain=False,
                 tol=TOL, max_iter=MAX_ITER, soften=0.0):
    """The method at T instants, one after the other (the kernel's NumPy reference).

    ``E`` (T, m, nv), ``e`` (T, m), ``k``, ``g`` (T, G); ``d0`` (T, nv) deformations to
    start from where ``start`` (T,) is set; ``chain``: each instant after a solved one
    starts from the deformations extrapolated from the ones before (:func:`extrapolate`,
    :func:`linearized`). Returns ``u`` (T, m), ``d`` (T, nv), status codes
    and iterations (T,).
    """
    T, m, nv = E.shape
    u_out, d_out = np.zeros((T, m)), np.zeros((T, nv))
    status, iters = np.zeros(T, np.int64), np.zeros(T, np.int64)
    for i in range(T):
        hint = d0[i] if start is not None and start[i] else None
        warm = chain and i and status[i - 1] == 0
        if warm:
            hint = extrapolate(d_out, status, i)
        u_out[i], status[i], iters[i] = _one(E[i], e[i], groups, k[i], g[i], hint, tol,
                                             max_iter, soften, warm)
        d_out[i] = E[i].T @ u_out[i]
    return u_out, d_out, status, iters


def extrapolate(d_out, status, i):
    """The deformations at instant ``i`` extrapolated by the polynomial through the
    last ``p <= EXTRAPOLATION`` solved instants before it, one after the other:
    ``sum_j (-1)^(j+1) binomial(p, j) d[i - j]`` (the ``p``-th difference is zero).
    """
    p = 1
    while p < EXTRAPOLATION and i - p - 1 >= 0 and status[i - p - 1] == 0:
        p += 1
    j = np.arange(1, p + 1)
    weights = (-1.0) ** (j + 1) * np.array([math.comb(p, int(x)) for x in j])
    return weights @ d_out[i - j]


def linearized(E, e, groups: Groups, k, g, hint, V, rho):
    """A chain's start: ``u`` of the contacts' law linearized at the deformations
    ``hint``, ``H u = e + E (W hint - f(hint))`` (``H``, ``W`` the Hessians there,
    ``H_q d_q = slope_q d_q``), and that ``H``, the first step's; ``None`` where ``H``
    has null directions beyond ``V`` (a direction only idle contacts resist).
    """
    r, slope, ratio, unit, _ = evaluate(hint, groups, k, g)
    H = _hessian(E, groups, ratio, slope, unit, 0.0)
    if null_basis(H).shape[1] != V.shape[1]:
        return None
    w = np.zeros(E.shape[1])
    real = groups.mask > 0
    w[groups.members[real]] = np.broadcast_to(slope[:, None], real.shape)[real]
    rhs = e + E @ (w * hint - forces(hint, groups, k, g))
    u = np.linalg.solve(H + rho * V @ V.T + REG_RTOL * rho * np.eye(len(e)), rhs)
    return u - V @ (V.T @ u), H


def _one(E, e, groups, k, g, hint, tol, max_iter, soften, warm):
    """One instant of :func:`newton_numpy`: ``(u, status, iterations)``; ``warm``: a
    chain's (:func:`linearized`, unsoftened; a cold start after :data:`WARM_ITER` steps
    without convergence), else ``hint`` is fitted by least squares.
    """
    if not (np.all(np.isfinite(E)) and np.all(np.isfinite(e)) and np.all(np.isfinite(k))
            and np.all(np.isfinite(g)) and np.all(k > 0)):
        return np.zeros(len(e)), 3, 0
    H0, rho = nominal(E, e, groups, k)
    V = null_basis(H0)
    rho_soft = soften * rho
    start = linearized(E, e, groups, k, g, hint, V, rho) if warm and not soften else None
    if start is not None:
        u, first = start
    elif hint is not None:
        u = np.linalg.lstsq(E.T, hint, rcond=None)[0]
        u, first = u - V @ (V.T @ u), None
    else:
        u, first = np.zeros(len(e)), H0
    args = (E, e, groups, k, g)
    if not warm:
        return _iterate(*args, u, first, V, rho, tol, max_iter, rho_soft)
    u, code, spent = _iterate(*args, u, first, V, rho, tol, min(WARM_ITER, max_iter),
                              rho_soft)
    if code == 0:  # else a start across a change of the contacts' states: cold
        return u, code, spent
    u, code, more = _iterate(*args, np.zeros(len(e)), H0, V, rho, tol, max_iter, rho_soft)
    return u, code, spent + more


def _iterate(E, e, groups, k, g, u, first, V, rho, tol, max_iter, rho_soft):
    """Newton's method from ``u`` (``first``: the first step's matrix, ``None`` for the
    Hessian at ``u``): ``(u, status, iterations)``.
    """
    project = np.eye(len(e)) - V @ V.T
    scale = max(float(np.linalg.norm(e)), 1e-300)
    for it in range(max_iter + 1):
        d = E.T @ u
        r, slope, ratio, unit, _ = evaluate(d, groups, k, g)
        grad = project @ (E @ forces(d, groups, k, g) - e + rho_soft * u)
        if not np.all(np.isfinite(grad)):
            return u, 3, it
        if np.linalg.norm(grad) <= tol * scale:
            return u, 0, it
        if it == max_iter:
            break
        H = first if it == 0 and first is not None else _hessian(E, groups, ratio, slope,
                                                                 unit, rho_soft)
        try:
            factor = np.linalg.cholesky(H + rho * V @ V.T + REG_RTOL * rho * np.eye(len(e)))
        except np.linalg.LinAlgError:
            return u, 4, it
        du = -np.linalg.solve(factor.T, np.linalg.solve(factor, grad))
        t = line_search(d, E.T @ du, u, du, e, groups, k, g, rho_soft, grad @ du)
        if t == 0.0:  # no decrease left: rounding, solved if within STALL tol
            return u, (0 if np.linalg.norm(grad) <= STALL * tol * scale else 2), it
        u = u + t * du
    return u, 1, max_iter
