"""Solver optimality (qpbenchmark's measures): closed forms, agreement with qpsolvers'
and qpbenchmark's own scoring on the same solves, and the settings as qpbenchmark's."""

import math

import numpy as np
import pytest
from cardan_forces.driveline.dynamics import simulate
from cardan_forces.driveline.equilibrium import build_operator
from cardan_forces.driveline.loading import load_scene
from cardan_forces.experiments import qpbench_harness as harness
from cardan_forces.experiments.bench_metrics import shifted_geometric_mean
from cardan_forces.formulations import FORMULATIONS
from cardan_forces.formulations.problems import QP, ForceChecks
from cardan_forces.solvers import available, judge, registry, settings
from cardan_forces.solvers.conversions import qp_duals


def _checks(n):
    return ForceChecks(A=np.ones((1, n)), b=np.ones(1), names=tuple(f"x{i}" for i in range(n)),
                       unilateral=np.zeros(n, bool))


def _box_qp():
    """min 1/2 (x0^2 + x1^2) - 2 x1  s.t.  x0 + x1 = 3,  x0 >= 2,  x1 <= 5.

    Optimum x = (2, 1): stationarity x0 + y - s = 0, x1 - 2 + y = 0 with the lower
    bound of x0 active (qpsolvers' z_box = -s on it): y = 1, s = 3, z_box = (-3, 0).
    """
    return QP(checks=_checks(2), P=np.eye(2), q=np.array([0.0, -2.0]),
              A=np.array([[1.0, 1.0]]), b=np.array([3.0]),
              lb=np.array([2.0, -np.inf]), ub=np.array([np.inf, 5.0]))


def test_closed_form_optimum_has_zero_measures_and_a_shift_has_known_ones():
    qp = _box_qp()
    y, z_box = np.array([1.0]), np.array([-3.0, 0.0])
    exact = judge.qp_residuals(qp, True, np.array([2.0, 1.0]), y, None, z_box)
    assert exact == {"primal": 0.0, "dual": 0.0, "gap": 0.0}
    # x0 = 1.9 breaks the bound by 0.1 and the equality by 0.1; stationarity
    # (1.9 + 1 - 3, 1 - 2 + 1) = (-0.1, 0); gap x'Px + q'x + b'y + lb'z_box^-
    # = (3.61 + 1) - 2 + 3 + 2 * (-3) = -0.39
    off = judge.qp_residuals(qp, True, np.array([1.9, 1.0]), y, None, z_box)
    assert off["primal"] == pytest.approx(0.1)
    assert off["dual"] == pytest.approx(0.1)
    assert off["gap"] == pytest.approx(0.39)


def test_missing_multipliers_make_dual_and_gap_infinite():
    found = judge.qp_residuals(_box_qp(), True, np.array([2.0, 1.0]), None, None, np.zeros(2))
    assert found["primal"] == 0.0 and math.isinf(found["dual"]) and math.isinf(found["gap"])
    assert all(math.isinf(v) for v in judge.qp_residuals(_box_qp(), True, None, None, None,
                                                      None).values())
    not_found = judge.qp_residuals(_box_qp(), False, np.array([2.0, 1.0]), np.ones(1), None,
                                np.array([-3.0, 0.0]))
    assert all(math.isinf(v) for v in not_found.values())  # as qpsolvers' Solution


def test_conic_form_gives_qpbenchmarks_numbers_on_a_qp():
    """The QP's standard form with mapped multipliers measures what qpbenchmark does."""
    qp = _box_qp()
    x, y, z_box = np.array([1.9, 1.2]), np.array([0.7]), np.array([-2.5, 0.0])
    direct = judge.qp_residuals(qp, True, x, y, None, z_box)
    conic = judge.solver_optimality(qp, x, qp_duals(qp, y, None, z_box))
    assert conic == pytest.approx(direct, rel=1e-12, abs=1e-15)


def test_cone_violation_by_hand():
    cones = (("zero", 1), ("nonneg", 2), ("soc", 3), ("pow", 0.5))
    s = np.array([[0.2, 1.0, -0.3, 1.0, 0.6, 0.8, 4.0, 1.0, 2.5]])
    # zero row 0.2, nonneg -0.3 -> 0.3, soc ||(0.6, 0.8)|| - 1 = 0, pow |2.5| - 2 = 0.5
    assert judge.cone_violation(cones, s)[0] == pytest.approx(0.5)
    s[0, 8] = 1.0
    assert judge.cone_violation(cones, s)[0] == pytest.approx(0.3)


def test_success_rule_is_strict_and_needs_found():
    mid = settings.SETTINGS["mid_accuracy"]
    assert harness.succeeds(True, 9e-7, 0.0, 0.0, mid)
    assert not harness.succeeds(True, 1e-6, 0.0, 0.0, mid)
    assert not harness.succeeds(False, 0.0, 0.0, 0.0, mid)
    assert not harness.succeeds(True, 0.0, math.nan, 0.0, mid)
    assert harness.failed_rule(True, {"primal": 0.0, "dual": 1.0, "gap": 2.0}, mid) == "dual+gap"
    assert harness.failed_rule(False, {"primal": 0.0, "dual": 0.0, "gap": 0.0}, mid) == "not found"


def test_time_limit_rule_and_shifted_mean():
    times = harness.runtime_for_mean([True, False], [1e-3, 1e-4], settings.SETTINGS["default"])
    assert list(times) == [1e-3, settings.QPBENCHMARK_TIME_LIMIT_S]
    assert shifted_geometric_mean([0.0, 0.0]) == pytest.approx(0.0, abs=1e-12)
    assert shifted_geometric_mean([10.0, 30.0], shift=10.0) == pytest.approx(
        math.sqrt(20 * 40) - 10)


