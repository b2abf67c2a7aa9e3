"""Backend ``reduced-ipm``: the reduced interior point against Clarabel and closed forms."""

import dataclasses

import numpy as np
import pytest
from cardan_forces.driveline.dynamics import simulate
from cardan_forces.driveline.equilibrium import build_operator
from cardan_forces.driveline.loading import builtin_names, load_scene
from cardan_forces.formulations import batch as fbatch
from cardan_forces.formulations.convex import NotApplicable
from cardan_forces.solvers import reduced_ipm
from cardan_forces.solvers import reduced_ipm_ as adapter
from cardan_forces.solvers.judge import objective_value
from cardan_forces.solvers.registry import batch_backends, solve, solve_batch

from cardan_forces.util import compiled

FORMULATIONS = ("min_max", "socp_face")
LEVEL = 1e-8
"""The package's optimality every instant the backend calls solved meets."""
@pytest.fixture(scope="module")
def op(paper):
    return build_operator(simulate(paper, paper.time.instants()[:41]))


def _batch(op, formulation, instants):
    problems = fbatch.build_problems(op, formulation, instants)
    return fbatch.conic_batch(problems, instants)


def _agrees_with_clarabel(batch, result):
    """Every instant solved; those the interior point answered itself (not its fallback)
    within :data:`LEVEL`; the optimal value Clarabel's (tol 1e-10) as closely as both
    measured gaps say (on ``axle-pinion``'s ``min_max`` Clarabel stops at a gap of 7e-8
    even at 1e-12), the unknowns as closely as the objective's strong convexity then
    bounds them (:func:`_distance_bound`).
    """
    assert all(s == "solved" for s in result.status)
    own = np.array([f"answered by {adapter.FALLBACK}" not in m for m in result.message])
    assert result.within(LEVEL)[own].all()
    for k, problem in enumerate(batch.problems):
        expected = solve(problem, "clarabel", tol=1e-10)
        assert expected.solved
        value = objective_value(problem, expected.z)
        gaps = (result.optimality.gap[k], expected.optimality.gap)
        assert objective_value(problem, result.z[k]) == pytest.approx(
            value, rel=max(LEVEL, 2 * max(gaps)), abs=1e-10)
        strong, bound = _distance_bound(problem, abs(value), gaps)
        assert np.linalg.norm((result.z[k] - expected.z)[strong]) <= bound


def _distance_bound(problem, value: float, gaps) -> tuple[np.ndarray, float]:
    """The unknowns in which the objective is strongly convex (``P``'s positive
    diagonal: every one but ``min_max``'s peak ``t``) and how far two answers with
    relative gaps ``gaps`` may lie apart in them: ``||z - z*|| <= sqrt(2 (f - f*) / w)``
    each, ``w`` the least of that diagonal (``min_max``'s tie-break weight 1e-4 lets its
    forces differ by about 1 % between two answers at a gap of 1e-8), twice over: a
    measured gap bounds ``f - f*`` only as far as its multipliers are dual feasible.
    """
    d = np.diag(np.asarray(problem.P, float))
    strong = d > 0
    w = d[strong].min()
    return strong, 2 * sum(np.sqrt(2 * (g * value + 1e-14) / w) for g in gaps) + 1e-9


@pytest.mark.parametrize("formulation", FORMULATIONS)
def test_agrees_with_clarabel_on_paper_instants(op, formulation):
    batch = _batch(op, formulation, np.arange(0, 41, 8))
    assert "reduced-ipm" in batch_backends(batch)
    _agrees_with_clarabel(batch, solve_batch(batch, "reduced-ipm"))


@pytest.mark.slow
@pytest.mark.parametrize("formulation", FORMULATIONS)
@pytest.mark.parametrize("scene", builtin_names())
def test_every_instant_of_every_builtin_scene(scene, formulation):
    op = build_operator(simulate(load_scene(scene)))
    try:
        batch = _batch(op, formulation, np.arange(len(op.t)))
    except NotApplicable:
        pytest.skip(f"{formulation} does not apply to {scene}")
    _agrees_with_clarabel(batch, solve_batch(batch, "reduced-ipm"))


def test_an_instants_answer_does_not_depend_on_its_batch(op):
    full = _batch(op, "socp_face", np.arange(41))
    some = dataclasses.replace(full, **_rows(full, np.arange(3, 41, 7)))
    a, b = adapter.solve_batch(full), adapter.solve_batch(some)
    np.testing.assert_array_equal(a.z[3::7], b.z)


def _rows(batch, rows):
    """The fields of ``batch`` that hold instants, at ``rows``."""
    return {"instants": batch.instants[rows], "q": batch.q[rows], "A": batch.A[rows],
            "b": batch.b[rows], "problems": tuple(batch.problems[k] for k in rows),
            "null_space": batch.null_space[rows]}


