"""Both accuracy views on the same solves, and qpbenchmark itself beside them.

``cardan bench --harness qpbenchmark`` runs each QP backend on exported problems at
qpbenchmark's four settings (:mod:`cardan_forces.solvers.settings`) and scores
every solve twice:

- **solver optimality** (:mod:`cardan_forces.solvers.judge`): qpbenchmark's
  absolute primal residual, dual residual and duality gap of the QP the solver
  received, with the solver's own ``found`` and multipliers; success as qpbenchmark's
  (found, and all three strictly below the setting's tolerance, :func:`succeeds`);
- **force accuracy** (the package's physics, ``ForceChecks.residuals``): equilibrium
  ``||Ax - b|| / ||b||``, pulling unilateral forces, end-face complementarity and cones,
  each relative to ``||b||``, and the distance to a reference answer where the optimum
  is unique, against :data:`FORCE_LEVEL`.

A QP solve here is qpbenchmark's own call (``qpsolvers.solve_problem`` on the problem
with the setting's options, timed around that call alone, sparse conversion outside
the timer), so its ``runtime_s`` is what qpbenchmark records; the force view is then the
package's :func:`~cardan_forces.solvers.judge.finalize` of that same answer.
:func:`run_qpbenchmark` runs qpbenchmark itself (its ``run`` and ``Results``) on the
exported test set, for its success and runtime tables.
"""

from __future__ import annotations

import contextlib
import importlib.util
import io
import logging
import math
import sys
import time
import warnings
from pathlib import Path

import numpy as np
from cardan_forces.formulations.problems import Conic
from cardan_forces.solvers import get, judge
from cardan_forces.solvers.conversions import convert
from cardan_forces.solvers.qpsolvers_ import conic_duals
from cardan_forces.solvers.record import ACCEPT, Outcome, Residuals, Status
from cardan_forces.solvers.registry import has_profile, profile, qpbenchmark_options, with_warnings
from cardan_forces.solvers.settings import SETTINGS, Setting

from . import progress
from .bench_metrics import SHIFT_S, shifted_geometric_mean
from .export import as_qp, class_name

FORCE_LEVEL = ACCEPT
"""Largest relative force residual of a force-accurate answer (the package's ``ACCEPT``)."""


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
    return "+".join(k for k in judge.MEASURES if not measures[k] < setting.tolerance)


def runtime_for_mean(found, runtime_s, setting: Setting):
    """The time-limit rule of qpbenchmark, elementwise: a run the solver reports as not found
    counts as the setting's time limit in the shifted geometric mean (a found run counts
    its time, whatever its accuracy).
    """
    return np.where(np.asarray(found, bool), np.asarray(runtime_s, float), setting.time_limit_s)


def qpsolvers_problem(qp, solver: str):
    """The qpsolvers problem of a package ``QP``, sparse for a sparse-only solver (as
    qpbenchmark's ``time_solve_problem`` converts it, outside the timer).
    """
    import qpsolvers

    problem = qpsolvers.Problem(*(None if (v := getattr(qp, k)) is None else np.asarray(v, float)
                                  for k in ("P", "q", "G", "h", "A", "b", "lb", "ub")))
    if solver in qpsolvers.sparse_solvers and solver not in qpsolvers.dense_solvers:
        import scipy.sparse as spa

        problem = qpsolvers.Problem(*(spa.csc_matrix(v) if k in "PGA" and v is not None else v
                                      for k, v in zip("PqGhAbLU", problem.unpack())))
    return problem


def solve_both(problem, backend: str, setting: str, reference=None) -> dict:
    """One solve of ``problem`` (LS or QP) by qpsolvers backend ``backend`` at
    qpbenchmark setting ``setting``, scored in both views: one row.
    """
    import qpsolvers

    began = time.perf_counter()
    qp = as_qp(problem)
    solver = profile(backend).solver
    data = qpsolvers_problem(qp, solver)
    options = qpbenchmark_options(backend, setting)
    with warnings.catch_warnings(record=True) as caught:  # kept with the row
        warnings.simplefilter("always")
        start = time.perf_counter()
        try:
            sol = qpsolvers.solve_problem(data, solver=solver, **options)
        except Exception as exc:  # as qpbenchmark: an exception is a solution not found
            sol, message = qpsolvers.Solution(data), f"{type(exc).__name__}: {exc}"
        else:
            message = ""
        runtime = time.perf_counter() - start
    message = with_warnings(message, caught)
    found = bool(sol.found)
    measured = judge.qp_residuals(qp, found, sol.x, sol.y, sol.z, sol.z_box)
    duals = conic_duals(qp, sol) if sol.x is not None else None
    status = "solved" if found else ("inaccurate" if sol.x is not None else "failed")
    record = judge.finalize(problem, backend, Outcome(status, sol.x, message=message,
                                                solve_s=runtime, y=duals), reference=reference)
    solver_s = runtime if sol.solve_time is None else float(sol.solve_time)
    return _row(problem, backend, setting, found, measured, record, runtime, solver_s, began)


