"""Every formulation with every backend that takes it: residuals, agreement, sets."""

import dataclasses

import numpy as np
import pytest
from cardan_forces.driveline.determinacy import determinacy
from cardan_forces.driveline.dynamics import simulate
from cardan_forces.driveline.equilibrium import build_operator
from cardan_forces.experiments import study
from cardan_forces.experiments.analysis import solve_all
from cardan_forces.experiments.study import intervals
from cardan_forces.formulations import FORMULATIONS
from cardan_forces.formulations.convex import contacts, orthogonal_equalities
from cardan_forces.formulations.sets import interval_slack
from cardan_forces.solvers import Status, backends_for, solve

from tests.conftest import variant

# how closely a solved record must reproduce the determinate components (relative to
# the force scale); solvers not named use "default"
AGREEMENT = {"default": 1e-6, "scipy-lsq_linear": 1e-5, "qpsolvers-osqp": 1e-4,
             "qpsolvers-scs": 1e-4, "cvxpy-scs": 1e-4, "cvxpy-ecos": 1e-5,
             "qpsolvers-ecos": 1e-5}


@pytest.fixture(scope="module")
def paper_op(paper):
    return build_operator(simulate(paper, [0.5]))


@pytest.fixture(scope="module")
def paper_records(paper_op):
    return solve_all(paper_op, 0)


def test_every_formulation_has_a_solved_backend(paper_records):
    solved = {r.formulation for r in paper_records if r.status == "solved"}
    assert solved == set(FORMULATIONS) - {"friction"}  # paper has no friction


def test_solved_records_meet_their_residuals_and_agree_on_determinate_forces(
        paper_op, paper_records):
    d = determinacy(paper_op, 0)
    scale = np.abs(d.min_norm).max()
    for r in paper_records:
        if r.status != "solved":
            continue
        judged = ("equilibrium", "sign", "complementarity", "cone")
        assert all(r.residuals[k] <= 1e-6 for k in judged), r
        if len(r.names) != len(paper_op.names):
            continue  # end faces with moments (socp_face, paper's rim): another model
        tol = AGREEMENT.get(r.solver, AGREEMENT["default"])
        gap = np.abs(r.x - d.min_norm)[d.determinate].max() / scale
        assert gap <= tol, (r.formulation, r.solver, gap)


def test_positive_never_pulls_and_lcp_is_complementary(paper_op, paper_records):
    uni = paper_op.unilateral
    for r in paper_records:
        if r.status == "solved" and r.formulation in ("positive", "lcp", "compliance"):
            assert r.x[uni].min() >= -1e-6 * np.abs(r.x).max()
            for i, j in paper_op.pairs:
                assert min(r.x[i], r.x[j]) <= 1e-5 * np.abs(r.x).max()


def test_indeterminate_forces_differ_between_selection_rules(paper_records, paper_op):
    d = determinacy(paper_op, 0)
    best = {}
    for r in paper_records:
        if r.status == "solved" and r.solver == "clarabel" and len(r.x) == len(d.names):
            best[r.formulation] = r.x
    free = ~d.determinate
    # least norm with pulling end faces vs only pushing: the end faces differ
    assert np.abs(best["min_norm"] - best["positive"])[free].max() > 1.0
    # least peak load: no other member has a smaller worst contact
    peak = lambda x: max(np.linalg.norm(x[g]) for g in contacts(paper_op))  # noqa: E731
    for name, x in best.items():
        if name != "min_norm" and name != "min_norm_scaled":
            assert peak(best["min_max"]) <= peak(x) * (1 + 1e-6), name
    # ... and all agree where the model determines the force
    for x in best.values():
        assert np.allclose(x[d.determinate], d.min_norm[d.determinate], rtol=1e-6, atol=1e-6)


def test_every_answer_lies_in_the_solution_set(paper_op, paper_records):
    sets = intervals(paper_op, 0)
    d = determinacy(paper_op, 0)
    for j, name in enumerate(paper_op.names):
        lo, hi = sets[name]["min"], sets[name]["max"]
        if d.determinate[j]:
            assert lo == pytest.approx(d.min_norm[j], abs=1e-6)
            assert hi == pytest.approx(d.min_norm[j], abs=1e-6)
        for r in paper_records:
            if r.status == "solved" and r.formulation not in (
                    "min_norm", "min_norm_scaled", "socp_face", "paper"):
                slack = 1e-4 * np.abs(r.x).max()
                assert lo is None or r.x[j] >= lo - slack
                assert hi is None or r.x[j] <= hi + slack
    # the axial split between two bearings of a shaft is free in both directions
    assert sets["bearing.input.near.x"] == {"min": None, "max": None, "status": "solved"}


