"""Every ``--json`` output is strict JSON on stdout and nothing else, whatever the
solver libraries print (captured at the file-descriptor level)."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest
from cardan_forces.experiments.environment import json_text

from cardan_forces.cli import main


def _strict(text: str):
    def refuse(constant):
        raise ValueError(f"not strict JSON: {constant}")
    return json.loads(text, parse_constant=refuse)


JSON_COMMANDS = [
    "sets --t 0.5 --json",
    "sets paper-fig15 --t 0.2 --json --multistart 2",
    "solvers --json",
    "solve --t 0.5 --json",
    "bench --quick --json --formulation positive --solver clarabel --out {out}",
    "hard --quick --json --case articulation-0 --formulation positive",
    "sweep --quick --json --angle 10 --formulation positive --workers 1 --out {out}",
]


@pytest.mark.parametrize("argv", JSON_COMMANDS)
def test_json_output_is_strict_and_alone(tmp_path, capfd, argv):
    code = main(argv.format(out=tmp_path).split())
    out, _ = capfd.readouterr()
    assert code == 0
    numbers = _numbers(_strict(out))
    assert all(isinstance(v, (int, float)) for v in numbers)  # no "nan"/"inf" strings


def _numbers(value):
    """The JSON's leaves that are numbers or spell one (``"nan"``, ``"inf"``)."""
    if isinstance(value, dict):
        return [v for child in value.values() for v in _numbers(child)]
    if isinstance(value, list):
        return [v for child in value for v in _numbers(child)]
    if isinstance(value, str):
        return [value] if value.lower() in ("nan", "inf", "-inf", "infinity") else []
    return [value] if isinstance(value, (int, float)) and not isinstance(value, bool) else []


@pytest.mark.slow
def test_solver_banners_go_to_stderr():
    """HiGHS (highspy) prints a banner on file descriptor 1: in a separate process, so
    that nothing but the real descriptors is involved."""
    proc = subprocess.run(
        [sys.executable, "-m", "cardan_forces.cli", "solve", "--t", "0.5", "--formulation",
         "positive", "--json"], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0
    records = _strict(proc.stdout)
    assert {r["formulation"] for r in records} == {"positive"}
    assert any(r["solver"] == "qpsolvers-highs" for r in records)


def test_undefined_numbers_become_null():
    """The one encoder: non-finite numbers (Python or NumPy, in dicts, lists, arrays) are
    null; words stay words, whatever they spell."""
    value = {"residual": float("nan"), "rows": [{"max": np.float64("inf"), "n": np.int64(3),
                                                 "x": np.array([1.5, -np.inf]),
                                                 "name": "nano", "word": "inf"}]}
    assert _strict(json_text(value)) == {
        "residual": None, "rows": [{"max": None, "n": 3, "x": [1.5, None], "name": "nano",
                                    "word": "inf"}]}


def _propshaft(tmp_path, name, *changes):
    """The built-in propshaft with text ``changes`` ``(pattern, replacement)`` (regex,
    each must apply), written as ``name``.toml."""
    import re

    from cardan_forces.driveline.loading import builtin_text

    text = builtin_text("propshaft")
    for pattern, new in changes:
        text, n = re.subn(pattern, new, text)
        assert n, pattern
    path = tmp_path / f"{name}.toml"
    path.write_text(text)
    return str(path)


def _sets(capsys, *argv):
    assert main(["sets", *argv, "--json"]) == 0
    return _strict(capsys.readouterr().out)


def test_a_micrometre_line_has_its_determinate_values_as_intervals(tmp_path, capsys):
    """Lengths of 1e-6 m (arms of micrometres, loads of 1e8 N): every determinate
    component carries its one value as min = max, equal to the least-norm value, and
    every interval holds the signed member."""
    path = _propshaft(tmp_path, "tiny", (r"length_m = [0-9.]+", "length_m = 1e-6"),
                      (r"offset_m = (-?)[0-9.]+", r"offset_m = \g<1>4e-7"))
    report = _sets(capsys, path)
    assert report["rigid_set"] == "solved"
    components = report["components"].values()
    assert sum(c["determinate"] for c in components) >= 10
    for c in components:
        if c["determinate"]:
            assert c["min"] == c["max"] == pytest.approx(c["min_norm"], rel=1e-9)
        assert c["interval_status"] == "solved"
        if c["positive"] is not None:
            lo = -np.inf if c["min"] is None else c["min"]
            hi = np.inf if c["max"] is None else c["max"]
            slack = 1e-6 * max(abs(lo) if np.isfinite(lo) else 0, abs(c["positive"]), 1.0)
            assert lo - slack <= c["positive"] <= hi + slack


def test_an_empty_rigid_set_calls_no_component_determinate(tmp_path, capsys):
    """The pinion's bearings both floating, the slip joint's friction the only axial
    hold of the rear half, gravity along the line and no torque (so no friction): no
    forces satisfy the equilibrium. No component is called determinate, none has an
    interval, and the text table says the set is empty instead of printing infinities."""
    path = _propshaft(tmp_path, "held_by_friction",
                      (r"friction_coefficient = 0.0", "friction_coefficient = 0.1"),
                      (r"input = 2500.0\nload = 2500.0", "input = 0.0\nload = 0.0"),
                      (r'(name = "pinion"(?:.|\n)*?)kind = "locating"', r'\1kind = "floating"'),
                      (r"gravity_m_s2 = \[0.0, 0.0, -9.81\]", "gravity_m_s2 = [-1.0, 0.0, -9.81]"))
    report = _sets(capsys, path)
    assert report["rigid_set"] == "infeasible"
    for c in report["components"].values():
        assert not c["determinate"] and c["min"] is None and c["max"] is None
        assert c["interval_status"] == "infeasible"
    assert main(["sets", path]) == 0
    out = capsys.readouterr().out
    table = out.split("max N\n", 1)[1].split("modes", 1)[0]
    assert "rigid set: empty" in out and "inf" not in table and "empty" in table


def test_a_determinate_component_always_has_its_value(capsys):
    """On the built-in scenes the rule holds too: determinate means min = max, numbers."""
    for scene in ("paper", "propshaft", "paper-slip"):
        report = _sets(capsys, scene)
        assert report["rigid_set"] == "solved"
        for c in report["components"].values():
            if c["determinate"]:
                assert c["min"] is not None and c["min"] == c["max"]
