"""How the paper's figures (:mod:`cardan_forces.paper_repro.figures`) are drawn: a grid
of panels read from a figure's CSV on one page, one shared legend below it, in the print
style and kept to the print rules of :mod:`cardan_forces.experiments.images`.

In each panel (:func:`draw_panel`):

- the rigid-model methods on top, each its own colour, dash and marker; the markers sit
  at staggered instants, so methods whose lines lie on one another stay told apart, and
  a line above the panel names those that do and within how much (found from the data,
  :func:`images.coinciding`);
- a simulation's curves (the penalty simulation's, MuJoCo's) only from the end of its
  start-up on (``starts``), the instants its statistics use: the penalty as a light raw
  line under a bold filtered one (the figure's filtered column);
- the y axis holds every bold curve (the rigid methods and the filtered penalty) and the
  rigid set's finite bounds near them (:func:`images.limits`); a bound far below them
  (a near-zero lower bound under loads of hundreds of newtons) is marked on the panel's
  lower edge instead of flattening the curves; the raw penalty line may leave the axis;
- behind them the rigid solution set (:func:`images.draw_set`).

What else a panel has to say (its rigid set's sides and bounds, where the raw line leaves
the axis) is its caption line, returned for the report's text rather than written over
the panels.
"""

from __future__ import annotations

import textwrap
from dataclasses import dataclass
from pathlib import Path
from typing import NamedTuple

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from cardan_forces.experiments import images  # noqa: E402

PENALTY = "penalty"
"""The method name of the penalty-contact simulation in histories and columns."""
MARKERS = "osD^vP"
DASHES = ("-", "--", "-.", ":")
SMOOTHED = {False: "_lowpass", True: "_smooth"}
"""Suffix of a penalty column's filtered copy: forces (low-pass), speeds."""
ROW_IN = {1: 2.25, 2: 1.95}
"""Height of a row of panels (inches, title and axis labels included) by the number of
columns: a plotting area of some 1.3-1.6 in."""
RAW_LABEL = "penalty (raw)"


class Drawn(NamedTuple):
    """A figure written: its CSV and its caption (one line per panel with something to
    say beyond the drawing; the report prints them under the figure's files).
    """

    csv: Path
    caption: list[str]


@dataclass(frozen=True)
class Panel:
    """One panel: the columns of ``quantity``. ``methods``: the rigid-model curves, the
    columns ``quantity_<method>`` (``""``: the column ``quantity`` itself, the rigid
    model's); the penalty's ``quantity_penalty`` (raw) and its filtered column where
    present; with ``sets``, ``quantity_set_min/max`` as the rigid solution set.
    """

    title: str
    quantity: str
    ylabel: str
    methods: tuple[str, ...] = ()
    sets: bool = False
    zero_line: bool = False
    labels: tuple[tuple[str, str], ...] = ()
    """Legend labels of ``methods`` as ``(method, label)`` pairs, where not the
    figure's own."""

    @property
    def unit(self) -> str:
        """The unit of the y axis (the bracketed part of ``ylabel``)."""
        found = images.UNIT.search(self.ylabel)
        return found.group(0)[1:-1] if found else ""


OPEN = {"above": 1.0, "below": -1.0}
"""Codes of a figure CSV's ``*_set_open`` column: a rigid set open above, below (both:
their sum plus 2, i.e. 2; closed: 0)."""


def read_csv(path: Path) -> dict[str, np.ndarray]:
    """Read a figure's CSV (``figures.write_csv``: empty cells not known) back into
    named columns, each rigid set's open sides as ``-inf``/``inf`` again (its
    ``*_set_open`` column read and dropped).
    """
    data = np.genfromtxt(path, delimiter=",", names=True, deletechars="")
    cols = {name: data[name] for name in data.dtype.names}
    for name in [n for n in cols if n.endswith("_set_open")]:
        q, code = name.removesuffix("_set_open"), cols.pop(name)
        cols[f"{q}_set_min"] = np.where(np.isin(code, (OPEN["below"], 2.0)), -np.inf,
                                        cols[f"{q}_set_min"])
        cols[f"{q}_set_max"] = np.where(np.isin(code, (OPEN["above"], 2.0)), np.inf,
                                        cols[f"{q}_set_max"])
    return cols


def plot_grid(csv: Path, panels: list[Panel], title: str, ncols: int, formats=("png",),
              labels: dict | None = None, starts: dict | None = None) -> Drawn:
    """:func:`grid_figure` of the CSV's columns, written beside it in each format; the
    CSV and the panels' caption lines.
    """
    with images.styled():
        fig, caption = grid_figure(read_csv(csv), panels, title, ncols, labels or {},
                                   starts or {})
        images.save(fig, csv.with_suffix(""), formats)
    plt.close(fig)
    return Drawn(csv, caption)


