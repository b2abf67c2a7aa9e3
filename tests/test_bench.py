"""``cardan bench``: the command's outputs and the metrics, on hand-made tables."""

import argparse
import csv
import json
import math

import numpy as np
import pytest
from cardan_forces.driveline.dynamics import simulate
from cardan_forces.driveline.equilibrium import build_operator
from cardan_forces.driveline.loading import load_scene
from cardan_forces.experiments import bench, bench_metrics, bench_report, bench_run, study
from cardan_forces.formulations import FORMULATIONS
from cardan_forces.solvers import SolverNotFound, failed_record, registry, settings, solve
from cardan_forces.solvers.record import Outcome


def _args(*argv):
    parser = argparse.ArgumentParser()
    bench.add_parser(parser.add_subparsers())
    return parser.parse_args(["bench", *argv])


def _read(path):
    with path.open() as handle:
        return list(csv.DictReader(handle))


def test_shifted_geometric_mean_by_hand():
    sgm = bench_metrics.shifted_geometric_mean
    assert sgm([1.0, 3.0], shift=1.0) == pytest.approx(math.sqrt(8) - 1)
    assert sgm([1.0, 4.0], shift=0.0) == pytest.approx(2.0)
    assert sgm([2e-3, 2e-3]) == pytest.approx(2e-3)
    assert math.isnan(sgm([]))


@pytest.fixture(scope="module")
def half_second():
    """The paper scene's operator at t = 0.5 s."""
    scene = load_scene("paper")
    return build_operator(simulate(scene, [0.5]))


def _worst(record):
    return max(record.optimality.values())


@pytest.mark.parametrize("formulation, solver", [
    ("positive", "qpsolvers-osqp"), ("positive", "qpsolvers-scs"), ("positive", "clarabel"),
    ("lcp", "lcp-fb-newton")])
def test_a_laddered_tolerance_sets_the_accuracy(half_second, formulation, solver):
    """The bench re-runs a backend at each tolerance of its ladder: worth it because the
    tolerance the backend declares really sets its accuracy. On the paper scene at 0.5 s
    a loose tolerance leaves the worst optimality measure (residuals checked by the
    package) at least 100 times that of a tight one."""
    if solver not in registry.available():
        pytest.skip(f"{solver} not installed")
    assert bench_run.tolerances(solver, (1e-2, 1e-9)) == [None, 1e-2, 1e-9]
    problem = FORMULATIONS[formulation](half_second, 0)
    loose, tight = (solve(problem, solver, tol=tol) for tol in (1e-2, 1e-9))
    assert tight.status == "solved" and _worst(tight) <= 1e-8
    assert _worst(loose) >= 100 * _worst(tight), (_worst(loose), _worst(tight))


@pytest.mark.parametrize("formulation, solver", [
    ("min_norm", "numpy-kkt"), ("lcp", "lcp-lemke")])
def test_no_ladder_for_a_backend_a_tolerance_does_not_change(half_second, formulation,
                                                              solver):
    """Direct methods declare no tolerance: the bench runs them once, and indeed any
    tolerance gives the very same forces."""
    assert bench_run.tolerances(solver, (1e-2, 1e-9)) == [None]
    problem = FORMULATIONS[formulation](half_second, 0)
    loose, tight = (solve(problem, solver, tol=tol) for tol in (1e-2, 1e-9))
    assert loose.status == tight.status == "solved"
    assert np.array_equal(loose.x, tight.x)


def _row(solver, instant, time_s, ok=True, tol="default", solve_s=None, **measures):
    base = {"primal": 0.0, "dual": 0.0, "gap": 0.0, "distance": math.nan}
    return {"formulation": "f", "solver": solver, "instant": instant, "time_s": time_s,
            "solve_s": time_s if solve_s is None else solve_s,
            "tol": tol, "status": "solved" if ok else "failed", "equilibrium": 0.0,
            **(base if ok else dict.fromkeys(base, math.inf)), **measures}


