"""Numbers the commands print or write are finite or explicitly undefined: a failed
record's residuals and a peak over no solved instant show as ``-`` in text and Markdown,
an empty cell in CSV, ``null`` in JSON; never ``inf`` or ``nan``."""

from __future__ import annotations

import argparse
import csv
import dataclasses
import json
import math
import re

import numpy as np
from cardan_forces.experiments import hard, sweep, sweep_store
from cardan_forces.experiments.environment import number_text
from cardan_forces.experiments.study import history_of
from cardan_forces.solvers import Status

from cardan_forces.cli import main

TOKEN = re.compile(r"(?<!\w)(nan|inf)(?![\w-])", re.IGNORECASE)
"""``inf``, ``-inf``, ``nan`` as printed numbers (not words such as ``NaN-free``)."""


def _clean(text: str, where: str) -> None:
    found = TOKEN.findall(text)
    assert not found, f"{where}: {found}"


def _numbers_or_empty(path, text_columns) -> list[dict]:
    """The CSV's rows; every other cell parses as a finite float or is empty."""
    with open(path, newline="") as f:
        table = list(csv.DictReader(f))
    for row in table:
        for column, cell in row.items():
            if column not in text_columns and cell != "":
                assert math.isfinite(float(cell)), (path.name, column, cell)
    return table


def test_number_text_keeps_the_width_and_says_undefined():
    assert number_text(1.5e-3, "9.1e") == "  1.5e-03"
    assert number_text(math.inf, "9.1e") == "        -"
    assert number_text(-math.inf, ".3e", "") == ""
    assert number_text(math.nan, ".3g") == "-"
    assert number_text(None, ".3g", "unbounded") == "unbounded"


def _fail_positive_at_second_instant(solve_over_time):
    """``solve_over_time`` with the ``positive`` record of instant 1 turned into a
    failure without forces, as a solver that gives up reports it."""
    def patched(op, formulation, solver=None, **kwargs):
        h = solve_over_time(op, formulation, solver, **kwargs)
        if formulation != "positive":
            return h
        records = list(h.records)
        r = records[1]
        records[1] = dataclasses.replace(r, status=Status.FAILED, x=np.full_like(r.x, np.nan),
                                         residuals=dataclasses.replace(
                                             r.residuals, **dict.fromkeys(r.residuals, math.inf)))
        return history_of(op, formulation, h.solver, h.instants, records, h.wall_s)
    return patched


