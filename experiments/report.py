"""``cardan report``: one scene's bearing and joint loads over time, with the rigid
solution set (DESIGN §4; any scene, its own names).

At ``--instants`` instants spread over the scene's window (by default enough to
resolve the intermediate shaft's twice-per-revolution fluctuation,
:func:`default_instants`): every contact force
component of the operator, the member ``positive`` picks (least force, end faces
pushing only), the interval ``[min, max]`` over every rigid solution with end faces
>= 0 (two LPs per component that is not determinate, the band; a determinate one's
interval is its value), and whether the component is determinate.
Written as ``report.csv`` (long format, with each component's unit), ``report.png``
(and ``.svg``/``.pdf`` with ``--format``: one panel per contact, unit and scale
group, a slip joint's forces in N apart from its moments in N m, a few-newton component
apart from a kilonewton one; each component's legend entry, below its panel, says
whether it is determinate or which side of its set is open) and ``report.md`` (the
determinacy table and the named modes). With ``--engine``, MuJoCo's forces under its
default softness (:mod:`cardan_forces.experiments.engine`) are drawn as open circles on
every panel and ``report.md`` says how they sit in the rigid set (:class:`EngineOverlay`).
"""

from __future__ import annotations

import csv
import math
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
from cardan_forces.experiments import engine, files
from cardan_forces.experiments import progress as bars
from cardan_forces.experiments.environment import number_text
from cardan_forces.experiments.images import format_list, save
from cardan_forces.experiments.study import interval_history, solve_over_time
from cardan_forces.formulations import SELECTION
from cardan_forces.formulations.convex import NotApplicable

from cardan_forces.commands import UsageError, whole_number

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
below 1e-6 of the panel's largest counts as zero and stays)."""


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
        if groups and size[j] <= 1e-6 * top:  # zero: drawn as well beside any scale
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


