"""ISO 281:2007 modified rating life ``L_nm = a1 a_ISO L10``: the reliability factor
against Table 12 and the Weibull law it is drawn from (ISO/TR 1281-2), the reference
viscosity and ``a_ISO`` against the standard's equations written out by hand and their
closed forms (``e_C C_u / P -> 0`` gives 0.1 for every ``kappa``, as the makers' a_ISO
diagrams note; the ranges of ``kappa`` meet; the limits 4, 0.1, 5 and 50), and the
reading of a rating's four inputs, each refused in one line naming its field."""

import copy
import dataclasses
import math

import numpy as np
import pytest
from cardan_forces.driveline import bearing_life as iso
from cardan_forces.driveline.loading import builtin_text, scene_from_dict
from cardan_forces.driveline.scene import (
    MEAN_DIAMETER_M,
    VISCOSITY_MM2_S,
    BearingRating,
    Range,
    SceneError,
)

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib

TABLE_12 = [(90.0, 1.0), (95.0, 0.64), (96.0, 0.55), (97.0, 0.47), (98.0, 0.37),
            (99.0, 0.25), (99.2, 0.22), (99.4, 0.19), (99.6, 0.16), (99.8, 0.12),
            (99.9, 0.093), (99.92, 0.087), (99.94, 0.08), (99.95, 0.077)]
"""ISO 281:2007 Table 12, reliability (%) and ``a1``, as printed."""


def _weibull_a1(r: float) -> float:
    """The law Table 12 is drawn from (ISO/TR 1281-2): Weibull slope 1.5, least life
    0.05 ``L10``."""
    return 0.95 * (math.log(100 / r) / math.log(100 / 90)) ** (2 / 3) + 0.05


def _by_hand(family: str, kappa: float, x: float) -> float:
    """``a_ISO`` as ISO 281:2007 prints it, with none of the package's tables, inside
    the limits (0.1 <= kappa <= 4, below the cap)."""
    if family == "ball":
        if kappa < 0.4:
            t = 2.5671 - 2.2649 / kappa ** 0.054381
        elif kappa < 1:
            t = 2.5671 - 1.9987 / kappa ** 0.19087
        else:
            t = 2.5671 - 1.9987 / kappa ** 0.071739
        return 0.1 * (1 - t ** 0.83 * x ** (1 / 3)) ** -9.3
    if kappa < 0.4:
        t = 1.5859 - 1.3993 / kappa ** 0.054381
    elif kappa < 1:
        t = 1.5859 - 1.2348 / kappa ** 0.19087
    else:
        t = 1.5859 - 1.2348 / kappa ** 0.071739
    return 0.1 * (1 - t * x ** 0.4) ** -9.185


BALL = BearingRating(type="ball", C_N=37100.0, C0_N=23200.0, C_u_N=1000.0,
                     mean_diameter_m=0.0725, viscosity_mm2_s=20.0, contamination=0.5)
ROLLER = BearingRating(type="tapered_roller", C_N=40200.0, C0_N=44000.0,
                       contact_angle_deg=15.0, X=0.4, Y=1.6, e=0.37, C_u_N=5000.0,
                       mean_diameter_m=0.06, viscosity_mm2_s=30.0, contamination=0.6)


def _with_kappa(rating: BearingRating, kappa: float, speed: float = 3000.0):
    """``rating`` with the viscosity that gives ``kappa`` at ``speed`` r/min."""
    nu1 = iso.rated_viscosity(speed, rating.mean_diameter_m * 1e3)
    return dataclasses.replace(rating, viscosity_mm2_s=kappa * nu1)


# ------------------------------------------------------------------ a1, Table 12


def test_a1_is_table_12_at_its_rows():
    for r, a1 in TABLE_12:
        assert iso.reliability_factor(r) == a1, r


def test_table_12_is_the_weibull_law_to_its_printed_digits():
    """Each row within half a unit of its last printed digit of the law: the table
    typed here is the standard's (a digit wrong by one fails)."""
    for r, a1 in TABLE_12:
        digits = len(repr(a1).split(".")[1])
        assert abs(_weibull_a1(r) - a1) <= 0.5 * 10 ** -max(digits, 2) + 1e-12, r


