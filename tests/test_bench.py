import argparse
import csv
import json
import math

import numpy as np
import pytest

from cardan_forces.driveline.dynamics import simulate
from cardan_forces.driveline.equilibrium import build_operator
from cardan_forces.experiments import batched, bench
from cardan_forces.formulations import FORMULATIONS
from cardan_forces.solvers import SolverNotFound, available, failed_record, solve
from cardan_forces.solvers.lcp_ import lemke


@pytest.fixture(scope="module")
def op(paper):
    return build_operator(simulate(paper, paper.time.instants()[:41]))


def _args(*argv):
    parser = argparse.ArgumentParser()
    bench.add_parser(parser.add_subparsers())
    return parser.parse_args(["bench", *argv])


def _read(path):
    with path.open() as handle:
        return list(csv.DictReader(handle))


def test_shifted_geometric_mean_by_hand():
    assert bench.shifted_geometric_mean([1.0, 3.0], shift=1.0) == pytest.approx(math.sqrt(8) - 1)
    assert bench.shifted_geometric_mean([1.0, 4.0], shift=0.0) == pytest.approx(2.0)
    assert bench.shifted_geometric_mean([2e-3, 2e-3]) == pytest.approx(2e-3)
    assert math.isnan(bench.shifted_geometric_mean([]))


def test_tolerance_ladder_only_where_a_solver_has_one():
    ladder = (1e-3, 1e-6)
    assert bench.tolerances("qpsolvers-osqp", ladder) == [1e-3, 1e-6]
    assert bench.tolerances("scipy-fsolve", ladder) == [1e-3, 1e-6]
    for solver in ("numpy-kkt", "lcp-lemke", bench.BATCHED):
        assert bench.tolerances(solver, ladder) == [None]


def test_quick_run_writes_csvs_report_and_json(tmp_path, monkeypatch, capsys):
    real = bench.solve

    def lemke_fails(problem, solver, **kwargs):
        if solver == "lcp-lemke":
            return failed_record(problem, solver, "injected failure")
        return real(problem, solver, **kwargs)

    monkeypatch.setattr(bench, "solve", lemke_fails)
    args = _args("--quick", "--json", "--out", str(tmp_path))
    assert args.func(args) == 0
    out = json.loads(capsys.readouterr().out)
    assert set(out) == {"throughput", "pareto"}
    assert {"formulation", "solver", "mode", "instants_per_s", "setup_s", "success_rate",
            "max_equilibrium"} <= set(out["throughput"][0])
    assert {"formulation", "solver", "tol", "time_s", "error", "equilibrium"} <= set(
        out["pareto"][0])
    modes = {(e["formulation"], e["mode"]) for e in out["throughput"]}
    assert {("paper", "cold"), ("paper", "warm"), ("min_norm", "batched"),
            ("positive", "batched")} <= modes

    rows = _read(tmp_path / "bench_throughput.csv")
    assert tuple(rows[0]) == bench.THROUGHPUT_COLUMNS
    failed = [r for r in rows if r["solver"] == "lcp-lemke"]
    assert len(failed) == bench.QUICK_INSTANTS  # every failed run is a row
    assert all(r["status"] == "failed" and float(r["equilibrium"]) == math.inf for r in failed)
    lemke_entry = next(e for e in out["throughput"] if e["solver"] == "lcp-lemke")
    assert lemke_entry["success_rate"] == 0.0 and lemke_entry["max_equilibrium"] == "inf"
    for key in {(r["formulation"], r["solver"], r["mode"]) for r in rows}:
        assert sum((r["formulation"], r["solver"], r["mode"]) == key for r in rows) == 41

    accuracy = _read(tmp_path / "bench_accuracy.csv")
    assert tuple(accuracy[0]) == bench.ACCURACY_COLUMNS
    assert {r["tol"] for r in accuracy} >= {"0.0001", "1e-08", "default"}
    assert all(float(r["error"]) == math.inf for r in accuracy if r["solver"] == "lcp-lemke")
    assert (tmp_path / "bench_pareto.png").stat().st_size > 10_000
    report = (tmp_path / "report.md").read_text()
    for heading in ("## Throughput", "## Targets", "## Success rate per accuracy level",
                    "## Pareto front", "## Known limitations"):
        assert heading in report
    assert "numpy" in report and "scipy" in report and "machine:" in report


def test_unknown_solver_is_an_error_before_any_work(tmp_path):
    with pytest.raises(SolverNotFound):
        bench.run(_args("--solver", "no-such-solver", "--out", str(tmp_path)))
    assert not (tmp_path / "report.md").exists()


def _quadprog():
    if "qpsolvers-quadprog" not in available():
        pytest.skip("quadprog not installed")
    return "qpsolvers-quadprog"


