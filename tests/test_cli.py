import json

import numpy as np
import pytest
from cardan_forces.paper_repro.figures import read_csv

from cardan_forces.cli import main


def test_sets_json_reports_every_component(capsys):
    for scene in ("paper", "paper-fig15"):
        assert main(["sets", scene, "--t", "0.5", "--json"]) == 0
        report = json.loads(capsys.readouterr().out)
        assert report["t"] == 0.5 and report["rank"] == 29 and report["nullity"] == 7
        components = report["components"]
        assert len(components) == 36
        assert set(components["bearing.input.near.x"]) == {"determinate", "min_norm", "min",
                                                           "max", "positive", "interval_status"}
        near_y = components["bearing.input.near.y"]
        assert near_y["determinate"] is True
        assert near_y["min"] == near_y["max"] == pytest.approx(near_y["min_norm"], abs=1e-6)
        near_x = components["bearing.input.near.x"]
        assert near_x["determinate"] is False and near_x["min"] is None and near_x["max"] is None


def test_sets_table_and_time_outside_span(capsys):
    assert main(["sets", "--t", "1.0"]) == 0
    assert "rank 29, nullity 7" in capsys.readouterr().out
    assert main(["sets", "--t", "9.0"]) == 2
    assert "outside the scene's time span" in capsys.readouterr().err


@pytest.fixture(scope="module")
def quick_repro(tmp_path_factory):
    """The folder ``cardan repro --quick --no-penalty`` wrote (every figure), read by the
    tests of its figures."""
    out = tmp_path_factory.mktemp("repro-quick")
    assert main(["repro", "--quick", "--no-penalty", "--out", str(out)]) == 0
    return out


def test_repro_quick_writes_fig11_fig12(quick_repro):
    tmp_path = quick_repro
    fig11 = read_csv(tmp_path / "fig11.csv")
    fig12 = read_csv(tmp_path / "fig12.csv")
    assert list(fig11) == ["t", "omega_input", "omega_output"]
    assert list(fig12) == ["t", "omega_intermediate"]
    assert (tmp_path / "fig11.png").stat().st_size > 10_000
    assert (tmp_path / "fig12.png").stat().st_size > 10_000
    # from rest; Z arrangement with equal angles: output speed equals input speed
    assert fig11["omega_input"][0] == 0.0
    assert np.allclose(fig11["omega_output"], fig11["omega_input"], rtol=1e-9, atol=1e-12)
    # intermediate speed oscillates about the input speed (eq. 3): 1/cos 30 at phi_i = 0
    ratio = fig12["omega_intermediate"][1:] / fig11["omega_input"][1:]
    assert ratio.max() <= 1 / np.cos(np.radians(30)) + 1e-9
    assert ratio.min() >= np.cos(np.radians(30)) - 1e-9


def test_scene_list_show_check(capsys):
    assert main(["scene", "list"]) == 0
    assert "paper-fig15" in capsys.readouterr().out
    assert main(["scene", "show", "paper"]) == 0
    assert "intermediate" in capsys.readouterr().out
    assert main(["scene", "check", "paper-fig15"]) == 0


def test_solvers_and_solve_commands(capsys):
    assert main(["solvers", "--json"]) == 0
    backends = json.loads(capsys.readouterr().out)
    names = {b["name"] for b in backends}
    assert {"numpy-kkt", "clarabel", "lcp-lemke", "scipy-fsolve"} <= names
    assert main(["solve", "--t", "0.5", "--formulation", "positive", "--formulation", "lcp",
                 "--json"]) == 0
    records = json.loads(capsys.readouterr().out)
    assert {r["formulation"] for r in records} == {"positive", "lcp"}
    assert set(records[0]) >= {"formulation", "solver", "status", "residuals", "forces",
                               "setup_s", "solve_s", "iterations"}
    assert any(r["status"] == "solved" for r in records)
    assert main(["solve", "--solver", "no-such-solver"]) == 2
    assert "unknown backend" in capsys.readouterr().err


