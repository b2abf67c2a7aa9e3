"""``cardan life``: every rated bearing's ISO 281 basic rating life, for each selection
the package can compute and over the whole rigid solution set.

For each bearing whose scene gives catalogue data (:class:`~cardan_forces.driveline.
scene.BearingRating`), at ``--instants`` instants spread over the scene's window: the
equivalent dynamic load ``P(t)`` (:mod:`cardan_forces.driveline.bearing_life`), the duty
cycle's mean load ``Pm`` over the revolutions of the bearing's shaft (the motion's
speed) and ``L10`` in millions of revolutions and in hours at the window's mean speed,

- for each selection, each a different kind of answer (:data:`MODELS`): the members of
  the rigid set :data:`SELECTIONS` (``positive``, ``compliance``,
  ``compliance_hertz``); MuJoCo's forces (:mod:`~cardan_forces.experiments.life_runs`),
  a soft-constraint engine's, which lie in the set up to its own residual, where it is
  installed and can express the scene (unless ``--no-engine``); and with ``--penalty``
  the penalty-contact simulation's average, a different model (the released line with
  its clearances) whose forces may lie outside the set (a simulation of the whole
  window; a dynamic scene). The answer says why one is not run, and for each selection
  and bearing whether its life lies within the set's interval (:func:`in_set`: its
  ``Pm`` between the set's least and greatest over the same instants, to
  :data:`IN_SET_TOL` of the bearing's load), computed, never assumed;
- over the rigid set (:func:`load_envelope`): the least and the greatest ``P`` at each
  instant over every rigid solution, hence ``L10`` from its worst to its best. ``P``
  grows with the radial load ``Fr`` and with the axial load's magnitude ``|Fa|``, so its
  ends come from theirs. ``|Fa|``'s ends are two LPs (exact). ``Fr`` is a norm over
  the set's projection on the radial plane (a polygon): its greatest value is the
  largest of :data:`DIRECTIONS` LPs along directions ``u`` of the plane, at least
  ``cos(pi / n)`` of the true one, which is reported (an upper bound, the LPs' value
  over ``cos(pi / n)``); its least is bounded below by the largest ``min u'F`` (0 when
  the polygon holds the origin). Where the radial components are determinate ``Fr`` is
  one value and no LP is needed. Where ``Fr`` and ``Fa`` are both free the ends pair
  the greatest ``Fr`` with the greatest ``|Fa|``, which one rigid solution may not
  reach together: a bound, said so in the answer.

Where a life has no finite value (a load not solved, no load, an open set) the answer
gives the reason beside it (:func:`~cardan_forces.driveline.bearing_life.
no_value_reason`); a scene whose rated shafts do not turn over the window is refused
(ISO 281 counts a life in revolutions). Where the set is open above, the worst case has
no finite value: the answer says so and names the release the advisor proposes
(:func:`~cardan_forces.driveline.release.advise`) that bounds it. Written into
``--out``: ``life.csv`` (every ``P`` over time, the reason beside an empty cell),
``life.md`` and the figure ``life.<format>`` (each bearing's life interval with each
selection's mark); ``--json`` prints the whole answer as strict JSON instead.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np
from cardan_forces.driveline import bearing_life as iso
from cardan_forces.driveline.determinacy import DETERMINATE_TOL, determinacy
from cardan_forces.driveline.dynamics import simulate
from cardan_forces.driveline.equilibrium import Operator, build_operator
from cardan_forces.driveline.loading import load_scene
from cardan_forces.driveline.modes import counts
from cardan_forces.driveline.release import advise, named_modes
from cardan_forces.driveline.scene import SceneError
from cardan_forces.experiments import files, images
from cardan_forces.experiments import progress as bars
from cardan_forces.experiments.arguments import whole_number
from cardan_forces.experiments.environment import json_text, number_text
from cardan_forces.experiments.images import format_list
from cardan_forces.experiments.life_runs import ENGINE, PENALTY, engine_history, penalty_history
from cardan_forces.experiments.study import solve_over_time, value_ranges
from cardan_forces.formulations import where

INSTANTS = 41
"""Instants by default (each costs a few warm LPs per bearing whose radial load is free)."""

MAX_INSTANTS = 2001
"""Most instants a run takes (checked before any work)."""

DIRECTIONS = 64
"""Directions of the radial plane along which the greatest radial load is sought: the
answer is within ``1 / cos(pi / 64) - 1 = 0.12 %`` above the true one."""

SELECTIONS = where(design=True)
"""The members of the rigid set whose lives are reported (the formulation records'
``design``), each by the study layer's default backend."""

NOT_ASKED = {
    PENALTY: "not run: ask for it with --penalty (a simulation of the released line over "
             "the window; its first run compiles the simulation's kernels)",
    ENGINE: "not run: left out by --no-engine",
}
"""Why a simulated selection (:mod:`~cardan_forces.experiments.life_runs`) is not among
the answer's selections when it was not asked for."""

MODELS = {
    **{name: "a member of the rigid solution set" for name in SELECTIONS},
    ENGINE: "a soft-constraint engine: its forces lie in the rigid set up to its own "
            "residual",
    PENALTY: "a different model, the released line with its clearances: its forces, "
             "hence its life, may lie outside the rigid set's",
}
"""What each selection is, against the rigid set whose interval the answer gives."""

