"""The compiled penalty integrator never raises on numbers: a run whose state goes bad
ends with a failed status and a reason, and ``method="auto"`` then integrates again
with SciPy's LSODA. Constructed cases: a body of zero mass (every acceleration a
division by zero) and a compiled run reported failed.
"""

import numpy as np
import pytest
from cardan_forces.driveline import penalty, penalty_kernels
from cardan_forces.driveline.loading import load_scene
from cardan_forces.driveline.penalty_integrators import Marks, run_compiled

pytestmark = pytest.mark.compiled  # also run for a generic CPU by .ci/run

pytest.importorskip("numba")


@pytest.fixture(scope="module")
def model():
    return penalty._Model(load_scene("paper-penalty"), penalty.DAMPING_LENGTH_UNIT_M)


def _massless(model):
    """The model's kernel arrays with the first body's mass set to zero."""
    mass = model.arrays.mass.copy()
    mass[0] = 0.0
    return model.arrays._replace(mass=mass)


def test_a_division_by_zero_in_the_kernels_gives_non_finite_numbers(model):
    y0 = model.initial_state()
    dy = penalty_kernels.rhs(0.0, y0, _massless(model))
    assert not np.all(np.isfinite(dy))


def test_a_run_gone_bad_ends_failed_with_a_reason(model, monkeypatch):
    monkeypatch.setattr(model, "arrays", _massless(model))
    y0 = model.initial_state()
    t = np.array([0.0, 0.01])
    states = np.full((2, model.n_state), np.nan)
    atol, _ = model.tolerances(1e-8)
    status, message, _ = run_compiled(model, 0.0, y0, t, atol, states,
                                      Marks(None, 0.0, 0.01, 0.01))
    assert status == -1
    assert "t = " in message


def test_auto_falls_back_to_lsoda_where_the_compiled_run_fails(monkeypatch):
    def broken(model, t0, y0, t, atol, states, marks):
        return -1, "required step size is less than spacing between numbers at t = 0 s", \
            (0, 0, 0, 0)

    monkeypatch.setattr(penalty, "run_compiled", broken)
    scene = load_scene("paper-penalty")
    result = penalty.simulate_penalty(scene, [0.0, 0.005])
    assert result.status == 0
    assert result.method == penalty.FALLBACK
    assert result.message.startswith(f"{penalty.COMPILED} failed")
    assert all(np.all(np.isfinite(v)) for v in result.forces.values())
