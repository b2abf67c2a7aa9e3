"""The answer to an instant does not depend on what was solved before it.

Every backend that builds something once and reuses it (cvxpy's compiled problem with
Parameters, moreau's compiled structure, the batched least norm's shared factorization
work, and Clarabel, whose reused solver once scaled new numbers by an old instant's
equilibration) solves the same instants in two orders; each answer is compared with a
fresh solve of that instant alone, by the objective and the package's optimality
measures, within a bound tied to the requested tolerance, never by last digits.
"""

from __future__ import annotations

import numpy as np
import pytest
from cardan_forces.driveline.dynamics import simulate
from cardan_forces.driveline.equilibrium import build_operator
from cardan_forces.driveline.loading import load_scene
from cardan_forces.formulations import batch as fbatch
from cardan_forces.solvers import available, solve
from cardan_forces.solvers.judge import objective_value
from cardan_forces.solvers.registry import solve_batch

INSTANTS = (0, 10, 20)
TOL = 1e-8
"""Tolerance requested from the iterative solvers."""

AGREE = 100 * TOL
"""Relative objective difference allowed between two solves of one instant: each is
within about TOL of the optimum (interior point, relative gap), so 100 TOL is slack
for the measures' own rounding and nothing more."""

ORDERS = (INSTANTS, INSTANTS[::-1])


@pytest.fixture(scope="module")
def op():
    """The propshaft, where a reused Clarabel solver changed answers and statuses."""
    scene = load_scene("propshaft")
    return build_operator(simulate(scene, scene.time.instants()[:21]))


def _need(name: str) -> None:
    if name not in available():
        pytest.skip(f"{name} not installed")


def _same_answer(problem, record, fresh) -> None:
    """Both answered, the same optimal objective within :data:`AGREE`, and each as
    optimal as the other by the package's measures (dual and gap within 100 TOL)."""
    assert record.status.has_answer and fresh.status.has_answer, (record.message,
                                                                  fresh.message)
    ours, theirs = objective_value(problem, record.z), objective_value(problem, fresh.z)
    assert ours == pytest.approx(theirs, rel=AGREE, abs=AGREE * 1e-6)
    for key in ("dual", "gap"):
        assert record.optimality[key] <= max(AGREE, 10 * fresh.optimality[key])


def _fresh_caches(monkeypatch) -> None:
    """Empty every build-once cache of the per-instant backends and keep none."""
    from cardan_forces.solvers import cvxpy_

    monkeypatch.setattr(cvxpy_, "CACHE_SIZE", 0)
    monkeypatch.setattr(cvxpy_, "_PROBLEMS", {})


@pytest.mark.parametrize(("solver", "formulation"), [
    ("clarabel", "min_max"), ("clarabel", "compliance_hertz"), ("clarabel", "positive"),
    ("cvxpy-clarabel", "min_max"), ("cvxpy-ecos", "socp_face"),
])
def test_per_instant_answers_do_not_depend_on_the_order(op, monkeypatch, solver, formulation):
    _need(solver)
    problems = dict(zip(INSTANTS, fbatch.build_problems(op, formulation, INSTANTS)))
    runs = [{i: solve(problems[i], solver, tol=TOL) for i in order} for order in ORDERS]
    _fresh_caches(monkeypatch)
    for i in INSTANTS:
        fresh = solve(problems[i], solver, tol=TOL)
        for run in runs:
            _same_answer(problems[i], run[i], fresh)


@pytest.mark.parametrize("formulation", ["min_max", "compliance_hertz"])
def test_moreau_answers_do_not_depend_on_the_batch(op, monkeypatch, formulation):
    """A compiled structure reused by batches in two orders, against each instant
    solved alone by a newly compiled solver."""
    _need("moreau")
    from cardan_forces.solvers import moreau_

    problems = dict(zip(INSTANTS, fbatch.build_problems(op, formulation, INSTANTS)))
    runs = []
    for order in ORDERS:
        result = solve_batch(fbatch.conic_batch([problems[i] for i in order], order),
                             "moreau", tol=TOL)
        runs.append({i: result.record(k) for k, i in enumerate(order)})
    for i in INSTANTS:
        monkeypatch.setattr(moreau_, "_COMPILED", {})
        fresh = solve_batch(fbatch.conic_batch([problems[i]], [i]), "moreau", tol=TOL).record(0)
        for run in runs:
            _same_answer(problems[i], run[i], fresh)


@pytest.mark.parametrize("formulation", ["min_norm", "positive"])
def test_batched_least_norm_answers_do_not_depend_on_the_batch(op, formulation):
    """A direct method: an instant in a batch of others, in two orders, and alone give
    the same forces (unique optimum) to 1e-9, its accuracy after refinement."""
    alone = {i: solve_batch(fbatch.least_norm_batch(op, formulation, [i]), "numpy-batched")
             for i in INSTANTS}
    for order in ORDERS:
        result = solve_batch(fbatch.least_norm_batch(op, formulation, list(order)),
                             "numpy-batched")
        for k, i in enumerate(order):
            x, fresh = result.x[k], alone[i].x[0]
            assert np.linalg.norm(x - fresh) <= 1e-9 * np.linalg.norm(fresh)
            assert result.within(1e-9)[k] and alone[i].within(1e-9)[0]