def solve_conic_both(problem, backend: str, setting: str, reference=None) -> dict:
    """One solve of a conic ``problem`` by backend ``backend`` (Clarabel's own API) at
    qpbenchmark setting ``setting``: solver optimality is the conic analogue (absolute
    KKT residuals of the standard form, :func:`~cardan_forces.solvers.judge.
    solver_optimality`), ``found`` the solver's own ``Solved``; one row.
    """
    began = time.perf_counter()
    received = convert(problem, (Conic,))
    try:
        outcome = get(backend).solve(received, **qpbenchmark_options(backend, setting))
    except Exception as exc:  # a failing solver is a solve not found
        outcome = Outcome("failed", None, message=f"{type(exc).__name__}: {exc}")
    found = outcome.status == "solved"
    measured = (judge.solver_optimality(received, outcome.z, outcome.y) if found
                else dict.fromkeys(judge.MEASURES, math.inf))
    record = judge.finalize(problem, backend, outcome, reference=reference)
    return _row(problem, backend, setting, found, measured, record,
                outcome.setup_s + outcome.solve_s, outcome.solve_s, began)


def _row(problem, backend, setting, found, measured, record, runtime, solver_s,
         began) -> dict:
    """One harness row: both views of a solve, its rules, its three times and the
    record's message (the solver's notes and warnings).
    """
    force = {k: float(record.residuals[k]) for k in Residuals.KEYS}
    if record.residuals.reference is not None and judge.unique_optimum(problem):
        force["distance"] = float(record.residuals.reference)
    chosen = SETTINGS[setting]
    return {
        "formulation": problem.formulation, "solver": backend, "setting": setting,
        "found": found, **measured, "solver_ok": bool(succeeds(found, *measured.values(),
                                                                  chosen)),
        "solver_rule": failed_rule(found, measured, chosen), **force,
        "force_ok": record.status.has_answer
                    and all(v <= FORCE_LEVEL for v in force.values()),
        "force_rule": force_rule(record.status, force),
        "runtime_s": runtime, "solver_s": solver_s,
        "end_to_end_s": time.perf_counter() - began, "message": record.message,
    }


def force_rule(status: str, force: dict[str, float]) -> str:
    """Which force check an answer fails at :data:`FORCE_LEVEL` (``""``: none): ``"no
    answer"`` or the residuals (and the distance, where measured) above the level,
    joined by ``+``.
    """
    if not Status(status).has_answer:
        return "no answer"
    return "+".join(k for k, v in force.items() if not v <= FORCE_LEVEL)


def backends_with_profiles(available) -> list[str]:
    """The qpsolvers backends among ``available`` that declare qpbenchmark's settings."""
    return [b for b in available if get(b).family == "qpsolvers"
            and has_profile(b)]


def conic_backends(available) -> list[str]:
    """The backends among ``available`` that take a conic problem per instant and
    declare qpbenchmark's settings (Clarabel's own API).
    """
    return [b for b in available if get(b).family != "qpsolvers" and get(b).solve is not None
            and Conic in get(b).accepts and has_profile(b)]


def run_package(problems: dict[str, object], backends, settings=tuple(SETTINGS),
                references=None):
    """Rows of :func:`solve_both` for every QP problem x qpsolvers backend x setting,
    and of :func:`solve_conic_both` for every conic problem x conic backend among
    ``backends`` x setting (with the problem's name in ``problem``); ``references``
    maps a problem's name to reference forces (the force view's distance, where the
    optimum is unique).
    """
    rows = []
    for name, problem in problems.items():
        if as_qp(problem) is not None:
            runs = [(solve_both, b) for b in backends_with_profiles(backends)]
        elif convert(problem, (Conic,)) is not None:
            runs = [(solve_conic_both, b) for b in conic_backends(backends)]
        else:
            runs = []
        for solve, backend in runs:
            for setting in settings:
                rows.append({"problem": name} | solve(problem, backend, setting,
                                                      (references or {}).get(name)))
    return rows


