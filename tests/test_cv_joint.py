"""The constant-velocity joint kind: homokinetic kinematics at any angle, its moment
about the bisector against the closed form of a CV joint's secondary couple, its compiled
form held to the NumPy reference, its checks, the models that refuse it and its penalty
model (a bushing homokinetic in twist, free in bending)."""

import dataclasses

import numpy as np
import pytest
from cardan_forces.driveline import dynamics, penalty
from cardan_forces.driveline.determinacy import determinacy
from cardan_forces.driveline.dynamics import simulate
from cardan_forces.driveline.elements.base import DRAKE, MUJOCO, PENALTY_SIMULATION
from cardan_forces.driveline.elements.cv import KIND, bisector
from cardan_forces.driveline.elements.registry import refusals
from cardan_forces.driveline.equilibrium import build_operator
from cardan_forces.driveline.kinematics import kinematics, rest_geometry
from cardan_forces.driveline.loading import load_scene, scene_from_dict
from cardan_forces.driveline.scene import SceneError
from penalty_checks import assert_compiled_equals_numpy, balanced_run, seeded_state
from scipy.spatial.transform import Rotation

TORQUE = 1000.0


def _quasi_static(**changes):
    """``halfshaft`` without gravity: its joints carry the torque alone."""
    return scene_from_dict({"extends": "halfshaft", "effects": [], **changes})


def test_the_driven_shaft_turns_with_the_driving_one_at_any_angle():
    scene = load_scene("halfshaft")
    q = np.linspace(0.0, 2 * np.pi, 13)
    kin = kinematics(rest_geometry(scene), q)
    assert np.allclose(kin.phi, q, rtol=0, atol=1e-15)
    assert np.all(kin.ratio == 1.0) and np.all(kin.ratio_dq == 0.0)


@pytest.mark.parametrize("angles", [(6.0, 10.0), (20.0, 45.0)])
def test_its_moment_is_the_torque_over_the_half_angles_cosine(angles):
    """Seherr-Thoss et al. (2006): a CV joint passes the torque ``T`` on and bends each
    shaft by ``T tan(beta/2)``: the moment about the bisector is ``T / cos(beta/2)``."""
    joints = [{"name": n, "kind": "cv", "articulation_deg": a}
              for n, a in zip(("inboard", "outboard"), angles)]
    op = build_operator(simulate(_quasi_static(joints=joints), [0.2]))
    d = determinacy(op, 0)
    geo = rest_geometry(op.scene)
    for j, (name, beta) in enumerate(zip(("inboard", "outboard"), angles)):
        k = op.names.index(f"{name}.moment")
        assert d.determinate[k]
        half = np.radians(beta) / 2
        assert d.min_norm[k] == pytest.approx(TORQUE / np.cos(half), rel=1e-9)
        moment = d.min_norm[k] * bisector(geo.axes[j], geo.axes[j + 1])
        driven = geo.axes[j + 1]
        along = moment @ driven
        across = np.linalg.norm(moment - along * driven)
        assert along == pytest.approx(TORQUE, rel=1e-9)
        assert across == pytest.approx(TORQUE * np.tan(half), rel=1e-9)


def test_the_compiled_reduced_equation_equals_the_arrays(monkeypatch):
    """A line mixing both joint kinds, with inertia: the compiled right-hand side is
    taken (it reproduces the array path) and agrees with it."""
    scene = scene_from_dict({"extends": "paper", "effects": ["inertia", "crosspin_inertia"],
                             "joints": [{"name": "cv1", "kind": "cv", "articulation_deg": 30.0},
                                        dataclasses.asdict(load_scene("paper").joints[1])]})
    geometry = rest_geometry(scene)
    rhs = dynamics._right_hand_side(scene, geometry)
    q = np.array([0.1, 0.9, 2.3])
    expected = dynamics._acceleration(scene, kinematics(geometry, q), 0.7, np.full(3, 2.0))
    got = np.array([rhs(0.7, np.array([a, 2.0]))[1] for a in q])
    assert np.allclose(got, expected, rtol=1e-12, atol=0)
    if dynamics.HAVE_NUMBA:
        assert rhs.__name__ == "<lambda>"  # the compiled one, not the array fallback


def test_an_angle_beyond_a_fixed_joints_reach_is_refused():
    with pytest.raises(SceneError, match="articulation_deg': 60 deg is outside -50 to 50"):
        _quasi_static(joints=[{"name": "a", "kind": "cv", "articulation_deg": 60.0},
                              {"name": "b", "kind": "cv", "articulation_deg": 10.0}])