@pytest.mark.parametrize("formulation, reference, solver", [
    ("min_norm", "min_norm", "numpy-kkt"),
    ("min_norm_scaled", "min_norm_scaled", "numpy-kkt"),
    ("positive", "lcp", "lcp-lemke"),
    ("lcp", "lcp", "lcp-lemke"),
    ("positive", "positive", None),
    ("compliance", "compliance", None),
])
def test_batched_equals_per_instant_answers(op, formulation, reference, solver):
    solver = solver or _quadprog()
    batch = batched.solve_batched(op, formulation)
    for i in range(0, 41, 5):
        expected = solve(FORMULATIONS[reference](op, i), solver)
        assert expected.status == "solved"
        x = batch.x[i]
        assert np.linalg.norm(x - expected.x) <= 1e-8 * np.linalg.norm(expected.x)
        checked = FORMULATIONS[formulation](op, i).checks.residuals(x)
        assert max(checked.values()) <= 1e-9
        for key, value in checked.items():
            assert batch.residuals[key][i] == pytest.approx(value, rel=1e-9, abs=1e-16)
    assert not batch.fallback.any()


def test_batched_subset_of_instants_matches_the_full_run(op):
    full = batched.solve_batched(op, "positive")
    some = batched.solve_batched(op, "positive", [3, 17, 40])
    assert np.allclose(some.x, full.x[[3, 17, 40]], rtol=1e-12, atol=1e-9)
    assert list(some.instants) == [3, 17, 40]


def test_active_set_solves_random_lcps_and_falls_back_to_lemke():
    rng = np.random.default_rng(7)
    T, k = 300, 8
    N = rng.standard_normal((T, k, 7))
    M = N @ N.transpose(0, 2, 1)  # positive semidefinite and singular, like positive's LCP
    # q = s - N z with s >= 0: the QP behind the LCP is feasible, so it has a solution
    q = rng.uniform(0, 5, (T, k)) - (N @ (10 * rng.standard_normal((T, 7, 1))))[:, :, 0]
    for max_iter in (30, 1):
        lam, iterations, fallback = batched._active_set(M, q, max_iter)
        assert iterations.max() <= max_iter
        w = np.einsum("tij,tj->ti", M, lam) + q
        assert lam.min() >= -1e-9 and w.min() >= -1e-9
        assert np.abs(lam * w).max() <= 1e-8
        for i in range(0, T, 30):  # y = N' lam is unique even where lam is not
            exact = lemke(M[i], q[i]).z
            assert np.allclose(N[i].T @ lam[i], N[i].T @ exact, atol=1e-8)
    assert fallback.any()  # one step is too few for some instants: Lemke solved them


def test_chain_orders_the_bodies_and_rejects_other_graphs(op):
    blocks = batched.chain(op.A[0])
    bodies = [op.rows[b.start].split(".force")[0] for b in blocks]
    assert bodies in (["input", "uj1.pin", "intermediate", "uj2.pin", "output"],
                      ["output", "uj2.pin", "intermediate", "uj1.pin", "input"])
    star = np.zeros((24, 3))
    for column, body in enumerate((1, 2, 3)):  # body 0 linked to three others
        star[0, column] = star[6 * body, column] = 1.0
    with pytest.raises(ValueError, match="chain"):
        batched.chain(star)


def test_chain_solve_equals_a_dense_solve():
    rng = np.random.default_rng(3)
    blocks = [slice(6 * k, 6 * k + 6) for k in (2, 0, 1)]
    A = np.zeros((4, 18, 12))
    for c, (a, b) in enumerate([(2, 0)] * 6 + [(0, 1)] * 6):
        A[:, 6 * a: 6 * a + 6, c] = rng.standard_normal((4, 6))
        A[:, 6 * b: 6 * b + 6, c] = rng.standard_normal((4, 6))
    K = A @ A.transpose(0, 2, 1) + np.eye(18)
    R = rng.standard_normal((4, 18, 3))
    assert np.allclose(batched.chain_solve(K, R, blocks), np.linalg.solve(K, R), atol=1e-12)


def test_pareto_front_keeps_the_points_nothing_beats():
    rows = [{"formulation": "f", "solver": s, "tol": tol, "time_s": t, "error": e,
             "equilibrium": 0.0}
            for s, tol, t, e in (("a", 1e-2, 1.0, 1e-3), ("b", 1e-8, 2.0, 1e-6),
                                 ("c", 1e-4, 3.0, 1e-4), ("d", "default", 0.5, math.inf))]
    front = {p["solver"] for p in bench.pareto(rows) if p["front"]}
    assert front == {"a", "b"}
