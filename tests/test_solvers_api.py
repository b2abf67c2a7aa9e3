"""The registry, the solution record and the settings: failures are data, not crashes."""

from __future__ import annotations

import dataclasses
import json
import math
from types import SimpleNamespace

import numpy as np
import pytest
from cardan_forces.formulations.problems import NLS, QP
from cardan_forces.solvers import (
    Backend,
    Residuals,
    SolverNotFound,
    Status,
    UnsupportedProblem,
    available,
    backends_for,
    failed_record,
    get,
    known_backends,
    registry,
    settings,
    solve,
)
from cardan_forces.solvers.lcp_methods import fb_newton
from cardan_forces.solvers.record import Outcome
from cardan_forces.solvers.reference_problems import references

REFS = {ref.name: ref for ref in references()}
JSON_KEYS = {"formulation", "solver", "status", "residuals", "forces", "setup_s", "solve_s",
             "iterations", "message", "optimality", "duals", "gap_kind", "solver_status",
             "solver_optimality", "checks_s", "wall_s"}


def _nan_ls():
    """ls_min_norm with a NaN in b, slipped past validation of the frozen dataclass."""
    ls = references()[0].problem
    object.__setattr__(ls, "b", np.array([np.nan, 2.0]))
    return ls


@pytest.fixture
def fake_backend(monkeypatch):
    """Register a backend ``fake`` for LS whose outcome the test chooses."""

    def register(solve_fn):
        available()  # load the real ones first
        backend = Backend(name="fake", family="test", distributions=("numpy",),
                          accepts=(REFS["ls_min_norm"].problem.__class__,), solve=solve_fn)
        monkeypatch.setitem(registry._CACHE, "fake", backend)

    return register


def test_core_backends_registered():
    names = available()
    for name in ("numpy-kkt", "scipy-lsq_linear", "scipy-highs", "scipy-fsolve",
                 "scipy-root-lm", "clarabel", "lcp-lemke", "lcp-pgs", "lcp-fb-newton"):
        assert name in names
    assert all(b.version and b.family for b in names.values())


def test_unknown_solver_raises():
    with pytest.raises(SolverNotFound, match="unknown backend"):
        solve(REFS["ls_min_norm"].problem, "no-such-solver")


def test_missing_package_gives_install_hint(monkeypatch):
    available()
    monkeypatch.delitem(registry._CACHE, "qpsolvers-daqp", raising=False)
    with pytest.raises(SolverNotFound, match=r'pip install "cardan-forces\[daqp\]"'):
        get("qpsolvers-daqp")
    assert known_backends()["qpsolvers-daqp"] == "daqp"
    assert set(available()) <= set(known_backends())


def test_unsupported_problem_raises():
    with pytest.raises(UnsupportedProblem):
        solve(REFS["lcp_mixed"].problem, "numpy-kkt")
    assert "numpy-kkt" not in backends_for(REFS["qp_active_inequality"].problem)
    with pytest.raises(UnsupportedProblem):  # lsq_linear takes no general inequalities
        solve(REFS["qp_active_inequality"].problem, "scipy-lsq_linear")


def test_power_cone_only_where_supported():
    names = backends_for(REFS["conic_pow"].problem)
    assert "clarabel" in names and "cvxpy-ecos" not in names


def test_conversion_chain_reaches_conic_backends():
    names = backends_for(REFS["ls_min_norm"].problem)
    assert {"numpy-kkt", "clarabel", "qpsolvers-osqp", "cvxpy-clarabel"} <= set(names)
    assert "clarabel" in backends_for(REFS["lp_vertex"].problem)


@pytest.mark.parametrize("name", ["scipy-fsolve", "scipy-root-lm"])
def test_nan_nls_is_failed(name):
    ref = REFS["nls_polynomial"].problem
    nan = NLS(checks=ref.checks, formulation="nan", fun=lambda z: np.full(2, np.nan),
              jac=lambda z: np.full((2, 2), np.nan), z0=np.ones(2))
    record = solve(nan, name)
    assert record.status == "failed"
    assert np.all(np.isnan(record.x))
    assert all(v == np.inf for v in record.residuals.values())


@pytest.mark.parametrize("name", backends_for(_nan_ls()))
def test_nan_problem_is_failed(name):
    record = solve(_nan_ls(), name)
    assert record.status == "failed" and record.message


def test_failed_conversion_is_a_record():
    record = solve(_nan_ls(), "clarabel")
    assert record.status == "failed" and "conversion failed" in record.message


