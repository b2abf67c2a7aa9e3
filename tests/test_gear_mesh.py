"""The gear mesh kind: ISO 6336's nominal loads of a helical gear and a bevel or hypoid
pinion's loads at its mean point, applied at the mesh point so that their moment about
the axis is the load torque the pure torque was, and its checks."""

import math
from pathlib import Path

import numpy as np
import pytest
from cardan_forces.driveline.determinacy import determinacy
from cardan_forces.driveline.dynamics import simulate
from cardan_forces.driveline.elements.base import DRAKE
from cardan_forces.driveline.elements.gear_mesh import (
    KIND,
    GearMesh,
    gear_tangential_force,
    nominal_forces,
)
from cardan_forces.driveline.equilibrium import build_operator
from cardan_forces.driveline.loading import load_scene, scene_from_dict
from cardan_forces.driveline.scene import SceneError

LBF, INCH = 4.4482216152605, 0.0254  # N, m

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


def test_helical_forces_against_shigleys_example_13_7():
    """Budynas & Nisbett, *Shigley's Mechanical Engineering Design*, 9th ed., Example
    13-7: an 18-tooth helical pinion, normal pressure angle 20 deg, helix angle 30 deg,
    normal diametral pitch 12 teeth/in (pitch diameter 1.732 in), 1 hp at 1800 rev/min:
    ``W_t = 40.4 lbf``, ``W_r = W_t tan(phi_t) = 17.0 lbf`` with ``tan(phi_t) =
    tan(phi_n) / cos(psi)``, ``W_a = W_t tan(psi) = 23.3 lbf``."""
    radius = 1.732 / 2 * INCH
    gear = GearMesh("g", "s", 0.0, radius, 20.0, 30.0)
    ft, fr, fa = nominal_forces(np.array([40.4 * LBF * radius]), gear)
    assert ft[0] / LBF == pytest.approx(40.4)
    assert fr[0] / LBF == pytest.approx(17.0, abs=0.05)
    assert fa[0] / LBF == pytest.approx(23.3, abs=0.05)


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
    x = determinacy(op, 0).min_norm
    assert np.linalg.norm(op.A[0] @ x - op.b[0]) <= 1e-9 * np.linalg.norm(op.b[0])


@pytest.mark.parametrize("meshes,why", [
    ([{**MESH, "shaft": "intermediate", "offset_m": 0.0}], "on the first shaft"),
    ([{**MESH, "shaft": "input", "offset_m": 0.0, "type": "bevel", "helix_angle_deg": None,
       "pitch_cone_angle_deg": 20.0}], "ends the line"),
    ([MESH, {**MESH, "name": "two", "offset_m": 0.3}], "at most one gear mesh")])
def test_a_mesh_off_the_ends_or_a_second_at_one_is_refused(meshes, why):
    meshes = [{k: v for k, v in m.items() if v is not None} for m in meshes]
    with pytest.raises(SceneError, match=why):
        scene_from_dict({"extends": "paper", "gear_meshes": meshes})


def test_a_driving_mesh_brings_the_input_torque_and_its_forces():
    """A helical gear on the first shaft drives the line: against the same line driven by
    a pure torque, the first body's moment about its axis is the same, and the force
    the mesh adds is ISO 6336's at the input torque, ``Fa`` reversed with ``Ft`` (a
    negative helix pushes the driven shaft downstream) and ``Fr`` toward the axis."""
    drive = {**MESH, "name": "drive", "shaft": "input", "offset_m": -0.3}
    plain = load_scene("paper")
    meshed = scene_from_dict({"extends": "paper", "gear_meshes": [drive]})
    ops = [build_operator(simulate(s, [0.3, 0.8])) for s in (plain, meshed)]
    pure, geared = (op.terms["applied"][:, :6] for op in ops)  # the first body's rows
    frame = ops[1].shaft_frames[0]
    force = pure[:, :3] - geared[:, :3]  # b holds minus the applied load
    torque = ops[1].scene.input_torque(ops[1].t)
    ft, fr, fa = nominal_forces(torque, meshed.elements[0])
    angle = math.radians(drive["mesh_angle_deg"])
    out = math.cos(angle) * frame[0] + math.sin(angle) * frame[1]
    assert np.allclose(force @ frame[2], fa)
    assert np.allclose(force @ out, -fr)
    assert np.allclose(force @ np.cross(frame[2], out), ft)
    assert np.allclose(geared[:, 3:] @ frame[2], pure[:, 3:] @ frame[2], rtol=1e-12)
    x = determinacy(ops[1], 0).min_norm
    assert np.linalg.norm(ops[1].A[0] @ x - ops[1].b[0]) <= 1e-9 * np.linalg.norm(ops[1].b[0])


