"""``cardan report``: one scene's bearing and joint loads over time, with the rigid
solution set (DESIGN §4; any scene, its own names).

At ``--instants`` instants spread over the scene's window (by default enough to
resolve the intermediate shaft's twice-per-revolution fluctuation,
:func:`default_instants`): every contact force
component of the operator, the member ``positive`` picks (least force, end faces
pushing only), the interval ``[min, max]`` over every rigid solution with end faces
>= 0 (two LPs per component that is not determinate, the band; a determinate one's
interval is its value), and whether the component is determinate.
Written as ``report.csv`` (long format, with each component's unit), the figure (one
panel per contact, unit and scale group, a slip joint's forces in N apart from its
moments in N m, a few-newton component apart from a kilonewton one; each component's
legend entry, below its panel, says whether it is determinate or which side of its set
is open) on pages of print size: ``report-1.png``, ``report-2.png``, ... (``report.png``
for one page; ``.svg`` likewise, ``report.pdf`` every page in one file, with
``--format``), and ``report.md`` (the determinacy table, the named modes and how the
figure is drawn). With ``--engine``, MuJoCo's forces under its
default softness (:mod:`cardan_forces.experiments.engine`) are drawn as open circles on
every panel and ``report.md`` says how they sit in the rigid set (:class:`EngineOverlay`).
"""

from __future__ import annotations

import csv
import math
import textwrap
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from cardan_forces.driveline import engine_mujoco
from cardan_forces.driveline.determinacy import determinacy
from cardan_forces.driveline.dynamics import simulate
from cardan_forces.driveline.equilibrium import Link, Operator, build_operator
from cardan_forces.driveline.loading import load_scene
from cardan_forces.driveline.release import named_modes
from cardan_forces.driveline.scene import MAX_INSTANTS
from cardan_forces.experiments import engine, files, images
from cardan_forces.experiments import progress as bars
from cardan_forces.experiments.arguments import UsageError, whole_number
from cardan_forces.experiments.environment import number_text
from cardan_forces.experiments.images import format_list
from cardan_forces.experiments.study import interval_history, solve_over_time
from cardan_forces.formulations import SELECTION
from cardan_forces.formulations.convex import NotApplicable

INSTANTS = 41
"""The fewest instants of the report by default (each costs two LPs per component)."""
PER_PERIOD = 10
"""Instants per period of the fastest periodic load by default: the intermediate
shaft's twice-per-revolution fluctuation at the input's highest speed (fewer alias it
into zig-zags)."""


def default_instants(scene) -> int:
    """Instants that resolve ``scene``'s fastest periodic load: :data:`PER_PERIOD` per
    period of the twice-per-revolution fluctuation (period ``pi / omega_max``, the
    input's highest speed in rad/s on the scene's own grid), at least :data:`INSTANTS`,
    at most the scene's grid.
    """
    grid = scene.time.instants()
    omega = float(np.max(np.abs(simulate(scene, grid).omega[0])))
    span = float(grid[-1] - grid[0])
    wanted = math.ceil(PER_PERIOD * span * omega / math.pi) + 1
    return int(min(len(grid), max(INSTANTS, wanted)))


def histories(op: Operator, progress=None) -> dict[str, np.ndarray]:
    """``value``, ``min``, ``max`` (T, n; NaN where unbounded or not solved) and
    ``determinate`` (T, n) over the operator's instants (a determinate component's
    interval is its one value).
    """
    chosen = solve_over_time(op, SELECTION)
    say = None if progress is None else (lambda m: progress(f"report: {m}"))
    with bars.ticks(len(op.t), "report: intervals", "instant", say) as tick:
        sets = interval_history(op, progress=tick)
    return {"value": chosen.forces, "min": sets.min, "max": sets.max,
            "determinate": sets.determinate}


