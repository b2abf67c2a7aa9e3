"""Metrics of ``cardan bench``: throughput summary, success per accuracy level, Pareto
fronts, Dolan-Moré performance profiles, shifted geometric means and the targets.

Accuracy is optimality measured from the problem data (:mod:`cardan_forces.solvers.
optimality`): a row succeeds at level ``eps`` when it has an answer and every measure
it has — primal residual, dual residual, duality (or objective) gap, and the distance to
the reference only where the optimum is unique — is at most ``eps``.
"""

from __future__ import annotations

import math

import numpy as np
from cardan_forces.solvers import Status

from .bench_run import MEASURES, SPLIT

SHIFT_S = 1e-4
"""Shift of the geometric mean of times per instant: about the fastest per-instant
solve, so timer noise below it is damped while differences above it are kept."""

PROFILES = (("default", None, 1e-6), ("high", "smallest", 1e-8))
"""Performance profiles: (name, requested tolerance, accuracy level). ``default``: every
backend at its own defaults, judged at 1e-6; ``high``: at the smallest tolerance of the
ladder, judged at 1e-8."""

TAUS = np.logspace(0.0, 3.0, 61)
"""The profile's abscissa: time ratio to the fastest successful backend, 1 to 1000."""

FAILURE_FACTOR = 10.0
"""A failed instant counts in the shifted geometric mean as this many times the
slowest successful time of its formulation and level (qpbenchmark's time-limit rule)."""

TARGET_RATES = {"min_norm": 1e5, "positive": 1e5}
"""Instants per second wanted from the batched runs of these formulations."""
PAPER_RATIO = 10.0
"""Wanted speed-up of every conic formulation's best run over the paper's method."""
GLUE_SHARE = 0.25
"""Largest share of a per-instant conic solve spent outside the solver."""
MIN_MAX_LEVEL, MIN_MAX_SUCCESS = 1e-6, 0.9
WALL_S = 180.0
"""Wanted wall time of the full benchmark."""


def shifted_geometric_mean(values, shift: float = SHIFT_S) -> float:
    """``exp(mean(log(v + shift))) - shift``; ``nan`` for no values."""
    v = np.asarray(values, float)
    return float(np.exp(np.mean(np.log(v + shift))) - shift) if v.size else math.nan


def within(row: dict, level: float) -> bool:
    """An answer whose every measure (NaN: the row has none of it) is <= ``level``."""
    if not Status(row["status"]).has_answer:
        return False
    return all(not (row[k] > level) for k in MEASURES)  # NaN compares False: absent


def worst_measure(row: dict) -> float:
    """The largest optimality measure a row has (``inf`` without an answer)."""
    if not Status(row["status"]).has_answer:
        return math.inf
    return max((row[k] for k in MEASURES if not math.isnan(row[k])), default=math.inf)


def groups(rows: list[dict], keys: tuple[str, ...]) -> dict[tuple, list[dict]]:
    """Rows grouped by the values of ``keys``, in first-seen order."""
    out: dict[tuple, list[dict]] = {}
    for r in rows:
        out.setdefault(tuple(r[k] for k in keys), []).append(r)
    return out


def summarize(rows: list[dict], setup: dict[str, float]) -> list[dict]:
    """Per formulation x backend x mode: instants, rate, shifted geometric mean time,
    success rate (status ``solved``), worst equilibrium residual (all / solved
    instants), mean time split and the solver's share, first message not solved.
    ``setup``: one-time build per formulation (s).
    """
    out = []
    for (formulation, solver, mode), group in groups(rows, ("formulation", "solver",
                                                             "mode")).items():
        times = [r["time_s"] for r in group]
        unsolved = [r["message"] for r in group if r["status"] != "solved"]
        split = {k: float(np.mean([r[k] for r in group])) for k in (*SPLIT, "time_s")}
        split["other_s"] = max(split["time_s"] - sum(split[k] for k in SPLIT), 0.0)
        out.append({
            "formulation": formulation, "solver": solver, "mode": mode,
            "instants": len(group), "instants_per_s": len(group) / max(sum(times), 1e-12),
            "sgm_s": shifted_geometric_mean(times), "setup_s": setup.get(formulation, 0.0),
            "success_rate": 1.0 - len(unsolved) / len(group),
            "max_equilibrium": max(r["equilibrium"] for r in group),
            "solved_equilibrium": max((r["equilibrium"] for r in group
                                       if r["status"] == "solved"), default=math.inf),
            "split_s": split,
            "solver_share": split["solve_s"] / max(split["time_s"], 1e-12),
            "note": next((m for m in unsolved if m), ""),
        })
    return out