def test_a1_between_rows_is_linear_and_near_the_law():
    assert iso.reliability_factor(92.5) == pytest.approx((1.0 + 0.64) / 2, abs=1e-15)
    assert iso.reliability_factor(99.1) == pytest.approx((0.25 + 0.22) / 2, abs=1e-14)
    # in the widest gap the line runs below the law: the shorter life
    assert iso.reliability_factor(92.5) < _weibull_a1(92.5) < 0.83
    for r in np.linspace(90.0, 99.95, 200):
        assert abs(iso.reliability_factor(r) - _weibull_a1(r)) < 0.01, r


@pytest.mark.parametrize("r", [89.99, 99.951, 100.0, 50.0, math.nan])
def test_a1_outside_table_12_is_refused(r):
    with pytest.raises(ValueError, match=r"outside 90 to 99\.95 %, .*Table 12"):
        iso.reliability_factor(r)


def test_the_reliability_span_is_table_12s():
    assert iso.RELIABILITY_PERCENT == Range(90.0, 99.95, "%")


# ------------------------------------------------------------------- nu1


def test_rated_viscosity_is_the_standards_two_expressions():
    assert iso.rated_viscosity(1000.0, 100.0) == pytest.approx(4500 / 1e5 ** 0.5, rel=1e-14)
    assert iso.rated_viscosity(3000.0, 72.5) == pytest.approx(9.6490, rel=1e-4)
    assert iso.rated_viscosity(100.0, 100.0) == pytest.approx(98.449, rel=1e-4)
    assert iso.rated_viscosity(10.0, 25.0) == pytest.approx(45000 * 10 ** -0.83 / 5,
                                                            rel=1e-14)


def test_rated_viscosity_exponents():
    """Speed exponents -0.83 below and -0.5 from 1000 r/min, diameter -0.5 in both."""
    nu1 = iso.rated_viscosity
    assert nu1(400.0, 50.0) / nu1(200.0, 50.0) == pytest.approx(2 ** -0.83, rel=1e-13)
    assert nu1(8000.0, 50.0) / nu1(2000.0, 50.0) == pytest.approx(0.5, rel=1e-13)
    for n in (200.0, 2000.0):
        assert nu1(n, 200.0) / nu1(n, 50.0) == pytest.approx(0.5, rel=1e-13)


def test_rated_viscosity_steps_by_two_per_cent_at_1000_rpm():
    """The two expressions do not meet: just below 1000 r/min ``nu1`` is
    ``10 * 1000^-0.33 = 10^0.01 = 1.0233`` times its value at 1000 (with -5/6 for
    -0.83 they would meet)."""
    below = iso.rated_viscosity(1000.0 * (1 - 1e-12), 80.0)
    assert below / iso.rated_viscosity(1000.0, 80.0) == pytest.approx(10 ** 0.01, rel=1e-9)


def test_rated_viscosity_edges():
    assert iso.rated_viscosity(0.0, 50.0) == math.inf
    assert math.isnan(iso.rated_viscosity(math.nan, 50.0))
    for n, dm in ((-1.0, 50.0), (100.0, 0.0), (100.0, -5.0)):
        with pytest.raises(ValueError, match="nu1 needs"):
            iso.rated_viscosity(n, dm)


# ------------------------------------------------------------------- a_ISO

KAPPAS = (0.1, 0.15, 0.25, 0.39, 0.4, 0.55, 0.8, 0.99, 1.0, 1.5, 2.5, 4.0)
RATIOS = (0.005, 0.02, 0.1, 0.3)


@pytest.mark.parametrize("family", ["ball", "roller"])
def test_a_iso_is_the_standards_equations(family):
    for kappa in KAPPAS[1:]:  # 0.1: the next test
        for x in RATIOS:
            expected = _by_hand(family, kappa, x)
            if expected < 50:
                assert iso.a_iso(family, kappa, x) == pytest.approx(expected, rel=1e-12)


