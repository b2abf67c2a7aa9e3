"""The package's own LCP methods: find ``z >= 0`` with ``w = M z + q >= 0`` and
``z'w = 0``. The backends of :mod:`.lcp_` run them, and the batched least norm falls back
on :func:`lemke` where its active set does not settle. Convergence of the iterative
methods is measured by the natural residual ``||min(z, w)||_inf <= tol * max(1,
||q||_inf)``.

- :func:`lemke`: complementary pivoting with covering vector ``e = 1``; finite, exact up
  to rounding; ends on a secondary ray (no solution found) or a pivot limit -> failed.
- :func:`pgs`: projected Gauss-Seidel; needs ``M_ii > 0``; converges for symmetric
  positive semidefinite ``M`` with positive diagonal (when a solution exists).
- :func:`fb_newton`: semismooth Newton on ``Phi_i = sqrt(z_i^2 + w_i^2) - z_i - w_i`` with
  an Armijo line search on ``1/2 ||Phi||^2``; at the kink ``z_i = w_i = 0`` it takes the
  generalized-Jacobian element of direction ``(1, 1)/sqrt 2``.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .record import Status

PIVOT_RTOL = 1e-12
"""Lemke's pivots: a column entry at most this times the largest of ``|M|`` (at least 1)
is rounding, not a pivot; ratios within this relatively of the least one tie (the
artificial variable then leaves first). About 4500 times machine epsilon, so rounding
never makes a pivot."""

DESCENT_RTOL = 1e-10
"""The Fischer-Burmeister Newton step is used when its slope on ``1/2 ||Phi||^2`` is below
``-DESCENT_RTOL ||d||^2`` (a descent direction by a margin above rounding), else the
steepest descent is taken."""

MIN_STEP = 1e-12
"""The Armijo line search's least step: below it the search has failed (the merit cannot
decrease along the direction within rounding)."""


class LCPResult(NamedTuple):
    """Answer of one LCP method, with the record's status."""

    z: np.ndarray
    status: Status
    iterations: int
    message: str


def natural_residual(M: np.ndarray, q: np.ndarray, z: np.ndarray) -> float:
    """``||min(z, M z + q)||_inf``: zero exactly at a solution."""
    return float(np.max(np.abs(np.minimum(z, M @ z + q)), initial=0.0))


def _scale(q: np.ndarray) -> float:
    return max(1.0, float(np.max(np.abs(q), initial=0.0)))


def lemke(M: np.ndarray, q: np.ndarray, max_pivots: int | None = None) -> LCPResult:
    """Lemke's method on the tableau ``w - M z - e z0 = q`` (columns w, z, z0, rhs)."""
    n = len(q)
    if np.all(q >= 0):
        return LCPResult(np.zeros(n), Status.SOLVED, 0, "q >= 0: z = 0")
    max_pivots = 50 * (n + 1) if max_pivots is None else max_pivots
    tableau = np.hstack([np.eye(n), -M, -np.ones((n, 1)), q[:, None]])
    basis = np.arange(n)
    artificial = 2 * n
    pivot_tol = PIVOT_RTOL * max(1.0, float(np.abs(M).max(initial=0.0)))
    row, entering = int(np.argmin(q)), artificial
    for pivots in range(1, max_pivots + 1):
        tableau[row] /= tableau[row, entering]
        others = np.arange(n) != row
        tableau[others] -= np.outer(tableau[others, entering], tableau[row])
        leaving, basis[row] = basis[row], entering
        if leaving == artificial:
            z = np.zeros(n)
            in_z = (basis >= n) & (basis < 2 * n)
            z[basis[in_z] - n] = tableau[in_z, -1]
            return LCPResult(z, Status.SOLVED, pivots, f"{pivots} pivots")
        entering = leaving + n if leaving < n else leaving - n
        column = tableau[:, entering]
        candidates = np.flatnonzero(column > pivot_tol)
        if candidates.size == 0:
            message = "secondary ray: no solution found"
            return LCPResult(np.full(n, np.nan), Status.FAILED, pivots, message)
        ratios = tableau[candidates, -1] / column[candidates]
        ties = candidates[ratios <= ratios.min() + PIVOT_RTOL * max(1.0, abs(ratios.min()))]
        leaves_artificial = ties[basis[ties] == artificial]
        row = int(leaves_artificial[0] if leaves_artificial.size else ties[0])
    return LCPResult(np.full(n, np.nan), Status.FAILED, max_pivots,
                     f"pivot limit {max_pivots} reached")


