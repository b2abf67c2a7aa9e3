"""Output of ``cardan bench``: CSV files, figures, the Markdown report and the JSON object."""

from __future__ import annotations

import csv
import datetime
import math
import numbers
import textwrap
from pathlib import Path

import numpy as np
from cardan_forces.formulations import BASELINE
from cardan_forces.solvers.record import ACCEPT
from cardan_forces.solvers.settings import REFERENCE_TOL

from . import files, images
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

COLUMNS = 2
"""Panels side by side on a page (each about :data:`images.COLUMN_IN` wide)."""
ROW_IN = 2.2
"""A row of panels (inches): its title, a plotting area of about 1.45 in, its axis labels."""
HEADER_LINE_IN = 0.2
"""A line of a page's title (inches), and the room above and below it."""
LEGEND_LINE_IN = 0.17
"""A line of a page's legend (inches), and the room below it."""
LEGEND_COLUMNS = 4
"""Entries side by side in a page's legend."""
MARKS_APART = 2
"""Steps of tau between the markers of two backends of one profile panel (each
backend's markers at tau steps of its own, so curves on one another still show theirs)."""
MARKS_EVERY = 8
"""The fewest steps of tau between two markers of one profile curve."""
PLOT_IN = (2.6, 1.45)
"""About the plotting area of a panel (inches): where markers overlap."""
MARKER_PT = 4.5
"""The Pareto figure's markers (points across)."""


def backend_styles(solvers) -> dict[str, tuple]:
    """One (colour, marker) per backend, fixed by the sorted names of every backend of
    one bench, so a backend looks the same in every panel and figure of that bench; 20
    dark colours (tab10's, then the darkest of tab20b's and tab20c's groups: a light
    one fades in print) with the markers cycled independently.
    """
    import matplotlib

    colours = (matplotlib.colormaps["tab10"].colors
               + matplotlib.colormaps["tab20b"].colors[::4]
               + matplotlib.colormaps["tab20c"].colors[::4])
    names = sorted(set(solvers))
    return {name: (colours[k % len(colours)], MARKERS[k % len(MARKERS)])
            for k, name in enumerate(names)}


def _header_lines(title: str) -> int:
    width = images.chars_across(images.PAGE_IN[0], images.TITLE_PT)
    return sum(len(textwrap.wrap(line, width)) for line in title.split("\n"))


def _legend_lines(entries: int) -> int:
    return max(1, math.ceil(entries / LEGEND_COLUMNS))


