"""Output of ``cardan bench``: CSV files, figures, the Markdown report and the JSON object."""

from __future__ import annotations

import csv
import datetime
import math
import numbers
from pathlib import Path

from cardan_forces.formulations import BASELINE
from cardan_forces.solvers.record import ACCEPT

from . import files
from .bench_metrics import PROFILES, SHIFT_S, TAUS, TIME_LIMIT_S, best_runs
from .bench_run import CHECK_PASSES
from .environment import json_number, machine, number_text, threads, versions

THROUGHPUT_COLUMNS = ("formulation", "solver", "mode", "instant", "t_s", "status", "time_s",
                      "build_s", "convert_s", "solve_s", "checks_s", "checks_first_s",
                      "iterations", "primal",
                      "dual", "gap", "distance", "equilibrium", "sign", "complementarity",
                      "cone")
ACCURACY_COLUMNS = ("formulation", "solver", "tol", "instant", "t_s", "status", "time_s",
                    "solve_s", "primal", "dual", "gap", "distance", "equilibrium", "sign",
                    "complementarity", "cone", "iterations")
PROFILE_COLUMNS = ("formulation", "profile", "clock", "level", "solver", "solved", "sgm_ratio",
                   "tau", "fraction")
VIEW_COLUMNS = ("problem", "formulation", "solver", "setting", "found", "primal", "dual", "gap",
                "solver_ok", "solver_rule", "equilibrium", "sign", "complementarity", "cone",
                "distance", "force_ok", "force_rule", "runtime_s", "solver_s", "end_to_end_s",
                "message")
"""Columns of ``bench_views.csv``: each solve of the two-view harness, one row."""