@pytest.mark.parametrize("formulation", FORMULATIONS)
def test_compiled_form_agrees_with_the_reference(op, formulation):
    """Every instant of ``paper``'s first 41: the same exit code and optimal value (to
    1e-9), the same answer to 1e-9 on ``socp_face``. On ``min_max`` the compiled form's
    Newton solve (scaled normal equations, refined) takes other roundings than the
    reference's LU, and its answer moves along the flat direction of the tie-break
    weight 1e-4 as far as the gap allows (about 1e-4 of the forces at a relative gap of
    1e-10, :func:`_distance_bound`): there it is held to the package's optimality at
    :data:`LEVEL` instead.
    """
    pytest.importorskip("numba")
    batch = _batch(op, formulation, np.arange(41))
    P, q, G, h, cones = adapter.reduced_problem(batch, np.arange(41))[1]
    ref = reduced_ipm.solve(P, q, G, h, cones)
    out = adapter.solve_reduced(P, q, G, h, cones, compiled=True)
    np.testing.assert_array_equal(out.code, ref.code)
    assert (ref.code == reduced_ipm.SOLVED).all()

    def value(x):
        return np.einsum("ti,tij,tj->t", x, P, x) / 2 + np.einsum("ti,ti->t", q, x)

    np.testing.assert_allclose(value(out.x), value(ref.x), rtol=1e-9, atol=1e-9)
    if formulation == "socp_face":
        np.testing.assert_allclose(out.x, ref.x, rtol=1e-9, atol=1e-9)
    result = solve_batch(batch, "reduced-ipm", compiled=True)
    assert all(s == "solved" for s in result.status)
    assert result.within(LEVEL).all()


@pytest.mark.parametrize("formulation", FORMULATIONS)
def test_compiled_reduction_and_lift_agree_with_the_reference(op, formulation):
    """The compiled reduction and lift give the reference's problems (1), cones and
    lifted answers and multipliers to rounding, on ``paper``'s first 41 instants.
    """
    pytest.importorskip("numba")
    batch = _batch(op, formulation, np.arange(41))
    _same_reduction(batch)


def _same_reduction(batch):
    """The compiled and the reference reduction of ``batch`` agree (problems, cones,
    the lift of one answer of each instant) to rounding.
    """
    lift, problem = adapter.reduced_problem(batch, slice(None), compiled=True)
    ref_lift, ref = adapter.reduced_problem(batch, slice(None), compiled=False)
    assert problem[4] == ref[4]
    for a, b in zip(problem[:4], ref[:4]):
        np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-12 * np.abs(b).max())
    answer = adapter.solve_reduced(*ref, compiled=False)
    for a, b in zip(lift(answer.x, answer.z), ref_lift(answer.x, answer.z)):
        np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-12 * np.abs(b).max())


@pytest.mark.parametrize("warm", [False, True])
def test_one_compiled_pass_is_reduction_interior_point_and_lift(op, warm):
    """The backend's one compiled pass over the instants gives, to the bit, what the
    compiled reduction, interior point and lift give one after the other.
    """
    pytest.importorskip("numba")
    batch = _batch(op, "min_max", np.arange(41))
    lift, problem = adapter.reduced_problem(batch, slice(None), compiled=True)
    answer = adapter.solve_reduced(*problem, compiled=True, warm=warm)
    out = adapter.solve_batch(batch, compiled=True, warm=warm)
    z, y = lift(answer.x, answer.z)
    solved = answer.code <= reduced_ipm.ALMOST  # the others are the fallback's
    np.testing.assert_array_equal(out.z[solved], z[solved])
    np.testing.assert_array_equal(out.y[solved], y[solved])
    np.testing.assert_array_equal(out.iterations, answer.iterations)


def test_compiled_reduction_folds_only_what_holds_at_every_instant(op):
    """A two-row cone whose member row matches its nonnegative row at the first instant
    but not at a later one is not folded, by both forms.
    """
    pytest.importorskip("numba")
    batch = _batch(op, "min_max", np.arange(0, 41, 10))
    P, q, G, h, cones = adapter.reduced_problem(batch, slice(None), compiled=False)[1]
    starts = np.cumsum([0, *(size for _, size in batch.cones)])
    member = 1 + next(start for start, (kind, size) in zip(starts, batch.cones)
                      if (kind, size) == ("soc", 2))  # min_max's two-row cones all fold
    b = batch.b.copy()
    b[2, member] += 1.0
    changed = dataclasses.replace(batch, b=b)
    _same_reduction(changed)
    assert adapter.reduced_problem(changed, slice(None), compiled=True)[1][4] != cones


@pytest.mark.parametrize("warm", [False, True])
def test_compiled_answers_do_not_depend_on_the_thread_count(op, warm):
    numba = pytest.importorskip("numba")
    batch = _batch(op, "min_max", np.arange(41))
    problem = adapter.reduced_problem(batch, np.arange(41))[1]
    was = numba.get_num_threads()
    try:
        numba.set_num_threads(1)
        one = adapter.solve_reduced(*problem, compiled=True, warm=warm)
        numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
        many = adapter.solve_reduced(*problem, compiled=True, warm=warm)
    finally:
        numba.set_num_threads(was)
    for a, b in zip(one.__dict__.values(), many.__dict__.values()):
        np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("formulation", FORMULATIONS)
