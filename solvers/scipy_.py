"""SciPy backends: ``scipy-lsq_linear``, ``scipy-highs``, ``scipy-fsolve``, ``scipy-root-lm``.

``scipy-lsq_linear`` is an *approximate* method: it cannot impose ``A z = b`` exactly,
so it solves the Tikhonov problem

    min ||A z - b||^2 + mu ||L' z + L^{-1} q||^2   s.t.  lb <= z <= ub,   P = L L',

whose answer tends to the QP's as ``mu -> 0``. ``mu = t * sigma_max(A L^{-T})^2`` with
``t = settings.tikhonov_weight(tol)``, so the bias is about ``t`` times the squared
condition number; the package's residual check reports it (``"inaccurate"`` above 1e-6).
It runs ``method="bvls"`` (exact active set for small dense problems): the default
``"trf"`` stops on a gradient norm that the penalty's conditioning makes meaningless.
The two MINPACK backends report function evaluations, not iterations (in ``message``),
and count as failed whenever ``F`` is not finite at the returned point.
"""

from __future__ import annotations

import time

import numpy as np
from cardan_forces.formulations.problems import LP, LS, NLS, QP

from cardan_forces.util.rank import numerical_rank

from . import settings
from .backend import Backend
from .conversions import qp_duals
from .record import Outcome, Status

EXTRAS: dict[str, str | None] = dict.fromkeys(
    ("scipy-lsq_linear", "scipy-highs", "scipy-fsolve", "scipy-root-lm")
)

LINPROG_STATUS = {0: Status.SOLVED, 1: Status.INACCURATE, 2: Status.INFEASIBLE,
                  3: Status.UNBOUNDED, 4: Status.FAILED}
"""``scipy.optimize.linprog`` status codes (1: iteration limit, 4: numerical trouble)."""


def _no_inequalities(problem) -> bool:
    return isinstance(problem, LS) or problem.G is None


def solve_lsq_linear(problem: LS | QP, tol=None, initvals=None, **options) -> Outcome:
    """Tikhonov-regularised bounded least squares (see the module docstring)."""
    from scipy.linalg import cholesky, solve_triangular
    from scipy.optimize import lsq_linear

    start = time.perf_counter()
    if isinstance(problem, LS):
        problem = problem.as_qp()
    n, P, q = problem.n, np.asarray(problem.P, float), np.asarray(problem.q, float)
    L = cholesky(P, lower=True)  # LinAlgError if P is not positive definite
    R, r = L.T, -solve_triangular(L, q, lower=True)
    message, mu = "exact (no equality rows)", 1.0
    if problem.A is not None:
        A, b = np.asarray(problem.A, float), np.asarray(problem.b, float)
        A_scaled = solve_triangular(L, A.T, lower=True).T
        mu = settings.tikhonov_weight(tol) * np.linalg.norm(A_scaled, 2) ** 2
        R, r = np.vstack([A, np.sqrt(mu) * R]), np.concatenate([b, np.sqrt(mu) * r])
        message = f"Tikhonov mu={mu:.1e}"
    lb = np.full(n, -np.inf) if problem.lb is None else problem.lb
    ub = np.full(n, np.inf) if problem.ub is None else problem.ub
    setup_done = time.perf_counter()
    kwargs = {"method": "bvls"} | settings.solver_options("lsq_linear", tol) | options
    res = lsq_linear(R, r, bounds=(lb, ub), **kwargs)
    status = (Status.SOLVED if res.status > 0
              else Status.INACCURATE if res.status == 0 else Status.FAILED)
    z = res.x
    solve_s = time.perf_counter() - setup_done
    return Outcome(status, z, iterations=int(res.nit), message=f"{message}; {res.message}",
                   objective=0.5 * z @ P @ z + q @ z,
                   y=_penalty_duals(problem, P, q, z, mu, res.active_mask),
                   setup_s=setup_done - start, solve_s=solve_s)


def _penalty_duals(problem: QP, P: np.ndarray, q: np.ndarray, z: np.ndarray, mu: float,
                   active: np.ndarray) -> np.ndarray:
    """The multipliers of the problem ``lsq_linear`` solved, in the rows of the QP's
    conic form: stationarity of the penalized objective over ``mu`` is ``P z + q + A'y
    + z_box = 0`` with ``y = (A z - b) / mu`` (the quadratic-penalty estimate, Nocedal
    and Wright, Numerical Optimization, 2nd ed., eq. 17.6) and ``z_box`` the rest of
    the gradient on the bounds BVLS holds active. They are that problem's own, up to
    the rounding of ``A z - b`` over ``mu`` (about ``eps / mu``: 1e-6 at tolerance 1e-10);
    the QP's measures show both, as its residuals show the penalty's bias. The checks
    need no multiplier recovery then (a least-squares solve per instant).
    """
    A = None if problem.A is None else np.asarray(problem.A, float)
    y = None if A is None else (A @ z - np.asarray(problem.b, float)) / mu
    gradient = P @ z + q + (0.0 if y is None else A.T @ y)
    z_box = np.where(active != 0, -gradient, 0.0)
    return qp_duals(problem, y, None, z_box)


