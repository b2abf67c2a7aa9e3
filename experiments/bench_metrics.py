"""Metrics of ``cardan bench``: throughput summary, success per accuracy level, Pareto
fronts, Dolan-Moré performance profiles, shifted geometric means, overhead: the
measurements the bench reports (what a developer's check wants of them is
:mod:`.bench_targets`).

The ladder's accuracy is the package's own view (relative measures,
:mod:`cardan_forces.solvers.judge`; not qpbenchmark's absolute ones, which the judge
also gives): a row succeeds at level ``eps`` when it has
an answer and every measure it has — primal (the worst force residual relative to
``||b||``), dual residual relative to the stationarity terms, duality (or objective)
gap relative to the objective, and the distance to the reference only where the
optimum is unique — is at most ``eps``.

Times: every row carries the solver's own time (``solve_s``, the backend call alone)
and the end-to-end time of the package's ``solve`` (``time_s``). Profiles and shifted
geometric means use the solver's time by default (:data:`CLOCKS`), with qpbenchmark's
shift (10 s) and its time-limit rule as far as a row tells it: a row without an answer
counts as the time limit (qpbenchmark: a run its solver reports as not found).
"""

from __future__ import annotations

import math

import numpy as np
from cardan_forces.solvers import Status
from cardan_forces.solvers.settings import SETTINGS

from .bench_run import MEASURES, SPLIT, TIME_FLOOR_S

SHIFT_S = 10.0
"""qpbenchmark's shift of the shifted geometric mean of runtimes (``sh = 10``)."""

CLOCKS = {"solver": "solve_s", "end_to_end": "time_s"}
"""The two times of a row: the solver's own call, and the package's whole ``solve``;
profiles are computed on both, ``solver`` first (the default view)."""

TIME_LIMIT_S = SETTINGS["default"].time_limit_s
"""qpbenchmark's time limit per solve (every setting's), at which a row without an
answer counts in a shifted geometric mean."""

PROFILES = (("default", None, SETTINGS["default"].tolerance), ("high", "smallest", 1e-8))
"""Performance profiles: (name, requested tolerance, accuracy level). ``default``: every
backend at its own defaults, judged by the tolerance of qpbenchmark's ``default``
setting (1: a solver's defaults are not asked for an accuracy they were not set to);
``high``: at the smallest tolerance of the ladder, judged at 1e-8."""

TAUS = np.logspace(0.0, 3.0, 61)
"""The profile's abscissa: time ratio to the fastest successful backend, 1 to 1000."""


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
    """Per formulation x backend x mode: instants, rate, shifted geometric mean of the
    solver's time (``sgm_s``) and of the end-to-end time, success rate (status
    ``solved``), worst equilibrium residual (all / solved instants), mean time split
    and the solver's share, mean iterations per instant, first message not solved.
    ``setup``: one-time build per formulation (s).
    """
    out = []
    for (formulation, solver, mode), group in groups(rows, ("formulation", "solver",
                                                             "mode")).items():
        times = [r["time_s"] for r in group]
        solver_times = [r["solve_s"] for r in group]
        unsolved = [r["message"] for r in group if r["status"] != "solved"]
        split = {k: float(np.mean([r[k] for r in group]))
                 for k in (*SPLIT, "time_s", "checks_first_s")}
        split["other_s"] = max(split["time_s"] - sum(split[k] for k in SPLIT), 0.0)
        out.append({
            "formulation": formulation, "solver": solver, "mode": mode,
            "instants": len(group), "instants_per_s": len(group) / max(sum(times), TIME_FLOOR_S),
            "sgm_s": shifted_geometric_mean(solver_times),
            "sgm_end_to_end_s": shifted_geometric_mean(times),
            "setup_s": setup.get(formulation, 0.0),
            "success_rate": 1.0 - len(unsolved) / len(group),
            "max_equilibrium": max(r["equilibrium"] for r in group),
            "solved_equilibrium": max((r["equilibrium"] for r in group
                                       if r["status"] == "solved"), default=math.inf),
            "split_s": split,
            "solver_share": split["solve_s"] / max(split["time_s"], TIME_FLOOR_S),
            "iterations": _mean_iterations(group),
            "note": next((m for m in unsolved if m), ""),
        })
    return out