def package_tables(rows: list[dict]) -> list[dict]:
    """Per solver x setting: solver-optimality success % (qpbenchmark's rule), the
    failing rules counted, force-accuracy success % and its causes, and the shifted
    geometric mean runtime with qpbenchmark's shift and time-limit rule.
    """
    out = []
    keys = dict.fromkeys((r["solver"], r["setting"]) for r in rows)
    for solver, setting in keys:
        mine = [r for r in rows if (r["solver"], r["setting"]) == (solver, setting)]
        chosen = SETTINGS[setting]
        times = runtime_for_mean([r["found"] for r in mine], [r["runtime_s"] for r in mine],
                                    chosen)
        out.append({
            "solver": solver, "setting": setting, "problems": len(mine),
            "solver_success": 100.0 * np.mean([r["solver_ok"] for r in mine]),
            "solver_failures": _count(r["solver_rule"] for r in mine),
            "force_success": 100.0 * np.mean([r["force_ok"] for r in mine]),
            "force_failures": _count(r["force_rule"] for r in mine),
            "runtime_sgm_s": shifted_geometric_mean(times),
        })
    return out


def _count(rules) -> str:
    """``"rule: count, ..."`` of the non-empty rules, most frequent first."""
    counts: dict[str, int] = {}
    for rule in rules:
        if rule:
            counts[rule] = counts.get(rule, 0) + 1
    return ", ".join(f"{k}: {v}" for k, v in sorted(counts.items(), key=lambda kv: -kv[1]))


def load_test_set(path: Path):
    """The test set of an exported module (loaded from its file, not from ``sys.path``)."""
    spec = importlib.util.spec_from_file_location(f"_exported_{path.stem}", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return getattr(module, class_name(path.stem))()


@contextlib.contextmanager
def _their_output():
    """The output of qpbenchmark held to the package's rules while it runs: its progress
    bars (tqdm on ``sys.stderr``) only where the package's are drawn
    (:func:`.progress.shown`), its log lines (info on the root logger, which its import
    sets to INFO with a handler of its own on the real stderr) none with ``--quiet``;
    warnings and errors still shown. The root logger's level is restored after, so
    other libraries' info lines do not follow.
    """
    root = logging.getLogger()
    level = root.level
    import qpbenchmark  # noqa: F401 - its import sets the root logger up

    try:
        root.setLevel(logging.WARNING if progress.quiet() else logging.INFO)
        with contextlib.redirect_stderr(sys.stderr if progress.shown() else io.StringIO()):
            yield
    finally:
        root.setLevel(level)


def run_qpbenchmark(path: Path, solvers, results: Path) -> list[dict]:
    """Run qpbenchmark itself on the test set at ``path`` for ``solvers`` (qpsolvers names):
    per solver x setting its success % and its runtime shifted-geometric-mean ratio to
    the best solver (its ``Results.build_success_rate_df`` and ``build_shgeom_df``).
    """
    with _their_output():
        import qpbenchmark

        test_set = load_test_set(path)
        found = qpbenchmark.Results(results, test_set)
        for solver in solvers:
            if solver in test_set.solvers:
                qpbenchmark.run(test_set, found, only_solver=solver)
    tol = test_set.tolerances
    success = found.build_success_rate_df({k: t.primal for k, t in tol.items()},
                                          {k: t.dual for k, t in tol.items()},
                                          {k: t.gap for k, t in tol.items()})
    runtime = found.build_shgeom_df("runtime", SHIFT_S,
                                    {k: t.runtime for k, t in tol.items()})
    return [{"solver": f"qpsolvers-{solver}", "setting": setting,
             "success": float(success.at[solver, setting]),
             "runtime_ratio": float(runtime.at[solver, setting])}
            for solver in success.index for setting in success.columns]


def side_by_side(package: list[dict], qpbench: list[dict]) -> list[dict]:
    """Package tables joined with qpbenchmark's on solver x setting, with the package's
    runtime ratio to the best solver of the setting (as qpbenchmark's).
    """
    theirs = {(r["solver"], r["setting"]): r for r in qpbench}
    best = {}
    for r in package:
        best[r["setting"]] = min(best.get(r["setting"], math.inf), r["runtime_sgm_s"])
    return [r | {"runtime_ratio": r["runtime_sgm_s"] / best[r["setting"]],
                 "qpbenchmark_success": theirs.get((r["solver"], r["setting"]), {}).get(
                     "success", math.nan),
                 "qpbenchmark_runtime_ratio": theirs.get((r["solver"], r["setting"]), {}).get(
                     "runtime_ratio", math.nan)}
            for r in package]
