"""``cardan bench``: throughput and accuracy-vs-time of every formulation x backend.

Time per instant = building the formulation's problem at that instant + the package's
``solve`` (conversion, the solver's setup and solve, the package's residual checks).
The operator over all instants is built once and reported apart as one-time setup.

- **Throughput** over the scene's instants in time order: ``cold`` (every instant from
  the formulation's own start), ``warm`` (the previous instant's answer as
  ``initvals``, for the backends in :data:`WARM_STARTS`) and ``batched`` (all instants
  at once, :mod:`cardan_forces.experiments.batched`). A per-instant run stops after ``--budget-s``
  seconds (the paper's method, the baseline, never does); its rate then comes from the
  instants it reached.
- **Accuracy vs time** on evenly spaced instants over the tolerance ladder, with the
  error measured against a reference (:func:`reference_for`) and the Pareto front of
  time against error per formulation.

Results (long-format CSV, one row per run and instant; a failed run is a row with
``inf`` residuals), a PNG and a Markdown report go to ``--out``.
"""

from __future__ import annotations

import csv
import datetime
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

from cardan_forces.driveline.dynamics import simulate
from cardan_forces.driveline.equilibrium import Operator, build_operator
from cardan_forces.driveline.scene import load_scene
from cardan_forces.formulations import FORMULATIONS
from cardan_forces.formulations.convex import MIN_MAX_NORM_WEIGHT, NotApplicable
from cardan_forces.formulations.problems import LCP, LS, NLS, QP
from cardan_forces.solvers import ACCEPT, available, backends_for, solve
from cardan_forces.solvers import get as get_backend
from cardan_forces.solvers.settings import TOLERANCE_PARAMETERS

from . import batched
from .environment import json_number, machine, versions

LADDER = (1e-2, 1e-4, 1e-6, 1e-8, 1e-10)
QUICK_LADDER = (1e-4, 1e-8)
SAMPLES, QUICK_SAMPLES = 25, 5
"""Evenly spaced instants of the accuracy runs."""
QUICK_INSTANTS = 41
BUDGET_S = 5.0
REPEATS = 20
"""Repeats of a batched run; its time is their median."""

SHIFT_S = 1e-4
"""Shift of the geometric mean of times per instant: about the fastest per-instant
solve, so timer noise below it is damped while differences above it are kept."""

BATCHED = "numpy-batched"
"""Solver name of the batched paths."""

WARM_STARTS = frozenset({
    "scipy-fsolve", "scipy-root-lm", "lcp-pgs", "lcp-fb-newton",
    "qpsolvers-osqp", "qpsolvers-proxqp", "qpsolvers-scs",
})
"""Backends whose adapter passes ``initvals`` on to the solver. cvxpy warm-starts only a
problem object it has solved before, and every instant builds a new one."""

QUICK_SOLVERS = ("scipy-fsolve", "numpy-kkt", "qpsolvers-osqp", "clarabel", "lcp-lemke",
                 "lcp-pgs", BATCHED)

TARGETS = {"min_norm": 1e5, "positive": 1e4}
"""Instants per second wanted from the best run of these formulations."""
PAPER_RATIO = 50.0
"""Wanted speed-up of every convex formulation's best run over the paper's method."""
EQUAL_FLOOR = 1e-12
"""Equilibrium residuals below this count as equal (rounding) in the speed-up target."""

THROUGHPUT_COLUMNS = ("formulation", "solver", "mode", "instant", "t_s", "status", "time_s",
                      "build_s", "setup_s", "solve_s", "iterations", "equilibrium", "sign",
                      "complementarity", "cone")
ACCURACY_COLUMNS = ("formulation", "solver", "tol", "instant", "t_s", "status", "time_s",
                    "error", "equilibrium", "sign", "complementarity", "cone", "iterations")
RESIDUALS = ("equilibrium", "sign", "complementarity", "cone")


def _progress(message: str) -> None:
    print(message, file=sys.stderr, flush=True)


def shifted_geometric_mean(values, shift: float = SHIFT_S) -> float:
    """``exp(mean(log(v + shift))) - shift``; ``nan`` for no values."""
    v = np.asarray(values, float)
    return float(np.exp(np.mean(np.log(v + shift))) - shift) if v.size else math.nan


