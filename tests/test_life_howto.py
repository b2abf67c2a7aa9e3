"""The life how-to's numbers are what ``cardan life`` gives now (docs/how-to/life.md:
"Why the built-in scenes' lives are long" over the window and at a speed, and the
engine spectrum's example)."""

import re
from pathlib import Path

import numpy as np
import pytest
from cardan_forces.driveline import duty
from cardan_forces.experiments import life_report, life_study

pytestmark = pytest.mark.slow  # a docs check: four life studies

PAGE = " ".join((Path(__file__).parents[1] / "docs/how-to/life.md").read_text().split())
SCENES = ("paper", "propshaft", "axle-pinion")
"""The scenes the paragraph speaks of."""


@pytest.fixture(scope="module")
def answers():
    return {scene: life_study.study(scene) for scene in SCENES}


def _lives(answers, key):
    return [s[key] for a in answers.values() for e in a["bearings"]
            for s in e["selections"].values() if s[key] is not None]


def _stated(pattern: str) -> float:
    return float(re.search(pattern, PAGE)[1])


def test_the_greatest_load_share_the_page_states_is_today_s(answers):
    stated = _stated(r"no bearing's greatest `P` passes ([\d.]+) %")
    peak = max(e["peak_P_over_C"] for a in answers.values() for e in a["bearings"])
    assert f"{100 * peak:.1f}" == f"{stated:.1f}"
    assert peak <= life_report.LIGHT_LOAD and "`P <= 0.05 C`" in PAGE


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
    answer = life_study.study("propshaft", speed_rpm=float(found[1]))
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


@pytest.fixture(scope="module")
def real():
    return {scene: life_study.study(scene, engine=False) for scene in ("light-truck",
                                                                 "transfer-output")}


def _g(value: float) -> str:
    """Two digits as the page prints them (``1.5e3``)."""
    return f"{value:.2g}".replace("e+0", "e")


def _bearing(answer, name):
    return next(e for e in answer["bearings"] if e["bearing"] == name)


def test_the_real_loads_section_states_today_s_lives(real):
    """light-truck's head and tail bearings and transfer-output's locating bearing, to
    the two digits printed; the head's greatest P over C and its a_ISO's ends."""
    head = _bearing(real["light-truck"], "pinion.head")
    sel = head["selections"]["positive"]
    stated = f"an `L10` of {_g(sel['L10_h'])} hours and an `L_nm` of {_g(sel['L_nm_h'])} hours"
    assert stated in PAGE
    assert f"is {100 * head['peak_P_over_C']:.0f} % of `C`" in PAGE
    a_iso = sel["a_ISO"]
    assert f"`a_ISO` runs from {a_iso[0]:.2g} in first gear to {a_iso[-1]:.2g} in sixth" in PAGE
    tail = _bearing(real["light-truck"], "pinion.tail")["selections"]["positive"]
    assert f"The tail bearing lives {_g(tail['L10_h'])} hours" in PAGE
    rear = _bearing(real["transfer-output"], "gearbox.rear")["selections"]["positive"]
    assert f"an `L10` of {_g(rear['L10_h'])} hours (`L_nm` {_g(rear['L_nm_h'])} hours)" in PAGE
