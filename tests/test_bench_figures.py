"""``cardan bench``'s figures: one style per backend across panels and pages, words on
an empty panel, tick labels that do not overlap, the print rules (a page at most, the
print style's type, every legend entry showing in every panel where its curves lie on
others), the y ranges of every figure (on hand-made points and profiles)."""

import itertools
import math

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
from cardan_forces.experiments import bench_report, images  # noqa: E402
from cardan_forces.experiments.bench_metrics import TAUS  # noqa: E402
from matplotlib.text import Text  # noqa: E402

MAKERS = (bench_report.pareto_pages, bench_report.profiles_pages)


def _point(formulation, solver, time_s, error, front=False):
    return {"formulation": formulation, "solver": solver, "time_s": time_s, "error": error,
            "front": front, "tol": "default"}


def _profile(formulation, profile, solver, curve):
    return {"formulation": formulation, "profile": profile, "clock": "solver",
            "level": 1e-8, "solver": solver, "curve": list(curve)}


def _close(figs):
    for fig in figs:
        plt.close(fig)


def _styles_by_panel(figs):
    """{backend: {(colour, marker), ...}} over every labelled line of every panel."""
    seen = {}
    for ax in (ax for fig in figs for ax in fig.axes):
        for line in ax.get_lines():
            if not line.get_label().startswith("_"):
                seen.setdefault(line.get_label(), set()).add(
                    (tuple(np.round(_rgb(line.get_color()), 6)), line.get_marker()))
    return seen


def _rgb(colour):
    from matplotlib.colors import to_rgb

    return to_rgb(colour)


def test_a_backend_keeps_its_colour_and_marker_in_every_panel():
    # the backends come in a different order, and different subsets, in each panel
    points = [_point("a", "zeta", 1e-3, 1e-8), _point("a", "alpha", 2e-3, 1e-9),
              _point("b", "alpha", 1e-3, 1e-6), _point("b", "mid", 3e-3, 1e-7),
              _point("b", "zeta", 5e-4, 1e-5), _point("c", "mid", 1e-3, 1e-9)]
    profiles = [_profile("b", "high", "mid", np.ones_like(TAUS)),
                _profile("a", "high", "zeta", np.ones_like(TAUS)),
                _profile("a", "high", "alpha", np.ones_like(TAUS))]
    styles = bench_report.backend_styles(["zeta", "alpha", "mid"])
    seen = {}
    for make, data in zip(MAKERS, (points, profiles)):
        figs = make(data, styles)
        for name, found in _styles_by_panel(figs).items():
            seen.setdefault(name, set()).update(found)
        _close(figs)
    assert set(seen) == {"zeta", "alpha", "mid"}
    assert all(len(found) == 1 for found in seen.values()), seen
    assert len({next(iter(found)) for found in seen.values()}) == 3  # all different


def test_styles_differ_for_many_backends_and_print_dark():
    names = [f"backend-{k}" for k in range(40)]
    styles = bench_report.backend_styles(names)
    assert len(set(styles.values())) == 40
    assert styles == bench_report.backend_styles(reversed(names))  # fixed by the names
    # no pale colour (a light tint fades in print): each at most 0.75 bright on average
    assert max(sum(_rgb(colour)) / 3 for colour, _ in styles.values()) <= 0.75


def _texts(ax):
    return " ".join(t.get_text() for t in ax.texts)


def test_an_empty_panel_says_why():
    profiles = [_profile("a", "high", "x", np.zeros_like(TAUS)),
                _profile("a", "high", "y", np.zeros_like(TAUS)),
                _profile("b", "high", "x", np.r_[np.zeros(5), np.ones(len(TAUS) - 5)])]
    fig, = bench_report.profiles_pages(profiles)
    empty, drawn = fig.axes[0], fig.axes[1]
    assert bench_report.EMPTY_PROFILE in _texts(empty)
    assert bench_report.EMPTY_PROFILE not in _texts(drawn)
    plt.close(fig)
    points = [_point("a", "x", 1e-3, math.nan), _point("b", "x", 1e-3, 1e-9, True)]
    fig, = bench_report.pareto_pages(points)
    assert bench_report.EMPTY_PARETO in _texts(fig.axes[0])
    assert bench_report.EMPTY_PARETO not in _texts(fig.axes[1])
    plt.close(fig)


