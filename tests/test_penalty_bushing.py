"""The penalty model's bushing (a linear six-way spring-damper, :meth:`ContactRows.bushing`)
on the released ``propshaft-disc``: its static law against the closed form, the
compiled kernels against the NumPy model, and the compiled integrator to the end."""

import numpy as np
import pytest
from cardan_forces.driveline import penalty
from cardan_forces.driveline.determinacy import determinacy
from cardan_forces.driveline.elements.base import DRAKE, PENALTY_SIMULATION
from cardan_forces.driveline.elements.disc_coupling import STIFFNESS
from cardan_forces.driveline.elements.registry import refusals
from cardan_forces.driveline.loading import scene_from_dict
from penalty_checks import assert_compiled_equals_numpy, balanced_run, seeded_state
from scipy.spatial.transform import Rotation

pytestmark = pytest.mark.compiled  # also run for a generic CPU by .ci/run


@pytest.fixture(scope="module")
def scene():
    return scene_from_dict({"extends": "propshaft-disc", "name": "propshaft-disc-released",
                            "effects": ["gravity", "inertia", "penalty_dynamics"]})


@pytest.fixture(scope="module")
def model(scene):
    return penalty._Model(scene, penalty.DAMPING_LENGTH_UNIT_M)


def _disc(model):
    link = next(k for k in model.operator.contacts if k.kind == "disc-coupling")
    disc = model.scene.elements[0]
    return link, disc


def _deflected(model, shift, turn):
    """The initial state at rest (no velocity) with the disc's downstream segment moved
    by ``shift`` (m, global) and turned by the rotation vector ``turn`` (rad, global)
    about the coupling's point.
    """
    link, _ = _disc(model)
    nb, body = model.n_bodies, link.body
    point = model.operator.points[0, link.columns[0]]
    y = model.initial_state()
    y[7 * nb:] = 0.0
    rotation = Rotation.from_rotvec(turn)
    centre = model.rest_centre[body]
    y[3 * body:3 * body + 3] = point + rotation.apply(centre - point) + shift - centre
    q = y[3 * nb + 4 * body:3 * nb + 4 * body + 4]
    turned = rotation * Rotation.from_quat(q[[1, 2, 3, 0]])
    y[3 * nb + 4 * body:3 * nb + 4 * body + 4] = turned.as_quat()[[3, 0, 1, 2]]
    return y


def _columns(model, y):
    link, _ = _disc(model)
    forces, _, _ = penalty._sample(model, y[None])
    return np.array([forces[model.operator.names[c]][0] for c in link.columns])


def test_the_penalty_simulation_takes_the_disc_and_the_engines_refuse_it(scene):
    assert refusals(scene, PENALTY_SIMULATION) == []
    assert any("disc coupling 'disc'" in why for why in refusals(scene, DRAKE))


@pytest.mark.parametrize("axis", range(3))
def test_static_deflection_gives_the_stiffness_in_the_links_columns(model, axis):
    """At rest, the downstream segment shifted by 10 um along axis ``i`` of the shaft's
    frame (r1, r2, axis) or turned by 2 mrad about it, about the coupling: the link's
    column along it is ``-k d`` (N) or ``-k sin(phi) cos(phi)`` (N m: the energy
    ``k sin(phi)^2 / 2`` of the bushing's ``theta = sin(phi)``) on the downstream
    segment, with the disc's own stiffness, and every other column zero to round-off.
    """
    link, disc = _disc(model)
    frame = model.operator.shaft_frames[link.shaft]
    k_trans = (disc.radial_stiffness_N_m,) * 2 + (disc.axial_stiffness_N_m,)
    k_rot = (disc.angular_stiffness_N_m_rad,) * 2 + (disc.torsional_stiffness_N_m_rad,)
    shift, phi = 1e-5, 2e-3
    moved = _columns(model, _deflected(model, shift * frame[axis], np.zeros(3)))
    expected = np.zeros(6)
    expected[axis] = -k_trans[axis] * shift
    assert moved == pytest.approx(expected, rel=1e-9, abs=1e-9 * abs(expected).max())
    turned = _columns(model, _deflected(model, np.zeros(3), phi * frame[axis]))
    expected = np.zeros(6)
    expected[3 + axis] = -k_rot[axis] * np.sin(phi) * np.cos(phi)
    assert turned == pytest.approx(expected, rel=1e-9, abs=1e-9 * abs(expected).max())


