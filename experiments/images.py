"""Image files of the figure commands (``cardan repro``, ``cardan report``, ``bench``,
``engine``, ``secondary``): the formats they write, the one way a figure (or a figure of
several pages) is saved in each (``--format png,svg,pdf``), the one figure style for
print (:data:`STYLE`) and the print rules every figure keeps.

Print rules: a figure's size (inches) is its printed size, at most a page's text block
(:data:`PAGE_IN`; a long figure is cut into pages, :func:`save_pages`); no text on it is
smaller than :data:`MIN_TEXT_PT`; a PNG is written at :data:`DPI` (vector formats are
resolution-free); every panel has a title and axis labels with their unit in brackets
(``[-]`` for a pure number); every legend entry names an artist that shows in the
drawn figure, not covered by others; no legend sits over a panel's plotting area.
:func:`problems` reads a drawn figure back against the rules any figure keeps,
:func:`print_problems` against all of them.
"""

from __future__ import annotations

import argparse
import re
import textwrap
from pathlib import Path

import numpy as np

from . import files

FORMATS = ("png", "svg", "pdf")
"""Image formats a figure can be written in."""
DPI = 150
"""Resolution of a PNG (dots per inch of the figure's printed size)."""
PAGE_IN = (7.0, 9.0)
"""The largest figure (width, height in inches): a page's text block, full width."""
COLUMN_IN = 3.5
"""The width of a figure of one column (inches)."""
MIN_TEXT_PT = 7.0
"""The smallest text on a figure (points at its printed size)."""
TITLE_PT = 9.0
"""A figure's title (points)."""
STYLE = {
    "font.size": 8.0, "axes.titlesize": 8.0, "axes.labelsize": 8.0,
    "xtick.labelsize": 7.0, "ytick.labelsize": 7.0, "legend.fontsize": 7.0,
    "figure.titlesize": TITLE_PT, "lines.linewidth": 1.0, "lines.markersize": 3.5,
    "axes.linewidth": 0.6, "xtick.major.width": 0.6, "ytick.major.width": 0.6,
    "xtick.major.size": 2.5, "ytick.major.size": 2.5, "grid.linewidth": 0.4,
    "grid.alpha": 0.35, "legend.frameon": False, "legend.handlelength": 2.4,
    "axes.titlepad": 3.0, "axes.labelpad": 2.0}
"""The figures' style for print (matplotlib settings; :func:`styled`): type sizes in
points at the figure's printed size, from :data:`MIN_TEXT_PT` for ticks and legends to
:data:`TITLE_PT` for a figure's title; lines and ticks thin enough for a 3.5 in panel."""
COINCIDE = 0.005
"""Curves closer than this share of their panel's y range at every instant are drawn
on one another (:func:`coinciding`); the figure says which, and within how much."""
SAME_RTOL = 1e-6
"""Values within this share of their scale are one value on a figure (a rigid set whose
ends meet, a component that is zero beside its panel's largest, loads that coincide
over a revolution): the package's acceptance of an answer (``solvers.ACCEPT``), below
which answers are not told apart."""
BOUND_REACH = 0.25
"""A finite bound of a rigid set is held in a panel's y range when it widens the range
of the curves by at most this share; one farther off (a near-zero lower bound under
loads of several hundred newtons) is marked on the panel's edge instead
(:func:`draw_set`), so that it does not flatten the curves."""
UNIT = re.compile(r"\[[^\]]+\]")
"""An axis label's unit: the text in brackets, as ``force [N]``."""
SET_COLOUR = "0.55"
SET_LABEL = "rigid solution set (both bounds finite)"
OPEN_ABOVE_LABEL = "lower bound of a rigid set open above (\u25b2: the open side)"
OPEN_BELOW_LABEL = "upper bound of a rigid set open below (\u25bc: the open side)"
BELOW_VIEW_LABEL = ("lower bound of a rigid set open above, below the axis "
                    "(\u25b2 on its lower edge)")
ABOVE_VIEW_LABEL = ("upper bound of a rigid set open below, above the axis "
                    "(\u25bc on its upper edge)")
