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