def test_a_iso_at_points_of_each_range():
    """One point of each range, ``e_C C_u / P = 0.1``, worked by hand to five digits
    (ball at 0.25: ``0.25^0.054381 = 0.927383``, ``2.5671 - 2.2649 / 0.927383 =
    0.124851``, ``^0.83 = 0.177835``, times ``0.1^(1/3) = 0.464159`` is 0.082544,
    ``0.1 * 0.917456^-9.3 = 0.22283``)."""
    assert iso.a_iso("ball", 0.25, 0.1) == pytest.approx(0.22283, rel=2e-4)
    assert iso.a_iso("ball", 0.6, 0.1) == pytest.approx(0.8012, rel=2e-4)
    assert iso.a_iso("ball", 2.0, 0.1) == pytest.approx(4.2015, rel=2e-4)
    assert iso.a_iso("roller", 0.25, 0.1) == pytest.approx(0.13312, rel=2e-4)
    assert iso.a_iso("roller", 0.6, 0.1) == pytest.approx(0.23644, rel=2e-4)
    assert iso.a_iso("roller", 2.0, 0.1) == pytest.approx(0.51610, rel=2e-4)


@pytest.mark.parametrize("family", ["ball", "roller"])
def test_no_fatigue_limit_term_gives_a_tenth(family):
    """``e_C C_u / P = 0`` (``e_C = 0`` or an unbounded load) gives 0.1 exactly for every
    ``kappa``: the bracket is 1."""
    for kappa in KAPPAS + (10.0,):
        assert iso.a_iso(family, kappa, 0.0) == 0.1


@pytest.mark.parametrize("family", ["ball", "roller"])
def test_the_ranges_of_kappa_meet(family):
    """At ``kappa = 1`` both ranges give the same value; at 0.4 they agree to the
    standard's printed digits (the term ``c - A / kappa^b`` to 4e-4 of itself)."""
    c = {"ball": 2.5671, "roller": 1.5859}[family]
    (_, a0, b0), (_, a1, b1), _ = iso.A_ISO_RANGES[family]
    low, high = c - a0 / 0.4 ** b0, c - a1 / 0.4 ** b1
    assert abs(low - high) < 4e-4 * high
    for x in RATIOS + (1.0,):
        assert iso.a_iso(family, 1.0 - 1e-12, x) == pytest.approx(
            iso.a_iso(family, 1.0, x), rel=1e-9)
        assert iso.a_iso(family, 0.4 - 1e-12, x) == pytest.approx(
            iso.a_iso(family, 0.4, x), rel=2e-3)


@pytest.mark.parametrize("family", ["ball", "roller"])
def test_a_tenth_at_the_least_kappa_whatever_the_load(family):
    """At ``kappa = 0.1`` the curves meet at 0.1: the term ``c - A / 0.1^b`` is 0 to the
    printed digits (a roller bearing's, -5.9e-5, taken as 0)."""
    for x in (0.01, 1.0, 5.0):
        assert iso.a_iso(family, 0.1, x) == pytest.approx(_by_hand(family, 0.1, x), rel=2e-3)
        assert 0.1 <= iso.a_iso(family, 0.1, x) < 0.1007


@pytest.mark.parametrize("family", ["ball", "roller"])
def test_limits_of_kappa_and_the_load_ratio_and_the_cap(family):
    assert iso.a_iso(family, 10.0, 0.1) == iso.a_iso(family, 4.0, 0.1)
    assert iso.a_iso(family, 0.2, 50.0) == iso.a_iso(family, 0.2, 5.0) < 50
    assert iso.a_iso(family, 4.0, 5.0) == 50.0
    assert math.isnan(iso.a_iso(family, 0.0999, 0.1))
    assert math.isnan(iso.a_iso(family, math.nan, 0.1))
    grid = [iso.a_iso(family, k, x) for k in np.linspace(0.1, 6, 60)
            for x in np.geomspace(1e-3, 100, 60)]
    assert max(grid) == 50.0 and min(grid) >= 0.1


@pytest.mark.parametrize("family", ["ball", "roller"])
def test_a_iso_rises_with_the_load_ratio_and_with_kappa_in_each_range(family):
    for kappa in KAPPAS:
        values = [iso.a_iso(family, kappa, x) for x in np.geomspace(1e-3, 5, 50)]
        assert all(np.diff(values) >= 0), kappa
    for lo, hi in ((0.1, 0.4), (0.4, 1.0), (1.0, 4.0)):
        values = [iso.a_iso(family, k, 0.05) for k in np.linspace(lo, hi * (1 - 1e-9), 30)]
        assert all(np.diff(values) > 0), (lo, hi)


