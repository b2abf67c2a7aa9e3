"""The paper's method solved: its 34 x 34 system (``formulations.paper``) through the
solver registry, like every other solve.

``"hybr"`` is MINPACK's hybrid Powell method (``scipy-fsolve``, MATLAB's ``fsolve``
counterpart, the paper's solver), ``"lm"`` MINPACK's Levenberg-Marquardt
(``scipy-root-lm``). Each run returns a package-judged record; ``success`` is its
``"solved"`` status (the solver's own success with every residual within
``solvers.ACCEPT``). After a run the radial magnitudes are made nonnegative
(``PaperNLS.canonical``); with the rim that moves the end-face points, so the system is
solved again from the flipped point (see :func:`_solve`).
"""

from __future__ import annotations

import numpy as np
from cardan_forces.driveline.equilibrium import Operator
from cardan_forces.driveline.scene import Scene
from cardan_forces.formulations.paper import PaperNLS, build_paper
from cardan_forces.solvers import Record, solve

from cardan_forces.util.rank import numerical_rank

METHODS = {"hybr": "scipy-fsolve", "lm": "scipy-root-lm"}
"""The paper method's names for its root finders -> their registry backends."""

CONVERGED = 1e-8
"""``paper_residual`` below which a solve counts as converged."""


def _backend(method: str) -> str:
    if method not in METHODS:
        raise ValueError(f"unknown method {method!r}: use 'hybr' or 'lm'")
    return METHODS[method]


def _z(problem: PaperNLS, record: Record) -> np.ndarray:
    """The record's polar unknowns (NaN when the solver returned none)."""
    return np.full(problem.n, np.nan) if record.z is None else np.asarray(record.z, float)


def _solve(problem: PaperNLS, method: str, z0: np.ndarray,
           xtol: float | None) -> tuple[np.ndarray, Record, list[Record]]:
    """Solve, then make the radial magnitudes >= 0 (``(-f, a) -> (f, a + pi)``).

    Without the rim that changes no force. With it the end-face points move, so it
    solves again from the flipped point and keeps that answer when it is solved and
    converged with all magnitudes >= 0; otherwise it keeps the first answer as the
    solver gave it. Returns the kept ``z``, the record that found it and every run's
    record.
    """
    backend = _backend(method)
    first = solve(problem, backend, initvals=z0, tol=xtol)
    z, flipped = problem.canonical(_z(problem, first))
    if not (flipped and problem.rim):
        return z, first, [first]
    second = solve(problem, backend, initvals=z, tol=xtol)
    again, flipped = problem.canonical(_z(problem, second))
    if second.status == "solved" and not flipped and problem.paper_residual(again) < CONVERGED:
        return again, second, [first, second]
    return _z(problem, first), first, [first, second]


def _jacobian(problem: PaperNLS, z: np.ndarray) -> tuple[int, float]:
    """Numerical rank and condition of the 34 x 34 Jacobian at ``z`` (0, NaN off a
    finite point).
    """
    if not np.all(np.isfinite(z)):
        return 0, float("nan")
    s = np.linalg.svd(problem.jac(z), compute_uv=False)
    rank = numerical_rank(s)
    return rank, float(s[0] / s[-1]) if s[-1] > 0 else float("inf")


def solve_paper(op: Operator, i: int, method: str = "hybr", rim: bool = True,
                z0: np.ndarray | None = None, xtol: float | None = None,
                scene: Scene | None = None) -> dict:
    """Solve the paper's system at instant ``i`` (start: eqs. 63-74 unless ``z0``);
    the Jacobian's rank and condition at the answer show the direction the 34
    equations leave free (the closed loop's self-stress). ``iterations`` is the sum over
    the runs, ``None`` where the backend counts none (MINPACK reports function
    evaluations in ``message``).
    """
    _backend(method)
    problem = build_paper(op, i, rim=rim, scene=scene)
    z, record, runs = _solve(problem, method, problem.z0 if z0 is None else z0, xtol)
    counts = [run.iterations for run in runs]
    rank, cond = _jacobian(problem, z)
    return {
        "x": problem.to_forces(z),
        "z": z,
        "success": record.status == "solved",
        "message": record.message,
        "iterations": None if None in counts else sum(counts),
        "paper_residual": problem.paper_residual(z),
        "jac_rank": rank,
        "jac_cond": cond,
    }


def multistart(op: Operator, i: int, n: int = 20, seed: int = 0, rim: bool = True,
               scene: Scene | None = None) -> np.ndarray:
    """``fsolve`` from ``n`` seeded random starts around eqs. 63-74's; the converged
    forces (n_converged, len(checks.names)): the 36 Cartesian forces, then with the rim
    the end-face moments) sample the rigid model's solution set.
    """
    problem = build_paper(op, i, rim=rim, scene=scene)
    rng = np.random.default_rng(seed)
    top = np.abs(problem.z0).max()
    found = []
    for _ in range(n):
        z0 = problem.z0.copy()
        z0[problem.radial] *= np.exp(0.5 * rng.standard_normal(len(problem.radial)))
        z0[problem.angles] += rng.uniform(-0.5, 0.5, len(problem.angles))
        z0[problem.end_faces] = rng.uniform(0.0, 0.2 * top, len(problem.end_faces))
        z, record, _ = _solve(problem, "hybr", z0, None)
        if record.status == "solved" and problem.paper_residual(z) < CONVERGED:
            found.append(problem.to_forces(z))
    return np.array(found).reshape(-1, len(problem.checks.names))
