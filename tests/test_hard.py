"""The hard-case suite: stability properties, never time (issue: benchmarks)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from cardan_forces.experiments import hard
from cardan_forces.solvers import Residuals, Status

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
        short = hard.Case(case.name, case.what, case.overrides, stop_s=0.05)
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
