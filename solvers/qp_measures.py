"""Solver optimality: qpbenchmark's measures on the problem as the solver received it.

This is the *solver-optimality* view of an answer (the *force-accuracy* view, the
package's physics on the named forces, is ``ForceChecks.residuals`` and
:mod:`.optimality`). It asks only whether the solver solved the problem it was given,
in that problem's own units, with the solver's own multipliers, exactly as
`qpbenchmark <https://github.com/qpsolvers/qpbenchmark>`_ 2.7 scores a solve through
qpsolvers' ``Solution`` methods. For a QP ``min 1/2 x'Px + q'x s.t. Ax = b, Gx <= h,
lb <= x <= ub`` with multipliers ``y, z, z_box`` (``Px + q + A'y + G'z + z_box = 0``):

- primal residual ``r_p = max(0, ||Ax - b||_inf, max(Gx - h), max(lb - x), max(x - ub))``;
- dual residual ``r_d = ||Px + q + A'y + G'z + z_box||_inf``;
- duality gap ``r_g = |x'Px + q'x + b'y + h'z + lb'z_box^- + ub'z_box^+|``
  (``v^- = min(v, 0)``, ``v^+ = max(v, 0)``, infinite bounds left out).

All three are absolute (in the units of the data: N, N², ...), as qpbenchmark's are.
A solve succeeds at a setting when the solver reports it found a solution and all
three are strictly below the setting's tolerance (:data:`.settings.SETTINGS`).

The same QP written in Clarabel's standard form (:meth:`QP.as_conic`: ``A_c z + s =
b_c``, ``s`` in zero x nonnegative cones, multipliers ``y_c`` with ``y_c = (y, z,
-z_box^- on finite lb, z_box^+ on finite ub)``) gives the very same numbers:
``A_c'y_c = A'y + G'z + z_box`` and ``b_c'y_c = b'y + h'z + lb'z_box^- +
ub'z_box^+``. So one function, :func:`conic_residuals`, measures both: for a QP it is
qpbenchmark's three measures; for a conic problem it is their analogue, the absolute KKT
residuals of the standard form, with the cone's violation in the primal residual
(``dist(b - Az, K)``, per block) and the dual cone's in the dual residual (a QP's
multipliers are not sign-checked, as qpbenchmark does not check them).

Arrays are batched: ``q`` (T, n), ``A`` (T, m, n) or (m, n), ``b`` (T, m), ``z`` (T, n),
``y`` (T, m); ``P`` (n, n), (T, n, n) or ``None``. Cost: a few dense products per
instant.
"""

from __future__ import annotations

import numpy as np
from cardan_forces.formulations.problems import LS, QP, Conic

from .conversions import convert
from .optimality import Parts, cone_violation
from .settings import Setting
from .stacking import times_P

SHIFT_S = 10.0
"""qpbenchmark's shift of the shifted geometric mean of runtimes (``sh = 10``)."""

MEASURES = ("primal", "dual", "gap")


def conic_residuals(P, q, A, b, cones, z, y, *, check_dual_cone: bool) -> dict:
    """Absolute primal, dual and gap of answers to a conic problem, per instant.

    Answers ``z`` with multipliers ``y`` (Clarabel's convention ``Pz + q + A'y = 0``) to
    ``min 1/2 z'Pz + q'z s.t. Az + s = b, s in K``; ``(T,)`` arrays:

    - ``primal = dist-like violation of b - Az in K``
      (:func:`~.optimality.cone_violation`);
    - ``dual = ||Pz + q + A'y||_inf``, and the dual cone's violation of ``y`` when
      ``check_dual_cone`` (conic problems; not for a QP, as qpbenchmark);
    - ``gap = |z'Pz + q'z + b'y|``.

    ``inf`` where the answer or the multipliers are missing or not finite.
    """
    A = np.asarray(A, float)
    z, y = np.asarray(z, float), np.asarray(y, float)
    bad = ~(np.all(np.isfinite(z), axis=1) & np.all(np.isfinite(y), axis=1))
    z, y = np.where(bad[:, None], 0.0, z), np.where(bad[:, None], np.nan, y)
    Az = z @ A.T if A.ndim == 2 else np.matmul(A, z[:, :, None])[:, :, 0]
    Aty = y @ A if A.ndim == 2 else np.matmul(y[:, None, :], A)[:, 0]
    return residuals_from(times_P(P, z), q, Az, Aty, b, cones, z, y,
                          check_dual_cone=check_dual_cone)


def residuals_from(Pz, q, Az, Aty, b, cones, z, y, *, check_dual_cone: bool) -> dict:
    """:func:`conic_residuals` from the products ``P z``, ``A z`` and ``A'y`` (for
    stacked data whose products are cheaper than dense ones, e.g. a QP's bound rows).
    """
    z, y, b, q = (np.asarray(v, float) for v in (z, y, b, q))
    with np.errstate(invalid="ignore", over="ignore"):
        parts = Parts.of(Pz, q, Aty, np.einsum("tm,tm->t", b, y), z, y,
                         cone_violation(cones, y, dual=True) if check_dual_cone else None)
    return from_parts(parts, b - Az, cones, check_dual_cone=check_dual_cone)


def from_parts(parts: Parts, slack: np.ndarray, cones, *, check_dual_cone: bool) -> dict:
    """:func:`conic_residuals` from the :class:`~.optimality.Parts` of the package's
    measures of the same answers (:func:`~.optimality.stacked_measures`) and the slack
    ``b - A z``: the same three numbers without computing their parts again.
    """
    dual = (np.maximum(parts.stationarity, parts.dual_cone) if check_dual_cone
            else parts.stationarity.copy())
    with np.errstate(invalid="ignore", over="ignore"):
        out = {"primal": cone_violation(cones, slack), "dual": dual,
               "gap": np.abs(parts.quad + parts.linear + parts.bty)}
    for value in out.values():
        value[parts.bad] = np.inf
    return out