def pareto(rows: list[dict]) -> list[dict]:
    """Per formulation x backend x tolerance: time (shifted geometric mean), worst and
    median of the worst measure per instant; ``front`` marks the points no other point
    of the formulation beats in both time and worst measure.
    """
    points = []
    for (formulation, solver, tol), group in groups(rows, ("formulation", "solver",
                                                           "tol")).items():
        errors = [worst_measure(r) for r in group]
        points.append({
            "formulation": formulation, "solver": solver, "tol": tol,
            "instants": len(group),
            "time_s": shifted_geometric_mean([r["time_s"] for r in group]),
            "error": max(errors), "error_median": float(np.median(errors)),
            "equilibrium": max(r["equilibrium"] for r in group),
        })
    for formulation in {p["formulation"] for p in points}:
        best = math.inf
        mine = [p for p in points if p["formulation"] == formulation]
        for p in sorted(mine, key=lambda p: (p["time_s"], p["error"])):
            p["front"] = math.isfinite(p["error"]) and p["error"] < best
            best = min(best, p["error"]) if p["front"] else best
    return points


def _at(group: list[dict], tol) -> list[dict]:
    """The rows of one backend's run at ``tol``, or its default run if it has no such."""
    mine = [r for r in group if r["tol"] == tol]
    return mine or [r for r in group if r["tol"] == "default"]


def success(rows: list[dict], ladder) -> list[dict]:
    """Rows ``{formulation, solver, level, rate, tol}``: per level of the ladder, the
    share of instants within it in the backend's best run (its defaults or any
    tolerance of the ladder; ``tol`` says which): whether the backend reaches that
    accuracy at all, and how often.
    """
    out = []
    for (formulation, solver), group in groups(rows, ("formulation", "solver")).items():
        runs = groups(group, ("tol",))
        for level in ladder:
            rates = {tol: float(np.mean([within(r, level) for r in run]))
                     for (tol,), run in runs.items()}
            best = max(rates, key=rates.get)
            out.append({"formulation": formulation, "solver": solver, "level": level,
                        "rate": rates[best], "tol": best})
    return out


def profiles(rows: list[dict], ladder) -> list[dict]:
    """Dolan-Moré performance profiles and shifted geometric mean ratios, per
    formulation x profile of :data:`PROFILES` x backend.

    On each instant a backend's time counts when it succeeds at the profile's level;
    ``curve[j]`` is the share of instants it solves within ``TAUS[j]`` times the fastest
    successful backend. ``sgm_ratio`` is its shifted geometric mean time (failures at
    :data:`FAILURE_FACTOR` times the slowest success) over the best backend's.
    """
    out = []
    for formulation, group in groups(rows, ("formulation",)).items():
        for name, tol, level in PROFILES:
            tol = min(ladder) if tol == "smallest" else ("default" if tol is None else tol)
            per_solver = {s: {r["instant"]: r for r in _at(g, tol)}
                          for (s,), g in groups(group, ("solver",)).items()}
            out += _profile(formulation[0], name, level, per_solver)
    return out


