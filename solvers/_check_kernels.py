"""Compiled optimality views of a check pass (numba, extra ``numba``).

The same measures as :func:`.optimality.stacked_measures` (the package's view) and
:func:`.qp_measures.from_parts` (the solver's view), by the formulas of those modules'
docstrings, fused into one pass over the instants: each instant's parts (``||Pz + q +
A'y||_inf``, ``z'Pz``, ``q'z``, ``b'y``, the dual cone's violation of ``y``, the primal
cone's violation of ``s = b - Az``) are summed and compared in scalars, instead of the
NumPy path's hundred-odd whole-array operations, each of which costs microseconds of
dispatch and, right after a solver has run, of cold caches. The products ``P z``,
``A z`` and ``A'y`` stay NumPy's (stacked matrix products, fast already).

Sums run in index order; NumPy's ``einsum`` may sum in another, so the two paths agree to
a few units in the last place, not to the bit (the tests hold them to 1e-12 relative).
A NaN propagates through every largest-of as through NumPy's ``maximum``. Compiling takes
a few seconds, once: numba caches the machine code.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

TINY = 1e-300
"""Floor of a denominator, as :data:`.optimality.TINY`."""

VIEWS = ("dual", "gap", "objective", "solver_primal", "solver_dual", "solver_gap")
"""The columns of :func:`views`' output, in order."""


@njit(cache=True, inline="always")
def _larger(a, b):
    """``max(a, b)``, NaN if either is NaN (NumPy's ``maximum``)."""
    return a if (a > b or a != a) else b


@njit(cache=True)
def _dual_cone(y, nonneg, apex, members, mask, pows, alphas):
    """Violation of ``y in K*`` of one instant (:func:`.optimality.dual_cone_violation`)."""
    worst = 0.0
    for i in nonneg:
        worst = _larger(worst, -y[i])
    for k in range(len(apex)):
        spread = 0.0
        for j in range(members.shape[1]):
            v = y[members[k, j]] * mask[k, j]
            spread += v * v
        worst = _larger(worst, math.sqrt(spread) - y[apex[k]])
    for k in range(len(alphas)):
        a = alphas[k]
        u, v, w = y[pows[k, 0]], y[pows[k, 1]], y[pows[k, 2]]
        mean = (max(u, 0.0) / a) ** a * (max(v, 0.0) / (1.0 - a)) ** (1.0 - a)
        negative = _larger(0.0, -min(u, v))
        worst = _larger(worst, _larger(abs(w) - mean, negative))
    return _larger(worst, 0.0)


@njit(cache=True)
def _primal_cone(s, zero, nonneg, apex, members, mask, pows, alphas):
    """Violation of ``s in K`` of one instant (:func:`.qp_measures.cone_violation`)."""
    worst = 0.0
    for i in zero:
        worst = _larger(worst, abs(s[i]))
    for i in nonneg:
        worst = _larger(worst, -s[i])
    for k in range(len(apex)):
        spread = 0.0
        for j in range(members.shape[1]):
            v = s[members[k, j]] * mask[k, j]
            spread += v * v
        worst = _larger(worst, math.sqrt(spread) - s[apex[k]])
    for k in range(len(alphas)):
        a = alphas[k]
        u, v, w = s[pows[k, 0]], s[pows[k, 1]], s[pows[k, 2]]
        mean = max(u, 0.0) ** a * max(v, 0.0) ** (1.0 - a)
        worst = _larger(worst, _larger(abs(w) - mean, -min(u, v)))
    return _larger(worst, 0.0)


@njit(cache=True)
def views(z, y, q, b, Pz, Az, Aty, zero, nonneg, apex, members, mask, pows, alphas,
          check_dual_cone, out):
    """Both views of T answers into ``out`` (T, 6), columns :data:`VIEWS`.

    ``z``, ``q``, ``Pz``, ``Aty`` (T, n); ``y``, ``b``, ``Az`` (T, m); the cone layout
    of :func:`.optimality.cone_layout`; ``check_dual_cone``: the solver's dual residual
    counts the dual cone's violation (a conic problem; not a QP's, as qpbenchmark).
    An instant whose ``z`` or ``y`` is not finite gets ``inf`` in every measure but the
    objective.
    """
    n, m = z.shape[1], y.shape[1]
    s = np.empty(m)
    for t in range(len(z)):
        bad = False
        stationarity = pz = qn = aty = yn = quad = linear = bty = 0.0
        for i in range(n):
            bad = bad or not math.isfinite(z[t, i])
            r = (Pz[t, i] + q[t, i]) + Aty[t, i]
            stationarity = _larger(stationarity, abs(r))
            pz, qn = _larger(pz, abs(Pz[t, i])), _larger(qn, abs(q[t, i]))
            aty = _larger(aty, abs(Aty[t, i]))
            quad += z[t, i] * Pz[t, i]
            linear += q[t, i] * z[t, i]
        for j in range(m):
            bad = bad or not math.isfinite(y[t, j])
            yn = _larger(yn, abs(y[t, j]))
            bty += b[t, j] * y[t, j]
            s[j] = b[t, j] - Az[t, j]
        dual_cone = _dual_cone(y[t], nonneg, apex, members, mask, pows, alphas)
        primal = 0.5 * quad + linear
        dual_objective = -0.5 * quad - bty
        out[t, 0] = _larger(stationarity / _larger(_larger(pz, qn), _larger(aty, TINY)),
                            dual_cone / _larger(yn, TINY))
        out[t, 1] = abs(primal - dual_objective) / _larger(
            _larger(abs(primal), abs(dual_objective)), TINY)
        out[t, 2] = primal
        out[t, 3] = _primal_cone(s, zero, nonneg, apex, members, mask, pows, alphas)
        out[t, 4] = _larger(stationarity, dual_cone) if check_dual_cone else stationarity
        out[t, 5] = abs(quad + linear + bty)
        if bad:
            for c in (0, 1, 3, 4, 5):
                out[t, c] = math.inf