def test_warm_started_instants_meet_the_level(op, formulation):
    """A warm start (each instant from the one before) changes the iterations, not the
    accuracy: every instant solved by the interior point itself, within :data:`LEVEL`.
    """
    pytest.importorskip("numba")
    batch = _batch(op, formulation, np.arange(41))
    result = solve_batch(batch, "reduced-ipm", warm=True)
    assert all(s == "solved" for s in result.status)
    assert not any(f"answered by {adapter.FALLBACK}" in m for m in result.message)
    assert result.within(LEVEL).all()


def _unit_ball(q, extra_rows=(), extra_h=()):
    """``min q'x s.t. ||x|| <= 1`` (and ``extra_rows x <= extra_h``) in the form (1)."""
    k = len(q)
    G = np.vstack([np.zeros((1, k)), -np.eye(k)])
    h = np.concatenate([[1.0], np.zeros(k)])
    cones = (("soc", k + 1),)
    if len(extra_rows):
        G = np.vstack([np.asarray(extra_rows, float), G])
        h = np.concatenate([extra_h, h])
        cones = (("nonneg", len(extra_h)), *cones)
    return np.zeros((1, k, k)), np.asarray(q, float)[None], G[None], h[None], cones


COMPILED = [False, pytest.param(True, marks=pytest.mark.skipif(
    not compiled.HAVE_NUMBA, reason="numba is not installed"))]
"""Both forms of the interior point."""


@pytest.mark.parametrize("compiled_form", COMPILED)
def test_closed_form_socp(compiled_form):
    """``min q'x, ||x|| <= 1``: ``x = -q/||q||`` at the optimal value ``-||q||``, the
    cone's multiplier ``(||q||, q)``; an inactive half-space beside it keeps a zero
    multiplier. A linear objective on a ball: ``x`` is as close as the square root of
    the gap.
    """
    q = np.array([1.0, 2.0, -2.0])
    answer = adapter.solve_reduced(*_unit_ball(q, [[1.0, 0.0, 0.0]], [0.5]),
                                   compiled=compiled_form)
    assert answer.code[0] == reduced_ipm.SOLVED
    assert q @ answer.x[0] == pytest.approx(-3.0, abs=1e-8)
    np.testing.assert_allclose(answer.x[0], -q / 3.0, atol=1e-4)
    np.testing.assert_allclose(answer.z[0], [0.0, 3.0, *q], atol=1e-6)


@pytest.mark.parametrize("compiled_form", COMPILED)
def test_infeasible_apex_and_nan_end_as_codes_never_exceptions(compiled_form):
    """``||x|| <= 1`` with ``x_0 >= 2`` has no point; ``||x|| <= 0`` only its apex,
    where strict complementarity fails; a NaN in ``h`` has no answer: none raises, the
    first and the last are not solved.
    """
    q = np.array([1.0, 2.0])
    infeasible = adapter.solve_reduced(*_unit_ball(q, [[-1.0, 0.0]], [-2.0]),
                                       compiled=compiled_form)
    assert infeasible.code[0] != reduced_ipm.SOLVED
    P, q1, G, h, cones = _unit_ball(q)
    apex = adapter.solve_reduced(P, q1, G, np.zeros_like(h), cones, compiled=compiled_form)
    assert apex.code[0] in range(len(reduced_ipm.CODES) - 1)
    if apex.code[0] == reduced_ipm.SOLVED:
        assert np.abs(apex.x[0]).max() <= 1e-6
    broken = adapter.solve_reduced(P, q1, G, np.where(h > 0, np.nan, h), cones,
                                   compiled=compiled_form)
    assert broken.code[0] not in (reduced_ipm.SOLVED, reduced_ipm.ALMOST, reduced_ipm.RUNNING)


def test_unsolved_instants_fall_back_and_say_so(op):
    batch = _batch(op, "min_max", np.arange(0, 41, 20))
    result = solve_batch(batch, "reduced-ipm", max_iter=1)
    assert all(s == "solved" for s in result.status)
    assert all(f"answered by {adapter.FALLBACK}" in m for m in result.message)


def test_a_rank_change_of_the_equalities_is_reduced_in_groups(op):
    """Instant 0 gets a copy of an equality row in place of another (its rank drops by
    one): the instants are reduced in one group per rank, each said, none fails.
    """
    batch = _batch(op, "socp_face", np.arange(0, 41, 10))
    A, b = batch.A.copy(), batch.b.copy()
    A[0, 1], b[0, 1] = A[0, 0], b[0, 0]
    changed = dataclasses.replace(batch, A=A, b=b, null_space=None)
    out = adapter.solve_batch(changed)
    assert all("equality rank changes" in m for m in out.messages)
    assert all(s == "solved" for s in out.status)
    same = adapter.solve_batch(batch)
    np.testing.assert_allclose(out.z[1:], same.z[1:], atol=1e-7)