def qp_residuals(qp, found: bool, x, y, z, z_box) -> dict[str, float]:
    """The three measures of qpbenchmark for one qpsolvers answer ``x``.

    With qpsolvers' multipliers ``y, z, z_box`` (each ``None`` where qpsolvers gave
    none) to ``qp`` (a package ``QP``), by the formulas of the module docstring, term for term as
    ``qpsolvers.Solution.primal_residual``, ``dual_residual`` and ``duality_gap``:
    ``inf`` when the solver did not report ``found``, without ``x``, or without a
    multiplier that the problem's constraints need.
    """
    if not found or x is None:
        return dict.fromkeys(MEASURES, np.inf)
    x, P, q = np.asarray(x, float), np.asarray(qp.P, float), np.asarray(qp.q, float)
    parts = {"A": (qp.A, qp.b, y), "G": (qp.G, qp.h, z)}
    primal = [0.0] + [float(np.max(bound - x)) for bound in (qp.lb,) if bound is not None]
    primal += [float(np.max(x - bound)) for bound in (qp.ub,) if bound is not None]
    stationarity, gap, missing = P @ x + q, x @ P @ x + q @ x, False
    for key, (M, v, mult) in parts.items():
        if M is None:
            continue
        r = np.asarray(M, float) @ x - np.asarray(v, float)
        primal.append(float(np.max(np.abs(r) if key == "A" else r)))
        if mult is None:
            missing = True
            continue
        stationarity = stationarity + np.asarray(M, float).T @ np.asarray(mult, float)
        gap += float(np.asarray(v, float) @ np.asarray(mult, float))
    if qp.lb is not None or qp.ub is not None:
        if z_box is None:
            missing = True
        else:
            zb = np.asarray(z_box, float)
            stationarity = stationarity + zb
            for bound, part in ((qp.lb, np.minimum(zb, 0.0)), (qp.ub, np.maximum(zb, 0.0))):
                if bound is not None:
                    keep = np.isfinite(bound)
                    gap += float(np.asarray(bound, float)[keep] @ part[keep])
    dual = np.inf if missing else float(np.abs(stationarity).max(initial=0.0))
    return {"primal": max(primal), "dual": dual, "gap": np.inf if missing else abs(gap)}


def qp_duals(qp, y, z, z_box) -> np.ndarray:
    """Multipliers ``y, z, z_box`` (qpsolvers') of ``qp`` (a package ``QP``) as the
    multipliers of ``qp.as_conic()``'s rows (see the module docstring).
    """
    parts = [np.asarray(v, float) for v, rows in ((y, qp.A), (z, qp.G)) if rows is not None]
    for bound, part in ((qp.lb, np.minimum), (qp.ub, np.maximum)):
        if bound is not None:
            keep = np.isfinite(bound)
            sign = -1.0 if part is np.minimum else 1.0
            parts.append(sign * part(np.asarray(z_box, float), 0.0)[keep])
    return np.concatenate(parts) if parts else np.zeros(0)


def solver_optimality(received, z, y) -> dict[str, float]:
    """The three measures of one answer ``z`` (``y``: multipliers in the rows of the
    received problem's conic form, ``None``: none given) to the problem a backend
    received (an ``LS``, ``QP`` or ``Conic``): qpbenchmark's for a QP or least norm, the
    conic KKT analogue for a conic problem. ``inf`` without an answer or multipliers
    (qpbenchmark's value for a missing dual).
    """
    conic = convert(received, (Conic,))
    if z is None or y is None or conic is None:
        return dict.fromkeys(MEASURES, np.inf)
    found = conic_residuals(conic.P, np.asarray(conic.q, float)[None], conic.A,
                            np.asarray(conic.b, float)[None], conic.cones,
                            np.asarray(z, float)[None], np.asarray(y, float)[None],
                            check_dual_cone=not isinstance(received, (LS, QP)))
    return {k: float(v[0]) for k, v in found.items()}


def succeeds(found, primal, dual, gap, setting: Setting):
    """The success rule of qpbenchmark, elementwise: the solver reported a solution and the
    primal residual, dual residual and duality gap are each strictly below the
    setting's tolerance (a NaN measure fails).
    """
    tol = setting.tolerance
    return (np.asarray(found, bool) & (np.asarray(primal) < tol) & (np.asarray(dual) < tol)
            & (np.asarray(gap) < tol))


def failed_rule(found: bool, measures: dict[str, float], setting: Setting) -> str:
    """Which part of :func:`succeeds` a run fails (``""``: none): ``"not found"`` or the
    measures at or above the tolerance, joined by ``+``.
    """
    if not found:
        return "not found"
    return "+".join(k for k in MEASURES if not measures[k] < setting.tolerance)


def runtime_for_mean(found, runtime_s, setting: Setting):
    """The time-limit rule of qpbenchmark, elementwise: a run the solver reports as not found
    counts as the setting's time limit in the shifted geometric mean (a found run counts
    its time, whatever its accuracy).
    """
    return np.where(np.asarray(found, bool), np.asarray(runtime_s, float), setting.time_limit_s)


def shifted_geometric_mean(values, shift: float = SHIFT_S) -> float:
    """The ``shgeom`` of qpbenchmark: ``exp(mean(log(v + shift))) - shift`` (``nan`` for none)."""
    v = np.asarray(values, float)
    return float(np.exp(np.mean(np.log(v + shift))) - shift) if v.size else float("nan")