def test_a_cardan_field_on_a_cv_joint_is_named():
    with pytest.raises(SceneError, match=r"joints\[0\].hs_m': unknown key"):
        _quasi_static(joints=[{"name": "a", "kind": "cv", "articulation_deg": 6.0,
                               "hs_m": 0.02},
                              {"name": "b", "kind": "cv", "articulation_deg": 10.0}])


def test_drake_refuses_it_by_name_and_mujoco_takes_it():
    joint = load_scene("halfshaft").joints[0]
    assert "constant-velocity joint 'inboard'" in KIND.refusal(joint, DRAKE)
    assert KIND.refusal(joint, MUJOCO) is None


@pytest.mark.parametrize("j", [0, 1])
def test_mujocos_three_hinges_start_homokinetic_with_still_bodies_between(j):
    """:meth:`CV.mjcf_steps`: hinges through the centre about ``a_in``, the shafts'
    normal and ``a_out``; their speeds leave the engine bodies between them still and
    give the driven shaft the driving one's spin about its own axis; the coupling ties
    the last hinge to minus the first."""
    from cardan_forces.driveline.engine_mujoco import start_of

    op = build_operator(simulate(load_scene("halfshaft"), [0.0]))
    link = [c for c in op.contacts if c.kind == "cv-joint"][j]
    start = start_of(op)
    steps = KIND.mjcf_steps(link, link.body, start)
    a_in, a_out = start.geo.axes[j], start.geo.axes[j + 1]
    assert [s.type for s in steps] == ["hinge"] * 3
    assert np.allclose(steps[0].axis, a_in) and np.allclose(steps[2].axis, a_out)
    assert abs(steps[1].axis @ a_in) < 1e-12 and abs(steps[1].axis @ a_out) < 1e-12
    spin = start.speed * start.kin.ratio[j, 0] * a_in
    assert np.allclose(spin + steps[0].speed * a_in, 0.0, atol=1e-12)
    driven = spin + sum(s.speed * s.axis for s in steps)
    assert np.allclose(driven, start.speed * start.kin.ratio[j + 1, 0] * a_out, atol=1e-12)
    coupling = KIND.mjcf_couplings(link, ["psi", "beta", "chi"], "")
    assert 'joint1="chi" joint2="psi" polycoef="0 -1 0 0 0"' in coupling


# ------------------------------------------------------------------ penalty model


def _released(name="halfshaft"):
    return scene_from_dict({"extends": name, "name": f"{name}-released",
                            "effects": ["gravity", "inertia", "penalty_dynamics"]})


@pytest.fixture(scope="module")
def penalty_model():
    return penalty._Model(_released(), penalty.DAMPING_LENGTH_UNIT_M)


def _moved(model, body, point, turn, shift=(0.0, 0.0, 0.0)):
    """The start state at rest with ``body`` turned by the rotation vector ``turn``
    (rad, global) about ``point`` and shifted by ``shift`` (m)."""
    nb = model.n_bodies
    y = model.initial_state()
    y[7 * nb:] = 0.0
    rotation, centre = Rotation.from_rotvec(turn), model.rest_centre[body]
    y[3 * body:3 * body + 3] = point + rotation.apply(centre - point) - centre + shift
    q = y[3 * nb + 4 * body:3 * nb + 4 * body + 4]
    turned = rotation * Rotation.from_quat(q[[1, 2, 3, 0]])
    y[3 * nb + 4 * body:3 * nb + 4 * body + 4] = turned.as_quat()[[3, 0, 1, 2]]
    return y


def _joint_columns(model, link, y):
    forces, _, _ = penalty._sample(model, y[None])
    return np.array([forces[model.operator.names[c]][0] for c in link.columns])


def _cv_links(model):
    return [link for link in model.operator.contacts if link.kind == "cv-joint"]


def test_the_penalty_simulation_takes_it_and_the_engines_refuse_it():
    scene = _released()
    assert refusals(scene, PENALTY_SIMULATION) == []
    assert any("constant-velocity joint 'inboard'" in why
               for why in refusals(scene, DRAKE))