def write_csv(op: Operator, h: dict[str, np.ndarray], path: Path,
              overlay: EngineOverlay | None = None) -> None:
    """Long format, one row per component x instant; an empty cell where the answer
    is missing (not solved) or an end of the interval is unbounded. With ``overlay``, a
    column ``engine_N``: MuJoCo's value (empty before its settling).
    """
    extra = ["engine_N"] if overlay is not None else []
    with files.replacing(path, newline="") as f:
        w = csv.writer(f)
        w.writerow(["t_s", "component", "contact", "kind", f"{SELECTION}_N", "min_N", "max_N",
                    "determinate", "unit", *extra])
        for c in op.contacts:
            for j, unit in zip(c.columns, c.units or ("N",) * len(c.columns)):
                for i, t in enumerate(op.t):
                    w.writerow([f"{t:.6g}", op.names[j], c.name, c.kind,
                                *(number_text(h[k][i, j], ".9g", "")
                                  for k in ("value", "min", "max")),
                                bool(h["determinate"][i, j]), unit,
                                *(number_text(overlay.forces[i, j], ".9g", "")
                                  for _ in extra)])


@dataclass(frozen=True)
class EngineOverlay:
    """MuJoCo's forces at the report's instants under its default softness, from a
    forward simulation of the scene's window, and how they sit in the rigid set. Each
    is read at the engine step nearest its instant (at most half a step away, 1.25e-4 s
    on ``paper``: an instant off the scene's grid adds ~1e-5 of the load to the
    determinate error).

    ``forces`` (T, n; N, N m) is NaN before the engine's settling (the line starts
    unloaded and sags into its soft constraints: :func:`engine.settle_s`), where it is
    not compared; ``comparisons`` one per settled instant (residual of ``A x = b``,
    largest determinate error, the indeterminate components outside their interval,
    the distance from the drawn ``positive`` answer).
    """

    version: str
    forces: np.ndarray
    settle_s: float
    comparisons: tuple[engine.InstantComparison, ...]
    indeterminate: int
    steps: int
    wall_s: float


def check_engine(scene) -> str:
    """MuJoCo's version, before any work; :class:`NotApplicable` (one line) where the
    scene has an element the engine cannot express or MuJoCo is not installed.
    """
    try:
        engine_mujoco.check_expressible(scene)
        return engine_mujoco.mujoco_version()
    except engine_mujoco.EngineUnsupported as err:
        raise NotApplicable(str(err)) from None


def engine_overlay(op: Operator, h: dict[str, np.ndarray], version: str) -> EngineOverlay:
    """MuJoCo (the first of :data:`engine.SETTINGS`, its default softness) on ``op``,
    compared at every settled instant with the report's intervals ``h``.
    """
    run = engine.engine_runs(op, engine.SETTINGS[:1])[engine.SETTINGS[0].label]
    settle = engine.settle_s({"": run})
    settled = op.t - op.t[0] >= settle
    comparisons, indeterminate = [], 0
    for i in np.flatnonzero(settled):
        det = determinacy(op, int(i))
        interval = np.stack([np.nan_to_num(h["min"][i], nan=-np.inf),
                             np.nan_to_num(h["max"][i], nan=np.inf)], axis=1)
        drawn = h["value"][i]
        forms = {SELECTION: drawn} if np.all(np.isfinite(drawn)) else {}
        comparisons.append(engine.compare_instant(op, int(i), "default", run.forces[i], det,
                                                  interval, forms))
        indeterminate += int(np.sum(~det.determinate))
    forces = np.where(settled[:, None], run.forces, np.nan)
    return EngineOverlay(version, forces, settle, tuple(comparisons), indeterminate,
                         run.steps, run.wall_s)


def engine_lines(op: Operator, overlay: EngineOverlay) -> list[str]:
    """``report.md``'s MuJoCo section: what was run, and over the settled instants the
    residual, the determinate agreement and the inside/outside counts.
    """
    rows, soft = overlay.comparisons, engine.SETTINGS[0]
    outside = [n for c in rows for n in c.outside]
    span = op.t[-1] - op.t[0]
    lines = ["", "## MuJoCo beside the rigid set", "",
             f"MuJoCo {overlay.version}, forward simulation of the scene from its start under "
             f"its default softness (`solref=\"{soft.solref()}\"`, "
             f"`solimp=\"{soft.solimp}\"`), every bearing a soft `connect` equality; its "
             "forces are the open circles on each panel, in the component's colour. "
             f"Compared at the {len(rows)} of {len(op.t)} instants "
             f"after the engine's settling ({overlay.settle_s:g} s from the start: the line "
             "starts unloaded and sags into its constraints; not drawn before it).", ""]
    if not rows:
        return lines + ["No instant after the settling: nothing compared."]
    closest = [c.closest[1] for c in rows if c.closest[0] == SELECTION]
    lines += [
        f"- residual of A x = b (relative): at most {_g(max(c.residual for c in rows))}",
        "- determinate components: MuJoCo against the rigid value, at most "
        f"{_g(max(c.determinate_error_N for c in rows))} (N, N m)",
        f"- indeterminate components inside their interval: {overlay.indeterminate - len(outside)}"
        f" of {overlay.indeterminate} (component x instant); outside: "
        + (", ".join(f"{n} ({outside.count(n)})" for n in dict.fromkeys(outside)) or "none"),
        f"- distance from the `{SELECTION}` line, ||x_engine - x|| / ||x||: at most "
        f"{_g(max(closest, default=np.nan))}: within the set, the engine's softness, not the "
        "machine, picks which member (`cardan engine` varies it)",
        f"- cost: {overlay.wall_s:.1f} s for {span:g} s simulated ({overlay.steps} RK4 steps)"]
    return lines


