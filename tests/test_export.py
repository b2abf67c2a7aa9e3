"""``cardan export``: the files say what the package solves, and qpbenchmark runs them."""

import csv
import shutil
import subprocess

import numpy as np
import pytest
from cardan_forces.experiments import export, qpbench_harness
from cardan_forces.formulations.problems import Conic
from cardan_forces.solvers import judge, settings, solve
from cardan_forces.solvers.conversions import convert


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    folder = tmp_path_factory.mktemp("export")
    problems = export.collect(["paper"], ["positive", "min_norm", "min_max"], 2)
    return folder, problems, export.export(folder, problems, "cardan_small")


def test_names_say_scene_formulation_and_instant(exported):
    _, problems, written = exported
    assert set(written) == {"qpbenchmark", "conic"}
    assert sorted(problems) == sorted(f"paper_{f}_{i:04d}" for f in ("positive", "min_norm",
                                                                    "min_max")
                                      for i in (0, 1000))


def test_conic_file_in_its_documented_form_holds_the_optimum(exported):
    """The package's optimum of each conic problem, put into the exported arrays with
    the documented convention (``A z + s = b``, ``s`` in the listed cones), leaves ``s``
    in the cones and reproduces the optimal objective ``1/2 z'Pz + q'z``."""
    folder, problems, written = exported
    with np.load(written["conic"]) as data:
        names = [str(n) for n in data["names"]]
        assert names == [n for n in problems if "min_max" in n]
        for name in names:
            P, q, A, b = (data[f"{name}/{k}"] for k in ("P", "q", "A", "b"))
            cones = tuple(zip(data[f"{name}/cone_kinds"].tolist(),
                              data[f"{name}/cone_sizes"].tolist()))
            record = solve(problems[name], "clarabel", tol=1e-10)
            z = np.asarray(record.z, float)
            slack = (b - A @ z)[None]
            assert judge.cone_violation(cones, slack)[0] <= 1e-8 * max(1, np.abs(b).max())
            original = convert(problems[name], (Conic,))
            assert 0.5 * z @ P @ z + q @ z == pytest.approx(
                0.5 * z @ np.asarray(original.P if original.P is not None else P) @ z
                + original.q @ z, rel=1e-12)


def test_test_set_yields_the_packages_qps(exported):
    pytest.importorskip("qpbenchmark")
    folder, problems, written = exported
    test_set = qpbench_harness.load_test_set(written["qpbenchmark"])
    loaded = {p.name: p for p in test_set}
    assert sorted(loaded) == sorted(n for n in problems if "min_max" not in n)
    for name, p in loaded.items():
        qp = export.as_qp(problems[name])
        for key in export.QP_KEYS:
            ours = getattr(qp, key)
            assert (ours is None) == (getattr(p, key) is None), (name, key)
            if ours is not None:
                np.testing.assert_array_equal(getattr(p, key), ours)