def test_sets_multistart_points_lie_in_the_intervals(capsys):
    assert main(["sets", "--t", "0.5", "--json", "--multistart", "4"]) == 0
    report = json.loads(capsys.readouterr().out)
    for entry in report["components"].values():
        points = entry["paper_multistart"]
        assert len(points) == 4
        lo = -np.inf if entry["min"] is None else entry["min"]
        hi = np.inf if entry["max"] is None else entry["max"]
        assert all(lo - 1e-6 <= p <= hi + 1e-6 for p in points)


def test_repro_quick_writes_all_figures_and_report(quick_repro):
    tmp_path = quick_repro
    for n in ("11", "12", "13", "14", "15_paper-fig15", "15_paper-fig15-axial"):
        assert (tmp_path / f"fig{n}.csv").is_file() and (tmp_path / f"fig{n}.png").is_file()
    report = (tmp_path / "report.md").read_text()
    assert "## Fig. 13" in report and "## Fig. 15" in report
    fig13 = read_csv(tmp_path / "fig13.csv")
    for method in ("paper", "positive", "min_max", "compliance"):
        for k in range(1, 9):
            values = fig13[f"F{k}_{method}"]
            assert np.all(values[np.isfinite(values)] >= 0)
    # complementary end faces in positive: one face of each pair at most pushes
    assert np.all(np.minimum(fig13["F3_positive"], fig13["F4_positive"]) < 1e-6)
    fig14 = read_csv(tmp_path / "fig14.csv")
    # every method's axial load lies inside the shaded rigid set where it was computed
    low, high = fig14["axial_set_min"], fig14["axial_set_max"]
    done = ~np.isnan(low)
    assert done.sum() >= 10
    for method in ("paper", "positive", "compliance"):
        v = fig14[f"axial_{method}"][done]
        assert np.all((low[done] - 1e-6 <= v) & (v <= high[done] + 1e-6))


def test_repro_overlays_the_penalty_simulation(tmp_path, empty_pictures):
    """The released line's speeds and forces beside the rigid ones, and the compliance
    vs penalty comparison: the bearing loads of the compliant world are a member of the
    rigid set close to the convex selections (measured: ~2 % after smoothing)."""
    assert main(["repro", "--fig", "11", "--fig", "13", "--quick", "--out",
                 str(tmp_path)]) == 0
    fig11 = read_csv(tmp_path / "fig11.csv")
    assert {"omega_input_penalty", "omega_output_penalty"} <= set(fig11)
    assert np.all(np.isfinite(fig11["omega_input_penalty"]))
    # from rest the released input shaft first turns freely through the play: it leads
    assert np.all(fig11["omega_input_penalty"][1:] >= fig11["omega_input"][1:])
    fig13 = read_csv(tmp_path / "fig13.csv")
    assert all(np.all(np.isfinite(fig13[f"F{k}_penalty"])) for k in range(1, 9))
    assert all(np.all(fig13[f"F{k}_penalty"] >= 0) for k in range(1, 9))
    rows = np.genfromtxt(tmp_path / "compliance_vs_penalty.csv", delimiter=",", names=True,
                         dtype=None, encoding=None)
    compliance = rows[rows["method"] == "compliance"][0]
    assert compliance["bearings_smoothed"] < 0.1
    report = (tmp_path / "report.md").read_text()
    assert "s per simulated second" in report and "## Compliance vs penalty" in report


def test_ctrl_c_ends_a_run_with_one_line_and_code_130(monkeypatch, capsys):
    def interrupted(args):
        raise KeyboardInterrupt

    monkeypatch.setattr("cardan_forces.commands.solvers.run", interrupted)
    assert main(["solvers"]) == 130
    assert capsys.readouterr().err == "cardan: interrupted\n"


def test_hard_with_an_unexpected_failure_exits_1(monkeypatch, capsys):
    from cardan_forces.experiments import hard

    args = ["hard", "--quick", "--case", "articulation-0", "--formulation", "positive"]
    assert main(args) == 0
    monkeypatch.setattr(hard, "_verdict", lambda row: "FAIL")
    assert main(args) == 1
    assert main([*args, "--json"]) == 1