def tolerances(solver: str, ladder) -> list[float | None]:
    """The ladder for a backend with a tolerance, ``[None]`` (its defaults) otherwise."""
    if solver == BATCHED:
        return [None]
    key = solver.split("-", 1)[1] if solver.split("-")[0] in ("qpsolvers", "cvxpy",
                                                              "scipy") else solver
    return list(ladder) if TOLERANCE_PARAMETERS.get(key) else [None]


# ---------------------------------------------------------------------------- runs


def _row(formulation, solver, instant, t, status, time_s, residuals, **extra) -> dict:
    return {"formulation": formulation, "solver": solver, "instant": int(instant),
            "t_s": float(t), "status": status, "time_s": time_s,
            **{k: float(residuals[k]) for k in RESIDUALS}, **extra}


def run_instants(op: Operator, formulation: str, solver: str, instants, *, warm=False,
                 tol=None, budget_s=math.inf, reference=None) -> list[dict]:
    """One backend on one formulation at ``instants`` in order, one row per instant.

    ``warm``: the previous instant's answer (when it has one) is the start; ``reference``
    maps an instant to reference forces, giving the row an ``error`` (the distance to
    them; without a reference, the worst residual).
    """
    rows, start, previous = [], time.perf_counter(), None
    for i in instants:
        if rows and time.perf_counter() - start > budget_s:
            break
        ref = None if reference is None else reference[int(i)]
        began = time.perf_counter()
        try:
            problem = FORMULATIONS[formulation](op, int(i))
            built = time.perf_counter()
            record = solve(problem, solver, tol=tol, initvals=previous if warm else None,
                           reference=ref)
        except Exception as exc:  # a run that raises is a failed row, never a crash
            rows.append(_row(formulation, solver, i, op.t[i], "failed",
                             time.perf_counter() - began, dict.fromkeys(RESIDUALS, math.inf),
                             error=math.inf, message=f"{type(exc).__name__}: {exc}"))
            previous = None
            continue
        wall = time.perf_counter() - began
        res = record.residuals
        error = res.get("reference", max(res[k] for k in RESIDUALS))
        rows.append(_row(formulation, solver, i, op.t[i], record.status, wall, res,
                         build_s=built - began, setup_s=record.setup_s,
                         solve_s=record.solve_s, iterations=record.iterations, error=error,
                         message=record.message))
        answered = record.status in ("solved", "inaccurate") and record.z is not None
        previous = np.asarray(record.z, float) if answered else None
    return rows


