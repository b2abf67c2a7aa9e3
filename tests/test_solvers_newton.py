"""The newton family: Newton's method on the contacts' displacement dual.

Held to independent methods (Clarabel's interior point on every formulation it takes,
at instants of every built-in scene; the exact SVD and active-set methods where the
optimum is one point), to closed forms on hand-checkable problems, and its compiled
kernel to its NumPy reference.
"""

import numpy as np
import pytest
from cardan_forces.driveline.determinacy import RANK_RTOL
from cardan_forces.driveline.dynamics import simulate
from cardan_forces.driveline.equilibrium import build_operator
from cardan_forces.driveline.loading import builtin_names, load_scene
from cardan_forces.formulations import FORMULATIONS
from cardan_forces.formulations import batch as fbatch
from cardan_forces.formulations.convex import NotApplicable
from cardan_forces.solvers import UnsupportedProblem, solve
from cardan_forces.solvers import _newton_numpy as method
from cardan_forces.solvers import newton_ as nt
from cardan_forces.solvers.registry import batch_backends, solve_batch

FORMULATIONS_TAKEN = ("min_norm", "positive", "lcp", "compliance", "compliance_hertz")

CLARABEL_RTOL = {"min_norm": 1e-8, "positive": 5e-5, "lcp": 5e-5, "compliance": 5e-5,
                 "compliance_hertz": 1e-5}
"""Relative force distance to Clarabel at tol 1e-10: an interior-point solver leaves
an idle end-face pair at about ``sqrt(tol) ||b||`` (formulations.convex, ``positive``),
and the Hertz energy is flat near an idle face; the exact methods are held tighter
(:data:`EXACT`)."""

EXACT = {"min_norm": ("numpy-kkt", 1e-9), "lcp": ("lcp-lemke", 1e-9)}
"""Exact direct methods and the distance held to them."""

INSTANTS = 5
"""Evenly spaced instants per scene (the scenes' grids are 101-1001 instants)."""


@pytest.fixture(scope="module", params=builtin_names())
def scene_op(request):
    scene = load_scene(request.param)
    times = scene.time.instants()
    picks = np.unique(np.linspace(0, len(times) - 1, INSTANTS).round().astype(int))
    return request.param, build_operator(simulate(scene, times[picks]))


def _relative(x, ref):
    return float(np.linalg.norm(x - ref) / max(np.linalg.norm(ref), 1e-300))


REFERENCES = ("clarabel", "qpsolvers-daqp")
"""Independent references, Clarabel first: the first whose answer the package's own
measures hold optimal, else Clarabel's (Clarabel's interior point loses primal accuracy
on the soft disc coupling of ``propshaft-disc`` in ``compliance``, where DAQP's active
set does not; DAQP takes QPs only)."""


def _reference(problem):
    answers = []
    for solver in REFERENCES:
        try:
            theirs = solve(problem, solver, tol=1e-10)
        except UnsupportedProblem:
            continue
        if theirs.x is not None and theirs.within(1e-8):
            return theirs
        answers.append(theirs)
    return answers[0]


@pytest.mark.parametrize("formulation", FORMULATIONS_TAKEN)
def test_answers_equal_clarabels_at_every_scene(scene_op, formulation):
    name, op = scene_op
    for i in range(len(op.t)):
        try:
            problem = FORMULATIONS[formulation](op, i)
        except NotApplicable:
            pytest.skip(f"{formulation} does not apply to {name}")
        mine = solve(problem, "newton")
        against = problem if formulation != "lcp" else FORMULATIONS["positive"](op, i)
        theirs = _reference(against)
        assert mine.status == "solved", (name, i, mine.message)
        assert _relative(mine.x, theirs.x) <= CLARABEL_RTOL[formulation], (name, i)
        if mine.solver_status == "solved":  # its claim, held to the package's measures
            assert mine.within(1e-10), (name, i, dict(mine.optimality))
        if formulation in EXACT:
            exact, rtol = EXACT[formulation]
            assert _relative(mine.x, solve(problem, exact).x) <= rtol, (name, i)


