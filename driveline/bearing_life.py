"""ISO 281 basic rating life of a rolling bearing: the equivalent dynamic load, the
duty cycle's mean load and ``L10``, from a bearing's catalogue data
(:class:`~.scene.BearingRating`) and its radial and axial loads over time.

- Equivalent dynamic radial load (ISO 281, radial ball and radial roller bearings):
  ``P = X Fr + Y Fa`` where ``Fa / Fr > e``, ``P = Fr`` where ``Fa / Fr <= e``
  (``X = 1``, ``Y = 0``), with ``Fa`` the magnitude of the axial load.
- Factors where the scene gives none (:func:`factors`):

  * ``ball`` (single-row radial, contact angle 0): ``X = 0.56`` and ``e``, ``Y`` by the
    relative axial load ``Fa / C0`` from the rows of ISO 281:1990 Table 3
    (:data:`DEEP_GROOVE_ROWS`, nine rows 0.014 to 0.56), linear between rows and held at
    the end rows outside them (the 2007 edition writes the rows as ``f0 Fa / C0`` with
    the bearing's geometry factor ``f0``; the 1990 form needs no ``f0``);
  * ``angular_contact_ball`` (single row): ``X``, ``Y``, ``e`` of Table 3's rows for
    contact angles 20, 25, 30, 35, 40 and 45 deg (:data:`ANGULAR_ROWS`), linear in the
    angle between rows (Table 3's note allows it); 5 to 15 deg, whose rows depend on
    ``Fa / C0``, are not implemented (the scene then gives ``X``, ``Y``, ``e``);
  * ``tapered_roller`` (single row, ``alpha != 0``, the radial roller bearings'
    factors): ``e = 1.5 tan alpha``,
    ``X = 0.4``, ``Y = 0.4 cot alpha``;
  * ``cylindrical_roller`` (``alpha = 0``): radial load only, ``P = Fr`` (a radial
    roller bearing of contact angle 0 is rated under radial load only).

- Basic rating life: ``L10 = (C / P)^p`` million revolutions, ``p = 3`` for
  ball and ``10/3`` for roller bearings.
- Variable load, the duty cycle's mean load: ``Pm = (sum P_i^p n_i / sum n_i)^(1/p)``
  over the revolutions ``n_i`` of each stretch.

Where ``Pm`` or ``L10`` has no finite value (a shaft that does not turn, a load not
known, no load, an unbounded load), :func:`no_value_reason` says why in words, so that
no answer carries an undefined number without its reason.

ISO 281:2007 modified rating life (clause 9), :func:`modified_life`:
``L_nm = a1 a_ISO L10`` (million revolutions).

- ``a1``, the life modification factor for reliability (:func:`reliability_factor`):
  ISO 281:2007 Table 12, 90 % (1) to 99.95 % (0.077), linear between its rows.
- ``nu1``, the reference (rated) kinematic viscosity (mm^2/s, :func:`rated_viscosity`):
  ``45000 n^-0.83 D_pw^-0.5`` for ``n < 1000`` r/min and ``4500 n^-0.5 D_pw^-0.5``
  for ``n >= 1000`` r/min, speed ``n`` in r/min and pitch diameter ``D_pw`` in mm (the
  rating's mean diameter ``(d + D) / 2`` stands for it, as catalogues take it).
- ``kappa = nu / nu1``, the viscosity ratio, ``nu`` the lubricant's kinematic
  viscosity at operating temperature (mm^2/s).
- ``a_ISO``, the life modification factor for the systems approach
  (:func:`life_modification_factor`), with ``x = e_C C_u / P`` (``e_C`` the
  contamination factor of Table 13, ``C_u`` the fatigue load limit, N; ``P`` the
  equivalent dynamic load, N):

  * radial ball bearings: ``a_ISO = 0.1 [1 - (2.5671 - A / kappa^b)^0.83 x^(1/3)]^-9.3``,
  * radial roller bearings: ``a_ISO = 0.1 [1 - (1.5859 - A / kappa^b) x^0.4]^-9.185``,

  with ``(A, b)`` by the range of ``kappa`` (:data:`A_ISO_RANGES`):
  0.1 <= kappa < 0.4: ball (2.2649, 0.054381), roller (1.3993, 0.054381);
  0.4 <= kappa < 1: ball (1.9987, 0.19087), roller (1.2348, 0.19087);
  1 <= kappa <= 4: ball (1.9987, 0.071739), roller (1.2348, 0.071739).
  The ranges meet: at ``kappa = 1`` the coefficients are equal; at 0.4 the terms
  ``c - A / kappa^b`` of the two ranges agree to the printed digits (to 7e-5 of 0.186
  for ball, 7e-7 of 0.115 for roller bearings). At ``kappa = 0.1`` that term is next to
  0 (7.5e-5 ball, -5.9e-5 roller, taken as 0 where below it), so ``a_ISO`` is 0.1
  there whatever the load, and never below 0.1.
  The standard's limits: ``kappa > 4`` is taken as 4; ``kappa < 0.1`` is outside the
  standard (no value); ``a_ISO <= 50``.
  ``x`` is taken as at most 5, the end of the standard's ``a_ISO`` diagrams (``a_ISO``
  rises with ``x``, so the clamp errs towards a shorter life). ``e_C = 0`` gives
  ``a_ISO = 0.1`` for every ``kappa``. The standard's allowance for EP additives
  (``kappa = 1`` with ``a_ISO <= 3`` where ``kappa < 1`` and ``e_C >= 0.2``) is not
  taken: a scene does not say whether its lubricant has them.
"""