def _g(value: float) -> str:
    return number_text(value, ".3g")


UNIT_AXIS = {"N": "force [N]", "N m": "moment [N m]"}
"""The y label of a panel by the unit of its components."""

@dataclass(frozen=True)
class Panel:
    """One panel: components of one contact that share a unit (a slip joint's forces, N,
    and moments, N m, get one each, so a 2500 N m torque does not flatten a shear of tens
    of newtons) and a scale (:data:`SCALE_GROUP`: a bearing's 560 N vertical load does
    not flatten its few-newton horizontal ones). ``split``: the contact's components of
    this unit span several panels, so the title names them.
    """

    contact: Link
    unit: str
    columns: tuple[int, ...]
    names: tuple[str, ...] = ()
    split: bool = False

    @property
    def title(self) -> str:
        kind = self.contact.element_kind.words(self.contact)
        what = {"N": "forces", "N m": "moments"}[self.unit] \
            if len(set(self.contact.units)) > 1 else ""
        return (f"{self.contact.name} ({kind}{', ' + what if what else ''})"
                + (f": {', '.join(self.names)}" if self.split else ""))


SCALE_GROUP = 10.0
"""Components of one panel span at most this factor in their largest magnitude (of the
value and finite ends); a smaller one goes to a panel of its own scale (a component
below :data:`~.images.SAME_RTOL` of the panel's largest counts as zero and stays)."""


def panels(op: Operator, h: dict[str, np.ndarray] | None = None) -> list[Panel]:
    """The report's panels, contact by contact, one per unit of its components and, with
    the histories ``h``, per scale group (:data:`SCALE_GROUP`).
    """
    out = []
    for c in op.contacts:
        units = c.units or ("N",) * len(c.columns)
        for unit in dict.fromkeys(units):
            columns = [j for j, u in zip(c.columns, units) if u == unit]
            groups = _scale_groups(h, columns) if h is not None else [columns]
            for group in groups:
                out.append(Panel(c, unit, tuple(group),
                                 tuple(op.names[j][len(c.name) + 1:] for j in group),
                                 len(groups) > 1))
    return out


def _scale_groups(h: dict[str, np.ndarray], columns: list[int]) -> list[list[int]]:
    """``columns`` in groups whose largest magnitudes lie within :data:`SCALE_GROUP`."""
    size = {j: max(float(np.nanmax(np.abs(np.where(np.isfinite(h[k][:, j]), h[k][:, j],
                                                        np.nan)), initial=0.0))
                   for k in ("value", "min", "max")) for j in columns}
    top = max(size.values(), default=0.0)
    groups: list[list[int]] = []
    for j in sorted(columns, key=lambda j: -size[j]):
        if groups and size[j] <= images.SAME_RTOL * top:  # zero: drawn beside any scale
            groups[0].append(j)
        elif groups and size[j] * SCALE_GROUP >= size[groups[-1][0]]:
            groups[-1].append(j)
        else:
            groups.append([j])
    return sorted(sorted(g) for g in groups)


