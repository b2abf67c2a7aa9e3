"""The hard-case suite: stability properties, never time (issue: benchmarks)."""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pytest
from cardan_forces.driveline.loading import builtin_text
from cardan_forces.experiments import hard, study
from cardan_forces.solvers import Residuals, Status
from cardan_forces.solvers.record import Results

from cardan_forces.cli import main

INSTANTS = 3


@pytest.fixture(scope="module")
def suite():
    """Every case with the reduced backend set, a short window each."""
    runs = []
    for case in hard.CASES:
        runs += hard.run_case(case, solvers=hard.QUICK_SOLVERS, instants=INSTANTS)
    return runs


def test_every_case_builds_a_valid_scene():
    names = [c.name for c in hard.CASES]
    assert len(set(names)) == len(names)
    for case in hard.CASES:
        assert case.scene().name == f"hard-{case.name}"


def test_every_case_and_formulation_is_covered_or_a_listed_failure(suite):
    rows = hard.summarize(suite)
    cases = {c.name for c in hard.CASES}
    assert {r["case"] for r in rows} == cases
    uncovered = [(r["case"], r["formulation"]) for r in rows if not r["covered"]]
    assert [u for u in uncovered if u not in hard.KNOWN_FAILURES] == []
    # every known failure names a real case and formulation of the suite
    assert set(hard.KNOWN_FAILURES) <= {(r["case"], r["formulation"]) for r in rows}


def test_no_nan_anywhere_and_failures_are_records(suite):
    assert all(run.nan_free for run in suite)
    for run in suite:
        for record in run.records:
            assert isinstance(record.status, Status)
            if record.status.has_answer:
                assert all(not math.isnan(v) for v in record.residuals.values())
            else:
                assert all(v == math.inf for v in record.residuals.values())


def test_solved_records_meet_their_residuals(suite):
    for run in suite:
        for record in run.records:
            if record.solved:
                worst = max(record.residuals[k] for k in Residuals.KEYS)
                assert worst <= 1e-6, (run.case, run.solver)


def test_the_paper_method_fails_where_its_equations_are_singular(suite):
    """Equal contact angles make eq. 33 divide by zero: the paper method does not get
    there, every convex formulation does."""
    surface = [r for r in suite if r.case == "surface-contact"]
    paper = [r for r in surface if r.formulation == "paper"]
    assert paper and not hard.covered(paper)
    for formulation in ("min_norm", "positive", "lcp", "compliance", "min_max"):
        assert hard.covered([r for r in surface if r.formulation == formulation])


@pytest.mark.parametrize("formulation,solver", [("min_norm", "numpy-kkt"),
                                                ("positive", "qpsolvers-daqp"),
                                                ("compliance", "qpsolvers-daqp")])
def test_selected_forces_are_continuous_in_time(formulation, solver):
    """Halving the step halves the largest jump between neighbouring instants (the
    selected member of the solution set moves smoothly), on the steepest case."""
    case = next(c for c in hard.CASES if c.name == "articulation-89")
    jumps = []
    for n in (9, 17):
        short = dataclasses.replace(case, stop_s=0.05)
        (run,) = hard.run_case(short, [formulation], [solver], instants=n)
        assert run.n_solved == n
        jumps.append(run.max_jump)
    assert 1.6 < jumps[0] / jumps[1] < 2.5


def test_huge_loads_keep_relative_residuals(suite):
    """1e6 N m through the joints: the conic formulations, scaled by ||b||, stay at
    relative residuals as small as at the paper's load."""
    conic = {"socp_face", "compliance_hertz", "min_max"}
    runs = [r for r in suite if r.case == "torque-1e6" and r.solver == "clarabel"
            and r.formulation in conic]
    assert {r.formulation for r in runs} == conic
    for run in runs:
        assert run.n_solved == INSTANTS, run.formulation
        assert run.worst()["equilibrium"] <= 1e-8