def test_bushing_damping_is_the_scenes_fraction_of_each_stiffness(model):
    """The six rows' ``c`` is the scene's damping fraction times their ``k`` (a linear
    law: the same read in any length unit), the springs along the shaft's frame.
    """
    c = model.c
    rows = np.flatnonzero(c.radial >= penalty.kernels.SPRING)
    assert len(rows) == 6
    fraction = model.scene.contact.damping_fraction_of_stiffness
    assert np.allclose(c.c_max[rows], fraction * c.stiffness[rows], rtol=1e-15)


@pytest.mark.skipif(not penalty.kernels.HAVE_NUMBA, reason="numba not installed")
@pytest.mark.parametrize("seed", range(3))
def test_compiled_bushing_equals_the_numpy_model(model, seed):
    """Right-hand side and Jacobian of the compiled kernels against the NumPy model's
    (its Jacobian by complex steps) at seeded states where every bushing row is
    deflected and moving: accelerations to 1e-11 of their block's largest, the
    Jacobian to 1e-9 of each entry's row and column scale (offsets of micrometres taken
    between positions of metres lose digits in both), the bushing's six deflections
    and forces to 1e-12.
    """
    y = seeded_state(model, seed)
    t = 0.01 * seed
    assert_compiled_equals_numpy(model, t, y)
    depth, push, _, _, _, _ = penalty.kernels.contact_forces(y, model.arrays)
    d, f, _, _, _ = model.contacts(model.bodies(y[:, None]))
    rows = model.c.radial >= penalty.kernels.SPRING
    assert np.all(np.abs(d[rows, 0]) > 0) and np.all(np.abs(f[rows, 0]) > 0)
    assert np.abs(depth[rows] - d[rows, 0]).max() <= 1e-12 * np.abs(d[rows]).max()
    assert np.abs(push[rows] - f[rows, 0]).max() <= 1e-12 * np.abs(f[rows]).max()


@pytest.mark.skipif(not penalty.kernels.HAVE_NUMBA, reason="numba not installed")
def test_compiled_integrator_finishes_on_the_disc_line(scene):
    """The compiled BDF itself (no fallback) runs the released line with its disc 0.1 s
    from rest; its forces satisfy the rigid equilibrium (``||A x - b||`` under 1 % of
    ``||A|| ||x||``, as ``propshaft``'s in test_penalty) and, over the second half, the
    torque through the disc equals the rigid model's on average within 1 %. Its shear
    and bending do not: the rubber disc bends under the couple it carries, away from the
    rigid model's geometry.
    """
    t = np.arange(0.0, 0.1 + 1e-9, 0.005)
    late = np.flatnonzero(t >= 0.05)
    op, x, residual = balanced_run(scene, t, late)
    assert residual < 0.01
    torque = op.names.index("disc.torque")
    rigid = np.mean([determinacy(op, i).min_norm[torque] for i in late])
    assert x[late, torque].mean() == pytest.approx(rigid, rel=0.01)


@pytest.mark.skipif(not penalty.kernels.HAVE_NUMBA, reason="numba not installed")
def test_compiled_integrator_steps_over_the_stiffest_disc():
    """The stiffest disc the kind accepts (a steel disc pack: 1e11 N/m, 1e9 and 1e10 N
    m/rad; its damped modes decay at up to ~6e8 1/s, the radial damping over the short
    segment's mass): the compiled BDF finishes 0.05 s from rest by itself.
    """
    stiffest = {key: within.most for key, within in STIFFNESS.items()}
    scene = scene_from_dict({
        "extends": "propshaft-disc", "name": "propshaft-steel-disc-released",
        "effects": ["gravity", "inertia", "penalty_dynamics"],
        "disc_couplings": [{"name": "disc", "shaft": "front_prop", "offset_m": -0.55,
                            **stiffest}]})
    result = penalty.simulate_penalty(scene, np.arange(0.0, 0.05 + 1e-9, 0.005),
                                      method=penalty.COMPILED)
    assert result.success, result.message
