"""The built-in scenes that carry real loads: ``light-truck`` (a hypoid axle pinion on
a tapered pair, rated over a duty cycle) and ``transfer-output`` (the same line driven
through a helical gear on its first shaft). Their data say what their comments say,
and a bearing's loads and life agree with a calculation by hand from the gear's
ISO 6336 loads."""

import math

import numpy as np
import pytest
from cardan_forces.driveline import bearing_life as iso
from cardan_forces.driveline.duty import from_engine
from cardan_forces.driveline.dynamics import simulate
from cardan_forces.driveline.equilibrium import build_operator
from cardan_forces.driveline.loading import load_scene
from cardan_forces.experiments import life_report, life_study
from cardan_forces.experiments.life_study import loads, rated
from cardan_forces.experiments.study import solve_over_time

# the engine, gears and shares light-truck.toml's comment states
ENGINE = dict(engine_torque_N_m=[220, 220, 200, 180, 160, 150],
              engine_speed_rpm=[2000, 2200, 2300, 2300, 2200, 2100],
              gear_ratios=[5.0, 2.6, 1.52, 1.0, 0.79, 0.64],
              time_shares=[0.02, 0.05, 0.13, 0.2, 0.3, 0.3], efficiency=0.97)


def test_the_duty_cycle_is_the_engines_through_the_gears_the_comment_names():
    assert load_scene("light-truck").duty_cycle == from_engine(**ENGINE)
    assert load_scene("transfer-output").duty_cycle == load_scene("light-truck").duty_cycle


def _hand(torque_N_m: float) -> tuple[float, float]:
    """The gearbox shaft's locating (upstream) bearing by hand, the helical gear midway
    between its two bearings 0.3 m apart: ISO 6336-1's ``Ft = T / r``,
    ``Fr = Ft tan(alpha_n) / cos(beta)``, ``Fa = Ft tan(beta)``; each bearing takes
    half of ``Ft`` and of ``Fr``, and the axial force's moment about the gear's centre,
    ``r Fa`` (it acts on the pitch circle), adds ``r Fa / 0.3`` to the upstream
    bearing's share of ``Fr`` (the driven gear's thrust points upstream for a positive
    helix); the locating bearing takes all of ``Fa``. The joints' secondary couples
    and the weight are left out."""
    r, span = 0.055, 0.3
    ft = torque_N_m / r
    fr = ft * math.tan(math.radians(20.0)) / math.cos(math.radians(25.0))
    fa = ft * math.tan(math.radians(25.0))
    return math.hypot(ft / 2.0, fr / 2.0 + r * fa / span), fa


def test_the_transfer_cases_locating_bearing_carries_the_gears_loads():
    """At the first bin's 1067 N m: radial within 2 % of the hand value (the joint's
    secondary couple, ``T tan(3 deg)`` over the 0.3 m bearing span, and the shaft's
    weight add up to about 2 %; leaving out the thrust's moment would miss by 7 %),
    axial within 0.5 % (the slip joint frees the line behind the first joint, so the
    locating bearing takes the mesh's thrust alone)."""
    scene = load_scene("transfer-output")
    op = build_operator(simulate(scene, np.linspace(0.0, scene.time.stop_s, 5)))
    contact, rating = next((c, r) for c, r in rated(op) if c.element == "gearbox.rear")
    fr, fa = loads(op, contact, solve_over_time(op, "positive").forces)
    radial, axial = _hand(scene.input_torque.mean_N_m)
    assert fr == pytest.approx(radial, rel=0.02)
    assert np.abs(fa) == pytest.approx(axial, rel=0.005)
    p = iso.equivalent_load(rating, fr, fa)
    x, y, _ = iso.factors(rating, axial)
    assert p == pytest.approx(float(x) * radial + float(y) * axial, rel=0.02)


def test_the_pinion_pairs_worst_case_is_open_by_its_preload_with_no_release():
    """The slip joint leaves no loop and no axial split: only the O-arranged pair's
    preload is free, which no release removes (the design states it)."""
    motion = simulate(load_scene("light-truck"), [0.0, 0.05])
    op = build_operator(motion)
    assert "bearing pair's preload is free" in life_study._open_reason(motion, op)
    release = life_study._release(motion)
    assert release["labels"] == [] and "preload bounds the worst case" in release["words"]


@pytest.mark.slow
@pytest.mark.parametrize("scene, loaded", [
    ("light-truck", ("pinion.tail", "pinion.head")),
    ("transfer-output", ("gearbox.rear", "gearbox.front", "pinion.tail", "pinion.head"))])
def test_loaded_bearings_live_hundreds_to_a_million_hours(scene, loaded):
    """Over the duty cycle every selection's L10 and L_nm of a loaded bearing lie between
    1e2 and 1e6 hours (a catalogue calculation's range for such loads), the others are
    named lightly loaded, and each selection lies in the rigid set's interval."""
    answer = life_study.study(scene, instants=9, engine=False)
    for entry in answer["bearings"]:
        for name, sel in entry["selections"].items():
            assert sel["in_set"]["inside"], (entry["bearing"], name)
            if entry["bearing"] in loaded:
                assert 1e2 <= sel["L10_h"] <= 1e6 and 1e2 <= sel["L_nm_h"] <= 1e6
            else:
                assert entry["peak_P_over_C"] <= life_report.LIGHT_LOAD
    words = life_report.markdown(answer)
    assert "Lightly loaded (P <= 0.05 C): " in words
    assert "bearing pair's preload is free" in words
