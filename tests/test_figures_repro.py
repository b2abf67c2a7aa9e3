"""``cardan repro``'s figures read back from what they drew: the print rules (titles,
units, legible type, every legend entry visible), the penalty's low-pass honest about
impacts and drawn only after its start-up, the rigid set drawn where it informs,
coinciding methods told apart, what a panel has to say in the figure's caption."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
from cardan_forces.driveline.dynamics import simulate  # noqa: E402
from cardan_forces.driveline.equilibrium import build_operator  # noqa: E402
from cardan_forces.driveline.loading import load_scene  # noqa: E402
from cardan_forces.experiments import images  # noqa: E402
from cardan_forces.paper_repro import figures, figures_draw, verdicts  # noqa: E402

T = np.arange(0.0, 0.6001, 0.005)
SETTLED = verdicts.SETTLED_S
"""The penalty's start-up, left out of its statistics and of the figures."""


@pytest.fixture(scope="module")
def op():
    return build_operator(simulate(load_scene("paper"), T))


@pytest.fixture
def drawn(monkeypatch):
    """The figures each command draws, kept (with their text sizes) instead of saved."""
    kept = []

    def keep(fig, stem, formats=("png",)):
        kept.append(fig)
        return []

    monkeypatch.setattr(images, "save", keep)
    yield kept
    for fig in kept:
        plt.close(fig)


def _histories(op):
    """Constructed forces (N): ``positive`` and ``min_max`` equal, ``compliance`` 5 %
    above, the penalty a ramp with an impact spike every 0.1 s."""
    n = len(op.names)
    base = 100.0 + 50.0 * np.outer(np.sin(4 * T), np.linspace(0.5, 1.5, n))
    spikes = np.where(np.arange(len(T)) % 20 == 7, 3.0, 1.0)[:, None]
    return {"positive": base, "min_max": base.copy(), "compliance": 1.05 * base,
            "penalty": (base + 40.0 * T[:, None]) * spikes}


def _bounds(labels, open_above=(), both_open=()):
    """label -> (low, high): open above at 10 N, open on both sides, or a band."""
    out = {}
    for q in labels:
        lo = np.full(len(T), 10.0 if q in open_above else -np.inf if q in both_open else 50.0)
        hi = np.full(len(T), np.inf if q in open_above or q in both_open else 300.0)
        out[q] = (lo, hi)
    return out


def _texts(fig) -> str:
    return " | ".join(t.get_text() for t in fig.findobj(matplotlib.text.Text))


def test_fig13_keeps_the_print_rules_and_names_what_it_plots(op, tmp_path, drawn):
    labels = sorted(op.joint_contacts(0))
    bounds = _bounds(labels, open_above=labels[:6], both_open=labels[6:7])
    _, caption = figures.fig13(op, _histories(op), bounds, tmp_path, settled_s=SETTLED)
    fig, = drawn
    assert images.print_problems(fig) == []
    text, said = _texts(fig), "\n".join(caption)
    assert "|F1|, magnitude" in text and "F3, push (end face)" in text
    assert "to 0 N" not in said.replace("0 to 0 N", "X")  # one value is printed once
    assert "0 to 0 N" not in said
    assert "open above and below (any value)" in said and "rigid set:" not in text
    assert "positive = min_max within 0 N" in text and "compliance" not in text.split("=")[-1][:20]


def test_an_open_set_is_its_bound_and_the_open_side_not_a_hatched_panel(op, tmp_path, drawn):
    labels = sorted(op.joint_contacts(0))
    _, caption = figures.fig13(op, _histories(op), _bounds(labels, open_above=labels),
                               tmp_path, settled_s=SETTLED)
    fig, = drawn
    for ax, label in zip(fig.axes, labels):
        assert not [c for c in ax.collections if c.get_hatch()], "no hatching"
        bound = {line.get_label(): line for line in ax.get_lines() if line.get_label() in
                 (images.OPEN_ABOVE_LABEL, images.BELOW_VIEW_LABEL)}
        assert [line.get_marker() for line in bound.values()] == ["^"]  # to the open side
        low, high = ax.get_ylim()
        if images.OPEN_ABOVE_LABEL in bound:  # the finite bound in view, else on the edge
            assert low < 10.0 < high
        else:
            assert 10.0 < low and "below the axis" in caption[labels.index(label) + 1]
        line = next(c for c in caption if c.startswith(f"- ({'abcdefgh'[labels.index(label)]})"))
        assert "open above at all" in line


