"""The repro report's verdicts and the figures' drawing rules."""

import matplotlib.pyplot as plt
import numpy as np
import pytest
from cardan_forces.paper_repro import figures, repro


def test_a_verdict_the_halves_do_not_share_is_undecided():
    values = np.r_[np.full(50, 3.0), np.full(50, 1.0)]  # the first half says yes, then no
    ok = np.ones(100, dtype=bool)
    stat = lambda mask: values[mask].mean()  # noqa: E731
    verdict, text = repro._verdict(stat, ok, lambda x: x >= 1.5, lambda x: x <= 0.5)
    assert verdict == "undecided" and "first half 3" in text
    steady = lambda mask: 3.0  # noqa: E731
    assert repro._verdict(steady, ok, lambda x: x >= 1.5, lambda x: x <= 0.5)[0] == "agrees"
    assert repro._verdict(lambda m: 1.0, ok, lambda x: x >= 1.5, lambda x: x <= 0.5)[0] == \
        "undecided"  # between the thresholds
    assert repro._verdict(lambda m: np.nan, ok, lambda x: x >= 1.5, lambda x: x <= 0.5)[0] == \
        "undecided"


def test_sign_test_tells_a_coin_toss_from_a_bias():
    """Blocks of 20 instants; a difference positive in 53 % of the blocks is no evidence
    (p > 0.05), one positive in 80 % of 100 blocks is."""
    rng = np.random.default_rng(1)
    scale = [np.full(2000, 100.0)]
    coin = np.repeat(np.where(np.arange(100) < 53, 1.0, -1.0), 20)
    share, n, p, _ = repro._sign_test([coin], scale, 20)
    assert n == 100 and share == 0.53 and p > 0.5
    biased = np.repeat(np.where(rng.permutation(100) < 80, 5.0, -5.0), 20)
    share, n, p, rel = repro._sign_test([biased], scale, 20)
    assert share == 0.8 and p < 1e-6 and rel == 0.05
    ties = repro._sign_test([np.zeros(2000)], scale, 20)
    assert ties[1] == 0 and ties[2] == 1.0


def test_y_limits_follow_the_rigid_methods_not_the_spikes():
    low, high = figures._limits([np.array([500.0, 520.0]), np.array([510.0, 530.0])])
    assert 470 < low < 500 and 530 < high < 560  # margin: 5 % of the largest load
    flat_low, flat_high = figures._limits([np.full(5, 100.0)])
    assert flat_low < 100 < flat_high  # a flat line gets a margin, not a zero range


def test_an_unbounded_set_is_written_not_shaded():
    t = np.linspace(0, 1, 11)
    fig, ax = plt.subplots()
    handles = figures._draw_set(ax, t, np.full(11, 10.0), np.full(11, np.inf), 0.0, 50.0)
    texts = " ".join(x.get_text() for x in ax.texts)
    assert "unbounded above at 100 %" in texts and "lower bound 10 to 10 N (dashed)" in texts
    assert "rigid solution set" not in handles  # nothing shaded
    handles = figures._draw_set(ax, t, np.full(11, -5.0), np.full(11, 5.0), -10.0, 10.0)
    assert "rigid solution set" in handles
    plt.close(fig)


def test_moving_average_of_a_line_is_the_line():
    t = np.linspace(0, 1, 201)
    assert np.allclose(figures.moving_average(3 * t + 1, t)[20:-20], (3 * t + 1)[20:-20])


def test_one_penalty_simulation_per_scene_and_the_runs_listed(tmp_path, monkeypatch):
    """Fig. 15 on the same scene as Figs. 11-14 reuses its penalty simulation; the report
    lists what was made and what for; without the penalty nothing is simulated."""
    made = []
    real = repro.run_penalty

    def counted(scene, times, progress=None):
        made.append(scene.name)
        return real(scene, times, progress)

    monkeypatch.setattr(repro, "run_penalty", counted)
    report = repro.run_repro(figs=(11, 15), out=tmp_path, quick=True, fig15_scene="paper",
                             progress=lambda s: None).read_text()
    assert made == ["paper"]
    assert "penalty simulation `paper-penalty` (made once, used for Fig. 11 and the " \
           "compliance comparison, Fig. 15)" in report
    assert "s per simulated second" in report and "motion of `paper`" in report
    made.clear()
    report = repro.run_repro(figs=(11,), out=tmp_path, quick=True, penalty=False,
                             progress=lambda s: None).read_text()
    assert made == [] and "penalty simulations: not made (`--no-penalty`" in report


def _hide(monkeypatch, *names):
    """The registry as on a machine without the packages of backends ``names``."""
    from cardan_forces.solvers import available, registry

    available()  # loaded, so that the hidden names stay hidden
    for name in names:
        if name in registry._CACHE:
            monkeypatch.delitem(registry._CACHE, name)


def test_default_backend_falls_back_when_its_first_choice_is_absent(monkeypatch, paper):
    from cardan_forces.driveline.dynamics import simulate
    from cardan_forces.driveline.equilibrium import build_operator
    from cardan_forces.experiments import study
    from cardan_forces.formulations import FORMULATIONS
    from cardan_forces.solvers import available, backends_for

    op = build_operator(simulate(paper, [0.1, 0.2]))
    first = study.DEFAULT_BACKENDS["positive"][0]
    _hide(monkeypatch, first)
    problem = FORMULATIONS["positive"](op, 0)
    chosen = study.default_backend("positive", problem)
    assert chosen != first and chosen in available() and chosen in backends_for(problem)
    assert study.solve_over_time(op, "positive").solved == 2
    _hide(monkeypatch, *backends_for(problem))
    with pytest.raises(study.NoBackend, match="no backend"):
        study.default_backend("positive", problem)


def test_repro_without_the_optional_qp_backend(monkeypatch, tmp_path):
    """``cardan repro --fig 13 --quick --no-penalty`` on the core dependencies alone."""
    from cardan_forces.cli import main

    _hide(monkeypatch, "qpsolvers-daqp")
    assert main(["repro", "--fig", "13", "--quick", "--no-penalty", "--out",
                 str(tmp_path)]) == 0
    report = next(tmp_path.rglob("*.md")).read_text()
    assert "qpsolvers-daqp" not in report
