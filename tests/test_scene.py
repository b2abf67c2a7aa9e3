import dataclasses
import subprocess
import sys

import numpy as np
import pytest
from cardan_forces.driveline.kinematics import rest_geometry
from cardan_forces.driveline.loading import builtin_names, builtin_text, load_scene, scene_from_dict
from cardan_forces.driveline.scene import SceneError

from cardan_forces.cli import main
from tests.conftest import variant


def test_builtins_load_and_paper_fields(paper):
    assert {"paper", "paper-fig15"} <= set(builtin_names())
    assert [s.name for s in paper.shafts] == ["input", "intermediate", "output"]
    assert paper.gravity_m_s2 == (0.0, 0.0, -9.8)
    assert len(paper.time.instants()) == 1001
    assert paper.joints[0].radial_clearance_m == pytest.approx(0.25e-3)
    assert paper.joints[0].axial_clearance_m == pytest.approx(0.75e-3)
    assert paper.input_torque(0.0) == pytest.approx(5.0)  # 10 - 5 cos 0
    assert paper.input_torque(0.5) == pytest.approx(15.0)
    fig15 = load_scene("paper-fig15")
    assert fig15.gravity_m_s2 == (0.0, 9.8, 0.0)
    assert fig15.shafts == paper.shafts


def test_dump_then_load_gives_the_same_scene(tmp_path, capsys):
    for name in builtin_names():
        assert main(["scene", "dump", name]) == 0
        path = tmp_path / f"{name}.toml"
        path.write_text(capsys.readouterr().out)
        again = load_scene(path)
        original = load_scene(name)
        assert again.shafts == original.shafts and again.joints == original.joints
        assert again.gravity_m_s2 == original.gravity_m_s2


def test_extends_relative_file(tmp_path):
    (tmp_path / "base.toml").write_text(builtin_text("paper"))
    (tmp_path / "child.toml").write_text('extends = "base.toml"\nname = "child"\n'
                                         'arrangement = "W"\n')
    scene = load_scene(tmp_path / "child.toml")
    assert scene.name == "child" and scene.arrangement == "W"


BAD = [
    ({"colour": "red"}, "colour", "unknown key"),
    ({"time": {"stop_s": 5.0, "step_s": 0.0}}, "time.step_s", "positive"),
    ({"time": {"stop_s": -1.0}}, "time.stop_s", "after"),
    ({"time": {"stop_s": "five"}}, "time.stop_s", "expected a number"),
    ({"gravity_m_s2": [0, 0]}, "gravity_m_s2", "3 numbers"),
    ({"effects": ["gravity", "magnetism"]}, "effects", "unknown effect"),
    ({"arrangement": "S"}, "arrangement", "one of"),
    ({"effects": ["crosspin_inertia"]}, "effects", "needs 'inertia'"),
    ({"effects": ["friction"]}, "contact.friction_coefficient", "positive coefficient"),
    ({"torque": {"input": "10 - 5 cos(2 pi t)"}}, "torque.input", "expected a number"),
    ({"torque": {"input": {"kind": "square", "value_N_m": 1}}}, "torque.input.kind", "one of"),
    ({"torque": {"input": {"kind": "constant"}}}, "torque.input.value_N_m", "missing"),
]


@pytest.mark.parametrize("override,field,text", BAD)
def test_bad_scene_names_file_and_field(override, field, text):
    with pytest.raises(SceneError) as err:
        scene_from_dict({"extends": "paper", **override}, source="bad.toml")
    message = str(err.value)
    assert "bad.toml" in message and f"'{field}'" in message and text in message


def _shaft_override(paper_raw, key, value, index=0):
    shafts = paper_raw["shafts"]
    shafts[index][key] = value
    return {"shafts": shafts}


@pytest.mark.parametrize(
    "key,value,field,text",
    [
        ("mass_kg", 0.0, "shafts[0].mass_kg", "positive"),
        ("mass_kg", -3.0, "shafts[0].mass_kg", "positive"),
        ("length_m", 0.0, "shafts[0].length_m", "positive"),
        ("inertia_kg_m2", [1.0, -1.0, 1.0], "shafts[0].inertia_kg_m2", "positive definite"),
        ("inertia_kg_m2", [1.0, 1.0, 5.0], "shafts[0].inertia_kg_m2", "triangle"),
        ("mass_kg", True, "shafts[0].mass_kg", "expected a number"),
        ("wheels", 4, "shafts[0].wheels", "unknown key"),
    ],
)
def test_bad_shaft(paper_raw, key, value, field, text):
    with pytest.raises(SceneError, match=text) as err:
        scene_from_dict({"extends": "paper", **_shaft_override(paper_raw, key, value)}, "s.toml")
    assert f"'{field}'" in str(err.value)


