"""Every available backend on every reference problem it accepts (known answers)."""

from __future__ import annotations

import numpy as np
import pytest
from cardan_forces.solvers import ACCEPT, backends_for, solve
from cardan_forces.solvers.reference_problems import references

TOL = 1e-9
"""Tolerance requested from every backend in the reference runs."""

ANSWER_TOL = {
    "default": 1e-6,
    "scipy-lsq_linear": 1e-4,  # Tikhonov bias, about TOL * cond^2
    "cvxpy-scs": 1e-4,
    "qpsolvers-scs": 1e-4,
    "cvxpy-ecos": 1e-4,  # a QP becomes an SOCP: the forces are only ~sqrt(gap) accurate
    "qpsolvers-ecos": 1e-4,
}
"""Largest relative distance of solved forces from the known answer, per backend."""

CERTIFIES = {
    "scipy-highs", "clarabel", "cvxpy-clarabel", "cvxpy-ecos", "cvxpy-scs", "cvxpy-osqp",
    "qpsolvers-clarabel", "qpsolvers-ecos", "qpsolvers-osqp", "qpsolvers-piqp",
    "qpsolvers-proxqp", "qpsolvers-scs",
}
"""Backends that report infeasibility and unboundedness (the others just fail)."""

REFERENCES = references()
CASES = [(ref, name) for ref in REFERENCES for name in backends_for(ref.problem)]
IDS = [f"{ref.name}-{name}" for ref, name in CASES]
SOLVABLE = [(ref, name) for ref, name in CASES if ref.status == "solved"]


def _checked(residuals: dict[str, float]) -> dict[str, float]:
    return {k: v for k, v in residuals.items() if k != "reference"}


def test_every_reference_has_a_backend():
    assert all(backends_for(ref.problem) for ref in REFERENCES)


@pytest.mark.parametrize(("ref", "name"), CASES, ids=IDS)
def test_reference(ref, name):
    record = solve(ref.problem, name, tol=TOL, reference=ref.x)
    assert record.solver == name and record.names == ref.problem.checks.names
    assert record.setup_s >= 0 and record.solve_s >= 0
    if ref.status == "solved":  # the answer is judged, not the solver's word on it
        assert record.status.has_answer, record.message
        assert max(_checked(record.residuals).values()) <= ACCEPT
        assert record.residuals["reference"] <= ANSWER_TOL.get(name, ANSWER_TOL["default"])
    else:
        assert record.status != "solved", record.message
        if name in CERTIFIES or record.status in ("infeasible", "unbounded"):
            assert record.status == ref.status, record.message
        if record.status != "inaccurate":
            assert np.all(np.isnan(record.x))
            assert all(v == np.inf for v in _checked(record.residuals).values())


@pytest.mark.parametrize(("ref", "name"), SOLVABLE, ids=[f"{r.name}-{n}" for r, n in SOLVABLE])
def test_reference_with_solver_defaults(ref, name):
    """With tol=None every backend answers; looser defaults may only make it inaccurate."""
    record = solve(ref.problem, name, reference=ref.x)
    assert record.status.has_answer, record.message
    assert np.all(np.isfinite(record.x))
    if record.status == "inaccurate":
        assert record.message
