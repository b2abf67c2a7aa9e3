"""Batched backends: the same answers and records as the per-instant ones."""

import numpy as np
import pytest
from cardan_forces.driveline.dynamics import simulate
from cardan_forces.driveline.equilibrium import build_operator
from cardan_forces.driveline.loading import builtin_names, load_scene
from cardan_forces.formulations import FORMULATIONS
from cardan_forces.formulations import batch as fbatch
from cardan_forces.formulations.problems import Conic
from cardan_forces.solvers import available, solve
from cardan_forces.solvers import numpy_batched_ as nb
from cardan_forces.solvers.judge import objective_value
from cardan_forces.solvers.lcp_methods import lemke
from cardan_forces.solvers.registry import UnsupportedProblem, batch_backends, solve_batch

pytestmark = pytest.mark.compiled  # also run for a generic CPU by .ci/run


@pytest.fixture(scope="module")
def op(paper):
    return build_operator(simulate(paper, paper.time.instants()[:41]))


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
def test_numpy_batched_equals_per_instant_answers(op, formulation, reference, solver):
    solver = solver or _quadprog()
    batch = fbatch.least_norm_batch(op, formulation)
    assert "numpy-batched" in batch_backends(batch)
    result = solve_batch(batch, "numpy-batched")
    assert set(result.duals) == {"solver"}
    for i in range(0, 41, 5):
        expected = solve(FORMULATIONS[reference](op, i), solver)
        assert expected.status == "solved"
        x = result.x[i]
        assert np.linalg.norm(x - expected.x) <= 1e-9 * np.linalg.norm(expected.x)
        checked = FORMULATIONS[formulation](op, i).checks.residuals(x)
        assert max(checked.values()) <= 1e-9
        for key, value in checked.items():  # one residual code for both paths
            assert result.residuals[key][i] == pytest.approx(value, rel=1e-9, abs=1e-16)
        record = result.record(i)
        assert record.status == "solved" and record.within(1e-9)
    assert result.within(1e-9).all()


def test_batched_subset_of_instants_matches_the_full_run(op):
    full = solve_batch(fbatch.least_norm_batch(op, "positive"), "numpy-batched")
    some = solve_batch(fbatch.least_norm_batch(op, "positive", [3, 17, 40]), "numpy-batched")
    assert np.allclose(some.x, full.x[[3, 17, 40]], rtol=1e-12, atol=1e-9)
    assert len(some) == 3 and list(some.status) == [full.status[i] for i in (3, 17, 40)]


def test_a_conic_formulation_has_no_least_norm_batch(op):
    with pytest.raises(ValueError):
        fbatch.least_norm_batch(op, "min_max")
    batch = fbatch.conic_batch(fbatch.build_problems(op, "min_max", [0, 1]), [0, 1])
    assert "numpy-batched" not in batch_backends(batch)
    with pytest.raises(UnsupportedProblem):
        solve_batch(batch, "numpy-batched")


@pytest.mark.parametrize("formulation", ["socp_face", "min_max", "compliance_hertz"])
def test_moreau_batch_agrees_with_clarabel(op, formulation):
    """One compiled structure for all instants; the rows are regrouped for moreau's
    cone layout (compliance_hertz interleaves second-order and power cones)."""
    if "moreau" not in available():
        pytest.skip("moreau not installed")
    instants = np.arange(0, 41, 4)
    problems = fbatch.build_problems(op, formulation, instants)
    result = solve_batch(fbatch.conic_batch(problems, instants), "moreau", tol=1e-9)
    assert set(result.duals) == {"solver"}
    for k, problem in enumerate(problems):
        expected = solve(problem, "clarabel", tol=1e-9)
        assert result.record(k).status.has_answer and expected.status.has_answer
        # the same optimal value (min_max's forces are a set: compare values, optimality)
        ours, theirs = (objective_value(problem, z) for z in (result.z[k], expected.z))
        assert ours == pytest.approx(theirs, rel=1e-6, abs=1e-9)
        assert result.optimality["gap"][k] <= 1e-6 and result.optimality["dual"][k] <= 1e-6
        if formulation != "min_max":
            assert np.linalg.norm(result.x[k] - expected.x) <= 1e-5 * np.linalg.norm(expected.x)