def _texts_of(ax) -> str:
    return " ".join(t.get_text() for t in ax.texts) + ax.get_title(loc="left")


def test_the_penalty_is_drawn_after_its_start_up_and_low_passed_from_there(op, tmp_path,
                                                                          drawn):
    """Raw and filtered penalty curves start at the statistics' settled instant; the
    filtered one is the low-pass of the raw instants from there on (nothing of the
    start-up leaks in); the caption says from when and with which filter."""
    labels = sorted(op.joint_contacts(0))
    _, caption = figures.fig13(op, _histories(op), _bounds(labels), tmp_path, settled_s=SETTLED)
    cols = figures.read_csv(tmp_path / "fig13.csv")
    start = T[0] + verdicts.SETTLED_S
    expected = figures.low_pass(cols["F1_penalty"], T, start_s=start)
    assert np.allclose(cols["F1_penalty_lowpass"], expected, equal_nan=True)
    assert np.isnan(cols["F1_penalty_lowpass"][T < start]).all()
    assert np.isfinite(cols["F1_penalty_lowpass"][T >= start]).all()
    labels_drawn = figures.smooth_labels(start)
    assert images.drawn_before(drawn[0], start, tuple(labels_drawn.values())) == []
    line = next(line for line in drawn[0].axes[0].get_lines()
                if line.get_label() == labels_drawn[figures.SMOOTHED[False]])
    assert np.allclose(line.get_ydata(), expected, equal_nan=True)
    said = "\n".join(caption)
    assert f"from {start:g} s on" in said and f"cut-off {figures.LOWPASS_HZ:g} Hz" in said


def test_the_low_pass_makes_an_impact_a_bump_where_it_happened_not_a_plateau():
    """One instant of 2000 N over 100 N (an impact, t = 1 s): the box average of the
    statistics spreads it evenly over its 0.1 s window; the figures' low-pass peaks at
    the impact, is above its half for less than half the window, and keeps a slow swing."""
    t = np.arange(0.0, 2.0001, 0.005)
    slow = 100.0 + 20.0 * np.sin(2 * np.pi * 4.0 * t)
    hit = slow.copy()
    hit[200] += 1900.0
    low = figures.low_pass(hit, t)
    bump = low - figures.low_pass(slow, t)
    assert int(np.nanargmax(bump)) == 200
    assert np.ptp(np.flatnonzero(bump > bump[200] / 2)) * 0.005 <= figures.SMOOTH_S / 2
    box = figures.moving_average(hit, t) - figures.moving_average(slow, t)
    assert np.ptp(box[190:211]) < 1e-9  # the plateau the figures no longer draw
    swing = figures.low_pass(slow, t)[50:-50]
    assert abs(np.ptp(swing) / 2 - 20.0) < 0.05 * 20.0  # 4 Hz kept within 5 %


def test_the_low_pass_leaves_out_what_it_cannot_filter():
    t = np.arange(0.0, 1.0001, 0.005)
    values = np.sin(t)
    values[100] = np.nan
    low = figures.low_pass(values, t, start_s=0.2)
    assert np.isnan(low[t < 0.2]).all() and np.isnan(low[100])
    assert np.isfinite(low[41:100]).all() and np.isfinite(low[101:]).all()
    short = figures.low_pass(values[:60], t[:60], start_s=0.25)  # 0.045 s < 1 / 10 Hz
    assert np.isnan(short).all()


def test_speed_smoothing_leaves_out_the_ends_too():
    t = np.arange(0.0, 1.0001, 0.005)
    smooth = figures.smooth_speed(np.sin(t), t)
    half = figures._window(t, figures.SPEED_SMOOTH_S) // 2
    assert np.isnan(smooth[:half]).all() and np.isnan(smooth[-half:]).all()
    assert np.isfinite(smooth[half:-half]).all()
    assert np.allclose(smooth[half:-half], np.sin(t)[half:-half], atol=1e-6)  # a cubic fits