def _crossing_ends(monkeypatch, j: int, value: float, delta: float):
    """Every interval LP answers as if component ``j``'s ends were ``value + delta``
    (min) and ``value - delta`` (max): ends that cross by ``2 delta``.
    """
    def fake(problem, solver, **kwargs):
        record = solve(problem, solver, **kwargs)
        sign = 1.0 if problem.formulation == "interval.min" else -1.0
        x = np.zeros_like(record.x)
        x[j] = value + sign * delta
        return dataclasses.replace(record, status=Status.SOLVED, x=x)
    monkeypatch.setattr(study, "solve", fake)


def test_interval_ends_never_cross(paper_op, monkeypatch):
    """Ends within the problem's tolerance of each other are one value (their mean);
    ends that cross by more are not reported: min <= max always."""
    j = paper_op.index("bearing.input.near.x")
    c = np.eye(len(paper_op.names))[j]
    slack = interval_slack(paper_op, 0, c)
    _crossing_ends(monkeypatch, j, 250.0, 0.1 * slack)
    near = study.cold_range(paper_op, 0, c)
    assert near["min"] == near["max"] == pytest.approx(250.0, abs=slack)
    _crossing_ends(monkeypatch, j, 250.0, 10 * slack)
    far = study.cold_range(paper_op, 0, c)
    assert far["min"] is None and far["max"] is None and far["status"] == "inconsistent"


def test_interval_tolerance_follows_the_loads(paper_op):
    """The same line under loads 1e6 times larger: the crossing tolerance grows alike."""
    big = dataclasses.replace(paper_op, b=1e6 * paper_op.b)
    c = np.eye(len(paper_op.names))[paper_op.index("bearing.input.near.x")]
    assert interval_slack(big, 0, c) == pytest.approx(1e6 * interval_slack(paper_op, 0, c))


def test_a_determinate_component_is_its_value_whatever_its_lps_say(paper_op, monkeypatch):
    """A determinate component takes no LP: an LP failing on it (a badly scaled line)
    cannot make it unbounded. Every LP of a bound is made to fail here, warm and cold;
    the determinate components keep min = max = their value, the others say the
    failure."""
    real, warm = study.solve, study.ranges

    def warm_failing(lp, objectives, start=None):
        found = warm(lp, objectives, start)
        return dataclasses.replace(found, statuses=((Status.FAILED,) * 2,) * len(objectives))

    def failing(problem, solver, **kwargs):
        record = real(problem, solver, **kwargs)
        if problem.formulation.startswith("interval.") and problem.c.any():
            return dataclasses.replace(record, status=Status.FAILED)
        return record
    monkeypatch.setattr(study, "solve", failing)
    monkeypatch.setattr(study, "ranges", warm_failing)
    sets = study.intervals(paper_op, 0)
    d = determinacy(paper_op, 0)
    assert d.determinate.any() and not d.determinate.all()
    for j, name in enumerate(paper_op.names):
        entry = sets[name]
        if d.determinate[j]:
            assert entry["min"] == entry["max"] == pytest.approx(d.min_norm[j])
        else:
            assert entry["min"] is None and entry["max"] is None
            assert entry["status"] != "solved"


def test_lever_rule_on_a_straight_line():
    """Straight line, gravity only: every formulation gives the lever rule on the input
    shaft's vertical bearing forces (the intermediate shaft hangs half on each joint)."""
    joints = [dict(name=n, articulation_deg=0.0, hs_m=0.03, rs_m=0.005, rb_m=0.0052, ht_m=0.02,
                   hb_m=0.021, rt_m=0.006) for n in ("uj1", "uj2")]
    scene = variant(effects=["gravity"], joints=joints,
                    torque={"input": 0.0}, initial={"speed_rad_s": 0.0})
    op = build_operator(simulate(scene, [0.2]))
    m_in, m_mid = scene.shafts[0].mass_kg, scene.shafts[1].mass_kg
    g = 9.8
    near = (0.4 * m_in + 0.9 * m_mid / 2) * g / 0.8  # moments about the far bearing at 0.1 m
    far = (m_in + m_mid / 2) * g - near
    d = determinacy(op, 0)
    assert d.determinate[op.index("bearing.input.near.z")]
    for r in solve_all(op, 0, formulations=["min_norm", "positive", "lcp", "compliance"]):
        if r.status == "solved":
            tol = AGREEMENT.get(r.solver, AGREEMENT["default"])
            assert r.forces()["bearing.input.near.z"] == pytest.approx(near, rel=10 * tol)
            assert r.forces()["bearing.input.far.z"] == pytest.approx(far, rel=10 * tol)


