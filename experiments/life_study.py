"""The study of ``cardan life``: every rated bearing's ISO 281 basic rating life, for
each selection the package can compute and over the whole rigid solution set, as one
JSON-ready answer (:func:`study`). It writes no file and draws nothing: the answer is
plain data that :mod:`~cardan_forces.experiments.life_report` writes out and ``--json``
prints, and that other studies (``cardan tolerances``) and the tests read without the
report's files or figures.

For each bearing whose scene gives catalogue data (:class:`~cardan_forces.driveline.
scene.BearingRating`), at ``--instants`` instants of a load history: the equivalent
dynamic load ``P(t)`` (:mod:`cardan_forces.driveline.bearing_life`), the mean load
``Pm`` over the revolutions of the bearing's shaft and ``L10`` in millions of
revolutions. The history is a duty cycle's where the run has one (the scene's
``[[duty_cycle]]``, ``--duty-cycle FILE`` or ``--speed-rpm N``): each bin's steady
state over one input revolution, the bins combined by Palmgren-Miner, with hours at
the spectrum's mean speed and ISO 281:2007's modified life ``L_nm`` for
``--reliability`` (:mod:`~cardan_forces.experiments.life_duty`). Without one it is the
scene's window, a start-up: lives in revolutions only, without hours or ``L_nm`` (each
says why). Per bearing also its loads' ranges and the requisite minimum load
(:data:`MINIMUM_LOAD`), checked. Lives are given

- for each selection, each a different kind of answer (:data:`MODELS`): the members of
  the rigid set :data:`SELECTIONS` (``positive``, ``compliance``,
  ``compliance_hertz``); MuJoCo's forces (:mod:`~cardan_forces.experiments.life_runs`),
  a soft-constraint engine's, which lie in the set up to its own residual, where it is
  installed and can express the scene (unless ``--no-engine``); and with ``--penalty``
  the penalty-contact simulation's average, a different model (the released line with
  its clearances) whose forces may lie outside the set (a simulation of the whole
  window; a dynamic scene, no duty cycle). The answer says why one is not run, and
  for each selection and bearing whether its life lies within the set's interval
  (:func:`in_set`: its ``Pm`` between the set's least and greatest over the same
  instants, to :data:`IN_SET_TOL` of the bearing's load), computed, never assumed;
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
(:func:`~cardan_forces.driveline.release.advise`) that bounds it.
"""

from __future__ import annotations

import dataclasses
import math
from typing import NamedTuple

import numpy as np
from cardan_forces.driveline import bearing_life as iso
from cardan_forces.driveline import duty
from cardan_forces.driveline.determinacy import DETERMINATE_TOL, determinacy
from cardan_forces.driveline.dynamics import Motion, simulate
from cardan_forces.driveline.equilibrium import Operator, build_operator
from cardan_forces.driveline.loading import load_scene
from cardan_forces.driveline.modes import counts
from cardan_forces.driveline.release import advise, named_modes
from cardan_forces.driveline.scene import SceneError
from cardan_forces.experiments import life_duty
from cardan_forces.experiments import progress as bars
from cardan_forces.experiments.life_runs import ENGINE, PENALTY, engine_history, penalty_history
from cardan_forces.experiments.study import solve_over_time, value_ranges
from cardan_forces.formulations import where

INSTANTS = 41
"""Instants by default (each costs a few warm LPs per bearing whose radial load is free)."""

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

MINIMUM_LOAD = {"ball": 0.01, "roller": 0.02}
"""The requisite minimum load as a share of ``C``: "As a general rule, minimum loads of
0,01 C should be imposed on ball bearings and 0,02 C on roller bearings" (SKF, Rolling
bearings, PUB BU/P1 17000 EN, 2018, "Requisite minimum load"); below it, skidding and
smearing rather than fatigue may end the bearing's life."""

RELIABILITY = 90.0
"""The reliability (%) of a life by default: ISO 281's ``L10``, ``a1 = 1``."""

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


