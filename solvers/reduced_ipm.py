r"""A primal-dual interior point for many small cone programs at once (NumPy reference).

Each instant ``t`` is the reduced form of a formulation (:class:`~.conversions.Reduced`:
its equality rows eliminated through a null-space basis, ``k`` unknowns left)::

    min 1/2 x'Px + q'x   s.t.   G x + s = h,   s in K = R^l_+ x Q^q1 x ... x Q^qp   (1)

with multipliers ``z in K`` (both cones are self-dual) and optimality conditions

    P x + q + G'z = 0,   G x + s = h,   s o z = 0,   s, z in K                        (2)

(``o`` the Jordan product: ``u o v = u * v`` on the orthant, ``(u'v, u0 v1 + v0 u1)``
on a second-order block). Arrays carry a leading instant axis; every instant iterates on
its own and stops on its own (an instant's answer does not depend on the others in its
batch).

The method is CVXOPT's ``coneqp`` without equality rows (Vandenberghe, "The CVXOPT
linear and quadratic cone program solvers", 2010, sections 2-5), with Mehrotra's
predictor-corrector:

- Nesterov-Todd scaling ``W`` with ``W z = W^-1 s = lambda`` (eqs. 4-6 there): on the
  orthant ``W = diag(sqrt(s / z))``; on a second-order block
  ``W = eta [w0 w1'; w1 I + w1 w1' / (1 + w0)]``, ``eta = (s'Js / z'Jz)^(1/4)``,
  ``w = (s/sqrt(s'Js) + J z/sqrt(z'Jz)) / (2 gamma)``, ``J = diag(1, -1, ..., -1)``,
  ``gamma = sqrt((1 + s'z / sqrt(s'Js z'Jz)) / 2)``;
- the Newton step of (2) with ``lambda o (W dz + W^-1 ds) = -r_s`` is, with
  ``u = lambda \ (-r_s)``, the augmented system (3)
  ``[P G'; G -W^2] (dx, dz) = (-r_x, -r_z - W u)`` of size ``k + m``, solved by LU
  with partial pivoting. Not the ``k x k`` normal equations ``P + G'W^-2 G``: near the
  optimum ``W^-2`` spans many decades, and on ``min_max`` (its tie-break weight 1e-4)
  their rounding left the dual residual near 1e-7 while the gap fell;
- predictor ``r_s = lambda o lambda``; corrector ``r_s = lambda o lambda +
  (W^-1 ds_a) o (W dz_a) - sigma mu e`` with ``sigma = (1 - alpha_a)^3``,
  ``mu = s'z / (l + p)``; step ``min(1, 0.99 alpha_max)`` to the cones' boundary
  (a second-order block's by the closed form of ECOS's ``conicline``), halved while it
  leaves a block off centre (:func:`_central`);
- start (CVXOPT's): ``x`` from ``(P + G'G) x = -q + G'h``, ``s = h - G x``, ``z = -s``,
  each moved into its cone along ``e`` by its most negative eigenvalue plus one.

Stopping, with ``tol`` (:data:`TOL` by default), relative as Clarabel's:
``||Gx + s - h||_inf <= tol (1 + max(||h||, ||Gx||, ||s||))``,
``||Px + q + G'z||_inf <= tol (1 + max(||Px||, ||q||, ||G'z||))`` and
``s'z <= tol max(1, min(|p|, |d|))`` (``p``, ``d`` the primal and dual objectives).
A primal infeasibility certificate (``h'z < 0``, ``||G'z||_inf <= tol |h'z|``) ends an
instant as infeasible; a step below :data:`MIN_STEP`, a non-finite iterate or
:data:`MAX_ITER` iterations end it unsolved (:data:`STALLED`, :data:`BROKEN`,
:data:`LIMIT`) at its best iterate, or :data:`ALMOST` solved, never in an exception.

Second-order blocks are laid out padded to the longest (``soc`` (p, qmax) row indices,
the pad pointing at a zero row): the pads of every iterate, direction and scaling
vector stay zero, so one array shape serves every block.
"""

from __future__ import annotations

import contextlib
import functools
from dataclasses import dataclass

import numpy as np

TOL = 1e-10
"""Default relative tolerance of the stopping rules (the package's optimality measures
of the lifted answers then sit near 1e-10, below the bench's 1e-8 level)."""