def test_a_reversed_torque_keeps_the_helical_radial_force_separating():
    gear = GearMesh("g", "s", 0.0, 0.05, 20.0, -15.0)
    ahead, back = (nominal_forces(np.array([t]), gear) for t in (500.0, -500.0))
    assert back[0][0] == -ahead[0][0] and back[2][0] == -ahead[2][0]
    assert back[1][0] == ahead[1][0] > 0


def test_models_that_apply_a_torque_refuse_it_by_name():
    scene = load_scene(str(Path(__file__).parent / "data" / "every_kind.toml"))
    gear = next(e for e in scene.elements if isinstance(e, GearMesh))
    assert "gear mesh 'transfer'" in KIND.refusal(gear, DRAKE)


# ------------------------------------------------------------------ bevel and hypoid



def bevel(delta, psi=0.0, hand=None, alpha=20.0, r=0.03, kind="bevel", psi_gear=None,
          mesh_angle=0.0):
    return GearMesh("p", "s", 0.0, r, alpha, None, mesh_angle, kind, delta, psi, hand,
                    psi_gear)


def test_straight_bevel_against_shigleys_example_13_8():
    """Budynas & Nisbett, *Shigley's Mechanical Engineering Design*, 9th ed., Example
    13-8: 5 hp at 600 rev/min, the 45-tooth gear of a 15:45 pair (pitch angle
    ``Gamma = 71.6 deg``), average pitch radius 1.293 in, 20 deg: ``W_t = 406 lbf``,
    ``W_r = W_t tan 20 cos Gamma = 46.6 lbf``, ``W_a = W_t tan 20 sin Gamma = 140 lbf``
    (eq. 13-38), from the example's rounded ``W_t`` and ``Gamma`` (the gear's forces at
    its mean point are the pinion's formulas with the gear's pitch angle)."""
    torque = 406 * 1.293 * LBF * INCH
    ft, fr, fa = nominal_forces(np.array([torque]), bevel(71.6, r=1.293 * INCH))
    assert ft[0] / LBF == pytest.approx(406, abs=0.5)
    assert fr[0] / LBF == pytest.approx(46.6, abs=0.1)
    assert fa[0] / LBF == pytest.approx(140, abs=0.5)


@pytest.mark.parametrize("delta", [10.0, 26.565, 45.0, 80.0])
def test_straight_bevel_is_the_spiral_ones_zero(delta):
    """``psi = 0``: Fa = Ft tan(alpha) sin(delta), Fr = Ft tan(alpha) cos(delta), of
    either hand."""
    t = math.tan(math.radians(20.0))
    for hand in ("left", "right", None):
        ft, fr, fa = nominal_forces(np.array([300.0]), bevel(delta, 0.0, hand))
        assert fa[0] == pytest.approx(1e4 * t * math.sin(math.radians(delta)), rel=1e-14)
        assert fr[0] == pytest.approx(1e4 * t * math.cos(math.radians(delta)), rel=1e-14)


def _tooth_force(ft, delta, psi, hand, alpha):
    """The force on a driving pinion's tooth built from its geometry, apart from the
    formulas: pinion axis z, mean point on x, apex at +z, turning positive about z
    (clockwise seen from the back toward the apex); the tooth trace's outer half leans
    clockwise seen from the apex for a right hand (AGMA 1012); the normal force lies at
    ``alpha`` out of the pitch plane toward the axis, its in-plane part normal to the
    trace and against the motion."""
    d, p, a = (math.radians(v) for v in (delta, psi, alpha))
    g = np.array([-math.sin(d), 0.0, math.cos(d)])  # along the cone toward the apex
    y = np.array([0.0, 1.0, 0.0])  # the motion at the mean point
    cone = np.array([math.cos(d), 0.0, math.sin(d)])  # the pitch cone's outer normal
    lean = -1.0 if hand == "right" else 1.0
    trace = math.cos(p) * -g + lean * math.sin(p) * y  # toward the heel
    inplane = np.cross(cone, trace)
    inplane *= -np.sign(inplane @ y)  # against the motion
    normal = math.cos(a) * inplane - math.sin(a) * cone
    return normal * ft / -(normal @ y)  # scaled to the tangential force