def life(rating, p_values: np.ndarray, revs: np.ndarray, keep: np.ndarray | None = None
         ) -> dict:
    """``Pm`` (N) and ``L10`` (million revolutions) of a load history over stretches of
    ``revs`` revolutions, and ``reason``: why one of them has no finite value (``None``
    where both have one); with ``keep``, over those instants only.
    """
    kept = slice(None) if keep is None else keep
    pm = iso.mean_load(p_values[kept], revs[kept], iso.exponent(rating))
    reason = iso.no_value_reason(p_values[kept], revs[kept])
    if reason and revs.sum() > 0 and not revs[kept].sum() > 0:
        reason = "no value: the shaft turns at none of the instants kept"
    return {"Pm_N": pm, "L10_Mrev": iso.rating_life(rating, pm), "reason": reason}


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
          engine: bool = True, duty_file: str | None = None, speed_rpm: float | None = None,
          reliability: float = RELIABILITY) -> dict:
    """The whole answer of ``cardan life`` for one scene, as JSON-ready data (non-finite
    numbers are the encoder's ``null``): each rated bearing's ``P`` at each instant,
    ``Pm``, ``L10`` and ``L_nm`` per selection and over the set, the selections not run
    and why, what each selection is (:data:`MODELS`) and whether its life lies in the
    set's, and where the set is open, why and the release that bounds it.

    With a duty cycle (the scene's, ``duty_file``'s or one bin at ``speed_rpm``:
    :func:`~cardan_forces.experiments.life_duty.spectrum`) each bin is rated as a steady
    state at ``instants`` instants over one input revolution and the bins combined
    (:func:`_spectrum_study`), with hours at the spectrum's mean speed and ISO
    281:2007's modified life for ``reliability`` (%); without one, the scene's window at
    ``instants`` instants (:func:`_window_study`), in revolutions only. ``penalty`` and
    ``engine`` add the simulated selections (:mod:`~cardan_forces.experiments.
    life_runs`) where the scene allows them (not on a duty cycle). A scene none of
    whose rated shafts turns is refused (:class:`SceneError`) before any solve.
    """
    scene = load_scene(scene_spec)
    bins, source = life_duty.spectrum(scene_spec, scene, duty_file, speed_rpm)
    if bins:
        return _spectrum_study(scene, bins, source, instants, progress, reliability)
    return _window_study(scene, instants, progress, penalty, engine)


def _window_study(scene, instants: int, progress, penalty: bool, engine: bool) -> dict:
    """:func:`study` over the scene's window: lives in revolutions, no hours (a start-up
    is not the bearing's service) and no modified life (no operating speed).
    """
    t = np.linspace(scene.time.start_s, scene.time.stop_s, instants)
    motion = simulate(scene, t)
    op = build_operator(motion)
    bearings = rated(op)
    _check_turning(scene, motion, op, bearings)
    chosen = _rigid(op)
    simulated, not_run = _simulated(op, penalty, engine, progress)
    chosen.update({name: history for name, (history, _) in simulated.items()})
    env = _envelope(op, bearings, progress)
    span = float(t[-1] - t[0])
    entries = [_bearing_entry(op, contact, rating, chosen, env, b,
                              iso.revolutions(motion.omega[contact.shaft], op.t), span)
               for b, (contact, rating) in enumerate(bearings)]
    for entry in entries:
        for one in (*entry["selections"].values(), entry["interval"]):
            _without_speed(one, isinstance(one["Pm_N"], list))
    return {"scene": scene.name, "t_s": t, "instants": len(t), "duty_cycle": None,
            "hours_reason": life_duty.NO_HOURS, "modified_reason": life_duty.NO_SPEED,
            **_about(op, {name: _summary(h, name, simulated) for name, h in chosen.items()},
                     not_run, bearings, entries, motion)}


def _without_speed(lives: dict, ends: bool) -> None:
    """A window's life (or the set's two ends) without hours or modified life, each
    with its reason (:mod:`~cardan_forces.experiments.life_duty`).
    """
    none = [math.nan, math.nan] if ends else math.nan
    lives.update({"L10_h": none, "hours_reason": life_duty.NO_HOURS, "L_nm_Mrev": none,
                  "L_nm_h": none, "a_ISO": none, "modified_reason": life_duty.NO_SPEED})


