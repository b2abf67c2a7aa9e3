import re
from pathlib import Path

import numpy as np
import pytest
from cardan_forces.driveline.determinacy import determinacy
from cardan_forces.driveline.dynamics import simulate
from cardan_forces.driveline.equilibrium import build_operator
from cardan_forces.driveline.loading import load_scene
from cardan_forces.experiments.hard import CASES
from cardan_forces.experiments.paper_method import multistart, solve_paper
from cardan_forces.formulations import FORMULATIONS
from cardan_forces.formulations.convex import socp_face
from cardan_forces.formulations.paper import build_paper

TIMES = [0.5, 1.3, 2.77]


@pytest.fixture(scope="module")
def op(paper):
    return build_operator(simulate(paper, TIMES))


def _fd_jac(fun, z, h=1e-6):
    return np.array([(fun(z + h * e) - fun(z - h * e)) / (2 * h) for e in np.eye(len(z))]).T


@pytest.mark.parametrize("rim", [True, False])
def test_jacobian_matches_finite_differences(op, rim):
    problem = build_paper(op, 0, rim=rim)
    rng = np.random.default_rng(1)
    z = problem.z0 + rng.normal(size=problem.n)
    z[problem.end_faces] = rng.uniform(10.0, 100.0, len(problem.end_faces))
    J = problem.jac(z)
    assert J.shape == (34, 34)
    assert np.abs(J - _fd_jac(problem.fun, z)).max() <= 1e-7 * np.abs(J).max()


def test_square_system_and_names(op):
    problem = build_paper(op, 0)
    assert problem.n == 34 and problem.fun(problem.z0).shape == (34,)
    assert len(set(problem.unknown_names)) == 34
    assert problem.unknown_names[:5] == (
        "input.bearing.far.radial", "input.bearing.far.angle", "input.bearing.near.radial",
        "input.bearing.near.angle", "input.axial_sum",
    )
    assert "uj1.theta1" in problem.unknown_names and "uj2.f8" in problem.unknown_names
    assert FORMULATIONS["paper"](op, 0).formulation == "paper"  # the registry names it


def test_without_rim_the_paper_rows_are_the_operator(op):
    problem = build_paper(op, 0, rim=False)
    z = problem.z0 + np.random.default_rng(2).normal(size=problem.n)
    eq = op.A[0] @ problem.to_forces(z) - op.b[0]
    np.testing.assert_allclose(problem.fun(z)[:30], eq, atol=1e-9 * np.linalg.norm(op.b[0]))


def test_start_is_least_norm_without_end_faces(op):
    problem = build_paper(op, 0)
    x0 = problem.to_forces(problem.z0)[: len(op.names)]
    assert np.all(x0[op.unilateral] == 0)
    keep = ~op.unilateral
    ref = np.linalg.lstsq(op.A[0][:, keep], op.b[0], rcond=None)[0]
    np.testing.assert_allclose(x0[keep], ref, atol=1e-9 * np.linalg.norm(ref))


@pytest.mark.parametrize("method", ["hybr", "lm"])
@pytest.mark.parametrize("rim", [True, False])
@pytest.mark.parametrize("i", range(len(TIMES)))
def test_solves_and_satisfies_complementarity(op, i, rim, method):
    r = solve_paper(op, i, method=method, rim=rim)
    assert r["success"] and r["paper_residual"] < 1e-8
    x, scale = r["x"], np.linalg.norm(op.b[i])
    res = build_paper(op, i, rim=rim).checks.residuals(x)
    assert res["sign"] < 1e-8 and res["complementarity"] < 1e-8
    problem = build_paper(op, i, rim=rim)
    assert np.all(r["z"][problem.radial] >= 0)
    if rim:  # judged with the rim moments as end-face moments on their cones
        assert res["equilibrium"] < 1e-8 and res["cone"] < 1e-8
        # ... which the axis-contact operator lacks
        axis = np.linalg.norm(op.A[i] @ x[: len(op.names)] - op.b[i]) / scale
        assert 1e-6 < axis < 1e-2
    else:
        assert np.linalg.norm(op.A[i] @ x - op.b[i]) / scale < 1e-8
    # one closed loop: the 34 x 34 Jacobian is singular along its self-stress
    assert r["jac_rank"] == 33 and r["jac_cond"] > 1e12


@pytest.mark.parametrize("i", range(len(TIMES)))
def test_determinate_components_match_least_norm(op, i):
    d = determinacy(op, i)
    x = solve_paper(op, i, rim=False)["x"]
    det = d.determinate
    assert det.any()
    np.testing.assert_allclose(x[det], d.min_norm[det], atol=1e-6 * np.linalg.norm(d.min_norm))