def test_fig14_and_the_engine_figure_keep_the_print_rules(op, tmp_path, drawn):
    bounds = {q: (np.zeros(len(T)), np.full(len(T), np.inf))
              for q in figures.bearing_loads(op, np.zeros((len(T), len(op.names))))}
    figures.fig14(op, _histories(op), bounds, tmp_path, settled_s=SETTLED)
    runs = {"default": _histories(op)["positive"], "stiffer": _histories(op)["compliance"]}
    figures.engine_figure(op, runs, bounds, tmp_path, settle_s=0.08)
    for fig in drawn:
        assert images.print_problems(fig) == []
        assert "magnitude of its radial load" in _texts(fig)
    assert images.drawn_before(drawn[1], 0.08, ("MuJoCo",)) == []


def test_a_clipped_raw_penalty_says_its_range_and_unit(tmp_path, drawn):
    """Fig. 12 (b)'s case: the smoothed difference within +-0.3 rad/s, the raw one
    spanning -1.8 to 1.6: the axis holds the bold curve and the panel says the rest."""
    t = np.arange(0.0, 2.0001, 0.005)
    raw = 0.3 * np.sin(2 * np.pi * t / 0.2)
    raw[50], raw[120] = -1.8, 1.6
    csv = figures.write_csv(tmp_path / "f.csv", figures._with_smoothed(
        {"t": t, "d_penalty": raw}, t, SETTLED, speeds=True))
    _, caption = figures._plot_grid(csv, [figures.Panel("(b) difference", "d",
                                                        "difference [rad/s]", zero_line=True)],
                                    "a title", ncols=1, settled_s=SETTLED)
    fig, = drawn
    assert images.print_problems(fig) == []
    assert "spans -1.8 to 1.6 rad/s (impacts), beyond the axis" in "\n".join(caption)


def test_y_limits_hold_the_bold_curves_with_a_margin():
    low, high = images.limits([np.array([500.0, 520.0]), np.array([510.0, 530.0])])
    assert 470 < low < 500 and 530 < high < 560  # margin: 5 % of the largest load
    flat_low, flat_high = images.limits([np.full(5, 100.0)])
    assert flat_low < 100 < flat_high  # a flat line gets a margin, not a zero range


def test_a_near_zero_bound_is_marked_on_the_edge_not_held_by_the_axis():
    """Loads of 560-770 N over a set open above from 0.001 N (engine.png, Fig. 14 (a),
    (b)): the axis holds the loads, and the bound is marked on its lower edge; a bound
    close to the loads is held."""
    loads = [np.linspace(560.0, 770.0, 11)]
    low, high = images.limits(loads, [np.full(11, 0.001)])
    assert low > 400 and high < 900
    assert images.limits(loads, [np.full(11, 520.0)])[0] < 520.0
    fig, ax = plt.subplots()
    t = np.linspace(0, 1, 11)
    handles, note = images.draw_set(ax, t, np.full(11, 0.001), np.full(11, np.inf),
                                    view=(low, high))
    edge = handles[images.BELOW_VIEW_LABEL]
    assert edge.get_marker() == "^" and np.all(np.asarray(edge.get_ydata()) > low)
    assert images.OPEN_ABOVE_LABEL not in handles
    assert "lower bound 0.001 N (below the axis at all 11 instants)" in note
    plt.close(fig)


def test_a_band_is_drawn_exactly_where_both_bounds_are_finite():
    """Bounded on the first half (lo = t, hi = t + 2), open above on the second: the
    shaded band spans [lo, hi] over the first half only, the bound on the second."""
    t = np.linspace(0, 1, 11)
    lo, hi = t.copy(), np.where(t <= 0.5, t + 2.0, np.inf)
    fig, ax = plt.subplots()
    handles, note = images.draw_set(ax, t, lo, hi)
    band = np.vstack([p.vertices for p in handles[images.SET_LABEL].get_paths()])
    assert band[:, 0].min() == 0.0 and band[:, 0].max() == 0.5
    for x in (0.0, 0.2, 0.5):
        at = band[np.isclose(band[:, 0], x), 1]
        assert np.isclose(at.min(), x) and np.isclose(at.max(), x + 2.0)
    bound = handles[images.OPEN_ABOVE_LABEL]
    y = np.asarray(bound.get_ydata(), float)
    assert np.isnan(y[t <= 0.5]).all() and np.allclose(y[t > 0.5], t[t > 0.5])
    assert "open above at 5 of 11 instants, lower bound 0.6 to 1 N" in note
    plt.close(fig)


