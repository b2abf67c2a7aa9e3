"""The numbers in the propshaft scene's comments are its data's: each one the header
states (angles, torque, tubes, cross, spline, bearing designations and ratings,
tolerances) is read from the comment and compared with the loaded scene, so that an
edit of one without the other fails here. Results (loads, lives) are not stated there;
``cardan life propshaft`` computes them.
"""

from __future__ import annotations

import math
import re

import pytest
from cardan_forces.driveline.loading import builtin_text, load_scene

TEXT = builtin_text("propshaft")
HEADER = " ".join(line[1:].strip() for line in TEXT.split("\nname =", 1)[0].splitlines())
"""The header comment as one line."""

STEEL_KG_M3 = 7850.0


@pytest.fixture(scope="module")
def scene():
    return load_scene("propshaft")


def said(pattern: str) -> list[float]:
    """The numbers the header says where ``pattern`` (its groups) matches."""
    found = re.search(pattern, HEADER)
    assert found, pattern
    return [float(g) for g in found.groups()]


def shaft(scene, name: str):
    return next(s for s in scene.shafts if s.name == name)


def test_the_joint_angles_and_the_torque(scene):
    bends = said(r"bends of ([+-]\d+), ([+-]\d+) and ([+-]\d+) deg")
    signs = scene.articulation_signs()
    assert bends == [j.articulation_deg * s for j, s in zip(scene.joints, signs)]
    assert said(r"torque: (\d+) N m")[0] == scene.input_torque.mean_N_m


def test_the_tubes(scene):
    outside, wall, per_metre = said(r"(\d+) mm outside, (\d+) mm wall \(([\d.]+) kg/m\)")
    area = math.pi / 4 * (outside ** 2 - (outside - 2 * wall) ** 2) * 1e-6
    assert round(area * STEEL_KG_M3, 1) == per_metre
    front, rear = said(r"front ([\d.]+) m, rear ([\d.]+) m")
    radius = (outside - wall) / 2e3
    for name, length in (("front_prop", front), ("rear_prop", rear)):
        tube = shaft(scene, name)
        assert tube.length_m == length and tube.mass_kg >= per_metre * length  # with yokes
        assert tube.inertia_kg_m2[1] == pytest.approx(tube.mass_kg * radius ** 2, rel=0.25)


def test_the_cross_and_the_spline(scene):
    contact, radius = said(r"trunnion contact (\d+) mm from the centre, trunnion radius "
                           r"(\d+) mm")
    assert all((j.hs_m, j.rs_m) == (contact / 1e3, radius / 1e3) for j in scene.joints)
    (pitch,) = said(r"spline pitch radius (\d+) mm")
    assert scene.elements[0].pitch_radius_m == pitch / 1e3


def test_the_bearing_designations_their_ratings_and_journals(scene):
    """Each designation's dimensions and ratings as the header gives them, the rating
    tables marked with it, and the journals: 50 mm at the gearbox and pinion, 40 mm at
    the centre bearing."""
    sizes = {m[0]: [float(v) for v in m[1:]] for m in re.findall(
        r"(\d{4}|NU \d+ ECP) \((\d+)x(\d+)x(\d+) mm, C ([\d.]+) kN, C0 ([\d.]+) kN[);]", HEADER)}
    assert len(sizes) == 3
    marked = re.findall(r"\[shafts\.bearings\.rating\]\s+# SKF (.+)\ntype = .*\n"
                        r"C_N = ([\d.]+)\nC0_N = ([\d.]+)", TEXT)
    assert len(marked) == sum(len(s.bearings) for s in scene.shafts)
    for designation, c, c0 in marked:
        assert sizes[designation][3:] == [float(c) / 1e3, float(c0) / 1e3], designation
    gearbox, centre = said(r"fit (\d+) mm journals at the gearbox and pinion and a (\d+) mm "
                           r"centre-bearing stub")
    bores = {name: sizes[d][0] for name, (d, _, _) in zip(
        [f"{s.name}.{b.name}" for s in scene.shafts for b in s.bearings], marked)}
    assert bores == {"gearbox.rear": gearbox, "gearbox.front": gearbox,
                     "front_prop.centre": centre, "pinion.front": gearbox,
                     "pinion.rear": gearbox}


def test_the_tolerances(scene):
    tol = scene.tolerances
    assert said(r"seats within \+-([\d.]+) mm radially")[0] == tol.bearing_seat_m * 1e3
    assert said(r"joint angles within \+-([\d.]+) deg")[0] == tol.articulation_deg
    spread, nominal = said(r"clearances within \+-(\d+) um of the nominal (\d+) um")
    assert spread == pytest.approx(tol.bearing_clearance_m * 1e6)
    assert nominal == pytest.approx(scene.contact.bearing_clearance_m * 1e6)


def test_no_load_or_life_is_stated():
    """Loads and lives are the package's answers, not the scene's data."""
    for words in ("L10", "million revolutions", "% of C", " rpm"):
        assert words not in HEADER