def solve_highs(problem: LP, tol=None, initvals=None, **options) -> Outcome:
    """``linprog(method="highs")``; free variables unless ``lb``/``ub`` say otherwise."""
    from scipy.optimize import linprog

    start = time.perf_counter()
    n = problem.n
    lb = np.full(n, -np.inf) if problem.lb is None else problem.lb
    ub = np.full(n, np.inf) if problem.ub is None else problem.ub
    setup_done = time.perf_counter()
    res = linprog(problem.c, A_ub=problem.G, b_ub=problem.h, A_eq=problem.A, b_eq=problem.b,
                  bounds=np.column_stack([lb, ub]), method="highs",
                  options=settings.solver_options("highs", tol) | options)
    return Outcome(LINPROG_STATUS.get(res.status, Status.FAILED), res.x, iterations=int(res.nit),
                   message=res.message, objective=res.fun, y=_highs_duals(problem, res),
                   setup_s=setup_done - start, solve_s=time.perf_counter() - setup_done)


def _highs_duals(problem: LP, res) -> np.ndarray | None:
    """HiGHS's multipliers in the rows of the LP's conic form (``A z = b``, then ``G z
    <= h``, ``-z <= -lb``, ``z <= ub`` for the finite bounds; Clarabel's convention
    ``c + A'y = 0``): the marginals are the objective's derivatives by the right-hand
    sides, so ``y`` is minus them, and plus them for the lower bounds (``-z <= -lb``).
    ``None`` where HiGHS gives none (an unbounded or failed LP).
    """
    marginals = [getattr(getattr(res, part, None), "marginals", None)
                 for part in ("eqlin", "ineqlin", "lower", "upper")]
    if any(m is None for m in marginals) or res.x is None:
        return None
    eq, ineq, lower, upper = (np.asarray(m, float) for m in marginals)
    lb = np.full(problem.n, -np.inf) if problem.lb is None else np.asarray(problem.lb)
    ub = np.full(problem.n, np.inf) if problem.ub is None else np.asarray(problem.ub)
    parts = [-eq if problem.A is not None else [], -ineq if problem.G is not None else [],
             lower[np.isfinite(lb)] if problem.lb is not None else [],
             -upper[np.isfinite(ub)] if problem.ub is not None else []]
    return np.concatenate([np.asarray(p, float) for p in parts])


def _jacobian_note(problem: NLS, z: np.ndarray) -> str:
    """Numerical rank and condition of the Jacobian at the answer (after timing): a
    rank-deficient square system has no isolated root, so its answer is one of many.
    """
    if problem.jac is None or not np.all(np.isfinite(z)):
        return ""
    s = np.linalg.svd(problem.jac(z), compute_uv=False)
    if not np.all(np.isfinite(s)) or s[0] == 0:
        return ""
    rank = numerical_rank(s)
    cond = s[0] / s[-1] if s[-1] > 0 else float("inf")
    return f"; jacobian rank {rank} of {len(s)}, cond {cond:.1e}"


def solve_fsolve(problem: NLS, tol=None, initvals=None, **options) -> Outcome:
    """MINPACK hybrid Powell (``fsolve``) with the problem's Jacobian; ``ier == 1`` is success."""
    from scipy.optimize import fsolve

    z0 = problem.z0 if initvals is None else initvals
    start = time.perf_counter()
    options = settings.solver_options("fsolve", tol) | options
    z, info, ier, mesg = fsolve(problem.fun, np.asarray(z0, float), fprime=problem.jac,
                                full_output=True, **options)
    status = (Status.SOLVED if ier == 1 and np.all(np.isfinite(info["fvec"]))
              else Status.FAILED)
    solve_s = time.perf_counter() - start
    return Outcome(status, z, message=f"{mesg.strip()} (nfev {info['nfev']}, ier {ier})"
                   + _jacobian_note(problem, z), solve_s=solve_s)


def solve_root_lm(problem: NLS, tol=None, initvals=None, **options) -> Outcome:
    """MINPACK Levenberg-Marquardt (``root(method="lm")``) with the problem's Jacobian."""
    from scipy.optimize import root

    z0 = problem.z0 if initvals is None else initvals
    start = time.perf_counter()
    sol = root(problem.fun, np.asarray(z0, float), jac=problem.jac, method="lm",
               options=settings.solver_options("root-lm", tol) | options)
    if not (sol.success and np.all(np.isfinite(sol.fun))):
        status = Status.FAILED
    else:  # status 4: a stationary point of ||F||^2, not necessarily a root
        status = Status.INACCURATE if sol.status == 4 else Status.SOLVED
    solve_s = time.perf_counter() - start
    return Outcome(status, sol.x, message=f"{sol.message} (nfev {sol.nfev}, status {sol.status})"
                   + _jacobian_note(problem, sol.x), solve_s=solve_s)


def backends() -> list[Backend]:
    """The four SciPy backends (SciPy is a core dependency)."""
    try:
        import scipy.optimize  # noqa: F401
    except ImportError:
        return []
    common = {"family": "scipy", "distributions": ("scipy",)}
    return [
        Backend(name="scipy-lsq_linear", accepts=(LS, QP), solve=solve_lsq_linear, **common,
                supports=_no_inequalities, tolerances=settings.TOLERANCES["lsq_linear"]),
        Backend(name="scipy-highs", accepts=(LP,), solve=solve_highs, **common,
                tolerances=settings.TOLERANCES["highs"], smallest_tol=settings.SMALLEST["highs"]),
        Backend(name="scipy-fsolve", accepts=(NLS,), solve=solve_fsolve, **common,
                tolerances=settings.TOLERANCES["fsolve"], warm_start=True),
        Backend(name="scipy-root-lm", accepts=(NLS,), solve=solve_root_lm, **common,
                tolerances=settings.TOLERANCES["root-lm"], warm_start=True),
    ]