IN_SET_TOL = 1e-4
"""How far, relative to a bearing's load scale (its greatest finite ``P`` of any
selection or of the set's ends), a selection's ``Pm`` may lie beyond the set's and still
count as within it: above the LP and QP solvers' tolerances (1e-6) and MuJoCo's
residual (a few 1e-5 of the load on the built-in scenes)."""

LIGHT_LOAD = 0.05
"""``P / C`` at or below which a bearing's load is light (the bearing makers' classes,
e.g. SKF's: light ``P <= 0.05 C``, normal up to ``0.1 C``, heavy above)."""

OPEN = "no finite worst case: the closed loop's self-stress is free"
"""What the answer says where the set is open above along a closed loop."""


def rated(op: Operator) -> list:
    """``(contact, rating)`` of every bearing of ``op`` whose scene gives a rating."""
    by_element = {f"{s.name}.{b.name}": b.rating for s in op.scene.shafts for b in s.bearings}
    return [(c, by_element[c.element]) for c in op.bearings() if by_element.get(c.element)]


def loads(op: Operator, contact, forces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(Fr, Fa)`` (N) of a bearing from forces ``(T, n)``: the radial load's length and
    the signed axial load on its shaft, in the shaft's frame (a floating bearing's is
    zero, not the rounding of its radial columns on the axis).
    """
    v = np.asarray(forces, float) @ op.bearing_matrix(contact).T
    axial = np.zeros(len(v)) if contact.element_kind.slides else v[:, 2]
    return np.hypot(v[:, 0], v[:, 1]), axial


def _directions(n: int) -> np.ndarray:
    """``n / 2`` unit vectors over half the circle (each LP pair covers ``u`` and ``-u``)."""
    theta = np.pi * np.arange(n // 2) / (n // 2)
    return np.column_stack([np.cos(theta), np.sin(theta)])


def _rows(op: Operator, contact, free_radial: bool, n: int) -> np.ndarray:
    """The linear forms ranged for one bearing: ``u'(r1, r2)`` along the directions when
    its radial load is free, then a locating bearing's axial load.
    """
    B = op.bearing_matrix(contact)
    radial = _directions(n) @ B[:2] if free_radial else np.zeros((0, B.shape[1]))
    return radial if contact.element_kind.slides else np.vstack([radial, B[2:]])


def _ends(entry: dict) -> tuple[float, float]:
    """An LP range's ends, ``-inf``/``inf`` for an open side, NaN where not answered."""
    if entry["status"] != "solved":
        return math.nan, math.nan
    lo, hi = entry["min"], entry["max"]
    return (-math.inf if lo is None else lo), (math.inf if hi is None else hi)


def envelope_at(op: Operator, i: int, bearings: list, n: int = DIRECTIONS) -> list[dict]:
    """Per bearing at instant ``i``: ``fr`` and ``fa`` as ``(least, greatest)`` of the
    radial load and of the axial load's magnitude over the rigid set (N; ``inf`` where
    open, NaN where an LP was not answered) and whether the radial load is determinate.
    """
    det = determinacy(op, i)
    plan, forms = [], []
    for contact, _ in bearings:
        B = op.bearing_matrix(contact)
        free = bool(np.linalg.norm(B[:2] @ det.null_basis) > DETERMINATE_TOL *
                    max(1.0, np.linalg.norm(B[:2])))
        plan.append((free, len(forms)))
        forms.extend(_rows(op, contact, free, n))
    found = value_ranges(op, i, np.array(forms)) if forms else []
    return [_bearing_ends(op, det, contact, free, found[start:], n)
            for (contact, _), (free, start) in zip(bearings, plan)]


def _bearing_ends(op: Operator, det, contact, free: bool, found: list, n: int) -> dict:
    """:func:`envelope_at`'s entry of one bearing from its share of the LP ranges."""
    B = op.bearing_matrix(contact)
    k = n // 2 if free else 0
    a_lo, a_hi = (0.0, 0.0) if contact.element_kind.slides else _ends(found[k])
    fa = (0.0 if a_lo <= 0 <= a_hi else min(abs(a_lo), abs(a_hi)), max(abs(a_lo), abs(a_hi)))
    if not free:
        fr = float(np.linalg.norm(B[:2] @ det.min_norm))
        return {"fr": (fr, fr), "fa": fa, "radial_determinate": True}
    ends = np.array([_ends(e) for e in found[:k]])  # (k, 2): min, max of u'F
    if np.isnan(ends).any():
        return {"fr": (math.nan, math.nan), "fa": fa, "radial_determinate": False}
    support = np.concatenate([ends[:, 1], -ends[:, 0]])  # max of u'F over the full circle
    reach = np.concatenate([ends[:, 0], -ends[:, 1]])  # min of u'F over the full circle
    return {"fr": (max(0.0, float(reach.max())), float(support.max()) / math.cos(math.pi / n)),
            "fa": fa, "radial_determinate": False}