def test_psd_only_quadprog_fails_as_data():
    if "qpsolvers-quadprog" not in available():
        pytest.skip("quadprog not installed")
    qp = REFS["qp_active_bound"].problem
    psd = QP(checks=qp.checks, P=np.diag([1.0, 1.0, 0.0]), q=qp.q, A=qp.A, b=qp.b, lb=qp.lb)
    record = solve(psd, "qpsolvers-quadprog")
    assert record.status == "failed" and record.message  # the reason, in quadprog's words
    assert np.all(np.isnan(record.x))


def test_backend_exception_is_failed_record(fake_backend):
    def boom(problem, tol=None, initvals=None):
        raise RuntimeError("boom")

    fake_backend(boom)
    record = solve(REFS["ls_min_norm"].problem, "fake")
    assert record.status == "failed" and "RuntimeError: boom" in record.message


def test_reported_success_with_nan_is_failed(fake_backend):
    fake_backend(lambda problem, tol=None, initvals=None: Outcome("solved", np.full(3, np.nan)))
    record = solve(REFS["ls_min_norm"].problem, "fake")
    assert record.status == "failed" and "NaN" in record.message
    assert np.all(np.isnan(record.x))


def test_reported_success_with_large_residual_is_inaccurate(fake_backend):
    fake_backend(lambda problem, tol=None, initvals=None: Outcome("solved", np.zeros(3)))
    record = solve(REFS["ls_min_norm"].problem, "fake", reference=np.array([0.0, 1, 1]))
    assert record.status == "inaccurate" and "equilibrium" in record.message
    assert record.residuals["equilibrium"] == pytest.approx(1.0)
    assert record.residuals["reference"] == pytest.approx(1.0)


def test_record_json_is_strict_json():
    ok = solve(REFS["ls_min_norm"].problem, "numpy-kkt", reference=REFS["ls_min_norm"].x)
    bad = failed_record(REFS["ls_min_norm"].problem, "numpy-kkt", "why")
    for record in (ok, bad):
        data = json.loads(json.dumps(record.to_json(), allow_nan=False))
        assert set(data) == JSON_KEYS
    assert ok.forces() == pytest.approx({"x0": 0.0, "x1": 1.0, "x2": 1.0}, abs=1e-12)
    assert bad.to_json()["residuals"]["equilibrium"] == "inf"
    assert bad.to_json()["forces"]["x0"] == "nan"
    assert "reference" not in bad.residuals


def test_initvals_reach_warm_startable_solvers():
    ref = REFS["nls_polynomial"]
    record = solve(ref.problem, "scipy-fsolve", initvals=np.array([2.2, 0.7]))
    assert record.forces() == pytest.approx({"x0": 2.0, "x1": 1.0})


def test_tol_none_changes_nothing():
    assert all(b.options(None) == {} for b in available().values())
    assert settings.options_for(("eps_abs", "eps_rel"), 1e-7) == {"eps_abs": 1e-7,
                                                                  "eps_rel": 1e-7}
    assert available()["scipy-highs"].options(1e-13)["primal_feasibility_tolerance"] == 1e-10
    assert available()["numpy-kkt"].options(1e-6) == {}  # a direct method has none


def test_tol_reaches_the_solver(monkeypatch):
    """The adapters hand a requested tolerance to the solver's own parameters, and
    none without one (spies on the calls; no iteration counts or last digits)."""
    from cardan_forces.solvers import lcp_

    seen = []

    def spy(M, q, **kwargs):
        seen.append(kwargs)
        return lcp_.fb_newton(M, q, **kwargs)

    adapter = lcp_._adapter(spy, "fb-newton", True)
    for tol in (1e-2, None):
        outcome = adapter(REFS["lcp_mixed"].problem, tol=tol)
        assert outcome.status == "solved"
    assert seen == [{"tol": 1e-2}, {}]
    qpsolvers = pytest.importorskip("qpsolvers")
    if "qpsolvers-osqp" not in available():
        return
    calls, real = [], qpsolvers.solve_problem

    def spy_qp(problem, solver, **kwargs):
        calls.append(kwargs)
        return real(problem, solver, **kwargs)

    monkeypatch.setattr(qpsolvers, "solve_problem", spy_qp)
    qp = REFS["ls_min_norm"].problem.as_qp()
    for tol in (1e-10, None):
        assert solve(qp, "qpsolvers-osqp", tol=tol).status.has_answer
    assert calls[0]["eps_abs"] == calls[0]["eps_rel"] == 1e-10
    assert "eps_abs" not in calls[1] and "eps_rel" not in calls[1]


