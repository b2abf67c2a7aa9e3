"""Bad input through the command line: one line ``cardan: error: ...`` naming the file,
the field and the value, exit code 2, no traceback, before any work.

Each row: a scene file (text, bytes, or none), the command line (``{path}`` is the
file), and the exact message expected.
"""

from __future__ import annotations

import re

import pytest
from cardan_forces.driveline.loading import builtin_names, builtin_text

from cardan_forces.cli import main

PAPER = builtin_text("paper")


def paper(*substitutions: tuple[str, str]) -> str:
    """The paper scene with whole lines replaced: ``(regex of the line, new line)``."""
    text = PAPER
    for pattern, line in substitutions:
        text, n = re.subn(rf"^{pattern}$", line, text, count=1, flags=re.M)
        assert n == 1, pattern
    return text


NO_INPUT_BEARINGS = ('bearings = \\[\n    { name = "far", offset_m = -0.4 },\n'
                     '    { name = "near", offset_m = 0.4 },\n\\]')


def without_bearings(text: str, keep_near_input: bool = False) -> str:
    text = re.sub(r"bearings = \[\n(.*\n)*?\]", "bearings = []", text)
    if keep_near_input:
        text = text.replace("bearings = []", 'bearings = [{ name = "near", offset_m = 0.4 }]', 1)
    return text


def three_joints(centre_bearing: bool) -> str:
    """Four shafts, three joints: input and output held by two bearings each, the two
    middle shafts by one centre bearing (the first) or none (``centre_bearing`` False).
    """
    head, rest = PAPER.split("\n[[shafts]]", 1)
    tail = rest[rest.index("\n[crosspin]"):]
    shafts = rest[:rest.index("\n[[joints]]")]
    input_shaft, _, output_shaft = shafts.split("\n[[shafts]]")
    centre = '[{ name = "centre", offset_m = 0.0 }]' if centre_bearing else "[]"
    middle = ('\n[[shafts]]\nname = "{}"\nlength_m = 1.5\nmass_kg = 33.764\n'
              'inertia_kg_m2 = [6.531, 0.0152, 6.531]\nbearings = {}\n')
    joint = ('\n[[joints]]\nname = "uj{}"\narticulation_deg = 20.0\nhs_m = 0.02925\n'
             'rs_m = 0.00475\nrb_m = 0.005\nht_m = 0.01925\nhb_m = 0.02\nrt_m = 0.00625\n')
    return (head + "\n[[shafts]]" + input_shaft + middle.format("mid1", centre)
            + middle.format("mid2", "[]") + "\n[[shafts]]" + output_shaft
            + "".join(joint.format(k) for k in (1, 2, 3)) + tail)


NOT_HELD = ("field 'shafts': the line is not held: its contacts leave {free} free motions "
            "where one (the line's rotation) is wanted; free besides it: {bodies}: add "
            "bearings that hold these bodies")