def load_envelope(op: Operator, bearings: list, n: int = DIRECTIONS, progress=None) -> dict:
    """:func:`envelope_at` over every instant of ``op``: ``fr_lo``, ``fr_hi``,
    ``fa_lo``, ``fa_hi`` (T, bearings; N) and ``radial_determinate`` (T, bearings).
    """
    shape = (len(op.t), len(bearings))
    out = {k: np.full(shape, np.nan) for k in ("fr_lo", "fr_hi", "fa_lo", "fa_hi")}
    out["radial_determinate"] = np.zeros(shape, bool)
    for i in range(len(op.t)):
        if progress:
            progress(f"life: intervals, instant {i + 1}/{len(op.t)}")
        for b, entry in enumerate(envelope_at(op, i, bearings, n)):
            out["fr_lo"][i, b], out["fr_hi"][i, b] = entry["fr"]
            out["fa_lo"][i, b], out["fa_hi"][i, b] = entry["fa"]
            out["radial_determinate"][i, b] = entry["radial_determinate"]
    return out


def p_ends(rating, env: dict, b: int) -> tuple[np.ndarray, np.ndarray]:
    """The least and the greatest ``P`` (N) over the set at each instant, bearing ``b``:
    ``P`` at the ends of ``Fr`` and ``|Fa|`` (it grows with each; ISO's factors are
    continuous at ``e`` to 0.3 %), the greatest no less than the greatest ``Fr``.
    """
    lo = iso.equivalent_load(rating, env["fr_lo"][:, b], env["fa_lo"][:, b])
    with np.errstate(invalid="ignore"):
        hi = np.fmax(iso.equivalent_load(rating, env["fr_hi"][:, b], env["fa_hi"][:, b]),
                     env["fr_hi"][:, b])
    return lo, np.where(np.isnan(env["fr_hi"][:, b]), np.nan, hi)


def life(rating, p_values: np.ndarray, revs: np.ndarray, span_s: float,
         keep: np.ndarray | None = None) -> dict:
    """``Pm`` (N), ``L10`` (million revolutions) and ``L10_h`` (hours) of a load history,
    and ``reason``: why one of them has no finite value (``None`` where all have one);
    with ``keep``, ``Pm`` over those instants only (``L10_h`` still at the whole
    window's mean speed).
    """
    kept = slice(None) if keep is None else keep
    pm = iso.mean_load(p_values[kept], revs[kept], iso.exponent(rating))
    l10 = iso.rating_life(rating, pm)
    reason = iso.no_value_reason(p_values[kept], revs[kept])
    if reason and revs.sum() > 0 and not revs[kept].sum() > 0:
        reason = "no value: the shaft turns at none of the instants kept"
    return {"Pm_N": pm, "L10_Mrev": l10, "L10_h": iso.life_hours(l10, revs, span_s),
            "reason": reason}


def in_set(pm: float, set_pm: tuple[float, float], scale: float) -> dict:
    """Whether a selection's ``Pm`` lies between the set's least and greatest ``set_pm``
    (over the same instants) to :data:`IN_SET_TOL` of the load ``scale`` (N):
    ``inside`` (``None`` where either side has no value, ``why`` then says so) and
    ``Pm_beyond``, how far beyond the nearer end relative to it (0 inside; negative
    below the least, a life longer than the set's best).
    """
    lo, hi = set_pm
    if math.isnan(pm) or math.isnan(lo) or math.isnan(hi):
        side = "the selection's" if math.isnan(pm) else "the set's"
        return {"inside": None, "Pm_beyond": math.nan,
                "why": f"not compared: {side} Pm has no value"}
    slack = IN_SET_TOL * scale
    end = lo if pm < lo - slack else hi if pm > hi + slack else None
    if end is None:
        return {"inside": True, "Pm_beyond": 0.0, "why": None}
    return {"inside": False, "Pm_beyond": (pm - end) / (end if end > 0 else scale),
            "why": None}


def study(scene_spec: str, instants: int = INSTANTS, progress=None, penalty: bool = False,
          engine: bool = True) -> dict:
    """The whole answer of ``cardan life`` for one scene, as JSON-ready data (non-finite
    numbers are the encoder's ``null``): the instants, each rated bearing's ``P`` over
    time, ``Pm`` and ``L10`` per selection and over the set, the selections not run and
    why, what each selection is (:data:`MODELS`) and whether its life lies in the set's,
    and where the set is open, why and the release that bounds it. ``penalty`` and
    ``engine`` add the simulated selections (:mod:`~cardan_forces.experiments.
    life_runs`) where the scene allows them. A scene none of whose rated shafts turns is
    refused (:class:`SceneError`) before any solve.
    """
    scene = load_scene(scene_spec)
    t = np.linspace(scene.time.start_s, scene.time.stop_s, instants)
    motion = simulate(scene, t)
    op = build_operator(motion)
    bearings = rated(op)
    _check_turning(scene, motion, op, bearings)
    chosen = {name: solve_over_time(op, name) for name in SELECTIONS}
    simulated, not_run = _simulated(op, penalty, engine, progress)
    chosen.update({name: history for name, (history, _) in simulated.items()})
    say = None if progress is None else progress
    with bars.ticks(len(op.t), "life: intervals", "instant", say) as tick:
        env = load_envelope(op, bearings, progress=tick)
    span = float(t[-1] - t[0])
    entries = [_bearing_entry(op, motion, contact, rating, chosen, env, b, span)
               for b, (contact, rating) in enumerate(bearings)]
    unbounded = any(e["interval"]["open"] for e in entries)
    return {
        "scene": scene.name, "t_s": t, "directions": DIRECTIONS,
        "direction_error": 1.0 / math.cos(math.pi / DIRECTIONS) - 1.0,
        "selections": {name: {"solver": h.solver, "solved": h.solved, "instants": len(h.t),
                              "model": MODELS[name],
                              **({"about": simulated[name][1]} if name in simulated else {})}
                       for name, h in chosen.items()},
        "in_set_tol": IN_SET_TOL,
        "not_run": not_run,
        "unrated": [c.element for c in op.bearings() if c not in [r[0] for r in bearings]],
        "bearings": entries, "open": unbounded,
        "open_reason": _open_reason(motion, op) if unbounded else None,
        "release": _release(motion) if unbounded else None,
    }


