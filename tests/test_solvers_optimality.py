"""Optimality measured from the problem data: dual residual, duality / objective gap,
distance only where the optimum is unique (the package's relative measures, not
qpbenchmark's absolute ones); the status rule that uses them, on constructed outcomes
whose measures are known by hand (a feasible answer that is not the optimum is never
solved, for every problem class and path); the checks of many instants at once against
each instant alone."""

import numpy as np
import pytest
from cardan_forces.formulations.problems import LCP, LP, LS, QP, Conic, ForceChecks
from cardan_forces.solvers import ACCEPT, Backend, Optimality, available, registry, solve
from cardan_forces.solvers.judge import finalize, judged_status, measures, recover, unique_optimum
from cardan_forces.solvers.record import Outcome
from cardan_forces.solvers.reference_problems import references


def _checks(A, b, unilateral):
    A = np.atleast_2d(np.asarray(A, float))
    return ForceChecks(A=A, b=np.asarray(b, float),
                       names=tuple(f"x{i}" for i in range(A.shape[1])),
                       unilateral=np.asarray(unilateral, bool))


def _projection() -> QP:
    """min 1/2||x - c||^2 on x0+x1+x2 = 1, x >= 0, c = (1.2, 0.6, -1): x = (0.8, 0.2, 0);
    by hand, x - c + y e + (lower-bound rows -I)' y_lb = 0 gives y = 0.4 on the
    equality (conic sign) and y_lb = (0, 0, 1.4) on the bounds.
    """
    ones = np.ones((1, 3))
    return QP(checks=_checks(ones, [1.0], [True] * 3), formulation="ref", P=np.eye(3),
              q=-np.array([1.2, 0.6, -1.0]), A=ones, b=np.array([1.0]), lb=np.zeros(3))


def _flat_lp() -> LP:
    """min x0 + x1 on x0 + x1 = 1, x >= 0: every point of the segment is optimal (value 1)."""
    return LP(checks=_checks([[1.0, 1.0]], [1.0], [True, True]), formulation="ref",
              c=np.array([1.0, 1.0]), A=np.array([[1.0, 1.0]]), b=np.array([1.0]),
              lb=np.zeros(2))


def test_known_multipliers_give_zero_dual_residual_and_gap():
    problem = _projection()
    exact = np.array([0.4, 0.0, 0.0, 1.4])
    record = finalize(problem, "hand", Outcome("solved", np.array([0.8, 0.2, 0.0]),
                                               y=exact))
    assert record.duals == "solver"
    assert record.optimality["dual"] <= 1e-15 and record.optimality["gap"] <= 1e-15
    wrong = finalize(problem, "hand", Outcome("solved", np.array([0.8, 0.2, 0.0]),
                                              y=exact + [0.1, 0, 0, 0]))
    assert wrong.optimality["dual"] > 1e-2  # stationarity fails with the wrong multiplier
    conic = problem.as_conic()
    assert np.allclose(recover(conic.P, conic.q, conic.A, conic.b, conic.cones,
                               np.array([0.8, 0.2, 0.0])), exact, atol=1e-12)


def test_a_feasible_point_that_is_not_optimal_has_a_gap():
    problem = _projection()
    record = finalize(problem, "hand", Outcome("solved", np.array([0.5, 0.5, 0.0])),
                      reference=np.array([0.8, 0.2, 0.0]))
    assert record.optimality["primal"] <= 1e-15  # primal feasible, yet not the optimum
    assert max(record.optimality["dual"], record.optimality["gap"]) > 1e-2
    assert record.status == "inaccurate"
    assert record.optimality["distance"] > 0.3  # unique optimum: the distance is reported
    assert not record.within(1e-6)


def test_non_unique_optimum_has_zero_gap_where_the_distance_would_fail():
    problem = _flat_lp()
    assert not unique_optimum(problem)
    for point in ([0.3, 0.7], [1.0, 0.0]):
        record = finalize(problem, "hand", Outcome("solved", np.array(point)),
                          reference=np.array([0.5, 0.5]), optimal_value=1.0)
        assert record.residuals["reference"] > 0.2  # distance to one optimal point fails
        assert "distance" not in record.optimality  # ... so it is not a measure here
        assert record.optimality["dual"] <= 1e-15 and record.optimality["gap"] <= 1e-15
        assert record.within(1e-12)


