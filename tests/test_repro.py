"""The repro report's verdicts and the figures' drawing rules."""

import re

import numpy as np
import pytest
from cardan_forces.driveline.loading import load_scene
from cardan_forces.experiments.study import History
from cardan_forces.paper_repro import figures, repro, verdicts
from cardan_forces.paper_repro import runs as repro_runs

from cardan_forces.cli import main


def test_a_verdict_the_halves_do_not_share_is_undecided():
    values = np.r_[np.full(50, 3.0), np.full(50, 1.0)]  # the first half says yes, then no
    ok = np.ones(100, dtype=bool)
    stat = lambda mask: values[mask].mean()  # noqa: E731
    verdict, text = verdicts._verdict(stat, ok, lambda x: x >= 1.5, lambda x: x <= 0.5)
    assert verdict == "undecided" and "first half 3" in text
    steady = lambda mask: 3.0  # noqa: E731
    assert verdicts._verdict(steady, ok, lambda x: x >= 1.5, lambda x: x <= 0.5)[0] == "agrees"
    assert verdicts._verdict(lambda m: 1.0, ok, lambda x: x >= 1.5, lambda x: x <= 0.5)[0] == \
        "undecided"  # between the thresholds
    assert verdicts._verdict(lambda m: np.nan, ok, lambda x: x >= 1.5, lambda x: x <= 0.5)[0] == \
        "undecided"


def test_sign_test_tells_a_coin_toss_from_a_bias():
    """Blocks of 20 instants; a difference positive in 53 % of the blocks is no evidence
    (p > 0.05), one positive in 80 % of 100 blocks is."""
    rng = np.random.default_rng(1)
    scale = [np.full(2000, 100.0)]
    coin = np.repeat(np.where(np.arange(100) < 53, 1.0, -1.0), 20)
    share, n, p, _ = verdicts._sign_test([coin], scale, 20)
    assert n == 100 and share == 0.53 and p > 0.5
    biased = np.repeat(np.where(rng.permutation(100) < 80, 5.0, -5.0), 20)
    share, n, p, rel = verdicts._sign_test([biased], scale, 20)
    assert share == 0.8 and p < 1e-6 and rel == 0.05
    ties = verdicts._sign_test([np.zeros(2000)], scale, 20)
    assert ties[1] == 0 and ties[2] == 1.0


def test_speed_smoothing_keeps_the_twice_per_revolution_fluctuation():
    """A 0.25 s fluctuation of amplitude 1 under rattle: the speeds' smoothing keeps its
    amplitude within 3 % (a 0.1 s moving average takes 1/4 off) and removes most of the
    rattle."""
    t = np.arange(0, 5.0001, 0.005)
    clean = 10 + np.sin(2 * np.pi * t / 0.25)
    rattle = 0.5 * np.random.default_rng(3).standard_normal(len(t))
    kept = figures.smooth_speed(clean + rattle, t)[100:-100]
    assert abs(np.ptp(figures.smooth_speed(clean, t)[100:-100]) / 2 - 1) < 0.03
    assert np.ptp(figures.moving_average(clean, t)[100:-100]) / 2 < 0.8
    assert np.std(kept - clean[100:-100]) < 0.5 * np.std(rattle)


def test_a_method_whose_end_faces_both_push_is_named_not_a_physical_selection():
    class Op:  # two pairs of end faces: columns (0, 1) and (2, 3)
        pairs = ((0, 1), (2, 3))
        t = np.array([0.0, 0.02, 0.04])

    both = np.array([[0, 3, 0, 0], [5.8, 5.8, 0, 1], [0, 0, 2, 0]], float)
    one = np.array([[0, 3, 0, 0], [5.8, 0, 0, 1], [0, 0, 2, 0]], float)
    hist = {m: History(m, "s", Op.t, x, (), 0.0) for m, x in (("min_max", both),
                                                              ("positive", one))}
    lines = verdicts._both_faces_note(Op, hist)
    assert "`min_max`: both end faces of a pair push at once at 1 of 3 instants (up to " \
           "5.8 N each, t = 0.020 s)" in lines[0]
    assert lines[1].startswith("- `positive`: no pair of end faces pushes at once")


@pytest.mark.parametrize("scale", [1.0, 1e3, 1e6])
def test_faces_pushing_by_a_rounding_of_the_loads_are_no_verdict(scale):
    """The rule is relative to the loads: both faces at 4e-5 of the largest load (an
    interior point's idle face, 0.04 N at 1 kN) count as zero at any scale; at 1e-3 of it
    they push, and the report's number for them is not 0."""
    class Op:
        pairs = ((0, 1),)
        t = np.array([0.0, 0.02])

    for share, flagged in ((4e-5, False), (1e-3, True)):
        x = scale * np.array([[share, share, 0.3], [0.0, 0.0, 1.0]])
        hist = {"positive": History("positive", "s", Op.t, x, (), 0.0)}
        lines = verdicts._both_faces_note(Op, hist)
        assert lines[0].startswith("- `positive`: both") is flagged, lines
        if flagged:
            shown = float(lines[0].split("up to ")[1].split(" N")[0])
            assert shown == pytest.approx(share * scale, rel=1e-2)