MAX_ITER = 50
"""Iterations before an instant stops unsolved."""

CENTRALITY = 1e-3
"""Least ``sqrt(s'Js z'Jz) / mu`` of a second-order block after a step (:func:`_central`)."""

BACKTRACKS = 10
"""Halvings of a step that leaves a block off centre, at most."""

MIN_STEP = 1e-8
"""A step below this ends an instant unsolved (a stall)."""

STEP_FRACTION = 0.99
"""Fraction of the step to the cones' boundary taken."""

REDUCED = 10.0
"""An instant that stops unsolved ends at its best iterate, which is :data:`ALMOST`
solved where it meets the stopping rules at ``REDUCED * tol``."""

SOLVED, ALMOST, INFEASIBLE, LIMIT, STALLED, BROKEN, RUNNING = range(7)
"""Per-instant exit codes: converged, stopped near the optimum (:data:`REDUCED`), primal
infeasibility certificate, iteration limit, step below :data:`MIN_STEP`, non-finite
numbers, still iterating."""

CODES = ("converged", "almost converged", "primal infeasible", "iteration limit", "stalled",
         "non-finite", "running")
"""The exit codes' words, by value."""


@dataclass(frozen=True)
class Layout:
    """The rows of a cone list without zero cones: ``nonneg`` (l,) orthant rows,
    ``soc`` (p, qmax) second-order rows, apex first, padded with ``m`` (a zero row).
    """

    m: int
    nonneg: np.ndarray
    soc: np.ndarray

    @property
    def degree(self) -> int:
        """``l + p``: the cone's degree (``mu = s'z / degree``)."""
        return len(self.nonneg) + len(self.soc)


@functools.lru_cache(maxsize=64)
def layout(cones: tuple) -> Layout:
    """The :class:`Layout` of ``cones`` (``("nonneg", l)`` and ``("soc", q)`` blocks in
    any order; ``ValueError`` for any other kind).
    """
    nonneg, socs, row = [], [], 0
    for kind, size in cones:
        size = int(size)
        if kind == "nonneg":
            nonneg.extend(range(row, row + size))
        elif kind == "soc":
            socs.append(list(range(row, row + size)))
        else:
            raise ValueError(f"the interior point takes nonneg and soc cones, not {kind}")
        row += size
    width = max((len(r) for r in socs), default=1)
    soc = np.full((len(socs), width), row, np.int64)
    for k, rows in enumerate(socs):
        soc[k, :len(rows)] = rows
    for array in (soc,):
        array.flags.writeable = False
    return Layout(row, np.array(nonneg, np.int64), soc)


def split(v: np.ndarray, lay: Layout) -> tuple[np.ndarray, np.ndarray]:
    """Rows ``v`` (T, m, ...) as the orthant part (T, l, ...) and the padded blocks
    (T, p, qmax, ...).
    """
    padded = np.concatenate([v, np.zeros_like(v[:, :1])], axis=1)
    return padded[:, lay.nonneg], padded[:, lay.soc]


def join(vl: np.ndarray, vq: np.ndarray, lay: Layout) -> np.ndarray:
    """:func:`split`'s inverse for vectors: (T, m)."""
    out = np.zeros((len(vl), lay.m + 1))
    out[:, lay.nonneg] = vl
    out[:, lay.soc] = vq
    return out[:, :lay.m]


# Cone algebra on pairs (orthant part (T, l), blocks (T, p, qmax)).

def dot(u, v) -> np.ndarray:
    """``u'v`` per instant."""
    return np.einsum("tl,tl->t", u[0], v[0]) + np.einsum("tpq,tpq->t", u[1], v[1])


def jordan(u, v):
    """``u o v``."""
    head = np.einsum("tpq,tpq->tp", u[1], v[1])
    tail = u[1][..., :1] * v[1] + v[1][..., :1] * u[1]
    tail[..., 0] = head
    return u[0] * v[0], tail


def jordan_solve(lam, v):
    """``w`` with ``lam o w = v`` (``lam`` in the cone's interior)."""
    l0, l1 = lam[1][..., 0], lam[1][..., 1:]
    v0, v1 = v[1][..., 0], v[1][..., 1:]
    det = l0 * l0 - np.einsum("tpq,tpq->tp", l1, l1)
    w0 = (l0 * v0 - np.einsum("tpq,tpq->tp", l1, v1)) / det
    tail = np.empty_like(v[1])
    tail[..., 0] = w0
    tail[..., 1:] = (v1 - w0[..., None] * l1) / l0[..., None]
    return v[0] / lam[0], tail