@pytest.mark.parametrize("low, high", [(1.4e-3, 2.2e-3), (1.1e-4, 2.9e-3), (1e-7, 3e-1)])
def test_tick_labels_do_not_overlap(low, high):
    points = [_point("a", "x", low, 1e-12), _point("a", "y", high, 3e-12),
              _point("b", "x", low, 1e-15), _point("b", "y", high, 1e-2)]
    fig, = bench_report.pareto_pages(points)
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    for ax in fig.axes:
        for axis in (ax.xaxis, ax.yaxis):
            boxes = [t.get_window_extent(renderer) for t in axis.get_ticklabels(which="both")
                     if t.get_visible() and t.get_text()]
            assert len(boxes) >= 2, "an axis without two labelled ticks cannot be read"
            for one, two in itertools.combinations(boxes, 2):
                assert not one.overlaps(two)
    plt.close(fig)


def hidden_in_its_panel(fig) -> list[str]:
    """The labelled lines of ``fig`` that do not show in their own panel: drawn
    without the line (and without anti-aliasing, as :func:`images.covered` does), the
    panel's pixels stay the same. Stricter than :func:`images.covered`, which asks a
    legend entry to show in one of its panels."""
    fig.canvas.draw()
    lines = [line for ax in fig.axes for line in ax.get_lines()
             if not line.get_label().startswith("_")]
    for line in lines:
        line.set_antialiased(False)
    renderer, found = fig.canvas.get_renderer(), []

    def pixels(ax):
        renderer.clear()
        ax.draw(renderer)
        return np.asarray(renderer.buffer_rgba()).copy()

    whole = {ax: pixels(ax) for ax in {line.axes for line in lines}}
    for line in lines:
        line.set_visible(False)
        if np.array_equal(pixels(line.axes), whole[line.axes]):
            found.append(f"{line.axes.get_title(loc='left').splitlines()[0]}: "
                         f"{line.get_label()}")
        line.set_visible(True)
    return found


def _crowded(formulations: int = 9):
    """A bench's worth of data where curves lie on one another: five backends at one
    time and 1e-14 (a sixth a hair away), profiles at 1 from the start or equal at
    every tau; nine formulations, so that the panels take pages."""
    solvers = ["clarabel", "moreau", "newton", "numpy-kkt", "qpsolvers-daqp", "osqp"]
    points, profiles = [], []
    for f in range(formulations):
        name = f"form-{f}"
        for k, solver in enumerate(solvers):
            points.append(_point(name, solver, 1.5e-3, 1e-14, k == 0))
            points.append(_point(name, solver, 1.5e-3 * (1 + 0.001 * k), 1e-14))
            points.append(_point(name, solver, 1e-4 * (k + 1), 10.0 ** -(6 + k)))
        for level in ("default", "high"):
            for k, solver in enumerate(solvers):
                curve = np.ones_like(TAUS) if k < 3 else np.where(TAUS >= 1 + k, 1.0, 0.2)
                profiles.append(_profile(name, level, solver, curve))
    return points, profiles


@pytest.mark.slow
@pytest.mark.parametrize("make", MAKERS, ids=["pareto", "profiles"])
def test_pages_keep_the_print_rules_where_curves_lie_on_one_another(make):
    """Every page: within a page (7 x 9 in), the print style's type only (no text
    larger than a figure's title, none under 7 pt), no problem of print
    (:func:`images.print_problems`), every backend showing in every panel it is drawn
    in; several pages, each titled with its number, every panel drawn once."""
    points, profiles = _crowded()
    figs = make(points if make is bench_report.pareto_pages else profiles, None, "paper")
    assert len(figs) > 1
    sizes = set()
    for k, fig in enumerate(figs, 1):
        width, height = fig.get_size_inches()
        assert width <= images.PAGE_IN[0] and height <= images.PAGE_IN[1]
        assert images.print_problems(fig) == [], fig.get_suptitle()
        assert hidden_in_its_panel(fig) == [], fig.get_suptitle()
        assert f"page {k} of {len(figs)}" in fig.get_suptitle()
        assert "(scene paper)" in fig.get_suptitle()
        sizes |= {t.get_fontsize() for t in fig.findobj(Text) if t.get_text().strip()}
    assert images.MIN_TEXT_PT <= min(sizes) and max(sizes) <= images.TITLE_PT
    titles = [ax.get_title(loc="left") for fig in figs for ax in fig.axes if ax.get_visible()]
    assert len(titles) == (9 if make is bench_report.pareto_pages else 18)
    _close(figs)


