"""The reduced form (equality rows eliminated) and the QOCO backend.

The reduction is checked on a problem whose answer and multipliers are known by hand,
and on the package's conic formulations, where every reduced backend must give the
full form's optimal objective and pass the package's optimality measures on the full
problem (residuals, dual residual and gap with the lifted multipliers).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from cardan_forces.driveline.dynamics import simulate
from cardan_forces.driveline.equilibrium import build_operator
from cardan_forces.driveline.loading import load_scene
from cardan_forces.formulations import batch as fbatch
from cardan_forces.formulations.problems import Conic, ForceChecks
from cardan_forces.solvers import ACCEPT, available, solve
from cardan_forces.solvers.conversions import eliminate_equalities
from cardan_forces.solvers.judge import measures, objective_value
from cardan_forces.solvers.registry import solve_batch

FORMULATIONS = ("socp_face", "min_max", "compliance_hertz", "positive")
INSTANTS = (0, 7, 15)
TOL = 1e-8
AGREE = 100 * TOL
"""Relative objective difference allowed between two interior-point answers at TOL."""


def reduced_conic(conic: Conic):
    """One :class:`Conic` in its reduced form (a problem in ``y``, the original's checks)
    and the :class:`~cardan_forces.solvers.conversions.Reduced` that lifts answers.
    """
    red = eliminate_equalities(conic.P, conic.q[None], np.asarray(conic.A, float)[None],
                               np.asarray(conic.b, float)[None], conic.cones,
                               None if conic.null_space is None else conic.null_space[None])
    problem = Conic(checks=conic.checks, formulation=conic.formulation, P=red.P[0],
                    q=red.q[0], A=red.A[0], b=red.b[0], cones=red.cones)
    return problem, red


def _need(name: str) -> None:
    if name not in available():
        pytest.skip(f"{name} not installed")


def _simplex(rows: np.ndarray, rhs: np.ndarray) -> Conic:
    """min 1/2 ||z||^2 on ``rows z = rhs``, z >= 0 (three unknowns)."""
    checks = ForceChecks(A=rows, b=rhs, names=("a", "b", "c"), unilateral=np.ones(3, bool))
    return Conic(checks=checks, formulation="ref", P=np.eye(3), q=np.zeros(3),
                 A=np.vstack([rows, -np.eye(3)]), b=np.concatenate([rhs, np.zeros(3)]),
                 cones=(("zero", len(rhs)), ("nonneg", 3)))


def test_reduction_by_hand():
    # z = (1, 1, 1) on a + b + c = 3: interior, so the bound multipliers are 0 and the
    # equality's is -1 (P z + A'y = 0 with A = (1, 1, 1)).
    problem = _simplex(np.ones((1, 3)), np.array([3.0]))
    inner, red = reduced_conic(problem)
    assert inner.cones == (("nonneg", 3),) and inner.n == 2
    z, y = red.lift(np.zeros((1, 2)), np.zeros((1, 3)))  # y = 0 is z0 itself
    assert z[0] == pytest.approx([1.0, 1.0, 1.0])
    assert y[0] == pytest.approx([-1.0, 0.0, 0.0, 0.0])
    assert red.offset[0] == pytest.approx(1.5)


def test_dependent_rows_reduce_at_their_rank():
    # the same plane twice: one independent row, the same answer and objective
    twice = _simplex(np.ones((2, 3)), np.array([3.0, 3.0]))
    _, red = reduced_conic(twice)
    assert red.N.shape == (1, 3, 2)
    assert red.z0[0] == pytest.approx([1.0, 1.0, 1.0])
    # stationarity z + A_eq' l = 0 at z = (1, 1, 1) holds for l1 + l2 = -1; the lifted
    # multipliers are the least-norm ones, split evenly
    _, y = red.lift(np.zeros((1, 2)), np.zeros((1, 3)))
    assert y[0] == pytest.approx([-0.5, -0.5, 0.0, 0.0, 0.0])


@pytest.mark.parametrize("P", [np.diag([1.0, 2.0, 3.0]),
                               np.array([[2.0, 1.0, 0.0], [1.0, 2.0, 0.0], [0.0, 0.0, 1.0]])])
def test_reduced_objective_and_rows_are_the_full_ones(P):
    """At any ``y``, the reduced objective plus the offset is the full objective at the
    lifted ``z``, and the reduced cone rows are the full ones there (a diagonal ``P``
    takes a shortcut of its own, a full one the general products)."""
    problem = dataclasses.replace(_simplex(np.array([[1.0, 1.0, 1.0]]), np.array([3.0])),
                                  P=P, q=np.array([0.5, -1.0, 0.0]))
    inner, red = reduced_conic(problem)
    for y in (np.zeros(2), np.array([0.3, -1.2])):
        z = red.lift(y[None], None)[0][0]
        full = 0.5 * z @ P @ z + problem.q @ z
        assert 0.5 * y @ inner.P @ y + inner.q @ y + red.offset[0] == pytest.approx(full)
        assert inner.b - inner.A @ y == pytest.approx(problem.b[1:] - problem.A[1:] @ z)


def test_rank_changing_between_instants_is_refused():
    A = np.stack([np.vstack([np.ones((2, 3)), -np.eye(3)]),
                  np.vstack([np.eye(3)[:2], -np.eye(3)])])
    with pytest.raises(ValueError, match="rank"):
        eliminate_equalities(None, np.zeros((2, 3)), A, np.zeros((2, 5)),
                             (("zero", 2), ("nonneg", 3)))


def _peak(sign: float) -> Conic:
    """min t on x1 + x2 = 2 sign, sign x >= 0, |x_i| <= t over z = (x1, x2, t): the
    optimum x = (sign, sign), t = 1. Each two-row cone's member is ``x_i``, the slack of
    the row ``sign x_i >= 0`` times ``sign``.
    """
    rows = np.array([[1.0, 1.0, 0.0]])
    checks = ForceChecks(A=rows, b=np.array([2 * sign]), names=("x1", "x2", "t"),
                         unilateral=np.zeros(3, bool))
    A = np.vstack([rows, -sign * np.eye(3)[:2], [[0, 0, -1], [-1, 0, 0]],
                   [[0, 0, -1], [0, -1, 0]]])
    return Conic(checks=checks, formulation="ref", P=None, q=np.array([0.0, 0.0, 1.0]),
                 A=A, b=np.array([2 * sign, 0, 0, 0, 0, 0, 0]),
                 cones=(("zero", 1), ("nonneg", 2), ("soc", 2), ("soc", 2)))


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_two_row_cones_fold_into_linear_rows(sign):
    """Both cones fold (one linear row each, no cone left) and the lifted answer and
    multipliers are the full problem's, known by hand: stationarity in t makes the two
    cones' apex multipliers sum to 1, symmetry splits it, so the cones' multipliers are
    (1/2, -sign/2) (on their boundary, opposite to the slack (1, sign)), the bounds'
    are 0 (x inside them) and the equality's is -sign/2."""
    from cardan_forces.solvers.reduced_ import fold

    problem = _peak(sign)
    _, red = reduced_conic(problem)
    plan = fold(red.A_in, problem.b[None, red.rows_in], red.cones)
    assert plan is not None and plan.cones == (("nonneg", 4),)
    record = solve(problem, "clarabel-reduced", tol=TOL)
    assert record.z == pytest.approx([sign, sign, 1.0], abs=1e-6)
    assert record.y == pytest.approx([-sign / 2, 0, 0, 0.5, -sign / 2, 0.5, -sign / 2],
                                     abs=1e-6)


def test_a_cone_folds_only_where_its_row_matches_at_every_instant():
    """Two instants whose nonnegative row matches the cone's member at the first only:
    nothing folds (a plan is one structure for the whole batch)."""
    from cardan_forces.solvers.reduced_ import fold

    A = np.zeros((2, 3, 2))
    A[:, 0, 0] = -1.0  # nonneg row: -x
    A[:, 1, 1] = -1.0  # cone apex: t
    A[:, 2, 0] = [-1.0, -2.0]  # cone member: x, then 2x
    cones = (("nonneg", 1), ("soc", 2))
    assert fold(A[:1], np.zeros((1, 3)), cones) is not None
    assert fold(A, np.zeros((2, 3)), cones) is None


@pytest.fixture(scope="module")
def problems():
    scene = load_scene("paper")
    op = build_operator(simulate(scene, scene.time.instants()[:16]))
    return {name: fbatch.build_problems(op, name, INSTANTS) for name in FORMULATIONS}


@pytest.mark.parametrize("name", ["socp_face", "min_max", "compliance_hertz"])
def test_formulations_null_space_is_the_factored_one(problems, name):
    """A formulation's own null-space basis (``Conic.null_space``) spans what factoring
    its zero-cone rows gives, and the reduction from it has the same least-norm point
    and the same reduced objective at the same point of the subspace."""
    conic = fbatch.as_conic(problems[name][1])
    data = (conic.P, conic.q[None], conic.A[None], conic.b[None], conic.cones)
    given, factored = (eliminate_equalities(*data, N) for N in (conic.null_space[None], None))
    N, M = given.N[0], factored.N[0]
    assert N.T @ N == pytest.approx(np.eye(N.shape[1]), abs=1e-12)
    assert M @ (M.T @ N) == pytest.approx(N, abs=1e-10)  # the same subspace
    assert given.z0 == pytest.approx(factored.z0, abs=1e-12)
    rotation = M.T @ N  # y for the given basis is rotation @ y for the factored one
    y = np.linspace(-1.0, 1.0, N.shape[1])
    for red, point in ((given, y), (factored, rotation @ y)):
        value = 0.5 * point @ red.P[0] @ point + red.q[0] @ point + red.offset[0]
        assert value == pytest.approx(objective_value(conic, red.lift(point[None], None)[0][0]))


def _agree(problem, record, fresh) -> None:
    assert record.status.has_answer and fresh.status.has_answer, record.message
    # complementarity is left out: in positive it is no constraint but a property of the
    # optimum, met to about the square root of an interior point's gap by any solver
    assert max(record.residuals[k] for k in ("equilibrium", "sign", "cone")) <= ACCEPT
    ours, theirs = objective_value(problem, record.z), objective_value(problem, fresh.z)
    assert ours == pytest.approx(theirs, rel=AGREE, abs=AGREE * 1e-6)
    for key in ("dual", "gap"):
        assert record.optimality[key] <= max(AGREE, 10 * fresh.optimality[key])


@pytest.mark.parametrize("solver", ["clarabel-reduced", "qoco", "qoco-reduced"])
@pytest.mark.parametrize("name", FORMULATIONS)
def test_per_instant_agrees_with_clarabel(problems, name, solver):
    _need(solver)
    for problem in problems[name]:
        conic = fbatch.as_conic(problem)
        if not available()[solver].supports(conic):
            pytest.skip(f"{solver} does not take {name}")
        _agree(problem, solve(problem, solver, tol=TOL), solve(problem, "clarabel", tol=TOL))


@pytest.mark.parametrize("name", FORMULATIONS)
def test_lifted_multipliers_are_the_full_problems(problems, name):
    """The lifted ``y`` satisfies the full problem's stationarity: its measures come from
    the full data, not from the reduced problem the solver saw."""
    conic = fbatch.as_conic(problems[name][0])
    record = solve(conic, "clarabel-reduced", tol=TOL)
    found = measures(conic.P, conic.q[None], conic.A[None], conic.b[None], conic.cones,
                     record.z[None], record.y[None])
    assert record.duals == "solver"
    assert found["dual"][0] <= AGREE and found["gap"][0] <= AGREE


@pytest.mark.parametrize("name", FORMULATIONS)
def test_batched_reduced_agrees_with_full(problems, name):
    _need("moreau-reduced")
    batch = fbatch.conic_batch(problems[name], INSTANTS)
    full, reduced = (solve_batch(batch, s, tol=TOL) for s in ("moreau", "moreau-reduced"))
    assert set(reduced.status) == {"solved"}, reduced.message
    for k, problem in enumerate(batch.problems):
        ours = objective_value(problem, reduced.z[k])
        assert ours == pytest.approx(objective_value(problem, full.z[k]), rel=AGREE,
                                     abs=AGREE * 1e-6)
    assert np.all(reduced.optimality.within(max(AGREE, ACCEPT)))


@pytest.mark.parametrize("solver", ["qoco-batched", "qoco-batched-reduced"])
@pytest.mark.parametrize("name", ["socp_face", "min_max"])
def test_qoco_batch_answers_do_not_depend_on_the_order(problems, name, solver):
    """One QOCO solver per batch, its numbers replaced instant by instant: each answer,
    in either order, is the answer of that instant solved alone."""
    _need(solver)
    by_instant = dict(zip(INSTANTS, problems[name]))
    alone = {i: solve_batch(fbatch.conic_batch([p], [i]), solver, tol=TOL).record(0)
             for i, p in by_instant.items()}
    for order in (INSTANTS, INSTANTS[::-1]):
        result = solve_batch(fbatch.conic_batch([by_instant[i] for i in order], order),
                             solver, tol=TOL)
        for k, i in enumerate(order):
            _agree(by_instant[i], result.record(k), alone[i])


@pytest.mark.parametrize("solver", ["moreau-warm", "moreau-warm-reduced"])
@pytest.mark.parametrize("name", ["socp_face", "compliance_hertz"])
def test_moreau_warm_agrees_with_cold(problems, name, solver):
    """Odd instants started from their even neighbour reach the cold optimum."""
    _need(solver)
    batch = fbatch.conic_batch(problems[name], INSTANTS)
    cold, warm = (solve_batch(batch, s, tol=TOL) for s in ("moreau", solver))
    for k, problem in enumerate(batch.problems):
        _agree(problem, warm.record(k), cold.record(k))


def test_a_reduced_backend_is_the_registrys_variant_of_one_that_declares_it():
    """Reductions are one wrapper the registry applies: every ``-reduced`` backend is
    the variant of a backend that declares it takes the reduced form (``reducible``,
    or ``reduced_only`` where only the variant is registered), every backend that
    declares it has its variant, and the wrapper's module imports no adapter."""
    import ast
    import inspect

    from cardan_forces.solvers import reduced_, registry

    tree = ast.parse(inspect.getsource(reduced_))
    imported = {alias.name for node in ast.walk(tree) if isinstance(node, ast.ImportFrom)
                for alias in node.names} | {node.module for node in ast.walk(tree)
                                            if isinstance(node, ast.ImportFrom)}
    assert not imported & set(registry.ADAPTERS)
    found = available()
    declared = [b for module in registry.ADAPTERS
                for b in registry._adapter(module).backends()]
    for backend in declared:
        variant = backend.name + reduced_.SUFFIX
        assert (variant in found) == (backend.reducible or backend.reduced_only)
        assert (backend.name in found) == (not backend.reduced_only)
    bases = {b.name for b in declared}
    for name in found:
        if name.endswith(reduced_.SUFFIX) and name not in bases:
            assert name.removesuffix(reduced_.SUFFIX) in bases
            assert not found[name].warm_start and not found[name].reducible
