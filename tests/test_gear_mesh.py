"""The gear mesh kind: ISO 6336's nominal loads, applied at the mesh point so that
their moment about the axis is the load torque the pure torque was, and its checks."""

import math
from pathlib import Path

import numpy as np
import pytest
from cardan_forces.driveline.dynamics import simulate
from cardan_forces.driveline.elements.gear_mesh import KIND, GearMesh, nominal_forces
from cardan_forces.driveline.equilibrium import build_operator
from cardan_forces.driveline.loading import load_scene, scene_from_dict
from cardan_forces.driveline.scene import SceneError

MESH = {"name": "out", "shaft": "output", "offset_m": 0.45, "pitch_radius_m": 0.05,
        "pressure_angle_deg": 20.0, "helix_angle_deg": -15.0, "mesh_angle_deg": 30.0}


def test_nominal_forces_are_iso_6336s():
    """T = 500 N m on d = 100 mm: Ft = 2000 T / d = 10 kN; Fr = Ft tan(20) / cos(15),
    Fa = Ft tan(15)."""
    gear = GearMesh("g", "s", 0.0, 0.05, 20.0, -15.0)
    ft, fr, fa = nominal_forces(np.array([500.0]), gear)
    assert ft[0] == pytest.approx(2000 * 500 / 100)
    assert fr[0] == pytest.approx(1e4 * math.tan(math.radians(20)) / math.cos(math.radians(15)))
    assert fa[0] == pytest.approx(1e4 * math.tan(math.radians(15)))


def _ops():
    plain = load_scene("paper")
    meshed = scene_from_dict({"extends": "paper", "gear_meshes": [MESH],
                              "torque": {"load": 4.0}})
    loaded = plain.with_changes(load_torque=meshed.load_torque)
    return (build_operator(simulate(s, [0.3, 0.8])) for s in (loaded, meshed))


def test_the_mesh_takes_the_load_torque_and_adds_its_forces():
    """Against the same line loaded by a pure torque: the last body's moment about its
    axis is the same, its force rows differ by the mesh force, whose
    size is ISO 6336's."""
    torque_op, mesh_op = _ops()
    body = len(torque_op.bodies) - 1 - 2  # the output shaft: before the two pins
    rows = slice(6 * body, 6 * body + 6)
    axis = mesh_op.shaft_frames[-1][2]
    pure, meshed = torque_op.terms["applied"][:, rows], mesh_op.terms["applied"][:, rows]
    force = pure[:, :3] - meshed[:, :3]  # b holds minus the applied load
    ft, fr, fa = nominal_forces(mesh_op.scene.load_torque(mesh_op.t) * np.ones(2),
                                mesh_op.scene.elements[0])
    assert np.allclose(np.linalg.norm(force, axis=1), np.sqrt(ft**2 + fr**2 + fa**2))
    assert np.allclose(force @ axis, -fa)  # a negative helix pushes upstream
    assert np.allclose(meshed[:, 3:] @ axis, pure[:, 3:] @ axis, rtol=1e-12)


def test_its_loads_are_carried():
    _, op = _ops()
    from cardan_forces.driveline.determinacy import determinacy

    x = determinacy(op, 0).min_norm
    assert np.linalg.norm(op.A[0] @ x - op.b[0]) <= 1e-9 * np.linalg.norm(op.b[0])


@pytest.mark.parametrize("meshes,why", [
    ([{**MESH, "shaft": "input", "offset_m": 0.0}], "on its last shaft"),
    ([MESH, {**MESH, "name": "two", "offset_m": 0.3}], "at most one gear mesh")])
def test_a_mesh_off_the_last_shaft_or_a_second_is_refused(meshes, why):
    with pytest.raises(SceneError, match=why):
        scene_from_dict({"extends": "paper", "gear_meshes": meshes})


def test_models_that_apply_a_torque_refuse_it_by_name():
    scene = load_scene(str(Path(__file__).parent / "data" / "every_kind.toml"))
    gear = next(e for e in scene.elements if isinstance(e, GearMesh))
    assert "gear mesh 'transfer'" in KIND.refusal(gear, "the engine")