@pytest.mark.parametrize("hand", ["left", "right"])
@pytest.mark.parametrize("delta,psi", [(20.0, 35.0), (12.0, 50.0), (63.4, 10.0)])
def test_the_spiral_formulas_are_the_tooth_normals_components(hand, delta, psi):
    """Fa (away from the apex) and Fr (toward the axis) of the module's formulas are the
    components of the force built from the tooth's geometry: the sign of each spiral
    term is the hand's and the sense of rotation's, not a convention of the formulas.
    Crosher, "Tooth Tips", Gear Solutions: a right-hand pinion driving clockwise moves
    toward the cone centre (Fa < 0 here at a large spiral angle)."""
    force = _tooth_force(1.0, delta, psi, hand, 20.0)
    _, fr, fa = nominal_forces(np.array([0.03]), bevel(delta, psi, hand))
    assert fa[0] == pytest.approx(-force[2], rel=1e-12)
    assert fr[0] == pytest.approx(-force[0], rel=1e-12)
    if hand == "left":
        assert fa[0] > 0  # pushed out of mesh
    if hand == "right" and psi >= 35:
        assert fa[0] < 0


def test_flipping_the_hand_or_the_torque_flips_the_spiral_terms():
    """Left and right differ by twice the spiral terms; a reversed torque loads the other
    flank: the spiral terms change sign, the pressure terms still separate."""
    t, d, p = math.tan(math.radians(20)), math.radians(20), math.radians(35)
    left, right = bevel(20.0, 35.0, "left"), bevel(20.0, 35.0, "right")
    (_, frl, fal), (_, frr, far) = (nominal_forces(np.array([300.0, -300.0]), g)
                                    for g in (left, right))
    n = 1e4 / math.cos(p)
    assert fal - far == pytest.approx([2 * n * math.sin(p) * math.cos(d),
                                       -2 * n * math.sin(p) * math.cos(d)])
    assert frl + frr == pytest.approx(2 * n * t * math.cos(d) * np.ones(2))
    assert (fal[1], frl[1]) == pytest.approx((far[0], frr[0]))


@pytest.mark.parametrize("hand,helix", [("right", 20.0), ("left", -20.0)])
def test_a_bevel_of_no_cone_is_the_helical_gear(hand, helix):
    """``delta -> 0``: the bevel's loads are the helical gear's of the same hand (a
    right-hand spiral is a right-hand helix in the limit), in magnitude and in space:
    Fr = Ft tan(alpha) / cos(psi), |Fa| = Ft tan(psi), the axial force toward the apex
    (downstream) for a right hand, as a positive helix angle's."""
    frame, centre = np.eye(3), np.zeros(3)
    for angle in (0.0, 40.0):
        cone = bevel(0.0, abs(helix), hand, mesh_angle=angle)
        helical = GearMesh("g", "s", 0.0, 0.03, 20.0, helix, angle)
        torque = np.array([300.0, -120.0])
        (_, frb, fab), (_, frh, fah) = (nominal_forces(torque[:1], g) for g in (cone, helical))
        assert (frb[0], abs(fab[0])) == pytest.approx((frh[0], fah[0]), rel=1e-14)
        (pb, fb), (ph, fh) = (KIND.load(g, torque, frame, centre) for g in (cone, helical))
        assert np.allclose(pb, ph)
        assert np.allclose(fb[0], fh[0], rtol=1e-13, atol=1e-9)


@pytest.mark.parametrize("kind,hand", [("bevel", "left"), ("bevel", "right"),
                                       ("hypoid", "left")])
def test_in_space_the_pinion_takes_the_load_torque_and_its_thrust(kind, hand):
    """Its moment about the axis is minus the load torque; its axial component is -Fa
    (Fa away from the apex, which lies downstream), its part toward the axis Fr."""
    rng = np.random.default_rng(3)
    frame = np.linalg.qr(rng.normal(size=(3, 3)))[0].T
    centre = rng.normal(size=3)
    gear = bevel(14.0, 45.0, hand, r=0.04, kind=kind, psi_gear=30.0, mesh_angle=70.0)
    torque = np.array([500.0, -200.0, 0.0])
    point, force = KIND.load(gear, torque, frame, centre)
    axis = frame[2]
    arm = point - centre
    assert np.allclose(np.cross(arm, force) @ axis, -torque)
    ft, fr, fa = nominal_forces(torque, gear)
    assert np.allclose(force @ axis, -fa)
    out = arm - (arm @ axis) * axis
    assert np.allclose(force @ (-out / np.linalg.norm(out)), fr)