def write_csv(path: Path, rows: list[dict], columns: tuple[str, ...]) -> None:
    """Long-format CSV with fixed ``columns`` (floats with 4 significant digits; an
    empty cell where a number is missing or undefined), written whole or not at all
    (:func:`.files.replacing`).
    """
    with files.replacing(path, newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(columns)
        for r in rows:
            writer.writerow([_cell(r.get(c, "")) for c in columns])


def _cell(value):
    """A number as its text, an undefined one (``None``, ``inf``, NaN, of any float
    type) as an empty cell; integers, flags and text as they are.
    """
    real = isinstance(value, numbers.Real) and not isinstance(value, numbers.Integral)
    return number_text(value, ".4g", "") if value is None or real else value


def profile_rows(profiles: list[dict]) -> list[dict]:
    """The profiles in long format, one row per curve point."""
    return [{k: p[k] for k in PROFILE_COLUMNS[:7]} | {"tau": float(tau), "fraction": frac}
            for p in profiles for tau, frac in zip(TAUS, p["curve"])]


MARKERS = "os^vD<>phX*P8"
"""Markers of the backends' styles, cycled with the colours (:func:`backend_styles`)."""

EMPTY_PARETO = "no solve of this formulation\ngave an answer"
EMPTY_PROFILE = "no solve of this formulation\nreached this level"
"""The words on a panel that has no curve to draw."""


def backend_styles(solvers) -> dict[str, tuple]:
    """One (colour, marker) per backend, fixed by the sorted names of every backend of
    one bench, so a backend looks the same in every panel and figure of that bench.
    """
    import matplotlib

    colours = matplotlib.colormaps["tab20"].colors
    names = sorted(set(solvers))
    return {name: (colours[2 * (k % 10) + k // 10 % 2], MARKERS[k % len(MARKERS)])  # dark, light
            for k, name in enumerate(names)}


def _figure(panels: int, cols: int = 3):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    cols = max(1, min(cols, panels))
    rows = math.ceil(panels / cols)
    fig, axes = plt.subplots(rows, cols, figsize=(4.6 * cols, 3.6 * rows + 1.4), squeeze=False)
    for ax in axes.flat[panels:]:
        ax.set_visible(False)
    return plt, fig, axes


def _log_ticks(ax, axis: str) -> None:
    """Labels on a log axis that never overlap, the limits the data's with a margin of
    8 % of their span in log (at least 0.05 decade): plain numbers at a few even steps
    over less than a factor of 6 (where the 1-2-5 values may hold fewer than two), the
    1-2-5 values over less than two decades, the decades otherwise; no labels on the
    minor ticks.
    """
    from matplotlib import ticker

    which = ax.xaxis if axis == "x" else ax.yaxis
    low, high = ax.dataLim.intervalx if axis == "x" else ax.dataLim.intervaly
    if not (0 < low <= high and math.isfinite(high)):
        return
    pad = max(0.08 * math.log10(high / low), 0.05)
    low, high = low / 10 ** pad, high * 10 ** pad
    (ax.set_xlim if axis == "x" else ax.set_ylim)(low, high)
    decades = math.log10(high / low)
    if decades < math.log10(6.0):
        which.set_major_locator(ticker.MaxNLocator(nbins=4, steps=[1, 2, 2.5, 5, 10]))
        which.set_major_formatter(ticker.FuncFormatter(lambda v, _: f"{v:.3g}"))
    else:
        subs = (1.0, 2.0, 5.0) if decades < 2.0 else (1.0,)
        which.set_major_locator(ticker.LogLocator(base=10.0, subs=subs, numticks=12))
        which.set_major_formatter(ticker.LogFormatterSciNotation(labelOnlyBase=False))
    which.set_minor_formatter(ticker.NullFormatter())


def _empty(ax, words: str) -> None:
    """A panel with nothing to draw says so in its middle."""
    ax.text(0.5, 0.5, words, transform=ax.transAxes, ha="center", va="center",
            fontsize=10, color="0.3")


def _shared_legend(fig, styles: dict, shown, title: str, extra=()) -> None:
    """The figure's ``title`` above its panels and one legend under them: each backend
    drawn, with its colour and marker, then ``extra`` (label, line style) entries, each
    the label of a line drawn in the panels.
    """
    from matplotlib.lines import Line2D

    handles = [Line2D([], [], color=styles[s][0], marker=styles[s][1], ls=":", lw=1.0,
                      label=s) for s in sorted(set(shown))]
    handles += [Line2D([], [], color="k", ls=ls, lw=1.2, label=label) for label, ls in extra]
    cols = min(5, max(1, len(handles)))
    rows = math.ceil(len(handles) / cols)
    height = fig.get_figheight()
    fig.suptitle(title, fontsize=11)
    fig.legend(handles=handles, loc="lower center", ncol=cols, fontsize=9, frameon=False)
    fig.tight_layout(rect=(0, min(0.4, (0.3 * rows + 0.2) / height), 1, 1 - 0.6 / height))


def _written(drawn, path: Path, formats) -> list[Path]:
    """A drawn ``(plt, fig)`` saved as ``path.<format>`` for each of ``formats``."""
    from .images import save

    plt, fig = drawn
    written = save(fig, path.with_suffix(""), formats)
    plt.close(fig)
    return written


def plot_pareto(points: list[dict], path: Path, formats=("png",), styles=None,
                scene: str = "") -> list[Path]:
    """:func:`pareto_figure` written as ``path.<format>`` for each of ``formats``."""
    return _written(pareto_figure(points, styles, scene), path, formats)


FRONT = "Pareto front (no answer both faster and more accurate)"
ERROR_FLOOR = 1e-17
"""A worst optimality measure of exactly 0 is drawn here (a log axis has no 0)."""


def pareto_figure(points: list[dict], styles=None, scene: str = ""):
    """Log-log time per instant vs worst optimality measure, one panel per formulation,
    each backend in its colour and marker (:func:`backend_styles`, one legend for all
    panels; each line labelled with its backend), its points (one per tolerance
    setting) joined by a dotted line in time order, the front as a step line; 0 is
    drawn at :data:`ERROR_FLOOR`; a panel without an answer says so. ``scene``: named in
    the title. Returns pyplot and the figure.
    """
    styles = styles or backend_styles(p["solver"] for p in points)
    names = list(dict.fromkeys(p["formulation"] for p in points))
    plt, fig, axes = _figure(len(names))
    shown = set()
    for ax, name in zip(axes.flat, names):
        mine = [p for p in points if p["formulation"] == name and math.isfinite(p["error"])]
        for solver in dict.fromkeys(p["solver"] for p in mine):
            pts = sorted((p for p in mine if p["solver"] == solver), key=lambda p: p["time_s"])
            colour, marker = styles[solver]
            ax.plot([p["time_s"] for p in pts], [max(p["error"], ERROR_FLOOR) for p in pts],
                    marker=marker, color=colour, ls=":", lw=0.8, label=solver)
            shown.add(solver)
        front = sorted((p for p in mine if p["front"]), key=lambda p: p["time_s"])
        if front:
            ax.step([p["time_s"] for p in front], [max(p["error"], ERROR_FLOOR) for p in front],
                    "k-", where="post", lw=1.2, label=FRONT)
        ax.set(xscale="log", yscale="log", title=name, xlabel="time per instant [s]",
               ylabel="worst optimality measure [-]")
        if mine:
            _log_ticks(ax, "x")
            _log_ticks(ax, "y")
        else:
            _empty(ax, EMPTY_PARETO)
    _shared_legend(fig, styles, shown, _title(
        "Time against accuracy per formulation", scene,
        "each point one tolerance setting of a backend, dotted lines join a backend's "
        f"settings in time order; an exact 0 is drawn at {ERROR_FLOOR:g}"), [(FRONT, "-")])
    return plt, fig


def _title(what: str, scene: str, how: str) -> str:
    return f"{what}{f' (scene {scene})' if scene else ''}\n{how}"


def plot_profiles(profiles: list[dict], path: Path, formats=("png",), styles=None,
                  scene: str = "") -> list[Path]:
    """:func:`profiles_figure` written as ``path.<format>`` for each of ``formats``."""
    return _written(profiles_figure(profiles, styles, scene), path, formats)


def profiles_figure(profiles: list[dict], styles=None, scene: str = ""):
    """Dolan-Moré curves on the solver's time, one panel per formulation x profile,
    each backend in its colour and marker (one legend for all panels; each line
    labelled with its backend); the y axis a little beyond 0 and 1, so a curve at
    either is not hidden by the frame; a panel where no solve reached the level says so
    and draws nothing. ``scene``: named in the title. Returns pyplot and the figure.
    """
    profiles = [p for p in profiles if p["clock"] == "solver"]
    styles = styles or backend_styles(p["solver"] for p in profiles)
    panels = list(dict.fromkeys((p["formulation"], p["profile"]) for p in profiles))
    plt, fig, axes = _figure(len(panels), cols=4)
    shown = set()
    for ax, (formulation, name) in zip(axes.flat, panels):
        curves = [p for p in profiles if (p["formulation"], p["profile"]) == (formulation, name)]
        reached = any(max(p["curve"]) > 0 for p in curves)
        for p in curves if reached else ():
            colour, marker = styles[p["solver"]]
            ax.step(TAUS, p["curve"], where="post", lw=1.0, color=colour, marker=marker,
                    markevery=10, ms=4, label=p["solver"], clip_on=False)
            shown.add(p["solver"])
        level = next(p["level"] for p in profiles if p["profile"] == name)
        ax.set(xscale="log", xlim=(TAUS[0], TAUS[-1]), ylim=(-0.06, 1.06),
               title=f"{formulation}, {name} ({level:g})",
               xlabel="tau: solver time / fastest [-]", ylabel="share of instants [-]")
        if not reached:
            _empty(ax, EMPTY_PROFILE)
    _shared_legend(fig, styles, shown, _title(
        "Performance profiles on the solver's time", scene,
        "share of instants a backend solves to the panel's level within tau times the "
        "fastest backend's time"))
    return plt, fig


def _fmt(value: float | None, digits: int = 2) -> str:
    return number_text(value, f".{digits}e")


def _us(seconds: float) -> str:
    return f"{seconds * 1e6:.1f}"


def _one_line(text: str, width: int = 120) -> str:
    """A message as one table cell: whitespace collapsed, no pipes, at most ``width``."""
    return " ".join(str(text).replace("|", "/").split())[:width]


def report(results: dict, settings: dict) -> str:
    """The Markdown report (each table under a one-line title)."""
    lines = _header(results, settings)
    lines += _throughput(results["summary"])
    lines += _best(results["summary"])
    lines += _conic_split(results["summary"])
    lines += _success(results["success"],
                      sorted({r["level"] for r in results["success"]}, reverse=True))
    lines += _views(results.get("views", []), results.get("view_count", 0),
                    results.get("qpbenchmark_ran", False))
    lines += _profiles(results["profiles"])
    lines += _overhead(results.get("overhead", []))
    lines += _pareto(results["points"], results["references"])
    lines += _stages(results["stages"])
    lines += _unsolved(results["summary"])
    lines += ["", "## Known limitations", "", *_limitations(results, settings)]
    return "\n".join(lines) + "\n"


def _header(results, settings) -> list[str]:
    builds = ", ".join(f"{k} {v:.2f} s" for k, v in results["setup"].items())
    return [
        f"# cardan bench: scene {settings['scene']}", "",
        f"- date: {datetime.datetime.now().isoformat(timespec='seconds')}",
        f"- machine: {machine()}",
        f"- threads: {threads()}",
        f"- versions: {versions()}",
        f"- settings: {settings['instants']} instants ({settings['span']}), budget "
        f"{settings['budget_s']:g} s per per-instant run, accuracy on {settings['samples']} "
        f"evenly spaced instants over the ladder "
        f"{', '.join(f'{t:g}' for t in settings['ladder'])} and each backend's defaults"
        f"{', quick' if settings['quick'] else ''}; wall time {settings['wall_s']:.0f} s",
        f"- one-time setup: motion {settings['simulate_s']:.2f} s, operator "
        f"{settings['operator_s'] * 1e3:.1f} ms; every formulation's problems built once "
        f"per operator: {builds}",
        "- time per instant = taking the prebuilt problem (build) + conversion and setup "
        "(the package's and the adapter's matrices) + the solver + the package's checks "
        "(residuals, optimality, the records); batched: the fastest of repeated runs over "
        "all instants, divided by their number; the checks of a per-instant run: the "
        f"fastest of {CHECK_PASSES} passes over its answers (the first, cold after the "
        "solver's run, is what its end-to-end time holds; its excess is in 'other')",
        "- two accuracy views: *solver optimality* is qpbenchmark's (absolute primal "
        "residual, dual residual and duality gap of the QP the solver received, its four "
        "settings and success rule; the section of that name); the ladder's *package "
        "optimality* is the package's own, relative: primal = the worst force residual "
        "over ||b||, dual residual over the stationarity terms, duality gap over the "
        "objective (objective gap to a high-precision solve for records without solver "
        "duals), and the distance to the reference only where the optimum is unique; a row "
        "succeeds at a level when all its measures are within it",
        f"- sgm: shifted geometric mean of the solver's own time per instant (the backend "
        f"call alone) unless a column says end to end; qpbenchmark's shift {SHIFT_S:g} s, "
        f"a run without an answer counted at its time limit {TIME_LIMIT_S:g} s",
        "- all times are wall-clock and move with the machine's load: read them as ratios "
        "within this run",
    ]


def solved_sentence(rows) -> str:
    """What the *solved* share of a run means, in one sentence naming the backends that
    left instants unsolved in ``rows`` (throughput rows: ``solver``, ``success_rate``):
    the package's accuracy, stricter than many solvers' defaults.
    """
    short = sorted({r["solver"] for r in rows if (r["success_rate"] or 0.0) < 1.0})
    which = f"here: {', '.join(short)}" if short else "none here"
    level = f"{ACCEPT:.0e}".replace("e-0", "e-")
    return (f"Solved: the share of instants whose record the package calls solved, its "
            f"primal residual, dual residual and gap all within {level}; that is stricter "
            f"than where many solvers stop by default, so a backend at its default "
            f"settings may solve fewer instants ({which}).")


def _throughput(summary) -> list[str]:
    lines = ["", "## Throughput per formulation x backend x mode (time split in us per "
             "instant)", "", solved_sentence(summary), "",
             "| formulation | solver | mode | instants | instants/s | sgm ms (solver) | solved "
             "| iterations | build "
             "| conversion | solver | checks | other | solver share |",
             "|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for e in summary:
        s = e["split_s"]
        lines.append(
            f"| {e['formulation']} | {e['solver']} | {e['mode']} | {e['instants']} | "
            f"{e['instants_per_s']:.1f} | {number_text(e['sgm_s'] * 1e3, '.3f')} | "
            f"{100 * e['success_rate']:.1f}% | {_iterations(e.get('iterations'))} | "
            f"{_us(s['build_s'])} | {_us(s['convert_s'])} | "
            f"{_us(s['solve_s'])} | {_us(s['checks_s'])} | {_us(s['other_s'])} | "
            f"{100 * e['solver_share']:.0f}% |")
    return lines


def _iterations(mean: float | None) -> str:
    """Mean iterations per instant for the table ("-" where the solver gives none)."""
    return "-" if mean is None else f"{mean:.2f}"


def best_table(summary) -> list[dict]:
    """Per formulation: its best run (solving every instant) and its ratio to the
    paper method's fastest run of the same benchmark.
    """
    best = best_runs(summary)
    paper = max((e for e in summary if e["formulation"] == BASELINE),
                key=lambda e: e["instants_per_s"], default=None)
    return [{"formulation": name, "solver": e["solver"], "mode": e["mode"],
             "instants_per_s": e["instants_per_s"],
             "paper_ratio": e["instants_per_s"] / paper["instants_per_s"] if paper else None}
            for name, e in best.items()]


def _best(summary) -> list[str]:
    lines = ["", "## Best backend per formulation (runs that solved every instant) and ratio "
             "to the paper method", "",
             "| formulation | best backend | mode | instants/s | x paper |",
             "|---|---|---|---:|---:|"]
    for b in best_table(summary):
        ratio = "" if b["paper_ratio"] is None else f"{b['paper_ratio']:.1f}"
        lines.append(f"| {b['formulation']} | {b['solver']} | {b['mode']} | "
                     f"{b['instants_per_s']:.0f} | {ratio} |")
    return lines


def _conic_split(summary) -> list[str]:
    rows = [e for e in summary if e["solver"] == "clarabel" and e["mode"] == "cold"]
    lines = ["", "## Whose time: one conic instant (clarabel, per instant)", ""]
    for e in rows:
        s = e["split_s"]
        lines.append(f"- `{e['formulation']}`: build {_us(s['build_s'])} us, conversion "
                     f"{_us(s['convert_s'])} us, solver {_us(s['solve_s'])} us, checks "
                     f"{_us(s['checks_s'])} us, other {_us(s['other_s'])} us: the solver's "
                     f"share {100 * e['solver_share']:.0f}%")
    return lines if rows else []


def _success(rows, ladder) -> list[str]:
    lines = ["", "## Success per accuracy level (package optimality, relative: all measures "
             "<= level, in the backend's best run: its defaults or a tolerance of the ladder)",
             "",
             "| formulation | solver | " + " | ".join(f"{t:g}" for t in ladder) + " |",
             "|---|---|" + "---:|" * len(ladder)]
    table: dict[tuple, dict] = {}
    for r in rows:
        table.setdefault((r["formulation"], r["solver"]), {})[r["level"]] = r["rate"]
    for (formulation, solver), rates in table.items():
        cells = " | ".join(f"{100 * rates[t]:.0f}%" if t in rates else "" for t in ladder)
        lines.append(f"| {formulation} | {solver} | {cells} |")
    return lines


def _profiles(profiles) -> list[str]:
    names = " / ".join(f"{n} ({'defaults' if t is None else 'smallest tol'}, level {lv:g})"
                       for n, t, lv in PROFILES)
    lines = ["", f"## Performance profiles: {names}", "",
             "Package optimality at the level; shifted geometric mean time over the best "
             f"backend's (shift {SHIFT_S:g} s; a run without an answer counts as "
             f"{TIME_LIMIT_S:g} s), on the solver's own time and end to end; curves (solver "
             "time) in `bench_profiles.png`, points in `bench_profiles.csv`.", "",
             "| formulation | profile | solver | solved | sgm ratio (solver) | share within "
             "10x | sgm ratio (end to end) |", "|---|---|---|---:|---:|---:|---:|"]
    ten = int(abs(TAUS - 10.0).argmin())
    wide = {(p["formulation"], p["profile"], p["solver"]): p["sgm_ratio"] for p in profiles
            if p["clock"] == "end_to_end"}
    mine = [p for p in profiles if p["clock"] == "solver"]
    for p in sorted(mine, key=lambda p: (p["formulation"], p["profile"], p["sgm_ratio"])):
        other = wide.get((p["formulation"], p["profile"], p["solver"]))
        lines.append(f"| {p['formulation']} | {p['profile']} | {p['solver']} | "
                     f"{100 * p['solved']:.0f}% | {number_text(p['sgm_ratio'], '.2f')} | "
                     f"{100 * p['curve'][ten]:.0f}% | {number_text(other, '.2f')} |")
    return lines


def _overhead(rows) -> list[str]:
    lines = ["", "## The package's time around the solver (per-instant runs, us per instant, "
             "median over backends)", "",
             "| formulation | backends | solver | end to end - solver | conversion | checks |",
             "|---|---:|---:|---:|---:|---:|"]
    for r in rows:
        lines.append(f"| {r['formulation']} | {r['backends']} | {_us(r['solver_s'])} | "
                     f"{_us(r['overhead_s'])} | {_us(r['convert_s'])} | {_us(r['checks_s'])} |")
    return lines


def _views(tables, problems: int, qpbenchmark_ran: bool) -> list[str]:
    if not tables:
        return []
    theirs = " | qpbenchmark itself" if qpbenchmark_ran else ""
    lines = ["", "## Solver optimality (qpbenchmark's measures and settings) and force "
             "accuracy, on the same solves", "",
             f"{problems} problems (the QP, least-norm and conic formulations at the accuracy "
             "instants, least norms as QPs), each solved once per backend and setting and "
             "scored twice: *solver optimality* succeeds as in qpbenchmark (solver reports "
             "found, absolute primal residual, dual residual and duality gap strictly below "
             "the setting's tolerance: default 1, low 1e-3, mid 1e-6, high 1e-9; for a conic "
             "problem the KKT residuals of its standard form); *force accuracy* is the "
             "package's physics on the same answer (equilibrium, signs, complementarity, "
             "cones, each over ||b||, and the distance to the reference answer where the "
             "optimum is unique, <= 1e-6). The failing rule of each failed solve is "
             "counted. Runtime: qpbenchmark's (the qpsolvers call), shifted geometric mean "
             f"(shift {SHIFT_S:g} s, not found at {TIME_LIMIT_S:g} s) over the best "
             "backend's.", "",
             f"| solver | setting | solver optimality{theirs} | failed rule | force accuracy | "
             f"failed check | runtime ratio{' | qpbenchmark runtime ratio' if theirs else ''} |",
             "|---|---|---:|" + ("---:|" if theirs else "") + "---|---:|---|---:|"
             + ("---:|" if theirs else "")]
    for r in tables:
        ours = f"{r['solver_success']:.0f}%"
        if qpbenchmark_ran:
            theirs_rate = r["qpbenchmark_success"]
            ours += " | -" if math.isnan(theirs_rate) else f" | {theirs_rate:.0f}%"
        tail = f" | {number_text(r['qpbenchmark_runtime_ratio'], '.2f')}" if theirs else ""
        lines.append(f"| {r['solver']} | {r['setting']} | {ours} | {r['solver_failures']} | "
                     f"{r['force_success']:.0f}% | {r['force_failures']} | "
                     f"{number_text(r['runtime_ratio'], '.2f')}{tail} |")
    return lines


def _pareto(points, references) -> list[str]:
    lines = ["", "## Pareto front per formulation (time sgm vs worst optimality measure)", "",
             "Figure: `bench_pareto.png`.", "",
             "| formulation | reference | solver | tol | time ms | worst measure | median | "
             "max equil |", "|---|---|---|---|---:|---:|---:|---:|"]
    for p in sorted((p for p in points if p["front"]),
                    key=lambda p: (p["formulation"], p["time_s"])):
        lines.append(f"| {p['formulation']} | {references[p['formulation']][0]} | "
                     f"{p['solver']} | {p['tol']} | {p['time_s'] * 1e3:.3f} | "
                     f"{_fmt(p['error'])} | {_fmt(p['error_median'])} | "
                     f"{_fmt(p['equilibrium'])} |")
    return lines


def _stages(stages) -> list[str]:
    lines = ["", "## Batched runs: where the time goes (us per instant)", ""]
    for (formulation, solver), parts in stages.items():
        lines.append(f"- `{formulation}` {solver}: "
                     + ", ".join(f"{k} {v:.1f} s" if k.endswith(", once") else
                                 f"{k} {_us(v)}" for k, v in parts.items()))
    return lines


def _unsolved(summary) -> list[str]:
    lines = ["", "## Runs not always solved", "",
             "| formulation | solver | mode | solved | first message |", "|---|---|---|---:|---|"]
    for e in summary:
        if e["success_rate"] < 1.0:
            lines.append(f"| {e['formulation']} | {e['solver']} | {e['mode']} | "
                         f"{100 * e['success_rate']:.1f}% | {_one_line(e['note'])} |")
    return lines


def _limitations(results, settings) -> list[str]:
    cut = [f"{e['formulation']}/{e['solver']}/{e['mode']} ({e['instants']})"
           for e in results["summary"] if e["instants"] < settings["instants"]]
    unsolved = [f"{name} {n}" for name, (_, n) in results["references"].items() if n]
    return [
        f"- Per-instant runs stop after {settings['budget_s']:g} s (not the paper's "
        "baseline, its default backend warm-started over every instant); these "
        f"ran on the first instants only (count in brackets): {', '.join(cut) or 'none'}.",
        "- cvxpy compiles one parametrized problem per structure (DPP) and reuses it; that "
        "first compilation (up to seconds for a conic form) falls in the run's first "
        "instant. Clarabel builds a new solver per instant (its data update would keep "
        "the first instant's scaling, so answers would depend on the order); moreau "
        "one compiled structure per batch shape.",
        "- The time split of a batched row spreads the batch's time evenly over its "
        "instants; its `conversion` is the layout and setup of the batch.",
        "- References (for the objective gap and, where the optimum is unique, the "
        "distance): the SVD for least norm and quadprog for QPs are exact; conic references "
        f"are Clarabel at 1e-10, not `solved` at: {', '.join(unsolved) or 'no sample'}.",
        "- The paper's root finding and the LCP have no objective: their accuracy is their "
        "own residuals (and, for the LCP, its complementarity).",
        "- Wall-clock times of one process on a shared machine; single runs of the "
        "per-instant loops, so rates carry noise: compare ratios within one run.",
    ]


def json_object(results: dict) -> dict:
    """The strict-JSON summary: throughput, pareto, success, profiles, solver optimality
    (the two-view tables), overhead, best.
    """
    def num(value):
        return None if value is None else json_number(value)

    return {
        "throughput": [{"formulation": e["formulation"], "solver": e["solver"],
                        "mode": e["mode"], "instants": e["instants"],
                        "instants_per_s": num(e["instants_per_s"]),
                        "success_rate": num(e["success_rate"]),
                        "setup_s": num(e["setup_s"]),
                        "max_equilibrium": num(e["max_equilibrium"]),
                        "solver_share": num(e["solver_share"]),
                        "iterations": num(e.get("iterations")),
                        "time_split_s": {k: num(v) for k, v in e["split_s"].items()}}
                       for e in results["summary"]],
        "pareto": [{"formulation": p["formulation"], "solver": p["solver"],
                    "tol": None if p["tol"] == "default" else p["tol"],
                    "time_s": num(p["time_s"]), "error": num(p["error"]),
                    "equilibrium": num(p["equilibrium"])}
                   for p in results["points"] if p["front"]],
        "success": [{k: num(r[k]) if isinstance(r[k], float) else r[k] for k in r}
                    for r in results["success"]],
        "profiles": [{"formulation": p["formulation"], "profile": p["profile"],
                      "clock": p["clock"], "level": p["level"], "solver": p["solver"],
                      "solved": num(p["solved"]),
                      "sgm_ratio": num(p["sgm_ratio"]),
                      "tau": [float(t) for t in TAUS], "curve": p["curve"]}
                     for p in results["profiles"]],
        "solver_optimality": [{k: num(v) if isinstance(v, float) else v
                               for k, v in r.items()} for r in results.get("views", [])],
        "overhead": [{k: num(v) if isinstance(v, float) else v for k, v in r.items()}
                     for r in results.get("overhead", [])],
        "best": [{k: num(v) if isinstance(v, float) else v for k, v in b.items()}
                 for b in best_table(results["summary"])],
    }