@pytest.fixture(scope="module")
def qpbenchmark():
    return pytest.importorskip("qpbenchmark")


def test_settings_are_qpbenchmarks(qpbenchmark):
    class Probe(qpbenchmark.TestSet):
        description, title, sparse_only = "", "", False

        def __iter__(self):
            return iter(())

    probe = Probe()
    assert set(probe.solver_settings) == set(settings.SETTINGS)
    for name, setting in settings.SETTINGS.items():
        tol = probe.tolerances[name]
        assert (tol.primal, tol.dual, tol.gap, tol.runtime) == (
            setting.tolerance, setting.tolerance, setting.tolerance, setting.time_limit_s)
        for profile in settings.PROFILES.values():
            assert profile.options(name) == dict(
                probe.solver_settings[name][profile.solver]), (name, profile.solver)
    for backend in available().values():  # each backend reads its own declaration
        if backend.qpbenchmark is not None:
            assert registry.qpbenchmark_options(backend.name, "high_accuracy") == (
                backend.qpbenchmark.options("high_accuracy"))


@pytest.fixture(scope="module")
def problems():
    op = build_operator(simulate(load_scene("paper"), [0.0, 0.5]))
    return {f"{name}_{i}": FORMULATIONS[name](op, i) for name in ("positive", "min_norm")
            for i in (0, 1)}


@pytest.mark.parametrize("solver", ["qpsolvers-clarabel", "qpsolvers-osqp",
                                    "qpsolvers-quadprog", "qpsolvers-highs"])
def test_verdicts_equal_qpbenchmarks_on_the_same_solves(qpbenchmark, problems, solver):
    """Each solve is scored by the package (``qp_residuals``, ``succeeds``) and by
    qpbenchmark's own ``Results`` from the very same qpsolvers ``Solution``: the three
    measures agree and so does the verdict at every setting."""
    import qpsolvers

    if solver not in available():
        pytest.skip(f"{solver} not installed")
    name = registry.profile(solver).solver

    class Empty(qpbenchmark.TestSet):
        description, title, sparse_only = "", "", False

        def __iter__(self):
            return iter(())

    results = qpbenchmark.Results(None, Empty())
    ours = {}
    for key, problem in problems.items():
        qp = harness.as_qp(problem)
        data = harness.qpsolvers_problem(qp, name)
        bench_problem = qpbenchmark.Problem.from_qpsolvers(data, key)
        for setting in settings.SETTINGS:
            sol = qpsolvers.solve_problem(data, solver=name,
                                          **registry.qpbenchmark_options(solver, setting))
            sol.problem = bench_problem
            results.update(bench_problem, name, setting, sol, 0.0)
            measured = judge.qp_residuals(qp, bool(sol.found), sol.x, sol.y, sol.z, sol.z_box)
            # equal up to the order of summation (qpsolvers' sparse products)
            assert measured["primal"] == pytest.approx(sol.primal_residual(), rel=1e-9,
                                                       abs=1e-12)
            assert measured["dual"] == pytest.approx(sol.dual_residual(), rel=1e-9, abs=1e-12)
            assert measured["gap"] == pytest.approx(sol.duality_gap(), rel=1e-6, abs=1e-9)
            ours[key, setting] = bool(harness.succeeds(bool(sol.found), *measured.values(),
                                                  settings.SETTINGS[setting]))
    tol = {k: s.tolerance for k, s in settings.SETTINGS.items()}
    theirs = results.build_success_rate_df(tol, tol, tol)
    for setting in settings.SETTINGS:
        rate = 100.0 * np.mean([ours[key, setting] for key in problems])
        assert rate == pytest.approx(theirs.at[name, setting]), setting


def test_conic_view_checks_the_dual_cone_and_a_qp_view_does_not():
    """min z0 s.t. (z0, z1, z2) in the second-order cone, z1 = 3, z2 = 4: z = (5, 3, 4).
    Stationarity q + A'y = 0 gives y = (y3, y4, 1, y3, y4) and complementarity with
    the cone's slack (5, 3, 4) gives (y3, y4) = (-3/5, -4/5). Doubling (y3, y4) keeps
    stationarity but leaves the dual cone by ||(1.2, 1.6)|| - 1 = 1: only the conic
    view's dual residual sees it."""
    A = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0],
                  [0.0, 0.0, -1.0]])
    b = np.array([[3.0, 4.0, 0.0, 0.0, 0.0]])
    cones = (("zero", 2), ("soc", 3))
    z, q = np.array([[5.0, 3.0, 4.0]]), np.array([[1.0, 0.0, 0.0]])
    y = np.array([[-0.6, -0.8, 1.0, -0.6, -0.8]])
    exact = judge.conic_residuals(None, q, A, b, cones, z, y, check_dual_cone=True)
    assert all(v[0] == pytest.approx(0.0, abs=1e-12) for v in exact.values())
    outside = np.array([[-1.2, -1.6, 1.0, -1.2, -1.6]])
    found = judge.conic_residuals(None, q, A, b, cones, z, outside, check_dual_cone=True)
    assert found["dual"][0] == pytest.approx(1.0)
    assert found["gap"][0] == pytest.approx(5.0)  # 5 + 3 (-1.2) + 4 (-1.6)
    plain = judge.conic_residuals(None, q, A, b, cones, z, outside, check_dual_cone=False)
    assert plain["dual"][0] == pytest.approx(0.0, abs=1e-12)
