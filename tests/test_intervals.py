"""Solution-set intervals by the warm-started ranging: constructed LPs whose ranges are
known, and agreement with the cold per-bound LPs on the built-in lines."""

import numpy as np
import pytest
from cardan_forces.driveline.determinacy import determinacy
from cardan_forces.driveline.dynamics import simulate
from cardan_forces.driveline.equilibrium import build_operator
from cardan_forces.driveline.loading import load_scene
from cardan_forces.experiments import study
from cardan_forces.formulations.problems import LP, ForceChecks
from cardan_forces.formulations.sets import interval_slack
from cardan_forces.solvers import Status

pytest.importorskip("highspy")
from cardan_forces.solvers.ranging import ranges  # noqa: E402


def _lp(A, b, lb, G=None, h=None) -> LP:
    A, b = np.asarray(A, float), np.asarray(b, float)
    n = A.shape[1]
    checks = ForceChecks(A=A, b=b, names=tuple(f"x{k}" for k in range(n)),
                         unilateral=np.zeros(n, bool))
    return LP(checks=checks, formulation="test", c=np.zeros(n), A=A, b=b,
              lb=np.asarray(lb, float), G=G, h=h)


def test_ranges_of_a_simplex():
    """On ``x >= 0, sum x = 1`` each coordinate spans [0, 1] and ``x0 - x1`` spans
    [-1, 1]; a row ``x0 - x1 <= 0.5`` cuts that to [-1, 0.5] and ``x0`` to [0, 0.75]."""
    lp = _lp([[1, 1, 1]], [1], [0, 0, 0])
    rows = np.array([[1, 0, 0], [0, 0, 1], [1, -1, 0]], float)
    found = ranges(lp, rows)
    assert found.feasible is Status.SOLVED
    assert np.allclose(found.low, [0, 0, -1], atol=1e-12)
    assert np.allclose(found.high, [1, 1, 1], atol=1e-12)
    cut = _lp([[1, 1, 1]], [1], [0, 0, 0], G=np.array([[1.0, -1.0, 0.0]]), h=np.array([0.5]))
    found = ranges(cut, rows)
    assert np.allclose(found.low, [0, 0, -1], atol=1e-12)
    assert np.allclose(found.high, [0.75, 1, 0.5], atol=1e-12)


def test_unbounded_sides_and_an_empty_set():
    """``x0 = x1 >= 0``: x0 is at least 0 with no top; a free x2 has neither end; with
    ``x0 + x1 = -1`` the set is empty and every row says so."""
    lp = _lp([[1, -1, 0]], [0], [0, 0, -np.inf])
    found = ranges(lp, np.eye(3)[[0, 2]])
    assert found.low[0] == pytest.approx(0.0, abs=1e-12) and np.isnan(found.high[0])
    assert found.statuses[0] == (Status.SOLVED, Status.UNBOUNDED)
    assert found.statuses[1] == (Status.UNBOUNDED, Status.UNBOUNDED)
    assert np.isnan(found.low[1]) and np.isnan(found.high[1])
    empty = ranges(_lp([[1, 1, 0]], [-1], [0, 0, 0]), np.eye(3))
    assert empty.feasible is Status.INFEASIBLE
    assert all(s == (Status.INFEASIBLE,) * 2 for s in empty.statuses)


def test_a_range_does_not_depend_on_the_objectives_before_it():
    """The warm model carries a basis from one objective to the next: the values must
    be the same in any order."""
    rng = np.random.default_rng(3)
    A = rng.normal(size=(3, 8))
    lp = _lp(A, A @ rng.uniform(1, 2, 8), np.zeros(8))
    rows = rng.normal(size=(6, 8))
    ahead, behind = ranges(lp, rows), ranges(lp, rows[::-1])
    assert np.allclose(ahead.low, behind.low[::-1], rtol=1e-9, atol=1e-9, equal_nan=True)
    assert np.allclose(ahead.high, behind.high[::-1], rtol=1e-9, atol=1e-9, equal_nan=True)


def test_ends_proved_by_a_point_or_a_ray_need_no_lp():
    """``x0 = x1 >= 0`` (a pair: one ray opens both tops) and ``x2 + x3 = 1``,
    ``x2, x3 >= 0``: every end is known, the same whatever proves it, and the pair's
    second top (or any end a point at its bound already shows) takes no LP of its own;
    a ray that breaks a constraint proves nothing."""
    from cardan_forces.solvers.ranging import _is_ray, _Proofs

    lp = _lp([[1, -1, 0, 0], [0, 0, 1, 1]], [0, 1], np.zeros(4))
    found = ranges(lp, np.eye(4))
    assert np.allclose(found.low, [0, 0, 0, 0], atol=1e-12)
    assert np.isnan(found.high[:2]).all() and np.allclose(found.high[2:], [1, 1], atol=1e-12)
    assert found.statuses[:2] == ((Status.SOLVED, Status.UNBOUNDED),) * 2
    assert found.lps < 1 + 2 * 4
    proofs = _Proofs(lp, np.array([0.0, 0.0, 1.0, 0.0]))
    assert proofs.settle(np.eye(4)[0]) == (Status.SOLVED, 0.0)  # x0 at its bound
    assert proofs.settle(np.eye(4)[2])[0] is None  # x2 = 1 is not its least
    assert proofs.settle(-np.eye(4)[1])[0] is None  # no ray yet
    proofs.add(Status.UNBOUNDED, np.array([2.0, 2.0, 0.0, 0.0]))
    assert proofs.settle(-np.eye(4)[1])[0] is Status.UNBOUNDED
    assert proofs.settle(-np.eye(4)[3])[0] is None
    assert not _is_ray(lp, np.array([1.0, 0.9, 0, 0]))
    assert not _is_ray(lp, np.array([-1.0, -1.0, 0, 0]))