from __future__ import annotations

import math

import numpy as np

from .scene import BearingRating, Range

DEEP_GROOVE_ROWS = np.array([
    # Fa / C0, e, Y      (X = 0.56 where Fa / Fr > e)
    (0.014, 0.19, 2.30), (0.028, 0.22, 1.99), (0.056, 0.26, 1.71),
    (0.084, 0.28, 1.55), (0.11, 0.30, 1.45), (0.17, 0.34, 1.31),
    (0.28, 0.38, 1.15), (0.42, 0.42, 1.04), (0.56, 0.44, 1.00),
])
"""ISO 281:1990 Table 3, single-row radial (deep-groove) ball bearings."""

DEEP_GROOVE_X = 0.56
"""``X`` of a radial ball bearing where ``Fa / Fr > e`` (Table 3)."""

ANGULAR_ROWS = np.array([
    # alpha (deg), X, Y, e   (single row, Fa / Fr > e)
    (20.0, 0.43, 1.00, 0.57), (25.0, 0.41, 0.87, 0.68), (30.0, 0.39, 0.76, 0.80),
    (35.0, 0.37, 0.66, 0.95), (40.0, 0.35, 0.57, 1.14), (45.0, 0.33, 0.50, 1.34),
])
"""ISO 281 Table 3, single-row angular-contact ball bearings, 20 to 45 deg."""

MILLION = 1e6
"""Revolutions in a unit of ``L10`` (ISO 281 states it in millions)."""


def exponent(rating: BearingRating) -> float:
    """The life exponent ``p``: 3 for ball, 10/3 for roller bearings."""
    return 10.0 / 3.0 if rating.roller else 3.0