def _rigid(op: Operator) -> dict:
    """Each rigid selection's history on ``op`` (:data:`SELECTIONS`)."""
    return {name: solve_over_time(op, name) for name in SELECTIONS}


def _envelope(op: Operator, bearings: list, progress) -> dict:
    """:func:`load_envelope` with a bar (or progress lines) over the instants."""
    with bars.ticks(len(op.t), "life: intervals", "instant", progress) as tick:
        return load_envelope(op, bearings, progress=tick)


def _summary(history, name: str, simulated: dict | None = None) -> dict:
    """A selection's line of the answer: its solver, instants solved of all, what it
    is (:data:`MODELS`) and, for a simulated one, what was run.
    """
    about = {"about": simulated[name][1]} if simulated and name in simulated else {}
    return {"solver": history.solver, "solved": history.solved, "instants": len(history.t),
            "model": MODELS[name], **about}


def _about(op, selections: dict, not_run, bearings, entries, motion) -> dict:
    """The parts of :func:`study`'s answer besides the scene and its instants: the
    ``selections``' lines, those not run, the bearings' entries, and where the set is
    open, why and the release that bounds it (at ``motion``'s instants).
    """
    unbounded = any(e["interval"]["open"] for e in entries)
    return {
        "directions": DIRECTIONS,
        "direction_error": 1.0 / math.cos(math.pi / DIRECTIONS) - 1.0,
        "selections": selections,
        "in_set_tol": IN_SET_TOL,
        "not_run": not_run,
        "unrated": [c.element for c in op.bearings() if c not in [r[0] for r in bearings]],
        "bearings": entries, "open": unbounded,
        "open_reason": _open_reason(motion, op) if unbounded else None,
        "release": _release(motion) if unbounded else None,
    }


class RatedBin(NamedTuple):
    """One duty-cycle bin rated (:func:`_rate_bin`)."""

    op: Operator
    motion: Motion
    chosen: dict
    entries: list


def _spectrum_study(scene, bins: tuple, source: str, instants: int, progress,
                    reliability: float) -> dict:
    """:func:`study` over a duty cycle: each bin's steady state rated by the same
    per-instant machinery as a window (:func:`_rate_bin`), the bins combined per
    bearing (:func:`~cardan_forces.experiments.life_duty.bearing_over_bins`).
    """
    rated_bins = []
    for k, duty_bin in enumerate(bins):
        if progress:
            progress(f"life: bin {k + 1}/{len(bins)}, {duty_bin.torque_N_m:g} N m at "
                     f"{duty_bin.speed_rpm:g} r/min")
        rated_bins.append(_rate_bin(scene, duty_bin, instants, progress))
    first = rated_bins[0]
    per_bearing = zip(*(r.entries for r in rated_bins))
    entries = [_in_set_over_bins(life_duty.bearing_over_bins(rating, list(of_bins), bins,
                                                             reliability))
               for (_, rating), of_bins in zip(rated(first.op), per_bearing)]
    opened = [r.motion for r in rated_bins if any(e["interval"]["open"] for e in r.entries)]
    not_run = {PENALTY: life_duty.NOT_RUN, ENGINE: life_duty.NOT_RUN}
    return {"scene": scene.name, "instants": instants * len(bins),
            "duty_cycle": _spectrum_words(bins, source, rated_bins, reliability),
            "hours_reason": None, "modified_reason": None,
            **_about(first.op, _bins_summary(rated_bins), not_run, rated(first.op), entries,
                     (opened or [first.motion])[0])}


def _spectrum_words(bins: tuple, source: str, rated_bins: list, reliability: float) -> dict:
    """The answer's ``duty_cycle``: where the bins come from, each with its share of the
    revolutions and its instants (s), the mean speed, the reliability and its ``a1``.
    """
    return {"source": source, "instants_per_bin": len(rated_bins[0].op.t),
            "mean_speed_rpm": duty.mean_speed_rpm(bins), "reliability_percent": reliability,
            "a1": iso.reliability_factor(reliability),
            "bins": [{**dataclasses.asdict(b), "revolution_share": u, "t_s": r.motion.t}
                     for b, u, r in zip(bins, duty.revolution_shares(bins), rated_bins)]}


