"""Least-norm formulations solved for all instants at once (vectorized NumPy).

``min_norm``, ``min_norm_scaled``, ``positive``, ``lcp`` and ``compliance`` (linear law,
no gaps) all pick the point of ``A x = b`` that is least in a diagonal norm
``1/2 x'Wx``; the last three also keep the end faces ``x_u >= 0``. With ``y = W^{1/2} x``
and ``B = A W^{-1/2}`` (T instants stacked):

- least norm: ``y0 = B' mu`` with ``K mu = b``, ``K = B B' + delta I``. The rows of ``A``
  are dependent along the motion (rank 29 of 30), so ``K`` is singular; ``delta =
  GRAM_RTOL * trace(K) / rows`` biases ``y0`` by about ``delta / sigma_min^2`` of the
  range (1e-12 relative in ``paper``, 1e-7 in ``propshaft``, whose scales differ), which
  one step of iterative refinement removes; the left null direction it inflates is
  annihilated by ``B'``. A contact loads at most two bodies and the bodies form a chain
  (shaft, cross-pin, shaft, ...), so ``K`` is block tridiagonal in 6 x 6 body blocks:
  block elimination with one batched 6 x 6 inverse per body (:func:`chain_solve`).
- end faces >= 0: with ``U = B[:, u]`` the KKT conditions reduce to the LCP of the
  formulation ``lcp``, ``0 <= lam ⟂ w = M lam + q >= 0`` with ``M = I - U' K^+ U``
  (``= N_u N_u'`` for any orthonormal null basis ``N``) and ``q = y0_u``, here built
  from the same factorization (right-hand sides ``[b, U]``) without a null basis. It is
  solved for all instants at once by a primal-dual active-set method (semismooth
  Newton on ``min(lam, w) = 0``), started from the faces that pull in ``y0``; an
  instant whose active set has not settled after ``max_iter`` steps is solved by the
  package's Lemke method. Then ``y = y0 + E_u lam - B' K^+ U lam``.

Every answer is judged by :func:`residuals`, the vectorized ``ForceChecks.residuals``.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from cardan_forces.driveline.equilibrium import Operator
from cardan_forces.formulations import FORMULATIONS
from cardan_forces.formulations.problems import QP
from cardan_forces.solvers.lcp_ import lemke

GRAM_RTOL = 1e-15
"""Regularization of the Gram matrix, relative to its mean diagonal."""

LCP_RTOL = 1e-12
"""Sign tolerance of the active-set steps, relative to ``max(1, max |q|)``."""

LCP_DELTA = 1e-14
"""Regularization of the active block of ``M`` (singular when more faces are pinned
than the null space has directions)."""

BATCHED = ("min_norm", "min_norm_scaled", "positive", "lcp", "compliance")
"""Formulations with a batched path (``compliance`` only where it is a QP)."""


@dataclass(frozen=True)
class Batch:
    """Forces ``x`` (T, n) of one formulation over the instants, with its own checks.

    ``residuals`` holds (T,) arrays of ``ForceChecks.residuals``' keys; ``iterations``
    the active-set steps per instant (0 without end faces); ``fallback`` marks instants
    solved by Lemke; ``stages`` the wall time (s) of each stage.
    """

    formulation: str
    instants: np.ndarray
    x: np.ndarray
    residuals: dict[str, np.ndarray]
    iterations: np.ndarray
    fallback: np.ndarray
    stages: dict[str, float]


def supports(op: Operator, formulation: str) -> bool:
    """Whether ``formulation`` has a batched path on ``op``."""
    if formulation not in BATCHED:
        return False
    try:
        chain(op.A[0])
    except ValueError:
        return False
    return _batchable(formulation, FORMULATIONS[formulation](op, 0))


def _batchable(formulation: str, problem) -> bool:
    """``compliance`` only as a QP with a diagonal ``P`` (no gaps, linear law)."""
    if formulation != "compliance":
        return formulation in BATCHED
    return isinstance(problem, QP) and not np.any(problem.P - np.diag(np.diag(problem.P)))


def weights(formulation: str, problem, A: np.ndarray) -> np.ndarray | None:
    """Diagonal ``W`` of the norm (T, n) for the stacked ``A``; ``None`` for the plain norm.

    ``min_norm_scaled``: squared column norms of ``A`` (its default reference length of
    1 m leaves the moment rows as they are); ``compliance``: the QP's ``diag(P)``
    (``problem`` at any instant: it depends on the scene only).
    """
    if formulation == "min_norm_scaled":
        return np.einsum("tij,tij->tj", A, A)
    if formulation == "compliance":
        p = np.diag(problem.P)
        return np.broadcast_to(p, (len(A), len(p)))
    return None


def least_norm(A: np.ndarray, b: np.ndarray, w: np.ndarray | None = None,
               unilateral: np.ndarray | None = None, max_iter: int = 30):
    """Least ``1/2 x'Wx`` on ``A x = b`` (stacked, ``A`` (T, m, n)), optionally with
    ``x[unilateral] >= 0``: ``(x, iterations, fallback, stages)``.
    """
    stages = {}
    clock = time.perf_counter()
    T, m, n = A.shape
    root = None if w is None else np.sqrt(w)
    B = A if root is None else A / root[:, None, :]
    K = B @ B.transpose(0, 2, 1)
    K[:, np.arange(m), np.arange(m)] += (GRAM_RTOL / m) * np.trace(K, axis1=1, axis2=2)[:, None]
    u = np.flatnonzero(unilateral) if unilateral is not None else np.zeros(0, int)
    U = B[:, :, u]
    clock = _lap(stages, "gram", clock)
    Z = chain_solve(K, np.concatenate([b[:, :, None], U], axis=2), chain(A[0]))
    y = (Z[:, None, :, 0] @ B)[:, 0]
    # one step of iterative refinement removes the bias of the regularization, whatever
    # the scene's scales (without it: 1e-7 relative on the propshaft, 1e-14 on paper)
    r = b - (B @ y[:, :, None])[:, :, 0]
    y += (chain_solve(K, r[:, :, None], chain(A[0]))[:, None, :, 0] @ B)[:, 0]
    clock = _lap(stages, "factor+solve", clock)
    iterations, fallback = np.zeros(T, int), np.zeros(T, bool)
    if u.size:
        M = np.eye(len(u)) - U.transpose(0, 2, 1) @ Z[:, :, 1:]
        lam, iterations, fallback = _active_set(M, y[:, u], max_iter)
        y[:, u] += lam
        y -= ((Z[:, :, 1:] @ lam[:, :, None]).transpose(0, 2, 1) @ B)[:, 0]
        clock = _lap(stages, "lcp", clock)
    return (y if root is None else y / root), iterations, fallback, stages


def chain(A: np.ndarray) -> list[slice]:
    """The bodies' row blocks (6 rows each) in order along the chain that their shared
    contact columns form (shaft, cross-pin, shaft, ...), from one instant's ``A``.

    A contact acts on at most two bodies, each with a nonzero force part, so the
    coupling of bodies is structural; ``ValueError`` if it is not a path.
    """
    touches = np.any(A.reshape(-1, 6, A.shape[1]) != 0, axis=1).astype(int)
    linked = touches @ touches.T > 0
    np.fill_diagonal(linked, False)
    degree = linked.sum(axis=1)
    ends = np.flatnonzero(degree <= 1)
    if len(degree) > 1 and (degree.max() > 2 or len(ends) != 2 or degree.min() == 0):
        raise ValueError("the bodies do not form a chain")
    order = [int(ends[0])]
    while len(order) < len(degree):
        order.append(int(next(k for k in np.flatnonzero(linked[order[-1]]) if k not in order)))
    return [slice(6 * k, 6 * k + 6) for k in order]


def chain_solve(K: np.ndarray, R: np.ndarray, blocks: list[slice]) -> np.ndarray:
    """``K^{-1} R`` for a stack of matrices that are block tridiagonal along ``blocks``:
    block elimination (``D_k = K_kk - K_k,k-1 D_k-1^{-1} K_k-1,k``, positive definite
    for a positive definite ``K``), one batched inverse per block (for 6 x 6 blocks and
    several right-hand sides NumPy inverts faster than it solves).
    """
    inverse = np.linalg.inv(K[:, blocks[0], blocks[0]])
    nxt, rhs = [], [inverse @ R[:, blocks[0]]]
    for prev, rows in zip(blocks, blocks[1:]):
        nxt.append(inverse @ K[:, prev, rows])
        coupling = K[:, rows, prev]
        inverse = np.linalg.inv(K[:, rows, rows] - coupling @ nxt[-1])
        rhs.append(inverse @ (R[:, rows] - coupling @ rhs[-1]))
    out = np.empty_like(R)
    out[:, blocks[-1]] = rhs[-1]
    for k in range(len(blocks) - 2, -1, -1):
        out[:, blocks[k]] = rhs[k] - nxt[k] @ out[:, blocks[k + 1]]
    return out


def _lap(stages: dict[str, float], name: str, since: float) -> float:
    now = time.perf_counter()
    stages[name] = now - since
    return now


def _active_set(M: np.ndarray, q: np.ndarray, max_iter: int):
    """``0 <= lam ⟂ M lam + q >= 0`` for every instant: primal-dual active set.

    Pinned faces ``P`` solve ``M_PP lam_P = -q_P`` with ``lam = 0`` elsewhere; the next
    set keeps the pinned faces with ``lam > 0`` and adds the free ones with ``w < 0``.
    An instant is done when its set repeats.
    """
    T, k = q.shape
    eps = LCP_RTOL * np.maximum(1.0, np.abs(q).max(axis=1, initial=0.0))[:, None]
    pinned = q < 0
    lam = np.zeros((T, k))
    iterations = np.zeros(T, int)
    todo = np.arange(T)
    eye = np.eye(k)
    for step in range(1, max_iter + 1):
        P = pinned[todo]
        both = P[:, :, None] & P[:, None, :]
        system = np.where(both, M[todo] + LCP_DELTA * eye, 0.0) + eye * ~P[:, None, :]
        lam[todo] = np.linalg.solve(system, np.where(P, -q[todo], 0.0)[:, :, None])[:, :, 0]
        w = np.einsum("tij,tj->ti", M[todo], lam[todo]) + q[todo]
        nxt = np.where(P, lam[todo] > -eps[todo], w < -eps[todo])
        settled = np.all(nxt == P, axis=1)
        iterations[todo] = step
        pinned[todo] = nxt
        todo = todo[~settled]
        if not todo.size:
            break
    fallback = np.zeros(T, bool)
    fallback[todo] = True
    for i in todo:
        lam[i] = lemke(M[i], q[i]).z
    return lam, iterations, fallback


def residuals(A: np.ndarray, b: np.ndarray, x: np.ndarray, unilateral: np.ndarray,
              pairs: tuple[tuple[int, int], ...]) -> dict[str, np.ndarray]:
    """``ForceChecks.residuals`` for every instant at once: (T,) arrays, ``inf`` where
    ``x`` is not finite; no cones (none of the batched formulations has one).
    """
    scale = np.maximum(np.linalg.norm(b, axis=1), 1e-12)
    xu = x[:, np.asarray(unilateral, bool)]
    sign = np.maximum(0.0, -xu.min(axis=1, initial=np.inf)) if xu.shape[1] else np.zeros(len(x))
    pair = np.asarray(pairs, int).reshape(-1, 2)
    comp = np.maximum(0.0, np.minimum(x[:, pair[:, 0]], x[:, pair[:, 1]])).max(axis=1, initial=0.0)
    out = {
        "equilibrium": np.linalg.norm((A @ x[:, :, None])[:, :, 0] - b, axis=1) / scale,
        "sign": sign / scale,
        "complementarity": comp / scale,
        "cone": np.zeros(len(x)),
    }
    bad = ~np.all(np.isfinite(x), axis=1)
    for value in out.values():
        value[bad] = np.inf
    return out


def solve_batched(op: Operator, formulation: str, instants=None) -> Batch:
    """One batched formulation at ``instants`` (default all), checked by the package's
    residuals in the formulation's own terms (signs and pairs only where it imposes
    them).
    """
    clock = time.perf_counter()
    every = instants is None
    instants = np.arange(len(op.t)) if every else np.asarray(instants, int)
    problem = FORMULATIONS[formulation](op, int(instants[0]))
    if not _batchable(formulation, problem):
        raise ValueError(f"no batched path for {formulation!r} on this scene")
    A, b = (op.A, op.b) if every else (op.A[instants], op.b[instants])
    w = weights(formulation, problem, A)
    stages = {"setup": time.perf_counter() - clock}
    signed = formulation in ("positive", "lcp", "compliance")
    x, iterations, fallback, solve_stages = least_norm(
        A, b, w, op.unilateral if signed else None)
    stages.update(solve_stages)
    clock = time.perf_counter()
    res = residuals(A, b, x, problem.checks.unilateral, problem.checks.pairs)
    stages["check"] = time.perf_counter() - clock
    return Batch(formulation, instants, x, res, iterations, fallback, stages)