def identity(lay: Layout, T: int):
    """The cone's identity ``e`` (ones; ``(1, 0, ..., 0)`` per block)."""
    e = np.zeros((T, len(lay.soc), lay.soc.shape[1]))
    e[..., 0] = 1.0
    return np.ones((T, len(lay.nonneg))), e


def least_eigenvalue(u) -> np.ndarray:
    """The least eigenvalue of ``u`` per instant (``u0 - ||u1||`` on a block)."""
    low = u[1][..., 0] - np.sqrt(np.einsum("tpq,tpq->tp", u[1][..., 1:], u[1][..., 1:]))
    return np.minimum(u[0].min(axis=1, initial=np.inf), low.min(axis=1, initial=np.inf))


def axpy(a: np.ndarray, u, v):
    """``v + a u`` with ``a`` (T,)."""
    return v[0] + a[:, None] * u[0], v[1] + a[:, None, None] * u[1]


@dataclass(frozen=True)
class Scaling:
    """Nesterov-Todd scaling of one iterate: ``d`` (T, l) on the orthant, ``eta``
    (T, p) and ``w`` (T, p, qmax) per block (module docstring); ``lam = W z``.
    """

    d: np.ndarray
    eta: np.ndarray
    w: np.ndarray
    lam: tuple

    @classmethod
    def of(cls, s, z) -> Scaling:
        """The scaling of ``s``, ``z`` (both in the cone's interior)."""
        ns, nz = _jnorm(s[1]), _jnorm(z[1])
        sb, zb = s[1] / ns[..., None], z[1] / nz[..., None]
        gamma = np.sqrt(0.5 * (1.0 + np.einsum("tpq,tpq->tp", sb, zb)))
        w = sb.copy()
        w[..., 0] += zb[..., 0]
        w[..., 1:] -= zb[..., 1:]
        w /= 2.0 * gamma[..., None]
        eta = np.sqrt(ns / nz)
        d = np.sqrt(s[0] / z[0])
        scaling = cls(d, eta, w, ())
        return cls(d, eta, w, scaling.apply(z))

    def squared(self, lay: Layout) -> np.ndarray:
        """``W^2`` (T, m, m): ``d^2`` on the orthant, ``eta^2 (2 w w' - J)`` per block."""
        T, m = len(self.d), lay.m
        out = np.zeros((T, m + 1, m + 1))
        out[:, lay.nonneg, lay.nonneg] = self.d ** 2
        block = 2.0 * self.w[..., :, None] * self.w[..., None, :]
        width = self.w.shape[-1]
        block += np.diag(np.r_[-1.0, np.ones(width - 1)])
        block *= (self.eta ** 2)[..., None, None]
        out[:, lay.soc[:, :, None], lay.soc[:, None, :]] = block
        return out[:, :m, :m]

    def apply(self, v, inverse: bool = False):
        """``W v`` (``W^-1 v`` with ``inverse``); ``v`` a pair with any trailing axes."""
        vl, vq = v
        extra = vl.ndim - 2
        d = self.d.reshape(self.d.shape + (1,) * extra)
        eta = self.eta.reshape(self.eta.shape + (1,) * (extra + 1))
        w = self.w.reshape(self.w.shape + (1,) * extra)
        w0, w1 = w[:, :, :1], w[:, :, 1:]
        v0, v1 = vq[:, :, :1], vq[:, :, 1:]
        w1v1 = np.sum(w1 * v1, axis=2, keepdims=True)
        sign = -1.0 if inverse else 1.0
        out = np.empty_like(vq)
        out[:, :, :1] = w0 * v0 + sign * w1v1
        out[:, :, 1:] = v1 + (sign * v0 + w1v1 / (1.0 + w0)) * w1
        return (vl / d, out / eta) if inverse else (vl * d, out * eta)


def _jnorm(u: np.ndarray) -> np.ndarray:
    """``sqrt(u'Ju)`` per block (``u`` strictly inside)."""
    return np.sqrt(u[..., 0] ** 2 - np.einsum("tpq,tpq->tp", u[..., 1:], u[..., 1:]))