def test_options_override_tol():
    lcp = REFS["lcp_mixed"].problem
    record = solve(lcp, "lcp-fb-newton", tol=1e-14, max_iter=1)
    # the cap reached the method, not only tol: the answer is one capped call's
    capped = fb_newton(np.asarray(lcp.M, float), np.asarray(lcp.q, float), tol=1e-14,
                       max_iter=1)
    np.testing.assert_array_equal(record.z, capped.z)
    # whatever one step reached, the record is judged by the package's own residuals
    assert record.status.has_answer and math.isfinite(record.residuals["complementarity"])


@pytest.mark.parametrize(("solver", "extras", "expected"), [
    ("osqp", {"info": SimpleNamespace(status="primal infeasible inaccurate")}, "infeasible"),
    ("osqp", {"info": SimpleNamespace(status="dual infeasible")}, "unbounded"),
    ("osqp", {"info": SimpleNamespace(status="maximum iterations reached")}, "inaccurate"),
    ("piqp", {"info": SimpleNamespace(status="Status.PIQP_DUAL_INFEASIBLE")}, "unbounded"),
    ("clarabel", {"status": "almost optimal"}, "inaccurate"),  # the rule's "almost" words
    ("clarabel", {"status": "NumericalError"}, "failed"),
    ("scs", {"status_val": -2}, "infeasible"),
    ("ecos", {"exitFlag": 10}, "inaccurate"),
    ("daqp", {}, "failed"),
])
def test_qpsolvers_status_map(solver, extras, expected):
    from cardan_forces.solvers.qpsolvers_ import _unfound_status

    assert _unfound_status(solver, extras)[0] == expected


def test_a_solver_past_its_time_limit_is_a_failed_record(monkeypatch):
    """HiGHS's QP iterations are not bounded in time: the adapter passes the package's
    limit, and a solve that reaches it is a record, never a hang."""
    pytest.importorskip("highspy")
    from cardan_forces.solvers import settings

    monkeypatch.setattr(settings, "TIME_LIMIT_S", 0.0)
    problem = next(r.problem for r in REFS.values() if isinstance(r.problem, QP))
    record = solve(problem, "qpsolvers-highs")
    assert record.status in ("failed", "inaccurate")
    assert "time limit" in record.message


def test_status_is_ordered_and_reads_as_its_string():
    """Worst of several is ``max``; a status compares, hashes, prints and goes to JSON
    and CSV as the plain string that callers and files already hold."""
    import csv
    import io

    assert max(Status.SOLVED, Status.FAILED, Status.INACCURATE) is Status.FAILED
    assert sorted(["failed", Status.INACCURATE, Status.SOLVED], key=Status) == [
        "solved", "inaccurate", "failed"]
    assert [s.has_answer for s in Status] == [True, True, False, False, False]
    assert Status.SOLVED == "solved" and "solved" in {Status.SOLVED}
    assert f"{Status.INFEASIBLE:>11}" == " infeasible" and str(Status.FAILED) == "failed"
    assert json.dumps({"status": Status.UNBOUNDED}) == '{"status": "unbounded"}'
    buffer = io.StringIO()
    csv.writer(buffer).writerow([Status.SOLVED])
    assert buffer.getvalue().strip() == "solved"


def test_typed_measures_read_like_the_dicts_they_replace():
    record = solve(REFS["ls_min_norm"].problem, "numpy-kkt", reference=REFS["ls_min_norm"].x)
    checked = tuple(f.name for f in dataclasses.fields(Residuals) if f.name != "reference")
    assert checked == Residuals.KEYS  # one field per residual the checks compute
    assert tuple(record.residuals) == (*Residuals.KEYS, "reference")
    assert record.residuals.get("cone") == record.residuals["cone"] == record.residuals.cone
    assert "distance" in record.optimality and record.optimality.get("nothing") is None
    bad = failed_record(REFS["ls_min_norm"].problem, "numpy-kkt", "why")
    assert "reference" not in bad.residuals and len(bad.residuals) == 4
    with pytest.raises(KeyError):
        bad.residuals["reference"]
    # a record rebuilt with plain values gets the types back
    rebuilt = dataclasses.replace(record, status="failed",
                                  residuals=dict.fromkeys(record.residuals, math.inf))
    assert rebuilt.status is Status.FAILED and rebuilt.residuals.worst()[1] == math.inf