def test_cli_json_and_reports(tmp_path, capsys):
    code = main(["hard", "--quick", "--case", "surface-contact", "--formulation", "paper",
                 "--formulation", "positive", "--json", "--out", str(tmp_path)])
    assert code == 0
    cases = json.loads(capsys.readouterr().out)["cases"]
    assert {c["formulation"] for c in cases} == {"paper", "positive"}
    for c in cases:
        assert set(c) >= {"case", "formulation", "solver", "status", "residuals", "forces"}
        # --json prints undefined numbers (a failed solve's residuals) as null
        residuals = {k: np.inf if v is None else float(v) for k, v in c["residuals"].items()}
        if c["status"] == "solved":
            assert residuals["equilibrium"] <= 1e-6
            assert np.all(np.isfinite([float(v) for v in c["forces"].values()]))
    assert (tmp_path / "hard.csv").read_text().count("\n") > len(cases)
    assert "known failure" in (tmp_path / "hard.md").read_text()


def test_cli_rejects_unknown_case(capsys):
    assert main(["hard", "--case", "no-such-case"]) == 2
    assert capsys.readouterr().err.startswith("cardan: error: argument --case: invalid choice")


def _with_equilibrium(run, value: float):
    """``run`` with every record solved at an equilibrium residual of ``value``."""
    records = [dataclasses.replace(r, residuals=dataclasses.replace(r.residuals,
                                                                    equilibrium=value))
               for r in run.records]
    return dataclasses.replace(run, history=dataclasses.replace(
        run.history, results=Results.of(records)))


def test_the_bar_follows_the_tolerance_asked_for(suite):
    """A record at 4e-8 after a 1e-8 ask passes (the solver's last digits are not the
    bar); after a 1e-12 ask it does not."""
    (run,) = [r for r in suite if (r.case, r.formulation, r.solver)
              == ("articulation-0", "positive", "qpsolvers-daqp")]
    assert all(r.solved for r in run.records)
    runs = [_with_equilibrium(run, 4e-8)]
    assert hard.covered(runs, tol=1e-8)
    assert not hard.covered(runs, tol=1e-12)
    assert hard.bar(None) == hard.bar(1.0) == hard.ACCEPT


def _fail_positive_at_the_second_instant(monkeypatch):
    real = hard.solve_over_time

    def patched(op, formulation, solver=None, **kwargs):
        h = real(op, formulation, solver, **kwargs)
        if formulation != "positive":
            return h
        records = list(h.records)
        records[1] = dataclasses.replace(records[1], status=Status.FAILED,
                                         x=np.full_like(records[1].x, np.nan))
        return study.history_of(op, formulation, h.solver, h.instants, records, h.wall_s)
    monkeypatch.setattr(hard, "solve_over_time", patched)


def test_a_failing_run_says_which_rows_failed_and_why(monkeypatch, capsys):
    _fail_positive_at_the_second_instant(monkeypatch)
    code = main(["hard", "--quick", "--case", "articulation-0", "--formulation", "positive",
                 "--formulation", "min_norm"])
    out = capsys.readouterr().out
    assert code == 1
    (line,) = [x for x in out.splitlines() if x.startswith("FAIL ")]
    assert "articulation-0 / positive" in line and "failed" in line and "t=" in line


def test_a_variant_beyond_the_scene_limits_does_not_apply(tmp_path, capsys):
    """A middle shaft of 1e4 kg made 1e6 times heavier exceeds the mass limit: the case
    is reported as not applying, the suite still exits 0."""
    text = builtin_text("paper").replace("mass_kg = 33.764", "mass_kg = 1e4")
    path = tmp_path / "heavy.toml"
    path.write_text(text)
    case = next(c for c in hard.CASES if c.name == "mass-1e6")
    assert "mass" in hard.applies(case, str(path)).reason
    assert hard.applies(case, "paper").name == "hard-mass-1e6"
    code = main(["hard", str(path), "--quick", "--case", "mass-1e6", "--case", "base",
                 "--formulation", "positive"])
    out = capsys.readouterr().out
    assert code == 0 and "does not apply mass-1e6" in out


def test_case_words_follow_the_joint_count():
    case = next(c for c in hard.CASES if c.name == "articulation-89")
    assert case.describe(2).startswith("both joints")
    assert case.describe(3).startswith("all 3 joints")