def test_hard_prints_and_writes_no_inf_or_nan(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(hard, "solve_over_time",
                        _fail_positive_at_second_instant(hard.solve_over_time))
    argv = ["hard", "--quick", "--case", "articulation-0", "--formulation", "positive",
            "--formulation", "min_norm", "--out", str(tmp_path)]
    assert main(argv) == 1  # positive fails at an instant: an unexpected failure
    out = capsys.readouterr().out
    _clean(out, "stdout")
    row = next(line for line in out.splitlines() if " positive " in line)
    assert " - " in row and row.endswith("FAIL")
    _clean((tmp_path / "hard.md").read_text(), "hard.md")
    csv_text = (tmp_path / "hard.csv").read_text()
    _clean(csv_text, "hard.csv")
    table = _numbers_or_empty(tmp_path / "hard.csv",
                              ("case", "formulation", "solver", "status", "message"))
    failed = [r for r in table if r["status"] == "failed"]
    assert failed and all(r["equilibrium"] == "" and r["jump"] == "" for r in failed)
    assert any(r["status"] == "solved" and float(r["equilibrium"]) < 1e-6 for r in table)


def _study(args: list[str]):
    parser = argparse.ArgumentParser()
    sweep.add_parser(parser.add_subparsers())
    return sweep.plan(parser.parse_args(["sweep", *args]))


def test_sweep_prints_and_writes_no_inf_or_nan(tmp_path, capsys):
    """A failed row (an unphysical point's, resumed from the CSV under a point of the
    study) next to a computed one: the table, ``sweep.md``, the CSV and the JSON."""
    args = ["--angle", "0", "--angle", "30", "--formulation", "min_norm", "--quick",
            "--workers", "1", "--out", str(tmp_path)]
    study = _study(args)
    (failed,) = sweep.run_point(study.point(95.0, study.amplitudes[0]))
    assert failed.status == "failed" and failed.max_equilibrium == math.inf
    with open(tmp_path / "sweep.csv", "w", newline="") as f:
        sweep_store.append(f, [dataclasses.replace(failed, angle_deg=30.0)], header=True)
    assert main(["sweep", *args]) == 0
    out = capsys.readouterr().out
    _clean(out, "stdout")
    row = next(line for line in out.splitlines() if " failed " in line)
    assert row.split()[6:13] == ["-"] * 7  # max_equilibrium and the six peaks
    _clean((tmp_path / "sweep.md").read_text(), "sweep.md")
    _clean((tmp_path / "sweep.csv").read_text(), "sweep.csv")
    table = _numbers_or_empty(tmp_path / "sweep.csv",
                              ("scene", "formulation", "solver", "status", "message",
                               "scene_sha256"))
    assert sorted(r["status"] for r in table) == ["failed", "solved"]
    assert main(["sweep", *args, "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)["rows"]
    bad = next(r for r in rows if r["status"] == "failed")
    assert bad["max_equilibrium"] is None and bad["peak_joint1_N"] is None
    good = next(r for r in rows if r["status"] == "solved")
    assert 0.0 <= good["max_equilibrium"] < 1e-8


def _no_undefined_cells(path) -> None:
    """No ``inf``/``nan`` in the file, and every cell that reads as a number is finite
    (text cells, such as a status or ``default``, are left alone)."""
    _clean(path.read_text(), path.name)
    with open(path, newline="") as f:
        for row in csv.DictReader(f):
            for column, cell in row.items():
                try:
                    value = float(cell)
                except ValueError:
                    continue
                assert math.isfinite(value), (path.name, column, cell)


def _rows(path) -> list[dict]:
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def _failing_at_odd_instants():
    """A least-norm backend that answers at every other instant and fails without an
    answer at the others (undefined residuals and measures in the bench's rows)."""
    from cardan_forces.formulations.problems import LS
    from cardan_forces.solvers.numpy_kkt_ import solve_ls
    from cardan_forces.solvers.record import Outcome
    from cardan_forces.solvers.registry import Backend

    calls = []

    def solve(problem, tol=None, initvals=None):
        calls.append(1)
        return solve_ls(problem) if len(calls) % 2 else Outcome("failed", None, message="x")

    return Backend(name="half-ls", family="test", distributions=("numpy",), accepts=(LS,),
                   solve=solve)


def _undefined_engine_row(op) -> dict:
    """An engine's row where every number is undefined (a run that gave no forces)."""
    from cardan_forces.experiments import regularization

    return {"scene": op.scene.name, "formulation": "MuJoCo (default softness)",
            **dict.fromkeys(regularization.COLUMNS[2:], math.nan), "time_us": math.inf,
            "instants": 0}


def test_bench_and_regularization_write_no_inf_or_nan(tmp_path, monkeypatch, capsys,
                                                     empty_pictures):
    """Every CSV a bench run writes, ``regularization.csv`` with it, holds an empty cell
    where a number is undefined: a backend's failed instants (no residuals, no
    optimality, no time ratio for a profile none solved), the engine's row (no
    softening, no Newton steps), each through the writer the run uses; the Markdown
    shows ``-``."""
    from cardan_forces.experiments import regularization
    from cardan_forces.solvers import registry

    registry.available()
    monkeypatch.setitem(registry._CACHE, "half-ls", _failing_at_odd_instants())
    study = regularization.study
    monkeypatch.setattr(regularization, "mujoco_row", _undefined_engine_row)
    monkeypatch.setattr(regularization, "drake_row", lambda op: None)  # no Drake run here
    monkeypatch.setattr(regularization, "study", lambda folder, formats: study(
        folder, scenes=("paper",), instants=5, formats=formats))
    assert main(["bench", "--quick", "--quiet", "--formulation", "min_norm", "--solver",
                 "half-ls", "--regularization", "--out", str(tmp_path)]) == 0
    _clean(capsys.readouterr().out, "stdout")
    written = sorted(tmp_path.glob("*.csv"))
    assert {p.name for p in written} >= {"bench_throughput.csv", "bench_accuracy.csv",
                                         "bench_profiles.csv", "regularization.csv"}
    for path in written:
        _no_undefined_cells(path)
    for name in ("report.md", "regularization.md"):
        _clean((tmp_path / name).read_text(), name)
    engine = [r for r in _rows(tmp_path / "regularization.csv")
              if r["formulation"].startswith("MuJoCo")]
    assert engine and engine[0]["R"] == engine[0]["time_us"] == ""
    failed = [r for r in _rows(tmp_path / "bench_throughput.csv") if r["status"] == "failed"]
    assert failed and all(r["equilibrium"] == "" for r in failed)


def test_the_experiments_csv_writer_leaves_every_undefined_float_empty(tmp_path):
    """Whatever the float type (Python's, NumPy's of any width), an infinity or a NaN is
    an empty cell; integers, flags and text are kept."""
    from cardan_forces.experiments.bench_report import write_csv

    values = [math.nan, -math.inf, None, np.float32("nan"), np.float64("inf"),
              np.float16("-inf"), 1.5, np.float32(2.5), 3, np.int64(4), True, "text"]
    columns = tuple(f"c{k}" for k in range(len(values)))
    write_csv(tmp_path / "t.csv", [dict(zip(columns, values))], columns)
    (row,) = _rows(tmp_path / "t.csv")
    assert list(row.values()) == ["", "", "", "", "", "", "1.5", "2.5", "3", "4", "True",
                                  "text"]