def set_words(lo: np.ndarray, hi: np.ndarray, determinate: np.ndarray) -> str:
    """One component's rigid solution set over the instants, in words: ``determinate``
    (one value, every instant), ``bounded`` (a band) or which side is open, and at how
    many instants where not at all of them. ``lo``, ``hi``: its ends (NaN: open).
    """
    n = len(lo)
    if determinate.all():
        return "determinate"
    below, above = int(np.sum(~np.isfinite(lo))), int(np.sum(~np.isfinite(hi)))
    if not below and not above:
        return "bounded" if not determinate.any() else \
            f"bounded, determinate at {int(determinate.sum())} of {n}"

    def side(count: int, word: str) -> str:
        return word if count == n else f"{word} at {count} of {n}"

    if below == above == n:
        return "open below and above"
    return "open " + " and ".join(side(k, w) for k, w in ((below, "below"), (above, "above"))
                                  if k)


BOTH_OPEN_MARK = "$\\updownarrow$"
"""The marker along a component whose set is open on both sides (any value)."""


@dataclass(frozen=True)
class Drawing:
    """What a panel draws, found before it is drawn (the page's layout reserves its
    legend's lines): the y range, each component's legend entry and its line style
    (interleaved dashes for the components whose lines lie on one another).
    """

    ylim: tuple[float, float]
    entries: tuple[str, ...]
    styles: tuple


def drawing(op: Operator, h: dict[str, np.ndarray], panel: Panel,
            engine_forces: np.ndarray | None = None) -> Drawing:
    """:class:`Drawing` of ``panel``: the y range holds the lines, every finite end and
    the engine's values; an entry says the component's set (:func:`set_words`), that
    its line lies on its set's finite end or on another component's, and within how
    much (so every entry names a line that shows or says where it is).
    """
    held = [h[k][:, j] for j in panel.columns for k in ("min", "max", "value")]
    held += [] if engine_forces is None else [engine_forces[:, j] for j in panel.columns]
    low, high = images.limits(held)
    tol = images.COINCIDE * (high - low)
    values = {_name(op, panel, j): h["value"][:, j] for j in panel.columns}
    together = images.coinciding(values, tol)
    entries, styles = [], []
    for j, name in zip(panel.columns, values):
        lo, hi, both = h["min"][:, j], h["max"][:, j], np.isfinite(h["min"][:, j] + h["max"][:, j])
        free = ~np.isfinite(lo) & ~np.isfinite(hi) & ~h["determinate"][:, j]
        words = [set_words(lo, hi, h["determinate"][:, j])
                 + (" (\u2195 on the line)" if free.any() else "")]
        words += [f"the line on its {word} bound" for bound, word in ((lo, "lower"), (hi, "upper"))
                  if not both.all()
                  and images.on_bound({name: values[name]}, np.where(both, np.nan, bound), tol)]
        group = next((g for g in together if name in g), (name,))
        if group.index(name):
            words.append(f"= {group[0]} within "
                         f"{images.spread(values, (group[0], name)):.2g} {panel.unit}")
        entries.append(textwrap.fill(f"{name}: " + "; ".join(words), LEGEND_CHARS))
        styles.append(images.interleave(group.index(name), len(group)))
    if engine_forces is not None:
        entries.append(textwrap.fill(ENGINE_LABEL, LEGEND_CHARS))
    return Drawing((low, high), tuple(entries), tuple(styles))


def _name(op: Operator, panel: Panel, j: int) -> str:
    return op.names[j][len(panel.contact.name) + 1:] or "force"