def _draw(ax, op: Operator, h: dict[str, np.ndarray], panel: Panel,
          engine_forces: np.ndarray | None = None) -> None:
    """One panel: each component's selected value as a line, its rigid set in the same
    colour: shaded where both ends are finite; where one side is open, the finite end
    dashed with triangles pointing to the open side; where both are, double arrows along
    the line; ``engine_forces`` (T, n), where given, as open circles in the same colour.
    The y range holds the lines and every finite end; the legend sits below the panel.
    """
    held = []
    step = max(1, len(op.t) // 10)
    for k, j in enumerate(panel.columns):
        lo, hi, value = h["min"][:, j], h["max"][:, j], h["value"][:, j]
        both = np.isfinite(lo) & np.isfinite(hi)
        free = ~np.isfinite(lo) & ~np.isfinite(hi) & ~h["determinate"][:, j]
        name = op.names[j][len(panel.contact.name) + 1:] or "force"
        words = set_words(lo, hi, h["determinate"][:, j])
        ax.plot(op.t, value, lw=1.4, color=f"C{k}", zorder=3,
                label=f"{name}: {words}" + (" (\u2195 on the line)" if free.any() else ""))
        if free.any():
            ax.plot(op.t, np.where(free, value, np.nan), ls="none", marker=BOTH_OPEN_MARK,
                    ms=10, color=f"C{k}", markevery=(k * step // len(panel.columns), step),
                    zorder=3)
        ax.fill_between(op.t, np.where(both, lo, np.nan), np.where(both, hi, np.nan),
                        color=f"C{k}", alpha=0.2, lw=0, zorder=1)
        for bound, other, marker in ((lo, hi, "^"), (hi, lo, "v")):  # open above: ^
            one = np.where(np.isfinite(bound) & ~np.isfinite(other), bound, np.nan)
            if np.isfinite(one).any():
                ax.plot(op.t, one, ls="--", lw=1.1, color=f"C{k}", marker=marker, ms=5,
                        markevery=(0, step), zorder=2)
        held += [lo, hi, value]
        if engine_forces is not None:
            ax.plot(op.t, engine_forces[:, j], ls="none", marker="o", ms=4.5, mfc="none",
                    mew=1.1, color=f"C{k}", zorder=4,
                    label=ENGINE_LABEL if k == 0 else "_")
            held.append(engine_forces[:, j])
    ax.set_ylim(*_limits(held))
    ax.set_title(panel.title, fontsize=9, y=1.0)  # placed, not searched for: no top ticks
    ax.set_xlabel("time t [s]", fontsize=8.5)
    ax.set_ylabel(UNIT_AXIS.get(panel.unit, f"[{panel.unit}]"), fontsize=8.5)
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(-0.02, -LEGEND_DROP_IN / PANEL_IN[1]),
              frameon=False, borderaxespad=0.0, handlelength=1.6)


ENGINE_LABEL = "MuJoCo, default softness (open circles, each component's colour)"


def _limits(curves: list[np.ndarray]) -> tuple[float, float]:
    """A y range holding every finite value of ``curves``, with a margin (8 % of the
    range, at least 5 % of the largest magnitude, so a flat line is not drawn as noise).
    """
    finite = np.concatenate([c[np.isfinite(c)] for c in curves] + [np.zeros(0)])
    if not finite.size:
        return -1.0, 1.0
    low, high = float(finite.min()), float(finite.max())
    margin = max(0.08 * (high - low), 0.05 * max(abs(low), abs(high)), 1e-6)
    return low - margin, high + margin


STYLE = {"axes.grid": True, "grid.alpha": 0.3, "xtick.labelsize": 8, "ytick.labelsize": 8}
"""Matplotlib settings of the report's figure: each tick is made with them, instead of
every tick of 60 axes restyled after it is made."""

MARGINS_IN = {"left": 0.75, "right": 0.2, "top": 0.45, "line": 0.2,
              "wspace": 0.9, "hspace": 0.85, "entry": 0.19}
"""The figure's margins and the gaps between panels (inches): room for the tick labels
and axis labels at the report's font sizes, ``entry`` more below each row per entry of
the longest legend below a panel, and ``line`` per line of the suptitle above ``top``
(a fixed layout: a constrained one measured every panel's text twice and took a third
of the figure's time)."""
PANEL_IN = (4.0, 2.1)
"""A panel's plotting area (inches, its printed size)."""
LEGEND_DROP_IN = 0.42
"""How far below a panel its legend starts (inches): under the axis label."""


def write_figure(op: Operator, h: dict[str, np.ndarray], stem: Path,
                 formats=("png",), overlay: EngineOverlay | None = None) -> list[Path]:
    """Every :func:`panels` panel in a grid, written as ``stem.<format>`` per format
    (with ``overlay``, MuJoCo's forces on each).
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    with plt.rc_context(STYLE):
        fig = figure(op, h, overlay)
        paths = save(fig, stem, formats)
    plt.close(fig)
    return paths


def figure(op: Operator, h: dict[str, np.ndarray], overlay: EngineOverlay | None = None):
    """The report's figure (not yet drawn; :func:`write_figure` writes it under
    :data:`STYLE`).
    """
    import matplotlib.pyplot as plt

    grid = panels(op, h)
    cols = min(4, len(grid))
    rows = math.ceil(len(grid) / cols)
    m = MARGINS_IN
    below = m["entry"] * max(len(p.columns) + (overlay is not None) for p in grid)
    size = (m["left"] + m["right"] + cols * PANEL_IN[0] + (cols - 1) * m["wspace"],
            m["top"] + 2 * m["line"] + rows * (PANEL_IN[1] + m["hspace"] + below))
    fig, axes = plt.subplots(rows, cols, figsize=size, squeeze=False)
    for ax, panel in zip(axes.ravel(), grid):
        _draw(ax, op, h, panel, None if overlay is None else overlay.forces)
    for ax in axes.ravel()[len(grid):]:
        ax.set_visible(False)
    title = fig.suptitle(
        f"{op.scene.name}: contact forces over time, the {SELECTION} selection (lines) and "
        "the rigid solution set of each component (same colour): shaded where both ends "
        "are finite,\nthe finite end dashed with triangles to the open side where one "
        "side is open, double arrows on the line where both are (any value); each panel "
        "its own scale"
        + ("; MuJoCo's forces as open circles (default softness, after its settling)"
           if overlay is not None else ""), fontsize=10, va="top")
    _place(fig, rows, cols, title, below)
    return fig


def _place(fig, rows: int, cols: int, title, below: float) -> None:
    """Panels and suptitle at :data:`MARGINS_IN` of a figure of ``rows`` x ``cols``,
    ``below`` inches more under each row for its legends.
    """
    width, height = fig.get_size_inches()
    m = MARGINS_IN
    top = m["top"] + m["line"] * (title.get_text().count("\n") + 1)
    gap = m["hspace"] + below
    panel_w = (width - m["left"] - m["right"] - (cols - 1) * m["wspace"]) / cols
    panel_h = (height - gap - top - (rows - 1) * gap) / rows
    fig.subplots_adjust(left=m["left"] / width, right=1 - m["right"] / width,
                        bottom=gap / height, top=1 - top / height,
                        wspace=m["wspace"] / panel_w, hspace=gap / panel_h)
    title.set_y(1 - 0.1 / height)


def write_md(op: Operator, h: dict[str, np.ndarray], modes, path: Path,
             overlay: EngineOverlay | None = None) -> None:
    """The determinacy table, the named modes and, with ``overlay``, MuJoCo's section."""
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
    lines += engine_lines(op, overlay) if overlay is not None else []
    files.write_text(path, "\n".join(lines) + "\n")


def run_report(scene_spec: str, out: Path, instants: int | None = None,
               progress=None, formats=("png",), with_engine: bool = False) -> list[Path]:
    """Write ``report.csv``, ``report.<format>`` for each of ``formats`` and
    ``report.md`` for one scene into ``out``; their paths. ``with_engine``: MuJoCo
    beside the rigid set (refused before any work where it does not apply);
    ``instants``: default :func:`default_instants`.
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
    write_md(op, h, named_modes(motion, 0, op), out / "report.md", overlay)
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
    """Write the report; the paths written on stdout, progress on stderr."""
    written = run_report(args.scene, Path(args.out), args.instants, progress=bars.line,
                         formats=args.format, with_engine=args.engine)
    for path in written:
        print(path)
    files.say_written("report", written)
    return 0
