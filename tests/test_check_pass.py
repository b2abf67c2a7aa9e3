"""The check pass over a run of many instants against each instant checked alone: the
same statuses and measures on every conic formulation's answers (solver multipliers
perturbed at every other instant, so that the measures are well above rounding there
and those answers not solved; a NaN and an inf answer among them), by the same
arithmetic whatever the run's length, and a run's columns read back as the records
they hold."""

import numpy as np
import pytest
from cardan_forces.driveline.dynamics import simulate
from cardan_forces.driveline.equilibrium import build_operator
from cardan_forces.formulations import batch as fbatch
from cardan_forces.solvers.judge import finalize, finalize_all
from cardan_forces.solvers.record import Outcome, Results
from cardan_forces.solvers.registry import solve_unchecked
from cardan_forces.solvers.stacking import stack_all

FORMULATIONS = ("min_norm", "min_norm_scaled", "positive", "compliance", "compliance_hertz",
                "min_max", "socp_face")


@pytest.fixture(scope="module")
def operator(paper):
    return build_operator(simulate(paper, paper.time.instants()[:40]))


def _answers(op, name):
    """The formulation's problems at every instant of ``op``, Clarabel's answers with
    their multipliers perturbed at odd instants, instant 3's answer NaN and instant 5's
    multipliers inf.
    """
    problems = fbatch.build_problems(op, name, np.arange(len(op.t)))
    rng = np.random.default_rng(7)
    outcomes = []
    for k, problem in enumerate(problems):
        found = solve_unchecked(problem, "clarabel").outcome
        y = found.y * (1.0 + 1e-3 * (k % 2) * rng.standard_normal(len(found.y)))
        z = np.full_like(found.z, np.nan) if k == 3 else found.z
        y = np.full_like(y, np.inf) if k == 5 else y
        outcomes.append(Outcome("solved", z, y=y))
    return problems, outcomes


@pytest.mark.parametrize("name", FORMULATIONS)
def test_a_long_check_pass_gives_the_records_of_each_instant_alone(operator, name):
    problems, outcomes = _answers(operator, name)
    together = finalize_all(problems, "hand", outcomes, stacks=stack_all(problems))
    assert isinstance(together, Results) and len(together) == len(problems)
    for problem, outcome, record in zip(problems, outcomes, together):
        alone = finalize(problem, "hand", outcome)
        assert (record.status, record.duals) == (alone.status, alone.duals)
        assert dict(record.optimality) == pytest.approx(dict(alone.optimality), rel=1e-9,
                                                        abs=1e-13)
        assert (record.solver_optimality is None) == (alone.solver_optimality is None)
        if alone.solver_optimality is not None:
            assert dict(record.solver_optimality) == pytest.approx(
                dict(alone.solver_optimality), rel=1e-9, abs=1e-10)
    assert {r.status for r in together} >= {"solved", "failed"}
    assert np.all(np.isinf(together.optimality.dual[[3, 5]]))


@pytest.mark.parametrize("name", ("positive", "socp_face"))
def test_a_runs_columns_are_the_columns_of_its_records(operator, name):
    """``Results.of`` the records a run's columns give holds those columns again: the
    per-instant record is a view of the columns, not a second account of the answer."""
    problems, outcomes = _answers(operator, name)
    results = finalize_all(problems, "hand", outcomes, references=[
        None if k % 2 else np.zeros(len(p.checks.names)) for k, p in enumerate(problems)])
    again = Results.of(list(results))
    assert list(again.status) == list(results.status)
    for key in ("primal", "dual", "gap", "distance"):
        np.testing.assert_array_equal(getattr(again.optimality, key),
                                      getattr(results.optimality, key))
    for key in (*results.residuals.KEYS, "reference"):
        np.testing.assert_array_equal(getattr(again.residuals, key),
                                      getattr(results.residuals, key))
    assert np.isnan(results.residuals.reference[1::2]).all()
    assert results[1].residuals.reference is None and results[0].residuals.reference >= 0
    for a, b in zip(again.x, results.x):
        np.testing.assert_array_equal(a, b)