def test_active_set_solves_random_lcps_and_falls_back_to_lemke():
    rng = np.random.default_rng(7)
    T, k = 300, 8
    N = rng.standard_normal((T, k, 7))
    M = N @ N.transpose(0, 2, 1)  # positive semidefinite and singular, like positive's LCP
    # q = s - N z with s >= 0: the QP behind the LCP is feasible, so it has a solution
    q = rng.uniform(0, 5, (T, k)) - (N @ (10 * rng.standard_normal((T, 7, 1))))[:, :, 0]
    for max_iter in (30, 1):
        lam, iterations, fallback = nb._active_set(M, q, max_iter)
        assert iterations.max() <= max_iter
        w = np.einsum("tij,tj->ti", M, lam) + q
        assert lam.min() >= -1e-9 and w.min() >= -1e-9
        assert np.abs(lam * w).max() <= 1e-8
        for i in range(0, T, 30):  # y = N' lam is unique even where lam is not
            exact = lemke(M[i], q[i]).z
            assert np.allclose(N[i].T @ lam[i], N[i].T @ exact, atol=1e-8)
    assert fallback.any()  # one step is too few for some instants: Lemke solved them


def test_chain_orders_the_bodies_and_rejects_other_graphs(op):
    blocks = nb.chain(op.A[0])
    bodies = [op.rows[b.start].split(".force")[0] for b in blocks]
    assert bodies in (["input", "uj1.pin", "intermediate", "uj2.pin", "output"],
                      ["output", "uj2.pin", "intermediate", "uj1.pin", "input"])
    star = np.zeros((24, 3))
    for column, body in enumerate((1, 2, 3)):  # body 0 linked to three others
        star[0, column] = star[6 * body, column] = 1.0
    with pytest.raises(ValueError, match="chain"):
        nb.chain(star)


def test_a_link_missing_at_one_instant_still_makes_a_chain():
    A = np.zeros((2, 18, 2))
    A[:, 0, 0] = A[:, 6, 0] = 1.0  # bodies 0-1 linked by column 0 at both instants
    A[1, 7, 1] = A[1, 12, 1] = 1.0  # bodies 1-2 by column 1, zero at instant 0
    with pytest.raises(ValueError, match="chain"):
        nb.chain(A[0])
    batch = fbatch.LeastNormBatch("min_norm", np.arange(2), A, np.zeros((2, 18)), None,
                                  np.zeros(2, bool), checks=None)
    assert nb._chain_shaped(batch)


def test_chain_solve_equals_a_dense_solve():
    rng = np.random.default_rng(3)
    blocks = [slice(6 * k, 6 * k + 6) for k in (2, 0, 1)]
    A = np.zeros((4, 18, 12))
    for c, (a, b) in enumerate([(2, 0)] * 6 + [(0, 1)] * 6):
        A[:, 6 * a: 6 * a + 6, c] = rng.standard_normal((4, 6))
        A[:, 6 * b: 6 * b + 6, c] = rng.standard_normal((4, 6))
    K = A @ A.transpose(0, 2, 1) + np.eye(18)
    R = rng.standard_normal((4, 18, 3))
    assert np.allclose(nb.chain_solve(K, R, blocks), np.linalg.solve(K, R), atol=1e-12)


@pytest.fixture(scope="module")
def propshaft_op():
    from cardan_forces.driveline.loading import load_scene

    scene = load_scene("propshaft")  # scales differ: every instant takes a refinement step
    return build_operator(simulate(scene, scene.time.instants()[:21]))


@pytest.mark.parametrize("scene", ["paper", "propshaft"])
@pytest.mark.parametrize("formulation", ["min_norm_scaled", "positive", "compliance"])
def test_compiled_least_norm_equals_the_numpy_path(op, propshaft_op, scene, formulation):
    """The compiled pass over the instants and NumPy's stacked steps: the same forces and
    face multipliers; ``mu`` agrees up to the rows' dependency, which ``A'`` removes."""
    pytest.importorskip("numba")
    batch = fbatch.least_norm_batch(op if scene == "paper" else propshaft_op, formulation)
    args = (batch.A, batch.b, batch.weights, batch.signed)
    compiled, plain = nb.least_norm(*args), nb._least_norm_numpy(*args)
    x, mu, nu = compiled[:3]
    assert np.abs(x - plain[0]).max() <= 1e-11 * np.abs(plain[0]).max()
    assert np.abs(nu - plain[2]).max() <= 1e-9 * max(np.abs(plain[2]).max(), 1.0)
    At = batch.A.transpose(0, 2, 1)
    Atmu = np.einsum("tnm,tm->tn", At, plain[1])
    assert np.abs(np.einsum("tnm,tm->tn", At, mu) - Atmu).max() <= 1e-9 * np.abs(Atmu).max()


def test_instants_whose_active_set_does_not_settle_are_solved_by_lemke(op):
    """No active-set step allowed: every instant goes to Lemke's method, same answer."""
    batch = fbatch.least_norm_batch(op, "compliance")
    args = (batch.A, batch.b, batch.weights, batch.signed)
    settled, forced = nb.least_norm(*args), nb.least_norm(*args, max_iter=0)
    assert not settled[4].any() and forced[4].all()
    for got, expected in zip(forced[:3:2], settled[:3:2]):  # forces, face multipliers
        assert np.abs(got - expected).max() <= 1e-9 * np.abs(expected).max()
    record = solve_batch(batch, "numpy-batched", max_iter=0)
    assert record.within(1e-9).all() and set(record.message) == {"Lemke fallback"}


