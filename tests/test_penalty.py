"""The penalty-contact simulation (paper eqs. 75-78) against the rigid model."""

import numpy as np
import pytest
from scipy.integrate import cumulative_trapezoid

from cardan_forces.driveline import penalty
from cardan_forces.driveline.contact import hertz_stiffness
from cardan_forces.driveline.determinacy import determinacy
from cardan_forces.driveline.dynamics import simulate
from cardan_forces.driveline.equilibrium import build_operator
from cardan_forces.driveline.penalty import contact_law, simulate_penalty
from cardan_forces.driveline.scene import load_scene

STOP_S = 0.2
LATE_S = 0.1  # after the play has closed (~0.07 s from rest) and the first impacts


@pytest.fixture(scope="module")
def scene():
    return load_scene("paper-penalty")


@pytest.fixture(scope="module")
def run(scene):
    marks = []
    result = simulate_penalty(scene, np.arange(0.0, STOP_S + 1e-9, 0.005), progress=marks.append)
    return result, marks


@pytest.fixture(scope="module")
def rigid(scene, run):
    return build_operator(simulate(scene, run[0].t))


def test_refuses_a_scene_without_the_effect(paper):
    with pytest.raises(ValueError, match="penalty_dynamics"):
        simulate_penalty(paper, [0.0, 0.01])


def test_contact_law_eqs_75_78():
    k, n, c, d_max = 1e10, 1.5, 1e7, 1e-5
    assert contact_law(-1e-6, -5.0, k, n, c, d_max) == 0.0
    assert contact_law(2e-5, 0.0, k, n, c, d_max) == pytest.approx(k * 2e-5**1.5)
    assert contact_law(2e-5, 1e-3, k, n, c, d_max) == pytest.approx(k * 2e-5**1.5 + c * 1e-3)
    # the cubic step is half way at half depth; a contact never pulls
    half = contact_law(5e-6, 1e-3, k, n, c, d_max) - k * 5e-6**1.5
    assert half == pytest.approx(0.5 * c * 1e-3)
    assert contact_law(1e-6, -1.0, k, n, c, d_max) == 0.0


def test_contact_parameters(scene):
    """Joints: Hertz K (eqs. 76-77), c_max = 1 % of K read in mm-N-s units; bearings:
    linear, c_max = 0.01 s times their stiffness."""
    contacts = penalty._Model(scene, penalty.DAMPING_LENGTH_UNIT_M).c
    k = hertz_stiffness(scene, scene.joints[0])
    joint, bearing = contacts.exponent == 1.5, contacts.exponent == 1.0
    assert joint.sum() == 16 and bearing.sum() == 12
    assert np.allclose(contacts.stiffness[joint], k)
    assert np.allclose(contacts.c_max[joint], 0.01 * k * 1e-3**0.5)
    assert np.allclose(contacts.c_max[bearing], 0.01 * scene.contact.bearing_stiffness_N_m)


def test_jacobian_colouring_is_exact(run):
    """The coloured, vectorized difference equals the column-by-column one (up to the
    round-off of a batched product) at a state with contacts pressed (shafts 15 um,
    pins 0.8 mm down) and every body moving.
    """
    model = penalty._Model(run[0].scene, penalty.DAMPING_LENGTH_UNIT_M)
    speeds = np.arange(model.n_state) >= 7 * model.n_bodies
    y = model.initial_state(0.0) + 1e-4 * speeds * np.random.default_rng(0).standard_normal(
        model.n_state)
    y[2:15:3] = [-1.5e-5] * 3 + [-8e-4] * 2  # vertical displacements of the 5 bodies
    assert np.sum(model.contacts(model.bodies(y[:, None]))[1] > 0) >= 10
    _, step = model.tolerances(1e-8)
    f0 = model.rhs(0.0, y[:, None])[:, 0]
    columns = [(model.rhs(0.0, (y + h * np.eye(len(y))[i])[:, None])[:, 0] - f0) / h
               for i, h in enumerate(step)]
    expected = np.array(columns).T
    error = np.abs(model.jacobian(0.0, y, step) - expected)
    assert error.max() <= 1e-9 * np.abs(expected).max()  # round-off of the batched call


def test_runs_to_the_end_with_progress(run):
    result, marks = run
    assert result.success, result.message
    assert marks == pytest.approx([0.1, 0.2])
    assert result.nfev > 0 and result.wall_s > 0
    assert np.all(np.isfinite(result.omega))


def test_forces_have_the_operators_names(run, rigid):
    assert tuple(run[0].forces) == rigid.names


