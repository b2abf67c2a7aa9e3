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
"""

from __future__ import annotations

import math

import numpy as np

from .scene import BearingRating

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
