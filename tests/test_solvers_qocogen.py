"""The generated-QOCO backend (``qocogen-reduced``): a C solver compiled per structure.

Checked on a problem whose answer is known by hand (the point of a line nearest to a
point, an SOCP with one equality row), on the package's ``min_max`` against Clarabel by
objective and optimality measures, for answers that do not depend on the order of the
instants, and for its cache (a structure is compiled once). Skipped without qocogen or
a C compiler.
"""

from __future__ import annotations

import numpy as np
import pytest
from cardan_forces.driveline.dynamics import simulate
from cardan_forces.driveline.equilibrium import build_operator
from cardan_forces.driveline.loading import load_scene
from cardan_forces.formulations import batch as fbatch
from cardan_forces.formulations.problems import Conic, ForceChecks
from cardan_forces.solvers import ACCEPT, available, solve
from cardan_forces.solvers.judge import objective_value
from cardan_forces.solvers.registry import solve_batch

SOLVER = "qocogen-reduced"
TOL = 1e-8
AGREE = 100 * TOL
INSTANTS = (0, 7, 15)

pytestmark = pytest.mark.skipif(SOLVER not in available(),
                                reason="qocogen or a C compiler is not installed")


def _nearest(level: float) -> Conic:
    """min t s.t. x1 + x2 = level, ||(x1 - 3, x2)|| <= t over z = (x1, x2, t)."""
    checks = ForceChecks(A=np.array([[1.0, 1.0, 0.0]]), b=np.array([level]),
                         names=("x1", "x2", "t"), unilateral=np.zeros(3, bool))
    A = np.array([[1.0, 1.0, 0.0], [0.0, 0.0, -1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])
    return Conic(checks=checks, formulation="ref", P=None, q=np.array([0.0, 0.0, 1.0]),
                 A=A, b=np.array([level, 0.0, -3.0, 0.0]),
                 cones=(("zero", 1), ("soc", 3)))


@pytest.fixture
def fresh_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("CARDAN_FORCES_CACHE", str(tmp_path))
    return tmp_path


def test_nearest_point_of_a_line(fresh_cache):
    # the point of x1 + x2 = c nearest to (3, 0) is (3, 0) - (3 - c)/2 (1, 1), at
    # distance (3 - c)/sqrt(2)
    levels = (2.0, 1.0)
    batch = fbatch.conic_batch([_nearest(c) for c in levels], [0, 1])
    result = solve_batch(batch, SOLVER, tol=TOL)
    assert set(result.status) == {"solved"}, result.message
    for k, c in enumerate(levels):
        expected = [3 - (3 - c) / 2, -(3 - c) / 2, (3 - c) / np.sqrt(2)]
        assert result.z[k] == pytest.approx(expected, abs=1e-6)
    assert np.all(result.optimality.within(ACCEPT))


def _nearest_on(a: float, level: float) -> Conic:
    """:func:`_nearest` on the line ``x1 + a x2 = level`` (``a = 0``: one nonzero fewer)."""
    problem = _nearest(level)
    A, checks = problem.A.copy(), problem.checks
    A[0, 1] = a
    checks = ForceChecks(A=A[:1].copy(), b=checks.b, names=checks.names,
                         unilateral=checks.unilateral)
    return Conic(checks=checks, formulation="ref", P=None, q=problem.q, A=A, b=problem.b,
                 cones=problem.cones)


def test_a_cached_solver_whose_pattern_covers_a_batch_is_reused(fresh_cache):
    """A batch with a nonzero fewer (other instants of the same problem) is solved by the
    cached solver of the fuller pattern, not compiled again; its answer is its own."""
    from cardan_forces.solvers import qocogen_

    qocogen_.solve_batch(fbatch.conic_batch([_nearest_on(1.0, 2.0)], [0]))
    sparser = qocogen_.solve_batch(fbatch.conic_batch([_nearest_on(0.0, 2.0)], [0]),
                                   tol=TOL)
    assert len(list(fresh_cache.glob("qocogen/*.so"))) == 1
    assert sparser.z[0] == pytest.approx([2.0, 0.0, 1.0], abs=1e-6)  # (c, 0), t = 3 - c


def test_a_structure_is_compiled_once(fresh_cache):
    from cardan_forces.solvers import qocogen_

    batch = fbatch.conic_batch([_nearest(2.0)], [0])
    first = qocogen_.solve_batch(batch)
    assert len(list(fresh_cache.glob("qocogen/*.so"))) == 1
    again = qocogen_.solve_batch(batch)
    assert first.stages["compile"] > 0.0 and again.stages["compile"] == 0.0
    assert np.array_equal(first.z, again.z)


def test_unknown_option_is_a_failed_batch():
    batch = fbatch.conic_batch([_nearest(2.0)], [0])
    result = solve_batch(batch, SOLVER, not_a_setting=1)
    assert set(result.status) == {"failed"} and "not_a_setting" in result.message[0]


@pytest.fixture(scope="module")
def min_max():
    scene = load_scene("paper")
    op = build_operator(simulate(scene, scene.time.instants()[:16]))
    return fbatch.build_problems(op, "min_max", INSTANTS)


def test_min_max_agrees_with_clarabel(min_max):
    result = solve_batch(fbatch.conic_batch(min_max, INSTANTS), SOLVER, tol=TOL)
    for k, problem in enumerate(min_max):
        fresh = solve(problem, "clarabel", tol=TOL)
        record = result.record(k)
        assert record.status == "solved", record.message
        assert max(record.residuals[key] for key in ("equilibrium", "sign", "cone")) <= ACCEPT
        ours, theirs = objective_value(problem, record.z), objective_value(problem, fresh.z)
        assert ours == pytest.approx(theirs, rel=AGREE, abs=AGREE * 1e-6)
        for key in ("dual", "gap"):
            assert record.optimality[key] <= max(AGREE, 10 * fresh.optimality[key])


def test_answers_do_not_depend_on_the_order(min_max):
    """One workspace per batch, its numbers replaced instant by instant: in either order
    each instant gets the same answer, to the last digit."""
    forward = solve_batch(fbatch.conic_batch(min_max, INSTANTS), SOLVER, tol=TOL)
    backward = solve_batch(fbatch.conic_batch(min_max[::-1], INSTANTS[::-1]), SOLVER, tol=TOL)
    assert np.array_equal(forward.z, backward.z[::-1])


@pytest.mark.slow
def test_line_search_takes_the_bisections_steps(min_max, tmp_path, monkeypatch):
    """The closed-form line search rounds the step to the cones' boundary down to the
    bisection's grid, so the solver takes QOCO's own steps: its answers are those of the
    generated solver with its bisection (built apart, into another cache), to rounding.
    A step off that grid (the boundary's own) ends elsewhere within the tolerance."""
    from cardan_forces.solvers import qocogen_

    batch = fbatch.conic_batch(min_max, INSTANTS)
    ours = solve_batch(batch, SOLVER, tol=TOL)
    monkeypatch.setenv("CARDAN_FORCES_CACHE", str(tmp_path))
    monkeypatch.setattr(qocogen_, "_exact_steps", lambda cone: None)
    bisected = solve_batch(batch, SOLVER, tol=TOL)
    assert set(ours.status) == set(bisected.status) == {"solved"}
    np.testing.assert_allclose(ours.z, bisected.z, rtol=0.0, atol=1e-12)


@pytest.mark.parametrize("caller_sets_refinement", [False, True])
def test_unsolved_instants_are_solved_again_refined(fresh_cache, monkeypatch,
                                                    caller_sets_refinement):
    """An instant the first call leaves unsolved (made so here: its code replaced by
    'numerical error') is solved again alone with iterative refinement, its iterations
    added; the others keep their first answer. A caller's own ``iter_ref_iters`` is
    final: no second call."""
    from cardan_forces.solvers import qocogen_

    calls, real = [], qocogen_._run

    def run(library, dims, values, chosen):
        out = real(library, dims, values, chosen)
        calls.append((len(values[1]), *(chosen[qocogen_.SETTINGS.index(name)]
                                         for name in ("iter_ref_iters", "bisect_iters"))))
        if len(calls) == 1:
            out[4][1] = 3
        return out

    monkeypatch.setattr(qocogen_, "_run", run)
    batch = fbatch.conic_batch([_nearest(c) for c in (2.0, 1.0, 0.5)], [0, 1, 2])
    options = {"iter_ref_iters": 0} if caller_sets_refinement else {}
    result = qocogen_.solve_batch(batch, **options)
    dims, masks, rows = qocogen_._structure(batch)
    library, masks, _ = qocogen_._library(dims, masks)
    values = qocogen_._data(batch, masks, rows)
    alone = real(library, dims, [v[1:2] for v in values],
                 qocogen_._options(None, qocogen_.REFINED))
    first = (3, qocogen_.DEFAULTS["iter_ref_iters"], qocogen_.DEFAULTS["bisect_iters"])
    if caller_sets_refinement:
        assert calls == [first] and result.status[1] == "failed"
    else:
        again = (1, qocogen_.REFINED["iter_ref_iters"], qocogen_.REFINED["bisect_iters"])
        assert calls == [first, again] and set(result.status) == {"solved"}
        assert np.array_equal(result.z[1], alone[0][0])
        assert result.iterations[1] > alone[3][0]


def test_status_rule_by_table():
    """Solved only where the generated solver says so and its own dual residual and gap
    are within the claim; its inaccurate codes are inaccurate, any other code failed;
    a message names the code wherever an instant is not solved."""
    from cardan_forces.solvers.qocogen_ import CLAIM_TOL, _statuses

    codes = np.array([1, 1, 2, 4, 3, 9], np.int32)
    info = np.zeros((6, 3))
    info[1, 2] = 10 * CLAIM_TOL  # a gap beyond the claim
    status, messages = _statuses(codes, info)
    assert list(status) == ["solved", "inaccurate", "inaccurate", "inaccurate", "failed",
                            "failed"]
    assert messages[0] == "" and all("qocogen: " in m for m in messages[1:])
    assert "9" in messages[5]


def test_a_relative_cache_folder_builds_and_solves(tmp_path, monkeypatch):
    """A relative ``CARDAN_FORCES_CACHE`` (resolved against the working folder, not the
    compiler's): the solver is built into it and solves."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("CARDAN_FORCES_CACHE", "relative")
    result = solve_batch(fbatch.conic_batch([_nearest(2.0)], [0]), SOLVER, tol=TOL)
    assert set(result.status) == {"solved"}, result.message
    assert len(list((tmp_path / "relative" / "qocogen").glob("*.so"))) == 1


def _compiler_fails(monkeypatch, tmp_path):
    monkeypatch.setenv("CC", "false")


def _compiler_errs(monkeypatch, tmp_path):
    script = tmp_path / "cc"
    script.write_text("#!/bin/sh\necho 'a.c:1: note: first' >&2\n"
                      "echo 'collect2: error: ld returned 1 exit status' >&2\nexit 1\n")
    script.chmod(0o755)
    monkeypatch.setenv("CC", str(script))


def _generation_raises(monkeypatch, tmp_path):
    import qocogen

    def broken(*args, **kwargs):
        raise ValueError("first line\nsecond line")

    monkeypatch.setattr(qocogen, "generate_solver", broken)


def _cache_is_a_file(monkeypatch, tmp_path):
    (tmp_path / "file").write_text("not a folder")
    monkeypatch.setenv("CARDAN_FORCES_CACHE", str(tmp_path / "file"))


def _loading_fails(monkeypatch, tmp_path):
    from cardan_forces.solvers import qocogen_

    def refuse(path, *args, **kwargs):
        raise OSError(f"{path}: cannot open shared object file")

    monkeypatch.setattr(qocogen_.ctypes, "CDLL", refuse)


@pytest.mark.parametrize("fault", [_compiler_fails, _compiler_errs, _generation_raises,
                                   _cache_is_a_file, _loading_fails])
def test_a_solver_that_cannot_be_built_is_a_failed_batch_with_one_line(
        fresh_cache, monkeypatch, tmp_path, fault):
    """Whatever step fails (generation, compilation, the cache folder, loading): every
    instant is a failed record whose message is one line saying the solver could not
    be built and why; a second batch of the structure fails at once, not built again."""
    from cardan_forces.solvers import qocogen_

    fault(monkeypatch, tmp_path)
    builds = []
    real = qocogen_._build
    monkeypatch.setattr(qocogen_, "_build", lambda *a: builds.append(1) or real(*a))
    batch = fbatch.conic_batch([_nearest(c) for c in (2.0, 1.0)], [0, 1])
    for _ in range(2):
        result = solve_batch(batch, SOLVER)
        assert set(result.status) == {"failed"}
        (message,) = set(result.message)
        assert qocogen_.UNBUILT in message and "\n" not in message
    assert len(builds) <= 1
    if fault is _compiler_errs:
        assert message.endswith("collect2: error: ld returned 1 exit status")
