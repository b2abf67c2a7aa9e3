"""``cardan repro``'s figures read back from what they drew: the print rules (titles,
units, legible type, every legend entry visible), the smoothing honest at the ends, the
rigid set drawn where it informs, coinciding methods told apart."""

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
from cardan_forces.paper_repro import figures, figures_draw  # noqa: E402

T = np.arange(0.0, 0.6001, 0.005)


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

    monkeypatch.setattr(figures_draw, "save", keep)
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
    figures.fig13(op, _histories(op), bounds, tmp_path)
    fig, = drawn
    assert images.problems(fig) == []
    text = _texts(fig)
    assert "|F1|, magnitude" in text and "F3, push (end face)" in text
    assert "to 0 N" not in text.replace("0 to 0 N", "X")  # one value is printed once
    assert "0 to 0 N" not in text
    assert "open above and below (any value)" in text
    assert "positive = min_max" in text and "compliance" not in text.split("=")[-1][:20]


def test_an_open_set_is_its_bound_and_the_open_side_not_a_hatched_panel(op, tmp_path, drawn):
    labels = sorted(op.joint_contacts(0))
    figures.fig13(op, _histories(op), _bounds(labels, open_above=labels), tmp_path)
    fig, = drawn
    for ax in fig.axes[:len(labels)]:
        assert not [c for c in ax.collections if c.get_hatch()], "no hatching"
        bound = [line for line in ax.get_lines()
                 if line.get_label() == images.OPEN_ABOVE_LABEL]
        assert bound and bound[0].get_marker() == "^"  # triangles point to the open side
        low, high = ax.get_ylim()
        assert low < 10.0 < high  # the finite bound in view
        assert "open above at all" in _texts_of(ax)


def _texts_of(ax) -> str:
    return " ".join(t.get_text() for t in ax.texts) + ax.get_title(loc="left")


def test_the_smoothed_penalty_starts_with_a_full_window_or_not_at_all(op, tmp_path, drawn):
    labels = sorted(op.joint_contacts(0))
    hist = _histories(op)
    csv = figures.fig13(op, hist, _bounds(labels), tmp_path)
    cols = figures.read_csv(csv)
    window = figures._window(T, figures.SMOOTH_S)
    raw = cols["F1_penalty"]
    for ax in drawn[0].axes[:1]:
        line = next(line for line in ax.get_lines()
                    if line.get_label() == figures.SMOOTH_LABELS["_avg"])
        y = np.asarray(line.get_ydata(), float)
        first = np.flatnonzero(np.isfinite(y))[0]
        half = window // 2
        assert first >= half  # no part window at the start
        assert np.isclose(y[first], raw[first - half:first + half + 1].mean())
        last = np.flatnonzero(np.isfinite(y))[-1]
        assert last <= len(T) - 1 - half
        assert "none within 0.05 s of either end" in line.get_label()
    assert np.isnan(cols["F1_penalty_avg"][:window // 2]).all()


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
    figures.fig14(op, _histories(op), bounds, tmp_path)
    runs = {"default": _histories(op)["positive"], "stiffer": _histories(op)["compliance"]}
    figures.engine_figure(op, runs, bounds, tmp_path)
    for fig in drawn:
        assert images.problems(fig) == []
        assert "magnitude of its radial load" in _texts(fig)


def test_a_clipped_raw_penalty_says_its_range_and_unit(tmp_path, drawn):
    """Fig. 12 (b)'s case: the smoothed difference within +-0.3 rad/s, the raw one
    spanning -1.8 to 1.6: the axis holds the bold curve and the panel says the rest."""
    t = np.arange(0.0, 2.0001, 0.005)
    raw = 0.3 * np.sin(2 * np.pi * t / 0.2)
    raw[50], raw[120] = -1.8, 1.6
    csv = figures.write_csv(tmp_path / "f.csv", figures._with_smoothed(
        {"t": t, "d_penalty": raw}, t, speeds=True))
    figures._plot_grid(csv, [figures.Panel("(b) difference", "d", "difference [rad/s]",
                                           zero_line=True)], "a title", ncols=1)
    fig, = drawn
    assert images.problems(fig) == []
    assert "clipped: it spans -1.8 to 1.6 rad/s" in _texts(fig)


def test_y_limits_hold_the_bold_curves_with_a_margin():
    low, high = figures_draw.limits([np.array([500.0, 520.0]), np.array([510.0, 530.0])])
    assert 470 < low < 500 and 530 < high < 560  # margin: 5 % of the largest load
    flat_low, flat_high = figures_draw.limits([np.full(5, 100.0)])
    assert flat_low < 100 < flat_high  # a flat line gets a margin, not a zero range


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
    fig, ax = plt.subplots()
    labels = {"paper": figures.method_label("paper")} | figures.SMOOTH_LABELS
    handles = figures_draw.draw_panel(ax, cols, figures.Panel("q", "q", "force [N]",
                                                              ("paper", "positive")), labels)
    low, high = ax.get_ylim()
    for name in ("q_paper", "q_positive", "q_penalty_avg"):
        assert low < cols[name].min() and cols[name].max() < high
    assert "clipped: it spans 0 to 1.5e+03 N" in _texts_of(ax)
    assert figures.method_label("paper") in handles  # the paper's method, as computed here
    plt.close(fig)


def test_fig11_and_fig12_keep_the_print_rules_and_smooth_honestly(tmp_path, drawn):
    """The speeds' figures with a penalty run (the rigid speeds plus rattle): print
    rules, and the smoothed speed absent where its centred window does not fit."""
    motion = simulate(load_scene("paper"), T)
    rattle = 0.3 * np.random.default_rng(2).standard_normal(motion.omega.shape)
    csv11 = figures.fig11(motion, tmp_path, motion.omega + rattle)
    figures.fig12(motion, tmp_path, motion.omega + rattle)
    half = figures._window(T, figures.SPEED_SMOOTH_S) // 2
    for fig in drawn:
        assert images.problems(fig) == []
        for line in (line for ax in fig.axes for line in ax.get_lines()
                     if line.get_label() == figures.SMOOTH_LABELS["_smooth"]):
            y = np.asarray(line.get_ydata(), float)
            assert np.isnan(y[:half]).all() and np.isfinite(y[half:-half]).all()
    cols = figures.read_csv(csv11)
    assert np.isnan(cols["omega_input_penalty_smooth"][:half]).all()