@pytest.mark.slow
@pytest.mark.parametrize("name", builtin_names())
def test_chained_batches_equal_clarabel_at_every_instant(name):
    """Every instant of every built-in scene, each formulation the family takes solved
    as one chained batch (the ``lcp`` held to ``positive``'s answer), against a
    reference's per instant (:func:`_reference`: Clarabel's where it is optimal); every
    instant solved, and at the package's 1e-10 level where the batch says its solver
    solved it.
    """
    op = build_operator(simulate(load_scene(name)))
    for formulation in FORMULATIONS_TAKEN:
        try:
            against = fbatch.build_problems(
                op, "positive" if formulation == "lcp" else formulation)
        except NotApplicable:
            continue
        try:
            batch = fbatch.least_norm_batch(op, formulation)
        except ValueError:  # not a diagonal least norm here: its conic form
            batch = fbatch.conic_batch(against, np.arange(len(against)))
        mine = solve_batch(batch, "newton-batched-warm")
        assert np.all(mine.status == "solved"), (name, formulation)
        claimed = np.array([s == "solved" for s in mine.solver_status])
        assert np.all(mine.within(1e-10)[claimed]), (name, formulation)
        for i, problem in enumerate(against):
            theirs = _reference(problem)
            assert _relative(mine.x[i], theirs.x) <= CLARABEL_RTOL[formulation], (
                name, formulation, i)


@pytest.fixture(scope="module")
def paper_op(paper):
    return build_operator(simulate(paper, paper.time.instants()[::40]))


@pytest.mark.parametrize("formulation", ("positive", "compliance"))
def test_batched_equals_the_exact_active_set(paper_op, formulation):
    batch = fbatch.least_norm_batch(paper_op, formulation)
    assert {"newton-batched", "newton-batched-warm"} <= set(batch_backends(batch))
    exact = solve_batch(batch, "numpy-batched")
    for name in ("newton-batched", "newton-batched-warm"):
        mine = solve_batch(batch, name)
        assert np.all(mine.status == "solved")
        assert np.all(mine.within(1e-10))
        assert np.max(np.linalg.norm(mine.x - exact.x, axis=1)
                      / np.linalg.norm(exact.x, axis=1)) <= 1e-9


def test_batched_hertz_equals_per_instant(paper_op):
    problems = fbatch.build_problems(paper_op, "compliance_hertz")
    batch = fbatch.conic_batch(problems, np.arange(len(problems)))
    for name in ("newton-batched", "newton-batched-warm"):
        mine = solve_batch(batch, name)
        assert np.all(mine.within(1e-10))
        for k in range(0, len(problems), 5):
            one = solve(problems[k], "newton")
            assert _relative(mine.x[k], one.x) <= 1e-9


def test_warm_start_reaches_the_same_answer(paper_op):
    problems = fbatch.build_problems(paper_op, "compliance_hertz")
    previous = solve(problems[0], "newton")
    for problem in problems[1:6]:
        warm = solve(problem, "newton", initvals=previous.z)
        cold = solve(problem, "newton")
        assert warm.status == "solved"
        assert _relative(warm.x, cold.x) <= 1e-9
        previous = warm


def _one_row(k, g, n, signed, F):
    """Contacts in parallel on one body: ``E = [1 ... 1]``, load ``F``."""
    groups = method.groups_of([[j] for j in range(len(k))], signed, n)
    E = np.ones((1, 1, len(k)))
    return method.newton_numpy(E, np.array([[F]]), groups, np.array([k], float),
                           np.array([g], float)), groups


def test_linear_springs_share_a_load_by_stiffness():
    """Compliances ``k`` (energy ``k f^2 / 2``): ``f_i = F / k_i / sum(1 / k)``."""
    k = np.array([1.0, 2.0, 4.0])
    (u, d, status, _), groups = _one_row(k, [0, 0, 0], [1, 1, 1], [False] * 3, 7.0)
    f = method.forces(d[0], groups, k, np.zeros(3))
    assert status[0] == 0
    np.testing.assert_allclose(f, 7.0 / k / np.sum(1.0 / k), rtol=1e-12)


