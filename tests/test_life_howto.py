"""The life how-to's numbers on the built-in scenes' lives are what ``cardan life``
gives now (docs/how-to/life.md, "Why the built-in scenes' lives are long")."""

import re
from pathlib import Path

import numpy as np
import pytest
from cardan_forces.experiments import life

pytestmark = pytest.mark.slow  # a docs check: three life studies

PAGE = " ".join((Path(__file__).parents[1] / "docs/how-to/life.md").read_text().split())
SCENES = ("paper", "propshaft", "axle-pinion")
"""The scenes the paragraph speaks of."""


@pytest.fixture(scope="module")
def answers():
    return {scene: life.study(scene) for scene in SCENES}


def _lives(answers, key):
    return [s[key] for a in answers.values() for e in a["bearings"]
            for s in e["selections"].values() if s[key] is not None]


def test_the_greatest_load_share_the_page_states_is_today_s(answers):
    stated = float(re.search(r"no bearing's greatest `P` passes ([\d.]+) %", PAGE)[1])
    peak = max(e["peak_P_over_C"] for a in answers.values() for e in a["bearings"])
    assert f"{100 * peak:.1f}" == f"{stated:.1f}"
    assert peak <= life.LIGHT_LOAD and "`P <= 0.05 C`" in PAGE


def _stated(pattern: str) -> float:
    return float(re.search(pattern, PAGE)[1])


def test_the_lives_and_loads_the_page_states_hold(answers):
    """Each stated lower bound holds and is the bound's own decade (not stale)."""
    for key, pattern in (("L10_h", r"lives come out at ([\d.e+]+) hours and more"),
                         ("L10_Mrev", r"lives of ([\d.e+]+) million revolutions and more")):
        stated, least = _stated(pattern), min(_lives(answers, key))
        assert stated <= least < 10 * stated, (key, least)
    assert "load its bearings with less than 1 kN" in PAGE
    loads = [np.nanmax(s["P_N"]) for e in answers["propshaft"]["bearings"]
             for s in e["selections"].values()]
    assert 100.0 < max(loads) < 1000.0