"""Legend labels of the rigid solution set as :func:`draw_set` draws it."""
SUPERSCRIPTS = {"^2": "\u00b2", "^3": "\u00b3", "^-1": "\u207b\u00b9"}
"""Powers of a unit as a figure prints them (:func:`typeset`): ``m/s^2`` is ``m/s\u00b2``."""


def styled():
    """A context in which figures are made in :data:`STYLE`."""
    import matplotlib.pyplot as plt

    return plt.rc_context(STYLE)


def chars_across(width_in: float, pt: float = MIN_TEXT_PT) -> int:
    """How many characters of ``pt`` type fit across ``width_in`` inches, at most (a
    wide character's width, 0.6 of the type size): where text is wrapped.
    """
    return max(20, int(width_in * 72 / (0.6 * pt)))


def typeset(text: str) -> str:
    """``text`` for a figure: the powers of units as superscripts (:data:`SUPERSCRIPTS`)."""
    for plain, raised in SUPERSCRIPTS.items():
        text = text.replace(plain, raised)
    return text


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


def legend_below(fig, handles: dict) -> None:
    """One legend for the figure under its panels, in two columns where the labels
    allow (a long label wrapped), the panels laid out above it.
    """
    texts = [textwrap.fill(label, 58) for label in handles]
    ncol = 2 if len(texts) > 2 else 1
    legend = fig.legend(list(handles.values()), texts, loc="lower center", ncol=ncol,
                        bbox_to_anchor=(0.5, 0.0), columnspacing=1.5)
    fig.canvas.draw()
    below = legend.get_window_extent().height / fig.dpi + 0.08
    fig.tight_layout(rect=(0, below / fig.get_figheight(), 1, 1), h_pad=0.6, w_pad=1.0)


def save(fig, stem: Path, formats=("png",)) -> list[Path]:
    """Write ``fig`` as ``stem.<format>`` for each of ``formats`` (PNG at :data:`DPI`),
    each whole or not at all (:func:`.files.replacing`); their paths.
    """
    paths = [stem.with_suffix(f".{fmt}") for fmt in formats]
    for path, fmt in zip(paths, formats):
        with files.replacing(path, "wb") as handle:
            fig.savefig(handle, format=fmt, dpi=DPI)
    return paths


def page_stems(stem: Path, pages: int) -> list[Path]:
    """The stems of a figure's pages: ``stem`` itself for one page, else ``stem-1``,
    ``stem-2``, ...
    """
    if pages == 1:
        return [stem]
    return [stem.with_name(f"{stem.name}-{k}") for k in range(1, pages + 1)]


def save_pages(figs: list, stem: Path, formats=("png",)) -> list[Path]:
    """Write the pages ``figs`` of one figure: a PDF holds them all (``stem.pdf``), a PNG
    or an SVG is one page (``stem-1.png``, ``stem-2.png``, ...; ``stem.png`` when there
    is one page). Pages of ``stem`` in the same format that an earlier, longer or
    shorter, drawing left are removed, so the folder holds this figure's pages only.
    Returns the paths written.
    """
    from matplotlib.backends.backend_pdf import PdfPages

    stems, paths = page_stems(stem, len(figs)), []
    for fmt in formats:
        if fmt == "pdf" and len(figs) > 1:
            paths.append(stem.with_suffix(".pdf"))
            with files.replacing(paths[-1], "wb") as handle, PdfPages(handle) as pdf:
                for fig in figs:
                    pdf.savefig(fig, dpi=DPI)
            continue
        written = [save(fig, page, (fmt,))[0] for fig, page in zip(figs, stems)]
        _drop_other_pages(stem, fmt, written)
        paths += written
    return paths


def _drop_other_pages(stem: Path, fmt: str, kept: list[Path]) -> None:
    """Remove ``stem.<fmt>`` and ``stem-<k>.<fmt>`` other than ``kept``."""
    page = re.compile(rf"{re.escape(stem.name)}(-\d+)?\.{fmt}")
    for path in stem.parent.glob(f"{stem.name}*.{fmt}"):
        if page.fullmatch(path.name) and path not in kept:
            path.unlink()