def max_step(u, du) -> np.ndarray:
    """The largest ``a`` with ``u + a du`` in the cone (``u`` strictly inside; ``inf``
    where every direction stays inside). A block's by ECOS's closed form: ``u`` moved to
    the axis by a hyperbolic rotation, where the boundary is a ratio.
    """
    ratio = np.where(du[0] < 0, -u[0] / np.where(du[0] < 0, du[0], -1.0), np.inf)
    step = ratio.min(axis=1, initial=np.inf)
    v0, v1 = u[1][..., 0], u[1][..., 1:]
    d0, d1 = du[1][..., 0], du[1][..., 1:]
    inv = 1.0 / _jnorm(u[1])
    rho0 = (v0 * d0 - np.einsum("tpq,tpq->tp", v1, d1)) * inv * inv
    factor = (rho0 + d0 * inv) / (v0 * inv + 1.0)
    rho1 = np.sqrt(np.sum(((d1 - factor[..., None] * v1) * inv[..., None]) ** 2, axis=2))
    sigma = rho1 - rho0
    block = np.where(sigma > 0, 1.0 / np.where(sigma > 0, sigma, 1.0), np.inf)
    return np.minimum(step, block.min(axis=1, initial=np.inf))


@dataclass(frozen=True)
class Answer:
    """What :func:`solve` returns per instant: ``x`` (T, k), ``z`` (T, m) multipliers of
    the rows of (1), ``s`` (T, m) slacks, ``iterations`` (T,), ``code`` (T,) exit codes
    (:data:`SOLVED` ...).
    """

    x: np.ndarray
    z: np.ndarray
    s: np.ndarray
    iterations: np.ndarray
    code: np.ndarray


def solve(P: np.ndarray, q: np.ndarray, G: np.ndarray, h: np.ndarray, cones: tuple,
          tol: float = TOL, max_iter: int = MAX_ITER) -> Answer:
    """Problems (1) at T instants: ``P`` (T, k, k), ``q`` (T, k), ``G`` (T, m, k), ``h``
    (T, m); ``cones`` nonneg and soc blocks in row order. Non-finite numbers end their
    instant (:data:`BROKEN`) without a warning.
    """
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        return _solve(P, q, G, h, layout(tuple(cones)), tol, max_iter)


def _solve(P, q, G, h, lay: Layout, tol: float, max_iter: int) -> Answer:
    """:func:`solve` within NumPy's quiet error state."""
    T, k = q.shape
    Gs, hs = split(G, lay), split(h, lay)
    x = _start_x(P, q, G, h)
    residual = _plus(_times(Gs, x), _negate(hs))
    s = _into_cone(_negate(residual), lay)
    z = _into_cone(residual, lay)
    code = np.full(T, RUNNING)
    iterations = np.zeros(T, np.int64)
    h_norm = _inf(hs)
    best = (x, s, z, np.full(T, np.inf))
    for it in range(max_iter + 1):
        Gx = _times(Gs, x)
        Px = np.einsum("tij,tj->ti", P, x)
        Gtz = _transposed(Gs, z)
        rx = Px + q + Gtz
        rz = _plus(_plus(Gx, s), _negate(hs))
        gap = dot(s, z)
        primal = np.einsum("ti,ti->t", x, 0.5 * Px + q)
        dual = -np.einsum("ti,ti->t", x, 0.5 * Px) - dot(hs, z)
        scale = 1 + np.maximum.reduce([np.abs(Px).max(axis=1), np.abs(q).max(axis=1),
                                       np.abs(Gtz).max(axis=1)])
        merit = np.maximum.reduce([
            _inf(rz) / (1 + np.maximum.reduce([h_norm, _inf(Gx), _inf(s)])),
            np.abs(rx).max(axis=1) / scale,
            gap / np.maximum(1.0, np.minimum(np.abs(primal), np.abs(dual)))]) / tol
        done = merit <= 1.0
        better = (code == RUNNING) & (merit < best[3])
        best = _keep(better, (x, s, z, merit), best)
        hz = dot(hs, z)
        infeasible = (hz < 0) & (np.abs(Gtz).max(axis=1) <= tol * -hz)
        finite = np.isfinite(x).all(axis=1) & np.isfinite(gap)
        running = code == RUNNING
        code[running & ~finite] = BROKEN
        code[running & finite & infeasible] = INFEASIBLE
        code[running & finite & done] = SOLVED
        if it == max_iter:
            code[code == RUNNING] = LIMIT
        go = code == RUNNING
        if not go.any():
            break
        iterations[go] += 1
        i = np.flatnonzero(go)  # the step of the running instants only
        dx, ds, dz, alpha = _step(P[i], G[i], _take(Gs, i), _take(s, i), _take(z, i), rx[i],
                                  _take(rz, i), gap[i], lay)
        stall = ~(alpha >= MIN_STEP)  # a NaN step too (a singular or non-finite system)
        code[i[stall]] = STALLED
        i, alpha, dx, ds, dz = i[~stall], alpha[~stall], dx[~stall], _take(ds, ~stall), \
            _take(dz, ~stall)
        x[i] += alpha[:, None] * dx
        for mine, step in ((s, ds), (z, dz)):
            mine[0][i] += alpha[:, None] * step[0]
            mine[1][i] += alpha[:, None, None] * step[1]
    unsolved = code >= LIMIT
    x, s, z, merit = _keep(unsolved, best, (x, s, z, best[3]))
    code[unsolved & (merit <= REDUCED)] = ALMOST
    return Answer(x, join(*z, lay), join(*s, lay), iterations, code)


