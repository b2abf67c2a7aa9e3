"""How the paper's figures (:mod:`cardan_forces.paper_repro.figures`) are drawn: a grid
of panels read from a figure's CSV, one shared legend below it, kept to the print rules
of :mod:`cardan_forces.experiments.images` (8 pt text or more, 150 dpi PNG).

In each panel (:func:`draw_panel`):

- the rigid-model methods on top, each its own colour, dash and marker; the markers sit
  at staggered instants, so methods whose lines lie on one another stay told apart, and
  the panel names those that do (found from the data, :func:`images.coinciding`);
- the penalty simulation as a light raw line under a bold smoothed one (the figure's
  smoothed column, absent where its centred window does not fit);
- the y axis holds every bold curve (the rigid methods and the smoothed penalty) and
  every finite bound of the rigid set, with a margin; only the raw penalty line may
  leave it, and the panel then says so with its range and unit;
- behind them the rigid solution set (:func:`images.draw_set`): shaded where both bounds are
  finite; where one side is open, the finite bound as a dashed line with triangles
  pointing to the open side; a set open on both sides (any value) is said in the panel.
"""

from __future__ import annotations

import textwrap
from dataclasses import dataclass
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from cardan_forces.experiments.images import UNIT, coinciding, draw_set, save, span_text  # noqa: E402, E501

PENALTY = "penalty"
"""The method name of the penalty-contact simulation in histories and columns."""
MARKERS = "osD^vP"
DASHES = ("-", "--", "-.", ":")
COINCIDE = 0.005
"""Curves closer than this share of the axis range at every instant are drawn on one
another; the panel names them."""
STYLE = {"font.size": 9.0, "axes.titlesize": 9.5, "axes.labelsize": 9.0,
         "xtick.labelsize": 8.0, "ytick.labelsize": 8.0, "legend.fontsize": 8.5}
"""Type sizes (pt at the figure's printed size: 8 in wide for one column, 11 for two)."""
NOTE_PT = 8.0
SMOOTHED = {False: "_avg", True: "_smooth"}
"""Suffix of a penalty column's smoothed copy: forces (moving average), speeds."""


@dataclass(frozen=True)
class Panel:
    """One panel: the columns of ``quantity``. ``methods``: the rigid-model curves, the
    columns ``quantity_<method>`` (``""``: the column ``quantity`` itself, the rigid
    model's); the penalty's ``quantity_penalty`` (raw) and its smoothed column where
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
        found = UNIT.search(self.ylabel)
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
              labels: dict | None = None) -> list[Path]:
    """:func:`grid_figure` of the CSV's columns, written beside it in each format."""
    with plt.rc_context(STYLE):
        fig = grid_figure(read_csv(csv), panels, title, ncols, labels or {})
        paths = save(fig, csv.with_suffix(""), formats)
    plt.close(fig)
    return paths