def test_performance_profile_on_a_hand_made_table():
    # solver time per instant:  0    1    2    3
    # a (fast):                 1    1    1    fails
    # b:                        2    4    1    3
    # end to end: the solver's time + 100 s of the package at every instant
    rows = ([_row("a", i, 101.0, solve_s=1.0) for i in range(3)]
            + [_row("a", 3, 101.0, ok=False, solve_s=1.0)]
            + [_row("b", i, 100.0 + t, solve_s=t) for i, t in enumerate((2.0, 4.0, 1.0, 3.0))])
    profiles = bench_metrics.profiles(rows, (1e-8,))
    found = {p["solver"]: p for p in profiles
             if p["profile"] == "default" and p["clock"] == "solver"}
    taus = list(bench_metrics.TAUS)
    at = {tau: next(k for k, t in enumerate(taus) if t >= tau) for tau in (1.0, 2.0, 4.0)}
    # ratios to the best per instant: a (1, 1, 1, inf), b (2, 4, 1, 1)
    assert found["a"]["curve"][at[1.0]] == 0.75 and found["a"]["curve"][-1] == 0.75
    assert found["b"]["curve"][at[1.0]] == 0.5
    assert found["b"]["curve"][at[2.0]] == 0.75 and found["b"]["curve"][at[4.0]] == 1.0
    assert found["a"]["solved"] == 0.75 and found["b"]["solved"] == 1.0
    # shifted geometric means (qpbenchmark's shift), the run without an answer counted
    # at qpbenchmark's time limit
    sgm_a = bench_metrics.shifted_geometric_mean([1.0, 1.0, 1.0, bench_metrics.TIME_LIMIT_S])
    sgm_b = bench_metrics.shifted_geometric_mean([2.0, 4.0, 1.0, 3.0])
    assert found["b"]["sgm_ratio"] == pytest.approx(sgm_b / min(sgm_a, sgm_b))
    assert found["a"]["sgm_ratio"] == pytest.approx(sgm_a / min(sgm_a, sgm_b))
    # on the end-to-end clock the package's constant time compresses b's ratios
    wide = {p["solver"]: p for p in profiles
            if p["profile"] == "default" and p["clock"] == "end_to_end"}
    assert wide["b"]["curve"][at[1.0] + 1] == 1.0 > found["b"]["curve"][at[1.0] + 1]


def test_success_needs_every_measure_and_ignores_the_absent_ones():
    assert bench_metrics.within(_row("a", 0, 1.0, dual=1e-7), 1e-6)
    assert not bench_metrics.within(_row("a", 0, 1.0, gap=1e-5), 1e-6)
    assert not bench_metrics.within(_row("a", 0, 1.0, distance=1e-5), 1e-6)
    assert not bench_metrics.within(_row("a", 0, 1.0, ok=False), 1.0)
    rows = [_row("a", i, 1.0, tol=1e-6, gap=g) for i, g in enumerate((1e-7, 1e-5))]
    rows += [_row("a", i, 1.0, tol=1e-8, gap=g) for i, g in enumerate((1e-9, 1e-7))]
    rates = bench_metrics.success(rows, (1e-6, 1e-8))  # the best run per level
    assert rates == [{"formulation": "f", "solver": "a", "level": 1e-6, "rate": 1.0,
                      "tol": 1e-8},
                     {"formulation": "f", "solver": "a", "level": 1e-8, "rate": 0.5,
                      "tol": 1e-8}]


def test_pareto_front_keeps_the_points_nothing_beats():
    rows = [_row(s, 0, t, tol=tol, primal=e)
            for s, tol, t, e in (("a", 1e-2, 1.0, 1e-3), ("b", 1e-8, 2.0, 1e-6),
                                 ("c", 1e-4, 3.0, 1e-4))] + [_row("d", 0, 0.5, ok=False)]
    front = {p["solver"] for p in bench_metrics.pareto(rows) if p["front"]}
    assert front == {"a", "b"}