def grid_figure(cols: dict[str, np.ndarray], panels: list[Panel], title: str, ncols: int,
                labels: dict, starts: dict | None = None):
    """``panels`` in a grid of ``ncols`` columns on one page with one shared legend
    below; the figure and its caption lines. ``labels``: legend labels of methods and
    filtered columns (name -> label); ``starts``: the time (s) from which a simulated
    method's curves are drawn (method -> s).
    """
    nrows = -(-len(panels) // ncols)
    width = images.PAGE_IN[0]
    height = min(images.PAGE_IN[1], 0.5 + ROW_IN[ncols] * nrows + 1.0)
    fig, axes = plt.subplots(nrows, ncols, figsize=(width, height), squeeze=False)
    handles: dict[str, object] = {}
    caption = []
    for ax, panel in zip(axes.ravel(), panels):
        drawn, note = draw_panel(ax, cols, panel, labels, width / ncols, starts or {})
        handles.update(drawn)
        if note:
            caption.append(f"- {panel.title}: {note}")
    for ax in axes.ravel()[len(panels):]:
        ax.axis("off")
    fig.suptitle(images.typeset(title))
    images.legend_below(fig, handles)
    return fig, caption


def draw_panel(ax, cols: dict[str, np.ndarray], panel: Panel, labels: dict,
               width_in: float = images.PAGE_IN[0], starts: dict | None = None
               ) -> tuple[dict, str]:
    """One panel (:class:`Panel`) on ``ax`` (about ``width_in`` wide); its legend
    handles by label and its caption note.
    """
    t, q, starts = cols["t"], panel.quantity, starts or {}
    curves = {m or "rigid model": _from(t, cols[f"{q}_{m}" if m else q], starts.get(m))
              for m in panel.methods}
    raw, smooth = _penalty(cols, q, starts.get(PENALTY))
    first = min((starts.get(m, -np.inf) for m in panel.methods), default=None)
    bounds = tuple(_from(t, cols[f"{q}_set_{end}"], first) for end in ("min", "max")
                   ) if panel.sets else ()
    bold = [c for c in [*curves.values(), *(c for _, c in smooth)] if np.isfinite(c).any()]
    low, high = images.limits(bold or [raw], list(bounds))
    own = dict(panel.labels) | {"rigid model": "rigid model"}
    handles = _draw_methods(ax, t, curves, {m: own.get(m) or labels.get(m, m) for m in curves})
    notes = []
    if raw is not None and np.isfinite(raw).any():
        handles[labels.get(RAW_LABEL, RAW_LABEL)], = ax.plot(
            t, raw, lw=0.5, color="0.45", alpha=0.45, zorder=1,
            label=labels.get(RAW_LABEL, RAW_LABEL))
        notes.append(clip_note(raw, low, high, panel.unit))
    for suffix, values in smooth:
        if not np.isfinite(values).any():
            continue
        handles[labels[suffix]], = ax.plot(t, values, lw=1.8, color="C4", zorder=3,
                                           label=labels[suffix])
    if bounds:
        drawn, note = images.draw_set(ax, t, *bounds, panel.unit, view=(low, high))
        handles.update(drawn)
        notes.insert(0, note)
    if panel.zero_line:
        ax.axhline(0.0, color="0.2", lw=0.6, zorder=2)
    ax.set_ylim(low, high)
    named = {dict(panel.labels).get(m, m): v for m, v in curves.items()}
    tol = images.COINCIDE * (high - low)
    above = [images.coincide_note(named, images.coinciding(named, tol), panel.unit)]
    for bound, word in zip(bounds, ("lower", "upper")):
        above.append(images.bound_note(images.on_bound(named, bound, tol), word, panel.unit))
    titles(ax, panel.title, "; ".join(n for n in above if n), width_in)
    ax.set_xlabel("time t [s]")
    ax.set_ylabel(panel.ylabel)
    ax.grid(True)
    return handles, "; ".join(n for n in notes if n)


def _from(t: np.ndarray, values: np.ndarray, start: float | None) -> np.ndarray:
    """``values`` with NaN (not drawn) before ``start`` (s; None: from the first)."""
    return values if start is None or start == -np.inf else np.where(
        t >= start - 1e-12, values, np.nan)


def _penalty(cols: dict, q: str, start: float | None):
    """The penalty's raw column of ``q`` (None if absent) and its filtered one as
    ``[(suffix, values)]``, each from ``start`` on.
    """
    t, raw = cols["t"], cols.get(f"{q}_{PENALTY}")
    smooth = [(s, _from(t, cols[f"{q}_{PENALTY}{s}"], start)) for s in SMOOTHED.values()
              if f"{q}_{PENALTY}{s}" in cols]
    return (None if raw is None else _from(t, raw, start)), smooth


def _draw_methods(ax, t, curves: dict, labels: dict) -> dict:
    """Each method's curve, its markers at instants staggered between methods."""
    handles, step = {}, max(1, len(t) // 8)
    for k, (method, values) in enumerate(curves.items()):
        label = labels[method]
        handles[label], = ax.plot(t, values, lw=1.1, color=f"C{k}", zorder=4,
                                  ls=DASHES[k % 4], marker=MARKERS[k % len(MARKERS)], ms=3.5,
                                  markevery=(k * step // len(curves), step), label=label)
    return handles


def titles(ax, title: str, note: str, width_in: float) -> None:
    """The panel's title on the left, wrapped to the panel's width, and ``note`` (curves
    drawn on one another, at :data:`images.MIN_TEXT_PT`) between it and the plotting
    area.
    """
    lines = 0
    if note:
        note = textwrap.fill(note, images.chars_across(width_in - 0.8))
        lines = note.count("\n") + 1
        ax.annotate(note, xy=(0, 1), xycoords="axes fraction", xytext=(0, 3),
                    textcoords="offset points", va="bottom", ha="left",
                    fontsize=images.MIN_TEXT_PT, color="0.25")
    ax.set_title(textwrap.fill(images.typeset(title), images.chars_across(
        width_in - 0.8, images.STYLE["axes.titlesize"])), loc="left",
        pad=5 + 1.3 * images.MIN_TEXT_PT * lines)


def clip_note(raw: np.ndarray, low: float, high: float, unit: str) -> str:
    """What the caption says when the raw penalty line leaves the drawn range: its range."""
    ok = np.isfinite(raw)
    if not ok.any() or low <= raw[ok].min() and raw[ok].max() <= high:
        return ""
    return (f"the raw penalty line (thin grey) spans {images.span_text(raw[ok], unit)} "
            "(impacts), beyond the axis")
