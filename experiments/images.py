"""Image files of the figure commands (``cardan repro``, ``cardan report``, ``bench``,
``engine``, ``secondary``): the formats they write, the one way a figure is saved in
each (``--format png,svg,pdf``) and the print rules every figure keeps.

Print rules: a figure's size (inches) is its printed size; no text on it is smaller
than :data:`MIN_TEXT_PT`; a PNG is written at :data:`DPI` (vector formats are
resolution-free); every panel has a title and axis labels with their unit in brackets
(``[-]`` for a pure number); every legend entry names an artist visible in the figure;
no legend sits over a panel's plotting area. :func:`problems` reads a drawn figure back
against them.
"""

from __future__ import annotations

import argparse
import re
from pathlib import Path

import numpy as np

from . import files

FORMATS = ("png", "svg", "pdf")
"""Image formats a figure can be written in."""
DPI = 150
"""Resolution of a PNG (dots per inch of the figure's printed size)."""
MIN_TEXT_PT = 8.0
"""The smallest text on a figure (points at its printed size)."""
UNIT = re.compile(r"\[[^\]]+\]")
"""An axis label's unit: the text in brackets, as ``force [N]``."""
SET_COLOUR = "0.55"
SET_LABEL = "rigid solution set (both bounds finite)"
OPEN_ABOVE_LABEL = "lower bound of a rigid set open above (\u25b2: the open side)"
OPEN_BELOW_LABEL = "upper bound of a rigid set open below (\u25bc: the open side)"
"""Legend labels of the rigid solution set as :func:`draw_set` draws it."""


def format_list(text: str) -> tuple[str, ...]:
    """``--format``'s value: comma-separated formats of :data:`FORMATS`, order kept,
    repeats dropped (an argparse type: anything else is one usage error).
    """
    words = tuple(dict.fromkeys(w.strip().lower() for w in text.split(",") if w.strip()))
    bad = [w for w in words if w not in FORMATS]
    if bad or not words:
        raise argparse.ArgumentTypeError(
            f"{'unknown ' + ', '.join(bad) if bad else 'empty'}; choose among "
            f"{','.join(FORMATS)}")
    return words


def save(fig, stem: Path, formats=("png",)) -> list[Path]:
    """Write ``fig`` as ``stem.<format>`` for each of ``formats`` (PNG at :data:`DPI`),
    each whole or not at all (:func:`.files.replacing`); their paths.
    """
    paths = [stem.with_suffix(f".{fmt}") for fmt in formats]
    for path, fmt in zip(paths, formats):
        with files.replacing(path, "wb") as handle:
            fig.savefig(handle, format=fmt, dpi=DPI)
    return paths


def write_study(out: Path, stem: str, write_csv, text: str, figure, formats=("png",)
                ) -> list[Path]:
    """A study's outputs into ``out``: ``stem.csv`` (``write_csv(path)``), ``stem.md``
    (``text``) and the figure ``figure()`` draws in each of ``formats``, each file
    whole; their paths.
    """
    import matplotlib

    matplotlib.use("Agg")  # files only, whatever display there is
    import matplotlib.pyplot as plt

    out.mkdir(parents=True, exist_ok=True)
    write_csv(out / f"{stem}.csv")
    files.write_text(out / f"{stem}.md", text)
    fig = figure()
    images = save(fig, out / stem, formats)
    plt.close(fig)
    return [out / f"{stem}.csv", out / f"{stem}.md", *images]


def problems(fig) -> list[str]:
    """What in the drawn ``fig`` breaks the print rules (module doc), one line each;
    empty when it keeps them all.
    """
    if not hasattr(fig.canvas, "get_renderer"):  # a closed pyplot figure: draw it again
        from matplotlib.backends.backend_agg import FigureCanvasAgg

        FigureCanvasAgg(fig)
    fig.canvas.draw()
    found = _small_text(fig) + _unlabelled(fig)
    renderer = fig.canvas.get_renderer()
    areas = [ax.bbox for ax in fig.axes if ax.get_visible() and ax.axison]
    for legend in fig.legends + [ax.get_legend() for ax in fig.axes if ax.get_legend()]:
        box = legend.get_window_extent(renderer)
        if any(box.overlaps(area) for area in areas):
            found.append("a legend sits over a panel's plotting area")
        for text in legend.get_texts():
            if not any(_shows(a) for a in _labelled(fig, text.get_text())):
                found.append(f"legend entry {text.get_text()!r} has no visible artist")
    return found


def _small_text(fig) -> list[str]:
    from matplotlib.text import Text

    return [f"text {t.get_text()[:40]!r} at {t.get_fontsize():g} pt"
            for t in fig.findobj(Text)
            if t.get_visible() and t.get_text().strip() and t.get_fontsize() < MIN_TEXT_PT]


def _unlabelled(fig) -> list[str]:
    found = [] if fig.get_suptitle() else ["no figure title"]
    for ax in fig.axes:
        if not (ax.get_visible() and ax.axison and (ax.lines or ax.collections)):
            continue
        if not any(ax.get_title(loc=loc) for loc in ("left", "center", "right")):
            found.append("a panel without a title")
        for label in (ax.get_xlabel(), ax.get_ylabel()):
            if not UNIT.search(label):
                found.append(f"axis label {label!r} without a unit in brackets")
    return found