def _check_turning(scene, motion, op: Operator, bearings: list) -> None:
    """Refuse (:class:`SceneError`, one line) a scene none of whose rated bearings' shafts
    turns over the window: ISO 281 counts a life in revolutions, so none would have a
    value.
    """
    if bearings and not any(iso.revolutions(motion.omega[c.shaft], op.t).sum() > 0
                            for c, _ in bearings):
        raise SceneError(
            f"scene {scene.name}: no rated bearing's shaft turns from {op.t[0]:g} to "
            f"{op.t[-1]:g} s (speed 0), and ISO 281 counts a life in revolutions; give the "
            "scene an initial speed ([initial] speed_rad_s) or a net torque")


def _simulated(op: Operator, penalty: bool, engine: bool, progress) -> tuple[dict, dict]:
    """The simulated selections run (name: (history, what it is)) and those not run
    (name: why), in the order penalty, MuJoCo.
    """
    ran, not_run = {}, {}
    for name, asked, run in ((PENALTY, penalty, lambda: penalty_history(op, progress)),
                             (ENGINE, engine, lambda: engine_history(op))):
        if not asked:
            not_run[name] = NOT_ASKED[name]
            continue
        if progress:
            progress(f"life: {name} simulation of {op.scene.name} ...")
        history, words = run()
        if history is None:
            not_run[name] = words
        else:
            ran[name] = (history, words)
    return ran, not_run


def _bearing_entry(op, motion, contact, rating, chosen, env, b, span) -> dict:
    """One bearing's part of :func:`study`'s answer: per selection
    (:func:`_selection_entry`) and over the set ``P``, ``Pm`` and ``L10``, each life's
    reason where it has no finite value, and whether each selection's lies in the set's.
    """
    revs = iso.revolutions(motion.omega[contact.shaft], op.t)
    lo, hi = p_ends(rating, env, b)
    selections = {name: _selection_entry(op, contact, rating, name, history, revs, span)
                  for name, history in chosen.items()}
    peaks = [np.nanmax(s["P_N"]) for s in selections.values() if np.isfinite(s["P_N"]).any()]
    scale = max([*peaks, *lo[np.isfinite(lo)], *hi[np.isfinite(hi)]], default=0.0)
    for name, sel in selections.items():
        keep = np.isfinite(sel["P_N"]) if name in (PENALTY, ENGINE) else None
        ends = [life(rating, p, revs, span, keep)["Pm_N"] for p in (lo, hi)]
        sel["in_set"] = in_set(sel["Pm_N"], ends, scale)
    worst, best = life(rating, hi, revs, span), life(rating, lo, revs, span)
    determinate = bool(env["radial_determinate"][:, b].all())
    return {
        "bearing": contact.element, "kind": contact.kind.removeprefix("bearing-"),
        "rating": {"type": rating.type, "contact_angle_deg": rating.contact_angle_deg,
                   "C_N": rating.C_N, "C0_N": rating.C0_N, "p": iso.exponent(rating),
                   "X_Y_e": ([rating.X, rating.Y, rating.e] if rating.X is not None
                             else "ISO 281 tables")},
        "revolutions": float(revs.sum()),
        "mean_speed_rpm": float(revs.sum() / span * 60.0) if span > 0 else math.nan,
        "selections": selections,
        "peak_P_over_C": float(max(peaks, default=math.nan)) / rating.C_N,
        "interval": {
            "P_min_N": lo, "P_max_N": hi, "Pm_N": [best["Pm_N"], worst["Pm_N"]],
            "L10_Mrev": [worst["L10_Mrev"], best["L10_Mrev"]],
            "L10_h": [worst["L10_h"], best["L10_h"]],
            "reason": [worst["reason"], best["reason"]],
            "open": bool(np.isinf(hi).any()),
            "radial_determinate": determinate,
            "ends": _ends_words(determinate, contact.element_kind.slides, env, b)},
    }


