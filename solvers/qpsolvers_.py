"""Backends ``qpsolvers-<name>``: every QP solver that qpsolvers finds installed.

Matrices go dense to solvers that take dense input, CSC to the others. qpsolvers only
says ``found``; when it fails, the solver's own status (in ``extras``) tells infeasible
from unbounded where the solver reports it. ``setup_s`` includes qpsolvers' build time.
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np
from cardan_forces.formulations.problems import QP

from . import settings
from .backend import Backend
from .ranging import HAVE_HIGHSPY, without_banner
from .record import Outcome, Status

DISTRIBUTIONS: dict[str, str] = {
    "clarabel": "clarabel", "daqp": "daqp", "ecos": "ecos", "highs": "highspy", "osqp": "osqp",
    "piqp": "piqp", "proxqp": "proxsuite", "quadprog": "quadprog", "scs": "scs",
}
"""The distribution behind each qpsolvers solver name we know."""

CORE = ("clarabel", "osqp")
"""Solvers installed with the package itself; the others have an extra of their name."""

EXTRAS: dict[str, str | None] = {
    f"qpsolvers-{name}": None if name in CORE else name for name in DISTRIBUTIONS
}

WARM_STARTS = ("osqp", "proxqp", "scs")
"""Solvers to which qpsolvers passes ``initvals``."""

BOUNDS_AS_ROWS = ("ecos",)
"""Solvers that reject infinite bounds; their finite bounds are passed as rows of G."""

SCS_STATUS = {2: Status.INACCURATE, -1: Status.UNBOUNDED, -2: Status.INFEASIBLE,
              -6: Status.UNBOUNDED, -7: Status.INFEASIBLE}
ECOS_STATUS = {10: Status.INACCURATE, -1: Status.INACCURATE, 1: Status.INFEASIBLE,
               2: Status.UNBOUNDED, 11: Status.INFEASIBLE, 12: Status.UNBOUNDED}


def _unfound_status(solver: str, extras: dict) -> tuple[Status, str]:
    """Our status for a run qpsolvers did not call found, from the solver's own status.

    Infeasibility and unboundedness certificates are kept; "inaccurate" and iteration
    limits become ``INACCURATE`` (the package then checks the iterate); else ``FAILED``.
    """
    if solver == "scs":
        code = extras.get("status_val")
        return SCS_STATUS.get(code, Status.FAILED), f"SCS status {code}"
    if solver == "ecos":
        code = extras.get("exitFlag")
        return ECOS_STATUS.get(code, Status.FAILED), f"ECOS exit flag {code}"
    info = extras.get("info")
    text = str(getattr(info, "status", extras.get("status", "")))
    key = text.lower().replace("_", "").replace(" ", "")
    if "dualinfeasible" in key or "unbounded" in key:
        return Status.UNBOUNDED, text
    if "infeasible" in key:
        return Status.INFEASIBLE, text
    if "inaccurate" in key or "almost" in key or ("max" in key and "iter" in key):
        return Status.INACCURATE, text
    return Status.FAILED, text or "no solution found"


def _iterations(extras: dict) -> int | None:
    info = extras.get("info")
    count = getattr(info, "iter", extras.get("iter"))
    return None if count is None else int(count)


def bounds_as_rows(problem: QP) -> QP:
    """The same QP with its finite bounds as rows of ``G`` and no ``lb``/``ub``."""
    n = problem.n
    rows = [] if problem.G is None else [np.asarray(problem.G, float)]
    rhs = [] if problem.h is None else [np.asarray(problem.h, float)]
    for bound, sign in ((problem.lb, -1.0), (problem.ub, 1.0)):
        if bound is not None:
            keep = np.isfinite(bound)
            rows.append(sign * np.eye(n)[keep])
            rhs.append(sign * np.asarray(bound, float)[keep])
    G, h = (np.vstack(rows), np.concatenate(rhs)) if sum(len(r) for r in rhs) else (None, None)
    return dataclasses.replace(problem, G=G, h=h, lb=None, ub=None)


def conic_duals(problem: QP, sol) -> np.ndarray | None:
    """Qpsolvers' multipliers (``P z + q + A'y + G'z + z_box = 0``) in the rows of
    ``problem.as_conic()``: equalities, ``G``, finite lower bounds, finite upper bounds
    (a lower bound's multiplier is ``-z_box``, an upper bound's ``z_box``). ``None`` when
    the solver reported some of them not.
    """
    parts = []
    for rows, duals in ((problem.A, sol.y), (problem.G, sol.z)):
        if rows is not None:
            if duals is None or len(duals) != len(rows):
                return None
            parts.append(np.asarray(duals, float))
    for bound, sign in ((problem.lb, -1.0), (problem.ub, 1.0)):
        if bound is not None:
            if sol.z_box is None:
                return None
            keep = np.isfinite(bound)
            parts.append(np.maximum(sign * np.asarray(sol.z_box, float)[keep], 0.0))
    return np.concatenate(parts) if parts else np.zeros(0)


def _solve_with(solver: str):
    """The adapter function for one qpsolvers solver."""

    def solve_qp(problem: QP, tol=None, initvals=None, **options) -> Outcome:
        import qpsolvers
        import scipy.sparse as spa

        if solver == "highs" and HAVE_HIGHSPY:
            without_banner()  # qpsolvers makes highspy solvers: the banner's first one
        start = time.perf_counter()
        if solver in BOUNDS_AS_ROWS:
            problem = bounds_as_rows(problem)
        matrix = np.asarray if solver in qpsolvers.dense_solvers else spa.csc_matrix

        def mat(m):
            return None if m is None else matrix(np.asarray(m, float))

        def vec(v):
            return None if v is None else np.asarray(v, float)

        P, q = np.asarray(problem.P, float), vec(problem.q)
        qp = qpsolvers.Problem(mat(P), q, mat(problem.G), vec(problem.h), mat(problem.A),
                               vec(problem.b), vec(problem.lb), vec(problem.ub))
        kwargs = settings.solver_options(solver, tol) | settings.time_limit(solver)
        if solver == "osqp":
            kwargs["raise_error"] = False  # today's behaviour, without osqp's FutureWarning
        setup_done = time.perf_counter()
        sol = qpsolvers.solve_problem(qp, solver=solver, initvals=initvals, **(kwargs | options))
        wall = time.perf_counter() - setup_done
        build = sol.build_time or 0.0
        solve_s = wall - build if sol.solve_time is None else sol.solve_time
        extras = sol.extras or {}
        status, text = (Status.SOLVED, "") if sol.found else _unfound_status(solver, extras)
        if not sol.found and solver in settings.TIME_LIMITED and wall >= settings.TIME_LIMIT_S:
            text = f"{text}; time limit of {settings.TIME_LIMIT_S:g} s reached"
        z = sol.x
        objective = None if z is None else 0.5 * z @ P @ z + q @ z
        return Outcome(status, z, iterations=_iterations(extras), message=text,
                       objective=objective, setup_s=setup_done - start + build, solve_s=solve_s,
                       y=conic_duals(problem, sol))

    return solve_qp


def backends() -> list[Backend]:
    """One backend per solver in ``qpsolvers.available_solvers``."""
    try:
        import qpsolvers
    except ImportError:
        return []
    return [
        Backend(name=f"qpsolvers-{name}", family="qpsolvers",
                distributions=("qpsolvers", DISTRIBUTIONS.get(name, name)),
                extra=EXTRAS.get(f"qpsolvers-{name}"), accepts=(QP,), solve=_solve_with(name),
                tolerances=settings.TOLERANCES.get(name, ()),
                smallest_tol=settings.SMALLEST.get(name, 0.0), warm_start=name in WARM_STARTS,
                qpbenchmark=settings.PROFILES.get(name))
        for name in qpsolvers.available_solvers
    ]
