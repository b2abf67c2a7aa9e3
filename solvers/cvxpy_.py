"""Backends ``cvxpy-clarabel``, ``cvxpy-ecos``, ``cvxpy-scs``, ``cvxpy-osqp``.

Each problem class becomes a cvxpy problem directly (no conversion): cones of a
:class:`Conic` act on the slack ``s = b - A z`` (zero: ``s == 0``, nonneg: ``s >= 0``,
soc: ``cp.SOC``, pow: ``cp.PowCone3D``). "Defaults" here are cvxpy's defaults for each
solver (cvxpy itself sets e.g. OSQP's and SCS's eps to 1e-5). ``setup_s`` is building
the expressions plus cvxpy's compilation; ``solve_s`` the rest of ``Problem.solve``.
"""

from __future__ import annotations

import time

import numpy as np

from cardan_forces.formulations.problems import LP, LS, QP, Conic

from . import settings
from .record import Outcome
from .registry import Backend

SOLVERS: dict[str, tuple[str, str, str | None]] = {
    "cvxpy-clarabel": ("CLARABEL", "clarabel", None),
    "cvxpy-ecos": ("ECOS", "ecos", "ecos"),
    "cvxpy-scs": ("SCS", "scs", None),
    "cvxpy-osqp": ("OSQP", "osqp", None),
}
"""Backend name -> (cvxpy solver name, settings key and distribution, pip extra)."""

EXTRAS: dict[str, str | None] = {name: extra for name, (_, _, extra) in SOLVERS.items()}

TOLERANCES: dict[str, tuple[str, ...]] = {
    "clarabel": ("tol_gap_abs", "tol_gap_rel", "tol_feas"),
    "ecos": ("abstol", "reltol", "feastol"),
    "scs": ("eps_abs", "eps_rel"),
    "osqp": ("eps_abs", "eps_rel"),
}
"""Each solver's own parameters a requested tolerance sets (cvxpy passes them on)."""

STATUS = {
    "optimal": "solved",
    "optimal_inaccurate": "inaccurate",
    "user_limit": "inaccurate",
    "infeasible": "infeasible",
    "infeasible_inaccurate": "infeasible",
    "unbounded": "unbounded",
    "unbounded_inaccurate": "unbounded",
}
"""cvxpy status -> ours; anything else (solver_error, infeasible_or_unbounded) is failed."""


def _linear_constraints(z, problem) -> list:
    cons = []
    if problem.A is not None:
        cons.append(np.asarray(problem.A, float) @ z == np.asarray(problem.b, float))
    if problem.G is not None:
        cons.append(np.asarray(problem.G, float) @ z <= np.asarray(problem.h, float))
    for bound, sign in ((problem.lb, 1.0), (problem.ub, -1.0)):
        if bound is not None:
            keep = np.flatnonzero(np.isfinite(bound))
            if keep.size:
                cons.append(sign * z[keep] >= sign * np.asarray(bound)[keep])
    return cons


def _quadratic(cp, z, P) -> object:
    P = np.asarray(P, float)
    return 0.5 * cp.quad_form(z, 0.5 * (P + P.T), assume_PSD=True)


def _conic_constraints(cp, z, problem: Conic) -> list:
    s = np.asarray(problem.b, float) - np.asarray(problem.A, float) @ z
    cons, row = [], 0
    for kind, size in problem.cones:
        rows = 3 if kind == "pow" else int(size)
        block = s[row:row + rows]
        if kind == "zero":
            cons.append(block == 0)
        elif kind == "nonneg":
            cons.append(block >= 0)
        elif kind == "soc":
            cons.append(cp.SOC(block[0], block[1:]))
        else:
            cons.append(cp.PowCone3D(block[0], block[1], block[2], float(size)))
        row += rows
    return cons


def build(cp, problem) -> tuple[object, object]:
    """The cvxpy problem for an LS, QP, LP or Conic, and its variable."""
    z = cp.Variable(problem.n)
    if isinstance(problem, LS):
        w = np.ones(problem.n) if problem.weights is None else np.asarray(problem.weights, float)
        objective = 0.5 * cp.sum(cp.multiply(w, cp.square(z)))
        cons = [np.asarray(problem.A, float) @ z == np.asarray(problem.b, float)]
    elif isinstance(problem, QP):
        objective = _quadratic(cp, z, problem.P) + np.asarray(problem.q, float) @ z
        cons = _linear_constraints(z, problem)
    elif isinstance(problem, LP):
        objective = np.asarray(problem.c, float) @ z
        cons = _linear_constraints(z, problem)
    else:
        objective = np.asarray(problem.q, float) @ z
        if problem.P is not None:
            objective = objective + _quadratic(cp, z, problem.P)
        cons = _conic_constraints(cp, z, problem)
    return cp.Problem(cp.Minimize(objective), cons), z


def _solve_with(name: str):
    """The adapter function for one cvxpy solver."""
    cvx_name, key, _ = SOLVERS[name]

    def solve_cvxpy(problem, tol=None, initvals=None, **options) -> Outcome:
        import cvxpy as cp

        start = time.perf_counter()
        prob, z = build(cp, problem)
        if initvals is not None:
            z.value = np.asarray(initvals, float)
        built = time.perf_counter()
        prob.solve(solver=cvx_name, warm_start=initvals is not None,
                   **(settings.options_for(TOLERANCES[key], tol) | options))
        wall = time.perf_counter() - built
        compile_s = prob.compilation_time or 0.0
        stats = prob.solver_stats
        return Outcome(STATUS.get(prob.status, "failed"), z.value,
                       iterations=stats.num_iters,
                       message="" if prob.status == "optimal" else f"cvxpy status {prob.status}",
                       objective=prob.value, setup_s=built - start + compile_s,
                       solve_s=wall - compile_s)

    return solve_cvxpy


def _no_power_cone(problem) -> bool:
    return not (isinstance(problem, Conic) and any(k == "pow" for k, _ in problem.cones))


def backends() -> list[Backend]:
    """One backend per solver of :data:`SOLVERS` that cvxpy reports installed."""
    try:
        import cvxpy as cp
    except ImportError:
        return []
    installed = set(cp.installed_solvers())
    found = []
    for name, (cvx_name, key, extra) in SOLVERS.items():
        if cvx_name not in installed:
            continue
        accepts = (LS, QP) if key == "osqp" else (LS, QP, LP, Conic)
        limits = {"supports": _no_power_cone} if key == "ecos" else {}
        found.append(Backend(name, accepts, _solve_with(name), ("cvxpy", key), extra, "cvxpy",
                             tolerances=TOLERANCES[key], **limits))
    return found