def _selection_entry(op, contact, rating, name, history, revs, span) -> dict:
    """One selection's ``P``, the radial and axial loads ``Fr``, ``Fa`` it comes from
    (N), at how many instants ``|Fa| > e Fr`` (``P = X Fr + Y |Fa|``), ``Pm`` and
    ``L10`` at one bearing. A simulated selection's ``Pm`` is over the instants it has
    (the others left out, their count said); a rigid one's has no value where an
    instant was not solved.
    """
    fr, fa = loads(op, contact, history.forces)
    p = iso.equivalent_load(rating, fr, fa)
    keep = np.isfinite(p) if name in (PENALTY, ENGINE) else None
    with np.errstate(invalid="ignore"):
        axial = int(np.sum(np.abs(fa) > iso.factors(rating, fa)[2] * fr))
    return {"P_N": p, "Fr_N": fr, "Fa_N": fa, "axial_instants": axial,
            **life(rating, p, revs, span, keep), "unsolved_instants": int(np.isnan(p).sum())}


def _ends_words(determinate: bool, slides: bool, env: dict, b: int) -> str:
    """How exact the interval's ends are, in words."""
    axial_free = bool((env["fa_hi"][:, b] > env["fa_lo"][:, b]).any())
    if determinate:
        return "exact: the radial load is determinate, the axial ends are LPs"
    if slides or not axial_free:
        return (f"the greatest radial load from {DIRECTIONS} directions, an upper bound "
                f"within 1/cos(pi/{DIRECTIONS}) of it; the least a lower bound")
    return ("a bound: the greatest radial and the greatest axial load paired, which one "
            f"rigid solution may not reach together (radial from {DIRECTIONS} directions)")


def _open_reason(motion, op) -> str:
    """Why the set is open, from the named modes at the first instant."""
    kinds = counts(named_modes(motion, 0, op))
    if kinds.get("closed loop"):
        return OPEN
    return "no finite worst case: the axial split between locating bearings is free"


