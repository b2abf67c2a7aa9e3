"""Checks the penalty model's tests share: the compiled kernels held to the NumPy
model at a seeded state off rest, and a compiled run's forces held to the rigid
equilibrium."""

import numpy as np
from cardan_forces.driveline import penalty
from cardan_forces.driveline.dynamics import simulate
from cardan_forces.driveline.equilibrium import build_operator


def seeded_state(model, seed: int) -> np.ndarray:
    """The model's initial state moved off rest by a seeded draw: positions by
    micrometres, orientations by 1e-4, rates by 1e-3, so that every contact row is
    deflected and moving."""
    rng = np.random.default_rng(seed)
    nb = model.n_bodies
    y = model.initial_state()
    y[:3 * nb] += 2e-6 * rng.standard_normal(3 * nb)
    y[3 * nb:7 * nb] *= 1.0 + 1e-4 * rng.standard_normal(4 * nb)
    y[7 * nb:] += 1e-3 * rng.standard_normal(6 * nb)
    return y


def assert_compiled_equals_numpy(model, t: float, y: np.ndarray) -> None:
    """Right-hand side and Jacobian of the compiled kernels against the NumPy model's
    (its Jacobian by complex steps) at ``(t, y)``: accelerations to 1e-11 of their
    block's largest, the Jacobian to 1e-9 of each entry's row and column scale
    (offsets of micrometres taken between positions of metres lose digits in both)."""
    nb = model.n_bodies
    compiled, reference = model.rhs_compiled(t, y), model.rhs(t, y[:, None])[:, 0]
    for rows in np.split(np.arange(13 * nb), [3 * nb, 7 * nb, 10 * nb]):
        assert np.abs(compiled - reference)[rows].max() <= 1e-11 * np.abs(reference[rows]).max()
    _, step = model.tolerances(1e-8)
    exact, jac = model.jacobian(t, y, step), model.jacobian_compiled(t, y)
    scale = np.maximum(np.abs(exact).max(axis=1)[:, None], np.abs(exact).max(axis=0)[None, :])
    assert np.all(np.abs(jac - exact) <= 1e-9 * scale)


def balanced_run(scene, t: np.ndarray, late: np.ndarray):
    """A run of ``scene`` by the compiled BDF itself (no fallback) sampled at ``t``:
    the rigid operator, the forces ``x`` (instants, columns) and the median over
    ``late`` of the rigid equilibrium's residual ``||A x - b||`` over ``||A|| ||x||``."""
    result = penalty.simulate_penalty(scene, t, method=penalty.COMPILED)
    assert result.success, result.message
    op = build_operator(simulate(scene, t))
    x = np.array([result.forces[n] for n in op.names]).T
    residual = np.linalg.norm(np.einsum("tij,tj->ti", op.A, x) - op.b, axis=1)
    scale = np.linalg.norm(op.A, axis=(1, 2)) * np.linalg.norm(x, axis=1)
    return op, x, float(np.median(residual[late] / scale[late]))