@pytest.mark.slow
def test_quick_run_writes_csvs_report_and_json(tmp_path, monkeypatch, capsys):
    real = bench_run.solve

    def lemke_fails(problem, solver, **kwargs):
        if solver == "lcp-lemke":
            return failed_record(problem, solver, "injected failure")
        return real(problem, solver, **kwargs)

    unchecked = registry.solve_unchecked

    def lemke_fails_unchecked(problem, solver, **kwargs):  # the per-instant loop's solve
        if solver == "lcp-lemke":
            return registry.Pending(problem, solver, Outcome("failed", None,
                                                             message="injected failure"),
                                    problem, None, None, 0.0, 0.0)
        return unchecked(problem, solver, **kwargs)

    monkeypatch.setattr(bench_run, "solve", lemke_fails)
    monkeypatch.setattr(study, "solve", lemke_fails)
    monkeypatch.setattr(study, "solve_unchecked", lemke_fails_unchecked)
    # a budget no run reaches on any machine: every run covers every instant
    args = _args("--quick", "--json", "--out", str(tmp_path), "--budget-s", "600")
    assert args.func(args) == 0
    out = json.loads(capsys.readouterr().out)
    assert set(out) == {"throughput", "pareto", "success", "profiles", "best",
                        "solver_optimality", "overhead"}
    views = {(r["solver"], r["setting"]) for r in out["solver_optimality"]}
    judged = {b for b in bench_run.QUICK_SOLVERS  # QPs through qpsolvers, conic problems
              if b.startswith("qpsolvers-") and b in registry.available()} | {"clarabel"}
    assert views == {(b, s) for b in judged for s in settings.SETTINGS}
    assert {p["clock"] for p in out["profiles"]} == {"solver", "end_to_end"}
    assert {"formulation", "solver", "mode", "instants_per_s", "success_rate",
            "time_split_s"} <= set(out["throughput"][0])
    assert set(out["throughput"][0]["time_split_s"]) >= set(bench_run.SPLIT)
    assert {"formulation", "solver", "level", "rate", "tol"} == set(out["success"][0])
    assert {r["level"] for r in out["success"]} >= {1e-4, 1e-6, 1e-8}
    modes = {(e["formulation"], e["mode"]) for e in out["throughput"]}
    assert {("paper", "cold"), ("paper", "warm"), ("min_norm", "batched"),
            ("positive", "batched")} <= modes
    lemke = next(e for e in out["throughput"] if e["solver"] == "lcp-lemke")
    assert lemke["success_rate"] == 0.0 and lemke["max_equilibrium"] is None  # undefined
    best = {b["formulation"]: b for b in out["best"]}
    assert best["paper"]["paper_ratio"] == 1.0 and "min_norm" in best

    rows = _read(tmp_path / "bench_throughput.csv")
    assert tuple(rows[0]) == bench_report.THROUGHPUT_COLUMNS
    failed = [r for r in rows if r["solver"] == "lcp-lemke"]
    assert len(failed) == bench_run.QUICK_INSTANTS  # every failed run is a row
    assert all(r["status"] == "failed" and r["primal"] == "" for r in failed)  # undefined
    for key in {(r["formulation"], r["solver"], r["mode"]) for r in rows}:
        assert sum((r["formulation"], r["solver"], r["mode"]) == key for r in rows) == 41
    accuracy = _read(tmp_path / "bench_accuracy.csv")
    assert {r["tol"] for r in accuracy} >= {"0.0001", "1e-08", "default"}
    for stem in ("bench_pareto", "bench_profiles"):  # a page each where they take several
        pages = sorted(tmp_path.glob(f"{stem}-*.png")) or [tmp_path / f"{stem}.png"]
        assert all(page.stat().st_size > 10_000 for page in pages)
    assert _read(tmp_path / "bench_profiles.csv")
    report = (tmp_path / "report.md").read_text()
    views = _read(tmp_path / "bench_views.csv")
    assert {r["formulation"] for r in views} >= {"min_norm", "positive", "min_max"}
    for heading in ("## Throughput", "## Best backend", "## Whose time",
                    "## Success per accuracy level", "## Performance profiles",
                    "## Solver optimality", "## The package's time around the solver",
                    "## Pareto front", "## Known limitations"):
        assert heading in report
    assert "numpy" in report and "scipy" in report and "machine:" in report


def test_unknown_solver_is_an_error_before_any_work(tmp_path):
    with pytest.raises(SolverNotFound):
        bench.run(_args("--solver", "no-such-solver", "--out", str(tmp_path)))
    assert not (tmp_path / "report.md").exists()


def test_a_new_backend_is_one_registration(tmp_path, monkeypatch, capsys):
    """A fake backend declared in one place (its Backend) is planned, warm-started,
    laddered and versioned by the bench without any other list changing."""
    from cardan_forces.formulations.problems import LS
    from cardan_forces.solvers.numpy_kkt_ import solve_ls
    from cardan_forces.solvers.registry import Backend

    calls = []

    def fake(problem, tol=None, initvals=None):
        calls.append((tol, initvals is not None))
        return solve_ls(problem)

    registry.available()
    monkeypatch.setitem(registry._CACHE, "fake-ls", Backend(
        name="fake-ls", family="test", distributions=("numpy",), accepts=(LS,), solve=fake,
        tolerances=("eps",), warm_start=True))
    args = _args("--quick", "--json", "--formulation", "min_norm", "--solver", "fake-ls",
                 "--out", str(tmp_path))
    assert args.func(args) == 0
    out = json.loads(capsys.readouterr().out)
    assert {e["mode"] for e in out["throughput"]} == {"cold", "warm"}
    assert {tol for tol, _ in calls} >= {None, 1e-4, 1e-8}  # its ladder
    assert any(warm for _, warm in calls)
    assert all(e["success_rate"] == 1.0 for e in out["throughput"])