def write_study(out: Path, stem: str, write_csv, text: str, pages, formats=("png",)
                ) -> list[Path]:
    """A study's outputs into ``out``: ``stem.csv`` (``write_csv(path)``), ``stem.md``
    (``text``) and the figure's pages that ``pages()`` draws, in :data:`STYLE`, in each
    of ``formats`` (:func:`save_pages`), each file whole; their paths.
    """
    import matplotlib

    matplotlib.use("Agg")  # files only, whatever display there is
    import matplotlib.pyplot as plt

    out.mkdir(parents=True, exist_ok=True)
    write_csv(out / f"{stem}.csv")
    files.write_text(out / f"{stem}.md", text)
    with styled():
        figs = pages()
        written = save_pages(figs, out / stem, formats)
    for fig in figs:
        plt.close(fig)
    return [out / f"{stem}.csv", out / f"{stem}.md", *written]


def problems(fig) -> list[str]:
    """What in the drawn ``fig`` breaks the print rules any figure keeps (module doc:
    type size, titles and units, legends off the panels, every legend entry with an
    artist in view), one line each; empty when it keeps them all.
    """
    _drawn(fig)
    found = _small_text(fig) + _unlabelled(fig)
    renderer = fig.canvas.get_renderer()
    areas = [ax.bbox for ax in fig.axes if ax.get_visible() and ax.axison]
    for legend in _legends(fig):
        box = legend.get_window_extent(renderer)
        if any(box.overlaps(area) for area in areas):
            found.append("a legend sits over a panel's plotting area")
        for text in legend.get_texts():
            if not any(_shows(a) for a in _labelled(fig, text.get_text())):
                found.append(f"legend entry {text.get_text()!r} has no visible artist")
    return found


def print_problems(fig) -> list[str]:
    """:func:`problems`, and what else breaks the rules of print: a figure larger than
    :data:`PAGE_IN`, text running off it, a legend entry whose artists are all covered
    by others (drawn without them, the figure's pixels do not change).
    """
    found = problems(fig) + _off_page(fig)
    width, height = fig.get_size_inches()
    if width > PAGE_IN[0] + 1e-6 or height > PAGE_IN[1] + 1e-6:
        found.append(f"{width:.2f} x {height:.2f} in: larger than a page "
                     f"({PAGE_IN[0]:g} x {PAGE_IN[1]:g} in)")
    return found + [f"legend entry {label!r} is covered by other artists"
                    for label in covered(fig)]


def covered(fig) -> list[str]:
    """The legend entries of ``fig`` whose artists do not show: hidden, the pixels of
    their panels stay the same (other artists lie over every pixel of theirs). Drawn
    without anti-aliasing for the comparison, so that a line under an equal one is not
    taken to show by the blended pixels of its edges.
    """
    _drawn(fig)
    drawn = [a for ax in fig.axes for a in ax.lines + ax.collections]
    smooth = [a.get_antialiased() for a in drawn]
    for artist in drawn:
        artist.set_antialiased(False)
    try:
        whole = {ax: _panel_pixels(fig, ax) for ax in fig.axes if ax.get_visible()}
        found = []
        for label in dict.fromkeys(t.get_text() for lg in _legends(fig)
                                   for t in lg.get_texts()):
            artists = [a for a in _labelled(fig, label) if a.get_visible()]
            for artist in artists:
                artist.set_visible(False)
            if all(np.array_equal(_panel_pixels(fig, ax), whole[ax])
                   for ax in {a.axes for a in artists}):
                found.append(label)
            for artist in artists:
                artist.set_visible(True)
    finally:
        for artist, was in zip(drawn, smooth):
            artist.set_antialiased(was)
    return found


def _panel_pixels(fig, ax) -> np.ndarray:
    """The pixels of ``ax`` drawn alone on the figure's canvas."""
    renderer = fig.canvas.get_renderer()
    renderer.clear()
    ax.draw(renderer)
    return np.asarray(renderer.buffer_rgba()).copy()