def test_the_types_map_to_radial_ball_and_radial_roller():
    p, n = 4000.0, 1500.0
    ball = iso.life_modification_factor(BALL, p, n)
    angular = dataclasses.replace(BALL, type="angular_contact_ball", contact_angle_deg=25.0)
    assert iso.life_modification_factor(angular, p, n) == ball
    taper = iso.life_modification_factor(ROLLER, p, n)
    cylinder = dataclasses.replace(ROLLER, type="cylindrical_roller", contact_angle_deg=0.0)
    assert iso.life_modification_factor(cylinder, p, n) == taper
    assert ball[0] == pytest.approx(_by_hand("ball", ball[1], 0.5 * 1000.0 / p), rel=1e-12)
    assert taper[0] == pytest.approx(_by_hand("roller", taper[1], 0.6 * 5000.0 / p),
                                     rel=1e-12)


def test_kappa_is_the_viscosity_over_nu1():
    a, kappa, reason = iso.life_modification_factor(BALL, 4000.0, 3000.0)
    assert kappa == pytest.approx(20.0 / (4500 / (3000 * 72.5) ** 0.5), rel=1e-12)
    assert reason is None
    a, kappa, _ = iso.life_modification_factor(_with_kappa(BALL, 9.0), 4000.0, 3000.0)
    assert kappa == pytest.approx(9.0) and a == iso.a_iso("ball", 4.0, 0.125)


def test_contamination_zero_gives_a_tenth():
    clean_none = dataclasses.replace(BALL, contamination=0.0)
    for kappa in (0.3, 0.7, 2.0):
        a, _, reason = iso.life_modification_factor(_with_kappa(clean_none, kappa), 1e3, 3e3)
        assert a == 0.1 and reason is None


def test_no_value_and_its_reason():
    bare = BearingRating(type="ball", C_N=37100.0, C0_N=23200.0)
    a, kappa, reason = iso.life_modification_factor(bare, 4000.0, 3000.0)
    assert math.isnan(a) and math.isnan(kappa)
    assert reason.startswith("no ISO 281:2007 inputs: ") and "C_u_N" in reason
    thin = _with_kappa(BALL, 0.05)
    a, kappa, reason = iso.life_modification_factor(thin, 4000.0, 3000.0)
    assert math.isnan(a) and kappa == pytest.approx(0.05) and "below 0.1" in reason
    a, kappa, reason = iso.life_modification_factor(BALL, 4000.0, 0.0)
    assert math.isnan(a) and kappa == 0.0 and "does not turn" in reason
    a, _, reason = iso.life_modification_factor(BALL, math.nan, 3000.0)
    assert math.isnan(a) and "P is not known" in reason


def test_an_unloaded_bearing_takes_the_load_ratio_at_its_limit():
    """``P <= 0``: ``e_C C_u / P`` unbounded, taken as 5, the limit of ``P -> 0``: the
    cap 50 where ``kappa`` is high enough, below it where not; said in the reason."""
    a, _, reason = iso.life_modification_factor(_with_kappa(BALL, 1.0), 0.0, 3000.0)
    assert a == 50.0 and reason.startswith("unloaded (P = 0 N)")
    low = _with_kappa(BALL, 0.2)
    a, _, reason = iso.life_modification_factor(low, 0.0, 3000.0)
    assert a == iso.a_iso("ball", 0.2, 5.0) < 50 and "unloaded" in reason
    assert a == pytest.approx(iso.life_modification_factor(low, 1e-9, 3000.0)[0])


# ------------------------------------------------------------------- L_nm


def test_modified_life_is_a1_a_iso_l10():
    l10 = 500.0
    out = iso.modified_life(ROLLER, l10, 6000.0, 1500.0, reliability_percent=99.0)
    assert set(out) == {"a1", "a_ISO", "kappa", "nu1_mm2_s", "L_nm_Mrev", "reason"}
    a, kappa, reason = iso.life_modification_factor(ROLLER, 6000.0, 1500.0)
    assert (out["a1"], out["a_ISO"], out["kappa"], out["reason"]) == (0.25, a, kappa, reason)
    assert out["nu1_mm2_s"] == pytest.approx(4500 / (1500 * 60) ** 0.5, rel=1e-12)
    assert out["L_nm_Mrev"] == pytest.approx(0.25 * a * l10, rel=1e-15)
    assert iso.modified_life(ROLLER, l10, 6000.0, 1500.0)["a1"] == 1.0


