"""``cardan life``: every rated bearing's ISO 281 basic rating life, for each member of
the rigid solution set the package can pick and over the whole set.

For each bearing whose scene gives catalogue data (:class:`~cardan_forces.driveline.
scene.BearingRating`), at ``--instants`` instants spread over the scene's window: the
equivalent dynamic load ``P(t)`` (:mod:`cardan_forces.driveline.bearing_life`), the duty
cycle's mean load ``Pm`` over the revolutions of the bearing's shaft (the motion's
speed) and ``L10`` in millions of revolutions and in hours at the window's mean speed,

- for each physical selection of :data:`SELECTIONS` (``positive``, ``compliance``,
  ``compliance_hertz``) and the simulated ones (:mod:`~cardan_forces.experiments.
  life_runs`): MuJoCo's forces where it is installed and can express the scene (unless
  ``--no-engine``), the penalty-contact simulation's average with ``--penalty`` (a
  simulation of the whole window; a dynamic scene); the answer says why one is not
  run, and
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

Where the set is open above, the worst case has no finite value: the answer says so
and names the release the advisor proposes (:func:`~cardan_forces.driveline.release.
advise`) that bounds it. Written into ``--out``: ``life.csv`` (every ``P`` over time),
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
from cardan_forces.experiments import files
from cardan_forces.experiments import progress as bars
from cardan_forces.experiments.environment import json_text, number_text
from cardan_forces.experiments.images import format_list, write_study
from cardan_forces.experiments.life_runs import ENGINE, PENALTY, engine_history, penalty_history
from cardan_forces.experiments.study import solve_over_time, value_ranges
from cardan_forces.formulations import where

from cardan_forces.commands import whole_number

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
    """``Pm`` (N), ``L10`` (million revolutions) and ``L10_h`` (hours) of a load history;
    with ``keep``, ``Pm`` over those instants only (``L10_h`` still at the whole
    window's mean speed).
    """
    kept = slice(None) if keep is None else keep
    pm = iso.mean_load(p_values[kept], revs[kept], iso.exponent(rating))
    l10 = iso.rating_life(rating, pm)
    return {"Pm_N": pm, "L10_Mrev": l10, "L10_h": iso.life_hours(l10, revs, span_s)}


def study(scene_spec: str, instants: int = INSTANTS, progress=None, penalty: bool = False,
          engine: bool = True) -> dict:
    """The whole answer of ``cardan life`` for one scene, as JSON-ready data (non-finite
    numbers are the encoder's ``null``): the instants, each rated bearing's ``P`` over
    time, ``Pm`` and ``L10`` per selection and over the set, the selections not run and
    why, and where the set is open, why and the release that bounds it. ``penalty`` and
    ``engine`` add the simulated selections (:mod:`~cardan_forces.experiments.
    life_runs`) where the scene allows them.
    """
    scene = load_scene(scene_spec)
    t = np.linspace(scene.time.start_s, scene.time.stop_s, instants)
    motion = simulate(scene, t)
    op = build_operator(motion)
    bearings = rated(op)
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
                              **({"about": simulated[name][1]} if name in simulated else {})}
                       for name, h in chosen.items()},
        "not_run": not_run,
        "unrated": [c.element for c in op.bearings() if c not in [r[0] for r in bearings]],
        "bearings": entries, "open": unbounded,
        "open_reason": _open_reason(motion, op) if unbounded else None,
        "release": _release(motion) if unbounded else None,
    }


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
    """One bearing's part of :func:`study`'s answer: per selection ``P``, the radial
    and axial loads ``Fr``, ``Fa`` it comes from (N), at how many instants ``|Fa| > e
    Fr`` (``P = X Fr + Y |Fa|``), ``Pm`` and ``L10``. A simulated selection's ``Pm`` is
    over the instants it has (the others left out, their count said); a rigid one's is
    NaN where an instant was not solved.
    """
    revs = iso.revolutions(motion.omega[contact.shaft], op.t)
    selections = {}
    for name, history in chosen.items():
        fr, fa = loads(op, contact, history.forces)
        p = iso.equivalent_load(rating, fr, fa)
        keep = np.isfinite(p) if name in (PENALTY, ENGINE) else None
        with np.errstate(invalid="ignore"):
            axial = int(np.sum(np.abs(fa) > iso.factors(rating, fa)[2] * fr))
        selections[name] = {"P_N": p, "Fr_N": fr, "Fa_N": fa, "axial_instants": axial,
                            **life(rating, p, revs, span, keep),
                            "unsolved_instants": int(np.isnan(p).sum())}
    peaks = [np.nanmax(s["P_N"]) for s in selections.values() if np.isfinite(s["P_N"]).any()]
    lo, hi = p_ends(rating, env, b)
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
            "open": bool(np.isinf(hi).any()),
            "radial_determinate": determinate,
            "ends": _ends_words(determinate, contact.element_kind.slides, env, b)},
    }


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


def write_csv(answer: dict, path: Path) -> None:
    """Long format: one row per bearing, instant and series (each selection's ``P``,
    the set's least and greatest); an empty cell where undefined (open or unsolved).
    """
    with files.replacing(path, newline="") as f:
        w = csv.writer(f)
        w.writerow(["t_s", "bearing", "series", "P_N"])
        for entry in answer["bearings"]:
            series = {name: sel["P_N"] for name, sel in entry["selections"].items()}
            series.update(set_min=entry["interval"]["P_min_N"],
                          set_max=entry["interval"]["P_max_N"])
            for name, values in series.items():
                for t, p in zip(answer["t_s"], values):
                    w.writerow([f"{t:.6g}", entry["bearing"], name, number_text(p, ".9g", "")])


def _life_text(value: float) -> str:
    if math.isinf(value):
        return "unloaded"
    return number_text(value, ".4g", "-")


def markdown(answer: dict) -> str:
    """``life.md``: per bearing ``Pm`` and ``L10`` (h) of each selection and of the set,
    what the interval's ends are, what was not run, and the release where it is open.
    """
    names = list(answer["selections"])
    lines = [f"# Bearing life (ISO 281 L10) of scene {answer['scene']}", "",
             f"{len(answer['t_s'])} instants; `L10` in hours at each shaft's mean speed "
             "over the window; the set's worst and best over every rigid solution.", "",
             "| bearing | type | " + " | ".join(f"{n} L10 [h]" for n in names) +
             " | set worst L10 [h] | set best L10 [h] | set's ends |",
             "|---" * (len(names) + 5) + "|"]
    for e in answer["bearings"]:
        cells = [_life_text(e["selections"][n]["L10_h"]) for n in names]
        worst, best = e["interval"]["L10_h"]
        lines.append(f"| {e['bearing']} | {e['rating']['type']} | " + " | ".join(cells) +
                     f" | {'0 (open)' if e['interval']['open'] else _life_text(worst)} | "
                     f"{_life_text(best)} | {e['interval']['ends']} |")
    lines += _split_lines(answer) + _load_lines(answer)
    lines += ["", f"Radial directions: {answer['directions']} (greatest radial load within "
              f"{100 * answer['direction_error']:.2f} % above the true one)."]
    lines += [f"- {name}: {sel['about']}" for name, sel in answer["selections"].items()
              if "about" in sel]
    lines += [f"- {name}: {why}" for name, why in answer["not_run"].items()]
    if answer["unrated"]:
        lines.append(f"- no catalogue data (no life): {', '.join(answer['unrated'])}")
    if answer["open"]:
        release = answer["release"]
        lines += ["", f"**{answer['open_reason']}.** The release that bounds it: "
                  f"{release['words']} ({', '.join(release['labels']) or 'none'})."]
    return "\n".join(lines) + "\n"


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


def figure(answer: dict):
    """Each bearing's ``L10`` (h) interval over the rigid set as a bar between end
    ticks (one tick where it is a point), each selection's as a mark; an open worst
    case as a bar from the axis' left edge, labelled.
    """
    import matplotlib.pyplot as plt
    from matplotlib.ticker import NullFormatter

    entries = answer["bearings"]
    fig, ax = plt.subplots(figsize=(8.0, 1.6 + 0.55 * max(len(entries), 1)))
    values = [v for e in entries for v in (*e["interval"]["L10_h"],
              *(s["L10_h"] for s in e["selections"].values())) if 0 < v < math.inf]
    left = 10.0 ** math.floor(math.log10(min(values, default=1.0) / 100.0))  # a decade
    shown = set()
    for k, e in enumerate(entries):
        worst, best = e["interval"]["L10_h"]
        lo = left if e["interval"]["open"] or not worst > 0 else worst
        hi = best if math.isfinite(best) else max(values, default=1.0) * 100.0
        if math.isfinite(lo) and math.isfinite(hi) and hi > 0:
            ax.plot([lo, max(hi, lo)], [k, k], color="0.6", lw=7, solid_capstyle="butt",
                    marker="|", ms=16, mew=2.5,
                    label=None if "set" in shown else "rigid set: worst to best")
            shown.add("set")
        if e["interval"]["open"]:
            ax.annotate("open: no finite worst case", (left, k), xytext=(4, 7),
                        textcoords="offset points", fontsize=8)
        for c, (name, sel) in enumerate(e["selections"].items()):
            if 0 < sel["L10_h"] < math.inf:
                ax.plot([sel["L10_h"]], [k], MARKS.get(name, "x"), color=f"C{c}", ms=6,
                        mfc="none", label=None if name in shown else name)
                shown.add(name)
    ax.set_xscale("log")
    ax.xaxis.set_minor_formatter(NullFormatter())  # a span under two decades: no crowding
    ax.set_xlim(left, 10.0 ** math.ceil(math.log10(ax.dataLim.intervalx[1])))  # decades
    ax.set_yticks(range(len(entries)), [e["bearing"] for e in entries])
    ax.set_ylim(-0.7, len(entries) - 0.3)
    ax.set_xlabel("basic rating life L10 [h]")
    ax.set_ylabel("bearing [-]")
    ax.set_title("L10 over every rigid solution (bar) and each selection (marks)", fontsize=9)
    fig.suptitle(f"{answer['scene']}: ISO 281 bearing life", fontsize=10)
    if entries:
        ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, frameon=False)
    else:
        ax.text(0.5, 0.5, "no bearing of the scene has catalogue data", ha="center",
                transform=ax.transAxes, fontsize=9)
    height = fig.get_size_inches()[1]
    fig.subplots_adjust(left=0.2, right=0.74, bottom=0.6 / height, top=1 - 0.75 / height)
    return fig


def write_outputs(answer: dict, out: Path, formats=("png",)) -> list[Path]:
    """``life.csv``, ``life.md`` and ``life.<format>`` into ``out``; their paths."""
    return write_study(out, "life", lambda path: write_csv(answer, path), markdown(answer),
                       lambda: figure(answer), formats)


def add_parser(subparsers) -> None:
    """Register ``cardan life``."""
    p = subparsers.add_parser("life", help="ISO 281 bearing life of each selection and over "
                              "the rigid solution set (CSV, Markdown, figure; --json)")
    p.add_argument("scene", help="built-in name or TOML path")
    p.add_argument("--instants", type=whole_number(2, MAX_INSTANTS), default=INSTANTS,
                   help=f"instants over the scene's window (default {INSTANTS})")
    p.add_argument("--out", default="results/life", help="output folder (default %(default)s)")
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
    """The answer as JSON, or the files written (their paths on stdout)."""
    answer = study(args.scene, args.instants, progress=bars.line, penalty=args.penalty,
                   engine=args.engine)
    if not answer["bearings"]:
        bars.line(f"life: scene {answer['scene']} rates no bearing (no catalogue data)")
    if args.json:
        print(json_text(answer))
        return 0
    for path in write_outputs(answer, Path(args.out), args.format):
        print(path)
    return 0
