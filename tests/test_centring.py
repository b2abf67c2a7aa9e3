"""The centring device of a double-Cardan joint: where its ball sits, the pair's
constant velocity, the loops it adds, the release that takes it out and its penalty
contact (the ball held on the bore's axis)."""

import numpy as np
import pytest
from cardan_forces.driveline import penalty
from cardan_forces.driveline.determinacy import determinacy
from cardan_forces.driveline.dynamics import simulate
from cardan_forces.driveline.elements.base import DRAKE, MUJOCO, PENALTY_SIMULATION
from cardan_forces.driveline.elements.centring import KIND, meeting_point
from cardan_forces.driveline.elements.registry import refusals
from cardan_forces.driveline.equilibrium import build_operator
from cardan_forces.driveline.kinematics import kinematics, rest_geometry
from cardan_forces.driveline.loading import load_scene, scene_from_dict
from cardan_forces.driveline.release import released_scene
from cardan_forces.driveline.scene import SceneError
from penalty_checks import assert_compiled_equals_numpy, balanced_run, seeded_state
from scipy.spatial.transform import Rotation


@pytest.fixture(scope="module")
def scene():
    return load_scene("double-cardan")


def test_the_ball_sits_where_the_outer_axes_meet(scene):
    """Half the centre yoke over the cosine of one joint's angle beyond the first cross,
    on the input's axis and on the output's."""
    geo = rest_geometry(scene)
    point = meeting_point(geo.joint_centres[0], geo.axes[0], geo.joint_centres[1],
                          geo.axes[2])
    reach = 0.05 / np.cos(np.radians(15.0))
    assert np.allclose(point, geo.joint_centres[0] + reach * geo.axes[0], atol=1e-15)
    off_output = point - geo.joint_centres[1]
    assert np.linalg.norm(np.cross(off_output, geo.axes[2])) < 1e-15


def test_the_pair_turns_the_output_at_the_inputs_speed(scene):
    kin = kinematics(rest_geometry(scene), np.linspace(0.0, 2 * np.pi, 25))
    assert np.allclose(kin.ratio[-1], 1.0, rtol=0, atol=1e-12)
    assert np.ptp(kin.ratio[1]) > 0.05  # the centre yoke itself does not


def test_the_ball_adds_two_loops_and_its_force_is_not_unique(scene):
    op = build_operator(simulate(scene, [0.3]))
    without = build_operator(simulate(released_scene(scene, [
        KIND.releases(scene)[0]]), [0.3]))
    d, w = determinacy(op, 0), determinacy(without, 0)
    assert d.nullity == w.nullity + 2
    ball = [op.names.index(f"ball.{c}") for c in ("r1", "r2")]
    assert not d.determinate[ball].any()
    x = d.min_norm
    assert np.linalg.norm(op.A[0] @ x - op.b[0]) <= 1e-9 * np.linalg.norm(op.b[0])


@pytest.mark.parametrize("device", [{"name": "b", "shaft": "centre_yoke", "offset_m": 0.01},
                                    {"name": "b", "shaft": "transfer"}])
def test_a_ball_off_the_centre_yokes_middle_is_refused(device):
    with pytest.raises(SceneError, match="sits in the middle"):
        scene_from_dict({"extends": "double-cardan", "centring_devices": [device]})


def test_drake_refuses_it_by_name_and_mujoco_takes_it(scene):
    assert "centring device 'ball'" in KIND.refusal(scene.elements[0], DRAKE)
    assert KIND.refusal(scene.elements[0], MUJOCO) is None


def test_mujocos_carrier_slides_along_the_driven_axis_from_the_ball(scene):
    """:meth:`Centring.mjcf_loop`: the carrier hangs on the driven shaft's first body by
    a slide along that shaft's axis, at the ball's centre (the link's point)."""
    from cardan_forces.driveline.engine_mujoco import start_of

    op = build_operator(simulate(scene, [0.0]))
    link = next(c for c in op.contacts if c.element == "ball")
    host, step = KIND.mjcf_loop(link, start_of(op))
    assert host == link.body and step.type == "slide" and step.speed == 0.0
    assert np.allclose(step.axis, op.shaft_frames[link.shaft][2], atol=1e-12)
    assert np.allclose(step.point, op.points[0, link.columns[0]], atol=1e-12)


# ------------------------------------------------------------------ penalty model


def _released():
    return scene_from_dict({"extends": "double-cardan", "name": "double-cardan-released",
                            "effects": ["gravity", "inertia", "penalty_dynamics"]})


@pytest.fixture(scope="module")
def penalty_model():
    return penalty._Model(_released(), penalty.DAMPING_LENGTH_UNIT_M)


def _ball(model):
    return next(link for link in model.operator.contacts if link.kind == "centring-ball")


def test_the_penalty_simulation_takes_it_and_the_engines_refuse_it():
    scene = _released()
    assert refusals(scene, PENALTY_SIMULATION) == []
    assert any("centring device 'ball'" in why for why in refusals(scene, DRAKE))