def test_hertz_contact_with_a_gap_closes_by_its_law():
    """One Hertz contact ``f = ((d - g) / k)^(3/2)`` under ``F``: ``d = g + k F^(2/3)``;
    a pushing column under a pull stays idle and leaves the load to a two-sided one.
    """
    (u, d, status, _), _ = _one_row([2.0], [0.3], [1.5], [True], 8.0)
    assert status[0] == 0
    assert d[0, 0] == pytest.approx(0.3 + 2.0 * 8.0 ** (2.0 / 3.0), rel=1e-12)
    (u, d, status, _), groups = _one_row([1.0, 1.0], [0.0, 0.0], [1, 1], [True, False],
                                         -3.0)
    f = method.forces(d[0], groups, np.ones(2), np.zeros(2))
    np.testing.assert_allclose(f, [0.0, -3.0], atol=1e-12)


def test_left_null_space_is_the_operators(paper_op):
    """The operator's rows are dependent along the motion: the null directions found
    are ``m - rank(A)`` orthonormal vectors that no contact does work along.
    """
    groups = nt._scalars(paper_op.unilateral)
    ones = np.ones(len(paper_op.names))
    for A, b in zip(paper_op.A[:3], paper_op.b[:3]):
        s = np.linalg.svd(A, compute_uv=False)
        nullity = A.shape[0] - int(np.sum(s > RANK_RTOL * s[0]))
        V = method.null_basis(method.nominal(A, b, groups, ones)[0])
        assert V.shape[1] == nullity >= 1
        np.testing.assert_allclose(V.T @ V, np.eye(nullity), atol=1e-12)
        assert np.linalg.norm(A.T @ V) <= 1e-9 * np.linalg.norm(A)


def _batches(op):
    out = [fbatch.least_norm_batch(op, f) for f in ("min_norm", "positive", "compliance")]
    problems = fbatch.build_problems(op, "compliance_hertz")
    return out + [fbatch.conic_batch(problems, np.arange(len(problems)))]


@pytest.mark.compiled
@pytest.mark.parametrize("chain", (False, True))
def test_compiled_kernel_equals_numpy_reference(paper_op, chain):
    pytest.importorskip("numba")
    for batch in _batches(paper_op):
        ref = nt.solve_batch(batch, chain=chain, compiled=False)
        mine = nt.solve_batch(batch, chain=chain, compiled=True)
        assert np.array_equal(ref.status, mine.status)
        scale = np.abs(ref.z).max()
        np.testing.assert_allclose(mine.z, ref.z, atol=1e-9 * scale, rtol=0)
        np.testing.assert_allclose(mine.y, ref.y, atol=1e-9 * np.abs(ref.y).max(), rtol=0)


@pytest.mark.compiled
@pytest.mark.parametrize("compiled", (False, True))
def test_extrapolation_is_exact_on_cubics(compiled):
    """A chain's start is exact where the deformations are a cubic in the instant, and
    takes only the solved instants just before (a failed one cuts the polynomial).
    """
    t = np.arange(8.0)[:, None]
    d = 0.5 - 2.0 * t + 0.3 * t**2 - 0.01 * t**3 + np.array([[0.0, 1.0]])
    status = np.zeros(8, np.int64)
    if compiled:
        kernels = pytest.importorskip("cardan_forces.solvers._newton_kernels")

        def extrapolate(d_out, status, i):
            hint = np.zeros(d_out.shape[1])
            kernels._extrapolate(d_out, status, i, method.EXTRAPOLATION, hint)
            return hint
    else:
        extrapolate = method.extrapolate
    np.testing.assert_allclose(extrapolate(d, status, 6), d[6], rtol=1e-12)
    status[3] = 1  # two solved instants before 6: a straight line through them
    np.testing.assert_allclose(extrapolate(d, status, 6), 2.0 * d[5] - d[4], rtol=1e-12)