SCENES = [
    ("binary", bytes(range(256)) * 4,
     "not UTF-8 text (byte 0x80 at offset 128); TOML files are UTF-8"),
    ("utf16", PAPER.encode("utf-16"),
     "not UTF-8 text (byte 0xff at offset 0); TOML files are UTF-8"),
    ("latin1-byte", PAPER.replace("Wang", "W\xe4ng", 1).encode("latin-1"),
     "not UTF-8 text (byte 0xe4 at offset 23); TOML files are UTF-8"),
    ("nested-5000", PAPER + "\nextra = " + "[" * 5000 + "]" * 5000 + "\n",
     "not valid TOML: arrays or tables nested deeper than the parser can follow"),
    ("bearings-scalar", paper((r"bearings = \[\]", "bearings = 5")),
     "field 'shafts[1].bearings': expected an array of tables, got int 5"),
    ("bearings-string", paper((r"bearings = \[\]", 'bearings = "far"')),
     "field 'shafts[1].bearings': expected an array of tables, got str 'far'"),
    ("bearing-scalar-entry", paper((r"bearings = \[\]", "bearings = [5]")),
     "field 'shafts[1].bearings[0]': expected a table, got int 5"),
    ("table-for-scalar", paper((r"length_m = 1.5", "length_m = { value = 1.5 }")),
     "field 'shafts[1].length_m': expected a number, got dict {'value': 1.5}"),
    ("int-too-large", paper((r"mass_kg = 118.857", "mass_kg = 1" + "0" * 400)),
     "field 'shafts[0].mass_kg': integer too large for a number, got "
     "100000000000000000000000000000000000000000000000000000000..."),
    ("nan-mass", paper((r"mass_kg = 118.857", "mass_kg = nan")),
     "field 'shafts[0].mass_kg': must be finite, got nan"),
    ("mass-1e300", paper((r"mass_kg = 118.857", "mass_kg = 1e300")),
     "field 'shafts[0].mass_kg': must be at most 1e+09 in magnitude (limit for mass_kg), "
     "got 1e+300"),
    ("shaft-1e300-m", paper((r"length_m = 1.0", "length_m = 1e300")),
     "field 'shafts[0].length_m': must be at most 1000 in magnitude (limit for length_m), "
     "got 1e+300"),
    ("gravity-1e300", paper((r"gravity_m_s2 = .*", "gravity_m_s2 = [0.0, 0.0, -1e300]")),
     "field 'gravity_m_s2': components must be at most 1000 in magnitude (limit for "
     "gravity_m_s2), got [0.0, 0.0, -1e+300]"),
    ("torque-1e30", paper((r"load = .*", "load = 1e30")),
     "field 'torque.load': must be at most 1e+09 in magnitude (limit for torque_N_m), "
     "got 1e+30"),
    ("frequency-1e300", paper((r"input = .*", 'input = { kind = "harmonic", mean_N_m = 10.0, '
                               'amplitude_N_m = -5.0, frequency_hz = 1e300 }')),
     "field 'torque.input.frequency_hz': must be at most 10000 in magnitude (limit for "
     "frequency_hz), got 1e+300"),
    ("frequency-periods", paper((r"input = .*", 'input = { kind = "harmonic", mean_N_m = 10.0, '
                                 'amplitude_N_m = -5.0, frequency_hz = 5000.0 }')),
     "field 'torque.input': 5000 Hz over the time span is 2.5e+04 periods; at most 1000"),
    ("speed-1e30", paper((r"speed_rad_s = 0.0", "speed_rad_s = 1e30")),
     "field 'initial.speed_rad_s': must be at most 10000 in magnitude (limit for "
     "speed_rad_s), got 1e+30"),
    ("speed-turns", paper((r"speed_rad_s = 0.0", "speed_rad_s = 5000.0")),
     "field 'time.stop_s': over 5 s the line may turn 3.99e+03 revolutions (initial speed "
     "5000 rad/s and the torques); at most 1000: shorten the time span or lower the speed "
     "or torques"),
    ("grid-1e9-instants", paper((r"step_s = 0.005", "step_s = 5e-9")),
     "field 'time.step_s': gives 1e+09 instants from 0 to 5 s; at most 20001"),
    ("grid-overflow", paper((r"stop_s = 5.0", "stop_s = 1e300")),
     "field 'time.stop_s': must be at most 1e+06 in magnitude (limit for time_s), got 1e+300"),
    ("axis-1e200-start", paper((r"input_start_m = .*", "input_start_m = [1e200, 0.0, 0.0]")),
     "field 'frame.input_start_m': components must be at most 1000 in magnitude (limit for "
     "position_m), got [1e+200, 0.0, 0.0]"),
    ("articulation-89.5", paper((r"articulation_deg = 30.0", "articulation_deg = 89.5")),
     "field 'joints[0].articulation_deg': 89.5 deg is outside -89 to 89 deg (below 90 deg: "
     "the velocity ratio 1/cos grows without bound)"),
    ("dotted-name", paper((r'name = "intermediate"', 'name = "inter.mediate"')),
     "field 'shafts[1].name': a name is letters, digits, '_' or '-' (it becomes part of "
     "dotted force names), got 'inter.mediate'"),
    ("unknown-key", paper((r'arrangement = "Z"', 'arrangement = "Z"\ncolour = "red"')),
     "field 'colour': unknown key"),
    ("no-bearings", without_bearings(PAPER),
     NOT_HELD.format(free=10, bodies="input (moves along x, y, z), intermediate (moves along "
                     "x, y, z), output (moves along x, y, z), uj1.pin (moves along x, y, z), "
                     "uj2.pin (moves along x, y, z)")),
    ("one-bearing", without_bearings(PAPER, keep_near_input=True),
     NOT_HELD.format(free=7, bodies="input (moves along y, z), intermediate (moves along x, "
                     "y, z), output (moves along x, y, z), uj1.pin (moves along y, z), uj2.pin "
                     "(moves along x, y, z)")),
    ("middle-shaft-without-centre-bearing", three_joints(centre_bearing=False),
     NOT_HELD.format(free=2, bodies="mid1 (moves along y), mid2 (moves along y), uj2.pin "
                     "(moves along y)")),
]