def test_inconsistent_equilibrium_gives_no_solved_record(paper_op):
    """b off the range of A (the motion no longer obeys its own equation): no solver may
    report it solved, and none may raise."""
    d = determinacy(paper_op, 0)
    u, s, _ = np.linalg.svd(paper_op.A[0])
    bad_b = paper_op.b.copy()
    bad_b[0] += 1e3 * u[:, -1]  # a left null direction of A
    bad = dataclasses.replace(paper_op, b=bad_b)
    assert d.rank == 29
    for name in ("positive", "lcp", "compliance", "min_max"):
        problem = FORMULATIONS[name](bad, 0)
        for solver in backends_for(problem):
            record = solve(problem, solver)
            assert record.status != "solved", (name, solver)


def test_paper_rim_solution_is_a_member_of_the_face_cone_set(paper_records):
    """The paper's rim contacts put each end-face moment on its cone's boundary."""
    paper = [r for r in paper_records if r.formulation == "paper" and r.status == "solved"]
    face = [r for r in paper_records if r.formulation == "socp_face" and r.status == "solved"]
    assert paper and face and paper[0].names == face[0].names
    for r in paper:
        forces = r.forces()
        for name in ("uj1.F3", "uj1.F4", "uj2.F7", "uj2.F8"):
            moment = np.hypot(*[v for k, v in forces.items() if k.startswith(name + ".m_")])
            assert moment == pytest.approx(0.00625 * forces[name], rel=1e-9, abs=1e-9)


def _friction_op(mu):
    scene = variant(effects=["gravity", "inertia", "friction"],
                    contact={"friction_coefficient": mu})
    return build_operator(simulate(scene, [0.5]))


def test_friction_only_when_the_scene_asks(paper_op):
    from cardan_forces.formulations.convex import NotApplicable
    with pytest.raises(NotApplicable):
        FORMULATIONS["friction"](paper_op, 0)
    assert all(r.formulation != "friction" for r in solve_all(paper_op, 0))


def test_friction_cones_hold_and_vanish_without_friction():
    frictionless = _friction_op(1e-9)
    r0 = solve(FORMULATIONS["friction"](frictionless, 0), "clarabel")
    positive = solve(FORMULATIONS["positive"](frictionless, 0), "clarabel")
    assert r0.status == "solved" and positive.status == "solved"
    n = len(frictionless.names)
    assert np.allclose(r0.x[n:], 0, atol=1e-4)
    assert np.allclose(r0.x[:n], positive.x, atol=1e-4 * np.abs(positive.x).max())
    rough = _friction_op(0.2)
    r = solve(FORMULATIONS["friction"](rough, 0), "clarabel")
    assert r.status == "solved" and r.residuals["cone"] <= 1e-6
    # friction carries load: some tangential force is used, and the determinate
    # out-of-plane bearing forces do not change
    assert np.abs(r.x[n:]).max() > 1.0
    y = [rough.index(f"bearing.input.{b}.y") for b in ("near", "far")]
    assert np.allclose(r.x[y], positive.x[y], atol=1e-6)


def test_orthogonal_equalities_keep_the_feasible_set():
    """Rows with a held column (one of a pair of opposite columns) describe the same
    set as ``A x = b, x_held = 0``: mutually orthogonal rows, an orthonormal null-space
    basis of the right dimension, and every ``x0 + N y`` solves the original system."""
    rng = np.random.default_rng(3)
    A = rng.normal(size=(4, 6))
    A[:, 5] = -A[:, 4]  # a pair: holding column 5 leaves the column space as it is
    A[3] = A[0] + A[1]  # a dependent row: rank 3
    b = A @ np.array([1.0, -2.0, 0.5, 0.0, 3.0, 0.0])
    rows, rhs, basis = orthogonal_equalities(A, b, held=[5])
    gram = rows @ rows.T
    assert gram == pytest.approx(np.diag(np.diag(gram)), abs=1e-12)
    assert basis.shape == (6, 6 - 3 - 1)
    assert basis.T @ basis == pytest.approx(np.eye(2), abs=1e-12)
    x0 = rows.T @ (rhs / np.diag(gram))
    for y in (np.zeros(2), np.array([1.0, -4.0])):
        x = x0 + basis @ y
        assert A @ x == pytest.approx(b, abs=1e-10)
        assert x[5] == pytest.approx(0.0, abs=1e-12)


