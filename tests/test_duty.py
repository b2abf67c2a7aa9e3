"""Load spectra (driveline/duty.py): the engine's spectrum at the gearbox output by hand,
the mean speed and the revolution shares, Palmgren-Miner against its closed form, and a
spectrum that is none refused."""

import math

import numpy as np
import pytest
from cardan_forces.driveline import bearing_life as iso
from cardan_forces.driveline import duty
from cardan_forces.driveline.loading import load_scene
from cardan_forces.driveline.scene import BearingRating, DutyBin, SceneError

ENGINE = dict(engine_torque_N_m=400.0, engine_speed_rpm=2500.0,
              gear_ratios=[3.8, 2.1, 1.0], time_shares=[0.1, 0.3, 0.6], efficiency=0.96)
"""A car's engine at its greatest torque through three gears."""


def test_from_engine_by_hand():
    """T = T_e i eta and n = n_e / i per gear, written out: first gear carries the
    propshaft's design torque 400 * 3.8 * 0.96 = 1459.2 N m at 2500 / 3.8 r/min."""
    bins = duty.from_engine(**ENGINE)
    assert bins == pytest.approx((DutyBin(1459.2, 2500 / 3.8, 0.1),
                                  DutyBin(806.4, 2500 / 2.1, 0.3), DutyBin(384.0, 2500.0, 0.6)))
    per_gear = duty.from_engine([300.0, 350.0, 400.0], [2000.0, 2500.0, 3000.0],
                                [3.8, 2.1, 1.0], [0.1, 0.3, 0.6])
    assert [(b.torque_N_m, b.speed_rpm) for b in per_gear] == pytest.approx(
        [(1140.0, 2000 / 3.8), (735.0, 2500 / 2.1), (400.0, 3000.0)])


def test_mean_speed_and_revolution_shares_by_hand():
    """n_m = sum t_i n_i; u_i = t_i n_i / n_m: first gear's 10 % of the time is 3.4 %
    of the revolutions."""
    bins = duty.from_engine(**ENGINE)
    mean = 0.1 * 2500 / 3.8 + 0.3 * 2500 / 2.1 + 0.6 * 2500
    assert duty.mean_speed_rpm(bins) == pytest.approx(mean) == pytest.approx(1922.9323)
    u = duty.revolution_shares(bins)
    assert u == pytest.approx([0.1 * 2500 / 3.8 / mean, 0.3 * 2500 / 2.1 / mean,
                               0.6 * 2500 / mean])
    assert u.sum() == pytest.approx(1.0) and u[0] == pytest.approx(0.034213, rel=1e-4)
    assert duty.mean_speed_rpm(bins, [2 * b.speed_rpm for b in bins]) == pytest.approx(
        2 * mean)  # a shaft at twice the input's speed
    assert duty.revolution_shares(bins, [2 * b.speed_rpm for b in bins]) == pytest.approx(u)


def test_palmgren_miner_two_bins_by_hand():
    """A ball bearing of C = 50 kN at P = 5 kN for 20 % of its revolutions and 2 kN for
    80 %: L = 1 / (0.2 / 1000 + 0.8 / 15625) = 3980.9 million revolutions, the life at
    ISO 281's mean load Pm = (0.2 * 5^3 + 0.8 * 2^3)^(1/3) = 3.1548 kN."""
    u, lives = [0.2, 0.8], [(50 / 5) ** 3, (50 / 2) ** 3]
    assert lives == [1000.0, 15625.0]
    assert duty.miner_life(lives, u) == pytest.approx(1 / (0.2 / 1000 + 0.8 / 15625))
    assert duty.miner_life(lives, u) == pytest.approx(3980.89, rel=1e-6)
    pm = iso.mean_load(np.array([5e3, 2e3]), np.array(u), 3.0)
    assert pm == pytest.approx(31.4 ** (1 / 3) * 1e3)
    ball = BearingRating(type="ball", C_N=50e3, C0_N=30e3)
    assert iso.rating_life(ball, pm) == pytest.approx(duty.miner_life(lives, u), rel=1e-12)


def test_miner_without_damage_or_value():
    """A bin of infinite life does no damage, one of life 0 ends it, one without a value
    leaves none; a bin taking no revolutions counts for nothing."""
    assert duty.miner_life([math.inf, 100.0], [0.5, 0.5]) == pytest.approx(200.0)
    assert duty.miner_life([math.inf, math.inf], [0.5, 0.5]) == math.inf
    assert duty.miner_life([0.0, 100.0], [0.5, 0.5]) == 0.0
    assert math.isnan(duty.miner_life([math.nan, 100.0], [0.5, 0.5]))
    assert duty.miner_life([math.nan, 100.0], [0.0, 1.0]) == pytest.approx(100.0)


@pytest.mark.parametrize("change, words", [
    (dict(time_shares=[0.5, 0.5]), "one time share per gear"),
    (dict(time_shares=[0.1, 0.3, 0.5]), "sum to 0.9"),
    (dict(gear_ratios=[3.8, 0.0, 1.0]), "gear ratio must be positive"),
    (dict(engine_torque_N_m=-1.0), "engine torque must be positive"),
    (dict(engine_speed_rpm=[2500.0, math.nan, 2500.0]), "engine speed"),
    (dict(efficiency=1.2), "efficiency"),
])
def test_a_spectrum_that_is_none_is_refused(change, words):
    with pytest.raises(ValueError, match=words):
        duty.from_engine(**{**ENGINE, **change})


def test_an_engine_spectrum_is_a_scene_s_duty_cycle():
    """The helper's bins pass the scene's own checks (its reader, through a variant)."""
    bins = duty.from_engine(**ENGINE)
    scene = load_scene("propshaft").with_changes(duty_cycle=bins)
    assert scene.duty_cycle == bins
    with pytest.raises(SceneError, match="sum to 1.2"):
        load_scene("propshaft").with_changes(duty_cycle=(*bins, DutyBin(100.0, 900.0, 0.2)))
