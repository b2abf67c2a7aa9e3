"""The gear mesh in the penalty simulation: the line's torque taken off (or brought onto)
its end shaft as the mesh force at the mesh point (:meth:`Model._line_loads`), its
moment about the axis the torque, the compiled kernels held to the NumPy model, and a
compiled run whose bearing loads average to the rigid model's."""

import numpy as np
import pytest
from cardan_forces.driveline import penalty
from cardan_forces.driveline.determinacy import determinacy
from cardan_forces.driveline.elements.base import DRAKE, PENALTY_SIMULATION
from cardan_forces.driveline.elements.bodies import frames_of
from cardan_forces.driveline.elements.gear_mesh import KIND
from cardan_forces.driveline.elements.registry import refusals
from cardan_forces.driveline.loading import scene_from_dict
from penalty_checks import assert_compiled_equals_numpy, balanced_run, seeded_state

pytestmark = pytest.mark.compiled  # also run for a generic CPU by .ci/run

MESHES = [
    # a helical gear drives the input shaft (a transfer gear's output, 25 deg helix)
    {"name": "drive", "shaft": "input", "offset_m": 0.0, "pitch_radius_m": 0.08,
     "helix_angle_deg": 25.0, "mesh_angle_deg": 90.0},
    # a hypoid pinion takes the load off the last shaft (transfer-output's)
    {"name": "hypoid", "shaft": "pinion", "offset_m": 0.1, "type": "hypoid",
     "pitch_radius_m": 0.034, "pitch_cone_angle_deg": 14.0, "spiral_angle_deg": 48.0,
     "hand": "left", "gear_spiral_angle_deg": 30.0, "mesh_angle_deg": 90.0},
]
"""A mesh at each end of ``axle-pinion`` (the paper's line on an axle pinion's tapered
pair, already a penalty scene)."""

TORQUE = {"kind": "constant", "value_N_m": 400.0}
"""In and out (the paper's 10 N m and no load would leave the meshes idle): the
hypoid's tangential force ~12 kN."""


@pytest.fixture(scope="module")
def scene():
    return scene_from_dict({"extends": "axle-pinion", "name": "axle-pinion-meshed",
                            "gear_meshes": MESHES,
                            "torque": {"input": TORQUE, "load": TORQUE}})


@pytest.fixture(scope="module")
def model(scene):
    return penalty._Model(scene, penalty.DAMPING_LENGTH_UNIT_M)


def test_the_penalty_simulation_takes_a_mesh_and_the_engines_refuse_it(scene):
    assert refusals(scene, PENALTY_SIMULATION) == []
    assert any("gear mesh 'drive'" in why for why in refusals(scene, DRAKE))


@pytest.mark.parametrize("t", [0.0, 0.013])
def test_each_end_takes_the_mesh_force_whose_moment_is_the_torque(model, t):
    """At rest: on the body holding each mesh, no torque about its axis but the mesh
    force (N), the kind's own at the torque it takes (minus the input torque on the
    first shaft, the load torque on the last), at the mesh point; its moment about the
    shaft's axis (N m) is the input torque on the first shaft and minus the load torque
    on the last.
    """
    scene, geo = model.scene, model.motion.geometry
    nb = model.n_bodies
    centre = np.repeat(model.rest_centre[:, :, None], 2, axis=2)
    rot = np.repeat(model.start_frames[..., None], 2, axis=3)
    force, moment = model.line_loads(t, centre, rot)
    for end, (shaft, torque) in enumerate([(0, -scene.input_torque(t)),
                                           (len(scene.shafts) - 1, scene.load_torque(t))]):
        gear = MESHES[end]["name"]
        element = next(e for e in scene.elements if e.name == gear)
        point, expected = KIND.load(element, np.array([torque]), frames_of(geo)[shaft],
                                    geo.centres[shaft])
        body = model.load_bodies[end]
        assert model.segments[body].shaft == shaft
        assert force[body, :, 0] == pytest.approx(expected[0], rel=1e-12)
        about_axis = np.cross(point - geo.centres[shaft], expected[0]) @ geo.axes[shaft]
        assert about_axis == pytest.approx(-torque, rel=1e-12)
        arm = np.cross(point - model.rest_centre[body], expected[0])
        assert moment[body, :, 0] == pytest.approx(arm, rel=1e-12, abs=1e-9 * abs(arm).max())
    others = np.setdiff1d(np.arange(nb), model.load_bodies)
    assert not force[others].any() and not moment[others].any()


def test_without_a_mesh_the_torques_stay_pure_torques():
    plain = penalty._Model(scene_from_dict({"extends": "axle-pinion", "name": "plain"}),
                           penalty.DAMPING_LENGTH_UNIT_M)
    assert plain.load_bodies.tolist() == [0, plain.n_shafts - 1]
    assert plain.loads[:, 0].tolist() == [1.0, -1.0] and not plain.loads[:, 1:].any()


@pytest.mark.skipif(not penalty.kernels.HAVE_NUMBA, reason="numba not installed")
@pytest.mark.parametrize("seed", range(2))
def test_compiled_mesh_loads_equal_the_numpy_model(model, seed):
    """Right-hand side and Jacobian of the compiled kernels against the NumPy model's at
    seeded states off rest (the mesh force's moment about the body's moved centre, and
    its rate, included), to the tolerances of the bushing's test.
    """
    y = seeded_state(model, seed)
    t = 0.01 + 0.02 * seed
    assert_compiled_equals_numpy(model, t, y)


@pytest.mark.skipif(not penalty.kernels.HAVE_NUMBA, reason="numba not installed")
def test_compiled_run_with_meshes_averages_to_the_rigid_bearing_loads(scene):
    """The compiled BDF itself (no fallback) runs the meshed line 0.2 s from rest; its
    forces satisfy the rigid equilibrium (``||A x - b||`` under 1 % of ``||A|| ||x||``,
    the mesh forces in ``b``), and over the second half each bearing load the rigid
    model determines (the rows normal to the shafts' plane: the pinion's ~2.3 kN from
    the hypoid's separating and axial forces) equals its value on average within 5 %
    of the largest. The joints still rattle in their play after 0.2 s, so their loads
    are left out, as in ``paper-slip``'s test.
    """
    t = np.arange(0.0, 0.2 + 1e-9, 0.005)
    late = np.flatnonzero(t >= 0.1)
    op, x, residual = balanced_run(scene, t, late)
    assert residual < 0.01
    sets = [determinacy(op, i) for i in late]
    bearings = np.isin(np.arange(len(op.names)),
                       [c for link in op.bearings() for c in link.columns])
    determinate = np.logical_and.reduce([d.determinate for d in sets]) & bearings
    assert determinate.sum() == 4
    rigid = np.array([d.min_norm for d in sets])[:, determinate].mean(axis=0)
    gap = np.abs(x[late][:, determinate].mean(axis=0) - rigid)
    assert np.abs(rigid).max() > 2e3
    assert gap.max() < 0.05 * np.abs(rigid).max()
