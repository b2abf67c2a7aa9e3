"""Fields that set a stiffness or a geometry are held to physical ranges: each limited
key, just outside its range, is refused in one line naming the key, the value, its
unit and the range; at the range's ends it is not refused for it."""

import copy

import pytest
from cardan_forces.driveline.contact import hertz_stiffness
from cardan_forces.driveline.elements.cardan import CROSSPIN_KEYS
from cardan_forces.driveline.loading import builtin_text, load_scene, scene_from_dict
from cardan_forces.driveline.scene import (
    CONTACT_ANGLE_DEG,
    CROSSPIN_ASPECT,
    MAX_STIFFNESS_RATIO,
    SPLINE_PITCH_RADIUS_M,
    SceneError,
)

from cardan_forces.cli import main

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib


def _pinion_angle(rated: bool):
    """Both pinion bearings at one contact angle; their ratings' too, or none."""
    def change(raw, value):
        for b in raw["shafts"][2]["bearings"]:
            b["contact_angle_deg"] = value
            if rated:
                b["rating"]["contact_angle_deg"] = value
            else:
                del b["rating"]
    return change


def _ball_rating(raw, value):
    raw["shafts"][0]["bearings"][0]["rating"] = {
        "type": "angular_contact_ball", "C_N": 3e4, "C0_N": 2e4, "contact_angle_deg": value,
        "X": 0.4, "Y": 1.0, "e": 0.5}


def _pitch_radius(raw, value):
    raw["slip_joints"][0]["pitch_radius_m"] = value


def _stiffness(raw, value):
    raw["contact"]["bearing_stiffness_N_m"] = value


def _paper_secant() -> float:
    paper = load_scene("paper")
    ct = paper.contact
    return hertz_stiffness(paper, paper.joints[0]) * ct.damping_full_depth_m ** (
        ct.exponent - 1.0)


SECANT = _paper_secant()

LIMITED = [
    ("axle-pinion", _pinion_angle(False), "shafts[2].bearings[0].contact_angle_deg", "deg",
     CONTACT_ANGLE_DEG.least, CONTACT_ANGLE_DEG.most),
    ("axle-pinion", _pinion_angle(True), "shafts[2].bearings[0].rating.contact_angle_deg",
     "deg", CONTACT_ANGLE_DEG.least, CONTACT_ANGLE_DEG.most),
    ("paper", _ball_rating, "shafts[0].bearings[0].rating.contact_angle_deg", "deg",
     CONTACT_ANGLE_DEG.least, CONTACT_ANGLE_DEG.most),
    ("paper-slip", _pitch_radius, "slip_joints[0].pitch_radius_m", "m",
     SPLINE_PITCH_RADIUS_M.least, SPLINE_PITCH_RADIUS_M.most),
    ("paper", _stiffness, "contact.bearing_stiffness_N_m", "N/m",
     SECANT / MAX_STIFFNESS_RATIO, SECANT * MAX_STIFFNESS_RATIO),
]
"""``(scene, change(raw, value), field, unit, least, most)`` of each limited key."""


def _message(scene: str, change, value) -> str:
    raw = copy.deepcopy(tomllib.loads(builtin_text(scene)))
    change(raw, value)
    try:
        scene_from_dict(raw, "s.toml")
    except SceneError as err:
        return str(err)
    return ""


def _refusal(field, value, unit, least, most) -> str:
    return (f"scene s.toml: field '{field}': {value:g} {unit} is outside {least:g} to "
            f"{most:g} {unit}")


@pytest.mark.parametrize("scene, change, field, unit, least, most", LIMITED,
                         ids=[c[2] for c in LIMITED])
def test_a_limited_key_outside_its_range_is_named_with_value_unit_and_range(
        scene, change, field, unit, least, most):
    for value in (least * (1 - 1e-6), least / 10, most * (1 + 1e-6)):
        message = _message(scene, change, value)
        assert message.startswith(_refusal(field, value, unit, least, most)), message
        assert "\n" not in message
    for value in (least, most):
        assert "is outside" not in _message(scene, change, value)


@pytest.mark.parametrize("key", CROSSPIN_KEYS)
def test_a_crosspin_dimension_far_below_the_others_is_refused(key):
    """A dimension of a cross-pin below 1/CROSSPIN_ASPECT of its largest is a zero
    length: refused naming it; at the bound it is not refused for that."""
    raw = tomllib.loads(builtin_text("paper"))
    others = [raw["joints"][1][k] for k in CROSSPIN_KEYS if k != key]
    least = max(others) / CROSSPIN_ASPECT

    def change(raw, value):
        raw["joints"][1][key] = value

    value = least * (1 - 1e-6)
    message = _message("paper", change, value)
    assert message.startswith(_refusal(f"joints[1].{key}", value, "m", least, max(others)))
    assert "is outside" not in _message("paper", change, least)


def test_contact_angles_of_a_micro_degree_are_refused(tmp_path, capsys):
    """The degenerate pinion (both contact angles 1e-6 deg, an axial stiffness of
    3e-7 N/m) is refused in one line, exit 2."""
    path = tmp_path / "flat.toml"
    text = builtin_text("axle-pinion").replace("contact_angle_deg = 15.0",
                                               "contact_angle_deg = 1e-6")
    path.write_text(text)
    assert main(["scene", "check", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.splitlines() == [
        f"cardan: error: scene {path}: field 'shafts[2].bearings[0].rating."
        "contact_angle_deg': 1e-06 deg is outside 5 to 60 deg (the contact angles of real "
        "tapered roller bearings)"]


def test_the_scene_reference_states_the_ranges():
    from pathlib import Path

    page = (Path(__file__).resolve().parents[1] / "docs/reference/scene.md").read_text()
    angle = CONTACT_ANGLE_DEG
    assert f"| {angle.least:g} to {angle.most:g} deg (`CONTACT_ANGLE_DEG`) |" in page
    assert f"at least 1/{CROSSPIN_ASPECT:g} of the joint's largest" in page
    pitch = SPLINE_PITCH_RADIUS_M
    assert f"| {pitch.least * 1e3:g} mm to {pitch.most:g} m (`SPLINE" in page
    assert f"| {1 / MAX_STIFFNESS_RATIO:g} to {MAX_STIFFNESS_RATIO:g} times" \
        .replace("e-0", "e-").replace("e+0", "e") in page