def test_a_start_from_another_set_changes_no_answer():
    """The rays and basis of the LP before (``start``) prove ends only where they hold
    for this LP's set: ``x0 = x1`` hands on its ray ``(1, 1)``, which is not a ray of
    ``x0 = 2 x1`` (there x0 still has no top, by that set's own ray), and is one of
    ``x0 = x1 + 1``, where it proves the tops without an LP of their own."""
    rows = np.eye(2)
    before = ranges(_lp([[1, -1]], [0], [0, 0]), rows)
    assert before.rays.shape == (1, 2)
    for A, b, low in (([[1, -2]], [0], [0, 0]), ([[1, -1]], [1], [1, 0])):
        lp = _lp(A, b, [0, 0])
        warm, cold = ranges(lp, rows, start=before), ranges(lp, rows)
        assert np.allclose(warm.low, low, atol=1e-12) and np.allclose(cold.low, low, atol=1e-12)
        assert np.isnan(warm.high).all() and np.isnan(cold.high).all()
        assert warm.statuses == cold.statuses
    assert warm.lps < cold.lps  # x0 = x1 + 1: both tops proved by the ray handed on


@pytest.mark.parametrize("name, times", [("paper", (0.13, 0.5)), ("paper-slip", (0.2, 0.7)),
                                         ("propshaft", (0.05, 0.6))])
def test_warm_intervals_agree_with_cold_lps(name, times):
    """Every component's interval from the warm ranging equals the two cold LPs'
    (registry, one LP per bound): the same unbounded sides, the same statuses, finite
    ends within the problem-scaled tolerance."""
    scene = load_scene(name)
    op = build_operator(simulate(scene, [scene.time.start_s + t * (scene.time.stop_s
                                                                   - scene.time.start_s)
                                         for t in times]))
    for i in range(len(times)):
        warm, det = study.intervals(op, i), determinacy(op, i)
        assert not det.determinate.all()
        for j in np.flatnonzero(~det.determinate):
            c = np.eye(len(op.names))[j]
            cold, got = study.cold_range(op, i, c), warm[op.names[j]]
            assert got["status"] == cold["status"] == "solved", (name, op.names[j])
            for side in ("min", "max"):
                assert (got[side] is None) == (cold[side] is None), (name, op.names[j], side)
                if cold[side] is not None:
                    assert got[side] == pytest.approx(cold[side],
                                                      abs=interval_slack(op, i, c))


@pytest.mark.parametrize("name", ["paper", "propshaft"])
def test_a_history_is_the_intervals_of_its_instants(name):
    """:func:`interval_history` holds, instant by instant, what :func:`intervals` says
    alone (NaN where a side is unbounded; finite ends within the problem-scaled
    tolerance): starting each instant from the basis of the one before, in either
    order, changes no answer."""
    scene = load_scene(name)
    op = build_operator(simulate(scene, np.linspace(scene.time.start_s, scene.time.stop_s, 5)))
    ahead, behind = study.interval_history(op), study.interval_history(op, [4, 3, 2, 1, 0])
    eye = np.eye(len(op.names))
    for k in range(5):
        for j, entry in enumerate(study.intervals(op, k).values()):
            for side in ("min", "max"):
                for got in (getattr(ahead, side)[k, j], getattr(behind, side)[4 - k, j]):
                    if entry[side] is None:
                        assert np.isnan(got)
                    else:
                        assert got == pytest.approx(entry[side],
                                                    abs=interval_slack(op, k, eye[j]))


def test_the_range_of_a_combination_agrees_with_cold_lps():
    """:func:`value_range` of a linear form over several components (as the figures'
    summed axial loads are) equals the cold LPs' range."""
    op = build_operator(simulate(load_scene("paper"), [0.3]))
    det = determinacy(op, 0)
    free = np.flatnonzero(~det.determinate)
    rng = np.random.default_rng(7)
    for _ in range(3):
        c = np.zeros(len(op.names))
        c[rng.choice(free, 3, replace=False)] = rng.normal(size=3)
        got, cold = study.value_range(op, 0, c), study.cold_range(op, 0, c)
        assert got["status"] == cold["status"]
        for side in ("min", "max"):
            assert (got[side] is None) == (cold[side] is None)
            if cold[side] is not None:
                assert got[side] == pytest.approx(cold[side], abs=interval_slack(op, 0, c))