def test_fig15_names_the_scene_whose_verdicts_both_agree():
    y, x = load_scene("paper-fig15"), load_scene("paper-fig15-axial")
    _, _, lines = verdicts._fig15_summary([(y, {"radial": "disagrees", "axial": "disagrees"}),
                                           (x, {"radial": "agrees", "axial": "agrees"})])
    assert lines[-1] == "- matches the paper's text (both verdicts agree): `paper-fig15-axial`"
    _, _, lines = verdicts._fig15_summary([(y, {"radial": "agrees", "axial": "undecided"})])
    assert lines[-1].endswith("none of the scenes drawn")


@pytest.mark.slow
def test_both_fig15_scenes_by_default_in_every_format_asked(tmp_path):
    report = repro.run_repro(figs=(15,), out=tmp_path, quick=True, methods=("positive",),
                             formats=("png", "svg", "pdf"), progress=lambda s: None)
    for scene in repro.FIG15_SCENES:
        for ext in ("csv", "png", "svg", "pdf"):
            assert (tmp_path / f"fig15_{scene}.{ext}").stat().st_size > 0
    text = report.read_text()
    assert "## Fig. 15: which horizontal gravity matches the paper's text" in text
    assert "not judged (needs the paper's method and the penalty simulation)" in text


def test_a_slip_joint_scene_gets_its_figures_with_the_methods_that_apply(tmp_path, capsys,
                                                                         empty_pictures):
    out = str(tmp_path)
    args = ["repro", "paper-slip", "--quick", "--no-penalty", "--fig", "13", "--out", out]
    assert main(args) == 2  # the paper's method does not apply to a slip joint
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert err.startswith("cardan: error: cardan repro paper-slip: 'paper' (") and \
        "choose --methods among those that apply here: positive,min_max,compliance," in err
    assert not list(tmp_path.glob("fig*"))  # refused before any work
    assert main(args + ["--methods", "positive,compliance"]) == 0
    cols = figures.read_csv(tmp_path / "fig13.csv")
    assert {"F1_positive", "F1_compliance", "F1_set_min"} <= set(cols)
    assert "F1_paper" not in cols


def test_moving_average_of_a_line_is_the_line():
    t = np.linspace(0, 1, 201)
    assert np.allclose(figures.moving_average(3 * t + 1, t)[20:-20], (3 * t + 1)[20:-20])


def test_one_penalty_simulation_per_scene_and_the_runs_listed(tmp_path, monkeypatch,
                                                              empty_pictures):
    """Fig. 15 on the same scene as Figs. 11-14 reuses its penalty simulation; the report
    lists what was made and what for; without the penalty nothing is simulated."""
    made = []
    real = repro_runs.run_penalty

    def counted(scene, times, progress=None):
        made.append(scene.name)
        return real(scene, times, progress)

    monkeypatch.setattr(repro_runs, "run_penalty", counted)
    report = repro.run_repro(figs=(11, 15), out=tmp_path, quick=True, fig15_scenes=("paper",),
                             progress=lambda s: None, workers=0).read_text()
    assert made == ["paper"]
    assert "penalty simulation `paper-penalty` (made once, used for Fig. 11 and the " \
           "compliance comparison, Fig. 15 (paper))" in report
    assert "s per simulated second" in report and "motion of `paper`" in report
    made.clear()
    report = repro.run_repro(figs=(11,), out=tmp_path, quick=True, methods=repro.METHODS,
                             progress=lambda s: None).read_text()
    assert made == [] and "penalty simulations: not made (`--no-penalty`" in report


def test_the_runs_list_says_what_the_compiled_integrator_measured(paper):
    """The compiled integrator does not time its right-hand sides one by one (``rhs_s``
    NaN): the runs list gives the cost it did measure and no non-finite number."""
    from cardan_forces.driveline.penalty import COMPILED, PenaltyResult

    t = np.array([0.0, 0.5])
    runs = repro_runs._Runs(t, True, lambda _: None)
    runs.penalties["paper-penalty"] = PenaltyResult(
        paper, t, np.zeros((3, 2)), {}, np.zeros(2), wall_s=1.0, nfev=2000, njev=100,
        nlu=300, nsteps=1000, method=COMPILED, status=0, message="ok", kernel="numba",
        cpu_s=0.75)
    runs.uses["paper-penalty"] = ["Fig. 11"]
    text = "\n".join(runs.lines())
    assert not re.search(r"(?<![\w-])(nan|inf)(?!\w)", text, re.IGNORECASE), text
    assert "2.00 s per simulated second" in text  # 1 s of wall over 0.5 s simulated
    assert "1000.0 us per step" in text


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
    first = FORMULATIONS["positive"].backends[0]
    _hide(monkeypatch, first)
    problem = FORMULATIONS["positive"](op, 0)
    chosen = study.default_backend("positive", problem)
    assert chosen != first and chosen in available() and chosen in backends_for(problem)
    assert study.solve_over_time(op, "positive").solved == 2
    _hide(monkeypatch, *backends_for(problem))
    with pytest.raises(study.NoBackend, match="no backend"):
        study.default_backend("positive", problem)


@pytest.mark.slow  # the command end to end; the fallback itself is held in the default run
# by test_default_backend_falls_back_when_its_first_choice_is_absent and test_same_answers
def test_repro_without_the_optional_qp_backend(monkeypatch, tmp_path):
    """``cardan repro --fig 13 --quick --no-penalty`` on the core dependencies alone."""
    from cardan_forces.cli import main

    _hide(monkeypatch, "qpsolvers-daqp")
    assert main(["repro", "--fig", "13", "--quick", "--no-penalty", "--out",
                 str(tmp_path)]) == 0
    report = next(tmp_path.rglob("*.md")).read_text()
    assert "qpsolvers-daqp" not in report
