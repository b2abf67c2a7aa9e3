"""Reading a bearing's catalogue data and a scene's tolerances: the optional fields
that rate a bearing's life (ISO 281) and spread a line's geometry, each read through
:mod:`.loading`'s table reader (type, finiteness and :data:`~.scene.LIMITS` checked
where a field is read) and held to the rules below.
"""

from __future__ import annotations

from .bearing_life import ISO_INPUTS
from .scene import (
    ANGULAR_TABLE_DEG,
    BEARING_TYPES,
    CONTACT_ANGLE_DEG,
    MAX_ARTICULATION_DEG,
    MEAN_DIAMETER_M,
    VISCOSITY_MM2_S,
    BearingRating,
    Range,
    Tolerances,
    table_keys,
)

FACTORS = ("X", "Y", "e")
"""The load factors of a rating, given all three or none."""



def read_rating(t) -> BearingRating:
    """A bearing's catalogue data (:class:`~.scene.BearingRating`): type, ratings (N),
    contact angle (deg) where the type has one, and ``X``, ``Y``, ``e`` all three or
    none (then ISO 281's tables must cover the type and angle).

    ISO 281:2007's modified rating life reads four more, all four or none
    (:data:`ISO_INPUTS`): the fatigue load limit ``C_u_N`` (N, positive and below
    ``C0_N``: ISO 281:2007 Annex B estimates it as ``C0 / 22`` for ball and ``C0 / 8.2``
    for roller bearings up to 100 mm pitch diameter, less above, so a ``C_u`` at or above
    ``C0`` is a mistyped field); ``mean_diameter_m`` (m, within
    :data:`~.scene.MEAN_DIAMETER_M`); ``viscosity_mm2_s``, the lubricant's kinematic
    viscosity at operating temperature (mm^2/s, within :data:`~.scene.VISCOSITY_MM2_S`);
    ``contamination``, the factor ``e_C`` of ISO 281:2007 Table 13, above 0 and at most
    1 (the table's 0, very severe contamination, is a life ended by wear, which the
    fatigue life does not describe).
    """
    t.expect(table_keys(BearingRating))
    kind_of = t.string("type", choices=BEARING_TYPES)
    rating = BearingRating(
        type=kind_of, C_N=t.number("C_N", positive=True, kind="force_N"),
        C0_N=t.number("C0_N", positive=True, kind="force_N"),
        contact_angle_deg=_contact_angle(t, kind_of),
        X=t.number("X", nonnegative=True, kind="ratio") if "X" in t.raw else None,
        Y=t.number("Y", nonnegative=True, kind="ratio") if "Y" in t.raw else None,
        e=t.number("e", positive=True, kind="ratio") if "e" in t.raw else None,
        **_iso_inputs(t))
    t.used.update(FACTORS)
    given = [k for k in FACTORS if getattr(rating, k) is not None]
    if given and len(given) < len(FACTORS):
        missing = next(k for k in FACTORS if k not in given)
        t.fail(missing, f"missing: give X, Y and e together, or none (ISO 281's tables "
               f"then); got {', '.join(given)}")
    lo, hi = ANGULAR_TABLE_DEG
    if kind_of == "angular_contact_ball" and not given and \
            not lo <= rating.contact_angle_deg <= hi:
        t.fail("contact_angle_deg", f"ISO 281 Table 3's rows used here span {lo:g} to "
               f"{hi:g} deg; give X, Y and e for {rating.contact_angle_deg:g} deg")
    given = [k for k in ISO_INPUTS if getattr(rating, k) is not None]
    if given and len(given) < len(ISO_INPUTS):
        missing = next(k for k in ISO_INPUTS if k not in given)
        t.fail(missing, f"missing: ISO 281:2007's modified life takes "
               f"{', '.join(ISO_INPUTS)} together, or none; got {', '.join(given)}")
    if rating.C_u_N is not None and rating.C_u_N >= rating.C0_N:
        t.fail("C_u_N", f"the fatigue load limit must be below C0_N = {rating.C0_N:g} N "
               f"(catalogues list a few per cent of C0; ISO 281:2007 Annex B: about C0/22 "
               f"for ball, C0/8.2 for roller bearings), got {rating.C_u_N:g} N")
    t.done()
    return rating


def _iso_inputs(t) -> dict:
    """The rating's ISO 281:2007 inputs that ``t`` gives (the others left ``None``), each
    within its range; :func:`read_rating` holds them to all four or none and ``C_u`` to
    below ``C0``.
    """
    t.used.update(ISO_INPUTS)
    read = {}
    if "C_u_N" in t.raw:
        read["C_u_N"] = t.number("C_u_N", positive=True, kind="force_N")
    if "mean_diameter_m" in t.raw:
        read["mean_diameter_m"] = t.number(
            "mean_diameter_m", positive=True, kind="length_m", within=MEAN_DIAMETER_M,
            why="(d + D) / 2 of real rolling bearings, miniature to the largest")
    if "viscosity_mm2_s" in t.raw:
        read["viscosity_mm2_s"] = t.number(
            "viscosity_mm2_s", positive=True, kind="number", within=VISCOSITY_MM2_S,
            why="real lubricants at operating temperature")
    if "contamination" in t.raw:
        e_c = t.number("contamination", nonnegative=True, kind="ratio")
        if not 0.0 < e_c <= 1.0:
            t.fail("contamination", f"e_C is above 0 and at most 1 (ISO 281:2007 Table "
                   f"13: 1 extreme cleanliness; 0, very severe contamination, is a life "
                   f"ended by wear, outside the fatigue life), got {e_c:g}")
        read["contamination"] = e_c
    return read


def _contact_angle(t, kind_of: str) -> float:
    """The nominal contact angle (deg): 0 for the radial types (by definition), within
    :data:`~.scene.CONTACT_ANGLE_DEG` for the others.
    """
    if kind_of in ("ball", "cylindrical_roller"):
        if t.number("contact_angle_deg", 0.0, kind="angle_deg") != 0.0:
            t.fail("contact_angle_deg", f"a {kind_of} bearing has contact angle 0 by "
                   "definition; give 0 or none")
        return 0.0
    return t.number("contact_angle_deg", positive=True, kind="angle_deg",
                    within=CONTACT_ANGLE_DEG, why=f"the contact angles of real "
                    f"{kind_of.replace('_', ' ')} bearings")


def read_tolerances(top) -> Tolerances | None:
    """The optional ``[tolerances]`` table (:class:`~.scene.Tolerances`): half-widths,
    non-negative, an articulation's at most the largest angle (a study refuses samples
    that would pass it; one that samples a clearance below zero takes it as zero).
    """
    if "tolerances" not in top.raw:
        top.used.add("tolerances")
        return None
    tt = top.table("tolerances")
    tt.expect(table_keys(Tolerances))
    tol = Tolerances(
        bearing_seat_m=tt.number("bearing_seat_m", 0.0, nonnegative=True, kind="length_m"),
        articulation_deg=tt.number("articulation_deg", 0.0, nonnegative=True,
                                   kind="angle_deg", within=Range(0.0, MAX_ARTICULATION_DEG,
                                                                  "deg"),
                                   why="a joint's largest angle"),
        bearing_clearance_m=tt.number("bearing_clearance_m", 0.0, nonnegative=True,
                                      kind="length_m"))
    tt.done()
    return tol