def test_objective_gap_for_a_record_without_duals():
    record = finalize(_flat_lp(), "hand", Outcome("solved", np.array([0.5, 0.5])),
                      optimal_value=0.9)
    assert record.duals == "recovered" and record.gap_kind == "objective"
    assert record.optimality["gap"] == pytest.approx(0.1 / 0.9)


def test_second_order_cone_multiplier_on_the_boundary():
    # min t s.t. u + v = 2, ||(u, v)|| <= t: u = v = 1, t = sqrt 2; the multipliers are
    # y_eq = -1/sqrt2 (conic sign) and the cone's y = (1, -1/sqrt2, -1/sqrt2).
    A = np.vstack([[0.0, 1, 1], -np.eye(3)])
    b = np.array([2.0, 0, 0, 0])
    q = np.array([1.0, 0, 0])
    z = np.array([np.sqrt(2.0), 1, 1])
    y = recover(None, q, A, b, (("zero", 1), ("soc", 3)), z)
    exact = np.array([-1 / np.sqrt(2), 1.0, -1 / np.sqrt(2), -1 / np.sqrt(2)])
    assert np.allclose(y, exact, atol=1e-12)
    found = measures(None, q[None], A[None], b[None], (("zero", 1), ("soc", 3)), z[None],
                     exact[None])
    assert found["dual"][0] <= 1e-15 and found["gap"][0] <= 1e-15


def test_min_max_like_problem_solved_by_clarabel_is_optimal_without_a_distance():
    """The least peak of two loads whose sum is fixed, with a free third component: the
    optimum is a set, Clarabel lands somewhere in it, and the measures say optimal."""
    if "clarabel" not in available():
        pytest.skip("clarabel not installed")
    # z = (a, b, c, t): a + b = 2, |a| <= t, |b| <= t, c free in [-1, 1] and unused.
    A = np.vstack([[1.0, 1, 0, 0],
                   [0, 0, 0, -1], [-1, 0, 0, 0],
                   [0, 0, 0, -1], [0, -1, 0, 0],
                   [0, 0, 1, 0], [0, 0, -1, 0]])
    b = np.array([2.0, 0, 0, 0, 0, 1, 1])
    checks = _checks([[1.0, 1, 0, 0]], [2.0], [False] * 4)
    problem = Conic(checks=checks, formulation="ref", q=np.array([0.0, 0, 0, 1]), A=A, b=b,
                    cones=(("zero", 1), ("soc", 2), ("soc", 2), ("nonneg", 2)))
    record = solve(problem, "clarabel", tol=1e-9, reference=np.array([1.0, 1, 0.5, 1]))
    assert record.status == "solved" and record.duals == "solver"
    assert "distance" not in record.optimality
    assert record.within(1e-7)


def test_the_rule_asks_primal_dual_and_gap_of_every_answer_whatever_the_solver_said():
    good = Optimality(primal=1e-12, dual=1e-10, gap=1e-9)
    kept = ["failed", "infeasible", "unbounded"]
    assert list(judged_status(kept, good, "solver")) == kept  # no answer: nothing to judge
    for reported in ("solved", "inaccurate"):
        assert judged_status(reported, good, "solver") == "solved"
        for key in ("primal", "dual", "gap"):
            for value, expected in ((0.5 * ACCEPT, "solved"), (2.0 * ACCEPT, "inaccurate"),
                                    (np.nan, "inaccurate"), (np.inf, "inaccurate")):
                measured = Optimality(**{**good, key: value})
                assert judged_status(reported, measured, "recovered") == expected
            absent = Optimality(**{k: v for k, v in good.items() if k != key})
            assert judged_status(reported, absent, "solver") == "inaccurate"  # a measure it lacks
    batch = Optimality(**{k: np.array([v, 10 * ACCEPT, v]) for k, v in good.items()})
    assert list(judged_status(np.array(["inaccurate", "solved", "failed"], object), batch,
                      "solver")) == ["solved", "inaccurate", "failed"]