def test_json_is_strict_with_inf_and_nan():
    results = {"summary": [], "points": [], "success": [], "overhead": [
        {"formulation": "f", "solver_s": math.inf}],
        "profiles": [{"formulation": "f", "profile": "default", "clock": "solver",
                      "level": 1e-6, "solver": "a",
                      "solved": 0.0, "sgm_ratio": math.nan, "curve": [0.0]}]}
    text = json.dumps(bench_report.json_object(results), allow_nan=False)
    found = json.loads(text)  # undefined numbers are null, the finite ones kept
    assert found["overhead"][0]["solver_s"] is None and found["profiles"][0]["sgm_ratio"] is None
    assert np.isfinite(found["profiles"][0]["level"])


def test_json_stdout_is_only_json_even_when_a_solver_prints(tmp_path, capfd):
    """HiGHS prints a banner from C++: --json must still leave stdout strict JSON."""
    if "qpsolvers-highs" not in registry.available():
        pytest.skip("HiGHS not installed")
    from cardan_forces.cli import main  # the command line sends library output to stderr

    assert main(["bench", "--quick", "--json", "--formulation", "positive", "--solver",
                 "qpsolvers-highs", "--out", str(tmp_path)]) == 0
    out = json.loads(capfd.readouterr().out)
    assert out["throughput"][0]["solver"] == "qpsolvers-highs"


@pytest.mark.parametrize("budget", ["nan", "-1", "0", "inf", "soon"])
def test_a_budget_that_is_not_a_positive_number_is_refused(budget, capsys):
    with pytest.raises(SystemExit) as stop:
        _args("--budget-s", budget)
    assert stop.value.code == 2
    assert "positive number of seconds" in capsys.readouterr().err