def grid_figure(cols: dict[str, np.ndarray], panels: list[Panel], title: str, ncols: int,
                labels: dict):
    """``panels`` in a grid of ``ncols`` columns with one shared legend below.
    ``labels``: legend labels of methods and smoothed columns (name -> label).
    """
    nrows = -(-len(panels) // ncols)
    width = 8.0 if ncols == 1 else 11.0
    fig, axes = plt.subplots(nrows, ncols, figsize=(width, 2.7 * nrows + 1.4), squeeze=False)
    handles: dict[str, object] = {}
    for ax, panel in zip(axes.ravel(), panels):
        handles.update(draw_panel(ax, cols, panel, labels, width / ncols))
    for ax in axes.ravel()[len(panels):]:
        ax.axis("off")
    fig.suptitle(title, fontsize=11)
    longest = max((len(k) for k in handles), default=1)
    ncol = max(1, min(3, int(width * 72 / (longest * 0.52 * STYLE["legend.fontsize"] + 40))))
    fig.legend(list(handles.values()), list(handles), loc="lower center", ncol=ncol,
               frameon=False)
    rows = -(-len(handles) // ncol)
    fig.tight_layout(rect=(0, (0.15 + 0.19 * rows) / fig.get_figheight(), 1, 1))
    return fig


def draw_panel(ax, cols: dict[str, np.ndarray], panel: Panel, labels: dict,
               width_in: float = 8.0) -> dict:
    """One panel (:class:`Panel`) on ``ax`` (about ``width_in`` wide); returns its legend
    handles by label.
    """
    t, q = cols["t"], panel.quantity
    curves = {m or "rigid model": cols[f"{q}_{m}" if m else q] for m in panel.methods}
    raw = cols.get(f"{q}_{PENALTY}")
    smooth = next((s for s in SMOOTHED.values() if f"{q}_{PENALTY}{s}" in cols), None)
    bounds = (cols[f"{q}_set_min"], cols[f"{q}_set_max"]) if panel.sets else ()
    held = [*curves.values(), *bounds] + ([cols[f"{q}_{PENALTY}{smooth}"]] if smooth else [])
    low, high = limits(held or [raw])
    names = dict(panel.labels) | {"rigid model": "rigid model"}
    handles = _draw_methods(ax, t, curves, {m: names.get(m) or labels.get(m, m)
                                            for m in curves})
    own = dict(panel.labels)
    notes = [_coincide_note({own.get(m, m): v for m, v in curves.items()},
                            COINCIDE * (high - low))]
    if raw is not None:
        handles["penalty (raw)"], = ax.plot(t, raw, lw=0.5, color="0.45", alpha=0.45,
                                            zorder=1, label="penalty (raw)")
        notes.append(clip_note(raw, low, high, panel.unit))
    if smooth is not None:
        label = labels[smooth]
        handles[label], = ax.plot(t, cols[f"{q}_{PENALTY}{smooth}"], lw=2.2, color="C4",
                                  zorder=3, label=label)
    if bounds:
        drawn, note = draw_set(ax, t, *bounds, panel.unit)
        handles.update(drawn)
        notes.insert(0, note)
    if panel.zero_line:
        ax.axhline(0.0, color="0.2", lw=0.6, zorder=2)
    ax.set_ylim(low, high)
    titles(ax, panel.title, notes, width_in)
    ax.set_xlabel("time t [s]")
    ax.set_ylabel(panel.ylabel)
    ax.grid(alpha=0.3)
    return handles


def _draw_methods(ax, t, curves: dict, labels: dict) -> dict:
    """Each method's curve, its markers at instants staggered between methods."""
    handles, step = {}, max(1, len(t) // 8)
    for k, (method, values) in enumerate(curves.items()):
        label = labels[method]
        handles[label], = ax.plot(t, values, lw=1.3, color=f"C{k}", zorder=4,
                                  ls=DASHES[k % 4], marker=MARKERS[k % len(MARKERS)], ms=4.5,
                                  markevery=(k * step // len(curves), step), label=label)
    return handles


def _coincide_note(curves: dict, tol: float) -> str:
    groups = coinciding(curves, tol)
    return ("drawn on one another (markers tell them apart): "
            + "; ".join(" = ".join(g) for g in groups)) if groups else ""


def titles(ax, title: str, notes: list[str], width_in: float) -> None:
    """The panel's title on the left, its notes (at :data:`NOTE_PT`) between it and the
    plotting area, wrapped to the panel's width.
    """
    text = "\n".join(textwrap.wrap("; ".join(n for n in notes if n),
                                   width=max(30, int(width_in * 72 / (0.5 * NOTE_PT) * 0.8))))
    lines = text.count("\n") + 1 if text else 0
    if text:
        ax.annotate(text, xy=(0, 1), xycoords="axes fraction", xytext=(0, 3),
                    textcoords="offset points", va="bottom", ha="left", fontsize=NOTE_PT,
                    color="0.25")
    ax.set_title(title, loc="left", pad=4 + 1.25 * NOTE_PT * lines)


def limits(curves: list[np.ndarray]) -> tuple[float, float]:
    """The y range of ``curves``' finite values with a margin of 15 % of the range (at
    least 5 % of the largest magnitude, so a flat line is not drawn as noise).
    """
    finite = np.concatenate([c[np.isfinite(c)] for c in curves if c is not None]
                            or [np.zeros(1)])
    finite = finite if finite.size else np.zeros(1)
    lo, hi = float(finite.min()), float(finite.max())
    margin = max(0.15 * (hi - lo), 0.05 * max(abs(lo), abs(hi)), 1e-9)
    return lo - margin, hi + margin


def clip_note(raw: np.ndarray, low: float, high: float, unit: str) -> str:
    """What the panel says when the raw penalty line leaves the drawn range: its range."""
    ok = np.isfinite(raw)
    if not ok.any() or low <= raw[ok].min() and raw[ok].max() <= high:
        return ""
    return (f"raw penalty (thin grey) clipped: it spans {span_text(raw[ok], unit)} "
            "(impacts); the axis holds the bold curves")