def test_without_multipliers_the_primal_residual_decides_and_nothing_is_confirmed():
    """A root finding has no dual: its reported solved stands on its residual alone, and
    its reported inaccurate cannot be confirmed."""
    assert judged_status("solved", Optimality(primal=0.5 * ACCEPT), "none") == "solved"
    assert judged_status("solved", Optimality(primal=2.0 * ACCEPT), "none") == "inaccurate"
    assert judged_status("inaccurate", Optimality(primal=0.0), "none") == "inaccurate"
    per_instant = np.array(["solver", "none"], object)
    found = Optimality(primal=np.zeros(2), dual=np.array([1.0, np.nan]),
                       gap=np.array([1.0, np.nan]))
    assert list(judged_status(np.array(["solved"] * 2, object), found, per_instant)) == \
        ["inaccurate", "solved"]


EXACT_Y = np.array([0.4, 0.0, 0.0, 1.4])
"""The multipliers of :func:`_projection` (equality row, then the bounds' rows)."""

EXACT_Z = np.array([0.8, 0.2, 0.0])


def _shifted(eps: float) -> np.ndarray:
    """The exact multipliers with the equality's moved by ``eps``: by hand, the
    stationarity residual is ``eps`` in every component against the largest term
    ``||q||_inf = 1.2`` (dual ``eps / 1.2``), and the dual objective drops by ``eps``
    from the primal ``-0.74`` (gap ``eps / (0.74 + eps)``, relative to the larger).
    """
    return EXACT_Y + np.array([eps, 0.0, 0.0, 0.0])


@pytest.fixture
def stub(monkeypatch):
    """Register a backend ``stub`` for QPs that returns the outcome the test gives."""
    def register(outcome: Outcome):
        available()  # load the real ones first
        backend = Backend(name="stub", family="test", distributions=("numpy",),
                          accepts=(QP,), solve=lambda problem, tol=None, initvals=None: outcome)
        monkeypatch.setitem(registry._CACHE, "stub", backend)
    return register


@pytest.mark.parametrize(("eps", "expected"), [(0.0, "solved"), (0.5 * ACCEPT, "solved"),
                                               (2.0 * ACCEPT, "inaccurate")])
def test_a_solvers_inaccurate_is_solved_where_the_measures_say_so(stub, eps, expected):
    """Both sides of the rule through the registry, on measures known by hand."""
    stub(Outcome("inaccurate", EXACT_Z, message="stalled", y=_shifted(eps)))
    record = solve(_projection(), "stub")
    assert record.optimality["dual"] == pytest.approx(eps / 1.2, rel=1e-6, abs=1e-15)
    assert record.optimality["gap"] == pytest.approx(eps / (0.74 + eps), rel=1e-6, abs=1e-15)
    assert record.status == expected
    assert ("confirmed" in record.message) == (expected == "solved")


def test_an_infeasible_answer_is_not_confirmed(stub):
    """A primal residual above ACCEPT keeps the solver's inaccurate (and turns a
    reported solved into inaccurate), whatever the multipliers."""
    z = EXACT_Z + [2 * ACCEPT, 0.0, 0.0]  # equilibrium residual 2 ACCEPT (||b|| = 1)
    for reported in ("inaccurate", "solved"):
        stub(Outcome(reported, z, y=EXACT_Y))
        record = solve(_projection(), "stub")
        assert record.optimality["primal"] == pytest.approx(2 * ACCEPT)
        assert record.status == "inaccurate"


def test_recovered_multipliers_confirm_and_no_multipliers_do_not(stub):
    stub(Outcome("inaccurate", EXACT_Z))  # no duals: the package recovers them
    record = solve(_projection(), "stub")
    assert record.duals == "recovered" and record.status == "solved"
    ref = next(r for r in references() if r.name == "nls_polynomial")
    root = finalize(ref.problem, "hand", Outcome("inaccurate", ref.x))
    assert root.duals == "none" and root.optimality["primal"] <= 1e-15
    assert root.status == "inaccurate"  # a root finder's doubt has no dual to settle it


