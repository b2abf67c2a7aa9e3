"""``cardan engine --engine``: an engine that is not installed is one line; asked for
alone it is refused (exit 2) with the extra to install, within ``all`` it is left out
and the others run."""

import sys

import pytest

from cardan_forces.cli import main


def _lines(capsys) -> list[str]:
    return [line for line in capsys.readouterr().err.splitlines() if line.strip()]


def test_drake_asked_for_without_drake_says_how_to_install(tmp_path, capsys, monkeypatch):
    monkeypatch.setitem(sys.modules, "pydrake", None)
    monkeypatch.setitem(sys.modules, "pydrake.all", None)
    out = tmp_path / "e"
    assert main(["engine", "paper", "--engine", "drake", "--out", str(out)]) == 2
    line, = _lines(capsys)
    assert "Drake is not installed" in line and "[drake]" in line
    assert not out.exists()


def test_all_without_drake_runs_mujoco_and_says_why_drake_is_left_out(tmp_path, capsys,
                                                                       monkeypatch):
    pytest.importorskip("mujoco")
    monkeypatch.setitem(sys.modules, "pydrake", None)
    monkeypatch.setitem(sys.modules, "pydrake.all", None)
    out = tmp_path / "e"
    assert main(["engine", "paper", "--engine", "all", "--stop", "0.02", "--instants", "2",
                 "--out", str(out)]) == 0
    err = capsys.readouterr().err
    left_out = [line for line in err.splitlines() if "left out" in line]
    assert len(left_out) == 1 and "Drake is not installed" in left_out[0]
    report = (out / "engine.md").read_text()
    assert "Not run: Drake: Drake is not installed" in report
    assert "| Drake |" not in report and "| MuJoCo | default |" in report


def test_the_verdict_says_whether_a_miss_is_within_the_engine_s_residual():
    """Comparisons built by hand: a distance within the rule matches; a larger one is
    within the engine's own residual at its instant, or beyond it (the report then says
    why)."""
    from cardan_forces.experiments.engine import PREDICTION_RTOL, InstantComparison, verdict

    def at(distance, residual):
        return InstantComparison("s", 0.0, residual, 0.0, (), ("-", 0.0), distance)

    small, large = PREDICTION_RTOL / 2, 3 * PREDICTION_RTOL
    assert verdict([at(small, 1e-6), at(small, 1e-6)]) == "yes"
    assert verdict([at(small, 1e-6), at(large, 2 * large)]) == "no, within its residual"
    assert verdict([at(large, 2 * large), at(large, large / 3)]) == "no, beyond its residual"