def test_holding_an_idle_faces_moments_keeps_the_optimum(paper, monkeypatch):
    """``socp_face`` holds an idle end face's moments at zero with the face (its cone
    ``||m|| <= rt * 0`` forces them there): the optimal value is the one of the problem
    where only the cone holds them."""
    from cardan_forces.formulations import convex

    op = build_operator(simulate(paper, [0.1, 0.35]))
    tight = [convex.socp_face(op, i) for i in range(2)]
    held = [solve(problem, "clarabel", tol=1e-10) for problem in tight]
    monkeypatch.setattr(convex, "_held", lambda idle, cones: list(idle))
    loose = [convex.socp_face(op, i) for i in range(2)]
    assert loose[0].null_space.shape[1] > tight[0].null_space.shape[1]  # the moments free
    for record, problem in zip(held, loose):
        free = solve(problem, "clarabel", tol=1e-10)
        assert record.status.has_answer and free.status.has_answer
        value = [0.5 * r.z @ problem.P @ r.z for r in (record, free)]
        assert value[0] == pytest.approx(value[1], rel=1e-7)


def test_scaled_map_of_many_instants_equals_its_calls():
    """``x = scale z[:n]``, a signed pair's force on its pushing face; the stacked map
    gives each instant's call, and refuses maps of two structures."""
    from cardan_forces.formulations.problems import Scaled

    maps = [Scaled(2.0, 3, ((0, 2),)), Scaled(3.0, 3, ((0, 2),))]
    Z = np.array([[1.0, -1.0, 5.0, 9.0], [-2.0, 4.0, 7.0, 9.0]])
    X = Scaled.stacked(maps, Z)
    assert X.tolist() == [[2.0, -2.0, 0.0], [0.0, 12.0, 6.0]]
    assert all(np.array_equal(X[k], maps[k](Z[k])) for k in range(2))
    with pytest.raises(ValueError, match="structures"):
        Scaled.stacked([Scaled(1.0), Scaled(1.0, 3)], Z)


def test_null_space_map_of_many_instants_equals_its_calls(paper):
    """The LCP's ``x = x0 + N N_u' lam``: the stacked map gives each instant's call to
    rounding, its forces hold equilibrium, and it refuses maps of two structures."""
    from cardan_forces.formulations.convex import NullSpaceMap

    op = build_operator(simulate(paper, [0.1, 0.3, 0.5]))
    problems = [FORMULATIONS["lcp"](op, i) for i in range(3)]
    maps = [p.to_forces for p in problems]
    Z = np.random.default_rng(2).uniform(0.0, 50.0, (3, len(problems[0].q)))
    X = NullSpaceMap.stacked(maps, Z)
    for k, (m, problem) in enumerate(zip(maps, problems)):
        scale = np.abs(X[k]).max()
        assert np.allclose(X[k], m(Z[k]), rtol=0.0, atol=1e-14 * scale)
        c = problem.checks
        assert np.linalg.norm(c.A @ X[k] - c.b) <= 1e-9 * np.linalg.norm(c.b)
    other = NullSpaceMap(maps[0].x0, maps[0].N, maps[0].unilateral[1:])
    with pytest.raises(ValueError, match="structures"):
        NullSpaceMap.stacked([maps[0], other], Z[:2, 1:])


def test_hertz_compliance_full_form_holds_equilibrium_on_a_straight_propshaft():
    """A straight line leaves the end faces idle, at their cones' apex; Clarabel on the
    full conic form must still reach equilibrium there (a form that put the signed face
    force straight into its power cone stalled it at 0.37 of the load)."""
    from cardan_forces.experiments.hard import CASES
    from cardan_forces.solvers import solve

    scene = next(c for c in CASES if c.name == "articulation-0").scene("propshaft")
    op = build_operator(simulate(scene, scene.time.instants()[:1]))
    record = solve(FORMULATIONS["compliance_hertz"](op, 0), "clarabel")
    assert record.residuals.equilibrium <= 1e-6