@pytest.mark.compiled
def test_chain_through_a_change_of_the_null_space(paper_op):
    """A chained instant whose left null space grows (a row made a multiple of
    another) is not taken from the instant before's: the compiled chain still equals
    the reference at every instant.
    """
    pytest.importorskip("numba")
    batch = fbatch.least_norm_batch(paper_op, "positive")
    E, b = batch.A.copy(), batch.b.copy()
    E[3, 7], b[3, 7] = 2.0 * E[3, 8], 2.0 * b[3, 8]
    groups = nt._scalars(batch.signed)
    k = np.ones((len(E), E.shape[2]))
    ref = nt.solve_duals(E, b, groups, k, 0.0 * k, chain=True, compiled=False)
    mine = nt.solve_duals(E, b, groups, k, 0.0 * k, chain=True, compiled=True)
    assert np.array_equal(ref[2], mine[2]) and not np.any(mine[2])
    f_ref, f_mine = (method.forces(d, groups, k, 0.0 * k) for d in (ref[1], mine[1]))
    np.testing.assert_allclose(f_mine, f_ref, atol=1e-9 * np.abs(f_ref).max(), rtol=0)
    assert np.linalg.norm(E[3].T @ mine[0][3]) > 0  # a real instant, not a skipped one


@pytest.mark.compiled
def test_runs_side_by_side_give_the_answers_of_one_thread(paper_op, monkeypatch):
    """A batch of several runs (:data:`newton_.RUN` instants each, a chain of its own)
    gives the same answers, bit for bit, on one thread and on three; each run's first
    instant starts cold, as the reference's does.
    """
    pytest.importorskip("numba")
    batch = fbatch.least_norm_batch(paper_op, "compliance")
    reps = 2 * nt.RUN // len(batch.A) + 1  # three runs or more
    E, b = np.tile(batch.A, (reps, 1, 1)), np.tile(batch.b, (reps, 1))
    groups = nt._scalars(batch.signed)
    k = np.tile(batch.weights, (reps, 1))
    answers = []
    for threads in (1, 3):
        monkeypatch.setattr(nt, "_threads", lambda n=threads: n)
        answers.append(nt.solve_duals(E, b, groups, k, 0.0 * k, chain=True))
    for one, three in zip(*answers):
        assert np.array_equal(one, three)
    run = slice(nt.RUN, nt.RUN + 1)  # a run's first instant: as if solved alone, cold
    alone = nt.solve_duals(E[run], b[run], groups, k[run], 0.0 * k[run], chain=True)
    assert np.array_equal(alone[0][0], answers[0][0][nt.RUN])
    ref = nt.solve_duals(E, b, groups, k, 0.0 * k, chain=True, compiled=False)
    assert not np.any(ref[2]) and np.array_equal(ref[2], answers[0][2])
    f_ref, f_mine = (method.forces(d, groups, k, 0.0 * k) for d in (ref[1], answers[0][1]))
    np.testing.assert_allclose(f_mine, f_ref, atol=1e-9 * np.abs(f_ref).max(), rtol=0)


@pytest.mark.compiled
@pytest.mark.parametrize("compiled", (False, True))
def test_non_finite_data_end_as_a_failed_instant(paper_op, compiled):
    if compiled:
        pytest.importorskip("numba")
    batch = fbatch.least_norm_batch(paper_op, "positive")
    E, b = batch.A.copy(), batch.b.copy()
    E[1, 2, 3], b[2, 0] = np.nan, np.inf
    groups = nt._scalars(batch.signed)
    k = np.ones((len(E), E.shape[2]))
    u, d, status, _ = nt.solve_duals(E, b, groups, k, 0.0 * k, compiled=compiled)
    assert list(status[:4]) == [0, 3, 3, 0]
    assert method.REASONS[3] and method.STATUS[3] == "failed"


def test_refuses_what_it_does_not_solve(paper_op):
    problem = FORMULATIONS["min_max"](paper_op, 0)
    assert not nt.supports(problem)
