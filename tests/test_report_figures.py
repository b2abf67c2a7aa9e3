"""``cardan report``'s figure: what each panel shows (units, bands, determinacy), tested
on constructed solution sets whose drawing is known, and the command's image formats.
"""

from __future__ import annotations

import re

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
from cardan_forces.driveline.dynamics import simulate  # noqa: E402
from cardan_forces.driveline.equilibrium import build_operator  # noqa: E402
from cardan_forces.driveline.loading import load_scene  # noqa: E402
from cardan_forces.experiments import images, report  # noqa: E402
from matplotlib.collections import PolyCollection  # noqa: E402
from matplotlib.text import Text  # noqa: E402

from cardan_forces.cli import main  # noqa: E402

NAN = np.nan


@pytest.fixture(scope="module")
def op():
    return build_operator(simulate(load_scene("propshaft"), [0.0, 0.1, 0.2, 0.3]))


def _histories(op, columns: dict[int, tuple]) -> dict[str, np.ndarray]:
    """Constructed histories: every component 0 and determinate except ``columns``,
    ``{j: (value, min, max)}`` with each entry a number or an array over the instants.
    """
    shape = (len(op.t), len(op.names))
    h = {"value": np.zeros(shape), "min": np.zeros(shape), "max": np.zeros(shape),
         "determinate": np.ones(shape, bool)}
    for j, (value, lo, hi) in columns.items():
        h["value"][:, j], h["min"][:, j], h["max"][:, j] = value, lo, hi
        h["determinate"][:, j] = False
    return h


def _panel(op, name: str, unit: str = "N") -> report.Panel:
    return next(p for p in report.panels(op) if p.contact.name == name and p.unit == unit)


def _filled(ax) -> list[np.ndarray]:
    """The vertices of every non-empty filled region drawn on ``ax``."""
    return [path.vertices for c in ax.collections if isinstance(c, PolyCollection)
            for path in c.get_paths() if len(path.vertices)]


def test_moments_have_their_own_panel_and_every_axis_its_unit(op):
    grid = report.panels(op)
    assert sorted(j for p in grid for j in p.columns) == list(range(len(op.names)))
    for p in grid:  # no panel mixes N and N m
        assert {p.contact.units[p.contact.columns.index(j)] for j in p.columns} == {p.unit}
    spline = [p for p in grid if p.contact.name == "spline"]
    assert sorted(p.unit for p in spline) == ["N", "N m"]
    torque = op.index("spline.torque")
    assert torque in _panel(op, "spline", "N m").columns
    assert torque not in _panel(op, "spline", "N").columns
    fig, ax = plt.subplots()
    for panel, label in ((_panel(op, "spline", "N m"), "[N m]"), (_panel(op, "spline"), "[N]")):
        ax.clear()
        report._draw(ax, op, _histories(op, {}), panel)
        assert ax.get_ylabel().endswith(label) and ax.get_xlabel() == "time t [s]"
    plt.close(fig)


def test_band_where_both_ends_are_finite_and_the_finite_end_where_one_side_is_open(op):
    panel = _panel(op, "bearing.gearbox.rear")
    x, y, z = panel.columns
    h = _histories(op, {x: (0.0, -50.0, 80.0),       # bounded: a band from -50 to 80
                        y: (10.0, 5.0, NAN),         # open above: its lower end, 5
                        z: (0.0, NAN, NAN)})         # open both sides: nothing to shade
    fig, ax = plt.subplots()
    report._draw(ax, op, h, panel)
    regions = _filled(ax)
    band = [v for v in regions if np.isclose(v[:, 1].min(), -50) and np.isclose(
        v[:, 1].max(), 80)]
    assert band, "the bounded component's band is drawn"
    low, high = ax.get_ylim()
    assert low < -50 and high > 80  # the range holds the band
    dashed = [line for line in ax.get_lines()  # the set's ends: drawn, not in the legend
              if line.get_linestyle() == "--" and line.get_label().startswith("_")]
    ends = [np.asarray(line.get_ydata(), float) for line in dashed]
    assert any(np.allclose(e, 5.0) for e in ends), "the finite end of the open set"
    assert not [c for c in ax.collections if c.get_hatch()], "no hatched panel"
    assert [line.get_marker() for line in dashed] == ["^"]  # triangles to the open side
    arrows = [line for line in ax.get_lines() if line.get_marker() == report.BOTH_OPEN_MARK]
    assert len(arrows) == 1 and arrows[0].get_color() == "C2"  # z: any value, marked
    assert _legend(ax) == ["x: bounded", "y: open above",
                           "z: open below and above (\u2195 on the line); = x within 0 N"]
    plt.close(fig)