def test_a_long_run_says_it_is_still_running(monkeypatch, capsys):
    monkeypatch.setattr("cardan_forces.cli.HEARTBEAT_S", 0.05)

    def slow(args):
        import time

        time.sleep(0.3)
        return 0

    monkeypatch.setattr("cardan_forces.commands.solvers.run", slow)
    assert main(["solvers"]) == 0
    assert "cardan solvers: still running after" in capsys.readouterr().err


def _renamed_slip_line(tmp_path):
    """paper-slip with its shafts named Input, INPUT, input (in chain order)."""
    from cardan_forces.driveline.loading import builtin_text

    text = builtin_text("paper")
    for old, new in (("input", "Input"), ("intermediate", "INPUT"), ("output", "input")):
        text = text.replace(f'name = "{old}"', f'name = "{new}"')
    text += ('\n[[slip_joints]]\nname = "spline"\nshaft = "INPUT"\noffset_m = 0.0\n'
             'pitch_radius_m = 0.02\nfriction_coefficient = 0.0\n')
    path = tmp_path / "renamed.toml"
    path.write_text(text)
    return path


def test_secondary_finds_its_shafts_by_structure(tmp_path, capsys):
    """Shafts named Input/INPUT/input: the first shaft's bearings are compared, and the
    package's determinate loads meet the handbook's closed forms (an independent
    derivation) in every row."""
    path = _renamed_slip_line(tmp_path)
    assert main(["secondary", str(path), "--torque", "250", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "250 N m" in out and "first shaft 'Input'" in out and "-0.0000" not in out
    rows = [line.split() for line in out.splitlines() if line.endswith(tuple("0123456789"))]
    assert len(rows) == 16
    for row in rows:
        handbook, package = float(row[-2]), float(row[-1])
        assert package == pytest.approx(handbook, abs=1e-3), row


def test_secondary_refuses_a_scene_without_its_layout(capsys):
    assert main(["secondary", "paper"]) == 2
    out, err = capsys.readouterr()
    assert out == ""
    assert err.count("\n") == 1 and "cardan secondary" in err and "slip joint" in err
    assert "revolution" not in err  # the command's needs, not its derived scene


def test_release_starts_from_the_applied_line(capsys):
    """--apply then --release: the advisor's set added to the applied one leaves only
    end-face pairs, and the released table is that of both (its nullity is the pairs')."""
    assert main(["sets", "paper", "--apply", "slip:intermediate", "--release", "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert [r["release"] for r in report["applied"]] == ["slip:intermediate"]
    assert all(r["release"] != "slip:intermediate" for r in report["releases"])
    pairs = [m for m in report["released"]["modes"] if m["kind"] == "end-face pair"]
    assert report["released"]["nullity"] == len(pairs) == len(report["released"]["modes"])
    applied_only = ["sets", "paper", "--apply", "slip:intermediate", "--json"]
    assert main(applied_only) == 0
    assert json.loads(capsys.readouterr().out)["nullity"] > report["released"]["nullity"] \
        or not report["releases"]


@pytest.mark.parametrize("extra", [[], ["--release"], ["--release", "--json"]])
def test_a_bad_apply_is_one_line_exit_2(capsys, extra):
    assert main(["sets", "paper", "--apply", "nonsense:foo", *extra]) == 2
    out, err = capsys.readouterr()
    assert out == "" and err.startswith("cardan: error: release 'nonsense:foo'")
    assert err.count("\n") == 1


def test_a_command_runs_with_one_blas_thread_and_its_workers_too(monkeypatch):
    """The problems are small dense matrices: one BLAS/OpenMP thread in the process while
    a command runs, and the environment its worker processes start with says the same."""
    from concurrent.futures import ProcessPoolExecutor

    from threadpoolctl import threadpool_info

    seen = {}

    def command(args):
        seen["here"] = {pool["num_threads"] for pool in threadpool_info()}
        with ProcessPoolExecutor(1) as pool:
            seen["worker"] = pool.submit(_threads).result()
        return 0

    for name in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
        monkeypatch.delenv(name, raising=False)
    monkeypatch.setattr("cardan_forces.commands.solvers.run", command)
    assert main(["solvers"]) == 0
    assert seen["here"] <= {1} and seen["worker"][0] <= {1}
    assert seen["worker"][1] == "1"


def _threads():
    import os

    from threadpoolctl import threadpool_info

    return {pool["num_threads"] for pool in threadpool_info()}, os.environ.get(
        "OPENBLAS_NUM_THREADS")


def _one_error_line(capsys) -> str:
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("cardan: error: "), captured.err
    return lines[0]


def test_solve_refuses_a_solver_that_cannot_take_the_formulation(capsys):
    """A solver outside the formulation's backends is one line and exit 2 naming those
    that can (it printed an empty table and exit 0).
    """
    from cardan_forces.driveline.dynamics import simulate
    from cardan_forces.driveline.equilibrium import build_operator
    from cardan_forces.driveline.loading import load_scene
    from cardan_forces.formulations import FORMULATIONS
    from cardan_forces.solvers import available, backends_for

    op = build_operator(simulate(load_scene("paper"), [0.5]))
    can = backends_for(FORMULATIONS["compliance_hertz"](op, 0))
    cannot = [n for n, b in available().items() if b.solve is not None and n not in can]
    if not cannot or not can:
        pytest.skip("every installed solver takes compliance_hertz")
    assert main(["solve", "--formulation", "compliance_hertz", "--solver", cannot[0]]) == 2
    line = _one_error_line(capsys)
    assert cannot[0] in line and all(name in line for name in can)
    assert capsys.readouterr().out == ""
    assert main(["solve", "--formulation", "compliance_hertz", "--solver", can[0]]) == 0
    assert "compliance_hertz" in capsys.readouterr().out


@pytest.mark.parametrize("flag", ["--formulation", "--solver"])
def test_solve_says_the_engine_is_a_simulation(capsys, flag):
    assert main(["solve", flag, "engine"]) == 2
    line = _one_error_line(capsys)
    assert "simulation" in line and "cardan engine" in line


@pytest.mark.parametrize("args, words", [
    (["engine", "paper", "--engine", "nope"], "--engine"),
    (["engine", "paper", "--stop", "-1"], "--stop"),
    (["engine", "paper", "--stop", "x"], "not a number"),
    (["engine", "paper", "--instants", "1"], "--instants"),
    (["engine", "paper", "--stop", "0.001"], "at least two"),
])
def test_engine_bad_input_is_one_line(tmp_path, capsys, args, words):
    out = tmp_path / "engine"
    assert main([*args, "--out", str(out)]) == 2
    assert words in _one_error_line(capsys)
    assert not out.exists()


def test_engine_and_repro_without_mujoco_say_how_to_install(tmp_path, capsys, monkeypatch):
    """Without MuJoCo: ``cardan engine`` and ``repro --methods engine`` are one line
    naming the extra; repro's default leaves the engine out.
    """
    import sys

    from cardan_forces.paper_repro import repro

    monkeypatch.setitem(sys.modules, "mujoco", None)
    assert main(["engine", "--out", str(tmp_path / "e")]) == 2
    assert "[mujoco]" in _one_error_line(capsys)
    assert main(["repro", "--quick", "--quiet", "--fig", "11", "--methods", "positive,engine",
                 "--out", str(tmp_path / "r")]) == 2
    assert "[mujoco]" in _one_error_line(capsys)
    assert not (tmp_path / "e").exists() and not (tmp_path / "r").exists()
    assert "engine" not in repro.default_methods()


def test_solve_says_why_a_record_is_not_solved():
    """The table's reason: the checked residual above the acceptance level for an answer
    the package judged inaccurate, the solver's own word for a failure, nothing for a
    solved record (records built by hand, so the answer is known)."""
    from cardan_forces.solvers.record import ACCEPT, Record, Status

    from cardan_forces.commands.solve import reason

    def record(status, message="", **residuals):
        every = {"equilibrium": 1e-14, "sign": 0.0, "complementarity": 0.0, "cone": 0.0}
        return Record("positive", "made-up", status, np.zeros(2), ("a", "b"), None, 0.0, 0.0,
                      every | residuals, message=message)

    assert reason(record(Status.SOLVED)) == ""
    why = reason(record(Status.INACCURATE, sign=3e-4))
    assert why.startswith("sign 3.0e-04") and f"> {ACCEPT:g}" in why
    why = reason(record(Status.INACCURATE, complementarity=2e-3, message="ignored"))
    assert why.startswith("complementarity")
    inf = float("inf")
    why = reason(record(Status.FAILED, "matrix\nnot positive definite", equilibrium=inf,
                        sign=inf, complementarity=inf, cone=inf))
    assert "failed" in why and "matrix not positive definite" in why
    assert len(reason(record(Status.FAILED, "x" * 500))) <= 60


def test_solve_lists_the_formulations_it_leaves_out(capsys):
    """With every formulation asked for, the paper scene (no friction effect) leaves
    friction out and says why; a formulation no asked-for solver takes is listed too."""
    assert main(["solve", "--solver", "clarabel", "--quiet"]) == 0
    lines = capsys.readouterr().out.splitlines()
    left = [line for line in lines if line.startswith("left out:")]
    assert any("friction" in line and "effects include 'friction'" in line for line in left)
    assert any("paper" in line.split(":")[1] and "clarabel" in line for line in left)
    assert not any(line.startswith("friction ") for line in lines)  # no record row


def test_version_is_the_installed_distributions(capsys):
    from importlib import metadata

    with pytest.raises(SystemExit) as stop:
        main(["--version"])
    assert stop.value.code == 0
    assert capsys.readouterr().out.split() == ["cardan", metadata.version("cardan-forces")]


@pytest.mark.parametrize("scene", ["paper", "paper-fig15"])
def test_sets_positive_member_lies_in_every_interval(scene, capsys):
    """The signed member 'sets' shows (the positive answer, a QP solver) lies inside the
    interval of every component (LPs over the same set), where the least-norm answer
    need not: it lets an end face pull."""
    assert main(["sets", scene, "--t", "0.5", "--json", "--quiet"]) == 0
    components = json.loads(capsys.readouterr().out)["components"]
    scale = max(abs(c["min_norm"]) for c in components.values())
    tol = 1e-6 * scale
    for name, c in components.items():
        assert c["positive"] is not None, name
        assert c["min"] is None or c["positive"] >= c["min"] - tol, name
        assert c["max"] is None or c["positive"] <= c["max"] + tol, name
        if c["determinate"]:
            assert c["positive"] == pytest.approx(c["min_norm"], abs=tol)
    assert any(c["min"] is not None and c["min_norm"] < c["min"] - tol
               for c in components.values())  # the column the table used to show


def _out_options():
    """``(command, its --out action)`` for every command that writes into a folder."""
    import argparse

    from cardan_forces.cli import _parser

    sub = next(a for a in _parser()._actions if isinstance(a, argparse._SubParsersAction))
    return [(name, action) for name, parser in sub.choices.items()
            for action in parser._actions if "--out" in action.option_strings]


def test_every_out_refuses_an_empty_folder():
    """An empty --out would write into the current folder: every command's --out takes
    the one folder type, which refuses it before any work."""
    from cardan_forces.experiments.files import folder

    found = _out_options()
    assert len(found) >= 10
    for name, action in found:
        assert action.type is folder, name


@pytest.mark.parametrize("command", ["repro", "bench", "sweep", "hard", "export"])
def test_an_empty_out_is_one_line_and_exit_2(command, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main([command, "--out", " ", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err.count("cardan: error:") == 1 and "--out" in err and "Traceback" not in err
    assert not any(tmp_path.iterdir())