def _keep(chosen: np.ndarray, new: tuple, old: tuple) -> tuple:
    """``(x, s, z, merit)`` of ``new`` at the instants ``chosen``, of ``old`` elsewhere."""
    return (np.where(chosen[:, None], new[0], old[0]), _where(chosen, new[1], old[1]),
            _where(chosen, new[2], old[2]), np.where(chosen, new[3], old[3]))


def _step(P, G, Gs, s, z, rx, rz, gap, lay: Layout):
    """The predictor-corrector step of the instants given: ``(dx, ds, dz, alpha)``
    (module docstring; ``alpha`` NaN where the Newton system is not finite).
    """
    W = Scaling.of(s, z)
    K = np.concatenate([np.concatenate([P, np.transpose(G, (0, 2, 1))], axis=2),
                        np.concatenate([G, -W.squared(lay)], axis=2)], axis=1)
    broken = ~np.isfinite(K).all(axis=(1, 2))
    K[broken] = np.eye(K.shape[1])
    lam = W.lam
    system = (K, W, lay, rx, rz, Gs)
    _, dzw_a, dsw_a = _newton(system, _negate(lam))
    alpha_a = np.minimum(1.0, np.minimum(max_step(lam, dsw_a), max_step(lam, dzw_a)))
    sigma = np.clip(1.0 - alpha_a, 0.0, 1.0) ** 3
    rs = _plus(jordan(lam, lam), jordan(dsw_a, dzw_a))
    rs = axpy(-sigma * gap / lay.degree, identity(lay, len(gap)), rs)
    dx, dzw, dsw = _newton(system, _negate(jordan_solve(lam, rs)))
    alpha = np.minimum(1.0, STEP_FRACTION * np.minimum(max_step(lam, dsw),
                                                       max_step(lam, dzw)))
    ds, dz = W.apply(dsw), W.apply(dzw, inverse=True)
    alpha = _central(s, z, ds, dz, alpha, lay.degree)
    return dx, ds, dz, np.where(broken, np.nan, alpha)


def _take(u, rows):
    """The pair ``u`` at ``rows`` (indices or a mask)."""
    return u[0][rows], u[1][rows]


def _central(s, z, ds, dz, alpha: np.ndarray, degree: int) -> np.ndarray:
    """``alpha`` halved (at most :data:`BACKTRACKS` times) until every second-order
    block of the new point keeps ``sqrt(s'Js z'Jz) >= CENTRALITY mu``: a block whose
    ``s`` and ``z`` near the boundary much faster than ``mu`` falls, at a relative
    distance below the rounding of ``s0 - ||s1||``, where its scaling is lost.
    """
    alpha = alpha.copy()
    for _ in range(BACKTRACKS):
        s_new, z_new = axpy(alpha, ds, s), axpy(alpha, dz, z)
        mu = dot(s_new, z_new) / degree
        product = _jsquare(s_new[1]) * _jsquare(z_new[1])
        low = ~(np.sqrt(np.maximum(product, 0.0)).min(axis=1, initial=np.inf)
                >= CENTRALITY * mu)
        if not low.any():
            break
        alpha[low] *= 0.5
    return alpha