def test_lsq_linear_multipliers_are_its_penalty_problems():
    """``scipy-lsq_linear`` solves a quadratic penalty of the QP; its multipliers
    ``y = (A z - b) / mu`` and the gradient on the active bounds are that problem's own.
    On ``min 1/2 |x|^2 - x_3, x_1 + x_2 = 1, 0 <= x, x_3 <= 1/2`` (optimum ``(1/2, 1/2,
    1/2)``, equality multiplier ``-1/2`` in the sign of ``P z + q + A'y = 0``, upper
    bound multiplier ``1/2``) they agree with the exact ones to the penalty's bias,
    and with them stationarity holds to the rounding of ``A z - b`` over ``mu``
    (``eps / mu``: 1e-10 at tolerance 1e-6, where ``mu`` is about 1e-6).
    """
    qp = QP(checks=REFS["qp_active_inequality"].problem.checks, formulation="test",
            P=np.eye(3), q=np.array([0.0, 0.0, -1.0]), A=np.array([[1.0, 1.0, 0.0]]),
            b=np.array([1.0]), lb=np.zeros(3), ub=np.array([np.inf, np.inf, 0.5]))
    record = solve(qp, "scipy-lsq_linear", tol=1e-6)
    assert record.duals == "solver"
    z, y = record.z, record.y  # rows: A, then -x >= 0 (3), then x_3 <= 1/2
    assert np.allclose(z, [0.5, 0.5, 0.5], atol=1e-4)
    assert abs(y[0] + 0.5) < 1e-4 and abs(y[-1] - 0.5) < 1e-4
    assert np.allclose(y[1:4], 0.0, atol=1e-4)
    conic = qp.as_conic()
    stationarity = conic.P @ z + conic.q + conic.A.T @ y
    assert np.abs(stationarity).max() < 1e-8


def test_a_non_finite_answer_fails_but_keeps_the_solvers_word():
    """An adapter that says ``solved`` and returns NaN forces gives a ``failed`` record
    whose ``solver_status`` is still what the adapter said (the status before the
    package judged it), with the reason in the message.
    """
    from cardan_forces.solvers.judge import finalize

    problem = REFS["ls_min_norm"].problem
    z = np.full(len(problem.checks.names), np.nan)
    record = finalize(problem, "stub", Outcome("solved", z))
    assert record.status == "failed" and record.solver_status == "solved"
    assert "NaN" in record.message


def test_clarabel_reads_the_packages_csc_as_scipys():
    """Clarabel takes a CSC matrix by its attributes: the package's light one (rows
    sorted, explicit zeros dropped) must hand it the very arrays scipy's would, and
    give the same answer to the bit."""
    clarabel = pytest.importorskip("clarabel")
    sparse = pytest.importorskip("scipy.sparse")
    from cardan_forces.solvers import clarabel_

    rng = np.random.default_rng(3)
    dense = rng.normal(size=(7, 5)) * (rng.random((7, 5)) < 0.4)
    light, reference = clarabel_._csc(dense), sparse.csc_matrix(dense)
    for name in ("data", "indices", "indptr"):
        assert np.array_equal(getattr(light, name), getattr(reference, name))
    assert light.nnz == reference.nnz and light.shape == reference.shape
    # min 1/2 |z|^2 + q'z s.t. dense z <= 1 (a nonnegative cone), both ways
    q = rng.normal(size=5)
    settings = clarabel.DefaultSettings()
    settings.verbose = False
    cones = [clarabel.NonnegativeConeT(7)]
    ours = clarabel_._solver(clarabel, clarabel_._csc(np.eye(5)), q, light, np.ones(7),
                             cones, settings).solve()
    theirs = clarabel.DefaultSolver(sparse.csc_matrix(np.eye(5)), q, reference, np.ones(7),
                                    cones, settings).solve()
    assert str(ours.status) == "Solved"
    assert np.array_equal(np.asarray(ours.x), np.asarray(theirs.x))


def test_no_adapter_imports_another():
    """Each adapter stands alone (what two share lives in a module of its own), and the
    reduced form's wrapper imports none: a backend added or removed touches its adapter
    and the registry's list, nothing else."""
    import ast
    import inspect

    from cardan_forces.solvers import reduced_

    adapters = set(registry.ADAPTERS)
    for module in [*(registry._adapter(name) for name in adapters), reduced_]:
        tree = ast.parse(inspect.getsource(module))
        named = {node.module for node in ast.walk(tree) if isinstance(node, ast.ImportFrom)}
        named |= {alias.name for node in ast.walk(tree) if isinstance(node, ast.ImportFrom)
                  and node.module is None for alias in node.names}
        own = module.__name__.rsplit(".", 1)[1]
        assert not (named - {own}) & adapters, module.__name__