def test_the_batched_path_follows_the_same_rule():
    """Three instants of a constructed batch: confirmed, not confirmed, reported solved;
    each batched record equals the per-instant record of the same outcome."""
    from cardan_forces.formulations.batch import conic_batch
    from cardan_forces.solvers.judge import finalize_batch
    from cardan_forces.solvers.record import BatchOutcome

    conic = _projection().as_conic()
    batch = conic_batch([conic] * 3, [0, 1, 2])
    status = np.array(["inaccurate", "inaccurate", "solved"], object)
    y = np.array([_shifted(0.5 * ACCEPT), _shifted(2 * ACCEPT), EXACT_Y])
    result = finalize_batch(batch, "stub", BatchOutcome(
        status=status, z=np.array([EXACT_Z] * 3), y=y, iterations=np.zeros(3, int),
        setup_s=0.0, solve_s=0.0))
    assert list(result.status) == ["solved", "inaccurate", "solved"]
    for k in range(3):
        alone = finalize(conic, "stub", Outcome(status[k], EXACT_Z, y=y[k]))
        assert result.record(k).status == alone.status
        for key, value in alone.optimality.items():
            assert result.optimality[key][k] == pytest.approx(value, rel=1e-9, abs=1e-18)


def _variants(k: int):
    """Constructed problems of three classes whose numbers change with ``k`` (the same
    structure), and answers near their optima with the multipliers perturbed."""
    qp = _projection()
    lifted = QP(checks=qp.checks, formulation="ref", P=(1 + k) * np.eye(3), q=qp.q - 0.1 * k,
                A=qp.A, b=qp.b + 0.2 * k, lb=np.array([0.0, -np.inf, 0.0]),
                ub=np.array([np.inf, 3.0, np.inf]))
    cone = Conic(checks=_checks(np.eye(3), [1.0, 0.5, 0.5], [False] * 3), formulation="ref",
                 P=np.eye(3), q=np.array([0.0, 1.0 + k, -1.0]), A=-np.eye(3),
                 b=np.zeros(3), cones=(("soc", 3),))
    return lifted, cone


def test_checks_of_many_instants_at_once_equal_each_instant_alone():
    """finalize_all stacks problems per structure (bounds as rows never written out);
    every record must equal the one finalize gives for its instant alone, for QPs with
    bounds, a second-order cone, answers without multipliers (recovered) or with NaN."""
    from cardan_forces.solvers.judge import finalize_all

    rng = np.random.default_rng(3)
    problems, outcomes, refs = [], [], []
    for k in range(4):
        for problem in _variants(k):
            conic = registry.convert(problem, (Conic,))
            found = solve(problem, "clarabel", tol=1e-10)
            z = found.z if isinstance(problem, Conic) else found.x
            y = None if k == 1 else found.y + 1e-4 * rng.standard_normal(len(conic.b))
            z = np.full_like(z, np.nan) if k == 3 and isinstance(problem, QP) else z
            problems.append(problem)
            outcomes.append(Outcome("solved" if k != 2 else "inaccurate", z, y=y))
            refs.append(found.x)
    together = finalize_all(problems, "hand", outcomes, references=refs)
    for problem, outcome, ref, record in zip(problems, outcomes, refs, together):
        alone = finalize(problem, "hand", outcome, reference=ref)
        assert (record.status, record.duals, record.gap_kind) == (alone.status, alone.duals,
                                                                  alone.gap_kind)
        assert dict(record.optimality) == pytest.approx(dict(alone.optimality), rel=1e-12)
        assert dict(record.residuals) == pytest.approx(dict(alone.residuals), rel=1e-12)
        assert (record.solver_optimality is None) == (alone.solver_optimality is None)
    assert {r.duals for r in together} >= {"solver", "recovered", "none"}