def run_batched(op: Operator, formulation: str, instants=None, repeats: int = REPEATS,
                reference=None) -> tuple[list[dict], dict[str, float]]:
    """The batched path: rows (the median wall time of ``repeats`` runs spread evenly
    over the instants) and the per-instant stage times of the median run.
    """
    runs = []
    for _ in range(repeats):
        began = time.perf_counter()
        batch = batched.solve_batched(op, formulation, instants)
        runs.append((time.perf_counter() - began, batch))
    wall, batch = sorted(runs, key=lambda run: run[0])[len(runs) // 2]
    n = len(batch.instants)
    rows = []
    for k, i in enumerate(batch.instants):
        res = {key: value[k] for key, value in batch.residuals.items()}
        worst = max(res.values())
        status = "failed" if not math.isfinite(worst) else (
            "solved" if worst <= ACCEPT else "inaccurate")
        error = worst
        if reference is not None:
            ref = reference[int(i)]
            error = float(np.linalg.norm(batch.x[k] - ref) / max(np.linalg.norm(ref), 1e-12))
        message = "Lemke fallback" if batch.fallback[k] else ""
        rows.append(_row(formulation, BATCHED, i, op.t[i], status, wall / n, res,
                         build_s=0.0, setup_s=0.0, solve_s=wall / n,
                         iterations=int(batch.iterations[k]), error=error, message=message))
    return rows, {stage: seconds / n for stage, seconds in batch.stages.items()}


def plan(op: Operator, formulations=None, solvers=None, quick=False) -> dict[str, list[str]]:
    """Backends per formulation: those that take it (and the batched path where there is
    one), limited to ``solvers`` if given and to :data:`QUICK_SOLVERS` when ``quick``.
    Without ``formulations``, every one the scene calls for.
    """
    out = {}
    for name in formulations or FORMULATIONS:
        try:
            problem = FORMULATIONS[name](op, 0)
        except NotApplicable:
            if formulations:
                raise
            continue
        usable = backends_for(problem)
        if batched.supports(op, name):
            usable.append(BATCHED)
        wanted = QUICK_SOLVERS if quick and solvers is None else solvers
        out[name] = usable if wanted is None else [s for s in usable if s in wanted]
    return out


def throughput(op: Operator, backends: dict[str, list[str]], instants, budget_s: float):
    """Rows of every formulation x backend x mode, and the batched stage times. A
    per-instant run stops after ``budget_s``, except the paper's (the baseline).
    """
    rows, stages = [], {}
    for formulation, solvers in backends.items():
        for solver in solvers:
            if solver == BATCHED:
                new, stages[formulation] = run_batched(op, formulation, instants)
                new = [r | {"mode": "batched"} for r in new]
                rows += new
                _report_progress(new)
                continue
            limit = math.inf if formulation == "paper" else budget_s  # the baseline: all
            for mode in ("cold", "warm") if solver in WARM_STARTS else ("cold",):
                new = [r | {"mode": mode} for r in run_instants(
                    op, formulation, solver, instants, warm=mode == "warm", budget_s=limit)]
                rows += new
                _report_progress(new)
    return rows, stages


def _report_progress(rows: list[dict]) -> None:
    r = rows[0]
    rate = len(rows) / sum(x["time_s"] for x in rows)
    solved = sum(x["status"] == "solved" for x in rows)
    _progress(f"bench: {r['formulation']:16s} {r['solver']:20s} {r['mode']:7s} "
              f"{len(rows):5d} instants {rate:10.1f}/s, {solved} solved")


def reference_for(op: Operator, formulation: str, instants) -> tuple[dict, str, int]:
    """Reference forces per instant, the method's name and the number of instants where
    the reference itself is not ``solved``.

    Least norm: the SVD (``numpy-kkt``), exact. QP and LCP (the LCP's forces are
    ``positive``'s): quadprog's dual active set, exact, where installed, else Clarabel
    at 1e-10. Conic: Clarabel at 1e-10. The paper's method has none: its rigid solution
    set is a continuum, so its error is its worst residual.
    """
    problem = FORMULATIONS[formulation](op, int(instants[0]))
    if isinstance(problem, NLS):
        return None, "none (worst residual)", 0
    source = "positive" if isinstance(problem, LCP) else formulation
    if isinstance(problem, LS):
        solver, tol = "numpy-kkt", None
    elif isinstance(problem, (QP, LCP)) and "qpsolvers-quadprog" in available():
        solver, tol = "qpsolvers-quadprog", None
    else:
        solver, tol = "clarabel", 1e-10
    refs, unsolved = {}, 0
    for i in instants:
        record = solve(FORMULATIONS[source](op, int(i)), solver, tol=tol)
        unsolved += record.status != "solved"
        if record.status in ("solved", "inaccurate"):
            refs[int(i)] = record.x
    name = solver if tol is None else f"{solver} tol {tol:g}"
    return refs, name if source == formulation else f"{name} on positive", unsolved


def accuracy(op: Operator, backends: dict[str, list[str]], samples, ladder, budget_s: float):
    """Rows of every formulation x backend x tolerance at ``samples`` (less those where
    the reference has no answer), and the reference used per formulation ``(name,
    instants where it is not solved)``.
    """
    rows, references = [], {}
    for formulation, solvers in backends.items():
        refs, name, unsolved = reference_for(op, formulation, samples)
        references[formulation] = (name, unsolved)
        usable = samples if refs is None else np.array([i for i in samples if int(i) in refs])
        for solver in solvers:
            for tol in tolerances(solver, ladder):
                if solver == BATCHED:
                    new = run_batched(op, formulation, usable, reference=refs)[0]
                else:
                    new = run_instants(op, formulation, solver, usable, tol=tol,
                                       budget_s=budget_s, reference=refs)
                rows += [r | {"tol": "default" if tol is None else tol} for r in new]
            _progress(f"bench: accuracy {formulation:16s} {solver:20s} done")
    return rows, references


# ---------------------------------------------------------------------------- summaries


def _groups(rows: list[dict], keys: tuple[str, ...]) -> dict[tuple, list[dict]]:
    out: dict[tuple, list[dict]] = {}
    for r in rows:
        out.setdefault(tuple(r[k] for k in keys), []).append(r)
    return out


def summarize(rows: list[dict], setup_s: float) -> list[dict]:
    """Per formulation x backend x mode: instants, rate, shifted geometric mean time,
    success rate (status ``solved``), worst equilibrium residual (over all instants, and
    over the solved ones), mean time split, and the first message of a run that was not
    solved.
    """
    out = []
    for (formulation, solver, mode), group in _groups(
            rows, ("formulation", "solver", "mode")).items():
        times = [r["time_s"] for r in group]
        unsolved = [r["message"] for r in group if r["status"] != "solved"]
        out.append({
            "formulation": formulation, "solver": solver, "mode": mode,
            "instants": len(group), "instants_per_s": len(group) / sum(times),
            "sgm_s": shifted_geometric_mean(times), "setup_s": setup_s,
            "success_rate": 1.0 - len(unsolved) / len(group),
            "max_equilibrium": max(r["equilibrium"] for r in group),
            "solved_equilibrium": max((r["equilibrium"] for r in group
                                       if r["status"] == "solved"), default=math.inf),
            "split_s": {k: float(np.mean([r.get(k, 0.0) for r in group]))
                        for k in ("build_s", "setup_s", "solve_s", "time_s")},
            "note": next((m for m in unsolved if m), ""),
        })
    return out


def pareto(rows: list[dict]) -> list[dict]:
    """Per formulation x backend x tolerance: time (shifted geometric mean), worst and
    median error, worst equilibrium residual; ``front`` marks the points no other point
    of the formulation beats in both time and worst error.
    """
    points = []
    for (formulation, solver, tol), group in _groups(
            rows, ("formulation", "solver", "tol")).items():
        errors = [r["error"] for r in group]
        points.append({
            "formulation": formulation, "solver": solver, "tol": tol,
            "instants": len(group), "time_s": shifted_geometric_mean([r["time_s"] for r in group]),
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


def success_rates(rows: list[dict], ladder) -> dict[tuple[str, str], list[float]]:
    """Per formulation x backend, the share of instants meeting each accuracy level
    ``eps`` of the ladder in the run at tolerance ``eps`` (or its only run): every
    residual and the error to the reference at most ``eps``.
    """
    out = {}
    for (formulation, solver), group in _groups(rows, ("formulation", "solver")).items():
        shares = []
        for eps in ladder:
            runs = [r for r in group if r["tol"] in (eps, "default")]
            ok = [max(r["error"], *(r[k] for k in RESIDUALS)) <= eps for r in runs]
            shares.append(float(np.mean(ok)) if ok else math.nan)
        out[formulation, solver] = shares
    return out


def targets(summary: list[dict]) -> dict:
    """The three targets measured in this run (``None`` where a formulation was not run).

    A formulation's best run is its fastest that solved every instant it ran. The paper
    baseline is its fastest run (its best showing), and its level is the worst
    equilibrium residual of the instants it solved; for the speed-up a convex
    formulation's best run must also stay at or below ``max(level, EQUAL_FLOOR)`` at
    every instant (``speedup``: that run, and the formulation's fastest run).
    """
    def fastest(entries):
        return max(entries, key=lambda e: e["instants_per_s"], default=None)

    solved = [e for e in summary if e["success_rate"] == 1.0]
    out = {"rates": {}, "paper": None, "speedup": {}}
    for name, wanted in TARGETS.items():
        out["rates"][name] = (fastest([e for e in solved if e["formulation"] == name]), wanted)
    paper = fastest([e for e in summary if e["formulation"] == "paper"])
    if paper is not None:
        out["paper"] = paper
        bound = max(paper["solved_equilibrium"], EQUAL_FLOOR)
        for name in dict.fromkeys(e["formulation"] for e in summary if
                                  e["formulation"] != "paper"):
            eligible = [e for e in solved if e["formulation"] == name
                        and e["max_equilibrium"] <= bound]
            out["speedup"][name] = (fastest(eligible), fastest(
                [e for e in summary if e["formulation"] == name]))
    return out


# ---------------------------------------------------------------------------- output


def write_csv(path: Path, rows: list[dict], columns: tuple[str, ...]) -> None:
    """Long-format CSV with fixed ``columns`` (floats with 4 significant digits)."""
    with path.open("w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(columns)
        for r in rows:
            writer.writerow([_cell(r.get(c, "")) for c in columns])


def _cell(value):
    if value is None:
        return ""
    return f"{value:.4g}" if isinstance(value, float) else value


def plot_pareto(points: list[dict], path: Path) -> None:
    """Log-log time per instant vs worst error, one panel per formulation, one marker per
    backend, the front as a step line; an error of 0 is drawn at 1e-17.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import NullFormatter

    names = list(dict.fromkeys(p["formulation"] for p in points))
    cols = min(3, len(names))
    rows = math.ceil(len(names) / cols)
    fig, axes = plt.subplots(rows, cols, figsize=(5 * cols, 4 * rows), squeeze=False)
    markers = "os^vD<>phX*P8"
    for ax, name in zip(axes.flat, names):
        mine = [p for p in points if p["formulation"] == name and math.isfinite(p["error"])]
        for k, solver in enumerate(dict.fromkeys(p["solver"] for p in mine)):
            pts = sorted((p for p in mine if p["solver"] == solver), key=lambda p: p["time_s"])
            ax.plot([p["time_s"] for p in pts], [max(p["error"], 1e-17) for p in pts],
                    markers[k % len(markers)], ls=":", lw=0.8, label=solver)
        front = sorted((p for p in mine if p["front"]), key=lambda p: p["time_s"])
        if front:
            ax.step([p["time_s"] for p in front], [max(p["error"], 1e-17) for p in front],
                    "k-", where="post", lw=1.2, label="front")
        ax.set(xscale="log", yscale="log", title=name, xlabel="time per instant (s)",
               ylabel="worst error")
        ax.xaxis.set_minor_formatter(NullFormatter())
        ax.legend(fontsize=6)
    for ax in axes.flat[len(names):]:
        ax.set_visible(False)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _fmt(value: float, digits: int = 2) -> str:
    return "inf" if value == math.inf else f"{value:.{digits}e}"


def report(summary, points, rates, target, stages, references, settings) -> str:
    """The Markdown report (each table under a one-line title)."""
    lines = [
        f"# cardan bench: scene {settings['scene']}", "",
        f"- date: {datetime.datetime.now().isoformat(timespec='seconds')}",
        f"- machine: {machine()}",
        f"- versions: {versions()}",
        f"- settings: {settings['instants']} instants ({settings['span']}), budget "
        f"{settings['budget_s']:g} s per run, accuracy on {settings['samples']} evenly "
        f"spaced instants over the ladder {', '.join(f'{t:g}' for t in settings['ladder'])}"
        f"{', quick' if settings['quick'] else ''}",
        f"- one-time setup: motion {settings['simulate_s']:.2f} s, operator "
        f"{settings['operator_s'] * 1e3:.1f} ms (shared by every run)",
        "- time per instant: building the problem + `solve` (conversion, solver, the "
        "package's checks); batched: the median of "
        f"{REPEATS} runs over all instants, divided by their number",
        f"- sgm: shifted geometric mean of the time per instant, shift {SHIFT_S:g} s",
        "",
        "## Throughput per formulation x backend x mode", "",
        "| formulation | solver | mode | instants | instants/s | sgm ms | solved | max equil |",
        "|---|---|---|---:|---:|---:|---:|---:|",
    ]
    for e in summary:
        lines.append(f"| {e['formulation']} | {e['solver']} | {e['mode']} | {e['instants']} | "
                     f"{e['instants_per_s']:.1f} | {e['sgm_s'] * 1e3:.3f} | "
                     f"{100 * e['success_rate']:.1f}% | {_fmt(e['max_equilibrium'])} |")
    lines += ["", "## Best instants/s per formulation and mode (runs that solved every instant)",
              "", "| formulation | cold | warm | batched |", "|---|---|---|---|"]
    for name in dict.fromkeys(e["formulation"] for e in summary):
        cells = []
        for mode in ("cold", "warm", "batched"):
            mine = [e for e in summary if e["formulation"] == name and e["mode"] == mode
                    and e["success_rate"] == 1.0]
            best = max(mine, key=lambda e: e["instants_per_s"], default=None)
            cells.append("" if best is None else
                         f"{best['instants_per_s']:.0f} ({best['solver']})")
        lines.append(f"| {name} | {' | '.join(cells)} |")
    lines += ["", *_target_lines(target, stages)]
    lines += ["", "## Success rate per accuracy level (residuals and error <= level)", "",
              "| formulation | solver | " + " | ".join(f"{t:g}" for t in settings["ladder"])
              + " |", "|---|---|" + "---:|" * len(settings["ladder"])]
    for (formulation, solver), shares in rates.items():
        lines.append(f"| {formulation} | {solver} | "
                     + " | ".join("" if math.isnan(s) else f"{100 * s:.0f}%" for s in shares)
                     + " |")
    lines += ["", "## Pareto front per formulation (time sgm vs worst error)", "",
              "Error: distance to the reference relative to its norm (the paper: worst "
              "residual). Figure: `bench_pareto.png`.", "",
              "| formulation | reference | solver | tol | time ms | worst error | median error "
              "| max equil |", "|---|---|---|---|---:|---:|---:|---:|"]
    for p in sorted((p for p in points if p["front"]),
                    key=lambda p: (p["formulation"], p["time_s"])):
        lines.append(f"| {p['formulation']} | {references[p['formulation']][0]} | "
                     f"{p['solver']} | {p['tol']} | {p['time_s'] * 1e3:.3f} | "
                     f"{_fmt(p['error'])} | {_fmt(p['error_median'])} | "
                     f"{_fmt(p['equilibrium'])} |")
    lines += ["", "## Runs not always solved", "",
              "| formulation | solver | mode | solved | first message |", "|---|---|---|---:|---|"]
    for e in summary:
        if e["success_rate"] < 1.0:
            lines.append(f"| {e['formulation']} | {e['solver']} | {e['mode']} | "
                         f"{100 * e['success_rate']:.1f}% | {_one_line(e['note'])} |")
    lines += ["", "## Known limitations", "", *_limitations(summary, references, settings)]
    return "\n".join(lines) + "\n"


def _target_lines(target: dict, stages: dict) -> list[str]:
    lines = ["## Targets (measured in this run)", ""]
    for name, (best, wanted) in target["rates"].items():
        if best is None:
            lines.append(f"- `{name}` >= {wanted:g} instants/s: no run solved every instant")
            continue
        rate = best["instants_per_s"]
        lines.append(f"- `{name}` >= {wanted:g} instants/s: {rate:.0f} ({best['solver']}, "
                     f"{best['mode']}), ratio {rate / wanted:.2f} "
                     f"{'met' if rate >= wanted else 'NOT met'}")
        if rate < wanted:
            lines.append(f"  - where the time goes: {_profile(best, stages)}")
    paper = target["paper"]
    if paper is None:
        return [*lines, "- speed-up over the paper's method: the paper's method was not run"]
    split = paper["split_s"]
    solve_only = 1.0 / max(split["time_s"] - split["build_s"], 1e-12)
    lines.append(f"- paper baseline: {paper['solver']} {paper['mode']}, "
                 f"{paper['instants_per_s']:.1f} instants/s ({solve_only:.1f} without building "
                 f"its problem), solved {100 * paper['success_rate']:.1f}%, worst equilibrium "
                 f"residual of the solved instants {_fmt(paper['solved_equilibrium'])}")
    lines.append(f"- each convex formulation's best run >= {PAPER_RATIO:g}x the paper's rate, "
                 "solving every instant at a worst equilibrium residual <= max(paper's, "
                 f"{EQUAL_FLOOR:g}):")
    for name, (best, fastest) in target["speedup"].items():
        if best is None:
            lines.append(f"  - `{name}`: NOT met, no run solves every instant at that residual; "
                         f"its fastest, {fastest['solver']} {fastest['mode']} "
                         f"{fastest['instants_per_s']:.0f}/s "
                         f"({fastest['instants_per_s'] / paper['instants_per_s']:.1f}x), solved "
                         f"{100 * fastest['success_rate']:.1f}% with a worst equilibrium "
                         f"residual of {_fmt(fastest['max_equilibrium'])}")
            continue
        ratio = best["instants_per_s"] / paper["instants_per_s"]
        lines.append(f"  - `{name}`: {best['solver']} {best['mode']} "
                     f"{best['instants_per_s']:.0f}/s, {ratio:.1f}x, ratio to target "
                     f"{ratio / PAPER_RATIO:.2f} {'met' if ratio >= PAPER_RATIO else 'NOT met'}")
        if ratio < PAPER_RATIO:
            lines.append(f"    - where the time goes: {_profile(best, stages)}")
    return lines


def _one_line(text: str, width: int = 120) -> str:
    """A message as one table cell: whitespace collapsed, no pipes, at most ``width``."""
    return " ".join(text.replace("|", "/").split())[:width]


def _profile(entry: dict, stages: dict) -> str:
    """Mean time split of one run, in microseconds per instant."""
    if entry["mode"] == "batched":
        parts = stages.get(entry["formulation"], {})
        return ", ".join(f"{k} {v * 1e6:.1f} us" for k, v in parts.items()) + (
            " per instant (NumPy calls LAPACK once per 6 x 6 body block and instant)")
    s = entry["split_s"]
    other = s["time_s"] - s["build_s"] - s["setup_s"] - s["solve_s"]
    return (f"build problem {s['build_s'] * 1e6:.0f} us, solver setup (conversion, "
            f"matrices) {s['setup_s'] * 1e6:.0f} us, solver {s['solve_s'] * 1e6:.0f} us, "
            f"package checks and dispatch {other * 1e6:.0f} us per instant")


def _limitations(summary, references, settings) -> list[str]:
    cut = [f"{e['formulation']}/{e['solver']}/{e['mode']} ({e['instants']})" for e in summary
           if e["instants"] < settings["instants"]]
    unsolved = [f"{name} {n}" for name, (_, n) in references.items() if n]
    return [
        f"- Per-instant runs stop after {settings['budget_s']:g} s (not the paper's); these "
        f"ran on the first instants only (count in brackets): {', '.join(cut) or 'none'}.",
        "- Warm starts only where the adapter passes `initvals` on "
        f"({', '.join(sorted(WARM_STARTS))}); cvxpy builds and compiles a new problem at "
        "every instant (no parameters), which bounds its rate and voids its warm start.",
        "- Batched paths exist for the least-norm formulations only; "
        f"{', '.join(_without_batched(summary)) or 'none'} ran instant by instant only.",
        "- References: the SVD for least norm and quadprog for QPs are exact, so those "
        "backends show an error at rounding level by construction; conic references are "
        f"Clarabel at 1e-10, not `solved` at: {', '.join(unsolved) or 'no sampled instant'}. "
        "The paper's rigid solution set is a continuum: its error is its worst residual.",
        f"- `min_max` fixes its forces only through a tie-break term of weight "
        f"{MIN_MAX_NORM_WEIGHT:g}, so its distance to the reference falls slowly with the "
        "tolerance.",
        *(["- The scene starts from rest (instant 0), where several backends lose accuracy."]
          if settings["from_rest"] else []),
        "- Wall-clock times of one process on a shared machine; single runs of the "
        "per-instant loops, so rates carry a few percent of noise.",
    ]


def _without_batched(summary) -> list[str]:
    modes: dict[str, set[str]] = {}
    for e in summary:
        modes.setdefault(e["formulation"], set()).add(e["mode"])
    return [name for name, seen in modes.items() if "batched" not in seen and name != "paper"]


# ---------------------------------------------------------------------------- command


def run(args) -> int:
    """``cardan bench``: write the CSVs, the PNG and the report into ``args.out``."""
    for name in args.solver or ():
        if name != BATCHED:
            get_backend(name)  # unknown or absent: SolverNotFound before any work
    scene = load_scene(args.scene)
    times = scene.time.instants()
    if args.quick:
        times = times[:QUICK_INSTANTS]
    ladder = QUICK_LADDER if args.quick else LADDER
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    started = time.perf_counter()
    _progress(f"bench: simulating {scene.name} over {len(times)} instants ...")
    motion = simulate(scene, times)
    simulated = time.perf_counter()
    op = build_operator(motion)
    operator_s = time.perf_counter() - simulated
    instants = np.arange(len(times))
    samples = np.unique(np.linspace(0, len(times) - 1, QUICK_SAMPLES if args.quick else
                                    SAMPLES).round().astype(int))
    backends = plan(op, args.formulation, args.solver, args.quick)
    rows, stages = throughput(op, backends, instants, args.budget_s)
    acc_rows, references = accuracy(op, backends, samples, ladder, args.budget_s)
    summary = summarize(rows, operator_s)
    points = pareto(acc_rows)
    target = targets(summary)
    write_csv(out / "bench_throughput.csv", rows, THROUGHPUT_COLUMNS)
    write_csv(out / "bench_accuracy.csv", acc_rows, ACCURACY_COLUMNS)
    plot_pareto(points, out / "bench_pareto.png")
    settings = {"scene": scene.name, "instants": len(times),
                "span": f"{times[0]:g}..{times[-1]:g} s", "budget_s": args.budget_s,
                "samples": len(samples), "ladder": ladder, "quick": args.quick,
                "simulate_s": simulated - started, "operator_s": operator_s,
                "from_rest": scene.initial_speed_rad_s == 0.0}
    (out / "report.md").write_text(report(summary, points, success_rates(acc_rows, ladder),
                                          target, stages, references, settings))
    _progress(f"bench: wrote {out} in {time.perf_counter() - started:.0f} s")
    if args.json:
        print(json.dumps({
            "throughput": [{k: json_number(e[k]) if isinstance(e[k], float) else e[k]
                            for k in ("formulation", "solver", "mode", "instants_per_s",
                                      "setup_s", "success_rate", "max_equilibrium")}
                           for e in summary],
            "pareto": [{"formulation": p["formulation"], "solver": p["solver"],
                        "tol": None if p["tol"] == "default" else p["tol"],
                        "time_s": p["time_s"], "error": json_number(p["error"]),
                        "equilibrium": json_number(p["equilibrium"])}
                       for p in points if p["front"]],
        }, indent=2))
    else:
        for e in summary:
            print(f"{e['formulation']:16s} {e['solver']:20s} {e['mode']:7s} "
                  f"{e['instants_per_s']:10.1f}/s  solved {100 * e['success_rate']:5.1f}%")
    return 0


def add_parser(subparsers) -> None:
    """Register ``cardan bench`` on the command line's subparsers."""
    p = subparsers.add_parser("bench", help="throughput and accuracy-vs-time of formulations "
                                            "x backends")
    p.add_argument("scene", nargs="?", default="paper", help="built-in name or TOML path")
    p.add_argument("--out", default="results/bench", help="output folder (default "
                                                          "results/bench/)")
    p.add_argument("--quick", action="store_true",
                   help=f"first {QUICK_INSTANTS} instants, {len(QUICK_LADDER)} tolerances, "
                        "a few backends (tests, CI)")
    p.add_argument("--json", action="store_true", help="print the summary as JSON")
    p.add_argument("--formulation", action="append", choices=list(FORMULATIONS),
                   help="one formulation (repeatable); default all")
    p.add_argument("--solver", action="append",
                   help=f"one backend (repeatable; {BATCHED} for the batched paths); "
                        "default all")
    p.add_argument("--budget-s", type=float, default=BUDGET_S,
                   help=f"seconds per per-instant run before it stops (default {BUDGET_S:g})")
    p.set_defaults(func=run)