def test_starts_centred_in_the_clearances(run, scene):
    result = run[0]
    assert result.penetration[0] == pytest.approx(-scene.contact.bearing_clearance_m)
    assert all(abs(f[0]) == 0.0 for f in result.forces.values())
    assert 0 < result.penetration[-1] < 1e-5  # micrometres once loaded


def test_angles_follow_the_rigid_model_within_the_play(run, scene):
    """From rest the input turns through the radial play before it meets the rest of the
    line: each shaft's angle leaves the rigid model's by at most the play of the whole
    line, 2 (rb - rs) / hs per joint (the trunnions at +-hs move oppositely), and by
    more than a tenth of it (the play is really there).
    """
    result = run[0]
    motion = simulate(scene, result.t)
    turned = lambda w: cumulative_trapezoid(w, result.t, initial=0.0, axis=1)  # noqa: E731
    lag = np.abs(turned(result.omega) - turned(motion.omega))
    play = sum(2.0 * j.radial_clearance_m / j.hs_m for j in scene.joints)
    assert 0.1 * play < lag.max() < play


def test_forces_satisfy_the_rigid_equilibrium(run, rigid):
    """``||A x - b|| / ||b||`` of the rigid operator at the same instants: what is left is
    the inertia of the clearance motion and the displaced geometry.
    """
    result = run[0]
    x = np.array([result.forces[name] for name in rigid.names]).T
    residual = np.linalg.norm(np.einsum("tij,tj->ti", rigid.A, x) - rigid.b, axis=1)
    relative = residual / np.linalg.norm(rigid.b, axis=1)
    late = result.t >= LATE_S
    assert np.median(relative[late]) < 2e-2
    assert np.max(relative[late]) < 0.2


def test_bearings_carry_the_weight_on_average(run, scene):
    result = run[0]
    vertical = sum(f for name, f in result.forces.items()
                   if name.startswith("bearing.") and name.endswith(".z"))
    weight = -scene.gravity_m_s2[2] * (sum(s.mass_kg for s in scene.shafts)
                                      + len(scene.joints) * scene.crosspin.mass_kg)
    late = result.t >= LATE_S
    assert np.mean(vertical[late]) == pytest.approx(weight, rel=0.02)


def test_end_faces_are_complementary(run, scene):
    forces = run[0].forces
    for joint in scene.joints:
        for a, b in (("F3", "F4"), ("F7", "F8")):
            pair = np.array([forces[f"{joint.name}.{a}"], forces[f"{joint.name}.{b}"]])
            assert np.all(pair >= 0.0)
            assert np.all(pair.min(axis=0) == 0.0)


def test_a_failed_integration_is_a_status(scene, monkeypatch):
    monkeypatch.setattr(penalty, "contact_law", lambda d, *args: np.full_like(d, np.nan))
    result = simulate_penalty(scene, [0.0, 0.005, 0.01])
    assert result.status == -1 and not result.success
    assert result.message
    assert np.all(np.isnan(result.omega[:, 1:]))


@pytest.mark.slow
def test_one_second_against_the_rigid_model(scene):
    """After the play has closed (t >= 0.5 s): speeds within a few percent, equilibrium
    up to the clearance motion's inertia, and the components the rigid model determines
    (out-of-plane bearing forces, the radial forces normal to the intermediate shaft's
    trunnions, the net end-face push of its yokes) equal to its values on average.
    """
    result = simulate_penalty(scene, np.arange(0.0, 1.0 + 1e-9, 0.005))
    assert result.success, result.message
    late = np.flatnonzero(result.t >= 0.5)
    motion = simulate(scene, result.t)
    op = build_operator(motion)
    assert np.all(np.abs(result.omega[:, late] / motion.omega[:, late] - 1.0) < 0.05)
    x = np.array([result.forces[name] for name in op.names]).T
    residual = np.linalg.norm(np.einsum("tij,tj->ti", op.A, x) - op.b, axis=1)
    assert np.median(residual[late] / np.linalg.norm(op.b[late], axis=1)) < 3e-2
    sets = [determinacy(op, i) for i in late]
    rigid = np.array([d.min_norm for d in sets])
    determinate = sets[0].determinate
    assert determinate.sum() == 8
    gap = np.abs(x[late].mean(axis=0) - rigid.mean(axis=0))
    assert np.all(gap[determinate] < 10.0)  # N; joint loads ~150 N, weight 2660 N
    for joint, push, pull in (("uj1", "F8", "F7"), ("uj2", "F4", "F3")):
        net = op.index(f"{joint}.{push}"), op.index(f"{joint}.{pull}")
        assert abs(np.mean(x[late, net[0]] - x[late, net[1]])
                   - np.mean(rigid[:, net[0]] - rigid[:, net[1]])) < 5.0
