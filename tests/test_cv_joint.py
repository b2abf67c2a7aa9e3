"""The constant-velocity joint kind: homokinetic kinematics at any angle, its moment
about the bisector against the closed form of a CV joint's secondary couple, its compiled
form held to the NumPy reference, its checks and the models that refuse it."""

import dataclasses

import numpy as np
import pytest
from cardan_forces.driveline import dynamics
from cardan_forces.driveline.determinacy import determinacy
from cardan_forces.driveline.dynamics import simulate
from cardan_forces.driveline.elements.cv import KIND, bisector
from cardan_forces.driveline.equilibrium import build_operator
from cardan_forces.driveline.kinematics import kinematics, rest_geometry
from cardan_forces.driveline.loading import load_scene, scene_from_dict
from cardan_forces.driveline.scene import SceneError

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


def test_models_without_a_homokinetic_constraint_refuse_it_by_name():
    joint = load_scene("halfshaft").joints[0]
    assert "constant-velocity joint 'inboard'" in KIND.refusal(joint, "the engine")