def test_its_penalty_rows_stay_unloaded_while_the_shafts_turn_homokinetically(
        penalty_model):
    """Both shafts turned about their own axes by the same angle (any angle: the
    homokinetic motion, the driven shaft the driving one's mirror in the bisecting
    plane): every spring and twist row of both joints reads zero to round-off."""
    model = penalty_model
    geo, nb = model.motion.geometry, model.n_bodies
    rows = np.flatnonzero(model.c.radial >= penalty.kernels.SPRING)
    for angle in (0.3, 1.7, 4.0):
        y = model.initial_state()
        for body, segment in enumerate(model.segments):
            turn = Rotation.from_rotvec(angle * geo.axes[segment.shaft])
            q = y[3 * nb + 4 * body:3 * nb + 4 * body + 4]
            y[3 * nb + 4 * body:3 * nb + 4 * body + 4] = (
                turn * Rotation.from_quat(q[[1, 2, 3, 0]])).as_quat()[[3, 0, 1, 2]]
        d, _, _, _, _ = model.contacts(model.bodies(y[:, None]))
        assert np.abs(d[rows]).max() < 1e-14


def test_its_penalty_law_is_stiff_in_twist_and_translation_and_free_in_bending(
        penalty_model):
    """The driven shaft turned about the joint centre by 0.1 mrad about the bisector: the
    moment column is ``-k (1 m)^2 psi`` (N m: the rigid law's stiffness, the twist
    row's ``theta = cos(beta/2) sin(psi)``-ish to second order); bent by 1 mrad about
    either axis normal to it: no force and no moment beyond second order; shifted by
    1 um normal to the shafts' plane: ``-k d``, within it: ``-k cos(beta) d`` (the
    symmetric stiffness ``k (Q + Q^T) / 2``)."""
    model = penalty_model
    k = model.scene.contact.bearing_stiffness_N_m
    for link in _cv_links(model):
        geo = model.motion.geometry
        a_in, a_out = geo.axes[link.shaft], geo.axes[link.shaft + 1]
        b = bisector(a_in, a_out)
        n = np.cross(a_in, a_out) / np.linalg.norm(np.cross(a_in, a_out))
        centre = model.operator.points[0, link.columns[0]]
        psi = 1e-4
        twisted = _joint_columns(model, link, _moved(model, link.body, centre, psi * b))
        assert twisted[3] == pytest.approx(-k * psi, rel=1e-6)
        assert np.abs(twisted[:3]).max() < 1e-6 * k * psi
        for axis in (n, np.cross(b, n)):
            bent = _joint_columns(model, link, _moved(model, link.body, centre, 1e-3 * axis))
            assert np.abs(bent).max() < 1e-6 * k * 1e-3
        cos_beta = float(a_in @ a_out)
        frame = model.operator.shaft_frames[link.shaft]
        for direction, stiffness in ((n, k), (np.cross(n, a_in), k * cos_beta)):
            shifted = _joint_columns(model, link, _moved(model, link.body, centre,
                                                         np.zeros(3), 1e-6 * direction))
            force = shifted[:3] @ frame  # the columns are along the driving shaft's frame
            assert force == pytest.approx(-stiffness * 1e-6 * direction, abs=1e-9 * k * 1e-6)


@pytest.mark.compiled
@pytest.mark.skipif(not penalty.kernels.HAVE_NUMBA, reason="numba not installed")
@pytest.mark.parametrize("seed", range(2))
def test_compiled_cv_rows_equal_the_numpy_model(penalty_model, seed):
    """Right-hand side and Jacobian of the compiled kernels against the NumPy model's at
    seeded states where every row is deflected and moving, to the bushing test's
    tolerances."""
    model = penalty_model
    y = seeded_state(model, seed)
    t = 0.01 * seed
    assert_compiled_equals_numpy(model, t, y)


@pytest.mark.compiled
@pytest.mark.skipif(not penalty.kernels.HAVE_NUMBA, reason="numba not installed")
def test_compiled_run_on_the_halfshaft_averages_to_the_rigid_set():
    """The compiled BDF itself (no fallback) runs the released ``halfshaft`` 0.1 s from
    rest; its forces satisfy the rigid equilibrium (``||A x - b||`` under 1 % of ``||A||
    ||x||``) and over the second half every load the rigid model determines (the CV
    joints' forces and moments among them) equals its value on average within 2 % of
    the largest (the hub's rows, ~2.1 kN)."""
    scene = _released()
    t = np.arange(0.0, 0.1 + 1e-9, 0.005)
    late = np.flatnonzero(t >= 0.05)
    op, x, residual = balanced_run(scene, t, late)
    assert residual < 0.01
    sets = [determinacy(op, i) for i in late]
    determinate = np.logical_and.reduce([d.determinate for d in sets])
    assert all(determinate[op.index(f"{j}.moment")] for j in ("inboard", "outboard"))
    rigid = np.array([d.min_norm for d in sets])[:, determinate].mean(axis=0)
    gap = np.abs(x[late][:, determinate].mean(axis=0) - rigid)
    assert gap.max() < 0.02 * np.abs(rigid).max()