def test_a_backend_that_takes_none_of_the_formulations_is_refused_up_front(tmp_path, capsys):
    """A chosen backend that takes none of the chosen formulations: one line naming the
    backends that would, exit 2, nothing written (not a crash drawing empty figures)."""
    from cardan_forces.cli import main

    assert main(["bench", "--quick", "--formulation", "positive", "--solver", "numpy-kkt",
                 "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1].startswith("cardan: error: no chosen backend (numpy-kkt) takes positive")
    assert "clarabel" in err[-1]
    assert not list(tmp_path.glob("bench_*"))


def test_a_second_run_replaces_the_first_and_says_so(tmp_path, capsys):
    """Two runs into one folder: the second's CSV holds its own rows alone (one per
    instant of each formulation x backend x mode it printed), an earlier run's figure in
    another format is removed, and stderr says where and that it replaced."""
    from cardan_forces.cli import main

    argv = ["bench", "--quick", "--formulation", "min_norm", "--solver", "numpy-kkt",
            "--out", str(tmp_path)]
    assert main([*argv, "--format", "svg"]) == 0
    capsys.readouterr()
    assert main([*argv, "--json"]) == 0
    captured = capsys.readouterr()
    printed = json.loads(captured.out)["throughput"]
    rows = _read(tmp_path / "bench_throughput.csv")
    assert len(rows) == len(printed) * bench_run.QUICK_INSTANTS
    assert not list(tmp_path.glob("*.svg")) and (tmp_path / "bench_pareto.png").exists()
    assert str(tmp_path) in captured.err and "replacing" in captured.err
    assert "bench_pareto.svg" in captured.err


def test_quiet_silences_qpbenchmark_too(tmp_path, capfd):
    """--quiet with --harness qpbenchmark: none of qpbenchmark's log lines (ANSI-coloured
    info on the root logger) or bars reach stderr, nothing does; qpbenchmark still ran
    (its results file is there)."""
    pytest.importorskip("qpbenchmark")
    if "qpsolvers-quadprog" not in registry.available():
        pytest.skip("quadprog not installed")
    from cardan_forces.cli import main

    assert main(["bench", "--quick", "--formulation", "positive", "--solver",
                 "qpsolvers-quadprog", "--harness", "qpbenchmark", "--quiet",
                 "--out", str(tmp_path)]) == 0
    err = capfd.readouterr().err
    assert err == ""
    assert (tmp_path / "qpbenchmark" / "qpbenchmark_results.csv").stat().st_size > 0


def test_the_regularization_study_is_a_section_of_the_report(tmp_path, monkeypatch):
    """``--regularization``: the study's table and figure join the bench's report and its
    files are among the run's (the study itself is tested in test_regularization)."""
    from cardan_forces.experiments import regularization

    from cardan_forces.cli import main

    def fake(folder, formats=("png",)):
        (folder / "regularization.md").write_text("## What regularization costs\n\n| R |\n")
        (folder / "regularization.png").write_bytes(b"png")
        return [folder / "regularization.md", folder / "regularization.png"]

    monkeypatch.setattr(regularization, "study", fake)
    assert main(["bench", "--quick", "--formulation", "min_norm", "--solver", "numpy-kkt",
                 "--regularization", "--out", str(tmp_path)]) == 0
    report = (tmp_path / "report.md").read_text()
    assert "## What regularization costs" in report
    assert "](regularization.png)" in report


def test_a_solver_that_cannot_be_built_ends_the_run_with_exit_1_and_its_reason(
        tmp_path, monkeypatch, capsys):
    """A generated solver that cannot be built here (no working compiler): its rows are
    failed records, and the run says so in one line and exits 1 (not 0 at 0 %)."""
    if "qocogen-reduced" not in registry.available():
        pytest.skip("qocogen or a C compiler is not installed")
    from cardan_forces.solvers.qocogen_ import UNBUILT

    from cardan_forces.cli import main

    monkeypatch.setenv("CARDAN_FORCES_CACHE", str(tmp_path / "cache"))
    monkeypatch.setenv("CC", "false")
    assert main(["bench", "--quick", "--quiet", "--formulation", "min_max", "--solver",
                 "qocogen-reduced", "--out", str(tmp_path / "out")]) == 1
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert line.startswith(f"bench: qocogen-reduced did not run: {UNBUILT}")
    rows = _read(tmp_path / "out" / "bench_throughput.csv")
    assert rows and {r["status"] for r in rows} == {"failed"}


@pytest.fixture(scope="module")
def two_instants():
    scene = load_scene("paper")
    return build_operator(simulate(scene, scene.time.instants()[:2]))


def test_the_harness_check_agrees_with_what_the_views_run(two_instants, tmp_path,
                                                         monkeypatch):
    """Every selection of one formulation and one of its backends: refused up front
    (one line) exactly when the views would run qpbenchmark on nothing (a conic problem,
    an LCP, a batched or non-qpsolvers backend), accepted exactly when they run it."""
    from cardan_forces.experiments import qpbench_harness
    from cardan_forces.formulations import batch as fbatch
    from cardan_forces.formulations.problems import LS, QP, Conic

    from cardan_forces.commands import UsageError

    monkeypatch.setattr(qpbench_harness, "run_package", lambda *a, **k: [])
    monkeypatch.setattr(qpbench_harness, "run_qpbenchmark", lambda path, solvers, results: [
        {"solver": f"qpsolvers-{s}", "setting": "default", "success": 100.0,
         "runtime_ratio": 1.0} for s in solvers])
    plan = bench_run.plan(two_instants)
    refused = accepted = 0
    for formulation, solvers in plan.items():
        problem = fbatch.build_problems(two_instants, formulation, [0])[0]
        scored = {f"{formulation}_0000": problem} if isinstance(problem, (LS, QP, Conic)) \
            else {}
        for solver in solvers:
            ran = bench.views(scored, {}, [solver], tmp_path, True)["qpbenchmark_ran"]
            try:
                bench.check_harness(two_instants, {formulation: [solver]})
            except UsageError as err:
                assert not ran and "\n" not in str(err), (formulation, solver)
                refused += 1
            else:
                assert ran, (formulation, solver)
                accepted += 1
    assert refused and accepted


@pytest.mark.parametrize("selection", [
    ["--formulation", "min_max", "--solver", "clarabel"],
    ["--formulation", "positive", "--solver", "numpy-batched"],
    ["--formulation", "positive", "--solver", "clarabel"],
    ["--formulation", "lcp"],
    ["--formulation", "min_max", "--formulation", "positive", "--solver", "clarabel",
     "--solver", "numpy-batched"],
])
def test_a_harness_run_with_no_qp_for_qpbenchmark_is_refused_in_one_line(
        selection, tmp_path, capsys):
    pytest.importorskip("qpbenchmark")
    from cardan_forces.cli import main

    assert main(["bench", "--quick", "--quiet", "--harness", "qpbenchmark", *selection,
                 "--out", str(tmp_path)]) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert line.startswith("cardan: error: --harness qpbenchmark: ")
    assert not list(tmp_path.glob("bench_*"))