def test_checks_with_stacks_built_beforehand_equal_the_checks_without():
    """finalize_all with the problems' data stacked once (stack_all, taken at some rows)
    gives the records it gives stacking itself, answered or not (a NaN answer, a
    recovered multiplier); stacks of other problems are ignored, not misread."""
    from cardan_forces.solvers.judge import finalize_all
    from cardan_forces.solvers.stacking import stack_all

    rng = np.random.default_rng(5)
    for pick in (0, 1):
        problems, outcomes = [], []
        for k in range(5):
            problem = _variants(k)[pick]
            found = solve(problem, "clarabel", tol=1e-10)
            z = found.z if isinstance(problem, Conic) else found.x
            z = np.full_like(z, np.nan) if k == 3 else z
            y = None if k == 1 else found.y + 1e-4 * rng.standard_normal(len(found.y))
            problems.append(problem)
            outcomes.append(Outcome("solved" if k != 2 else "inaccurate", z, y=y))
        stacks = stack_all(problems)
        assert stacks is not None and stacks.conic is not None
        rows = [0, 2, 3, 4]
        chosen, answers = [problems[k] for k in rows], [outcomes[k] for k in rows]
        plain = finalize_all(chosen, "hand", answers)
        for given in (stacks.take(rows), stacks.take([1, 2, 3, 4])):
            for record, alone in zip(finalize_all(chosen, "hand", answers, stacks=given),
                                     plain):
                assert (record.status, record.duals, record.gap_kind) == (
                    alone.status, alone.duals, alone.gap_kind)
                assert dict(record.optimality) == pytest.approx(dict(alone.optimality),
                                                                rel=1e-12)
                assert dict(record.residuals) == pytest.approx(dict(alone.residuals),
                                                               rel=1e-12)
                assert (record.solver_optimality is None) == (alone.solver_optimality is None)
                if record.solver_optimality is not None:
                    assert dict(record.solver_optimality) == pytest.approx(
                        dict(alone.solver_optimality), rel=1e-12)
        assert any(r.status == "failed" for r in plain)


def test_stacked_conic_form_equals_each_conversion():
    from cardan_forces.solvers.stacking import stack_conic

    problems = [_variants(k)[0] for k in range(3)]
    stacked = stack_conic(problems)
    z, y = np.random.default_rng(0).standard_normal((3, 3)), np.ones((3, 4))
    for k, problem in enumerate(problems):
        conic = problem.as_conic()
        assert np.array_equal(stacked.A(k), conic.A)
        assert np.array_equal(stacked.b[k], conic.b)
        assert stacked.cones == conic.cones
        assert np.allclose(stacked.Az(z)[k], conic.A @ z[k], rtol=0, atol=1e-14)
        assert np.allclose(stacked.Aty(y)[k], conic.A.T @ y[k], rtol=0, atol=1e-14)



def test_rows_shared_by_every_instant_are_kept_once_and_give_each_instants_products():
    """Rows the same at every instant (a cone's) are one matrix, the others a stack, in
    row order; products, an instant's A and a subset of instants equal the dense ones."""
    from cardan_forces.solvers.stacking import stacked_batch

    rng = np.random.default_rng(1)
    T, m, n = 4, 7, 3
    A = np.broadcast_to(rng.standard_normal((m, n)), (T, m, n)).copy()
    A[:, [1, 2, 5]] = rng.standard_normal((T, 3, n))  # rows that change with the instant
    stacked = stacked_batch(None, np.zeros((T, n)), A, np.zeros((T, m)), (("zero", m),))
    assert [np.ndim(block) for block in stacked.blocks] == [2, 3, 2, 3, 2]
    z, y = rng.standard_normal((T, n)), rng.standard_normal((T, m))
    for k in range(T):
        assert np.array_equal(stacked.A(k), A[k])
        assert np.allclose(stacked.Az(z)[k], A[k] @ z[k], rtol=0, atol=1e-14)
        assert np.allclose(stacked.Aty(y)[k], A[k].T @ y[k], rtol=0, atol=1e-14)
    some = stacked.take(np.array([3, 1]))
    assert np.array_equal(some.A(0), A[3]) and np.array_equal(some.A(1), A[1])
    assert np.allclose(some.Az(z[[3, 1]]), stacked.Az(z)[[3, 1]], rtol=0, atol=1e-14)

def test_every_record_carries_the_solver_view_of_the_problem_it_received():
    """The record's solver optimality is judge.solver_optimality of the received
    problem with the solver's multipliers (absolute), beside the package's relative
    measures; the adapter's own status is kept."""
    from cardan_forces.solvers import judge

    problem = _variants(1)[0]
    record = solve(problem, "clarabel")
    expected = judge.solver_optimality(problem.as_conic(), record.z, record.y)
    assert record.solver_status == "solved"
    assert dict(record.solver_optimality) == pytest.approx(expected, rel=1e-12, abs=1e-300)
    assert record.wall_s >= record.solve_s + record.checks_s


class _Halved:
    """A map to forces that offers the stacked form (``stacked``), counting its calls."""

    calls = 0

    def __call__(self, z):
        return 0.5 * np.asarray(z, float)

    @staticmethod
    def stacked(maps, Z):
        _Halved.calls += 1
        return 0.5 * np.asarray(Z, float)


