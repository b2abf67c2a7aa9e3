"""Backends ``cvxpy-clarabel``, ``cvxpy-ecos``, ``cvxpy-scs``, ``cvxpy-osqp``.

Each problem class becomes a cvxpy problem directly (no conversion): cones of a
:class:`Conic` act on the slack ``s = b - A z`` (zero: ``s == 0``, nonneg: ``s >= 0``,
soc: ``cp.SOC``, pow: ``cp.PowCone3D``). "Defaults" here are cvxpy's defaults for each
solver (cvxpy itself sets e.g. OSQP's and SCS's eps to 1e-5). ``setup_s`` is building
the expressions plus cvxpy's compilation; ``solve_s`` the rest of ``Problem.solve``.

The data that change between the instants of one formulation are cvxpy Parameters, so a
problem of a structure already seen (the same sizes, cones, ``P`` and bounds) is not
rebuilt: its parameters get the new values and cvxpy reuses its compilation (DPP).
"""

from __future__ import annotations

import time

import numpy as np
from cardan_forces.formulations.problems import LP, LS, QP, Conic

from . import settings
from .backend import Backend
from .record import Outcome, Status

SOLVERS: dict[str, tuple[str, str, str | None]] = {
    "cvxpy-clarabel": ("CLARABEL", "clarabel", None),
    "cvxpy-ecos": ("ECOS", "ecos", "ecos"),
    "cvxpy-scs": ("SCS", "scs", None),
    "cvxpy-osqp": ("OSQP", "osqp", None),
}
"""Backend name -> (cvxpy solver name, the solver's name in :data:`.settings.TOLERANCES`
and its distribution, pip extra); cvxpy passes the tolerance parameters on."""

EXTRAS: dict[str, str | None] = {name: extra for name, (_, _, extra) in SOLVERS.items()}

STATUS = {
    "optimal": Status.SOLVED,
    "optimal_inaccurate": Status.INACCURATE,
    "user_limit": Status.INACCURATE,
    "infeasible": Status.INFEASIBLE,
    "infeasible_inaccurate": Status.INFEASIBLE,
    "unbounded": Status.UNBOUNDED,
    "unbounded_inaccurate": Status.UNBOUNDED,
}
"""cvxpy status -> ours; anything else (solver_error, infeasible_or_unbounded) is failed."""


def _linear_constraints(z, problem, param) -> list:
    cons = []
    if problem.A is not None:
        cons.append(param("A") @ z == param("b"))
    if problem.G is not None:
        cons.append(param("G") @ z <= param("h"))
    for bound, sign in ((problem.lb, 1.0), (problem.ub, -1.0)):
        if bound is not None:
            keep = np.flatnonzero(np.isfinite(bound))
            if keep.size:
                cons.append(sign * z[keep] >= sign * np.asarray(bound)[keep])
    return cons


def _quadratic(cp, z, P) -> object:
    P = np.asarray(P, float)
    return 0.5 * cp.quad_form(z, 0.5 * (P + P.T), assume_PSD=True)


def _conic_constraints(cp, z, s, cones) -> list:
    """The cones on the slack ``s = b - A z``, block by block."""
    cons, row = [], 0
    for kind, size in cones:
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


def _diagonal(P) -> bool:
    P = np.asarray(P, float)
    return not np.any(P - np.diag(np.diag(P))) and bool(np.all(np.diag(P) >= 0))


def _field(name: str):
    if name == "P":
        return lambda problem: np.diag(np.asarray(problem.P, float))
    return lambda problem: np.asarray(getattr(problem, name), float)