def drawn_before(fig, until_s: float, labels) -> list[str]:
    """The curves of ``fig`` whose label starts with one of ``labels`` and that have a
    point drawn at x < ``until_s``: data inside a start-up interval the figure leaves
    out; one line each.
    """
    labels, found = tuple(labels), []
    for line in (line for ax in fig.axes for line in ax.lines
                 if line.get_label().startswith(labels)):
        x, y = (np.asarray(line.get_xdata(), float), np.asarray(line.get_ydata(), float))
        early = (x < until_s - 1e-12) & np.isfinite(y)
        if early.any():
            found.append(f"{line.get_label()!r} drawn at x = {x[early].min():g} < {until_s:g}")
    return found


def _drawn(fig) -> None:
    if not hasattr(fig.canvas, "get_renderer"):  # a closed pyplot figure: draw it again
        from matplotlib.backends.backend_agg import FigureCanvasAgg

        FigureCanvasAgg(fig)
    fig.canvas.draw()


def _legends(fig) -> list:
    return fig.legends + [ax.get_legend() for ax in fig.axes if ax.get_legend()]


def _off_page(fig) -> list[str]:
    """What of the drawn ``fig`` reaches beyond its edges (cut off in print): a panel
    with its labels, notes and legend, the figure's own texts and legends.
    """
    renderer, page = fig.canvas.get_renderer(), fig.bbox.padded(1.0)
    boxes = [(f"panel {ax.get_title(loc='left')[:40]!r}", ax.get_tightbbox(renderer))
             for ax in fig.axes if ax.get_visible()]
    boxes += [(f"text {t.get_text()[:40]!r}", t.get_window_extent(renderer))
              for t in fig.texts if t.get_visible() and t.get_text().strip()]
    boxes += [("a legend", legend.get_window_extent(renderer)) for legend in fig.legends]
    return [f"{what} runs off the figure" for what, box in boxes
            if not (page.contains(*box.min) and page.contains(*box.max))]


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
    """The lines and filled regions labelled ``label`` (a legend wraps long labels)."""
    words = label.split()
    return [a for ax in fig.axes for a in ax.lines + ax.collections
            if str(a.get_label()).split() == words]


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