@pytest.mark.parametrize("gamma", [90.0, -90.0, 120.0, 89.5])
def test_articulation_must_stay_below_90_degrees(paper_raw, gamma):
    joints = paper_raw["joints"]
    joints[1]["articulation_deg"] = gamma
    with pytest.raises(SceneError, match=r"joints\[1\].articulation_deg': -?[\d.]+ deg is "
                                         r"outside -89 to 89 deg"):
        scene_from_dict({"extends": "paper", "joints": joints})


def test_missing_field_and_joint_count(paper_raw):
    joints = [dict(j) for j in paper_raw["joints"]]
    del joints[0]["hs_m"]
    with pytest.raises(SceneError, match=r"'joints\[0\].hs_m': missing"):
        scene_from_dict({"extends": "paper", "joints": joints})
    with pytest.raises(SceneError, match="3 shafts need 2 joints"):
        scene_from_dict({"extends": "paper", "joints": paper_raw["joints"][:1]})


def test_cli_bad_scene_exit_2_without_traceback(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text('extends = "paper"\n[[shafts]]\nname = "x"\nlength_m = -1\n')
    proc = subprocess.run([sys.executable, "-m", "cardan_forces.cli", "scene", "check", str(bad)],
                          capture_output=True, text=True)
    assert proc.returncode == 2
    assert "Traceback" not in proc.stderr
    assert str(bad) in proc.stderr and "shafts[0]" in proc.stderr
    broken = tmp_path / "broken.toml"
    broken.write_text("name = [unclosed\n")
    assert main(["sets", str(broken)]) == 2
    assert main(["sets", "no-such-scene"]) == 2


@pytest.mark.parametrize("arrangement,output_angle_deg", [("Z", 0.0), ("W", 60.0)])
def test_arrangement_sets_where_the_output_points(arrangement, output_angle_deg):
    """Z (two 30 deg joints turning opposite ways) leaves the output parallel to the
    input; W (the same way) turns it by 60 deg: read from the laid-out geometry."""
    scene = variant(arrangement=arrangement)
    axes = rest_geometry(scene).axes
    angle = np.degrees(np.arccos(np.clip(axes[0] @ axes[-1], -1.0, 1.0)))
    assert angle == pytest.approx(output_angle_deg, abs=1e-9)


def test_extends_replaces_a_table_whose_kind_differs(tmp_path):
    child = tmp_path / "child.toml"
    child.write_text('extends = "paper"\nname = "child"\n[torque]\n'
                     'input = { kind = "constant", value_N_m = 7.0 }\n'
                     'load = { kind = "harmonic", mean_N_m = 1.0, amplitude_N_m = 0.5, '
                     'frequency_hz = 2.0 }\n')
    scene = load_scene(child)
    assert scene.input_torque(0.3) == pytest.approx(7.0) and scene.input_torque.amplitude_N_m == 0
    assert scene.load_torque(0.0) == pytest.approx(1.5) and scene.load_torque(0.25) == \
        pytest.approx(0.5)


def test_extends_merges_a_table_of_the_same_kind_key_by_key():
    scene = variant(torque={"input": {"kind": "harmonic", "mean_N_m": 20.0}})
    assert scene.input_torque(0.0) == pytest.approx(15.0)  # 20 - 5 cos 0: amplitude kept


@pytest.mark.parametrize("axis", [[1e-170, 0.0, 0.0], [1e200, 0.0, 0.0], [5e-324, 0.0, 0.0]])
def test_a_direction_of_any_finite_length_is_accepted(paper, axis):
    scene = variant(frame={"input_axis": axis})
    assert scene.frame.input_axis == (1.0, 0.0, 0.0)
    tilted = variant(frame={"input_axis": [axis[0], axis[0], 0.0]})
    assert tilted.frame.input_axis == pytest.approx((2**-0.5, 2**-0.5, 0.0), abs=1e-15)


def test_the_limits_admit_the_hard_cases():
    """The hard cases (masses and torques x 1e6, 89 deg, 1000 rad/s) load: the limits
    leave room for what the package itself studies."""
    from cardan_forces.experiments.hard import CASES

    assert [c.scene().name for c in CASES] == [f"hard-{c.name}" for c in CASES]


@pytest.mark.parametrize("gamma", [0.0, 89.0, -89.0])
def test_articulation_up_to_89_degrees_loads(paper_raw, gamma):
    joints = paper_raw["joints"]
    joints[1]["articulation_deg"] = gamma
    assert scene_from_dict({"extends": "paper", "joints": joints}).joints[1].articulation_deg \
        == gamma


def _scene_file(path, extends):
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(f'extends = "{extends}"\nname = "{path.stem}"\n')
    return path


@pytest.mark.parametrize("files,start", [
    ({"self.toml": "sub/../self.toml"}, "self.toml"),            # itself, by another path
    ({"a.toml": "sub/b.toml", "sub/b.toml": "../a.toml"}, "a.toml"),  # through a sub-folder
    ({"a.toml": "sub/b.toml", "sub/b.toml": "deeper/c.toml",
      "sub/deeper/c.toml": "../../sub/b.toml"}, "a.toml"),        # a loop not through a
])
def test_extends_loops_are_one_scene_error(tmp_path, files, start):
    (tmp_path / "sub").mkdir()
    for name, parent in files.items():
        _scene_file(tmp_path / name, parent)
    with pytest.raises(SceneError, match="'extends' loops back"):
        load_scene(tmp_path / start)


def test_a_long_extends_chain_is_one_scene_error_and_a_short_one_loads(tmp_path):
    from cardan_forces.driveline.loading import MAX_EXTENDS_DEPTH

    def chain(folder, length):
        _scene_file(folder / f"s{length - 1}.toml", "paper")
        for k in range(length - 1):
            _scene_file(folder / f"s{k}.toml", f"s{k + 1}.toml")
        return folder / "s0.toml"

    assert load_scene(chain(tmp_path / "short", 5)).name == "s0"
    assert load_scene(chain(tmp_path / "edge", MAX_EXTENDS_DEPTH - 1)).name == "s0"
    with pytest.raises(SceneError, match=f"at most {MAX_EXTENDS_DEPTH}"):
        load_scene(chain(tmp_path / "long", 5 * MAX_EXTENDS_DEPTH))


def test_with_changes_validates_the_variant(paper):
    """A variant is checked like a file: a field out of range and a rule between fields
    are refused; a valid change keeps every other field."""
    joint = dataclasses.replace(paper.joints[0], articulation_deg=95.0)
    with pytest.raises(SceneError, match="95 deg is outside -89 to 89 deg"):
        paper.with_changes(joints=(joint, *paper.joints[1:]))
    with pytest.raises(SceneError, match="'penalty_dynamics' needs 'inertia'"):
        paper.with_changes(effects=frozenset({"gravity", "penalty_dynamics"}))
    quiet = paper.with_changes(name="quiet", gravity_m_s2=(0.0, 0.0, 0.0))
    assert quiet.gravity_m_s2 == (0.0, 0.0, 0.0) and quiet.name == "quiet"
    assert dataclasses.replace(quiet, name=paper.name, gravity_m_s2=paper.gravity_m_s2) == paper


@pytest.mark.parametrize(
    "table,wrong,right",
    [
        ("shafts", "lenght_m", "length_m"),    # a required key: reported as the key written
        ("joints", "yoke_phase_dg", "yoke_phase_deg"),
    ],
)
def test_misspelled_key_names_itself_and_the_nearest_valid_key(paper_raw, table, wrong, right):
    rows = paper_raw[table]
    rows[0][wrong] = rows[0].pop(right)
    with pytest.raises(SceneError) as err:
        scene_from_dict({"extends": "paper", table: rows}, "s.toml")
    assert f"unknown key '{wrong}' in {table}[0]; did you mean '{right}'?" in str(err.value)


def test_misspelled_optional_top_level_key_is_named():
    with pytest.raises(SceneError) as err:
        scene_from_dict({"extends": "paper", "gravty_m_s2": [0.0, 0.0, -9.8]}, "s.toml")
    assert "unknown key 'gravty_m_s2' in the scene; did you mean 'gravity_m_s2'?" in str(err.value)


def test_in_motion_adds_inertia_to_a_quasi_static_scene_only():
    """A quasi-static scene gains the ``inertia`` effect and says so; a dynamic one is
    returned as it is."""
    quasi = load_scene("propshaft")
    moving = quasi.in_motion()
    assert moving.has("inertia") and not quasi.has("inertia")
    assert moving.effects - quasi.effects == {"inertia"}
    assert moving.shafts == quasi.shafts and "quasi-static" in moving.description
    paper = load_scene("paper")
    assert paper.in_motion() is paper