def test_an_instant_answer_does_not_depend_on_its_batch(op):
    """Each instant is solved from its own numbers: alone, in a subset or reversed."""
    batch = fbatch.least_norm_batch(op, "positive")
    full = nb.least_norm(batch.A, batch.b, None, batch.signed)[0]
    for chosen in ([7], [40, 3, 17], list(range(40, -1, -1))):
        part = nb.least_norm(batch.A[chosen], batch.b[chosen], None, batch.signed)[0]
        assert np.array_equal(part, full[chosen])


def test_a_group_of_instants_where_only_some_take_a_refinement_step(op, monkeypatch):
    """The compiled pass solves instants in groups; with the refinement threshold between
    the instants' own residuals, some instants of a group take the step and others not:
    each still gets the NumPy path's answer, and the same answer alone as in the batch."""
    pytest.importorskip("numba")
    batch = fbatch.least_norm_batch(op, "positive")
    K = batch.A @ batch.A.transpose(0, 2, 1)
    delta = nb.GRAM_RTOL * np.trace(K, axis1=1, axis2=2) / K.shape[1]
    mu = np.linalg.solve(K + delta[:, None, None] * np.eye(K.shape[1]), batch.b[:, :, None])
    residual = np.linalg.norm(batch.b[:, :, None] - K @ mu, axis=(1, 2))
    relative = residual / np.linalg.norm(batch.b, axis=1)
    monkeypatch.setattr(nb, "REFINE_RTOL", float(np.median(relative)))
    args = (batch.A, batch.b, None, batch.signed)
    compiled, plain = nb.least_norm(*args)[0], nb._least_norm_numpy(*args)[0]
    assert np.abs(compiled - plain).max() <= 1e-11 * np.abs(plain).max()
    for i in (0, 9, 21, 40):
        alone = nb.least_norm(batch.A[[i]], batch.b[[i]], None, batch.signed)[0]
        assert np.array_equal(alone[0], compiled[i])


def test_compiled_active_set_equals_the_numpy_one():
    pytest.importorskip("numba")
    rng = np.random.default_rng(11)
    N = rng.standard_normal((200, 8, 7))
    M = N @ N.transpose(0, 2, 1)
    q = rng.uniform(0, 5, (200, 8)) - (N @ (10 * rng.standard_normal((200, 7, 1))))[:, :, 0]
    compiled = nb._active_set(M, q, 30)
    plain = nb._active_set_numpy(M, q, 30)
    for lam in (compiled[0], plain[0]):  # both solve every LCP (Lemke where they stall)
        w = np.einsum("tij,tj->ti", M, lam) + q
        assert lam.min() >= -1e-9 and w.min() >= -1e-9 and np.abs(lam * w).max() <= 1e-8
    assert np.allclose(np.einsum("tij,tj->ti", N.transpose(0, 2, 1), compiled[0]),
                       np.einsum("tij,tj->ti", N.transpose(0, 2, 1), plain[0]), atol=1e-9)


def test_a_batched_record_is_the_per_instant_record_of_the_same_answer(op):
    """One residual code, one status rule, one optimality code: finalizing instant k of
    a moreau batch on its own gives the same record as the batch's."""
    if "moreau" not in available():
        pytest.skip("moreau not installed")
    from cardan_forces.solvers.judge import finalize
    from cardan_forces.solvers.record import Outcome

    instants = np.arange(0, 41, 10)
    problems = fbatch.build_problems(op, "socp_face", instants)
    batch = fbatch.conic_batch(problems, instants)
    result = solve_batch(batch, "moreau")
    for k, problem in enumerate(problems):
        outcome = Outcome(str(result.status[k]), result.z[k], y=result.y[k])
        alone = finalize(problem, "moreau", outcome)
        batched = result.record(k)
        assert alone.status == batched.status
        for key, value in alone.residuals.items():
            assert batched.residuals[key] == pytest.approx(value, rel=1e-9, abs=1e-18)
        for key, value in alone.optimality.items():
            assert batched.optimality[key] == pytest.approx(value, rel=1e-9, abs=1e-18)