def test_multistart_spreads_only_along_the_indeterminate_components(op):
    d = determinacy(op, 0)
    X = multistart(op, 0, n=8, seed=0, rim=False)
    assert X.shape[0] >= 4 and X.shape[1] == 36
    spread = X.max(axis=0) - X.min(axis=0)
    scale = np.linalg.norm(d.min_norm)
    assert spread[d.determinate].max() < 1e-6 * scale
    assert spread[~d.determinate].max() > 1e-3 * scale
    for x in X:
        assert np.linalg.norm(op.A[0] @ x - op.b[0]) < 1e-8 * np.linalg.norm(op.b[0])


def test_multistart_is_seeded(op):
    a = multistart(op, 0, n=3, seed=5)
    b = multistart(op, 0, n=3, seed=5)
    np.testing.assert_array_equal(a, b)


def test_unknown_method_is_refused(op):
    with pytest.raises(ValueError, match="unknown method"):
        solve_paper(op, 0, method="newton")


def test_rim_solution_balances_the_pin_with_explicit_contact_points(paper):
    """Independent of the operator: every contact at its rim/trunnion point (eqs. 15,
    18, 35-36, 41-43) and the massless pin in equilibrium (eqs. 55-56)."""
    motion = simulate(paper, [0.5])
    op = build_operator(motion)
    problem = build_paper(op, 0, rim=True)
    v = dict(zip(problem.unknown_names, solve_paper(op, 0, rim=True)["z"]))
    for j, joint in enumerate(paper.joints):
        e1, e2, e3 = (motion.kin.e1[j][0], motion.kin.e2[j][0], motion.kin.e3[j][0])
        g = lambda k, name=joint.name: v[f"{name}.{k}"]  # noqa: E731
        hs, rs, ht, rt = joint.hs_m, joint.rs_m, joint.ht_m, joint.rt_m
        t1, t2, t5, t6 = g("theta1"), g("theta2"), g("theta5"), g("theta6")
        rim1 = np.sign(np.sin((t2 - t1) / 2)) * (
            -np.sin((t1 + t2) / 2) * e2 + np.cos((t1 + t2) / 2) * e3)
        rim5 = np.sign(np.sin((t6 - t5) / 2)) * (
            np.cos((t5 + t6) / 2) * e1 - np.sin((t5 + t6) / 2) * e3)
        r1, r2 = (np.cos(t) * e2 + np.sin(t) * e3 for t in (t1, t2))
        r5, r6 = (np.sin(t) * e1 + np.cos(t) * e3 for t in (t5, t6))
        contacts = [
            (hs * e1 + rs * r1, -g("f1") * r1), (-hs * e1 + rs * r2, -g("f2") * r2),
            (ht * e1 + rt * rim1, -g("f3") * e1), (-ht * e1 - rt * rim1, g("f4") * e1),
            (hs * e2 + rs * r5, -g("f5") * r5), (-hs * e2 + rs * r6, -g("f6") * r6),
            (ht * e2 + rt * rim5, -g("f7") * e2), (-ht * e2 - rt * rim5, g("f8") * e2),
        ]
        scale = np.linalg.norm(op.b[0])
        assert np.linalg.norm(sum(f for _, f in contacts)) < 1e-9 * scale
        assert np.linalg.norm(sum(np.cross(p, f) for p, f in contacts)) < 1e-9 * scale * hs


def test_records_report_the_singular_jacobian(op):
    from cardan_forces.solvers import solve

    record = solve(build_paper(op, 0), "scipy-fsolve")
    assert record.status == "solved"
    assert "jacobian rank 33 of 34" in record.message


def test_formulations_solve_nothing():
    """Formulations build problems; every root finding and optimization goes through
    the solver registry (``solvers/``), which formulations must not import."""
    root = Path(__file__).resolve().parents[1] / "formulations"
    sources = sorted(root.glob("*.py"))
    assert any(path.name == "paper.py" for path in sources)
    pattern = re.compile(r"^\s*(?:from|import)\s+(?:scipy\.optimize|scipy\s+import\s+[^\n]*"
                         r"\boptimize\b|cardan_forces\.solvers|\.\.solvers)", flags=re.M)
    for path in sources:
        found = pattern.findall(path.read_text())
        assert not found, f"{path.name} imports {found}"


def test_canonical_flips_magnitudes_without_changing_forces(op):
    """``(-f, a) -> (f, a + pi)`` is a change of variables: without the rim the forces stay."""
    problem = build_paper(op, 0, rim=False)
    z = problem.z0 + np.random.default_rng(3).normal(size=problem.n)
    z[problem.radial[::2]] = -np.abs(z[problem.radial[::2]]) - 1.0
    flipped, any_flipped = problem.canonical(z)
    assert any_flipped and np.all(flipped[problem.radial] >= 0)
    assert np.all(np.abs(flipped[problem.angles]) <= np.pi)
    np.testing.assert_allclose(problem.to_forces(flipped), problem.to_forces(z),
                               atol=1e-9 * np.abs(problem.to_forces(z)).max())
    assert problem.canonical(flipped)[1] is False


