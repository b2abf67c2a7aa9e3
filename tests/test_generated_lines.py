"""Every command on generated drive lines (2-8 shafts; Cardan and slip joints, locating
and floating bearings, friction on or off) either answers consistently or refuses with
one line: exit 0 with strict JSON where ``--json`` is asked for, determinate components
with ``min == max`` and every interval ``min <= max``; or exactly one ``cardan: error:``
line on stderr and exit 2. Never a traceback (an exception out of ``main``), exit 1, or
a hang (an alarm ends a command after :data:`COMMAND_S`).

The commands run in this process (``main`` with captured output): the same code path
as the console script, without the start-up of a process per call.
"""

from __future__ import annotations

import contextlib
import io
import json
import math
import signal
import tempfile
from pathlib import Path

import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from cardan_forces.cli import main

COMMAND_S = 120
"""Longest a command may take on a generated line before the test calls it a hang."""

T = 0.05
"""The instant the one-instant commands look at (s): inside every generated time span."""

CROSS = ("hs_m = 0.06\nrs_m = 0.014\nrb_m = 0.01425\nht_m = 0.075\nhb_m = 0.0755\n"
         "rt_m = 0.018\n")
"""A ~165 mm cross (the propshaft's), the same in every joint."""

KINDS = ("locating", "floating")


@st.composite
def lines(draw, most_shafts: int = 8):
    """The TOML text of a drive line: shafts with their bearings, Cardan joints between
    them, at most one slip joint, friction on or off."""
    n = draw(st.integers(2, most_shafts))
    friction = draw(st.booleans())
    slip_in = draw(st.none() | st.integers(0, n - 1))
    effects = '"gravity", "friction"' if friction else '"gravity"'
    parts = [f'name = "generated"\ndescription = "generated line"\neffects = [{effects}]\n'
             f'arrangement = "{draw(st.sampled_from("ZW"))}"\n'
             'gravity_m_s2 = [0.0, 0.0, -9.81]\n'
             '[frame]\ninput_start_m = [0.0, 0.0, 0.0]\ninput_axis = [1.0, 0.0, 0.0]\n'
             'articulation_towards = [0.0, 0.0, 1.0]\n'
             '[crosspin]\nmass_kg = 1.2\ninertia_kg_m2 = [1.5e-3, 1.5e-3, 2.8e-3]\n'
             f'[torque]\ninput = {draw(st.sampled_from([100.0, 2500.0]))}\nload = 0.0\n'
             '[initial]\nangle_rad = 0.0\nspeed_rad_s = 10.0\n'
             '[time]\nstart_s = 0.0\nstop_s = 0.1\nstep_s = 0.05\n'
             f'[contact]\nfriction_coefficient = {0.1 if friction else 0.0}\n']
    for k in range(n):
        length = draw(st.sampled_from([0.3, 0.8, 1.5]))
        end = k in (0, n - 1)
        count = draw(st.sampled_from((2, 2, 2, 1) if end else (1, 1, 0)))  # mostly held
        offsets = (-0.3 * length, 0.3 * length)[2 - count:] if end else (0.3 * length,)[:count]
        bearings = ", ".join(f'{{ name = "b{j}", offset_m = {o:.6g}, kind = '
                             f'"{draw(st.sampled_from(KINDS))}" }}'
                             for j, o in enumerate(offsets))
        mass = 10.0 * length
        parts.append(f'[[shafts]]\nname = "s{k}"\nlength_m = {length}\nmass_kg = {mass}\n'
                     f'inertia_kg_m2 = [{mass * length ** 2 / 12:.6g}, 0.02, '
                     f'{mass * length ** 2 / 12:.6g}]\nbearings = [{bearings}]\n')
    for k in range(n - 1):
        angle = draw(st.sampled_from([0.0, 3.0, 15.0, 30.0]))
        parts.append(f'[[joints]]\nname = "uj{k + 1}"\narticulation_deg = {angle}\n{CROSS}')
    if slip_in is not None:
        parts.append(f'[[slip_joints]]\nname = "spline"\nshaft = "s{slip_in}"\n'
                     f'offset_m = 0.0\npitch_radius_m = 0.025\n'
                     f'friction_coefficient = {0.15 if friction else 0.0}\n')
    return "\n".join(parts)