def test_the_hypoid_ring_gears_tangential_force():
    """``Ft2 = Ft1 cos(beta_m2) / cos(beta_m1)`` (the normal force is common): with a
    pinion of 50 deg and a ring gear of 30 deg, Ft2 = 1.347296 Ft1; and the torques then
    stand in the tooth ratio, the two mean radii being tied by one mean normal module
    (ISO 23509: m_mn = d_m1 cos(beta_m1) / z1 = d_m2 cos(beta_m2) / z2)."""
    gear = bevel(12.0, 50.0, "left", kind="hypoid", psi_gear=30.0, r=0.025)
    ft1 = nominal_forces(np.array([400.0]), gear)[0]
    ft2 = gear_tangential_force(ft1, gear)
    assert ft2[0] / ft1[0] == pytest.approx(1.347296, rel=1e-6)
    z1, z2 = 9, 41
    r2 = gear.pitch_radius_m * math.cos(math.radians(50)) / math.cos(math.radians(30)) * z2 / z1
    assert ft2[0] * r2 == pytest.approx(400.0 * z2 / z1, rel=1e-12)
    assert gear_tangential_force(ft1, bevel(20.0, 35.0, "left"))[0] == pytest.approx(ft1[0])


PINION = {"name": "pinion-gear", "shaft": "pinion", "offset_m": 0.13,
          "pitch_radius_m": 0.025, "type": "hypoid", "pitch_cone_angle_deg": 12.0,
          "spiral_angle_deg": 48.0, "hand": "left", "gear_spiral_angle_deg": 30.0}


@pytest.mark.parametrize("mesh", [PINION, {**PINION, "type": "bevel",
                                           "gear_spiral_angle_deg": None}])
def test_an_axle_pinions_mesh_loads_and_its_bearings_carry_it(mesh):
    mesh = {k: v for k, v in mesh.items() if v is not None}
    scene = scene_from_dict({"extends": "axle-pinion", "gear_meshes": [mesh],
                             "torque": {"load": 300.0}})
    gear = scene.elements[-1]
    assert gear.type == mesh["type"] and gear.helix_angle_deg is None
    assert f"{mesh['type']} pinion" in KIND.describe(gear)
    op = build_operator(simulate(scene, [0.2]))
    from cardan_forces.driveline.determinacy import determinacy

    x = determinacy(op, 0).min_norm
    assert np.linalg.norm(op.A[0] @ x - op.b[0]) <= 1e-9 * np.linalg.norm(op.b[0])


@pytest.mark.parametrize("change,why", [
    ({"type": "helical"}, "'gear_meshes\\[0\\].pitch_cone_angle_deg': applies to bevel and "
                          "hypoid gears, not to a helical one"),
    ({"type": "bevel"}, "gear_spiral_angle_deg': applies to hypoid gears, not to a bevel"),
    ({"helix_angle_deg": 10.0}, "helix_angle_deg': applies to helical gears, not to a "
                                "hypoid"),
    ({"type": "worm"}, "must be one of helical, bevel, hypoid"),
    ({"pitch_cone_angle_deg": 90.0}, "outside 1 to 89 deg"),
    ({"spiral_angle_deg": 65.0}, "outside 0 to 60 deg"),
    ({"gear_spiral_angle_deg": -5.0}, "outside 0 to 60 deg"),
    ({"hand": "up"}, "must be one of left, right"),
    ({"hand": None}, "'gear_meshes\\[0\\].hand': missing"),
    ({"pitch_cone_angle_deg": None}, "pitch_cone_angle_deg': missing"),
])
def test_a_bevel_field_out_of_place_or_range_is_refused_in_one_line(change, why):
    mesh = {k: v for k, v in {**PINION, **change}.items() if v is not None}
    with pytest.raises(SceneError, match=why) as err:
        scene_from_dict({"extends": "axle-pinion", "gear_meshes": [mesh]})
    assert "\n" not in str(err.value)


def test_a_straight_bevel_needs_no_hand():
    mesh = {**PINION, "type": "bevel", "spiral_angle_deg": 0.0}
    del mesh["hand"], mesh["gear_spiral_angle_deg"]
    gear = scene_from_dict({"extends": "axle-pinion", "gear_meshes": [mesh]}).elements[-1]
    assert gear.hand is None and "straight teeth" in KIND.describe(gear)