def _jsquare(u: np.ndarray) -> np.ndarray:
    """``u'Ju`` per block."""
    return u[..., 0] ** 2 - np.einsum("tpq,tpq->tp", u[..., 1:], u[..., 1:])


def _newton(system, u):
    """The Newton direction (3) for the scaled right-hand side ``u``: ``(dx, W dz,
    W^-1 ds)`` from the augmented system ``[P G'; G -W^2] (dx, dz) = (-r_x, -r_z -
    W u)`` (``system``: its matrix, ``W``, the layout, ``r_x``, ``r_z``, ``G``), by LU
    with partial pivoting (a step of iterative refinement changed no status on the
    built-in scenes' ``min_max`` and ``socp_face``, and costs a second solve). On a row
    or block far from its bound (``W`` above 1) ``ds = -r_z - G dx`` (the primal
    equation, exact) rather than ``W (u - W dz)``: there ``W^2`` is large, and the
    latter carries the solve's rounding into the primal residual, which then grows
    while the gap falls; near its bound the latter keeps the step consistent with the
    centring.
    """
    K, W, lay, rx, rz, Gs = system
    rhs = np.concatenate([-rx, -join(*rz, lay) - join(*W.apply(u), lay)], axis=1)
    step = _solve_each(K, rhs)
    k = rx.shape[1]
    dx, dzw = step[:, :k], W.apply(split(step[:, k:], lay))
    exact = W.apply(_negate(_plus(rz, _times(Gs, dx))), inverse=True)  # G dx + ds = -r_z
    linear = _plus(u, _negate(dzw))
    return dx, dzw, (np.where(W.d > 1, exact[0], linear[0]),
                     np.where((W.eta > 1)[..., None], exact[1], linear[1]))


def _solve_each(K: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """``K^-1 rhs`` per instant (LU with partial pivoting); an instant whose ``K`` is
    singular gets NaN (it then ends as :data:`BROKEN`).
    """
    try:
        return np.linalg.solve(K, rhs[..., None])[..., 0]
    except np.linalg.LinAlgError:
        out = np.full_like(rhs, np.nan)
        for t in range(len(K)):
            with contextlib.suppress(np.linalg.LinAlgError):
                out[t] = np.linalg.solve(K[t], rhs[t])
        return out


def _start_x(P, q, G, h) -> np.ndarray:
    """CVXOPT's start: ``x`` with ``(P + G'G) x = -q + G'h``."""
    H = P + np.einsum("tmi,tmj->tij", G, G)
    H += 1e-14 * np.trace(H, axis1=1, axis2=2)[:, None, None] * np.eye(q.shape[1])
    return np.linalg.solve(H, (np.einsum("tmi,tm->ti", G, h) - q)[..., None])[..., 0]


def _into_cone(u, lay: Layout):
    """``u + (1 - min(0, lambda_min(u))) e`` where ``u`` is not strictly inside (CVXOPT):
    a start strictly inside the cone.
    """
    low = least_eigenvalue(u)
    shift = np.where(low < 1e-8 * np.maximum(1.0, _inf(u)), 1.0 - np.minimum(low, 0.0), 0.0)
    return axpy(shift, identity(lay, len(shift)), u)


def _where(go: np.ndarray, u, v):
    """``u`` at the instants ``go``, ``v`` elsewhere (a stopped instant keeps its
    iterate whatever numbers the others' step made for it).
    """
    return np.where(go[:, None], u[0], v[0]), np.where(go[:, None, None], u[1], v[1])


def _plus(u, v):
    return u[0] + v[0], u[1] + v[1]


def _negate(u):
    return -u[0], -u[1]


def _inf(u) -> np.ndarray:
    return np.maximum(np.abs(u[0]).max(axis=1, initial=0.0),
                      np.abs(u[1]).max(axis=(1, 2), initial=0.0))


def _times(Gs, x):
    """``G x`` as a pair."""
    return np.einsum("tli,ti->tl", Gs[0], x), np.einsum("tpqi,ti->tpq", Gs[1], x)


def _transposed(Gs, v) -> np.ndarray:
    """``G'v`` (T, k) of ``G`` as a pair (rows first, the column axis last)."""
    return np.einsum("tli,tl->ti", Gs[0], v[0]) + np.einsum("tpqi,tpq->ti", Gs[1], v[1])
