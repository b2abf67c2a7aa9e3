"""Compiled optimality views of a check pass (numba, extra ``numba``).

The same measures as :func:`.optimality.stacked_measures` (the package's view) and
:func:`.qp_measures.from_parts` (the solver's view), by the formulas of those modules'
docstrings, fused into one pass over the instants: each instant's parts (``||Pz + q +
A'y||_inf``, ``z'Pz``, ``q'z``, ``b'y``, the dual cone's violation of ``y``, the primal
cone's violation of ``s = b - Az``) are summed and compared in scalars, instead of the
NumPy path's hundred-odd whole-array operations, each of which costs microseconds of
dispatch and, right after a solver has run, of cold caches. A stacked (T, r, n) block
of rows, the largest array the pass reads, gives ``A z`` and ``A'y`` in one sweep over
its numbers (:func:`dense_products`), not one sweep each; ``P z`` and the products of
the other blocks (rows shared by all instants, sparse patterns, bounds) stay NumPy's.

Sums run in index order (a block's rows as :func:`dense_products` says); NumPy's
``einsum`` and matrix products may sum in another, so the two paths agree to a few units
in the last place, not to the bit (the tests hold them to 1e-9 relative, rounding of
sums whose terms cancel included).
A NaN propagates through every largest-of as through NumPy's ``maximum``. Compiling takes
a few seconds, once: numba caches the machine code.
"""

from __future__ import annotations

import math

import numpy as np

from ..driveline.compiled import HAVE_NUMBA, njit

if not HAVE_NUMBA:  # an optional extra: the callers take their NumPy paths
    raise ImportError("numba is not installed")


@njit(cache=True, inline="always")
def _larger(a, b):
    """``max(a, b)``, NaN if either is NaN (NumPy's ``maximum``)."""
    return a if (a > b or a != a) else b


@njit(cache=True, inline="always")
def _smaller(a, b):
    """``min(a, b)``, NaN if either is NaN (NumPy's ``minimum``)."""
    return a if (a < b or a != a) else b


@njit(cache=True, inline="always")
def _outside(v, k, apex, members, mask):
    """``||v_members|| - v_apex`` of second-order block ``k`` (a self-dual cone: the
    primal and the dual violation alike).
    """
    spread = 0.0
    for j in range(members.shape[1]):
        w = v[members[k, j]] * mask[k, j]
        spread += w * w
    return math.sqrt(spread) - v[apex[k]]


@njit(cache=True)
def _violation(v, zero, nonneg, apex, members, mask, pows, alphas, dual):
    """How far one instant's ``v`` is outside ``K`` (``dual`` False: the slack's, as
    :func:`.qp_measures.cone_violation`) or ``K*`` (``dual`` True: the multipliers', as
    :func:`.optimality.dual_cone_violation`; the zero cone's dual is free, the
    nonnegative and second-order cones are self-dual, the power cone's dual scales
    ``u, v`` by ``alpha, 1 - alpha``).
    """
    worst = 0.0
    if not dual:
        for i in zero:
            worst = _larger(worst, abs(v[i]))
    for i in nonneg:
        worst = _larger(worst, -v[i])
    for k in range(len(apex)):
        worst = _larger(worst, _outside(v, k, apex, members, mask))
    for k in range(len(alphas)):
        a = alphas[k]
        u, w = _larger(v[pows[k, 0]], 0.0), _larger(v[pows[k, 1]], 0.0)
        if dual:
            u, w = u / a, w / (1.0 - a)
        low = -_smaller(v[pows[k, 0]], v[pows[k, 1]])  # a negative u or v is outside both
        worst = _larger(worst, _larger(abs(v[pows[k, 2]]) - u ** a * w ** (1.0 - a), low))
    return _larger(worst, 0.0)


@njit(cache=True)
def views(z, y, q, b, Pz, Az, Aty, zero, nonneg, apex, members, mask, pows, alphas,
          check_dual_cone, tiny, out):
    """Both views of T answers into ``out`` (T, 6): the package's dual, gap and
    objective, the solver's primal, dual and gap.

    ``z``, ``q``, ``Pz``, ``Aty`` (T, n); ``y``, ``b``, ``Az`` (T, m); the cone layout
    of :func:`.optimality.cone_layout`; ``tiny``: the floor of a denominator
    (:data:`.optimality.TINY`); ``check_dual_cone``: the solver's dual residual
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
        dual_cone = _violation(y[t], zero, nonneg, apex, members, mask, pows, alphas, True)
        primal = 0.5 * quad + linear
        dual_objective = -0.5 * quad - bty
        out[t, 0] = _larger(stationarity / _larger(_larger(pz, qn), _larger(aty, tiny)),
                            dual_cone / _larger(yn, tiny))
        out[t, 1] = abs(primal - dual_objective) / _larger(
            _larger(abs(primal), abs(dual_objective)), tiny)
        out[t, 2] = primal
        out[t, 3] = _violation(s, zero, nonneg, apex, members, mask, pows, alphas, False)
        out[t, 4] = _larger(stationarity, dual_cone) if check_dual_cone else stationarity
        out[t, 5] = abs(quad + linear + bty)
        if bad:
            for c in (0, 1, 3, 4, 5):
                out[t, c] = math.inf


@njit(cache=True, fastmath={"reassoc", "contract"})
def dense_products(block, z, y, row, Az, Aty):
    """``Az[:, row:row + r] = B z`` and ``Aty += B'y[:, row:row + r]`` per instant for a
    stacked block ``B`` (T, r, n) of rows, each number of ``B`` read once.

    A row's sum may be reassociated (``fastmath`` reassoc and contract: the loop over a
    row runs in vector instructions, 2.5x faster than in sequence, and beats NumPy's two
    stacked products, 0.43 against 0.55 us an instant of ``compliance_hertz`` when
    both are in cache); the order is the compiled loop's, the same for every instant
    whatever the batch, as a matrix library's is.
    """
    r, n = block.shape[1], block.shape[2]
    for t in range(block.shape[0]):
        for i in range(r):
            acc = 0.0
            weight = y[t, row + i]
            for j in range(n):
                a = block[t, i, j]
                acc += a * z[t, j]
                Aty[t, j] += a * weight
            Az[t, row + i] = acc