def _draw(ax, op: Operator, h: dict[str, np.ndarray], panel: Panel,
          engine_forces: np.ndarray | None = None, found: Drawing | None = None) -> None:
    """One panel (its :func:`drawing`, ``found`` where known): each component's
    selected value as a line, its rigid set in the same colour: shaded where both ends
    are finite; where one side is open, the finite end dashed with triangles pointing to
    the open side; where both are, double arrows along the line; ``engine_forces``
    (T, n), where given, as open circles in the same colour. Components whose lines lie
    on one another are drawn in interleaved dashes, each colour showing in turn. The
    legend sits below the panel.
    """
    found = found or drawing(op, h, panel, engine_forces)
    step = max(1, len(op.t) // 10)
    for k, (j, label, style) in enumerate(zip(panel.columns, found.entries, found.styles)):
        _draw_component(ax, op.t, h, j, f"C{k}", (k * step // len(panel.columns), step),
                        label, style)
        if engine_forces is not None:
            ax.plot(op.t, engine_forces[:, j], ls="none", marker="o", ms=3.5, mfc="none",
                    mew=0.9, color=f"C{k}", zorder=4,
                    label=found.entries[-1] if k == 0 else "_")
    ax.set_ylim(*found.ylim)
    ax.set_title(textwrap.fill(panel.title, LEGEND_CHARS), loc="left")
    ax.set_xlabel("time t [s]")
    ax.set_ylabel(UNIT_AXIS.get(panel.unit, f"[{panel.unit}]"))
    ax.grid(True)
    ax.legend(loc="upper left", bbox_to_anchor=(-0.02, -LEGEND_DROP_IN / PANEL_IN[1]),
              borderaxespad=0.0, handlelength=2.4)


def _draw_component(ax, t, h: dict[str, np.ndarray], j: int, colour: str, every, label: str,
                    style) -> None:
    """One component ``j`` of a panel (:func:`_draw`) in ``colour``: its line in
    ``style``, the double arrows where its set is open on both sides (at the instants
    ``every``), its band and its open sets' finite ends.
    """
    lo, hi, value = h["min"][:, j], h["max"][:, j], h["value"][:, j]
    both = np.isfinite(lo) & np.isfinite(hi)
    free = ~np.isfinite(lo) & ~np.isfinite(hi) & ~h["determinate"][:, j]
    ax.plot(t, value, lw=1.2, color=colour, zorder=3, label=label, ls=style)
    if free.any():
        ax.plot(t, np.where(free, value, np.nan), ls="none", marker=BOTH_OPEN_MARK,
                ms=8, color=colour, markevery=every, zorder=3)
    ax.fill_between(t, np.where(both, lo, np.nan), np.where(both, hi, np.nan),
                    color=colour, alpha=0.2, lw=0, zorder=1)
    for bound, other, marker in ((lo, hi, "^"), (hi, lo, "v")):  # open above: ^
        one = np.where(np.isfinite(bound) & ~np.isfinite(other), bound, np.nan)
        if np.isfinite(one).any():
            ax.plot(t, one, ls="--", lw=0.9, color=colour, marker=marker, ms=4,
                    markevery=(0, every[1]), zorder=2)


ENGINE_LABEL = "MuJoCo, default softness (open circles, each component's colour)"
MARGINS_IN = {"left": 0.75, "right": 0.15, "top": 0.15, "line": 0.17, "title": 0.32,
              "wspace": 0.85, "axis": 0.42, "entry": 0.135, "gap": 0.12}
"""A page's margins and the room around each panel (inches): ``title`` above a panel
for its title (two lines at most), ``axis`` below it for its tick and axis labels,
``entry`` per entry of the longest legend below a panel and ``gap`` under it; ``line``
per line of the page's title below ``top`` (a fixed layout: a constrained one
measures every panel's text twice, a large share of the figure's time)."""
COLUMNS = 2
"""Panels side by side on a page."""
PANEL_IN = ((images.PAGE_IN[0] - MARGINS_IN["left"] - MARGINS_IN["right"]
             - (COLUMNS - 1) * MARGINS_IN["wspace"]) / COLUMNS, 1.3)
"""A panel's plotting area (inches, its printed size): the width a page's columns
leave, the least height (a page's rows share what the page has over it)."""
LEGEND_CHARS = images.chars_across(PANEL_IN[0] - 0.3)
"""A legend entry's line below a panel (characters: the panel's width less the
legend's handle; a longer entry is wrapped)."""
LEGEND_DROP_IN = 0.36
"""How far below a panel its legend starts (inches): under the axis label."""


def write_figure(op: Operator, h: dict[str, np.ndarray], stem: Path,
                 formats=("png",), overlay: EngineOverlay | None = None) -> list[Path]:
    """Every :func:`panels` panel on pages of a grid (:func:`pages`), written as
    ``stem.<format>`` per format (:func:`images.save_pages`: a PDF of every page, a PNG
    or SVG per page); with ``overlay``, MuJoCo's forces on each.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    with images.styled():
        figs = pages(op, h, overlay)
        paths = images.save_pages(figs, stem, formats)
    for fig in figs:
        plt.close(fig)
    return paths


def pages(op: Operator, h: dict[str, np.ndarray], overlay: EngineOverlay | None = None
          ) -> list:
    """The report's figure, :func:`panels` in :data:`COLUMNS` columns on as many pages
    of :data:`images.PAGE_IN` as they take (make them in :func:`images.styled`).
    """
    engine_forces = None if overlay is None else overlay.forces
    grid = [(p, drawing(op, h, p, engine_forces)) for p in panels(op, h)]
    below = MARGINS_IN["entry"] * max(sum(e.count("\n") + 1 for e in found.entries)
                                      for _, found in grid)
    rows = _rows_per_page(below)
    per_page = rows * COLUMNS
    count = -(-len(grid) // per_page)
    return [_page(op, h, grid[k:k + per_page], rows, below, engine_forces,
                  (k // per_page + 1, count)) for k in range(0, len(grid), per_page)]


def _room(below: float) -> tuple[float, float]:
    """A row's height besides its plotting area (inches) and a page's room for rows."""
    m = MARGINS_IN
    return (m["title"] + m["axis"] + below + m["gap"],
            images.PAGE_IN[1] - m["top"] - 2 * m["line"])


def _rows_per_page(below: float) -> int:
    """As many rows as a page holds with plotting areas :data:`PANEL_IN` tall or more."""
    extra, room = _room(below)
    return max(1, int(room // (PANEL_IN[1] + extra)))


def _page(op: Operator, h, grid: list[tuple[Panel, Drawing]], rows: int, below: float,
          engine_forces: np.ndarray | None, page: tuple[int, int]):
    """One page: the panels ``grid`` (with their drawings) in ``rows`` rows, its title
    saying which page.
    """
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(rows, COLUMNS, figsize=images.PAGE_IN, squeeze=False)
    for ax, (panel, found) in zip(axes.ravel(), grid):
        _draw(ax, op, h, panel, engine_forces, found)
    for ax in axes.ravel()[len(grid):]:
        ax.set_visible(False)
    title = fig.suptitle(
        f"{op.scene.name}: contact forces over time"
        + (f", page {page[0]} of {page[1]}" if page[1] > 1 else "")
        + f"\nlines: the {SELECTION} selection; same colour: each component's rigid set "
        "(report.md says how it is drawn)", va="top")
    _place(fig, rows, title, below)
    return fig


def _place(fig, rows: int, title, below: float) -> None:
    """Panels and title at :data:`MARGINS_IN` on a page of ``rows`` rows, ``below``
    inches more under each row for its legends; the rows share the page's height.
    """
    width, height = fig.get_size_inches()
    m = MARGINS_IN
    top = m["top"] + m["line"] * (title.get_text().count("\n") + 1) + m["title"]
    extra, _ = _room(below)
    panel_h = (height - top - rows * extra + m["title"]) / rows
    fig.subplots_adjust(left=m["left"] / width, right=1 - m["right"] / width,
                        bottom=(extra - m["title"]) / height, top=1 - top / height,
                        wspace=m["wspace"] / PANEL_IN[0], hspace=extra / panel_h)
    title.set_y(1 - m["top"] / height)


def figure_lines(written, overlay: EngineOverlay | None) -> list[str]:
    """``report.md``'s section on the figure: its files and how it is drawn."""
    return ["", "## Figure", "",
            "Files: " + ", ".join(f"`{p.name}`" for p in written) + " (a PDF holds every "
            "page; a PNG or an SVG is one page).", "",
            f"Each panel: one contact's components of one unit and scale, over time; the "
            f"`{SELECTION}` selection as a line and, in the same colour, the component's "
            "rigid solution set: shaded where both ends are finite; where one side is open, "
            "the finite end dashed with triangles pointing to the open side; double arrows "
            "on the line where both sides are (any value). Each panel has its own scale. "
            "Components whose lines lie on one another are drawn in interleaved dashes, "
            "each colour in turn; the legend below the panel names them and how close they "
            "are."
            + (" MuJoCo's forces are open circles in the component's colour (default "
               f"softness, from its settling on, {overlay.settle_s:g} s)."
               if overlay is not None else "")]


def write_md(op: Operator, h: dict[str, np.ndarray], modes, path: Path,
             overlay: EngineOverlay | None = None, images_written: tuple = ()) -> None:
    """The determinacy table, the named modes, with ``images_written`` the figure's
    section (:func:`figure_lines`) and with ``overlay`` MuJoCo's section.
    """
    det = determinacy(op, 0)
    lines = [f"# Loads of scene {op.scene.name}", "", op.scene.description, "",
             f"{len(op.t)} instants from {op.t[0]:g} to {op.t[-1]:g} s; rank {det.rank}, "
             f"nullity {det.nullity} at the first; `{SELECTION}` answer and the interval "
             "over all rigid solutions with end faces >= 0.", "",
             "| component | determinate (all instants) | largest interval width (N) |",
             "|---|---|---|"]
    width = np.nanmax(np.where(np.isfinite(h["max"] - h["min"]), h["max"] - h["min"], np.inf),
                      axis=0)
    for j, name in enumerate(op.names):
        lines.append(f"| {name} | {'yes' if h['determinate'][:, j].all() else 'no'} | "
                     f"{number_text(width[j], '.3g', 'unbounded')} |")
    lines += ["", "## Modes (null-space directions)", ""]
    lines += [f"- **{m.kind}**: {m.description}; release: {m.release}" for m in modes]
    lines += figure_lines(images_written, overlay) if images_written else []
    lines += engine_lines(op, overlay) if overlay is not None else []
    files.write_text(path, "\n".join(lines) + "\n")


def run_report(scene_spec: str, out: Path, instants: int | None = None,
               progress=None, formats=("png",), with_engine: bool = False) -> list[Path]:
    """Write ``report.csv``, the figure's pages in each of ``formats``
    (:func:`write_figure`) and ``report.md`` for one scene into ``out``; their paths.
    ``with_engine``: MuJoCo beside the rigid set (refused before any work where it does
    not apply); ``instants``: default :func:`default_instants`.
    """
    scene = load_scene(scene_spec)
    grid = len(scene.time.instants())
    if instants is not None and instants > grid:  # before any work
        raise UsageError(f"--instants {instants}: scene {scene.name} has {grid} instants on "
                         "its time grid; ask for at most as many")
    version = check_engine(scene) if with_engine else None
    instants = instants or default_instants(scene)
    t = np.linspace(scene.time.start_s, scene.time.stop_s, instants)
    motion = simulate(scene, t)
    op = build_operator(motion)
    h = histories(op, progress)
    overlay = None
    if version is not None:
        if progress is not None:
            progress(f"report: MuJoCo over {t[-1] - t[0]:g} s simulated ...")
        overlay = engine_overlay(op, h, version)
    out.mkdir(parents=True, exist_ok=True)
    write_csv(op, h, out / "report.csv", overlay)
    images = write_figure(op, h, out / "report", formats, overlay)
    write_md(op, h, named_modes(motion, 0, op), out / "report.md", overlay, tuple(images))
    return [out / "report.csv", *images, out / "report.md"]


def add_parser(subparsers) -> None:
    """Register ``cardan report``."""
    p = subparsers.add_parser("report", help="one scene's bearing and joint loads over time "
                              "with the rigid solution set (CSV, PNG, Markdown)")
    p.add_argument("scene", nargs="?", default="paper", help="built-in name or TOML path")
    p.add_argument("--out", type=files.folder, default="results/report",
                   help="output folder (default %(default)s)")
    p.add_argument("--instants", type=whole_number(2, MAX_INSTANTS), default=None,
                   help=f"instants over the scene's window (default: {PER_PERIOD} per period "
                   "of the intermediate shaft's twice-per-revolution fluctuation at the "
                   f"input's highest speed, at least {INSTANTS}, at most the scene's grid)")
    p.add_argument("--format", type=format_list, default=("png",),
                   help="comma-separated image formats (default png; any of png,svg,pdf)")
    p.add_argument("--engine", action="store_true",
                   help="also MuJoCo's forces (extra mujoco; default softness, a forward "
                   "simulation of the whole window), as open circles on each panel, with their "
                   "residual, determinate agreement and inside/outside counts in report.md. "
                   "Off by default: the report is the rigid set, and the engine's answer "
                   "is one member of it, picked by its constraint softness, not the machine "
                   "(cardan engine varies it). Refused for a scene MuJoCo cannot express "
                   "(e.g. quasi-static)")
    p.set_defaults(func=run)


def run(args) -> int:
    """Write the report; progress and the files written on stderr."""
    written = run_report(args.scene, Path(args.out), args.instants, progress=bars.line,
                         formats=args.format, with_engine=args.engine)
    files.say_written("report", written)
    return 0
