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
                              ("scene", "formulation", "solver", "status", "message"))
    assert sorted(r["status"] for r in table) == ["failed", "solved"]
    assert main(["sweep", *args, "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)["rows"]
    bad = next(r for r in rows if r["status"] == "failed")
    assert bad["max_equilibrium"] is None and bad["peak_joint1_N"] is None
    good = next(r for r in rows if r["status"] == "solved")
    assert 0.0 <= good["max_equilibrium"] < 1e-8