@pytest.mark.parametrize("content,message", [c[1:] for c in SCENES], ids=[c[0] for c in SCENES])
@pytest.mark.parametrize("command", ["scene check", "scene dump", "sets", "solve", "repro"])
def test_bad_scene_is_one_line_exit_2(tmp_path, capsys, content, message, command):
    path = tmp_path / "bad.toml"
    (path.write_bytes if isinstance(content, bytes) else path.write_text)(content)
    assert main([*command.split(), str(path)]) == 2
    out, err = capsys.readouterr()
    assert out == ""
    assert err.splitlines() == [f"cardan: error: scene {path}: {message}"]


def test_the_three_joint_line_with_its_centre_bearing_loads(tmp_path, capsys):
    path = tmp_path / "line.toml"
    path.write_text(three_joints(centre_bearing=True))
    assert main(["scene", "check", str(path)]) == 0
    assert "4 shafts, 3 joints" in capsys.readouterr().out


COMMANDS = [
    ("solve --tol -1", "--tol -1.0: must be a finite number in (0, 1]"),
    ("solve --tol nan", "--tol nan: must be a finite number in (0, 1]"),
    ("sets --multistart -5", "--multistart -5: must be a finite number in [0, 1000]"),
    ("sets --t nan", "--t nan: must be a finite number in [0, 1e+06]"),
    ("sets --t -0.5", "--t -0.5: must be a finite number in [0, 1e+06]"),
    ("sets --t 6", "--t 6.0: outside the scene's time span [0.0, 5.0] s"),
    ("sets --t abc", "argument --t: invalid float value: 'abc' (see 'cardan sets --help')"),
    ("bench --budget-s -1", "argument --budget-s: expected a positive number of seconds, "
                            "got '-1' (see 'cardan bench --help')"),
    ("hard --tol -1", "--tol -1.0: must be a finite number in (0, 1]"),
    ("sweep --angle 95", "--angle 95: |articulation| must be at most 89 deg"),
    ("sweep --amplitude 1e300", "--amplitude 1e+300: must be at most 1e+09 N m in magnitude"),
    ("sweep --instants 0", "--instants 0: must be at least 1"),
    ("sweep --workers -1", "--workers -1: must be in [1, 1024]"),
    ("report --instants 20002", "argument --instants: expected a whole number from 2 to "
                               "20001, got '20002' (see 'cardan report --help')"),
    ("report --instants 1002 --out {dir}", "--instants 1002: scene paper has 1001 instants "
                                           "on its time grid; ask for at most as many"),
    ("export --instants 1e20 --out {dir}", "argument --instants: expected a whole number "
                                           "from 1 to 20001, got '1e20' (see 'cardan export "
                                           "--help')"),
    ("", "the following arguments are required: command (see 'cardan --help')"),
    ("scene check {dir}", "scene {dir}: is a directory, not a scene file"),
    ("sets no-such-scene", f"scene no-such-scene: not a built-in name "
                           f"({', '.join(builtin_names())}) and no such file"),
]


@pytest.mark.parametrize("argv,message", COMMANDS, ids=[c[0] or "nothing" for c in COMMANDS])
def test_bad_command_line_is_one_line_exit_2(tmp_path, capsys, argv, message):
    names = {"dir": tmp_path}
    assert main(argv.format(**names).split()) == 2
    out, err = capsys.readouterr()
    assert out == ""
    assert err.splitlines() == [f"cardan: error: {message.format(**names)}"]