def _mean_iterations(group: list[dict]) -> float | None:
    """The solver's iterations per instant, averaged over the instants that report a
    count (``None`` where none does).
    """
    counts = [r["iterations"] for r in group if r.get("iterations") is not None]
    return float(np.mean(counts)) if counts else None


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
    formulation x profile of :data:`PROFILES` x clock of :data:`CLOCKS` x backend.

    On each instant a backend's time counts in the curve when it succeeds at the
    profile's level; ``curve[j]`` is the share of instants it solves within ``TAUS[j]``
    times the fastest successful backend. ``sgm_ratio`` is its shifted geometric mean
    time (shift :data:`SHIFT_S`; a row without an answer at :data:`TIME_LIMIT_S`, an
    answer at its time whatever its accuracy, as qpbenchmark) over the best backend's.
    """
    out = []
    for formulation, group in groups(rows, ("formulation",)).items():
        for name, tol, level in PROFILES:
            tol = min(ladder) if tol == "smallest" else ("default" if tol is None else tol)
            per_solver = {s: {r["instant"]: r for r in _at(g, tol)}
                          for (s,), g in groups(group, ("solver",)).items()}
            for clock in CLOCKS:
                out += _profile(formulation[0], name, level, per_solver, clock)
    return out


def _profile(formulation: str, name: str, level: float, per_solver: dict,
             clock: str) -> list[dict]:
    instants = sorted({i for runs in per_solver.values() for i in runs})
    solvers = list(per_solver)
    times = np.full((len(solvers), len(instants)), np.inf)
    charged = np.full((len(solvers), len(instants)), TIME_LIMIT_S)
    for a, s in enumerate(solvers):
        for b, i in enumerate(instants):
            row = per_solver[s].get(i)
            if row is not None and Status(row["status"]).has_answer:
                charged[a, b] = row[CLOCKS[clock]]
                if within(row, level):
                    times[a, b] = max(row[CLOCKS[clock]], 1e-9)  # a zero time still ranks
    best = times.min(axis=0, initial=np.inf)
    with np.errstate(invalid="ignore", divide="ignore"):
        ratio = np.where(np.isfinite(times), times / best, np.inf)
    sgm = [shifted_geometric_mean(t) for t in charged]
    top = min(sgm, default=math.nan)
    return [{"formulation": formulation, "profile": name, "clock": clock, "level": level,
             "solver": s, "solved": float(np.mean(np.isfinite(times[a]))) if instants else 0.0,
             "sgm_s": sgm[a], "sgm_ratio": sgm[a] / top if top > 0 else math.nan,
             "curve": [float(np.mean(ratio[a] <= tau)) for tau in TAUS]}
            for a, s in enumerate(solvers)]


def overhead(summary: list[dict]) -> list[dict]:
    """Per formulation, the package's time per instant around the solver in its
    per-instant runs (``cold``): the median over backends of end-to-end minus solver
    time, and of its parts (conversion and setup, checks), in s.
    """
    out = []
    for (formulation,), group in groups([e for e in summary if e["mode"] == "cold"],
                                        ("formulation",)).items():
        split = [e["split_s"] for e in group]
        out.append({"formulation": formulation, "backends": len(group),
                    "overhead_s": float(np.median([s["time_s"] - s["solve_s"] for s in split])),
                    "convert_s": float(np.median([s["convert_s"] for s in split])),
                    "checks_s": float(np.median([s["checks_s"] for s in split])),
                    "solver_s": float(np.median([s["solve_s"] for s in split]))})
    return out


def best_runs(summary: list[dict]) -> dict[str, dict]:
    """Per formulation, its fastest run that solved every instant of all of them."""
    out = {}
    for e in summary:
        if e["success_rate"] == 1.0 and e["instants"] == max(
                x["instants"] for x in summary if x["formulation"] == e["formulation"]):
            if e["instants_per_s"] > out.get(e["formulation"], {}).get("instants_per_s", 0):
                out[e["formulation"]] = e
    return out