def test_the_kernels_layout_names_the_rows_structure(op):
    """Each field of the compiled kernel's layout says what the rows' pattern says: the
    columns touching each body, those two neighbouring bodies share, where each face
    sits in its body's list and the first body it touches."""
    batch = fbatch.least_norm_batch(op, "positive")
    pattern = nb.structure(batch.A)
    u, layout = nb._make_layout(pattern, np.flatnonzero(batch.signed))
    assert sorted(u) == sorted(np.flatnonzero(batch.signed))
    touching = [set(np.flatnonzero(pattern[s:s + 6].any(axis=0))) for s in layout.starts]
    assert sorted(layout.starts) == list(range(0, pattern.shape[0], 6))
    for k, cols in enumerate(touching):
        own = list(layout.own[k, :layout.n_own[k]])
        assert set(own) == cols
        for j, face in enumerate(u):
            assert (layout.upos[k, j] >= 0) == (face in cols)
            if layout.upos[k, j] >= 0:
                assert own[layout.upos[k, j]] == face
        if k + 1 < len(touching):
            shared = cols & touching[k + 1]
            a, b = (layout.sh_a[k, :layout.n_sh[k]], layout.sh_b[k, :layout.n_sh[k]])
            assert {own[p] for p in a} == shared
            assert [own[p] for p in a] == [layout.own[k + 1, p] for p in b]
    assert [min(k for k, cols in enumerate(touching) if f in cols) for f in u] == list(
        layout.first)


BUILT_PER_STRUCTURE = ("qocogen-reduced",)
"""Batched backends that compile a C solver per structure (seconds each, tested in
their own file): here only their choice of batch is checked."""


def _batched_backends() -> list[str]:
    return [name for name, backend in available().items() if backend.batch is not None]


DEFAULT_RUN_SCENES = ("paper", "axle-pinion", "paper-slip")
"""Scenes of the default run here: the plain line, a clearance (compliance conic) with
angular-contact bearings, a slip joint; the others run in the slow job."""


@pytest.mark.parametrize("scene", [
    s if s in DEFAULT_RUN_SCENES else pytest.param(s, marks=pytest.mark.slow)
    for s in builtin_names()])
def test_every_batched_backend_runs_each_formulation_it_is_offered_or_says_why(scene):
    """Every batched backend x every formulation x every built-in scene, a few instants:
    the batch a backend takes is the one the scene's problem forms (a clearance makes
    ``compliance`` conic, so never its least-norm batch), the bench offers the backend
    exactly where it takes that batch (else leaves it out, saying so), and the bench's
    run of it gives a row per instant, solved or with its reason; never an exception."""
    from cardan_forces.experiments import bench_run
    from cardan_forces.formulations.convex import NotApplicable

    loaded = load_scene(scene)
    op = build_operator(simulate(loaded, loaded.time.instants()[:3]))
    backends = _batched_backends()
    offered = bench_run.plan(op, solvers=backends)
    for name in FORMULATIONS:
        try:
            problems = fbatch.build_problems(op, name)
        except NotApplicable:
            assert name not in offered
            continue
        prepared = bench_run.prepare(op, name, np.arange(3))
        for solver in backends:
            kind = bench_run.batch_kind(solver, prepared)
            takes = kind is not None and solver in batch_backends(
                fbatch.make_batch(kind, op, name, problems, [0, 1]))
            assert takes == (solver in offered.get(name, ())), (name, solver, kind)
            if not takes or solver in BUILT_PER_STRUCTURE:
                continue
            if isinstance(problems[0], Conic):  # no diagonal least norm: its batch is conic
                assert kind == "conic", (name, solver)
            rows, _ = bench_run.run_batched(prepared, solver, repeats=1)
            assert len(rows) == 3, (name, solver)
            for row in rows:
                assert row["status"] == "solved" or row["message"].strip(), (name, solver)


def test_the_batches_a_formulation_forms_follow_its_problem_on_the_scene(op):
    """``compliance`` is a diagonal least norm on the paper scene and a conic problem
    with the axle pinion's clearances: its batches are the least-norm and the conic one
    there, only the conic one here (its least-norm batch refused, not misbuilt); a
    backend that accepts both takes the first it can."""
    axle = load_scene("axle-pinion")
    clearance = build_operator(simulate(axle, axle.time.instants()[:2]))
    both = (fbatch.LeastNormBatch, fbatch.ConicBatch)
    expected = {("paper", "compliance"): ("least_norm", "conic"),
                ("axle", "compliance"): ("conic",), ("paper", "lcp"): ("least_norm",),
                ("paper", "min_max"): ("conic",), ("paper", "paper"): ()}
    for (where, name), kinds in expected.items():
        scene_op = op if where == "paper" else clearance
        problem = FORMULATIONS[name](scene_op, 0)
        assert fbatch.batch_kinds(name, problem) == kinds
        assert fbatch.batch_kind(both, name, problem) == (kinds[0] if kinds else None)
        assert fbatch.batch_kind((fbatch.ConicBatch,), name, problem) == (
            "conic" if "conic" in kinds else None)
    with pytest.raises(ValueError, match="not a diagonal least norm"):
        fbatch.least_norm_batch(clearance, "compliance")