def _profile(formulation: str, name: str, level: float, per_solver: dict) -> list[dict]:
    instants = sorted({i for runs in per_solver.values() for i in runs})
    solvers = list(per_solver)
    times = np.full((len(solvers), len(instants)), np.inf)
    for a, s in enumerate(solvers):
        for b, i in enumerate(instants):
            row = per_solver[s].get(i)
            if row is not None and within(row, level):
                times[a, b] = row["time_s"]
    best = times.min(axis=0, initial=np.inf)
    with np.errstate(invalid="ignore", divide="ignore"):
        ratio = np.where(np.isfinite(times), times / best, np.inf)
    finite = times[np.isfinite(times)]
    penalty = FAILURE_FACTOR * (finite.max() if finite.size else 1.0)
    sgm = [shifted_geometric_mean(np.where(np.isfinite(t), t, penalty)) for t in times]
    top = min(sgm, default=math.nan)
    return [{"formulation": formulation, "profile": name, "level": level, "solver": s,
             "solved": float(np.mean(np.isfinite(times[a]))) if instants else 0.0,
             "sgm_s": sgm[a], "sgm_ratio": sgm[a] / top if top > 0 else math.nan,
             "curve": [float(np.mean(ratio[a] <= tau)) for tau in TAUS]}
            for a, s in enumerate(solvers)]


def best_runs(summary: list[dict]) -> dict[str, dict]:
    """Per formulation, its fastest run that solved every instant of all of them."""
    out = {}
    for e in summary:
        if e["success_rate"] == 1.0 and e["instants"] == max(
                x["instants"] for x in summary if x["formulation"] == e["formulation"]):
            if e["instants_per_s"] > out.get(e["formulation"], {}).get("instants_per_s", 0):
                out[e["formulation"]] = e
    return out


def targets(summary: list[dict], success_rows: list[dict], conic: set[str],
            wall_s: float | None) -> list[dict]:
    """The targets measured in this run: ``{name, value, wanted, met, detail}`` rows.

    The paper's fair baseline is its fastest run (warm-started, analytic Jacobian);
    ``conic`` names the formulations whose problem is conic; ``min_max``'s success is
    its best backend's best run at level :data:`MIN_MAX_LEVEL` (``success_rows`` must
    hold that level).
    """
    best = best_runs(summary)
    paper = max((e for e in summary if e["formulation"] == "paper"),
                key=lambda e: e["instants_per_s"], default=None)
    out = []
    for name, wanted in TARGET_RATES.items():
        runs = [e for e in summary if e["formulation"] == name and e["mode"] == "batched"]
        run = max(runs, key=lambda e: e["instants_per_s"], default=None)
        out.append(_target(f"{name} batched instants/s", run and run["instants_per_s"],
                           wanted, run and f"{run['solver']}, solved "
                           f"{100 * run['success_rate']:.1f}%"))
    for name in sorted(conic):
        run = best.get(name)
        ratio = run and paper and run["instants_per_s"] / paper["instants_per_s"]
        out.append(_target(f"{name} best run / paper", ratio, PAPER_RATIO,
                           run and f"{run['solver']} {run['mode']}"))
        cold = [e for e in summary if e["formulation"] == name and e["mode"] == "cold"
                and e["solver"] == "clarabel"]
        if cold:
            glue = 1.0 - cold[0]["solver_share"]
            out.append(_target(f"{name} glue share (clarabel per instant)", glue, GLUE_SHARE,
                               "build + conversion + checks + dispatch", below=True))
    mine = [r for r in success_rows if r["formulation"] == "min_max"
            and r["level"] == MIN_MAX_LEVEL]
    top = max(mine, key=lambda r: r["rate"], default=None)
    out.append(_target(f"min_max success at {MIN_MAX_LEVEL:g} (best backend)",
                       None if top is None else top["rate"], MIN_MAX_SUCCESS,
                       None if top is None else f"{top['solver']} at tol {top['tol']}"))
    out.append(_target("wall time of the run (s)", wall_s, WALL_S, None, below=True))
    return out


def _target(name, value, wanted, detail, below=False) -> dict:
    met = None if value is None else (value <= wanted if below else value >= wanted)
    return {"name": name, "value": value, "wanted": wanted, "met": met,
            "detail": detail or ""}