def test_a_map_that_offers_its_stacked_form_maps_a_run_at_once_as_one_at_a_time():
    """Forces of a run whose maps offer ``stacked`` come from one call and equal the
    per-instant map's; an answer it cannot take (none given) falls back to the
    per-instant map, which names the failure."""
    from cardan_forces.solvers.judge import finalize_all
    from cardan_forces.solvers.stacking import stack_all

    problems = [QP(checks=_checks(np.ones((1, 3)), [1.0 + k], [True] * 3), formulation="ref",
                   to_forces=_Halved(), P=np.eye(3), q=np.zeros(3), A=np.ones((1, 3)),
                   b=np.array([2.0 + 2 * k]), lb=np.zeros(3)) for k in range(3)]
    outcomes = [Outcome("solved", np.full(3, (2.0 + 2 * k) / 3)) for k in range(3)]
    _Halved.calls = 0
    together = finalize_all(problems, "hand", outcomes, stacks=stack_all(problems))
    assert _Halved.calls == 1
    for problem, outcome, record in zip(problems, outcomes, together):
        assert np.array_equal(record.x, finalize(problem, "hand", outcome).x)
        assert record.status == "solved" and record.residuals["equilibrium"] < 1e-15
    outcomes[1] = Outcome("solved", None)
    _Halved.calls = 0
    mixed = finalize_all(problems, "hand", outcomes, stacks=stack_all(problems))
    assert _Halved.calls == 0
    assert [r.status for r in mixed] == ["solved", "failed", "solved"]
    assert "solver returned no solution" in mixed[1].message


def test_one_cone_violation_for_the_slack_and_the_multipliers():
    """K and K* by one formula: a zero row counts in K and is free in K*; a power cone's
    point on the boundary of K (``|w| = u^a x^(1-a)``) or of K* (``|w| = (u/a)^a
    (x/(1-a))^(1-a)``) is inside, and ``w`` beyond it by ``d`` is outside by ``d``."""
    from cardan_forces.solvers.judge import cone_violation

    a, u, x, d = 0.3, 2.0, 5.0, 0.25
    cones = (("zero", 1), ("pow", a))
    on_K, on_dual = u ** a * x ** (1 - a), (u / a) ** a * (x / (1 - a)) ** (1 - a)
    v = np.array([[-0.5, u, x, -on_K], [-0.5, u, x, on_K + d], [0.0, u, x, on_dual + d],
                  [0.0, u, x, -on_dual]])
    assert cone_violation(cones, v) == pytest.approx([0.5, 0.5, on_dual + d - on_K,
                                                      on_dual - on_K])
    assert cone_violation(cones, v[2:], dual=True) == pytest.approx([d, 0.0], abs=1e-12)
    assert cone_violation(cones, v[:2, :] * [1, 1, 1, 0], dual=True) == pytest.approx(
        [0.0, 0.0])


def _least_norm() -> LS:
    """min 1/2||x||^2 on x0 + x1 = 2: x = (1, 1), y = -1 (conic sign)."""
    return LS(checks=_checks([[1.0, 1.0]], [2.0], [False, False]), formulation="ref",
              A=np.array([[1.0, 1.0]]), b=np.array([2.0]))


def _cone() -> Conic:
    """min t on u + v = 2, ||(u, v)|| <= t (z = (t, u, v)): z = (sqrt 2, 1, 1)."""
    return Conic(checks=_checks([[0.0, 1.0, 1.0]], [2.0], [False] * 3), formulation="ref",
                 q=np.array([1.0, 0.0, 0.0]), A=np.vstack([[0.0, 1, 1], -np.eye(3)]),
                 b=np.array([2.0, 0, 0, 0]), cones=(("zero", 1), ("soc", 3)))


def _complementarity() -> LCP:
    """z >= 0, w = z + (-1, 1) >= 0, z'w = 0: z = (1, 0); forces z with z0 = 1."""
    return LCP(checks=_checks([[1.0, 0.0]], [1.0], [True, True]), formulation="ref",
               M=np.eye(2), q=np.array([-1.0, 1.0]))