def _on_alarm(signum, frame):
    raise TimeoutError(f"a command ran for more than {COMMAND_S} s")


def run(argv: list[str]) -> tuple[int, str, str]:
    """``cardan ARGV`` in this process: exit code, stdout, stderr."""
    out, err = io.StringIO(), io.StringIO()
    previous = signal.signal(signal.SIGALRM, _on_alarm)
    signal.alarm(COMMAND_S)
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            code = main(argv)
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)
    return code, out.getvalue(), err.getvalue()


def strict(text: str):
    def refuse(constant):
        raise ValueError(f"not strict JSON: {constant}")
    return json.loads(text, parse_constant=refuse)


def check_sets(report: dict) -> None:
    """Intervals consistent by construction: ``min <= max``; a determinate component's
    interval is its value (``min == max == min_norm``, both finite)."""
    for name, c in report["components"].items():
        scale = 1e-6 * (1.0 + abs(c["min_norm"]))
        lo, hi = c["min"], c["max"]
        if lo is not None and hi is not None:
            assert lo <= hi + scale, (name, c)
        if c["determinate"]:
            assert lo is not None and hi is not None, (name, c)
            assert abs(lo - hi) <= scale and abs(lo - c["min_norm"]) <= scale, (name, c)


def check_solve(records: list) -> None:
    for r in records:
        assert r["status"] in ("solved", "inaccurate", "unbounded", "infeasible", "failed")
        if r["status"] == "solved":
            assert r["residuals"]["equilibrium"] <= 1e-6, r
            assert all(v is None or math.isfinite(v) for v in r["forces"].values()), r


COMMANDS = (
    (["scene", "check"], None),
    (["sets", "--t", str(T)], None),
    (["sets", "--t", str(T), "--json"], check_sets),
    (["solve", "--t", str(T), "--formulation", "positive", "--solver", "clarabel", "--json"],
     check_solve),
    (["sets", "--t", str(T), "--release", "--json"], lambda report: check_sets(report["released"])),
    (["secondary", "--torque", "50", "--out", "{out}"], None),
)
"""Each command (the scene file goes after its first word) and its check of a JSON answer."""


def answers_or_refuses(text: str) -> None:
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "line.toml"
        path.write_text(text)
        for argv, check in COMMANDS:
            argv = [argv[0], *argv[1:2], str(path), *argv[2:]] if argv[0] == "scene" else \
                [argv[0], str(path), *(a.format(out=folder) for a in argv[1:])]
            code, out, err = run(argv)
            where = f"cardan {' '.join(argv)} on\n{text}\nstderr: {err}"
            assert code in (0, 2), where
            if code == 2:
                assert err.count("\n") == 1 and err.startswith("cardan: error: "), where
                if "--json" in argv:
                    assert out == "", where
                if argv[0] == "scene":
                    return  # a refused scene: every command refuses it alike
                continue
            if "--json" in argv:
                check(strict(out))


SLIP_FIRST = (Path(__file__).parent / "data" / "slip_in_first_shaft.toml").read_text()
"""A line the property test found: a frictionless slip joint in the first of two shafts,
every bearing locating. SciPy's HiGHS presolve called an infeasible point the optimum
of its feasibility LP, and ``sets --json`` showed determinate components with null ends."""


@pytest.mark.slow
@settings(max_examples=6, derandomize=True, deadline=None, database=None,
          suppress_health_check=list(HealthCheck))
@given(lines(most_shafts=4))
@example(SLIP_FIRST)
def test_every_command_answers_or_refuses_on_generated_lines(text):
    answers_or_refuses(text)


@pytest.mark.slow
@settings(max_examples=60, derandomize=True, deadline=None, database=None,
          suppress_health_check=list(HealthCheck))
@given(lines(most_shafts=8))
def test_every_command_answers_or_refuses_on_generated_lines_up_to_8_shafts(text):
    answers_or_refuses(text)
