"""The life how-to's numbers are what ``cardan life`` gives now (docs/how-to/life.md:
"Why the built-in scenes' lives are long" over the window and at a speed, and the
engine spectrum's example)."""

import re
from pathlib import Path

import numpy as np
import pytest
from cardan_forces.driveline import duty
from cardan_forces.experiments import life

pytestmark = pytest.mark.slow  # a docs check: four life studies

PAGE = " ".join((Path(__file__).parents[1] / "docs/how-to/life.md").read_text().split())
SCENES = ("paper", "propshaft", "axle-pinion")
"""The scenes the paragraph speaks of."""


@pytest.fixture(scope="module")
def answers():
    return {scene: life.study(scene) for scene in SCENES}


def _lives(answers, key):
    return [s[key] for a in answers.values() for e in a["bearings"]
            for s in e["selections"].values() if s[key] is not None]


def _stated(pattern: str) -> float:
    return float(re.search(pattern, PAGE)[1])


def test_the_greatest_load_share_the_page_states_is_today_s(answers):
    stated = _stated(r"no bearing's greatest `P` passes ([\d.]+) %")
    peak = max(e["peak_P_over_C"] for a in answers.values() for e in a["bearings"])
    assert f"{100 * peak:.1f}" == f"{stated:.1f}"
    assert peak <= life.LIGHT_LOAD and "`P <= 0.05 C`" in PAGE


def test_the_lives_and_loads_the_page_states_hold(answers):
    """Each stated lower bound holds and is the bound's own decade (not stale); a
    window gives no hours."""
    stated = _stated(r"lives of ([\d.e+]+) million revolutions and more")
    least = min(_lives(answers, "L10_Mrev"))
    assert stated <= least < 10 * stated, least
    assert all(np.isnan(v) for v in _lives(answers, "L10_h"))
    assert "load its bearings with less than 1 kN" in PAGE
    loads = [np.nanmax(s["P_N"]) for e in answers["propshaft"]["bearings"]
             for s in e["selections"].values()]
    assert 100.0 < max(loads) < 1000.0


def test_the_hours_at_a_speed_the_page_states_hold():
    """The propshaft at the stated speed: the stated least hours, its own decade, and
    every bearing below its minimum load."""
    found = re.search(r"At (\d+) r/min \(`cardan life propshaft --speed-rpm (\d+)`\) the "
                      r"propshaft's bearings last ([\d.e+]+) hours and more, and every one "
                      r"of them is below its minimum load", PAGE)
    assert found and found[1] == found[2]
    answer = life.study("propshaft", speed_rpm=float(found[1]))
    least = min(s["L10_h"] for e in answer["bearings"] for s in e["selections"].values())
    assert float(found[3]) <= least < 10 * float(found[3])
    assert all(e["minimum_load"]["below"] for e in answer["bearings"])


def test_the_engine_spectrum_example_is_what_the_helper_gives():
    """The page's from_engine call, its mean speed and first gear's share of the
    revolutions as printed."""
    bins = duty.from_engine(engine_torque_N_m=400.0, engine_speed_rpm=2500.0,
                            gear_ratios=[3.8, 2.1, 1.0], time_shares=[0.1, 0.3, 0.6],
                            efficiency=0.96)
    assert "efficiency=0.96)" in PAGE
    assert f"sum t_i n_i = {duty.mean_speed_rpm(bins):.0f} r/min" in PAGE
    assert f"first gear {100 * duty.revolution_shares(bins)[0]:.1f} %" in PAGE