ROOT2 = np.sqrt(2.0)
CASES = {
    # class: (problem, optimum z and y, a feasible answer that is not optimal, its y).
    # LS: x = (2, 0) with the optimum's y; stationarity and the gap fail (a least norm
    # has no inequality: feasible and stationary is optimal).
    "LS": (_least_norm, [1.0, 1.0], [-1.0], [2.0, 0.0], [-1.0]),
    # QP: x = (0.5, 0.5, 0) with y = (0.7; 0, 0.6, 1.7) >= 0 stationary by hand
    # (x - c + 0.7 e = y_lb), but y_lb's second row has slack 0.5: gap 0.3 / 0.95.
    "QP": (_projection, EXACT_Z, EXACT_Y, [0.5, 0.5, 0.0], [0.7, 0.0, 0.6, 1.7]),
    # Conic: z = (3, 2, 0) inside the cone, y = (0; 1, 0, 0) in K* and stationary
    # (q + A'y = 0), but not complementary: primal 3, dual 0, gap 1.
    "Conic": (_cone, [ROOT2, 1.0, 1.0], [-1 / ROOT2, 1.0, -1 / ROOT2, -1 / ROOT2],
              [3.0, 2.0, 0.0], [0.0, 1.0, 0.0, 0.0]),
    # LCP: z = (1, 1) gives w = (0, 2) >= 0 and the forces' checks hold, but z'w = 2.
    "LCP": (_complementarity, [1.0, 0.0], None, [1.0, 1.0], None),
}


@pytest.mark.parametrize("kind", list(CASES))
@pytest.mark.parametrize("given", [True, False], ids=["solver-duals", "no-duals"])
def test_a_feasible_answer_that_is_not_the_optimum_is_never_solved(kind, given):
    """The class of 'solved on residuals alone': tiny residuals and a large gap are not
    solved, whether the solver reported success and whether it gave multipliers (the
    package then recovers them, or for an LCP measures its own w); the optimum is."""
    make, best, best_y, other, other_y = CASES[kind]
    problem = make()
    for reported in ("solved", "inaccurate"):
        record = finalize(problem, "hand", Outcome(reported, np.array(other, float),
                                                   y=other_y if given else None))
        assert record.optimality["primal"] <= 1e-15
        assert max(record.optimality["dual"], record.optimality["gap"]) > 0.1
        assert record.status == "inaccurate"
        assert "> 1e-06" in record.message or reported == "inaccurate"
        optimum = finalize(problem, "hand", Outcome(reported, np.array(best, float),
                                                    y=best_y if given else None))
        assert optimum.status == "solved"
        assert not optimum.message.count("> 1e-06")


def test_a_large_gap_with_a_zero_dual_residual_is_named_in_the_message():
    """The issue's case in miniature: stationary multipliers, feasible answer, the gap
    alone says it is not the optimum, and the message says so."""
    _, _, _, other, other_y = CASES["Conic"]
    record = finalize(_cone(), "hand", Outcome("solved", np.array(other), y=other_y))
    assert record.optimality["dual"] <= 1e-15 and record.optimality["gap"] > 0.5
    assert record.status == "inaccurate" and "gap" in record.message


