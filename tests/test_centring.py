"""The centring device of a double-Cardan joint: where its ball sits, the pair's
constant velocity, the loops it adds and the release that takes it out."""

import numpy as np
import pytest
from cardan_forces.driveline.determinacy import determinacy
from cardan_forces.driveline.dynamics import simulate
from cardan_forces.driveline.elements.centring import KIND, meeting_point
from cardan_forces.driveline.equilibrium import build_operator
from cardan_forces.driveline.kinematics import kinematics, rest_geometry
from cardan_forces.driveline.loading import load_scene, scene_from_dict
from cardan_forces.driveline.release import released_scene
from cardan_forces.driveline.scene import SceneError


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


def test_models_without_non_adjacent_contacts_refuse_it_by_name(scene):
    assert "centring device 'ball'" in KIND.refusal(scene.elements[0], "the engine")