def _legend(ax) -> list[str]:
    """The entries of ``ax``'s legend, each on one line."""
    return [" ".join(t.get_text().split()) for t in ax.get_legend().get_texts()]


def test_a_determinate_component_is_not_called_unbounded(op):
    panel = _panel(op, "bearing.gearbox.rear")
    x, y, z = panel.columns
    fig, ax = plt.subplots()
    report._draw(ax, op, _histories(op, {x: (0.0, NAN, NAN)}), panel)
    assert _legend(ax) == ["x: open below and above (\u2195 on the line)",
                           "y: determinate; = x within 0 N", "z: determinate; = x within 0 N"]
    assert "unbounded" not in ax.get_title() and "open" not in ax.get_title()
    plt.close(fig)


def test_the_fixed_layout_holds_every_panel_s_text(op):
    """The grid's fixed margins (no layout engine): with the widest tick labels the
    loads give (five digits and a sign, as a trunnion's -20000 N), no panel's labels,
    title or legend reach into another's or out of its page, nor into the page's title;
    every panel is on one page, each page of print size."""
    h = _histories(op, {j: (-20000.0 + 4000.0 * k, NAN, NAN)
                        for k, j in enumerate(range(0, len(op.names), 3))})
    with images.styled():
        figs = report.pages(op, h)
    assert sum(ax.get_visible() for fig in figs for ax in fig.axes) == len(report.panels(op, h))
    for fig in figs:
        fig.canvas.draw()
        renderer = fig.canvas.get_renderer()
        boxes = [ax.get_tightbbox(renderer) for ax in fig.axes if ax.get_visible()]
        title = next(c for c in fig.get_children() if isinstance(c, Text)
                     and c.get_text() == fig.get_suptitle()).get_window_extent(renderer)
        for k, box in enumerate(boxes):
            assert fig.bbox.x0 <= box.x0 and box.x1 <= fig.bbox.x1
            assert fig.bbox.y0 <= box.y0 and box.y1 <= title.y0
            assert not any(box.overlaps(other) for other in boxes[k + 1:])
        assert title.y1 <= fig.bbox.y1
        assert tuple(fig.get_size_inches()) == images.PAGE_IN
        plt.close(fig)


@pytest.mark.parametrize(("lo", "hi", "det", "words"), [
    ([1.0, 2.0], [1.0, 2.0], [True, True], "determinate"),
    ([0.0, 1.0], [3.0, 4.0], [False, False], "bounded"),
    ([0.0, 0.0], [NAN, NAN], [False, False], "open above"),
    ([NAN, NAN], [0.0, 0.0], [False, False], "open below"),
    ([0.0, NAN], [NAN, NAN], [False, False], "open below at 1 of 2 and above"),
    ([1.0, 0.0], [1.0, 5.0], [True, False], "bounded, determinate at 1 of 2"),
])
def test_set_words(lo, hi, det, words):
    assert report.set_words(np.array(lo), np.array(hi), np.array(det)) == words


@pytest.mark.slow
def test_report_writes_every_format_asked_a_page_each_and_one_pdf(tmp_path, capsys):
    """A report of many panels on pages (paper's five): a PNG and an SVG per page, one
    PDF of them all, and ``report.md`` naming them."""
    assert main(["report", "paper", "--instants", "2", "--format", "png,svg,pdf",
                 "--out", str(tmp_path), "--quiet"]) == 0
    written = [p.name for p in tmp_path.iterdir()]
    assert {p.rsplit(".", 1)[1] for p in written} == {"csv", "png", "svg", "pdf", "md"}
    pngs = sorted(tmp_path.glob("report-*.png"))
    assert len(pngs) > 1 and len(pngs) == len(list(tmp_path.glob("report-*.svg")))
    assert not (tmp_path / "report.png").exists()
    assert (tmp_path / "report-1.svg").read_text().lstrip().startswith("<?xml")
    pdf = (tmp_path / "report.pdf").read_bytes()
    assert len(re.findall(rb"/Type /Page\b", pdf)) == len(pngs)
    md = (tmp_path / "report.md").read_text()
    assert "## Figure" in md and all(f"`{p.name}`" in md for p in pngs)
    assert main(["report", "propshaft", "--format", "gif", "--out", str(tmp_path)]) == 2
    assert "--format" in capsys.readouterr().err


