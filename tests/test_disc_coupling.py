"""The flexible disc coupling kind: its table, its columns (a weld in the rigid
model), its compliance laws, and the refusals of the models without a bushing."""

import numpy as np
import pytest
from cardan_forces.driveline.dynamics import simulate
from cardan_forces.driveline.elements.base import DRAKE, MUJOCO
from cardan_forces.driveline.elements.disc_coupling import COMPONENTS, KIND
from cardan_forces.driveline.engine_mujoco import start_of
from cardan_forces.driveline.equilibrium import build_operator
from cardan_forces.driveline.loading import load_scene, scene_from_dict
from cardan_forces.driveline.scene import SceneError

DISC = {"name": "disc", "shaft": "front_prop", "offset_m": -0.55,
        "radial_stiffness_N_m": 2e7, "axial_stiffness_N_m": 1e6,
        "angular_stiffness_N_m_rad": 2e3, "torsional_stiffness_N_m_rad": 3e4}


@pytest.fixture(scope="module")
def scene():
    return load_scene("propshaft-disc")


def test_its_link_has_six_components_in_the_shafts_frame(scene):
    op = build_operator(simulate(scene, [0.2]))
    link = next(c for c in op.contacts if c.element == "disc")
    assert link.components == COMPONENTS
    assert link.units == ("N",) * 3 + ("N m",) * 3
    frame = op.shaft_frames[link.shaft]
    directions = op.directions[0, list(link.columns)]
    assert np.allclose(directions, np.vstack([frame, frame]))


def test_each_component_takes_its_own_stiffness_without_gap(scene):
    op = build_operator(simulate(scene, [0.2]))
    link = next(c for c in op.contacts if c.element == "disc")
    laws = KIND.laws(link, scene)
    c = link.columns
    assert [(law.columns, law.stiffness, law.gap_m, law.hertz) for law in laws] == [
        (c[0:2], 2e7, 0.0, False), (c[2:3], 1e6, 0.0, False),
        (c[3:5], 2e3, 0.0, False), (c[5:6], 3e4, 0.0, False)]


def test_it_is_a_weld_in_the_rigid_model(scene):
    """Cut or not, the line has the same rigid set: the cut adds six rows and six
    columns and keeps the nullity."""
    whole = build_operator(simulate(load_scene("propshaft"), [0.2]))
    cut = build_operator(simulate(scene, [0.2]))
    assert cut.A[0].shape == (whole.A[0].shape[0] + 6, whole.A[0].shape[1] + 6)
    rank = np.linalg.matrix_rank
    assert cut.A[0].shape[1] - rank(cut.A[0]) == whole.A[0].shape[1] - rank(whole.A[0])


@pytest.mark.parametrize("key,value", [("angular_stiffness_N_m_rad", 0.1),
                                       ("torsional_stiffness_N_m_rad", 1e12)])
def test_a_stiffness_outside_its_range_is_refused_with_the_range(key, value):
    with pytest.raises(SceneError, match=f"'disc_couplings\\[0\\].{key}': .* outside"):
        scene_from_dict({"extends": "propshaft-disc",
                         "disc_couplings": [{**DISC, key: value}]})


def test_drake_refuses_it_by_name_and_mujoco_takes_it(scene):
    assert "disc coupling 'disc'" in KIND.refusal(scene.elements[0], DRAKE)
    assert KIND.refusal(scene.elements[0], MUJOCO) is None
    assert "disc coupling disc in shaft front_prop @ -0.55 m" in KIND.describe(
        scene.elements[0])


def test_mujocos_six_sprung_joints_have_each_components_stiffness(scene):
    """:meth:`Disc.mjcf_steps`: slides along ``r1, r2, axis`` with the radial, radial and
    axial stiffness, hinges about them with the angular, angular and torsional one, all
    at the coupling, each damped by the scene's fraction of its stiffness."""
    op = build_operator(simulate(scene, [0.0]))
    link = next(c for c in op.contacts if c.element == "disc")
    steps = KIND.mjcf_steps(link, link.body, start_of(op))
    disc, frame = scene.elements[0], op.shaft_frames[link.shaft]
    radial, angular = disc.radial_stiffness_N_m, disc.angular_stiffness_N_m_rad
    expected = [("slide", radial), ("slide", radial), ("slide", disc.axial_stiffness_N_m),
                ("hinge", angular), ("hinge", angular),
                ("hinge", disc.torsional_stiffness_N_m_rad)]
    assert [(s.type, s.stiffness) for s in steps] == expected
    for step, axis in zip(steps, np.concatenate([frame, frame])):
        assert np.allclose(step.axis, axis, atol=1e-12)
        assert np.allclose(step.point, op.points[0, link.columns[0]], atol=1e-12)
        assert step.damping == pytest.approx(
            scene.contact.damping_fraction_of_stiffness * step.stiffness)
        assert step.speed == 0.0
