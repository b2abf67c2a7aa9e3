"""The study layer: solve-over-time answers that do not depend on the order of instants,
histories that keep failures as records, and the unknown-backend error."""

import numpy as np
import pytest
from cardan_forces.driveline.dynamics import simulate
from cardan_forces.driveline.equilibrium import build_operator
from cardan_forces.experiments import study
from cardan_forces.solvers import SolverNotFound, Status


@pytest.fixture(scope="module")
def op(paper):
    return build_operator(simulate(paper, np.linspace(0.0, 0.5, 5)))


@pytest.mark.parametrize("formulation", ["positive", "compliance_hertz", "min_max"])
def test_an_instant_has_one_answer_whatever_was_solved_before(op, formulation):
    """Backwards, forwards, or alone: the same forces within the solver's tolerance."""
    forward = study.solve_over_time(op, formulation, tol=1e-9)
    backward = study.solve_over_time(op, formulation, tol=1e-9, instants=[4, 3, 2, 1, 0])
    assert forward.solved == backward.solved == 5
    scale = np.abs(forward.forces).max()
    assert np.allclose(forward.forces, backward.forces[::-1], atol=1e-6 * scale)
    alone = study.solve_over_time(op, formulation, tol=1e-9, instants=[2])
    assert np.allclose(alone.forces[0], forward.forces[2], atol=1e-6 * scale)


def test_a_problem_that_cannot_be_built_is_a_failed_instant(op):
    def problem(i):
        if i == 1:
            raise ValueError("no problem at this instant")
        return study.FORMULATIONS["positive"](op, i)
    h = study.solve_over_time(op, "positive", instants=[0, 1, 2], problem=problem)
    assert h.statuses[1] is Status.FAILED and h.status is Status.FAILED
    assert "no problem at this instant" in h.records[1].message
    assert np.isnan(h.forces[1]).all() and np.isfinite(h.forces[[0, 2]]).all()
    assert np.isinf(h.jumps()[1:]).all() and h.jumps()[0] == 0.0


def test_repeated_check_passes_keep_the_first_pass_records(op):
    """A benchmark's repeated checks change no record: the same statuses, forces and
    measures as one pass; the fastest pass's time is the history's, not a record's."""
    once = study.solve_over_time(op, "compliance_hertz", "clarabel")
    thrice = study.solve_over_time(op, "compliance_hertz", "clarabel", check_passes=3)
    assert once.checks_s is None and thrice.checks_s is not None and thrice.checks_s > 0
    assert thrice.statuses == once.statuses and thrice.solved == 5
    assert np.allclose(thrice.forces, once.forces, rtol=1e-9, atol=0.0)
    for a, b in zip(once.records, thrice.records):
        assert dict(a.optimality) == pytest.approx(dict(b.optimality), rel=1e-6, abs=1e-12)


def test_a_budget_stops_a_run_only_once_it_has_its_least_instants(op):
    """A budget every solve exceeds: one instant by default, ``least`` when asked."""
    assert len(study.solve_over_time(op, "positive", budget_s=1e-12).records) == 1
    h = study.solve_over_time(op, "positive", budget_s=1e-12, least=3)
    assert len(h.records) == 3 and h.solved == 3


def test_an_unknown_backend_is_an_error_not_failed_records(op):
    with pytest.raises(SolverNotFound):
        study.solve_over_time(op, "positive", "no-such-backend")


@pytest.mark.parametrize("formulation", ["positive", "min_norm", "socp_face", "lcp"])
def test_the_default_backend_is_the_first_of_its_list_that_takes_the_problem(op, formulation):
    """Asking the preferred backends one by one picks what the whole registry's list
    would: the first of the formulation's own list, then the fallback, then any."""
    from cardan_forces.formulations import FORMULATIONS
    from cardan_forces.solvers import backends_for

    problem = FORMULATIONS[formulation](op, 1)
    usable = backends_for(problem)
    order = [*FORMULATIONS[formulation].backends, study.FALLBACK, *usable]
    assert study.default_backend(formulation, problem) == next(s for s in order if s in usable)
    with pytest.raises(study.NoBackend):
        study.default_backend(formulation, problem, wanted=["no-such-backend"])


def test_one_backend_loads_one_adapter_s_package():
    """Choosing and running the default ``positive`` backend imports neither cvxpy nor
    the other optional solvers' packages (a fresh interpreter: nothing loaded before)."""
    import subprocess
    import sys

    code = ("import sys, numpy as np\n"
            "from cardan_forces.driveline.loading import load_scene\n"
            "from cardan_forces.driveline.dynamics import simulate\n"
            "from cardan_forces.driveline.equilibrium import build_operator\n"
            "from cardan_forces.experiments import study\n"
            "op = build_operator(simulate(load_scene('paper'), [0.1]))\n"
            "assert study.solve_over_time(op, 'positive').solved == 1\n"
            "print(sorted(m for m in ('cvxpy', 'qoco', 'moreau') if m in sys.modules))\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout
    assert out.strip().splitlines()[-1] == "[]"