def test_engine_forces_are_drawn_in_each_component_s_colour_and_held_by_the_range(op):
    """``--engine``'s overlay: one marker curve per component, in its colour, with the
    engine's values (NaN before the settling is left undrawn), and the y range holds a
    value far outside the band."""
    panel = _panel(op, "bearing.gearbox.rear")
    x, y, z = panel.columns
    h = _histories(op, {x: (0.0, -50.0, 80.0)})
    forces = np.zeros((len(op.t), len(op.names)))
    forces[:, x] = [NAN, 10.0, 20.0, 500.0]
    forces[:, y] = 3.0
    fig, ax = plt.subplots()
    report._draw(ax, op, h, panel, forces)
    marked = [line for line in ax.get_lines() if line.get_marker() == "o"]
    assert len(marked) == 3
    solid = {line.get_color() for line in ax.get_lines() if line.get_linestyle() != "None"
             and not line.get_label().startswith("_")}
    for line, j in zip(marked, (x, y, z)):
        assert np.array_equal(np.asarray(line.get_ydata(), float), forces[:, j], equal_nan=True)
        assert line.get_color() in solid
    assert ax.get_ylim()[1] > 500
    assert report.ENGINE_LABEL in _legend(ax)
    plt.close(fig)


@pytest.mark.parametrize("hide_mujoco", [False, True])
def test_engine_refused_in_one_line_before_any_work(tmp_path, capsys, monkeypatch, hide_mujoco):
    """A quasi-static scene (propshaft) cannot be simulated by the engine; without MuJoCo
    the refusal says how to install it. One line, exit 2, nothing written."""
    import sys

    if hide_mujoco:
        monkeypatch.setitem(sys.modules, "mujoco", None)
        scene, words = "paper", "pip install"
    else:
        scene, words = "propshaft", "quasi-static"
    assert main(["report", scene, "--engine", "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("cardan: error:") and words in err[0]
    assert not (tmp_path / "out").exists()


@pytest.mark.slow
def test_the_report_figure_keeps_the_print_rules(op, monkeypatch):
    """Titles, units, 8 pt type, every legend entry visible and off the data: on
    propshaft's contacts with a bounded, an open and a both-open component."""
    panel = _panel(op, "bearing.gearbox.rear")
    x, y, z = panel.columns
    h = _histories(op, {x: (0.0, -50.0, 80.0), y: (10.0, 5.0, NAN), z: (3.0, NAN, NAN)})
    with images.styled():
        figs = report.pages(op, h)
    for fig in figs:
        assert images.print_problems(fig) == []
        plt.close(fig)


def test_components_of_different_scales_get_panels_of_their_own(op):
    """A bearing's 21 kN component does not share an axis with one of a few newtons; a
    component at zero stays with the large one."""
    panel = _panel(op, "bearing.gearbox.rear")
    x, y, z = panel.columns
    h = _histories(op, {x: (21000.0, 20000.0, 22000.0), y: (3.0, 1.0, 5.0)})
    split = [p for p in report.panels(op, h) if p.contact.name == "bearing.gearbox.rear"]
    assert sorted(p.columns for p in split) == sorted([(x, z), (y,)])
    assert all(p.split and ", ".join(p.names) in p.title for p in split)
    assert sorted(j for p in report.panels(op, h) for j in p.columns) == list(range(len(op.names)))


@pytest.mark.parametrize("scene", ["paper", "propshaft"])
def test_default_instants_resolve_the_twice_per_revolution_fluctuation(scene):
    """At least 10 instants per period pi / omega_max of the intermediate shaft's
    fluctuation, or the whole grid."""
    s = load_scene(scene)
    grid = s.time.instants()
    n = report.default_instants(s)
    omega = np.max(np.abs(simulate(s, grid).omega[0]))
    per_period = (n - 1) / (grid[-1] - grid[0]) * np.pi / omega
    assert per_period >= 10 or n == len(grid)
    assert report.INSTANTS <= n <= len(grid)