def test_points_on_one_another_are_named_and_equal_profiles_interleaved():
    """Where open markers of several backends lie on one another the panel names them
    (five at 1.5e-3 s and 1e-14; not those at their own places); profiles equal at
    every tau are named and drawn in interleaved dashes, each curve with its markers at
    tau steps of its own."""
    points, profiles = _crowded(1)
    fig, = bench_report.pareto_pages(points)
    title = " ".join(fig.axes[0].get_title(loc="left").split())
    assert ("on one another: clarabel, moreau, newton, numpy-kkt, qpsolvers-daqp, osqp "
            "(0.0015 s, 1e-14)") in title
    plt.close(fig)
    fig, = bench_report.profiles_pages(profiles)
    ax = fig.axes[0]
    assert "equal at every tau: clarabel = moreau = newton" in " ".join(
        ax.get_title(loc="left").split())
    styles = {line.get_label(): line.get_linestyle() for line in ax.get_lines()}
    assert styles["clarabel"] == "-" and styles["moreau"] != "-" != styles["newton"]
    starts = [line.get_markevery()[0] for line in ax.get_lines()]
    assert len(set(starts)) == len(starts)
    plt.close(fig)


def test_y_ranges_are_the_figures_limits():
    """A profile panel's y range is :func:`images.limits` of its shares and 0 and 1
    (curves at 0 and 1 lie inside the frame); a Pareto panel's, of the logarithms of its
    measures; points between 1.4e-2 and 2.3e-2 s span most of the x axis (not squeezed
    at one edge of a widened one); a panel no solve reached draws no line."""
    points = [_point("a", "x", 1.4e-2, 1e-6), _point("a", "x", 2.3e-2, 1e-15, True)]
    fig, = bench_report.pareto_pages(points)
    low, high = fig.axes[0].get_xlim()
    assert math.log10(2.3e-2 / 1.4e-2) / math.log10(high / low) > 0.6
    expect = images.limits([np.log10([1e-6, 1e-15])])
    assert np.allclose(np.log10(fig.axes[0].get_ylim()), expect)
    plt.close(fig)
    profiles = [_profile("a", "high", "x", np.ones_like(TAUS)),
                _profile("a", "high", "y", np.zeros_like(TAUS)),
                _profile("b", "high", "x", np.zeros_like(TAUS))]
    fig, = bench_report.profiles_pages(profiles)
    low, high = fig.axes[0].get_ylim()
    assert (low, high) == images.limits([np.ones(3), np.zeros(3), [0.0, 1.0]])
    assert low < 0.0 and 1.0 < high
    assert len(fig.axes[0].get_lines()) == 2 and not fig.axes[1].get_lines()
    plt.close(fig)


def test_a_figure_of_several_pages_is_written_a_page_each_and_named_so(tmp_path):
    """``plot_profiles`` of 8 panels: a PNG per page and one PDF; the report names the
    pages it wrote."""
    _, profiles = _crowded(4)
    paths = bench_report.plot_profiles(profiles, tmp_path / "bench_profiles.png",
                                       ("png", "pdf"))
    pages = sorted(p.name for p in paths if p.suffix == ".png")
    assert len(pages) > 1 and pages[0] == "bench_profiles-1.png"
    assert tmp_path.joinpath("bench_profiles.pdf") in paths
    words = bench_report.profiles_files(profiles)
    assert all(f"`{name}`" in words for name in pages)
    assert bench_report.pareto_files([_point("a", "x", 1e-3, 1e-9)]) == "`bench_pareto.png`"