def test_modified_life_without_a_value():
    out = iso.modified_life(ROLLER, math.inf, 0.0, 1500.0)
    assert out["L_nm_Mrev"] == math.inf and "unloaded" in out["reason"]
    out = iso.modified_life(ROLLER, math.nan, 6000.0, 1500.0)
    assert math.isnan(out["L_nm_Mrev"]) and "L10 is not known" in out["reason"]
    bare = BearingRating(type="ball", C_N=37100.0, C0_N=23200.0)
    out = iso.modified_life(bare, 100.0, 2000.0, 1500.0)
    assert math.isnan(out["L_nm_Mrev"]) and math.isnan(out["nu1_mm2_s"])
    assert out["reason"].startswith("no ISO 281:2007 inputs")
    with pytest.raises(ValueError, match="Table 12"):
        iso.modified_life(ROLLER, 100.0, 6000.0, 1500.0, reliability_percent=99.99)


# ------------------------------------------------------------------- reading

INPUTS = {"C_u_N": 5000.0, "mean_diameter_m": 0.06, "viscosity_mm2_s": 30.0,
          "contamination": 0.5}
FIELD = "shafts[2].bearings[0].rating"


def _pinion(**changes) -> dict:
    """``axle-pinion`` as a dict, its first pinion rating given the four inputs with
    ``changes`` (a value ``None`` leaves that key out)."""
    raw = copy.deepcopy(tomllib.loads(builtin_text("axle-pinion")))
    rating = raw["shafts"][2]["bearings"][0]["rating"]
    for key, value in {**INPUTS, **changes}.items():
        if value is not None:
            rating[key] = value
    return raw


def test_a_rating_with_the_four_inputs_loads():
    scene = scene_from_dict(_pinion(), "s.toml")
    rating = scene.shafts[2].bearings[0].rating
    assert (rating.C_u_N, rating.mean_diameter_m, rating.viscosity_mm2_s,
            rating.contamination) == tuple(INPUTS.values())
    assert scene.shafts[2].bearings[1].rating.C_u_N is None
    out = iso.modified_life(rating, 100.0, 6000.0, 1500.0)
    assert out["reason"] is None and out["L_nm_Mrev"] > 0


def _refusal(**changes) -> str:
    with pytest.raises(SceneError) as err:
        scene_from_dict(_pinion(**changes), "s.toml")
    message = str(err.value)
    assert "\n" not in message
    return message


@pytest.mark.parametrize("key", list(INPUTS))
def test_the_four_inputs_come_together(key):
    message = _refusal(**{key: None})
    assert message.startswith(f"scene s.toml: field '{FIELD}.{key}': missing: ")
    assert "together, or none" in message


@pytest.mark.parametrize("key, value, says", [
    ("C_u_N", 44000.0, "below C0_N = 44000 N"),
    ("C_u_N", 60000.0, "below C0_N = 44000 N"),
    ("C_u_N", 0.0, "must be positive"),
    ("C_u_N", -10.0, "must be positive"),
    ("C_u_N", "5 kN", "expected a number"),
    ("mean_diameter_m", 0.0019, f"0.0019 m is outside {MEAN_DIAMETER_M}"),
    ("mean_diameter_m", 3.0, f"3 m is outside {MEAN_DIAMETER_M}"),
    ("mean_diameter_m", 0.0, "must be positive"),
    ("viscosity_mm2_s", 0.5, f"0.5 mm^2/s is outside {VISCOSITY_MM2_S}"),
    ("viscosity_mm2_s", 2e4, f"20000 mm^2/s is outside {VISCOSITY_MM2_S}"),
    ("viscosity_mm2_s", math.nan, "must be finite"),
    ("contamination", 0.0, "above 0 and at most 1"),
    ("contamination", 1.01, "above 0 and at most 1"),
    ("contamination", -0.2, "must not be negative"),
])
def test_a_bad_input_is_refused_naming_its_field(key, value, says):
    message = _refusal(**{key: value})
    assert message.startswith(f"scene s.toml: field '{FIELD}.{key}': "), message
    assert says in message, message


def test_the_ranges_ends_are_accepted():
    for key, rng in (("mean_diameter_m", MEAN_DIAMETER_M),
                     ("viscosity_mm2_s", VISCOSITY_MM2_S)):
        for value in (rng.least, rng.most):
            scene_from_dict(_pinion(**{key: value}), "s.toml")
    scene_from_dict(_pinion(contamination=1.0, C_u_N=43999.0), "s.toml")