@pytest.mark.slow
def test_qpbenchmark_runs_the_export_unchanged(exported, tmp_path):
    """``qpbenchmark FILE run`` on the exported module: one result per problem."""
    pytest.importorskip("qpbenchmark")
    command = shutil.which("qpbenchmark")
    if command is None:
        pytest.skip("qpbenchmark's command is not on PATH")
    _, problems, written = exported
    results = tmp_path / "results.csv"
    done = subprocess.run([command, str(written["qpbenchmark"]), "--results-path",
                           str(results), "run", "--solver", "quadprog", "--author", "test"],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr[-2000:]
    with results.open() as handle:
        rows = list(csv.DictReader(handle))
    qps = [n for n in problems if "min_max" not in n]
    assert sorted(r["problem"] for r in rows) == sorted(qps * len(settings.SETTINGS))
    assert {r["solver"] for r in rows} == {"quadprog"}


def test_help_lists_exactly_what_export_accepts(capsys):
    """``--help``'s list and the refusal come from one definition (a formulation once
    was accepted but missing from the help); the default set is among them."""
    from cardan_forces.experiments.arguments import UsageError
    from cardan_forces.formulations import FORMULATIONS

    from cardan_forces.cli import main

    with pytest.raises(SystemExit):
        main(["export", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    listed = set(text.split(" among ")[1].split("; default")[0].split(", "))
    accepted = set()
    for name in FORMULATIONS:
        try:
            export.collect(["paper"], [name], 1)
        except UsageError:
            continue
        accepted.add(name)
    assert listed == accepted and set(export.QP_FORMULATIONS) <= accepted


@pytest.mark.parametrize("argv, says", [
    (["--name", "1bad"], "Python identifier"),
    (["--instants", "0"], "whole number from 1 to"),
    (["--instants", "1000000000000"], "whole number from 1 to"),
    (["--instants", "1e20"], "whole number from 1 to"),
    (["--instants", "5000"], "scene paper has 1001 instants"),
    (["--formulation", "friction"], "none of the chosen formulations"),
    (["--formulation", "paper"], "neither a QP nor a conic problem"),
    (["--formulation", "lcp"], "neither a QP nor a conic problem"),
])
def test_bad_export_requests_are_one_line_and_exit_2(argv, says, tmp_path, capsys):
    from cardan_forces.cli import main

    assert main(["export", *argv, "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("cardan: error:") and says in err[0]
    assert not any(tmp_path.iterdir())


def test_a_solvers_warning_stays_with_its_row(exported, monkeypatch):
    """qpsolvers warns when a solver stops short (OSQP's 'maximum iterations reached');
    the harness keeps such notes with the solve instead of printing them."""
    import warnings

    import qpsolvers

    real = qpsolvers.solve_problem

    def noisy(*args, **kwargs):
        warnings.warn("OSQP exited with status 'maximum iterations reached'", stacklevel=2)
        return real(*args, **kwargs)

    monkeypatch.setattr(qpsolvers, "solve_problem", noisy)
    _, problems, _ = exported
    with warnings.catch_warnings(record=True) as escaped:
        warnings.simplefilter("always")
        row = qpbench_harness.solve_both(problems["paper_positive_0000"], "qpsolvers-osqp",
                                         "default")
    assert not escaped
    assert "maximum iterations reached" in row["message"]


def test_a_failed_write_leaves_the_earlier_export_whole(tmp_path, monkeypatch):
    """A write that fails half way (a full disk) removes its partial file and keeps the
    earlier export readable; no temporary file is left beside it."""
    import errno

    from cardan_forces.experiments import files

    problems = export.collect(["paper"], ["positive"], 2)
    export.export(tmp_path, problems, "cardan_qp")
    before = {p.name: p.read_bytes() for p in tmp_path.iterdir()}
    real = np.savez

    def disk_full(handle, **arrays):
        real(handle, **arrays)  # the bytes are written, then the disk is full
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(np, "savez", disk_full)
    with pytest.raises(OSError, match="No space"):
        export.export(tmp_path, export.collect(["paper"], ["min_norm"], 3), "cardan_qp")
    assert {p.name: p.read_bytes() for p in tmp_path.iterdir()} == before
    with np.load(tmp_path / "cardan_qp.npz") as data:
        assert sorted(data["names"]) == sorted(problems)
    assert files.stale(tmp_path, [], ["*.part"]) == []


def test_a_second_export_replaces_the_first_and_says_where(tmp_path, capsys):
    """An export with no conic problem after one with them removes the earlier conic
    file (the folder holds one export), and the run names its files on stderr."""
    from cardan_forces.cli import main

    assert main(["export", "--formulation", "min_max", "--formulation", "positive",
                 "--instants", "2", "--out", str(tmp_path)]) == 0
    assert (tmp_path / "cardan_qp_conic.npz").exists()
    capsys.readouterr()
    assert main(["export", "--instants", "3", "--out", str(tmp_path)]) == 0
    err = capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cardan_qp.npz", "cardan_qp.py"]
    assert str(tmp_path) in err and "replacing" in err and "9 problems" in err
    with np.load(tmp_path / "cardan_qp.npz") as data:
        assert len(data["names"]) == 9  # 3 formulations x 3 instants, nothing of the first