@pytest.mark.parametrize("component", range(3))
def test_its_penalty_row_holds_the_ball_on_the_bores_axis_and_lets_it_slide(
        penalty_model, component):
    """The driven shaft shifted by 1 um along its frame's ``r1``, ``r2`` (normal to the
    bore) or axis, at rest: the ball's columns are ``-k d`` along the shift normal to
    the bore and zero along it (N), ``k`` the bearing stiffness."""
    model, nb = penalty_model, penalty_model.n_bodies
    link = _ball(model)
    frame = model.operator.shaft_frames[link.shaft]
    y = model.initial_state()
    y[7 * nb:] = 0.0
    y[3 * link.body:3 * link.body + 3] += 1e-6 * frame[component]
    forces, _, _ = penalty._sample(model, y[None])
    columns = np.array([forces[model.operator.names[c]][0] for c in link.columns])
    k, expected = model.scene.contact.bearing_stiffness_N_m, np.zeros(2)
    if component < 2:
        expected[component] = -k * 1e-6
    assert columns == pytest.approx(expected, abs=1e-9 * k * 1e-6)


def test_its_penalty_row_stays_unloaded_as_either_shaft_spins(penalty_model):
    """The ball's centre lies on both outer shafts' axes: turning either about its axis
    by any angle leaves it on the bore's axis."""
    model, nb = penalty_model, penalty_model.n_bodies
    link = _ball(model)
    geo = model.motion.geometry
    row = np.flatnonzero(model.c.radial == penalty.kernels.LINE)
    for body in (link.body, link.other):
        y = model.initial_state()
        turn = Rotation.from_rotvec(2.1 * geo.axes[model.segments[body].shaft])
        q = y[3 * nb + 4 * body:3 * nb + 4 * body + 4]
        y[3 * nb + 4 * body:3 * nb + 4 * body + 4] = (
            turn * Rotation.from_quat(q[[1, 2, 3, 0]])).as_quat()[[3, 0, 1, 2]]
        d, _, _, _, _ = model.contacts(model.bodies(y[:, None]))
        assert np.abs(d[row]).max() < 1e-15


@pytest.mark.compiled
@pytest.mark.skipif(not penalty.kernels.HAVE_NUMBA, reason="numba not installed")
@pytest.mark.parametrize("seed", range(2))
def test_compiled_line_row_equals_the_numpy_model(penalty_model, seed):
    """Right-hand side and Jacobian of the compiled kernels against the NumPy model's at
    seeded states where the ball is off the bore's axis and moving, to the bushing
    test's tolerances."""
    model = penalty_model
    y = seeded_state(model, seed)
    t = 0.01 * seed
    assert_compiled_equals_numpy(model, t, y)
    depth, push, _, _, _, _ = penalty.kernels.contact_forces(y, model.arrays)
    d, f, _, _, _ = model.contacts(model.bodies(y[:, None]))
    row = model.c.radial == penalty.kernels.LINE
    assert depth[row] == pytest.approx(d[row, 0], rel=1e-12)
    assert push[row] == pytest.approx(f[row, 0], rel=1e-12)


@pytest.mark.compiled
@pytest.mark.skipif(not penalty.kernels.HAVE_NUMBA, reason="numba not installed")
def test_compiled_integrator_finishes_on_the_double_cardan_line():
    """The compiled BDF itself (no fallback) runs the released ``double-cardan`` 0.05 s
    from rest (its rattle starting), the ball pushing."""
    t = np.arange(0.0, 0.05 + 1e-9, 0.005)
    op, x, _ = balanced_run(_released(), t, t >= 0.0)
    ball = [op.names.index(f"ball.{c}") for c in ("r1", "r2")]
    assert np.abs(x[-1, ball]).max() > 100.0


@pytest.mark.slow
@pytest.mark.compiled
@pytest.mark.skipif(not penalty.kernels.HAVE_NUMBA, reason="numba not installed")
def test_the_ball_takes_load_within_the_rigid_set_and_leaves_the_crosses_alone():
    """0.8 s of the released ``double-cardan`` with and without its ball, averaged over
    the last two periods of the crosses' loads (0.2 pi s at 10 rad/s): the ball's
    forces stay within the rigid set (the equilibrium's residual under 2.5 %, as
    without the ball: the crosses' rattle at 15 deg and 1500 N m), it carries a load
    normal to the bore of the rigid set's sign (its size the compliances' choice: the
    set does not fix it) and the crosses' trunnion forces are the same as without it
    within 1 % (the ball relieves the bearings, not the crosses).
    """
    t = np.arange(0.0, 0.8 + 1e-9, 0.005)
    late = t >= 0.8 - 0.2 * np.pi
    with_ball = _released()
    without = released_scene(with_ball, [KIND.releases(with_ball)[0]])
    op, x, residual = balanced_run(with_ball, t, late)
    op_free, x_free, residual_free = balanced_run(without, t, late)
    assert residual < 0.025 and residual_free < 0.025
    r2 = op.names.index("ball.r2")
    rigid = np.mean([determinacy(op, i).min_norm[r2] for i in np.flatnonzero(late)])
    assert abs(x[late, r2].mean()) > 1e3 and np.sign(x[late, r2].mean()) == np.sign(rigid)
    for name in op_free.names:
        if ".F" in name and (name.endswith(".e1") or name.endswith(".e2")):
            mine, free = x[late, op.index(name)].mean(), x_free[late, op_free.index(name)].mean()
            assert mine == pytest.approx(free, rel=0.01, abs=20.0)
