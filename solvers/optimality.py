"""Optimality of an answer relative to the problem data: the package's measures.

These are the *package-optimality* measures of the bench's ladder, relative to the data;
qpbenchmark's are absolute and live in :mod:`.qp_measures` (the *solver-optimality*
view), computed as qpbenchmark computes them.

Every convex problem the package builds reaches Clarabel's standard form (``LS -> QP ->
Conic``, ``LP -> Conic``), ``min 1/2 z'Pz + q'z s.t. A z + s = b, s in K``, whose
optimality conditions with multipliers ``y`` are

- primal feasibility: ``s = b - A z in K`` (the package's force residuals, ``ForceChecks``);
- dual feasibility: ``P z + q + A'y = 0`` (stationarity of the Lagrangian) and
  ``y in K*`` (the dual cone);
- zero duality gap: ``(1/2 z'Pz + q'z) - (-1/2 z'Pz - b'y) = 0``.

``dual`` is the largest of the stationarity residual ``||Pz + q + A'y||_inf`` relative to
the largest of ``||Pz||_inf, ||q||_inf, ||A'y||_inf`` and the dual-cone violation
relative to ``||y||_inf``; ``gap`` is the duality gap relative to the larger objective.
Both are dimensionless, so a level such as 1e-6 means the same for a problem in N and
for one in units of the load. In formulas, with ``r = P z + q + A'y``:

- ``primal = max(equilibrium, sign, complementarity, cone)`` of the forces, each over
  ``||b_eq||_2`` (``ForceChecks.residuals``);
- ``dual = max(||r||_inf / max(||Pz||_inf, ||q||_inf, ||A'y||_inf),
  viol_K*(y) / ||y||_inf)``;
- ``gap = |p - d| / max(|p|, |d|)``, ``p = 1/2 z'Pz + q'z``, ``d = -1/2 z'Pz - b'y``
  (or ``|p - p*| / |p*|`` against a high-precision optimal value ``p*`` where the
  multipliers are recovered);
- both 0 where ``P z + q = 0`` (a feasibility problem's ``min 0``): ``y = 0`` satisfies
  stationarity and closes the gap, so a feasible ``z`` is optimal whatever multipliers
  the solver returned (relative to terms that vanish, theirs would measure only
  rounding).

Where they differ from qpbenchmark's (``r_p, r_d, r_g`` of :mod:`.qp_measures`) and
why: qpbenchmark's are absolute, in the units of the data, so on a least norm in
newtons (objective near 1e9) no exact solver meets a 1e-9 gap while on a small
objective the relative measure is the stricter; ``primal`` is taken on the forces and
includes end-face complementarity, which the physics asks and the QP does not; the
bench's success also asks the distance to a reference where the optimum is unique.

Where a backend returns no multipliers they are recovered (:func:`recover`) by a
nonnegative least-squares solve of stationarity on the constraints active at ``z``: a
row of the nonnegative cone with ``s_i = 0``, a cone block on its boundary (one
multiplier along the block's normal there), a block at its apex (the whole block).

All functions take a batch: ``q`` (T, n), ``A`` (T, m, n), ``b`` (T, m), ``z`` (T, n),
``y`` (T, m); ``P`` (n, n), (T, n, n) or ``None``.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np
from cardan_forces.formulations.problems import LS, QP, Conic

from .conversions import convert
from .stacking import Stacked, blocks, cone_layout, cone_spans, stacked_batch, times_P

ACTIVE_RTOL = 1e-7
"""A constraint counts as active when its slack is below this, relative to
``max(1, ||b||_inf, ||A z||_inf)``."""

TINY = 1e-300


def inf_norm(v: np.ndarray) -> np.ndarray:
    """``||v||_inf`` along the last axis (0 for none, NaN where ``v`` has a NaN), from
    the largest and the least entry: two reductions that write no (T, n) temporary.
    """
    return np.maximum(v.max(axis=-1, initial=0.0), -v.min(axis=-1, initial=0.0))


def below_zero(v: np.ndarray, spans) -> np.ndarray:
    """``max(0, -min v)`` over the rows ``spans`` (slices) of each instant: how far the
    entries that must be nonnegative go below zero.
    """
    worst = np.zeros(len(v))
    for rows in spans:
        worst = np.maximum(worst, -v[:, rows].min(axis=1))
    return worst


def cone_violation(cones, v: np.ndarray, dual: bool = False) -> np.ndarray:
    """How far each instant's ``v`` (T, m) is outside the cone ``K`` of ``cones`` (a
    slack ``s = b - A z``), or with ``dual`` outside its dual ``K*`` (multipliers
    ``y``): absolute, (T,), >= 0. ``|v_i|`` on zero rows (their dual is free); ``-v_i``
    on nonnegative rows and ``||v_1:|| - v_0`` on a second-order block (both cones are
    self-dual); on a power block ``|w| - u^a x^(1-a)``, or a negative ``u`` or ``x``
    (its dual: ``(u/a)^a (x/(1-a))^(1-a) >= |w|``).
    """
    zeros, nonnegs = cone_spans(tuple(cones))
    _, _, apex, members, mask, pows, alphas = cone_layout(tuple(cones))
    worst = below_zero(v, nonnegs)
    for rows in () if dual else zeros:
        worst = np.maximum(worst, inf_norm(v[:, rows]))
    if len(apex):
        spread = v[:, members] * mask
        spread = np.sqrt(np.einsum("tkj,tkj->tk", spread, spread))
        worst = np.maximum(worst, (spread - v[:, apex]).max(axis=1))
    if len(pows):
        u, x, w = v[:, pows[:, 0]], v[:, pows[:, 1]], v[:, pows[:, 2]]
        su, sx = (alphas, 1.0 - alphas) if dual else (1.0, 1.0)
        mean = (np.maximum(u, 0.0) / su) ** alphas * (np.maximum(x, 0.0) / sx) ** (1.0 - alphas)
        worst = np.maximum(worst, np.maximum(np.abs(w) - mean, -np.minimum(u, x)).max(axis=1))
    return np.maximum(worst, 0.0)


def measures(P, q, A, b, cones, z, y) -> dict[str, np.ndarray]:
    """``{"dual", "gap", "objective"}`` per instant ((T,) arrays; see the module docstring).

    ``objective`` is the primal objective ``1/2 z'Pz + q'z`` (for an objective gap).
    """
    return stacked_measures(stacked_batch(P, q, A, b, cones), z, y)[0]


def stacked_measures(st: Stacked, z: np.ndarray, y: np.ndarray) -> tuple[dict, Parts]:
    """:func:`measures` of answers ``z`` with multipliers ``y`` to the stacked problems
    ``st``, and the :class:`Parts` they were made of (the solver's view is made of the
    same, :func:`~.qp_measures.from_parts`, so each is computed once).
    """
    parts = Parts.of(times_P(st.P, z), st.q, st.Aty(y), np.einsum("tm,tm->t", st.b, y), z,
                     y, cone_violation(st.cones, y, dual=True))
    return _combined(parts, st.q, y), parts


def combine(Pz, q, Aty, bty, z, y, cone_violation) -> dict[str, np.ndarray]:
    """The measures from their parts (``P z``, ``q``, ``A'y``, ``b'y``, the dual-cone
    violation), for a backend whose problem form gives them more cheaply than
    :func:`measures`' dense products.
    """
    return _combined(Parts.of(Pz, q, Aty, bty, z, y, cone_violation), q, y)


@dataclass(frozen=True)
class Parts:
    """What the measures of T answers ``z`` with multipliers ``y`` are made of, (T,)
    arrays but the products: ``Pz`` and ``Aty`` (T, n); ``dual_cone``, the dual cone's
    violation of ``y`` (``None`` where not measured); ``stationarity``
    ``||Pz + q + A'y||_inf``; ``quad`` ``z'Pz``, ``linear`` ``q'z``, ``bty`` ``b'y``;
    ``bad``: where ``z`` or ``y`` is not finite. The package's view (relative) and the
    solver's (absolute, :func:`~.qp_measures.from_parts`) are both made of them.
    """

    Pz: np.ndarray
    Aty: np.ndarray
    dual_cone: np.ndarray
    stationarity: np.ndarray
    quad: np.ndarray
    linear: np.ndarray
    bty: np.ndarray
    bad: np.ndarray

    @classmethod
    def of(cls, Pz, q, Aty, bty, z, y, dual_cone) -> Parts:
        """The parts from the products and the dual cone's violation (``None``: not
        measured, for a QP's multipliers).
        """
        bad = ~(np.isfinite(z).all(axis=1) & np.isfinite(y).all(axis=1))
        residual = Pz + q
        residual += Aty
        return cls(Pz, Aty, dual_cone, inf_norm(residual), np.einsum("ti,ti->t", z, Pz),
                   np.einsum("ti,ti->t", q, z), bty, bad)

    def take(self, rows) -> Parts:
        """The parts of the answers at ``rows`` (indices or a mask)."""
        return Parts(*(getattr(self, f.name)[rows] for f in fields(self)))


def _combined(parts: Parts, q, y) -> dict[str, np.ndarray]:
    """The package's measures (the module docstring's formulas) from their parts."""
    stationarity = parts.stationarity / np.maximum(
        np.maximum(inf_norm(parts.Pz), inf_norm(q)), np.maximum(inf_norm(parts.Aty), TINY))
    cone = parts.dual_cone / np.maximum(inf_norm(y), TINY)
    primal = 0.5 * parts.quad + parts.linear
    dual_obj = -0.5 * parts.quad - parts.bty
    gap = np.abs(primal - dual_obj) / np.maximum(np.maximum(np.abs(primal), np.abs(dual_obj)),
                                                 TINY)
    dual = np.maximum(stationarity, cone)
    unforced = inf_norm(parts.Pz + q) == 0.0  # y = 0 certifies it (a feasibility problem)
    dual[unforced], gap[unforced] = 0.0, 0.0
    dual[parts.bad], gap[parts.bad] = np.inf, np.inf
    return {"dual": dual, "gap": gap, "objective": primal}


def _normal(kind: str, alpha: float, s: np.ndarray) -> np.ndarray | None:
    """The outward normal of a cone block's boundary at ``s`` (a direction in K*
    orthogonal to ``s``), or ``None`` at the apex.
    """
    if kind == "soc":
        return None if not np.any(s) else np.concatenate([[s[0]], -s[1:]])
    x, v, w = s
    if x <= 0 or v <= 0:
        return None
    mean = x ** alpha * v ** (1.0 - alpha)
    return np.array([alpha * mean / x, (1.0 - alpha) * mean / v, -np.sign(w)])


def recover(P, q, A, b, cones, z) -> np.ndarray:
    """Multipliers ``y`` (m,) for one instance: nonnegative least squares of
    ``A_act' y_act = -(P z + q)`` on the constraints active at ``z`` (see the module
    docstring); zero on inactive rows.
    """
    from scipy.optimize import lsq_linear

    z, b = np.asarray(z, float), np.asarray(b, float)
    A = np.asarray(A, float)
    s = b - A @ z
    level = ACTIVE_RTOL * max(1.0, float(inf_norm(b)), float(inf_norm(A @ z)))
    columns, lower, owners = [], [], []  # owners: (rows, direction or None)
    for kind, alpha, rows in blocks(cones):
        block = s[rows]
        if kind == "zero":
            cols = [A[r] for r in range(rows.start, rows.stop)]
            columns += cols
            lower += [-np.inf] * len(cols)
            owners += [(slice(r, r + 1), None) for r in range(rows.start, rows.stop)]
        elif kind == "nonneg":
            for r in np.flatnonzero(block <= level) + rows.start:
                columns.append(A[r])
                lower.append(0.0)
                owners.append((slice(r, r + 1), None))
        else:
            margin = (block[0] - np.linalg.norm(block[1:]) if kind == "soc" else
                      np.clip(block[0], 0, None) ** alpha * np.clip(block[1], 0, None)
                      ** (1 - alpha) - abs(block[2]))
            if margin > level:
                continue
            normal = _normal(kind, alpha, block) if inf_norm(block) > level else None
            if normal is None:  # apex: every multiplier of the block, checked by K* later
                for r in range(rows.start, rows.stop):
                    columns.append(A[r])
                    lower.append(-np.inf)
                    owners.append((slice(r, r + 1), None))
            else:
                columns.append(normal @ A[rows])
                lower.append(0.0)
                owners.append((rows, normal))
    y = np.zeros(len(b))
    if not columns:
        return y
    target = -(times_P(P, z[None])[0] + np.asarray(q, float))
    M = np.array(columns).T
    coef = lsq_linear(M, target, bounds=(np.array(lower), np.inf), method="bvls").x
    for value, (rows, normal) in zip(coef, owners):
        y[rows] = value if normal is None else value * normal
    return y


def multipliers(st: Stacked, z: np.ndarray, given: list) -> tuple[np.ndarray, np.ndarray]:
    """``y`` (T, m) of answers ``z`` (T, n) to the stacked problems ``st``: the solver's
    ``given[k]`` where it has one of length m, else recovered (:func:`recover`); and the
    mask of the instants whose multipliers the solver gave. The one place both the
    per-instant checks and a batch's find their multipliers.
    """
    m = st.b.shape[1]
    mask = [g is not None and len(g) == m for g in given]
    y = np.array(given if all(mask) else [
        given[k] if mask[k] else recover(st.Pk(k), st.q[k], st.A(k), st.b[k], st.cones, z[k])
        for k in range(len(z))], float).reshape(len(z), m)
    return y, np.array(mask, bool)


def unique_optimum(problem) -> bool:
    """Whether the problem's optimum is one point, known from its data: a least norm
    (positive weights) or a positive definite ``P`` (strictly convex objective).
    A distance to a reference point means something only then.
    """
    if isinstance(problem, LS):
        return True
    if isinstance(problem, (QP, Conic)) and problem.P is not None:
        try:
            np.linalg.cholesky(np.asarray(problem.P, float))
        except np.linalg.LinAlgError:
            return False
        return True
    return False


def objective_value(problem, z) -> float | None:
    """The objective ``1/2 z'Pz + q'z`` of an LS, QP, LP or conic problem at ``z`` (in
    its conic form; the same value along every conversion), ``None`` for the others.
    """
    conic = convert(problem, (Conic,))
    if conic is None or z is None:
        return None
    z = np.asarray(z, float)
    return float(0.5 * z @ times_P(conic.P, z[None])[0] + np.asarray(conic.q, float) @ z)