def _rows_per_page(title: tuple[str, str], entries: int) -> int:
    """As many rows of :data:`ROW_IN` as a page holds under the title (wrapped, with
    its page number) and over a legend of ``entries``.
    """
    header = HEADER_LINE_IN * (_header_lines(f"{title[0]}, page 9 of 9\n{title[1]}") + 1)
    legend = LEGEND_LINE_IN * (_legend_lines(entries) + 1)
    return max(1, int((images.PAGE_IN[1] - header - legend) // ROW_IN))


def page_count(count: int, title: tuple[str, str], entries: int) -> int:
    """Pages of ``count`` panels under ``title`` over a legend of ``entries``."""
    return max(1, math.ceil(count / (COLUMNS * _rows_per_page(title, entries))))


def _pages(count: int, title: tuple[str, str], entries: int):
    """Figures (the print style's, :func:`images.styled`) for ``count`` panels in
    :data:`COLUMNS` columns, as many pages as they take: yields each page's figure, its
    panels and its title (``title``: what, with ``page k of n`` where there are
    several, then how to read it).
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    per_page = COLUMNS * _rows_per_page(title, entries)
    total = page_count(count, title, entries)
    for page, first in enumerate(range(0, max(count, 1), per_page), 1):
        panels = min(per_page, count - first) if count else 1
        rows = math.ceil(panels / COLUMNS)
        what, how = title
        heading = f"{what}{'' if total == 1 else f', page {page} of {total}'}\n{how}"
        height = (HEADER_LINE_IN * (_header_lines(heading) + 1) + rows * ROW_IN
                  + LEGEND_LINE_IN * (_legend_lines(entries) + 1))
        fig, axes = plt.subplots(rows, COLUMNS, squeeze=False,
                                 figsize=(images.PAGE_IN[0], min(images.PAGE_IN[1], height)))
        for ax in axes.flat[panels:]:
            ax.set_visible(False)
        yield fig, list(axes.flat[:panels]), heading


def _log_ticks(ax, axis: str, span: tuple[float, float] | None = None) -> None:
    """Limits and labels of a log axis: ``span`` where given, else the data's with a
    margin of 8 % of their span in log (at least 0.05 decade); labels that never
    overlap: plain numbers at a few even steps over less than a factor of 6 (where the
    1-2-5 values may hold fewer than two), the 1-2-5 values over less than two decades,
    the decades otherwise; no labels on the minor ticks.
    """
    from matplotlib import ticker

    which = ax.xaxis if axis == "x" else ax.yaxis
    if span is None:
        low, high = ax.dataLim.intervalx if axis == "x" else ax.dataLim.intervaly
        if not (0 < low <= high and math.isfinite(high)):
            return
        pad = max(0.08 * math.log10(high / low), 0.05)
        span = (low / 10 ** pad, high * 10 ** pad)
    low, high = span
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


def _log_limits(values) -> tuple[float, float]:
    """A log axis' range over positive ``values``: :func:`images.limits` of their
    logarithms (the margins of every figure, in decades).
    """
    low, high = images.limits([np.log10(np.asarray(values, float))])
    return 10.0 ** low, 10.0 ** high


def _empty(ax, words: str) -> None:
    """A panel with nothing to draw says so in its middle."""
    ax.text(0.5, 0.5, words, transform=ax.transAxes, ha="center", va="center", color="0.3")


def _panel_title(ax, letter: int, text: str, note: str = "") -> None:
    """``(a) text`` over a panel, ``note`` (wrapped to the panel) under it."""
    width = images.chars_across(images.COLUMN_IN - 0.5, images.MIN_TEXT_PT + 1)
    lines = [f"({_letter(letter)}) {text}"] + (textwrap.wrap(note, width) if note else [])
    ax.set_title(images.typeset("\n".join(lines)), loc="left")


def _letter(k: int) -> str:
    letters = "abcdefghijklmnopqrstuvwxyz"
    return letters[k] if k < len(letters) else letters[k // 26 - 1] + letters[k % 26]


def _finish(fig, styles: dict, shown, title: str, extra=(), line=":", hollow=False) -> None:
    """The page's ``title`` above its panels and one legend under them: each backend
    ``shown`` on the page with its colour and marker, then ``extra`` (label, line
    style, marker) entries, each the label of a line drawn in the panels.
    """
    from matplotlib.lines import Line2D

    handles = [Line2D([], [], color=styles[s][0], marker=styles[s][1], ls=line,
                      mfc="none" if hollow else styles[s][0], label=s)
               for s in sorted(set(shown))]
    handles += [Line2D([], [], color="k", ls=ls, marker=marker, ms=FRONT_DOT_PT, label=label)
                for label, ls, marker in extra]
    width = images.chars_across(images.PAGE_IN[0], images.TITLE_PT)
    fig.suptitle(images.typeset("\n".join(textwrap.fill(line, width)
                                          for line in title.split("\n"))))
    if handles:
        fig.legend(handles=handles, loc="lower center", ncol=min(LEGEND_COLUMNS, len(handles)))
        fig.canvas.draw()
        below = fig.legends[0].get_window_extent().height / fig.dpi + 0.08
    else:
        below = 0.05
    fig.tight_layout(rect=(0, below / fig.get_figheight(), 1, 1), h_pad=0.8, w_pad=1.5)


def _written(figs: list, path: Path, formats) -> list[Path]:
    """The pages ``figs`` of one figure saved as ``path`` (:func:`images.save_pages`:
    ``path.<format>``, or a page each, ``path-1.<format>``, ..., where there are
    several; a PDF holds them all), then closed.
    """
    import matplotlib.pyplot as plt

    written = images.save_pages(figs, path.with_suffix(""), formats)
    for fig in figs:
        plt.close(fig)
    return written


def plot_pareto(points: list[dict], path: Path, formats=("png",), styles=None,
                scene: str = "") -> list[Path]:
    """:func:`pareto_pages` written as ``path.<format>`` for each of ``formats``."""
    return _written(pareto_pages(points, styles, scene), path, formats)


FRONT = "Pareto front"
FRONT_DOT_PT = 2.5
"""The front's points: a black dot in their open markers (a front of one point shows)."""
ERROR_FLOOR = 1e-17
"""A worst optimality measure of exactly 0 is drawn here (a log axis has no 0)."""


def pareto_pages(points: list[dict], styles=None, scene: str = "") -> list:
    """Log-log time per instant vs worst optimality measure, one panel per formulation
    (:data:`COLUMNS` side by side, as many pages as they take, in
    :func:`images.styled`), each backend in its colour and marker (:func:`backend_styles`,
    one legend a page; each line labelled with its backend), its points (one per
    tolerance setting) open markers joined by a dotted line in time order, so that
    points of several backends at one place all show; the front (no answer both faster
    and more accurate) as a step line; 0 drawn at :data:`ERROR_FLOOR`; the y range
    :func:`images.limits` of the measures' logarithms; a panel without an answer says
    so. ``scene``: named in the title. Returns the pages' figures.
    """
    styles = styles or backend_styles(p["solver"] for p in points)
    names, title, entries = _pareto_layout(points, scene)
    figs, done = [], 0
    with images.styled():
        for fig, axes, heading in _pages(len(names), title, entries):
            shown, fronts = set(), False
            for ax, name in zip(axes, names[done:]):
                shown |= _pareto_panel(ax, done, name, points, styles)
                fronts |= any(line.get_label() == FRONT for line in ax.get_lines())
                done += 1
            _finish(fig, styles, shown, heading, [(FRONT, "-", ".")] if fronts else [],
                    hollow=True)
            figs.append(fig)
    return figs


def _pareto_layout(points: list[dict], scene: str = "") -> tuple:
    """The Pareto figure's panels (formulations), title and legend entries."""
    names = list(dict.fromkeys(p["formulation"] for p in points))
    title = _title("Time against accuracy per formulation", scene,
                   "each open marker one tolerance setting of a backend, dotted lines join a "
                   "backend's settings in time order; the black step line joins the points of "
                   "the Pareto front (black dots: no answer both faster and more accurate); an "
                   f"exact 0 is drawn at {ERROR_FLOOR:g}")
    return names, title, len({p["solver"] for p in points}) + 1


def _pareto_panel(ax, k: int, name: str, points: list[dict], styles: dict) -> set:
    """The ``k``-th panel, formulation ``name``; the backends drawn."""
    mine = [p for p in points if p["formulation"] == name and math.isfinite(p["error"])]
    shown = set()
    for solver in dict.fromkeys(p["solver"] for p in mine):
        pts = sorted((p for p in mine if p["solver"] == solver), key=lambda p: p["time_s"])
        colour, marker = styles[solver]
        ax.plot([p["time_s"] for p in pts], [max(p["error"], ERROR_FLOOR) for p in pts],
                marker=marker, color=colour, mfc="none", mew=0.9, ms=4.5, ls=":", lw=0.8,
                label=solver)
        shown.add(solver)
    front = sorted((p for p in mine if p["front"]), key=lambda p: p["time_s"])
    if front:
        ax.step([p["time_s"] for p in front], [max(p["error"], ERROR_FLOOR) for p in front],
                "k-", marker=".", ms=FRONT_DOT_PT, where="post", lw=1.0, label=FRONT,
                zorder=1.5)
    ax.set(xscale="log", yscale="log", xlabel="time per instant [s]",
           ylabel="worst optimality measure [-]")
    if mine:
        _log_ticks(ax, "x")
        _log_ticks(ax, "y", _log_limits([max(p["error"], ERROR_FLOOR) for p in mine]))
    else:
        _empty(ax, EMPTY_PARETO)
    groups = on_one_another(ax, mine)
    _panel_title(ax, k, name, "on one another: " + "; ".join(
        f"{', '.join(g)} ({t:.2g} s, {e:.2g})" for g, (t, e) in groups) if groups else "")
    return shown


def on_one_another(ax, points: list[dict]) -> list[tuple[tuple[str, ...], tuple]]:
    """Points of several backends whose markers lie on one another in ``ax`` (centres
    closer than a marker, :data:`MARKER_PT`, on a plotting area of about
    :data:`PLOT_IN`): each group's backends (in the points' order) and where (time s,
    measure), the group's middle; where the open markers crowd, the panel names them.
    """
    if not points:
        return []
    place = ax.transScale + ax.transLimits  # data -> the panel's fraction
    xy = place.transform([(p["time_s"], max(p["error"], ERROR_FLOOR)) for p in points])
    inches = xy * np.array(PLOT_IN)
    near = MARKER_PT / 72.0
    group = list(range(len(points)))

    def root(i):
        while group[i] != i:
            i = group[i]
        return i

    for i in range(len(points)):
        for j in range(i):
            if np.hypot(*(inches[i] - inches[j])) < near:
                group[root(i)] = root(j)
    found = {}
    for i in range(len(points)):
        found.setdefault(root(i), []).append(i)
    out = []
    for members in found.values():
        names = tuple(dict.fromkeys(points[i]["solver"] for i in members))
        if len(names) > 1:
            t = float(np.exp(np.mean([np.log(points[i]["time_s"]) for i in members])))
            e = float(np.exp(np.mean([np.log(max(points[i]["error"], ERROR_FLOOR))
                                      for i in members])))
            out.append((names, (t, e)))
    return out


def _title(what: str, scene: str, how: str) -> tuple[str, str]:
    return f"{what}{f' (scene {scene})' if scene else ''}", how


def plot_profiles(profiles: list[dict], path: Path, formats=("png",), styles=None,
                  scene: str = "") -> list[Path]:
    """:func:`profiles_pages` written as ``path.<format>`` for each of ``formats``."""
    return _written(profiles_pages(profiles, styles, scene), path, formats)


def profiles_pages(profiles: list[dict], styles=None, scene: str = "") -> list:
    """Dolan-Moré curves on the solver's time, one panel per formulation x profile
    (:data:`COLUMNS` side by side, as many pages as they take, in
    :func:`images.styled`), each backend in its colour and marker (one legend a page;
    each line labelled with its backend) with its markers at tau steps of its own in
    the panel, so that curves on one another (many lie on 1) each show theirs; curves
    equal at every tau (:func:`images.coinciding`) drawn in interleaved dashes
    (:func:`images.interleave`) and named under the panel's title; the y range
    :func:`images.limits` of the shares and 0 and 1; a panel where no solve reached the
    level says so and draws nothing. ``scene``: named in the title. Returns the pages'
    figures.
    """
    profiles = [p for p in profiles if p["clock"] == "solver"]
    styles = styles or backend_styles(p["solver"] for p in profiles)
    panels, title, entries = _profiles_layout(profiles, scene)
    figs, done = [], 0
    with images.styled():
        for fig, axes, heading in _pages(len(panels), title, entries):
            shown = set()
            for ax, panel in zip(axes, panels[done:]):
                shown |= _profile_panel(ax, done, panel, profiles, styles)
                done += 1
            _finish(fig, styles, shown, heading, line="-")
            figs.append(fig)
    return figs


def _profiles_layout(profiles: list[dict], scene: str = "") -> tuple:
    """The profiles figure's panels (formulation, profile) on the solver's time, title
    and legend entries.
    """
    profiles = [p for p in profiles if p["clock"] == "solver"]
    panels = list(dict.fromkeys((p["formulation"], p["profile"]) for p in profiles))
    title = _title("Performance profiles on the solver's time", scene,
                   "the share of instants a backend solves to the panel's level within tau "
                   "times the fastest backend's time")
    return panels, title, len({p["solver"] for p in profiles})


def figure_files(stem: str, pages: int, fmt: str = "png") -> str:
    """The files of a figure of ``pages`` (:func:`images.save_pages`' names), in words."""
    names = [f"`{s.name}.{fmt}`" for s in images.page_stems(Path(stem), pages)]
    return names[0] if pages == 1 else f"{', '.join(names)} (one page each)"


def pareto_files(points: list[dict]) -> str:
    """The Pareto figure's PNG files, in words."""
    names, title, entries = _pareto_layout(points)
    return figure_files("bench_pareto", page_count(len(names), title, entries))


def profiles_files(profiles: list[dict]) -> str:
    """The profiles figure's PNG files, in words."""
    panels, title, entries = _profiles_layout(profiles)
    return figure_files("bench_profiles", page_count(len(panels), title, entries))


def _profile_panel(ax, k: int, panel: tuple, profiles: list[dict], styles: dict) -> set:
    """The ``k``-th panel, ``(formulation, profile)``; the backends drawn."""
    formulation, name = panel
    curves = [p for p in profiles if (p["formulation"], p["profile"]) == panel]
    reached = any(max(p["curve"]) > 0 for p in curves)
    drawn = {p["solver"]: np.asarray(p["curve"], float) for p in curves} if reached else {}
    groups = images.coinciding(drawn, images.COINCIDE * 1.0)  # shares span 0 to 1
    step = max(MARKS_APART * len(drawn), MARKS_EVERY)
    for j, (solver, curve) in enumerate(drawn.items()):
        group = next((g for g in groups if solver in g), (solver,))
        colour, marker = styles[solver]
        ax.step(TAUS, curve, where="post", color=colour, marker=marker,
                ls=images.interleave(group.index(solver), len(group)),
                markevery=(MARKS_APART * j + 1, step), label=solver, clip_on=False)
    level = next(p["level"] for p in curves)
    ax.set(xscale="log", xlim=(TAUS[0], TAUS[-1]),
           ylim=images.limits([*drawn.values(), [0.0, 1.0]]),
           xlabel="tau: solver time / fastest [-]", ylabel="share of instants [-]")
    note = "; ".join(" = ".join(g) for g in groups)
    _panel_title(ax, k, f"{formulation}, {name} (level {level:g})",
                 f"equal at every tau: {note}" if note else "")
    if not reached:
        _empty(ax, EMPTY_PROFILE)
    return set(drawn)


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
             f"time) in {profiles_files(profiles)}, points in `bench_profiles.csv`.", "",
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
             f"Figure: {pareto_files(points)}.", "",
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
        f"are Clarabel at {REFERENCE_TOL:g}, not `solved` at: "
        f"{', '.join(unsolved) or 'no sample'}.",
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