def factors(rating: BearingRating, fa: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(X, Y, e)`` where ``Fa / Fr > e`` for axial loads ``fa`` (N, magnitudes; only a
    radial ball bearing's depend on them, through ``Fa / C0``), each shaped as ``fa``.
    """
    fa = np.abs(np.asarray(fa, float))
    ones = np.ones_like(fa)
    if rating.X is not None:
        return rating.X * ones, rating.Y * ones, rating.e * ones
    if rating.type == "ball":
        rows = DEEP_GROOVE_ROWS
        rel = fa / rating.C0_N
        return (DEEP_GROOVE_X * ones, np.interp(rel, rows[:, 0], rows[:, 2]),
                np.interp(rel, rows[:, 0], rows[:, 1]))
    if rating.type == "angular_contact_ball":
        alpha = rating.contact_angle_deg
        rows = ANGULAR_ROWS
        return tuple(np.interp(alpha, rows[:, 0], rows[:, k]) * ones for k in (1, 2, 3))
    if rating.type == "tapered_roller":
        alpha = math.radians(rating.contact_angle_deg)
        return 0.4 * ones, 0.4 / math.tan(alpha) * ones, 1.5 * math.tan(alpha) * ones
    return ones, 0.0 * ones, math.inf * ones  # cylindrical roller: P = Fr


def equivalent_load(rating: BearingRating, fr, fa) -> np.ndarray:
    """``P`` (N) for radial loads ``fr`` >= 0 and axial loads ``fa`` (N, either sign):
    ``X Fr + Y |Fa|`` where ``|Fa| > e Fr``, else ``Fr``. NaN in, NaN out;
    an infinite load gives an infinite ``P``.
    """
    fr = np.asarray(fr, float)
    fa = np.abs(np.asarray(fa, float))
    x, y, e = factors(rating, fa)
    with np.errstate(invalid="ignore"):
        axial = fa > e * fr
        return np.where(axial, x * fr + y * fa, fr)


def revolutions(omega: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Revolutions of a shaft turning at ``omega`` (rad/s) over the stretch each instant
    of ``t`` (s) stands for (trapezoid weights: half of each neighbouring step).
    """
    t = np.asarray(t, float)
    if len(t) < 2:
        return np.zeros(len(t))
    steps = np.diff(t)
    weights = np.concatenate([[0.0], steps]) / 2.0 + np.concatenate([steps, [0.0]]) / 2.0
    return np.abs(np.asarray(omega, float)) * weights / (2.0 * math.pi)


def mean_load(p_values: np.ndarray, revs: np.ndarray, p: float) -> float:
    """The duty cycle's mean load ``Pm = (sum P_i^p n_i / sum n_i)^(1/p)`` (N); NaN when
    the shaft makes no revolution or a load is NaN, ``inf`` when a load is.
    """
    p_values, revs = np.asarray(p_values, float), np.asarray(revs, float)
    total = revs.sum()
    if not total > 0 or np.isnan(p_values[revs > 0]).any():
        return math.nan
    scale = float(np.max(p_values[revs > 0], initial=0.0))
    if not scale > 0 or math.isinf(scale):
        return scale
    return scale * float((((p_values / scale) ** p * revs).sum() / total) ** (1.0 / p))


def rating_life(rating: BearingRating, pm: float) -> float:
    """``L10 = (C / P)^p`` in millions of revolutions; ``inf`` for an
    unloaded bearing, 0 for an infinite load, NaN for an unknown one.
    """
    if math.isnan(pm):
        return math.nan
    if pm <= 0:
        return math.inf
    return (rating.C_N / pm) ** exponent(rating)


def life_hours(l10_mrev: float, revs: np.ndarray, span_s: float) -> float:
    """``L10`` in hours at the mean speed of the stretch (``sum n_i`` revolutions over
    ``span_s`` seconds); NaN when the shaft does not turn.
    """
    total = float(np.sum(revs))
    if not total > 0 or not span_s > 0 or math.isnan(l10_mrev):
        return math.nan
    return l10_mrev * MILLION / (total / span_s) / 3600.0


def no_value_reason(p_values: np.ndarray, revs: np.ndarray) -> str | None:
    """Why :func:`mean_load` and :func:`rating_life` of loads ``p_values`` (N) over
    stretches of ``revs`` revolutions give no finite ``Pm``, ``L10`` or hours, one
    sentence for each way; ``None`` where every one of them is finite.
    """
    p_values, revs = np.asarray(p_values, float), np.asarray(revs, float)
    turning = revs > 0
    if not turning.any():
        return ("no value: the shaft makes no revolution (speed 0), and ISO 281 counts a "
                "life in revolutions")
    unknown = int(np.isnan(p_values[turning]).sum())
    if unknown:
        return (f"no value: P is not known at {unknown} of the {int(turning.sum())} "
                "instants the shaft turns at (not solved)")
    top = float(np.max(p_values[turning]))
    if math.isinf(top):
        return "no finite Pm: P is unbounded (no finite greatest load), so L10 is 0"
    if top <= 0:
        return "unbounded: the bearing carries no load (P = 0 throughout), so L10 is infinite"
    return None


# ------------------------------------------------------- ISO 281:2007 modified life

RELIABILITY_ROWS = np.array([
    # reliability (%), a1
    (90.0, 1.0), (95.0, 0.64), (96.0, 0.55), (97.0, 0.47), (98.0, 0.37), (99.0, 0.25),
    (99.2, 0.22), (99.4, 0.19), (99.6, 0.16), (99.8, 0.12), (99.9, 0.093),
    (99.92, 0.087), (99.94, 0.08), (99.95, 0.077),
])
"""ISO 281:2007 Table 12, the life modification factor for reliability ``a1``."""

RELIABILITY_PERCENT = Range(90.0, 99.95, "%")
"""Reliabilities ``a1`` is given for (Table 12's first and last rows): below 90 % the
basic rating life ``L10`` is already the answer, above 99.95 % the standard gives no
factor."""

A_ISO_CAP = 50.0
"""Largest ``a_ISO`` (ISO 281:2007)."""

KAPPA_LEAST, KAPPA_MOST = 0.1, 4.0
"""The viscosity ratios ``a_ISO`` is given for: below 0.1 outside the standard, above 4
taken as 4."""

LOAD_RATIO_MOST = 5.0
"""Largest ``e_C C_u / P`` used, the end of the standard's ``a_ISO`` diagrams."""

NU1_SPEED_RPM = 1000.0
"""Speed (r/min) from which ``nu1`` takes its high-speed expression."""

A_ISO_RANGES = {
    # type family: ((kappa from, A, b), ...), the ranges in ascending order
    "ball": ((0.1, 2.2649, 0.054381), (0.4, 1.9987, 0.19087), (1.0, 1.9987, 0.071739)),
    "roller": ((0.1, 1.3993, 0.054381), (0.4, 1.2348, 0.19087), (1.0, 1.2348, 0.071739)),
}
"""``(A, b)`` of ``A / kappa^b`` in ``a_ISO`` by range of ``kappa`` (ISO 281:2007, radial
ball and radial roller bearings)."""

A_ISO_FORM = {"ball": (2.5671, 0.83, 1.0 / 3.0, 9.3), "roller": (1.5859, 1.0, 0.4, 9.185)}
"""``(c, q, s, w)`` of ``a_ISO = 0.1 [1 - (c - A / kappa^b)^q x^s]^-w``: radial ball and
radial roller bearings (ISO 281:2007)."""

ISO_INPUTS = ("C_u_N", "mean_diameter_m", "viscosity_mm2_s", "contamination")
"""A rating's fields the modified life needs (a scene gives all four or none)."""


def reliability_factor(reliability_percent: float) -> float:
    """``a1`` for a reliability in per cent, ISO 281:2007 Table 12
    (:data:`RELIABILITY_ROWS`): the table's value at a row, linear between rows.

    Linear interpolation keeps the table's own numbers at its rows, and between them
    stays within 0.005 of the Weibull law the table is drawn from (ISO/TR 1281-2:
    ``a1 = 0.95 (ln(100/R) / ln(100/90))^(2/3) + 0.05``, slope 1.5, least life 0.05
    ``L10``), below it in the widest gap (90 to 95 %), so on the short side. A
    reliability outside :data:`RELIABILITY_PERCENT` (or not a number) raises ValueError.
    """
    r = float(reliability_percent)
    if RELIABILITY_PERCENT.refusal(r) is not None or math.isnan(r):
        lo, hi = RELIABILITY_PERCENT.least, RELIABILITY_PERCENT.most
        raise ValueError(f"reliability {r:g} % is outside {lo:g} to {hi:g} %, the span "
                         "of ISO 281:2007 Table 12's life modification factor a1")
    rows = RELIABILITY_ROWS
    return float(np.interp(r, rows[:, 0], rows[:, 1]))


def rated_viscosity(speed_rpm: float, mean_diameter_mm: float) -> float:
    """``nu1`` (mm^2/s), the reference kinematic viscosity for adequate lubrication at
    speed ``speed_rpm`` (r/min) of a bearing of mean (pitch) diameter
    ``mean_diameter_mm`` (mm), ISO 281:2007: ``45000 n^-0.83 D_pw^-0.5`` below 1000
    r/min, ``4500 n^-0.5 D_pw^-0.5`` from 1000 r/min (the two meet to 2.3 %: the first
    is 1.023 times the second at 1000 r/min). ``inf`` at speed 0 (no film forms), NaN
    for NaN; a negative speed or a diameter not above 0 raises ValueError.
    """
    n, dm = float(speed_rpm), float(mean_diameter_mm)
    if math.isnan(n) or math.isnan(dm):
        return math.nan
    if n < 0 or not dm > 0:
        raise ValueError(f"nu1 needs a speed >= 0 r/min and a mean diameter > 0 mm, got "
                         f"{n:g} r/min and {dm:g} mm")
    if n == 0:
        return math.inf
    if n < NU1_SPEED_RPM:
        return 45000.0 * n ** -0.83 * dm ** -0.5
    return 4500.0 * n ** -0.5 * dm ** -0.5


def _family(rating: BearingRating) -> str:
    """``ball`` for the radial ball types, ``roller`` for the radial roller ones."""
    return "roller" if rating.roller else "ball"


def a_iso(family: str, kappa: float, load_ratio: float) -> float:
    """``a_ISO`` of a radial ``family`` (``ball`` or ``roller``) bearing at viscosity
    ratio ``kappa`` and ``load_ratio = e_C C_u / P`` >= 0, with the standard's limits:
    ``kappa`` above 4 taken as 4, ``load_ratio`` above 5 as 5, the result at most 50
    (also where the bracket reaches 0: ``a_ISO`` grows without bound towards it). NaN
    for ``kappa`` below 0.1 or NaN.
    """
    if not kappa >= KAPPA_LEAST:
        return math.nan
    k = min(kappa, KAPPA_MOST)
    x = min(load_ratio, LOAD_RATIO_MOST)
    _, a, b = [r for r in A_ISO_RANGES[family] if k >= r[0]][-1]
    c, q, s, w = A_ISO_FORM[family]
    # at kappa = 0.1 the printed digits give 7.5e-5 (ball) and -5.9e-5 (roller): the
    # curves meet at 0.1 there; held at 0 or above, a_ISO does not fall below 0.1
    base = max(c - a / k ** b, 0.0)
    bracket = 1.0 - base ** q * x ** s
    if bracket <= (0.1 / A_ISO_CAP) ** (1.0 / w):
        return A_ISO_CAP
    return 0.1 * bracket ** -w


def _missing_inputs(rating: BearingRating) -> str | None:
    """Why ``rating`` has no modified life, or None where it has the four inputs."""
    missing = [k for k in ISO_INPUTS if getattr(rating, k) is None]
    if missing:
        return (f"no ISO 281:2007 inputs: the rating gives no {', '.join(missing)} "
                "(the modified life needs C_u, mean diameter, viscosity and e_C)")
    return None


def life_modification_factor(rating: BearingRating, p_N: float,
                             speed_rpm: float) -> tuple[float, float, str | None]:
    """``(a_ISO, kappa, reason)`` of ``rating`` under equivalent load ``p_N`` (N) at
    ``speed_rpm`` (r/min), ISO 281:2007 (module docstring): ``kappa = nu / nu1``
    (unclamped, as found), ``a_ISO`` by :func:`a_iso` for the rating's family
    (``ball``, ``angular_contact_ball``: radial ball; ``cylindrical_roller``,
    ``tapered_roller``: radial roller).

    ``reason`` is None for a value found by the formulas; otherwise it says why in words:
    a rating without the four inputs, a shaft that does not turn (no film: ``kappa``
    0), ``kappa`` below 0.1, an unknown ``P`` (each NaN ``a_ISO``), and an unloaded
    bearing (``P <= 0``): ``e_C C_u / P`` unbounded, taken at its limit 5, which gives
    the cap 50 wherever ``kappa`` is above about 0.43 (ball) or 0.68 (roller).
    """
    missing = _missing_inputs(rating)
    if missing:
        return math.nan, math.nan, missing
    p, n = float(p_N), float(speed_rpm)
    if math.isnan(n):
        return math.nan, math.nan, "no value: the speed is not known"
    n = abs(n)
    if n == 0:
        return (math.nan, 0.0, "no value: the shaft does not turn (speed 0): no "
                "lubricant film, kappa = 0, below ISO 281:2007's least 0.1")
    nu1 = rated_viscosity(n, rating.mean_diameter_m * 1e3)
    kappa = rating.viscosity_mm2_s / nu1
    if kappa < KAPPA_LEAST:
        return (math.nan, kappa, f"no value: kappa = nu / nu1 = {kappa:.3g} is below "
                f"{KAPPA_LEAST:g}, outside ISO 281:2007's a_ISO (a film too thin for it)")
    if math.isnan(p):
        return math.nan, kappa, "no value: P is not known (not solved)"
    family = _family(rating)
    if p <= 0:
        value = a_iso(family, kappa, math.inf)
        return (value, kappa, f"unloaded (P = {p:g} N): e_C C_u / P is unbounded, taken "
                f"as {LOAD_RATIO_MOST:g}, the end of ISO 281:2007's diagrams: a_ISO = "
                f"{value:.3g} (the cap is {A_ISO_CAP:g})")
    return a_iso(family, kappa, rating.contamination * rating.C_u_N / p), kappa, None


def modified_life(rating: BearingRating, l10_mrev: float, p_N: float, speed_rpm: float,
                  reliability_percent: float = 90.0) -> dict:
    """ISO 281:2007's modified rating life ``L_nm = a1 a_ISO L10`` (million revolutions)
    of ``rating`` with basic rating life ``l10_mrev`` (million revolutions, from
    :func:`rating_life`) under equivalent load ``p_N`` (N) at ``speed_rpm`` (r/min), for
    ``reliability_percent`` (%, within :data:`RELIABILITY_PERCENT`, else ValueError).

    ``{"a1", "a_ISO", "kappa", "nu1_mm2_s", "L_nm_Mrev", "reason"}``: ``nu1_mm2_s`` the
    reference viscosity (NaN where the rating has no mean diameter or the speed is not
    known); ``reason`` as :func:`life_modification_factor` gives it, or why ``L10`` has
    no value; ``L_nm_Mrev`` NaN where ``a_ISO`` or ``L10`` is NaN, ``inf`` for an
    unbounded ``L10``.
    """
    a1 = reliability_factor(reliability_percent)
    value, kappa, reason = life_modification_factor(rating, p_N, speed_rpm)
    n = abs(float(speed_rpm))
    nu1 = (rated_viscosity(n, rating.mean_diameter_m * 1e3)
           if rating.mean_diameter_m is not None and not math.isnan(n) else math.nan)
    l10 = float(l10_mrev)
    if math.isnan(l10) and reason is None:
        reason = "no value: L10 is not known"
    return {"a1": a1, "a_ISO": value, "kappa": kappa, "nu1_mm2_s": nu1,
            "L_nm_Mrev": a1 * value * l10, "reason": reason}