def _release(motion) -> dict:
    """The release the advisor proposes at the middle instant (labels and words), or
    why there is none.
    """
    try:
        advice = advise(motion, len(motion.t) // 2)
    except SceneError as err:
        return {"labels": [], "words": f"none found: {err}"}
    return {"labels": [r.label for r in advice.releases],
            "words": "; ".join(r.words for r in advice.releases)}


# ---------------------------------------------------------------------------- output

MARKS = dict(zip((*SELECTIONS, PENALTY, ENGINE), "os^Dv<>"))
"""Each selection's marker on the figure."""


EMPTY = {
    "rigid": "not solved at this instant",
    "simulated": "left out at this instant (life.md's line of the selection says why)",
    "set": "not solved at this instant (an LP of the set's interval)",
    "open": "open: the set has no finite greatest P at this instant",
}
"""Why a cell of ``life.csv`` is empty, by the series' kind."""


def write_csv(answer: dict, path: Path) -> None:
    """Long format: one row per bearing, instant and series (each selection's ``P``,
    the set's least and greatest); an empty cell where undefined, with why in ``note``
    (:data:`EMPTY`).
    """
    with files.replacing(path, newline="") as f:
        w = csv.writer(f)
        w.writerow(["t_s", "bearing", "series", "P_N", "note"])
        for entry in answer["bearings"]:
            series = {name: sel["P_N"] for name, sel in entry["selections"].items()}
            series.update(set_min=entry["interval"]["P_min_N"],
                          set_max=entry["interval"]["P_max_N"])
            for name, values in series.items():
                for t, p in zip(answer["t_s"], values):
                    w.writerow([f"{t:.6g}", entry["bearing"], name,
                                number_text(p, ".9g", ""), _empty_note(name, p)])


def _empty_note(series: str, p: float) -> str:
    """``life.csv``'s note: why ``p`` of ``series`` is no number, empty where it is one."""
    if math.isfinite(p):
        return ""
    if math.isinf(p):
        return EMPTY["open"]
    kind = ("set" if series.startswith("set_") else
            "simulated" if series in (PENALTY, ENGINE) else "rigid")
    return EMPTY[kind]


def _life_text(value: float) -> str:
    if math.isinf(value):
        return "unloaded"
    return number_text(value, ".4g", "-")


def _cell(selection: dict) -> str:
    """A selection's ``L10`` (h) in life.md's table, marked where it lies outside the
    set's interval.
    """
    outside = " (outside the set)" if selection["in_set"]["inside"] is False else ""
    return _life_text(selection["L10_h"]) + outside


def markdown(answer: dict) -> str:
    """``life.md``: per bearing ``L10`` (h) of each selection and of the set, what each
    selection is and whether its life lies in the set's interval, why a life has no
    finite value, what the interval's ends are, what was not run, and the release where
    the set is open.
    """
    names = list(answer["selections"])
    lines = [f"# Bearing life (ISO 281 L10) of scene {answer['scene']}", "",
             f"{len(answer['t_s'])} instants; `L10` in hours at each shaft's mean speed "
             "over the window; the set's worst and best over every rigid solution.", "",
             "| bearing | type | " + " | ".join(f"{n} L10 [h]" for n in names) +
             " | set worst L10 [h] | set best L10 [h] | set's ends |",
             "|---" * (len(names) + 5) + "|"]
    for e in answer["bearings"]:
        cells = [_cell(e["selections"][n]) for n in names]
        worst, best = e["interval"]["L10_h"]
        lines.append(f"| {e['bearing']} | {e['rating']['type']} | " + " | ".join(cells) +
                     f" | {'0 (open)' if e['interval']['open'] else _life_text(worst)} | "
                     f"{_life_text(best)} | {e['interval']['ends']} |")
    lines += _selection_lines(answer) + _reason_lines(answer)
    lines += _split_lines(answer) + _load_lines(answer)
    lines += ["", f"Radial directions: {answer['directions']} (greatest radial load within "
              f"{100 * answer['direction_error']:.2f} % above the true one)."]
    if answer["unrated"]:
        lines.append(f"- no catalogue data (no life): {', '.join(answer['unrated'])}")
    if answer["open"]:
        release = answer["release"]
        lines += ["", f"**{answer['open_reason']}.** The release that bounds it: "
                  f"{release['words']} ({', '.join(release['labels']) or 'none'})."]
    return "\n".join(lines) + "\n"


def _selection_lines(answer: dict) -> list[str]:
    """What each selection is and at which bearings its life lies in the set's interval
    (its ``Pm`` between the set's over the same instants, to the answer's tolerance);
    then why each selection not run was not.
    """
    lines = ["", "Each selection, and whether its life lies within the set's interval (its "
             "Pm between the set's least and greatest over the same instants, to "
             f"{answer['in_set_tol']:g} of the bearing's greatest load):"]
    for name, sel in answer["selections"].items():
        about = f"{sel['about']}; " if "about" in sel else ""
        checks = {e["bearing"]: e["selections"][name]["in_set"] for e in answer["bearings"]}
        check = f" {_in_set_words(checks)}." if checks else ""
        lines.append(f"- {name}: {about}{sel['model']}.{check}")
    return lines + [f"- {name}: {why}" for name, why in answer["not_run"].items()]


def _in_set_words(checks: dict) -> str:
    """Where a selection's life lies in the set's interval, where outside (by how much)
    and where it was not compared, in words.
    """
    inside = [b for b, c in checks.items() if c["inside"]]
    parts = [f"outside at {b} (Pm {100 * abs(c['Pm_beyond']):.3g} % "
             f"{'below the least' if c['Pm_beyond'] < 0 else 'above the greatest'})"
             for b, c in checks.items() if c["inside"] is False]
    parts += [f"at {b} {c['why']}" for b, c in checks.items() if c["inside"] is None]
    if len(inside) == len(checks):
        return "Inside at every bearing"
    if inside:
        parts.append(f"inside at {', '.join(inside)}")
    text = "; ".join(parts)
    return text[:1].upper() + text[1:]


def _reason_lines(answer: dict) -> list[str]:
    """Why each life without a finite value has none (an open worst case is said below
    the table with the release that bounds it).
    """
    lines = []
    for e in answer["bearings"]:
        found = [(n, s["reason"]) for n, s in e["selections"].items() if s["reason"]]
        worst, best = e["interval"]["reason"]
        found += [("set worst", worst)] if worst and not e["interval"]["open"] else []
        found += [("set best", best)] if best else []
        lines += [f"- {e['bearing']}, {name}: {why}." for name, why in found]
    return ["", "Lives without a finite value:", *lines] if lines else []


def _split_lines(answer: dict) -> list[str]:
    """Per bearing that carries axial load beyond ``e`` in some selection: at how many
    instants ``P = X Fr + Y |Fa|`` in each, and the factors where the scene gives them.
    """
    lines = []
    for e in answer["bearings"]:
        counts = {n: s["axial_instants"] for n, s in e["selections"].items()}
        if not any(counts.values()):
            continue
        factors = e["rating"]["X_Y_e"]
        given = ("X, Y, e from ISO 281's tables" if isinstance(factors, str) else
                 "X {:g}, Y {:g}, e {:g} as the scene gives them".format(*factors))
        lines.append(f"- {e['bearing']}: P = X Fr + Y |Fa| (|Fa| > e Fr) at "
                     + ", ".join(f"{k} ({n})" for n, k in counts.items())
                     + f" of {len(answer['t_s'])} instants; {given}.")
    return [""] + lines if lines else []


def _load_lines(answer: dict) -> list[str]:
    """The greatest ``P`` of any selection against its bearing's ``C``, and where every
    bearing's is below :data:`LIGHT_LOAD`, that the lives are long because the loads
    are light.
    """
    ratios = {e["bearing"]: e["peak_P_over_C"] for e in answer["bearings"]
              if math.isfinite(e["peak_P_over_C"])}
    if not ratios:
        return []
    top = max(ratios, key=ratios.get)
    line = (f"Loads against the ratings: the greatest P of any selection is "
            f"{100 * ratios[top]:.2g} % of C ({top}).")
    if ratios[top] <= LIGHT_LOAD:
        line += (f" Every bearing is lightly loaded (P <= {LIGHT_LOAD:g} C): ISO 281's "
                 "L10 = (C/P)^p makes these lives long because the scene's loads are "
                 "light, not because of the bearings.")
    return ["", line]


ROW_IN = 0.6
"""The height of one bearing's row on the figure (inches): its bar and each
selection's mark at a height of its own."""

FRAME_IN = 1.25
"""The figure's height besides its rows and its legend (inches): the titles above the
panel and the x axis below it."""

LEGEND_LINE_IN = 0.14
"""The height of one line of the legend beside the panel (inches)."""

MARK_STEP = 0.19
"""How far apart (a row's height is 1) the selections' marks of one row are drawn: at
one life they all show, each at its own height."""

BAR, CAP, OPEN_END = "0.72", "0.3", "0.3"
"""The colours of a rigid set's bar, of its finite ends' caps, and of the arrow of an
open end."""

SET_BAR_LABEL = "rigid set: worst to best\n(a cap at a finite end)"
OPEN_WORST_LABEL = "open: no finite worst case\n(the arrow: L10 down to 0)"
UNLOADED_BEST_LABEL = "unloaded at best: no finite\nbest case (the arrow: L10\nunbounded)"
"""Legend labels of the rigid set's bar and of its open ends (wrapped to the legend's
width)."""


ROWS_PER_PAGE = int((images.PAGE_IN[1] - FRAME_IN) / ROW_IN)
"""How many bearings' rows one page of the figure holds (:data:`images.PAGE_IN`)."""


def _arrow(pointing: str):
    """A marker whose tip is the point it marks, pointing ``left`` or ``right``: drawn at
    the axis' edge, the arrow of an end that runs on beyond the axis (no cap).
    """
    from matplotlib.path import Path as Shape

    sign = 1.0 if pointing == "left" else -1.0
    return Shape([(0.0, 0.0), (sign * 1.6, 1.0), (sign * 1.6, -1.0), (0.0, 0.0)],
                 [Shape.MOVETO, Shape.LINETO, Shape.LINETO, Shape.CLOSEPOLY])


def _legend_in(answer: dict) -> float:
    """The height of the legend beside the panel at most (inches): each selection, the
    set's bar and its two open ends.
    """
    lines = len(answer["selections"]) + sum(
        label.count("\n") + 1 for label in (SET_BAR_LABEL, OPEN_WORST_LABEL,
                                            UNLOADED_BEST_LABEL))
    return lines * LEGEND_LINE_IN + 0.4


def figures(answer: dict) -> list:
    """The figure's pages (:data:`ROWS_PER_PAGE` bearings each, one x range on all):
    each bearing's ``L10`` (h) interval over the rigid set as a bar with a cap at each
    finite end, an open end as an arrow on the axis' edge pointing to the open side,
    and each selection's ``L10`` as a mark, each selection at a height of its own in
    the row so that marks at one life all show. Make them in :func:`images.styled`.
    """
    entries = answer["bearings"]
    pages = [entries[k:k + ROWS_PER_PAGE]
             for k in range(0, len(entries), ROWS_PER_PAGE)] or [[]]
    values = [v for e in entries for v in (*e["interval"]["L10_h"],
              *(s["L10_h"] for s in e["selections"].values())) if 0 < v < math.inf]
    room = 100.0 if any(e["interval"]["open"] for e in entries) else 1.0  # for the arrow
    span = (10.0 ** math.floor(math.log10(min(values, default=1.0) / room)),  # decades
            10.0 ** (math.floor(math.log10(max(values, default=1.0))) + 1))
    return [_page(answer, rows, span, k, len(pages)) for k, rows in enumerate(pages)]


def figure(answer: dict):
    """The figure of one page (a scene whose bearings fit one; :func:`figures`)."""
    return figures(answer)[0]


def _page(answer: dict, entries: list, span: tuple, page: int, pages: int):
    """One page of :func:`figures`: ``entries``' rows over the x range ``span``."""
    import matplotlib.pyplot as plt
    from matplotlib.ticker import LogLocator, NullFormatter

    names = list(answer["selections"])
    rows = max(len(entries), 1)
    height = max(FRAME_IN + ROW_IN * rows, _legend_in(answer))
    fig, ax = plt.subplots(figsize=(images.PAGE_IN[0], height))
    left, right = span
    for k, e in enumerate(entries):
        _bar(ax, k, e, left, right)
        for c, name in enumerate(names):
            value = e["selections"][name]["L10_h"]
            if 0 < value < math.inf:
                ax.plot([value], [k + MARK_STEP * (c - (len(names) - 1) / 2)],
                        MARKS.get(name, "x"), color=f"C{c}", ms=4.5, mfc="none", mew=1.0,
                        zorder=3, label=name)
    ax.set_xscale("log")
    ax.set_xlim(left, right)
    ax.xaxis.set_major_locator(LogLocator(numticks=12))
    ax.xaxis.set_minor_formatter(NullFormatter())
    ax.set_yticks(range(len(entries)), [e["bearing"] for e in entries])
    ax.tick_params(axis="y", length=0)
    reach = max(0.5, MARK_STEP * (len(names) - 1) / 2 + 0.18)  # the outer marks inside
    ax.set_ylim(rows - 1 + reach, -reach)  # the first bearing on top
    ax.grid(True, axis="x", which="major")
    ax.set_xlabel("basic rating life L10 [h]")
    ax.set_ylabel("rated bearing [shaft.bearing]")
    ax.set_title(images.typeset("L10 over the rigid set (bar) and of each selection "
                                "(marks, one height each)"), loc="left")
    of = f" ({page + 1} of {pages})" if pages > 1 else ""
    fig.suptitle(images.typeset(f"{answer['scene']}: ISO 281 bearing life{of}"))
    if entries:
        handles = _handles(ax)
        fig.legend(handles.values(), handles.keys(), loc="upper right",
                   bbox_to_anchor=(1.0, 1 - FRAME_IN / 2 / height), labelspacing=0.7)
    else:
        ax.set_axis_off()  # no rows, no lives: the page says so and draws no axes
        ax.set_title("", loc="left")
        ax.text(0.5, 0.5, "no bearing of the scene has catalogue data", ha="center",
                transform=ax.transAxes)
    fig.canvas.draw()
    beside = (fig.legends[0].get_window_extent().width / fig.dpi + 0.05
              if fig.legends else 0.0)
    above = fig._suptitle.get_window_extent().height / fig.dpi
    fig.tight_layout(rect=(0, 0, 1 - beside / images.PAGE_IN[0], 1 - above / height),
                     pad=0.3)
    return fig


def _bar(ax, k: int, entry: dict, left: float, right: float) -> None:
    """Row ``k``'s interval over the rigid set: a bar from the worst life to the best,
    a cap at each finite end (one cap where the interval is a point), an arrow on the
    axis' edge where an end is open (no finite worst case: to the left; unloaded at
    best: to the right). Nothing where an end was not solved.
    """
    worst, best = entry["interval"]["L10_h"]
    if math.isnan(worst) or math.isnan(best):
        return
    open_low = entry["interval"]["open"] or not worst > 0
    open_high = math.isinf(best)
    lo, hi = left if open_low else worst, right if open_high else max(best, worst)
    caps = [i for i, is_open in ((0, open_low), (1, open_high)) if not is_open]
    ax.plot([lo, hi], [k, k], color=BAR, lw=6, solid_capstyle="butt", zorder=1,
            marker="|", ms=11, mew=1.2, mec=CAP, markevery=caps, label=SET_BAR_LABEL)
    for is_open, x, side, label in ((open_low, left, "left", OPEN_WORST_LABEL),
                                    (open_high, right, "right", UNLOADED_BEST_LABEL)):
        if is_open:
            ax.plot([x], [k], ls="none", marker=_arrow(side), ms=15, color=OPEN_END,
                    zorder=2, clip_on=False, label=label)


def _handles(ax) -> dict:
    """One legend handle per label of ``ax``: the selections in their marks' order in a
    row (top to bottom), then the set's bar and its open ends.
    """
    handles = {}
    for line in ax.lines:
        handles.setdefault(line.get_label(), line)
    ends = (SET_BAR_LABEL, OPEN_WORST_LABEL, UNLOADED_BEST_LABEL)
    return {**{k: v for k, v in handles.items() if k not in ends},
            **{k: handles[k] for k in ends if k in handles}}


def write_outputs(answer: dict, out: Path, formats=("png",)) -> list[Path]:
    """``life.csv``, ``life.md`` and the figure (``life.<format>``; a page each where
    its rows take more than one, :func:`images.save_pages`) into ``out``; their paths.
    """
    return images.write_study(out, "life", lambda path: write_csv(answer, path),
                              markdown(answer), lambda: figures(answer), formats)


def add_parser(subparsers) -> None:
    """Register ``cardan life``."""
    p = subparsers.add_parser("life", help="ISO 281 bearing life of each selection and over "
                              "the rigid solution set (CSV, Markdown, figure; --json)")
    p.add_argument("scene", help="built-in name or TOML path")
    p.add_argument("--instants", type=whole_number(2, MAX_INSTANTS), default=INSTANTS,
                   help=f"instants over the scene's window (default {INSTANTS})")
    p.add_argument("--out", type=files.folder, default="results/life",
                   help="output folder (default %(default)s)")
    p.add_argument("--format", type=format_list, default=("png",),
                   help="comma-separated image formats (default png; any of png,svg,pdf)")
    p.add_argument("--penalty", action="store_true",
                   help="also rate the penalty-contact simulation's average (a simulation "
                        "of the released line over the window; dynamic scenes)")
    p.add_argument("--no-engine", dest="engine", action="store_false",
                   help="leave out MuJoCo's forces (run by default where installed and the "
                        "scene is expressible)")
    p.add_argument("--json", action="store_true",
                   help="print the whole answer as strict JSON on stdout (no files)")
    p.set_defaults(func=run)


def run(args) -> int:
    """The answer as JSON on stdout, or the files written (named on stderr)."""
    answer = study(args.scene, args.instants, progress=bars.line, penalty=args.penalty,
                   engine=args.engine)
    if not answer["bearings"]:
        bars.line(f"life: scene {answer['scene']} rates no bearing (no catalogue data)")
    if args.json:
        print(json_text(answer))
        return 0
    files.say_written("life", write_outputs(answer, Path(args.out), args.format))
    return 0