@pytest.mark.parametrize(("shift", "together"), [(0.0, True), (1e-3, True), (0.5, False)])
def test_coinciding_curves_are_found_from_the_data(shift, together):
    t = np.linspace(0, 1, 50)
    curves = {"a": np.sin(t), "b": np.sin(t) + shift, "c": np.cos(t) + 5}
    groups = images.coinciding(curves, tol=0.01)
    assert groups == ([("a", "b")] if together else [])


def test_the_y_range_holds_every_bold_curve_and_only_raw_spikes_are_clipped():
    """Rigid methods at 500-530 N, the penalty's average 244-742 N, raw spikes 0-1500 N:
    the axis holds the rigid curves and the average; the raw line leaves it, and the
    panel says so."""
    t = np.linspace(0, 5, 201)
    avg = 493 + 249 * np.sin(t)
    cols = {"t": t, "q_paper": 500 + 30 * (t / 5), "q_positive": np.full_like(t, 515.0),
            "q_penalty": np.where(np.arange(201) % 20 == 0, 1500.0, avg) * (t > 0.01),
            "q_penalty_avg": avg}
    cols["q_penalty_lowpass"] = cols.pop("q_penalty_avg")
    fig, ax = plt.subplots()
    labels = {"paper": figures.method_label("paper")} | figures.smooth_labels(0.0)
    handles, note = figures_draw.draw_panel(ax, cols, figures.Panel(
        "q", "q", "force [N]", ("paper", "positive")), labels)
    low, high = ax.get_ylim()
    for name in ("q_paper", "q_positive", "q_penalty_lowpass"):
        assert low < cols[name].min() and cols[name].max() < high
    assert "spans 0 to 1.5e+03 N" in note
    assert figures.method_label("paper") in handles  # the paper's method, as computed here
    plt.close(fig)


def test_fig11_and_fig12_keep_the_print_rules_and_smooth_honestly(tmp_path, drawn):
    """The speeds' figures with a penalty run (the rigid speeds plus rattle): print
    rules, and the smoothed speed absent where its centred window does not fit."""
    motion = simulate(load_scene("paper"), T)
    rattle = 0.3 * np.random.default_rng(2).standard_normal(motion.omega.shape)
    csv11, _ = figures.fig11(motion, tmp_path, motion.omega + rattle, settled_s=SETTLED)
    figures.fig12(motion, tmp_path, motion.omega + rattle, settled_s=SETTLED)
    half = figures._window(T, figures.SPEED_SMOOTH_S) // 2
    first = int(np.searchsorted(T, T[0] + verdicts.SETTLED_S - 1e-12)) + half
    label = figures.smooth_labels(T[0] + verdicts.SETTLED_S)[figures.SMOOTHED[True]]
    for fig in drawn:
        assert images.print_problems(fig) == []
        for line in (line for ax in fig.axes for line in ax.get_lines()
                     if line.get_label() == label):
            y = np.asarray(line.get_ydata(), float)
            assert np.isnan(y[:first]).all() and np.isfinite(y[first:-half]).all()
    cols = figures.read_csv(csv11)
    assert np.isnan(cols["omega_input_penalty_smooth"][:first]).all()


def test_without_a_filtered_curve_the_axis_holds_the_raw_line(tmp_path, drawn):
    """A quick run (0.15 s): after the start-up too few instants for the filter, so the
    penalty - rigid panel has its raw line only, and its axis is the raw line's, not a
    default range."""
    t = np.arange(0.0, 0.1501, 0.005)
    csv = figures.write_csv(tmp_path / "f.csv", figures._with_smoothed(
        {"t": t, "d_penalty": 0.13 + 0.01 * t}, t, SETTLED, speeds=True))
    figures._plot_grid(csv, [figures.Panel("(c) difference", "d", "difference [rad/s]",
                                           zero_line=True)], "a title", 1, settled_s=SETTLED)
    low, high = drawn[0].axes[0].get_ylim()
    assert low < 0.13 < 0.1315 < high and high - low < 0.1