def test_batched_paths_judge_a_feasible_answer_that_is_not_optimal_as_each_instant_alone():
    """A conic batch (QP and cone) and a least-norm batch, the optimum beside a
    feasible, stationary, non-complementary answer: solved and not, as finalize says."""
    from cardan_forces.formulations.batch import CheckBatch, LeastNormBatch, conic_batch
    from cardan_forces.solvers.judge import finalize_batch
    from cardan_forces.solvers.record import BatchOutcome

    def outcome(z, y):
        return BatchOutcome(status=np.array(["solved"] * 2, object), z=np.array(z, float),
                            y=None if y is None else np.array(y, float),
                            iterations=np.zeros(2, int), setup_s=0.0, solve_s=0.0)

    for kind in ("QP", "Conic"):
        make, best, best_y, other, other_y = CASES[kind]
        conic = registry.convert(make(), (Conic,))
        batch = conic_batch([conic] * 2, [0, 1])
        for ys in ([best_y, other_y], None):
            result = finalize_batch(batch, "hand", outcome([best, other], ys))
            assert list(result.status) == ["solved", "inaccurate"]
            for k, (z, y) in enumerate(zip((best, other), (best_y, other_y))):
                alone = finalize(conic, "hand", Outcome("solved", np.array(z, float),
                                                        y=y if ys else None))
                assert result.record(k).status == alone.status
    # min 1/2||x||^2 on x0 + x1 = 2, x >= 0 (rows A, then -x_j <= 0): the optimum (1, 1)
    # with y = (-1; 0, 0), and (2, 0) with y = (0; 2, 0) >= 0, stationary, gap 4 / 2.
    A, b = np.array([[[1.0, 1.0]]] * 2), np.array([[2.0]] * 2)
    checks = CheckBatch(A=A, b=b, names=("x0", "x1"), unilateral=np.array([True, True]))
    batch = LeastNormBatch("ref", np.arange(2), A, b, None, np.array([True, True]), checks)
    result = finalize_batch(batch, "hand", outcome([[1.0, 1.0], [2.0, 0.0]],
                                                   [[-1.0, 0.0, 0.0], [0.0, 2.0, 0.0]]))
    assert result.optimality["dual"][1] <= 1e-15 and result.optimality["gap"][1] > 1.0
    assert list(result.status) == ["solved", "inaccurate"]
    assert result.message[0] == "" and result.message[1].startswith("gap")


def _hand_lp() -> LP:
    """min 2 x0 - 2 x1 + x2 - x3 on x0 + x1 + x2 = 4, x1 - x2 <= 1, x0, x1 in [0, 3],
    x2, x3 <= 3: with x2 = 4 - x0 - x1 it is min x0 - 3 x1 - x3 + 4 on 2 x1 + x0 <= 5,
    so by hand x = (0, 2.5, 1.5, 3): an equality, an inequality, a lower bound and an
    upper bound active, each with a nonzero multiplier."""
    return LP(checks=_checks([[1.0, 1.0, 1.0, 0.0]], [4.0], [False] * 4), formulation="ref",
              c=np.array([2.0, -2.0, 1.0, -1.0]), A=np.array([[1.0, 1.0, 1.0, 0.0]]),
              b=np.array([4.0]), G=np.array([[0.0, 1.0, -1.0, 0.0]]), h=np.array([1.0]),
              lb=np.array([0.0, 0.0, -np.inf, -np.inf]), ub=np.full(4, 3.0))


@pytest.mark.parametrize("scale", [1.0, 1e3])
def test_an_lp_is_judged_with_its_solver_s_multipliers(scale):
    """HiGHS's marginals turned into the conic rows' multipliers: dual residual and gap
    of its optimum vanish, so its answer is solved on the solver's own duals (the
    multipliers a least-squares recovery finds for a degenerate LP need not be dual
    feasible)."""
    lp = _hand_lp()
    lp = LP(checks=lp.checks, formulation="ref", c=scale * lp.c, A=lp.A, b=lp.b, G=lp.G,
            h=lp.h, lb=lp.lb, ub=lp.ub)
    record = solve(lp, "scipy-highs")
    assert record.solved and record.duals == "solver"
    assert np.allclose(record.z, [0.0, 2.5, 1.5, 3.0], atol=1e-9)
    assert record.optimality["dual"] <= 1e-12 and record.optimality["gap"] <= 1e-12


def test_a_feasibility_problem_is_optimal_at_any_feasible_point():
    """min 0 over x0 + x1 = 1, x >= 0: a feasible z with y = 0 meets stationarity and
    closes the gap, so rounding-sized multipliers a solver returns (A'y = 1e-15, b'y =
    1e-15) cannot make it inaccurate; with an objective the same y is measured."""
    A = np.array([[1.0, 1.0], [-1.0, 0.0], [0.0, -1.0]])
    b, cones, z = np.array([1.0, 0.0, 0.0]), (("zero", 1), ("nonneg", 2)), np.array([[0.3, 0.7]])
    y = np.array([[1e-15, 0.0, 0.0]])
    found = measures(None, np.zeros((1, 2)), A[None], b[None], cones, z, y)
    assert found["dual"][0] == 0.0 and found["gap"][0] == 0.0
    found = measures(None, np.ones((1, 2)), A[None], b[None], cones, z, y)
    assert found["dual"][0] > 0.5  # q + A'y = 1 is no stationary point
