"""The compiled optimality views of a long check pass against the NumPy path they
replace: the same package measures and solver measures on every conic formulation's
answers (solver multipliers perturbed, so that the measures are well above rounding;
a NaN and an inf answer among them), and the same records from one long pass as from
each instant checked alone."""

import numpy as np
import pytest
from cardan_forces.driveline.dynamics import simulate
from cardan_forces.driveline.equilibrium import build_operator
from cardan_forces.formulations import batch as fbatch
from cardan_forces.solvers import optimality as O
from cardan_forces.solvers import qp_measures as Q
from cardan_forces.solvers.record import KERNEL_LEAST, Outcome, finalize, finalize_all, stack_all
from cardan_forces.solvers.registry import solve_unchecked

pytestmark = pytest.mark.compiled  # also run for a generic CPU by .ci/run

pytest.importorskip("numba")

FORMULATIONS = ("min_norm", "min_norm_scaled", "positive", "compliance", "compliance_hertz",
                "min_max", "socp_face")


@pytest.fixture(scope="module")
def operator(paper):
    return build_operator(simulate(paper, paper.time.instants()[:KERNEL_LEAST + 8]))


def _answers(op, name):
    """The formulation's problems at every instant of ``op``, Clarabel's answers with
    their multipliers perturbed, instant 3's answer NaN and instant 5's multipliers inf.
    """
    problems = fbatch.build_problems(op, name, np.arange(len(op.t)))
    rng = np.random.default_rng(7)
    outcomes = []
    for k, problem in enumerate(problems):
        found = solve_unchecked(problem, "clarabel").outcome
        y = found.y * (1.0 + 1e-3 * rng.standard_normal(len(found.y)))
        z = np.full_like(found.z, np.nan) if k == 3 else found.z
        y = np.full_like(y, np.inf) if k == 5 else y
        outcomes.append(Outcome("solved", z, y=y))
    return problems, outcomes


@pytest.mark.parametrize("name", FORMULATIONS)
def test_compiled_views_equal_the_numpy_views(operator, name):
    problems, outcomes = _answers(operator, name)
    st = stack_all(problems).conic
    z = np.array([o.z for o in outcomes])
    y, given = O.multipliers(st, z, [o.y for o in outcomes])
    assert given.all()
    numpy_view, parts = O.stacked_measures(st, z, y)
    for check in (True, False):
        package, solver = O.compiled_views(st, z, y, check_dual_cone=check)
        theirs = Q.from_parts(parts, st.b - st.Az(z), st.cones, check_dual_cone=check)
        good = np.isfinite(numpy_view["objective"])
        scale = 1.0 + np.abs(numpy_view["objective"][good]).max()
        for key in ("dual", "gap"):  # relative measures: rounding is 1e-16 of one
            np.testing.assert_allclose(package[key], numpy_view[key], rtol=1e-9, atol=1e-13)
        np.testing.assert_allclose(package["objective"][good],
                                   numpy_view["objective"][good], rtol=1e-12)
        for key in Q.MEASURES:  # absolute measures: rounding scales with the objective
            np.testing.assert_allclose(solver[key], theirs[key], rtol=1e-9,
                                       atol=1e-12 * scale)
        assert np.all(np.isinf(solver["gap"][[3, 5]]))
        assert np.all(np.isinf(package["dual"][[3, 5]]))
    if name == "compliance_hertz":  # the power cones' branches are exercised
        assert any(kind == "pow" for kind, _ in st.cones)
    assert np.all(numpy_view["dual"][np.isfinite(numpy_view["dual"])] > 1e-8)


@pytest.mark.parametrize("name", ("positive", "compliance_hertz", "socp_face"))
def test_a_long_check_pass_gives_the_records_of_each_instant_alone(operator, name):
    problems, outcomes = _answers(operator, name)
    assert len(problems) >= KERNEL_LEAST  # the pass goes through the compiled views
    together = finalize_all(problems, "hand", outcomes, stacks=stack_all(problems))
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