def _bins_summary(rated_bins: list) -> dict:
    """Each rigid selection's line of the answer over every bin's instants."""
    return {name: {**_summary(history, name),
                   "solved": sum(r.chosen[name].solved for r in rated_bins),
                   "instants": sum(len(r.chosen[name].t) for r in rated_bins)}
            for name, history in rated_bins[0].chosen.items()}


def _in_set_over_bins(entry: dict) -> dict:
    """A bearing's entry over a duty cycle with each selection's combined ``Pm`` checked
    against the set's combined ends (:func:`in_set`, to the bins' greatest load scale).
    """
    scale = max(e["load_scale_N"] for e in entry["bins"])
    best, worst = entry["interval"]["Pm_N"]
    for sel in entry["selections"].values():
        sel["in_set"] = in_set(sel["Pm_N"], (best, worst), scale)
    return entry


def _rate_bin(scene, duty_bin, instants: int, progress) -> RatedBin:
    """One bin's steady state (:func:`~cardan_forces.experiments.life_duty.bin_scene`)
    rated: its operator, motion, rigid selections' histories and bearings' entries.
    """
    variant, t = life_duty.bin_scene(scene, duty_bin, instants)
    motion = simulate(variant, t)
    op = build_operator(motion)
    chosen = _rigid(op)
    bearings = rated(op)
    env = _envelope(op, bearings, progress)
    period = 60.0 / duty_bin.speed_rpm
    entries = [_bearing_entry(op, contact, rating, chosen, env, b,
                              life_duty.revolutions(motion.omega[contact.shaft], period),
                              period)
               for b, (contact, rating) in enumerate(bearings)]
    return RatedBin(op, motion, chosen, entries)


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


def _bearing_entry(op, contact, rating, chosen, env, b, revs, span) -> dict:
    """One bearing's part of a window's or a bin's answer, its shaft turning ``revs``
    revolutions over each instant's stretch and ``span`` seconds in all: per selection
    (:func:`_selection_entry`) and over the set ``P``, ``Pm`` and ``L10``, each life's
    reason where it has no finite value, and whether each selection's lies in the set's;
    the loads' ranges, the greatest ``P`` over ``C`` and the minimum-load check.
    """
    lo, hi = p_ends(rating, env, b)
    selections = {name: _selection_entry(op, contact, rating, name, history, revs)
                  for name, history in chosen.items()}
    peaks = [np.nanmax(s["P_N"]) for s in selections.values() if np.isfinite(s["P_N"]).any()]
    scale = max([*peaks, *lo[np.isfinite(lo)], *hi[np.isfinite(hi)]], default=0.0)
    for name, sel in selections.items():
        keep = np.isfinite(sel["P_N"]) if name in (PENALTY, ENGINE) else None
        ends = [life(rating, p, revs, keep)["Pm_N"] for p in (lo, hi)]
        sel["in_set"] = in_set(sel["Pm_N"], ends, scale)
    worst, best = life(rating, hi, revs), life(rating, lo, revs)
    determinate = bool(env["radial_determinate"][:, b].all())
    return {
        "bearing": contact.element, "kind": contact.kind.removeprefix("bearing-"),
        "rating": _rating(rating),
        "revolutions": float(revs.sum()),
        "mean_speed_rpm": float(revs.sum() / span * 60.0) if span > 0 else math.nan,
        "load_range": _load_range(env, b, selections),
        "selections": selections,
        "peak_P_over_C": float(max(peaks, default=math.nan)) / rating.C_N,
        "load_scale_N": float(scale),
        "minimum_load": minimum_load(rating, selections),
        "interval": {
            "P_min_N": lo, "P_max_N": hi, "Pm_N": [best["Pm_N"], worst["Pm_N"]],
            "L10_Mrev": [worst["L10_Mrev"], best["L10_Mrev"]],
            "reason": [worst["reason"], best["reason"]],
            "open": bool(np.isinf(hi).any()),
            "radial_determinate": determinate,
            "ends": _ends_words(determinate, contact.element_kind.slides, env, b)},
    }