def _labelled(fig, label: str) -> list:
    return [a for ax in fig.axes for a in ax.lines + ax.collections if a.get_label() == label]


def _shows(artist) -> bool:
    """Whether ``artist`` (a line or a filled region) has something visible in its view."""
    if not artist.get_visible() or (artist.get_alpha() is not None and artist.get_alpha() <= 0):
        return False
    ax = artist.axes
    if hasattr(artist, "get_xydata"):
        if artist.get_linestyle() in ("None", "none", "") and artist.get_marker() in (
                "None", "none", "", None):
            return False
        xy = np.asarray(artist.get_xydata(), float).reshape(-1, 2)
    else:
        paths = artist.get_paths()
        xy = np.vstack([p.vertices for p in paths]) if paths else np.zeros((0, 2))
    (x0, x1), (y0, y1) = sorted(ax.get_xlim()), sorted(ax.get_ylim())
    inside = (xy[:, 0] >= x0) & (xy[:, 0] <= x1) & (xy[:, 1] >= y0) & (xy[:, 1] <= y1)
    return bool(inside.any())


def coinciding(curves: dict, tol: float) -> list[tuple[str, ...]]:
    """Groups (two or more names, in ``curves``' order) of curves that lie within ``tol``
    of each other at every instant and are missing (NaN) at the same instants: drawn, they
    would be one line. ``curves``: name -> values over the same instants.
    """
    groups: list[list[str]] = []
    for name, values in curves.items():
        values = np.asarray(values, float)
        for group in groups:
            first = np.asarray(curves[group[0]], float)
            same = np.isnan(first) == np.isnan(values)
            if same.all() and np.all(np.abs(np.nan_to_num(first - values)) <= tol):
                group.append(name)
                break
        else:
            groups.append([name])
    return [tuple(g) for g in groups if len(g) > 1]


def _number(value: float, scale: float) -> str:
    """``value`` to 3 significant digits, round-off about zero (relative to ``scale``) as 0."""
    return f"{value if abs(value) > 1e-9 * scale else 0.0:.3g}"


def span_text(values: np.ndarray, unit: str) -> str:
    """``a to b <unit>`` of finite ``values``, or one value where they print alike."""
    lo, hi = float(np.min(values)), float(np.max(values))
    scale = max(abs(lo), abs(hi))
    a, b = _number(lo, scale), _number(hi, scale)
    return f"{a} {unit}" if a == b else f"{a} to {b} {unit}"


def draw_set(ax, t, set_min, set_max, unit: str = "N") -> tuple[dict, str]:
    """Draw the rigid solution set behind the curves: shaded (with its edges, so a set of
    one value still shows) where both bounds are finite; where one side is open, the
    finite bound dashed with triangles pointing to the open side. Returns the legend
    handles and the panel's note: which sides are open, at how many instants, and the
    finite bounds' span.
    """
    checked = ~(np.isnan(set_min) | np.isnan(set_max))
    if not checked.any():
        return {}, ""
    lo, hi, tc = set_min[checked], set_max[checked], t[checked]
    both = np.isfinite(lo) & np.isfinite(hi)
    handles, notes, n = {}, [], int(checked.sum())
    if both.any():
        lo_b, hi_b = np.where(both, lo, np.nan), np.where(both, hi, np.nan)
        handles[SET_LABEL] = ax.fill_between(tc, lo_b, hi_b, color=SET_COLOUR, alpha=0.35,
                                             lw=0, zorder=0, label=SET_LABEL)
        ax.plot(tc, lo_b, tc, hi_b, color=SET_COLOUR, lw=0.8, zorder=0.5)
        single = both & (hi - lo <= 1e-6 * max(np.max(np.abs(hi[both])), 1e-9))
        if single.any():  # a determinate quantity: the band is a line under the curves
            notes.append(f"one value (determinate) {_share(int(single.sum()), n)}")
    sides = ((lo, hi, "^", OPEN_ABOVE_LABEL, "open above", "lower"),
             (hi, lo, "v", OPEN_BELOW_LABEL, "open below", "upper"))
    for bound, other, marker, label, side, word in sides:
        one = np.isfinite(bound) & ~np.isfinite(other)
        if one.any():
            handles[label], = ax.plot(tc, np.where(one, bound, np.nan), ls="--", lw=1.2,
                                      color="0.25", marker=marker, ms=5.5, zorder=2,
                                      markevery=(0, max(1, len(tc) // 10)), label=label)
            notes.append(f"{side} {_share(int(one.sum()), n)}, {word} bound "
                         f"{span_text(bound[one], unit)}")
    free = ~np.isfinite(lo) & ~np.isfinite(hi)
    if free.any():
        notes.append(f"open above and below (any value) {_share(int(free.sum()), n)}")
    return handles, "rigid set: " + "; ".join(notes) if notes else ""


def _share(count: int, total: int) -> str:
    return f"at all {total} instants" if count == total else f"at {count} of {total} instants"
