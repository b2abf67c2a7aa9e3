"""``cardan bench``'s figures: one style per backend across panels, words on an empty
panel, tick labels that do not overlap (on hand-made points and profiles)."""

import itertools
import math

import numpy as np
import pytest
from cardan_forces.experiments import bench_report
from cardan_forces.experiments.bench_metrics import TAUS


def _point(formulation, solver, time_s, error, front=False):
    return {"formulation": formulation, "solver": solver, "time_s": time_s, "error": error,
            "front": front, "tol": "default"}


def _profile(formulation, profile, solver, curve):
    return {"formulation": formulation, "profile": profile, "clock": "solver",
            "level": 1e-8, "solver": solver, "curve": list(curve)}


def _styles_by_panel(fig):
    """{backend: {(colour, marker), ...}} over every labelled line of every panel."""
    seen = {}
    for ax in fig.axes:
        for line in ax.get_lines():
            if not line.get_label().startswith("_"):
                seen.setdefault(line.get_label(), set()).add(
                    (tuple(np.round(line.get_color() if isinstance(line.get_color(), tuple)
                                    else _rgb(line.get_color()), 6)), line.get_marker()))
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
    for make, data in ((bench_report.pareto_figure, points),
                       (bench_report.profiles_figure, profiles)):
        plt, fig = make(data, styles)
        for name, found in _styles_by_panel(fig).items():
            seen.setdefault(name, set()).update(found)
        plt.close(fig)
    assert set(seen) == {"zeta", "alpha", "mid"}
    assert all(len(found) == 1 for found in seen.values()), seen
    assert len({next(iter(found)) for found in seen.values()}) == 3  # all different


def test_styles_differ_for_many_backends():
    names = [f"backend-{k}" for k in range(40)]
    styles = bench_report.backend_styles(names)
    assert len(set(styles.values())) == 40
    assert styles == bench_report.backend_styles(reversed(names))  # fixed by the names


def _texts(ax):
    return " ".join(t.get_text() for t in ax.texts)


def test_an_empty_panel_says_why():
    profiles = [_profile("a", "high", "x", np.zeros_like(TAUS)),
                _profile("a", "high", "y", np.zeros_like(TAUS)),
                _profile("b", "high", "x", np.r_[np.zeros(5), np.ones(len(TAUS) - 5)])]
    plt, fig = bench_report.profiles_figure(profiles)
    empty, drawn = fig.axes[0], fig.axes[1]
    assert bench_report.EMPTY_PROFILE in _texts(empty)
    assert bench_report.EMPTY_PROFILE not in _texts(drawn)
    plt.close(fig)
    points = [_point("a", "x", 1e-3, math.nan), _point("b", "x", 1e-3, 1e-9, True)]
    plt, fig = bench_report.pareto_figure(points)
    assert bench_report.EMPTY_PARETO in _texts(fig.axes[0])
    assert bench_report.EMPTY_PARETO not in _texts(fig.axes[1])
    plt.close(fig)


@pytest.mark.parametrize("low, high", [(1.4e-3, 2.2e-3), (1.1e-4, 2.9e-3), (1e-7, 3e-1)])
def test_tick_labels_do_not_overlap(low, high):
    points = [_point("a", "x", low, 1e-12), _point("a", "y", high, 3e-12),
              _point("b", "x", low, 1e-15), _point("b", "y", high, 1e-2)]
    plt, fig = bench_report.pareto_figure(points)
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


def test_both_figures_keep_the_print_rules_and_name_the_scene():
    from cardan_forces.experiments import images

    points = [_point("a", "x", 1.4e-2, 2e-6), _point("a", "x", 2.3e-2, 0.0, True),
              _point("a", "y", 1.9e-2, 1e-15, True), _point("b", "x", 1e-3, math.nan)]
    profiles = [_profile("a", "high", "x", np.ones_like(TAUS)),
                _profile("a", "high", "y", np.zeros_like(TAUS)),
                _profile("b", "high", "x", np.zeros_like(TAUS))]
    for make, data in ((bench_report.pareto_figure, points),
                       (bench_report.profiles_figure, profiles)):
        plt, fig = make(data, None, "paper")
        assert images.problems(fig) == []
        assert "(scene paper)" in fig.get_suptitle()
        plt.close(fig)


def test_points_fill_their_axis_and_curves_at_0_and_1_stay_in_view():
    """A formulation's points between 1.4e-2 and 2.3e-2 s span most of the x axis (not
    squeezed at one edge of a widened one); profile curves at exactly 0 and 1 lie
    inside the frame; a panel no solve reached draws no line."""
    points = [_point("a", "x", 1.4e-2, 1e-6), _point("a", "x", 2.3e-2, 1e-15, True)]
    plt, fig = bench_report.pareto_figure(points)
    low, high = fig.axes[0].get_xlim()
    assert math.log10(2.3e-2 / 1.4e-2) / math.log10(high / low) > 0.6
    plt.close(fig)
    profiles = [_profile("a", "high", "x", np.ones_like(TAUS)),
                _profile("a", "high", "y", np.zeros_like(TAUS)),
                _profile("b", "high", "x", np.zeros_like(TAUS))]
    plt, fig = bench_report.profiles_figure(profiles)
    low, high = fig.axes[0].get_ylim()
    assert low < 0.0 and 1.0 < high
    assert len(fig.axes[0].get_lines()) == 2 and not fig.axes[1].get_lines()
    plt.close(fig)