def pgs(M: np.ndarray, q: np.ndarray, z0: np.ndarray | None = None, tol: float = 1e-10,
        max_iter: int = 10_000) -> LCPResult:
    """Projected Gauss-Seidel sweeps ``z_i <- max(0, z_i - (M z + q)_i / M_ii)``."""
    n = len(q)
    diag = np.diag(M)
    if np.any(diag <= 0):
        return LCPResult(np.full(n, np.nan), Status.FAILED, 0, "PGS needs a positive diagonal of M")
    z = np.zeros(n) if z0 is None else np.maximum(np.asarray(z0, float), 0.0)
    target = tol * _scale(q)
    for sweep in range(1, max_iter + 1):
        for i in range(n):
            z[i] = max(0.0, z[i] - (M[i] @ z + q[i]) / diag[i])
        residual = natural_residual(M, q, z)
        if not np.isfinite(residual):
            return LCPResult(z, Status.FAILED, sweep, "iterates diverged")
        if residual <= target:
            return LCPResult(z, Status.SOLVED, sweep, f"natural residual {residual:.1e}")
    return LCPResult(z, Status.INACCURATE, max_iter, f"max_iter reached, residual {residual:.1e}")


def fischer_burmeister(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``phi(a, b) = sqrt(a^2 + b^2) - a - b``; zero iff ``a >= 0, b >= 0, a b = 0``."""
    return np.hypot(a, b) - a - b


def fb_newton(M: np.ndarray, q: np.ndarray, z0: np.ndarray | None = None, tol: float = 1e-12,
              max_iter: int = 100, sigma: float = 1e-4) -> LCPResult:
    """Semismooth Newton on the Fischer-Burmeister system, Armijo on ``1/2 ||Phi||^2``."""
    n = len(q)
    z = np.zeros(n) if z0 is None else np.asarray(z0, float).copy()
    target = tol * _scale(q)
    kink = 1.0 / np.sqrt(2.0) - 1.0
    for it in range(max_iter + 1):
        w = M @ z + q
        phi = fischer_burmeister(z, w)
        norm = float(np.max(np.abs(phi), initial=0.0))
        if not np.isfinite(norm):
            return LCPResult(z, Status.FAILED, it, "iterates diverged")
        if norm <= target:
            return LCPResult(z, Status.SOLVED, it, f"||Phi||_inf {norm:.1e}")
        if it == max_iter:
            break
        r = np.hypot(z, w)
        safe = np.where(r > 0, r, 1.0)
        da = np.where(r > 0, z / safe - 1.0, kink)
        db = np.where(r > 0, w / safe - 1.0, kink)
        J = np.diag(da) + db[:, None] * M
        grad = J.T @ phi
        try:
            d = np.linalg.solve(J, -phi)
        except np.linalg.LinAlgError:
            d = -grad
        if not np.all(np.isfinite(d)) or grad @ d > -DESCENT_RTOL * float(d @ d):
            d = -grad  # Newton direction unusable: steepest descent on 1/2||Phi||^2
        merit, slope, step = 0.5 * float(phi @ phi), float(grad @ d), 1.0
        while step > MIN_STEP:
            trial = z + step * d
            phi_trial = fischer_burmeister(trial, M @ trial + q)
            if 0.5 * float(phi_trial @ phi_trial) <= merit + sigma * step * slope:
                break
            step *= 0.5
        else:
            return LCPResult(z, Status.FAILED, it, f"line search failed at ||Phi||_inf {norm:.1e}")
        z = trial
    return LCPResult(z, Status.INACCURATE, max_iter, f"max_iter reached, ||Phi||_inf {norm:.1e}")