def draw_set(ax, t, set_min, set_max, unit: str = "N", view=None) -> tuple[dict, str]:
    """Draw the rigid solution set behind the curves: shaded (with its edges, so a set of
    one value still shows) where both bounds are finite; where one side is open, the
    finite bound dashed with triangles pointing to the open side. With ``view`` (the
    panel's y range, :func:`limits`), such a bound where it lies outside the range is
    marked by its triangles on the panel's edge instead. Returns the legend handles and
    the panel's note: which sides are open, at how many instants, and the finite
    bounds' span.
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
        single = both & (hi - lo <= SAME_RTOL * max(np.max(np.abs(hi[both])), 1e-9))
        if single.any():  # a determinate quantity: the band is a line under the curves
            notes.append(f"one value (determinate) {_share(int(single.sum()), n)}")
    low, high = view if view is not None else (-np.inf, np.inf)
    sides = ((lo, hi, "^", "open above", "lower", OPEN_ABOVE_LABEL, BELOW_VIEW_LABEL),
             (hi, lo, "v", "open below", "upper", OPEN_BELOW_LABEL, ABOVE_VIEW_LABEL))
    for bound, other, marker, side, word, label, off_label in sides:
        one = np.isfinite(bound) & ~np.isfinite(other)
        if not one.any():
            continue
        off = one & ((bound < low) if word == "lower" else (bound > high))
        every = (0, max(1, len(tc) // 10))
        if (one & ~off).any():
            handles[label], = ax.plot(tc, np.where(one & ~off, bound, np.nan), ls="--",
                                      lw=1.0, color="0.25", marker=marker, ms=4.5, zorder=2,
                                      markevery=every, label=label)
        if off.any():
            edge = low + 0.03 * (high - low) if word == "lower" else high - 0.03 * (high - low)
            handles[off_label], = ax.plot(tc, np.where(off, edge, np.nan), ls="none",
                                          color="0.25", marker=marker, ms=4.5, zorder=2,
                                          markevery=every, label=off_label)
        notes.append(f"{side} {_share(int(one.sum()), n)}, {word} bound "
                     f"{span_text(bound[one], unit)}"
                     + (f" ({'below' if word == 'lower' else 'above'} the axis "
                        f"{_share(int(off.sum()), int(one.sum()))})" if off.any() else ""))
    free = ~np.isfinite(lo) & ~np.isfinite(hi)
    if free.any():
        notes.append(f"open above and below (any value) {_share(int(free.sum()), n)}")
    return handles, "rigid set: " + "; ".join(notes) if notes else ""


def limits(curves: list, bounds: list = ()) -> tuple[float, float]:
    """A panel's y range: the finite values of ``curves`` with a margin of 15 % of their
    range (at least 5 % of the largest magnitude, so a flat line is not drawn as noise),
    widened to hold each finite value of ``bounds`` (a rigid set's ends) that lies
    within :data:`BOUND_REACH` of that range; those farther off are left outside.
    """
    low, high = _margin(_finite(curves))
    reach = BOUND_REACH * (high - low)
    near = _finite(bounds)
    near = near[(near >= low - reach) & (near <= high + reach)]
    return _margin(np.concatenate([_finite(curves), near])) if near.size else (low, high)


def _finite(curves) -> np.ndarray:
    values = [np.asarray(c, float).ravel() for c in curves if c is not None]
    values = np.concatenate(values) if values else np.zeros(0)
    return values[np.isfinite(values)]


def _margin(values: np.ndarray) -> tuple[float, float]:
    if not values.size or not np.any(values):  # nothing, or zero only: a unit each way
        return -1.0, 1.0
    lo, hi = float(values.min()), float(values.max())
    margin = max(0.15 * (hi - lo), 0.05 * max(abs(lo), abs(hi)), 1e-9)
    return lo - margin, hi + margin


def coincide_note(curves: dict, groups: list[tuple[str, ...]], unit: str) -> str:
    """``a = b within x N; c = d within y N``: the ``groups`` of ``curves`` drawn on one
    another (:func:`coinciding`), each with the largest difference between its members.
    """
    return "; ".join(f"{' = '.join(g)} within {spread(curves, g):.2g} {unit}"
                     for g in groups)


def spread(curves: dict, group) -> float:
    """The largest difference between the ``group`` of ``curves`` at one instant."""
    stack = np.array([curves[name] for name in group], float)
    return float(np.nanmax(np.ptp(stack, axis=0), initial=0.0))


def on_bound(curves: dict, bound: np.ndarray, tol: float) -> dict[str, float]:
    """The ``curves`` that lie within ``tol`` of ``bound`` (a rigid set's end) wherever
    both are finite (an instant at least), with their largest distance from it: drawn,
    they hide the bound's line.
    """
    bound = np.asarray(bound, float)
    found = {}
    for name, values in curves.items():
        both = np.isfinite(bound) & np.isfinite(np.asarray(values, float))
        gap = np.abs(np.asarray(values, float)[both] - bound[both])
        if both.any() and gap.max() <= tol:
            found[name] = float(gap.max())
    return found


def bound_note(found: dict[str, float], word: str, unit: str) -> str:
    """``a, b on the rigid set's lower bound within x N`` (:func:`on_bound`'s ``found``)."""
    if not found:
        return ""
    return (f"{', '.join(found)} on the rigid set's {word} bound within "
            f"{max(found.values()):.2g} {unit}")


def interleave(k: int, n: int, dash: float = 4.0) -> tuple:
    """The line style of the ``k``-th (from 0) of ``n`` curves drawn on one another:
    the first solid, each other dashed so that the dashes of each show in turn over it
    (every colour along the whole line).
    """
    if k == 0:
        return "-"
    return ((k - 1) * dash, (dash, (n - 1) * dash))


def _share(count: int, total: int) -> str:
    if count == total:
        return {1: "at the one instant", 2: "at both instants"}.get(total,
                                                                    f"at all {total} instants")
    return f"at {count} of {total} instants"