def _least_norm_forces(problem, op, i, z):
    """The forces, then the end-face moments as the weighted least-norm ``m`` with
    ``M m`` = the rim terms of the paper's rows (``fun`` less ``A x - b``), by the
    pseudo-inverse (SVD, rank rule 1e-9): the rule ``to_forces`` follows.
    """
    n = len(op.names)
    x = problem.to_forces(z)[:n]
    M = problem.checks.A[:, n:]
    owner = [cone.apex for cone in problem.checks.cones for _ in cone.members]
    weight = np.sqrt(np.maximum(x[owner], 0.0))
    rim = problem.fun(z)[:len(M)] - (op.A[i] @ x - op.b[i])
    return np.concatenate([x, weight * (np.linalg.pinv(M * weight, rcond=1e-9) @ rim)])


@pytest.mark.parametrize("case", ["paper", "speed-1000", "gravity-horizontal"])
def test_face_moments_are_the_weighted_least_norm_split(case):
    """The closed-form split (each pair's rim moment shared in proportion to its faces'
    forces) equals the least-norm solve on random points, with some faces idle and some
    pulling (where no face of a pair pushes, the least-squares split is taken)."""
    scene = (load_scene("paper") if case == "paper" else
             next(c for c in CASES if c.name == case).scene("paper"))
    op = build_operator(simulate(scene, scene.time.start_s + np.array([0.0, 1e-3, 7e-3])))
    rng = np.random.default_rng(4)
    for i in range(len(op.t)):
        problem = build_paper(op, i)
        top = np.abs(problem.z0).max()
        for trial in range(12):
            z = problem.z0 + 0.3 * top * rng.normal(size=problem.n)
            faces = problem.end_faces
            z[faces] = rng.uniform(0.0, top, len(faces)) if trial % 2 else z[faces]
            z[faces[::2]] = 0.0 if trial % 3 == 0 else z[faces[::2]]
            want = _least_norm_forces(problem, op, i, z)
            got = problem.to_forces(z)
            assert np.abs(got - want).max() <= 1e-12 * np.abs(want).max()
            n = len(op.names)
            M = problem.checks.A[:, n:]
            assert np.allclose(M @ got[n:], M @ want[n:], atol=1e-12 * top)


def test_checks_are_socp_face_s(op):
    """The paper's answers are judged in ``socp_face``'s force space, built without it."""
    for i in range(len(op.t)):
        mine, theirs = build_paper(op, i).checks, socp_face(op, i).checks
        np.testing.assert_array_equal(mine.A, theirs.A)
        np.testing.assert_array_equal(mine.b, theirs.b)
        assert (mine.names, mine.pairs, mine.cones) == (theirs.names, theirs.pairs,
                                                        theirs.cones)
        np.testing.assert_array_equal(mine.unilateral, theirs.unilateral)


def test_stacked_forces_are_the_least_norm_split_at_each_instant(paper):
    """The map over many instants at once gives each instant the weighted least-norm
    split (:func:`_least_norm_forces`, by the pseudo-inverse), also where a pair
    without a pushing face sends an instant to the least-squares split; it refuses maps
    of two operators."""
    op = build_operator(simulate(paper, [0.2, 0.9, 1.6, 2.3]))
    problems = [build_paper(op, i) for i in range(len(op.t))]
    rng = np.random.default_rng(5)
    Z = np.array([p.z0 + rng.normal(size=p.n) for p in problems])
    faces = problems[0].end_faces
    Z[:, faces] = np.abs(Z[:, faces]) + 1.0
    Z[1, faces[:2]] = -1.0  # both faces of one pair pull, under a nonzero rim term
    maps = [p.to_forces for p in problems]
    stacked = type(maps[0]).stacked(maps, Z)
    each = np.array([_least_norm_forces(p, op, i, z) for i, (p, z) in enumerate(zip(problems,
                                                                                  Z))])
    np.testing.assert_allclose(stacked, each, rtol=0, atol=1e-12 * np.abs(each).max())
    other = build_paper(build_operator(simulate(paper, [0.2])), 0).to_forces
    with pytest.raises(ValueError, match="operators"):
        type(maps[0]).stacked([maps[0], other], Z[:2])


def test_a_jacobian_asked_again_at_a_point_is_its_own_copy(op):
    """The Jacobian remembered for a repeated point is that point's, and a caller that
    changes the array it got does not change what the next caller gets."""
    problem = build_paper(op, 1)
    z = problem.z0 + np.random.default_rng(6).normal(size=problem.n)
    first = problem.jac(z)
    first[:] = 0.0
    np.testing.assert_array_equal(problem.jac(z), build_paper(op, 1).jac(z))
    other = z + 1.0
    np.testing.assert_array_equal(problem.jac(other), build_paper(op, 1).jac(other))