def _rating(rating) -> dict:
    """A rating's catalogue data as the answer gives it (ISO 281:2007's inputs null
    where the scene gives none).
    """
    return {"type": rating.type, "contact_angle_deg": rating.contact_angle_deg,
            "C_N": rating.C_N, "C0_N": rating.C0_N, "p": iso.exponent(rating),
            "X_Y_e": ([rating.X, rating.Y, rating.e] if rating.X is not None
                      else "ISO 281 tables"),
            **{k: getattr(rating, k) for k in iso.ISO_INPUTS}}


def _load_range(env: dict, b: int, selections: dict) -> dict:
    """The least and the greatest radial load ``Fr_N`` and axial load's magnitude
    ``Fa_N`` (N) of bearing ``b`` over the set's ends and every selection's loads, and
    ``reason`` where a greatest one has no finite value (the set open above).
    """
    fr = [env["fr_lo"][:, b], env["fr_hi"][:, b], *(s["Fr_N"] for s in selections.values())]
    fa = [env["fa_lo"][:, b], env["fa_hi"][:, b],
          *(np.abs(s["Fa_N"]) for s in selections.values())]
    found = {}
    for key, values in (("Fr_N", fr), ("Fa_N", fa)):
        both = np.concatenate(values)
        both = both[~np.isnan(both)]
        found[key] = ([float(both.min()), float(both.max())] if len(both)
                      else [math.nan, math.nan])
    unbounded = not all(math.isfinite(v) for pair in found.values() for v in pair)
    return {**found, "reason": "the set is open above: no finite greatest load, or a load "
            "not solved" if unbounded else None}


def minimum_load(rating, selections: dict) -> dict:
    """Whether the selections' least ``P`` (over every instant) meets the catalogue's
    requisite minimum load, ``P >= k C`` with ``k`` :data:`MINIMUM_LOAD` (ball 0.01,
    roller 0.02): ``rule_P_over_C``, ``least_P_over_C`` (NaN where none was solved) and
    ``below``.
    """
    rule = MINIMUM_LOAD["roller" if rating.roller else "ball"]
    values = np.concatenate([s["P_N"] for s in selections.values()] or [np.zeros(0)])
    values = values[np.isfinite(values)]
    least = float(values.min()) / rating.C_N if len(values) else math.nan
    return {"rule_P_over_C": rule, "least_P_over_C": least, "below": bool(least < rule)}


def _selection_entry(op, contact, rating, name, history, revs) -> dict:
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
            **life(rating, p, revs, keep), "unsolved_instants": int(np.isnan(p).sum())}


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
    """Why the set is open, from the named modes at the first instant: a closed loop's
    self-stress, a free axial split between locating bearings, or a bearing pair's
    preload (the one free mode that no release removes: the pair is the design).
    """
    modes = named_modes(motion, 0, op)
    kinds = counts(modes)
    if kinds.get("closed loop"):
        return OPEN
    if kinds.get("axial split"):
        return "no finite worst case: the axial split between locating bearings is free"
    pair = next(m for m in modes if m.kind == "bearing pair")
    return f"no finite worst case: a bearing pair's preload is free, {pair.description}"


def _release(motion) -> dict:
    """The release the advisor proposes at the middle instant (labels and words), or
    why there is none: where every free mode is one complementarity settles (a bearing
    pair, end-face pairs), the pair's preload is what bounds the worst case, a value
    the design states, not a constraint to release.
    """
    try:
        advice = advise(motion, len(motion.t) // 2)
    except SceneError as err:
        return {"labels": [], "words": f"none found: {err}"}
    if not advice.releases:
        return {"labels": [], "words": (
            "none: every free mode is one complementarity settles (without preload one "
            "bearing of a pair carries the axial load, the set's best end); the pair's "
            "stated preload bounds the worst case")}
    return {"labels": [r.label for r in advice.releases],
            "words": "; ".join(r.words for r in advice.releases)}