def build(cp, problem) -> tuple[object, object, list]:
    """The cvxpy problem for an LS, QP, LP or Conic, its variable, and its parameters:
    ``[(Parameter, getter)]`` for the data that change between instants of one
    formulation (``A, b, q, c, G, h``, least-norm weights, a diagonal ``P``); a
    non-diagonal ``P`` and the bounds stay constants of the structure.
    """
    z = cp.Variable(problem.n)
    params = []

    def param(name, nonneg=False):
        getter = _field(name)
        value = getter(problem)
        p = cp.Parameter(value.shape, nonneg=nonneg, value=value)
        params.append((p, getter))
        return p

    def quadratic(P):
        if _diagonal(P):
            return 0.5 * cp.sum(cp.multiply(param("P", nonneg=True), cp.square(z)))
        return _quadratic(cp, z, P)

    if isinstance(problem, LS):
        w = (np.ones(problem.n) if problem.weights is None else param("weights", nonneg=True))
        objective = 0.5 * cp.sum(cp.multiply(w, cp.square(z)))
        cons = [param("A") @ z == param("b")]
    elif isinstance(problem, (QP, LP)):
        linear = param("q" if isinstance(problem, QP) else "c") @ z
        objective = linear + (quadratic(problem.P) if isinstance(problem, QP) else 0)
        cons = _linear_constraints(z, problem, param)
    else:
        objective = param("q") @ z
        if problem.P is not None:
            objective = objective + quadratic(problem.P)
        cons = _conic_constraints(cp, z, param("b") - param("A") @ z, problem.cones)
    return cp.Problem(cp.Minimize(objective), cons), z, params


def _structure_key(problem, cvx_name: str) -> tuple:
    """What a compiled problem depends on besides its parameters."""
    def data(name):
        value = getattr(problem, name, None)
        if value is None:
            return None
        if name == "P" and _diagonal(value):
            return "diagonal"
        return np.shape(value), np.asarray(value, float).tobytes()

    shapes = tuple(np.shape(getattr(problem, f, None)) for f in ("A", "G", "weights"))
    return (type(problem).__name__, cvx_name, problem.n, shapes,
            getattr(problem, "cones", None), data("P"), data("lb"), data("ub"))


CACHE_SIZE = 16
"""Compiled cvxpy problems kept, one per structure."""

_PROBLEMS: dict[tuple, tuple] = {}


def _compiled(cp, problem, cvx_name: str):
    """The cached problem of this structure with this instant's numbers, or a new one."""
    key = _structure_key(problem, cvx_name)
    cached = _PROBLEMS.get(key)
    if cached is None:
        cached = build(cp, problem)
        if CACHE_SIZE > 0:
            while len(_PROBLEMS) >= CACHE_SIZE:
                _PROBLEMS.pop(next(iter(_PROBLEMS)))
            _PROBLEMS[key] = cached
        return cached
    for p, getter in cached[2]:
        p.value = getter(problem)
    return cached


def conic_duals(problem, constraints) -> np.ndarray | None:
    """Cvxpy's multipliers in the rows of the problem's conic form (``None`` if cvxpy
    gave none). cvxpy's duals of ``A z == b``, ``G z <= h``, ``z >= lb``, ``s >= 0`` and
    of the cones on ``s = b - A z`` are the conic ones; that of ``s == 0`` changes sign.
    """
    parts = []
    for con in constraints:
        value = con.dual_value
        if value is None:
            return None
        flat = np.concatenate([np.ravel(v) for v in value]) if isinstance(value, list) \
            else np.ravel(value)
        sign = -1.0 if isinstance(problem, Conic) and type(con).__name__ == "Equality" else 1.0
        parts.append(sign * np.asarray(flat, float))
    return np.concatenate(parts) if parts else np.zeros(0)


def _solve_with(name: str):
    """The adapter function for one cvxpy solver."""
    cvx_name, key, _ = SOLVERS[name]

    def solve_cvxpy(problem, tol=None, initvals=None, **options) -> Outcome:
        import cvxpy as cp

        start = time.perf_counter()
        prob, z, _ = _compiled(cp, problem, cvx_name)
        if initvals is not None:
            z.value = np.asarray(initvals, float)
        built = time.perf_counter()
        prob.solve(solver=cvx_name, warm_start=initvals is not None,
                   **(settings.solver_options(key, tol) | options))
        wall = time.perf_counter() - built
        compile_s = prob.compilation_time or 0.0
        stats = prob.solver_stats
        return Outcome(STATUS.get(prob.status, Status.FAILED), z.value,
                       iterations=stats.num_iters,
                       message="" if prob.status == "optimal" else f"cvxpy status {prob.status}",
                       objective=prob.value, setup_s=built - start + compile_s,
                       solve_s=wall - compile_s,
                       y=conic_duals(problem, prob.constraints) if z.value is not None
                       else None)

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
        found.append(Backend(name=name, family="cvxpy", distributions=("cvxpy", key),
                             extra=extra, accepts=accepts, solve=_solve_with(name),
                             tolerances=settings.TOLERANCES[key], **limits))
    return found
