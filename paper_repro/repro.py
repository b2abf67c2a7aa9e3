"""``cardan repro``: the paper's Figs. 11-15 and a report, on the embedded scenes.

Figs. 11-12 come from the motion; 13-15 from contact-force histories of the methods
chosen (the paper's method and the convex formulations,
:mod:`cardan_forces.paper_repro.histories`), drawn over the rigid solution set's interval
(the study layer's :func:`~cardan_forces.experiments.study.value_range`). Every figure
also carries the penalty-contact simulation of the same scene with its joints released
(the paper's ADAMS model, :mod:`cardan_forces.driveline.penalty`), and the report compares
it with the ``compliance`` formulations on the same stiffness and clearances. Fig. 15 is
drawn for both horizontal gravities (the paper does not say which) and the report says
which one matches the paper's text. The report states versions, machine, settings, and
per figure what the numbers say next to the paper's text.
"""

from __future__ import annotations

import datetime
import functools
import importlib.util
import os
import signal
import time
from collections.abc import Callable
from concurrent.futures import Future, ProcessPoolExecutor
from dataclasses import dataclass
from multiprocessing import get_all_start_methods, get_context
from pathlib import Path

import numpy as np
from cardan_forces.driveline import engine_mujoco
from cardan_forces.driveline.determinacy import determinacy
from cardan_forces.driveline.dynamics import Motion, simulate
from cardan_forces.driveline.engine_mujoco import EngineUnsupported
from cardan_forces.driveline.equilibrium import Operator, build_operator
from cardan_forces.driveline.kinematics import kinematics
from cardan_forces.driveline.loading import load_scene
from cardan_forces.driveline.penalty import PenaltyResult
from cardan_forces.driveline.scene import Scene
from cardan_forces.experiments import files
from cardan_forces.experiments.engine import (
    FIGURE_SETTINGS,
    SETTINGS,
    agreement_lines,
    compare,
    engine_runs,
    settle_s,
)
from cardan_forces.experiments.engine import (
    spread as softness_spread,
)
from cardan_forces.experiments.environment import machine, number_text, versions
from cardan_forces.experiments.progress import bar
from cardan_forces.experiments.study import value_ranges
from cardan_forces.formulations import FORMULATIONS, SELECTION, where
from cardan_forces.formulations.convex import NotApplicable
from scipy.stats import binomtest

from . import figures
from .figures import PENALTY, SMOOTH_S, moving_average
from .histories import METHODS, History, history, penalty_history, released, run_penalty

FIGURES = (11, 12, 13, 14, 15)
FIG15_SCENES = ("paper-fig15", "paper-fig15-axial")
"""Fig. 15's scenes: the paper says "horizontal" gravity but not which; +y (normal to
the articulation plane) and +x (along the input shaft) are both drawn."""
ENGINE = "engine"
"""The method name of MuJoCo's forward simulation
(:mod:`cardan_forces.experiments.engine`)."""
ALL_METHODS = (*METHODS, PENALTY, ENGINE)
"""What ``cardan repro`` can draw: the rigid-model methods, the penalty simulation and
MuJoCo (its own figure and section)."""
ENGINE_S = 0.5
"""MuJoCo's window (s from the start): its settling (80 ms at the softest setting drawn)
and some 100 ms of each load's swing, at about 0.7 s of CPU per setting."""
ENGINE_INSTANTS = 3
"""Instants of MuJoCo's window, after its settling, set against every component's
interval and the formulations (:func:`cardan_forces.experiments.engine.compare`; some
70 LPs each)."""
ENGINE_BOUND_INSTANTS = 11
"""Instants of MuJoCo's window at which its figure's rigid band is computed."""
ENGINE_RTOL = 1e-4
"""A load of MuJoCo's is inside the rigid band within this share of the largest load:
its soft constraints leave ``A x = b`` at ~1e-5 (module doc of the engine's tests)."""
BOUNDS_JOB_COST = 0.2
"""Relative CPU cost of a figure's rigid-set bounds, on the scale of the formulations'
``job_cost`` (:class:`~cardan_forces.formulations.Formulation`): jobs are queued for the
worker processes dearest first, so that they end together."""
BOUND_INSTANTS = 41
"""Instants (evenly spread) at which Figs. 13-15's solution-set intervals are computed."""
QUICK_S = 0.15
"""Window of ``--quick`` (s from the start)."""
SETTLED_S = 0.1
"""Penalty comparisons start here: from rest the input shaft first turns through the
joints' play (~0.07 s on ``paper-penalty``), a transient the rigid model has not."""
PENALTY_TARGET_S = 1.0
"""The penalty simulation's target cost: wall seconds per simulated second."""
SIGNIFICANCE = 0.05
"""Two-sided level of the sign test behind "larger" / "smaller" verdicts."""
COMPLIANCE_VS_PENALTY = where(beside_penalty=True)
"""Methods compared with the penalty simulation (each by its default backend), on the
released scene's operator (the same effects, so the compliance formulations see the
same clearances as gaps)."""


def default_methods() -> tuple[str, ...]:
    """What ``cardan repro`` draws unless told: every method, MuJoCo only where it is
    installed (the ``mujoco`` extra, in ``all``).
    """
    present = importlib.util.find_spec("mujoco") is not None
    return tuple(m for m in ALL_METHODS if present or m != ENGINE)


def joint_quantities(op: Operator, joint: int = 0) -> dict[str, np.ndarray]:
    """Fig. 13's quantities as rows over the forces: per contact ``F1`` ... ``F8`` of
    joint ``joint``, the unit rows of its columns (two for a radial force, whose
    magnitude is their length; one for an end face's push).
    """
    eye = np.eye(len(op.names))
    return {label: eye[list(link.columns)] for label, link in op.joint_contacts(joint).items()}


def bearing_quantities(op: Operator, shaft: int = 0) -> dict[str, np.ndarray]:
    """Figs. 14-15's quantities as rows over the forces, in the shaft's frame: per
    bearing ``<label>_radial`` its two rows normal to the axis; ``axial`` the one row of
    the sum of its bearings' axial loads.
    """
    rows = {c.label: op.bearing_matrix(c) for c in op.bearings(shaft)}
    out = {f"{label}_radial": m[:2] for label, m in rows.items()}
    out["axial"] = sum(m[2] for m in rows.values())[None, :]
    return out


def set_bounds(op: Operator, quantities: dict[str, np.ndarray], instants: int = BOUND_INSTANTS
               ) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """The interval of each quantity over the rigid set at ``instants`` instants
    (NaN elsewhere, and where an LP failed; +-inf where unbounded). A quantity of one row
    ``c``: the exact range of ``c x`` (:func:`value_ranges`, one warm ranging for every
    quantity at an instant). Of two rows: the range of the length of ``(c1 x, c2 x)``
    allowed by the two components' intervals (their box hull: it contains the exact
    range).
    """
    T = len(op.t)
    picks = np.unique(np.linspace(0, T - 1, min(instants, T)).round().astype(int))
    out = {q: (np.full(T, np.nan), np.full(T, np.nan)) for q in quantities}

    def span(r):  # None: unbounded on that side; a failed LP is not computed (NaN)
        if r["status"] != "solved":
            return np.nan, np.nan
        return (-np.inf if r["min"] is None else r["min"],
                np.inf if r["max"] is None else r["max"])

    starts = np.cumsum([0] + [len(rows) for rows in quantities.values()])
    every = np.vstack(list(quantities.values()))
    for i in picks:
        found = value_ranges(op, i, every)
        for (q, rows), start in zip(quantities.items(), starts):
            ranges = [span(r) for r in found[start:start + len(rows)]]
            if len(ranges) == 1:
                out[q][0][i], out[q][1][i] = ranges[0]
                continue
            closest = [0.0 if lo <= 0.0 <= hi else min(abs(lo), abs(hi)) for lo, hi in ranges]
            out[q][0][i] = np.hypot(*closest)
            out[q][1][i] = np.hypot(*[max(abs(lo), abs(hi)) for lo, hi in ranges])
    return out


def _refusal(scene: Scene, op: Operator, method: str) -> str:
    """Why ``method`` cannot draw ``scene`` (empty if it can): its problem cannot be
    built (the paper's method on a slip joint), or the penalty simulation of a
    quasi-static scene.
    """
    if method == PENALTY:
        return "" if scene.has("inertia") else "it is dynamic and needs the 'inertia' effect"
    if method == ENGINE:
        try:
            engine_mujoco.check_expressible(scene)
            engine_mujoco.mujoco_version()
        except EngineUnsupported as exc:
            return str(exc)
        return ""
    try:
        FORMULATIONS[method](op, 0)
    except NotApplicable as exc:
        return str(exc)
    return ""


def check_request(scene: Scene, op: Operator, methods, figs) -> None:
    """Refuse, before any long work, what the chosen methods or figures cannot do on
    ``scene`` (:class:`NotApplicable`, one line): a method that does not apply
    (:func:`_refusal`), Fig. 12 without an intermediate shaft, Figs. 13-15 without joint
    1's contacts or the first shaft's bearings.
    """
    why = {m: _refusal(scene, op, m) for m in methods}
    refused = [f"{m!r} ({why[m]})" for m in methods if why[m]]
    if refused:  # the others asked only to name what applies (MuJoCo's is an import)
        why |= {m: _refusal(scene, op, m) for m in ALL_METHODS if m not in why}
        usable = ",".join(m for m in ALL_METHODS if not why[m]) or "none"
        raise NotApplicable(f"cardan repro {scene.name}: {'; '.join(refused)}; choose "
                            f"--methods among those that apply here: {usable}")
    needs = []
    if 12 in figs and len(scene.shafts) < 3:
        needs.append("Fig. 12 draws an intermediate shaft (a line of at least 3 shafts)")
    if 13 in figs and not op.joint_contacts(0):
        needs.append("Fig. 13 draws joint 1's cross-pin contacts")
    if any(f in figs for f in (14, 15)) and not op.bearings(0):
        needs.append("Figs. 14-15 draw the first shaft's bearings")
    if needs:
        raise NotApplicable(f"cardan repro {scene.name}: {'; '.join(needs)}; leave them out "
                            "with --fig")


def _settled(t: np.ndarray) -> np.ndarray:
    return t >= t[0] + SETTLED_S


def _classify(value: float, agree, disagree) -> str:
    """``agrees`` / ``disagrees`` where ``agree(value)`` / ``disagree(value)``, else
    ``undecided`` (the band between the two thresholds).
    """
    if not np.isfinite(value):
        return "undecided"
    return "agrees" if agree(value) else "disagrees" if disagree(value) else "undecided"


def _verdict(stat, ok: np.ndarray, agree, disagree) -> tuple[str, str]:
    """Judge ``stat(mask)`` on the settled instants ``ok``, and again on each half of
    them: a verdict that the two halves of the run do not both give is ``undecided``
    (the data cannot tell). Returns the verdict and the values, for the report.
    """
    idx = np.flatnonzero(ok)
    halves = [np.isin(np.arange(len(ok)), part) for part in np.array_split(idx, 2)]
    whole, *parts = (stat(mask) for mask in (ok, *halves))
    verdict = _classify(whole, agree, disagree)
    if verdict != "undecided" and any(_classify(v, agree, disagree) != verdict
                                      for v in parts):
        verdict = "undecided"
    first, second = (number_text(v, ".3g", "no instant") for v in parts)
    return verdict, f"{number_text(whole, '.3g')} (first half {first}, second half {second})"


def _sign_test(differences: list[np.ndarray], scale: list[np.ndarray], block: int):
    """Sign test of ``differences`` (N) pooled over quantities, on means over blocks of
    ``block`` instants (neighbouring instants of a smoothed curve are not independent;
    blocks of the smoothing window are taken as independent samples). Ties (|mean| below
    1 mN, e.g. both forces zero) are dropped. Returns the share of positive blocks, their
    number, the two-sided p value and the median relative difference.
    """
    means, rel = [], []
    for d, s in zip(differences, scale):
        n = len(d) // block * block
        m = d[:n].reshape(-1, block).mean(axis=1)
        r = m / np.maximum(s[:n].reshape(-1, block).mean(axis=1), 1e-9)
        keep = np.isfinite(m) & (np.abs(m) > 1e-3)
        means.append(m[keep])
        rel.append(r[keep])
    means, rel = np.concatenate(means), np.concatenate(rel)
    if not means.size:
        return np.nan, 0, 1.0, np.nan
    positive = int(np.sum(means > 0))
    return (positive / means.size, means.size, binomtest(positive, means.size).pvalue,
            float(np.median(rel)))


def _fig13_notes(op: Operator, hist: dict[str, History]) -> list[str]:
    mags = {m: figures.joint_magnitudes(op, h.forces) for m, h in hist.items()}
    det = determinacy(op, len(op.t) // 2).determinate
    joint1 = sorted(c for link in op.joint_contacts(0).values() for c in link.columns)
    unique = [op.names[c] for c in joint1 if det[c]]
    lines = [f"- components of joint 1 that the rigid model determines (at t = "
             f"{op.t[len(op.t) // 2]:.3f} s): {', '.join(unique) or 'none'}; all others "
             "depend on the selection rule."]
    rigid = [m for m in mags if m != PENALTY]
    ref = SELECTION if SELECTION in rigid else rigid[0] if rigid else None
    for label in mags[ref] if ref else ():
        spread = np.nanmax([np.nanmax(np.abs(mags[m][label] - mags[ref][label]))
                            for m in rigid])
        peak = np.nanmax([np.nanmax(mags[m][label]) for m in rigid])
        lines.append(f"- |{label}|: peak {peak:.1f} N over the rigid methods; largest "
                     f"difference from `{ref}`: {spread:.1f} N")
    lines += _both_faces_note(op, hist)
    if PENALTY in mags and "paper" in mags:
        return lines + _frequency_note(op, mags) + _larger_note(op, mags)
    return lines + ["- the paper's text on Fig. 13 (penalty vs the paper's method): not "
                    "judged, the run draws only " + ", ".join(f"`{m}`" for m in mags)]


def _both_faces_note(op: Operator, hist: dict[str, History]) -> list[str]:
    """Where a method lets both end faces of one trunnion pair push at once (the paper's
    complementarity, eqs. 39, 46, does not hold): a force no contact can make.
    """
    lines, clean = [], []
    for m, h in hist.items():
        if m == PENALTY:
            continue
        both = np.max([np.minimum(h.forces[:, a], h.forces[:, b]) for a, b in op.pairs],
                      axis=0) if op.pairs else np.zeros(len(op.t))
        hit = np.isfinite(both) & (both > 1e-3)
        if hit.any():
            k = int(np.nanargmax(both))
            lines.append(f"- `{m}`: both end faces of a pair push at once at {hit.sum()} of "
                         f"{len(both)} instants (up to {both[k]:.1f} N each, t = "
                         f"{op.t[k]:.3f} s): it does not impose the faces' complementarity "
                         "(eqs. 39, 46), so its curves are a comparison, not a physical "
                         "selection (the figures' legend says so)")
        else:
            clean.append(f"`{m}`")
    if clean:
        lines.append(f"- {', '.join(clean)}: no pair of end faces pushes at once (above 1 mN)")
    return lines


def _frequency_note(op: Operator, mags) -> list[str]:
    """The paper: the ADAMS forces vary at a higher frequency than its method's."""
    def rough(ok):
        r = {m: np.nanmedian([np.nanmean(np.abs(np.diff(values[ok], 2)))
                              for values in mags[m].values()]) for m in ("paper", "penalty")}
        return r["penalty"] / r["paper"]

    verdict, values = _verdict(rough, _settled(op.t), lambda r: r >= 2.0, lambda r: r <= 0.5)
    return [f"- paper's text: the ADAMS forces vary at a higher frequency. Mean |second "
            f"difference| of the penalty curves over the paper method's (median over "
            f"F1-F8, after {SETTLED_S:g} s): {values}. Criterion: agrees at >= 2, disagrees "
            "at <= 1/2 (a factor of 2 either way, more than the paper method's own jumps "
            f"between members of the set can make up); both halves of the run must "
            f"agree: **{verdict}**."]


def _larger_note(op: Operator, mags) -> list[str]:
    """The paper: apart from peaks, its method's forces are slightly larger than ADAMS's."""
    ok = _settled(op.t)
    block = max(1, int(round(SMOOTH_S / np.median(np.diff(op.t))))) if len(op.t) > 1 else 1
    smooth = {k: moving_average(v, op.t)[ok] for k, v in mags["penalty"].items()}
    share, n, p, rel = _sign_test([mags["paper"][k][ok] - smooth[k] for k in smooth],
                                  list(smooth.values()), block)
    if n and p < SIGNIFICANCE and share > 0.5:
        verdict = "agrees" if rel <= 0.25 else "disagrees (larger, but not slightly)"
    elif n and p < SIGNIFICANCE:
        verdict = "disagrees (smaller)"
    else:
        verdict = "undecided"
    found = (f"positive in {100 * share:.0f} %, sign test p = {p:.2g}; median relative "
             f"difference {100 * rel:+.0f} %" if n else "too few to test")
    return [f"- paper's text: apart from peaks, its method's forces are slightly larger than "
            f"ADAMS's. Paper method minus the penalty's {SMOOTH_S:g} s average, F1-F8 pooled, "
            f"after {SETTLED_S:g} s, in {n} blocks of {SMOOTH_S:g} s: {found}. Criterion: "
            f"\"larger\" needs p < {SIGNIFICANCE:g} (a share "
            "near 50 % is a coin toss), \"slightly\" a median difference of at most +25 %: "
            f"**{verdict}**."]


def _bearing_notes(op: Operator, hist: dict[str, History], bounds, number: int
                   ) -> tuple[list[str], dict[str, str]]:
    """The report's notes on Fig. 14 or 15, and the verdicts on the paper's text
    (``radial``, ``axial``; empty without the paper's method and the penalty).
    """
    lines = []
    loads = {m: figures.bearing_loads(op, h.forces) for m, h in hist.items()}
    rigid = [m for m in loads if m != PENALTY]
    for q, (lo, hi) in bounds.items():
        ok = ~np.isnan(lo)
        unbounded = np.mean(np.isinf(hi[ok]) | np.isinf(lo[ok])) if ok.any() else np.nan
        spread = np.nanmax([np.nanmax(np.abs(loads[m][q] - loads[rigid[0]][q]))
                            for m in rigid]) if rigid else np.nan
        lines.append(f"- {q}: the rigid set is unbounded at {100 * unbounded:.0f} % of the "
                     f"instants checked; the rigid methods differ by up to {spread:.1f} N")
    if PENALTY not in loads or "paper" not in loads:
        return lines + [f"- the paper's text on Fig. {number} (penalty vs the paper's "
                        "method): not judged, the run draws only "
                        + ", ".join(f"`{m}`" for m in loads)], {}
    more, verdicts = _penalty_bearing_notes(op, loads, number)
    return lines + more, verdicts


def _penalty_bearing_notes(op: Operator, loads, number: int
                           ) -> tuple[list[str], dict[str, str]]:
    """The paper's Fig. 14/15 text against the penalty simulation, each verdict with its
    criterion (thresholds below), checked on both halves of the run; and the verdicts.
    """
    avg = {q: moving_average(loads["penalty"][q], op.t) for q in loads["penalty"]}

    def radial(ok):  # the larger |log10| of the penalty / paper ratio of median loads
        return max(abs(np.log10(np.nanmedian(avg[q][ok]) / np.nanmedian(loads["paper"][q][ok])))
                   for q in avg if q.endswith("_radial"))

    def axial(ok):  # median |difference| over the median paper-method axial load (>= 1 N)
        return (np.nanmedian(np.abs(avg["axial"][ok] - loads["paper"]["axial"][ok]))
                / max(np.nanmedian(np.abs(loads["paper"]["axial"][ok])), 1.0))

    ok = _settled(op.t)
    lines = [f"- penalty ({SMOOTH_S:g} s average) against the paper method after "
             f"{SETTLED_S:g} s: |log10| of the larger ratio of median radial loads "
             f"{radial(ok):.3f}; median |axial difference| / median paper-method axial load "
             f"{axial(ok):.2f}"]
    if number == 14:
        r, rv = _verdict(radial, ok, lambda x: x <= 0.5, lambda x: x >= 1.0)
        a, av = _verdict(axial, ok, lambda x: x >= 1.0, lambda x: x <= 0.25)
        lines.append(
            "- paper's text: the radial loads agree with ADAMS in order of magnitude, the axial "
            f"load differs greatly. Radial: |log10 ratio| = {rv}; criterion: agrees within "
            "half a decade (<= 0.5, a factor of 3.2), disagrees beyond a decade: "
            f"**{r}**. Axial: relative difference {av}; criterion: \"differs greatly\" = "
            "the difference at least the load itself (>= 1), disagrees at <= 0.25: "
            f"**{a}**. Both methods' loads are members of an unbounded rigid set, so any "
            "difference is a selection, not an error.")
    else:
        r, rv = _verdict(radial, ok, lambda x: x >= np.log10(1.2), lambda x: x <= np.log10(1.05))
        a, av = _verdict(axial, ok, lambda x: x <= 0.2, lambda x: x >= 0.5)
        lines.append(
            "- paper's text: under horizontal gravity the radial loads differ from ADAMS, the "
            f"axial load hardly. Radial: |log10 ratio| = {rv}; criterion: \"differ\" = more "
            "than 20 % apart (>= 0.079), disagrees within 5 % (<= 0.021): "
            f"**{r}**. Axial: relative difference {av}; criterion: \"hardly\" = within 20 % "
            f"of the load, disagrees beyond 50 %: **{a}**.")
    return lines, {"radial": r, "axial": a}


class _Runs:
    """The simulations of one ``cardan repro`` run: each penalty simulation made once per
    scene and reused by every figure that shows it, and a list of what was made, what
    for, and how long it took (for the report).

    With ``workers`` > 0 the penalty simulations (the slow part: seconds per simulated
    second each, one per scene) run in that many worker processes, started at once
    (:meth:`start`), while this process solves the rigid-model methods; with 0 each is
    run here on first use.
    """

    def __init__(self, times: np.ndarray, penalty: bool, progress, workers: int = 0):
        self.times, self.penalty, self.progress = times, penalty, progress
        self.workers = workers
        self.penalties: dict[str, PenaltyResult] = {}
        self.pending: dict[str, Future] = {}
        self.pool: ProcessPoolExecutor | None = None
        self.uses: dict[str, list[str]] = {}
        self.motions: list[tuple[str, int, float, str]] = []
        self.load_s: float | None = None
        self.kernel_s: float | None = None
        self.cpu0 = time.process_time()
        self.children0 = sum(os.times()[2:4])  # CPU of ended worker processes

    def start(self, scenes: list[Scene]) -> None:
        """Start the penalty simulations of ``scenes`` (one per released scene) in the
        worker processes; they ignore SIGINT (the main process handles a Ctrl-C).
        """
        todo = {released(s).name: s for s in scenes} if self.penalty else {}
        if not self.workers or not todo:
            return
        start = time.perf_counter()  # compiled kernels loaded here are inherited by fork
        run_penalty(next(iter(todo.values())), self.times[:2])
        self.kernel_s = time.perf_counter() - start
        context = get_context("fork") if "fork" in get_all_start_methods() else None
        self.pool = ProcessPoolExecutor(max_workers=min(self.workers, len(todo)),
                                        mp_context=context, initializer=signal.signal,
                                        initargs=(signal.SIGINT, signal.SIG_IGN))
        self.progress(f"repro: penalty simulations of {', '.join(todo)} started in "
                      f"{self.pool._max_workers} worker processes ...")
        self.pending = {name: self.pool.submit(run_penalty, s, self.times)
                        for name, s in todo.items()}

    def submit(self, fn, *args) -> Future | None:
        """``fn(*args)`` in a worker process (after the penalty simulations), or ``None``
        when there are no workers (the caller then runs it here).
        """
        return None if self.pool is None else self.pool.submit(fn, *args)

    def close(self, interrupted: bool = False) -> None:
        """End the worker processes: at once when ``interrupted`` (the simulations still
        running are lost), else after they finish.
        """
        if self.pool is None:
            return
        workers = list((self.pool._processes or {}).values())  # no public handle (< 3.14)
        self.pool.shutdown(wait=not interrupted, cancel_futures=interrupted)
        if interrupted:
            for process in workers:
                process.terminate()
                process.join(timeout=5.0)
        self.pool = None

    def motion(self, scene: Scene, purpose: str) -> Motion:
        """The 1-DOF motion of ``scene`` at the run's instants, timed; the first call also
        loads the compiled kernels (once per process), timed apart.
        """
        if self.load_s is None:
            start = time.perf_counter()
            simulate(scene, self.times[:2])
            self.load_s = time.perf_counter() - start
        start = time.perf_counter()
        motion = simulate(scene, self.times)
        self.motions.append((scene.name, len(self.times), time.perf_counter() - start, purpose))
        return motion

    def penalty_costs(self) -> dict[str, str]:
        """Each penalty simulation's cost: wall (and CPU) seconds per simulated second."""
        out = {}
        for name, r in self.penalties.items():
            span = max(r.t[-1] - r.t[0], 1e-12)
            out[name] = f"{r.wall_s / span:.2f} ({r.cpu_s / span:.2f} of CPU)"
        return out

    def penalty_result(self, scene: Scene, purpose: str) -> PenaltyResult | None:
        """The penalty simulation of ``released(scene)``: from its worker, or run here on
        first use; reused after.
        """
        if not self.penalty:
            return None
        name = released(scene).name
        if name not in self.penalties:
            if name in self.pending:
                self.progress(f"repro: waiting for the penalty simulation of {name} ...")
                self.penalties[name] = self.pending.pop(name).result()
            else:
                self.progress(f"repro: penalty simulation of {name} ({purpose}) ...")
                self.penalties[name] = run_penalty(scene, self.times, self.progress)
        self.uses.setdefault(name, []).append(purpose)
        return self.penalties[name]

    def lines(self) -> list[str]:
        """What was simulated, what for, and its cost."""
        out = [f"- the first motion's set-up (once per process; it loads the compiled kernels "
               f"where numba is installed): {1e3 * (self.load_s or 0.0):.0f} ms"]
        if self.kernel_s is not None:
            out.append(f"- the penalty kernels loaded (or compiled) once, before the worker "
                       f"processes start (they inherit them): {self.kernel_s:.1f} s")
        out += [f"- motion of `{name}` ({n} instants, 1-DOF): {1e3 * s:.0f} ms, for {why}"
                for name, n, s, why in self.motions]
        out += [f"- penalty simulation `{name}` (made once, used for "
                f"{', '.join(self.uses[name])}): {r.cost_text()}"
                for name, r in self.penalties.items()]
        if not self.penalty:
            out.append("- penalty simulations: not made (`--no-penalty`: the figures show the "
                       "rigid-model methods alone)")
        elif not self.penalties:
            out.append("- penalty simulations: not made (no figure asked for shows one)")
        return out


def run_repro(scene_name: str = "paper", figs=FIGURES, out: str | Path = "results",
              quick: bool = False, fig15_scenes=FIG15_SCENES,
              progress: Callable[[str], None] = print, methods=ALL_METHODS,
              formats=("png",), workers: int | None = None) -> Path:
    """Write the requested figures (CSV, and an image per format of ``formats``) and
    ``report.md`` into ``out``. ``methods``: what the figures draw (of
    :data:`ALL_METHODS`; ``penalty`` runs the penalty-contact simulation, once per
    scene); ``fig15_scenes``: Fig. 15's scenes, one figure each; ``workers``: processes
    for the penalty simulations (default: the CPUs; 0: in this process, one by one).
    A method or figure that cannot draw the scene is refused before any long work.
    """
    out, started = Path(out), time.perf_counter()
    scene = load_scene(scene_name)
    fig15 = [load_scene(s) for s in fig15_scenes] if 15 in figs else []
    times = scene.time.instants()
    if quick:
        times = times[times <= scene.time.start_s + QUICK_S + 1e-12]
    runs = _Runs(times, PENALTY in methods, progress,
                 (os.cpu_count() or 1) if workers is None else workers)
    rigid = tuple(m for m in methods if m not in (PENALTY, ENGINE))
    progress(f"repro: simulating {scene.name} over {len(times)} instants ...")
    shown = [f"Fig. {f}" for f in figs if f in (11, 12, 13, 14)]
    motion = runs.motion(scene, ", ".join(shown) or "the report")
    op = build_operator(motion)
    check_request(scene, op, methods, figs)
    fig15_ops = [(s, build_operator(runs.motion(s, "Fig. 15"))) for s in fig15]
    for s, o in fig15_ops:
        check_request(s, o, methods, (15,))
    out.mkdir(parents=True, exist_ok=True)
    runs.start(([scene] if shown else []) + fig15)
    try:  # the rigid-model work queued behind the penalty simulations, in the workers
        main_figs = [f for f in figs if f in (13, 14)]
        plan = _compliance_plan(runs, scene) if runs.penalty and shown else None
        jobs = _rigid_jobs(scene, op, main_figs, rigid) + [
            job for s, o in fig15_ops for job in _rigid_jobs(s, o, (15,), rigid)]
        futures = _run_jobs(runs, jobs + (plan[2] if plan else []))
        engine = _engine_work(scene, times, progress) if ENGINE in methods else None
        work = _rigid_result(runs, futures, scene, main_figs, rigid)
        compliance = None if plan is None else (plan[0], {
            job.args[0]: futures[job.key].result() for job in plan[2]}, plan[1])
        sections = _main_figures(runs, scene, motion, op, figs, work, compliance, out,
                                 formats)
        sections += _fig15(runs, [(s, o, _rigid_result(runs, futures, s, (15,), rigid))
                                  for s, o in fig15_ops], out, formats)
        if engine is not None:
            sections.append(_engine_section(engine, runs, out, formats))
    except BaseException:
        runs.close(interrupted=True)
        raise
    runs.close()
    report = _report(scene, motion, sections, quick, [s.name for s in fig15], methods,
                     formats, runs, time.perf_counter() - started)
    written = _written(sections, formats)
    stale = files.stale(out, [*written, out / "report.md"], OUTPUTS)
    path = files.write_text(out / "report.md", report + _stale_lines(stale))
    progress(f"repro: report -> {path} ({time.perf_counter() - started:.1f} s in all)")
    files.say_written("repro", [*written, path], note=f"{len(stale)} file(s) of an earlier "
                      "run left beside them, listed in report.md" if stale else "")
    return path


OUTPUTS = tuple(f"{stem}.{kind}" for stem in ("fig1[1-5]*", "engine")
                for kind in ("csv", "png", "svg", "pdf")) + ("compliance_vs_penalty.csv",)
"""Glob patterns of the files a run writes into its folder (besides ``report.md``)."""


def _written(sections, formats) -> list[Path]:
    """The files of the report's ``sections``: each CSV, and a figure's images."""
    out = []
    for _, csv, _ in sections:
        if csv is not None:
            images = formats if csv.name.startswith(("fig", "engine")) else ()
            out += [csv, *(csv.with_suffix(f".{f}") for f in images)]
    return out


def _stale_lines(stale: list[Path]) -> str:
    """``report.md``'s list of the files in its folder an earlier run left (another
    figure, format or method set): kept, for they may be wanted, but not this report's.
    """
    if not stale:
        return ""
    return "\n".join(["", "## Files of an earlier run", "",
                       "In this folder but not written by this run (another run's figures, "
                       "formats or methods; this report does not cover them):", "",
                       *(f"- `{p.name}`" for p in stale)]) + "\n"


@dataclass(frozen=True)
class _Job:
    """A piece of rigid-model work: ``fn(op, *args)`` on the operator ``op`` (a worker
    process builds its own from ``op.scene`` and the run's instants); ``key`` names it
    (the same key: the same work, done once), ``cost_s`` orders the queue.
    """

    key: tuple
    cost_s: float
    fn: Callable
    op: Operator
    args: tuple


def _rigid_jobs(scene: Scene, op: Operator, figs, rigid) -> list[_Job]:
    """The rigid-model work of Figs. 13-15 on ``scene`` as jobs: each method's history
    and the rigid set's bounds (13: joint 1's contacts; 14: the first shaft's bearings,
    for Figs. 14 and 15); none without such a figure.
    """
    if not figs:
        return []
    jobs = [_Job((scene, m, None), _cost(m), history, op, (m,)) for m in rigid]
    for number in (13, 14):
        if number in figs or (number == 14 and 15 in figs):
            jobs.append(_Job((scene, number), BOUNDS_JOB_COST, _bounds, op, (number,)))
    return jobs


def _cost(method: str) -> float:
    """A method's relative job cost (1 for one the registry does not hold)."""
    return FORMULATIONS[method].job_cost if method in FORMULATIONS else 1.0


def _bounds(op: Operator, number: int) -> dict:
    """The rigid set's bounds of Fig. 13 (joint 1's contacts) or 14-15 (the bearings)."""
    return set_bounds(op, joint_quantities(op) if number == 13 else bearing_quantities(op))


@functools.lru_cache(maxsize=len(FIG15_SCENES) + 2)
def _operator_of(scene: Scene, times: tuple[float, ...]) -> Operator:
    """``scene``'s operator at ``times``, built once per scene in a worker process for
    all its jobs on that scene.
    """
    return build_operator(simulate(scene, np.array(times)))


def _in_worker(fn: Callable, scene: Scene, times: tuple[float, ...], *args):
    """What a worker process runs for a :class:`_Job`: ``fn`` on ``scene``'s operator."""
    return fn(_operator_of(scene, times), *args)


def _run_jobs(runs: _Runs, jobs: list[_Job]) -> dict:
    """``key -> Future`` of each job (one per key): queued for the worker processes
    behind the penalty simulations, longest first, so that the workers end together
    while this process draws; without workers, done here at once.
    """
    unique = {job.key: job for job in reversed(jobs)}  # the first of a key stays
    order = sorted(unique.values(), key=lambda job: -job.cost_s)
    if runs.pool is None:
        order = bar(order, "repro", unit="job")
    instants, out = tuple(float(t) for t in runs.times), {}
    for job in order:
        future = runs.submit(_in_worker, job.fn, job.op.scene, instants, *job.args)
        if future is None:
            future = Future()
            future.set_result(job.fn(job.op, *job.args))
        out[job.key] = future
    return out


def _rigid_result(runs: _Runs, futures: dict, scene: Scene, figs, rigid) -> dict:
    """The rigid-model work of :func:`_rigid_jobs` on ``scene`` as the figures take it:
    ``{"hist": {method: History}, 13: bounds, 14: bounds}`` (what ``figs`` need).
    """
    if not figs:
        return {"hist": {}}
    keys = [(scene, m, None) for m in rigid] + [(scene, n) for n in (13, 14)
                                                 if (scene, n) in futures]
    if not all(futures[k].done() for k in keys):
        runs.progress(f"repro: waiting for the rigid-model work on {scene.name} ...")
    work = {"hist": {m: futures[(scene, m, None)].result() for m in rigid}}
    return work | {k[1]: futures[k].result() for k in keys[len(rigid):]}


def _main_figures(runs: _Runs, scene: Scene, motion: Motion, op: Operator, figs, work,
                  compliance, out: Path, formats) -> list:
    """Figs. 11-14 on the run's scene and the compliance comparison: report sections."""
    shown = [f"Fig. {f}" for f in figs if f in (11, 12, 13, 14)]
    pen = (runs.penalty_result(scene, ", ".join(shown) + " and the compliance comparison")
           if shown else None)
    pen_omega = None if pen is None else pen.omega
    sections = []
    if 11 in figs:
        csv = figures.fig11(motion, out, pen_omega, formats)
        diff = np.max(np.abs(motion.omega[-1] - motion.omega[0]))
        sections.append(("Fig. 11: input and output angular velocity", csv, [
            f"- the output turns with the input: max |omega_out - omega_in| = {diff:.1e} rad/s "
            "(paper: uniform output in the Z arrangement with equal angles, eq. 4)",
            f"- input speed at t = {motion.t[-1]:g} s: {motion.omega[0][-1]:.3f} rad/s",
            *_speed_notes(motion, pen, (0, -1))]))
    if 12 in figs:
        csv = figures.fig12(motion, out, pen_omega, formats)
        ratio = motion.omega[1][1:] / motion.omega[0][1:]
        g1 = scene.joints[0].articulation_deg
        sections.append(("Fig. 12: intermediate shaft angular velocity", csv, [
            f"- omega_intermediate / omega_input oscillates in [{ratio.min():.4f}, "
            f"{ratio.max():.4f}] (eq. 3: [cos g1, 1/cos g1] = "
            f"[{np.cos(np.radians(g1)):.4f}, {1 / np.cos(np.radians(g1)):.4f}] for "
            f"g1 = {g1:g} deg)",
            *_speed_notes(motion, pen, (1,))]))
    if any(f in figs for f in (13, 14)):
        sections += _contact_figures(op, figs, work, out, formats,
                                     None if pen is None else penalty_history(pen, op.names))
    if pen is not None:
        sections.append(_compliance_vs_penalty(compliance, pen, out))
    return sections


def _speed_notes(motion: Motion, pen, shafts) -> list[str]:
    """The paper: the clearances hardly affect the velocities. "Hardly" is measured
    against the one speed effect the figures are about, the intermediate shaft's
    fluctuation (eq. 3, half its peak-to-peak ratio to the input): agrees where the
    median relative difference stays below a tenth of it, disagrees above half of it.
    """
    if pen is None:
        return []
    result = pen
    ok = _settled(motion.t)
    lines = []
    for k in shafts:
        rigid, released_ = motion.omega[k][ok], result.omega[k][ok]
        rel = np.nanmedian(np.abs(released_ - rigid) / np.maximum(np.abs(rigid), 1e-9))
        lines.append(f"- penalty simulation, {motion.scene.shafts[k].name} shaft: median "
                     f"|omega_penalty - omega_rigid| / omega_rigid = {100 * rel:.2f} % after "
                     f"{SETTLED_S:g} s; at t = {motion.t[-1]:g} s {result.omega[k][-1]:.3f} "
                     f"vs {motion.omega[k][-1]:.3f} rad/s")
    turn = kinematics(motion.geometry, np.linspace(0.0, 2.0 * np.pi, 721))
    swing = max(0.5 * float(np.ptp(turn.ratio[1])) if len(turn.ratio) > 1 else 0.0, 1e-3)

    def worst(mask):
        return max(np.nanmedian(np.abs(result.omega[k][mask] - motion.omega[k][mask])
                                / np.maximum(np.abs(motion.omega[k][mask]), 1e-9))
                   for k in shafts)

    verdict, values = _verdict(worst, ok, lambda x: x <= 0.1 * swing, lambda x: x >= 0.5 * swing)
    lines.append(f"- paper's text: the clearances hardly affect the velocities. Largest median "
                 f"relative difference: {values}; criterion: agrees below a tenth of the "
                 f"intermediate shaft's own fluctuation (eq. 3: +-{100 * swing:.1f} %, so "
                 f"{10 * swing:.2f} %), disagrees above half of it ({50 * swing:.1f} %): "
                 f"**{verdict}**.")
    return lines


def _contact_figures(op: Operator, figs, work, out: Path, formats, penalty) -> list:
    hist = dict(work["hist"]) | ({} if penalty is None else {PENALTY: penalty})
    forces = {m: h.forces for m, h in hist.items()}
    sections = []
    if 13 in figs:
        csv = figures.fig13(op, forces, work[13], out, formats)
        sections.append(("Fig. 13: contact forces of joint 1", csv,
                         _fig13_notes(op, hist) + _status_lines(hist)))
    if 14 in figs:
        bounds = work[14]
        csv = figures.fig14(op, forces, bounds, out, formats=formats)
        sections.append(("Fig. 14: input shaft bearing loads", csv,
                         _bearing_notes(op, hist, bounds, 14)[0]))
    return sections


def _gravity(scene: Scene) -> str:
    return "gravity (" + ", ".join(f"{g:g}" for g in scene.gravity_m_s2) + ") m/s^2"


def _fig15(runs: _Runs, scenes_work, out: Path, formats) -> list:
    """Fig. 15 on each of its scenes (a figure ``fig15_<scene>`` each), and a section
    saying which of them matches the paper's text (both verdicts ``agrees``).
    ``scenes_work``: ``(scene, operator, its rigid-model work)`` (:func:`_rigid_result`).
    """
    sections, verdicts = [], []
    for scene, op, work in scenes_work:
        pen = runs.penalty_result(scene, f"Fig. 15 ({scene.name})")
        hist = dict(work["hist"]) | ({} if pen is None else
                                     {PENALTY: penalty_history(pen, op.names)})
        bounds = work[14]
        csv = figures.fig14(op, {m: h.forces for m, h in hist.items()}, bounds, out,
                            number=15, stem=f"fig15_{scene.name}",
                            subtitle=f", {_gravity(scene)}", formats=formats)
        notes, verdict = _bearing_notes(op, hist, bounds, 15)
        sections.append((f"Fig. 15 on `{scene.name}`: input shaft bearing loads, "
                         f"{_gravity(scene)}", csv, notes))
        verdicts.append((scene, verdict))
    if len(verdicts) > 1 or any(v for _, v in verdicts):
        sections.append(_fig15_summary(verdicts))
    return sections


def _fig15_summary(verdicts: list[tuple[Scene, dict[str, str]]]):
    """Which Fig. 15 scene matches the paper's text: both of its verdicts ``agrees``."""
    lines = ["The paper says only that gravity is horizontal in Fig. 15. Its text: the "
             "radial loads differ from ADAMS, the axial load hardly (criteria in each "
             "figure's section)."]
    for scene, v in verdicts:
        said = (f"radial **{v['radial']}**, axial **{v['axial']}**" if v else
                "not judged (needs the paper's method and the penalty simulation)")
        lines.append(f"- `{scene.name}` ({scene.description}; {_gravity(scene)}): {said}")
    match = [f"`{s.name}`" for s, v in verdicts if v and set(v.values()) == {"agrees"}]
    lines.append("- matches the paper's text (both verdicts agree): "
                 + (", ".join(match) if match else "none of the scenes drawn"))
    return ("Fig. 15: which horizontal gravity matches the paper's text", None, lines)


def _compliance_plan(runs: _Runs, scene: Scene):
    """The methods of :data:`COMPLIANCE_VS_PENALTY` on the released scene's rigid
    operator (those that do not apply left out, with why): the operator, the
    refusals, and the histories of those that apply as jobs (``args``: method,
    backend).
    """
    runs.progress("repro: compliance vs penalty ...")
    op = build_operator(runs.motion(released(scene), "the compliance comparison"))
    jobs, skipped = [], []
    for method in COMPLIANCE_VS_PENALTY:
        why = _refusal(op.scene, op, method)  # builds the method's first problem
        if why:
            skipped.append(f"`{method}` ({why})")
        else:
            jobs.append(_Job((op.scene, method, None), _cost(method), history, op, (method,)))
    return op, skipped, jobs


def _compliance_vs_penalty(compliance, result, out: Path):
    """The compliance formulations (and two rigid selections for contrast) on the released
    scene's rigid operator vs the penalty simulation: relative distance per contact group
    and instant, raw and both smoothed over ``SMOOTH_S``; cost of each.
    """
    op, hist, skipped = compliance
    bearings = np.zeros(len(op.names), bool)
    bearings[[c for link in op.bearings() for c in link.columns]] = True
    groups = {"bearings": bearings, "joints": ~bearings}
    pen = np.column_stack([result.forces[n] for n in op.names])
    ok = _settled(op.t) & np.all(np.isfinite(pen), axis=1)
    rows = []
    for method, h in hist.items():
        row = {"method": method, "solver": h.solver, "solved": f"{h.solved}/{len(h.statuses)}",
               "seconds": h.seconds}
        for g, cols in groups.items():
            for label, a, b in (("raw", h.forces, pen),
                                ("smoothed", moving_average(h.forces, op.t),
                                 moving_average(pen, op.t))):
                dist = np.linalg.norm(a[:, cols] - b[:, cols], axis=1) / \
                    np.maximum(np.linalg.norm(b[:, cols], axis=1), 1e-9)
                row[f"{g}_{label}"] = float(np.nanmedian(dist[ok])) if ok.any() else np.nan
        rows.append(row)
    path = out / "compliance_vs_penalty.csv"
    keys = list(rows[0])
    files.write_text(path, ",".join(keys) + "\n" + "".join(
        ",".join(f"{r[k]:.6g}" if isinstance(r[k], float) else str(r[k]) for k in keys) + "\n"
        for r in rows))
    lines = [f"Median over the instants after {SETTLED_S:g} s of ||x_method - x_penalty|| / "
             f"||x_penalty|| per group (raw; and both smoothed over {SMOOTH_S:g} s), on "
             f"`{op.scene.name}` (clearances as gaps for `compliance*`). Penalty: "
             f"{result.wall_s:.1f} s wall for {op.t[-1] - op.t[0]:g} s simulated "
             f"({result.nsteps} steps, {result.method}, status: {result.message}).", "",
             "| method | backend | solved | bearings raw | bearings smoothed | joints raw | "
             "joints smoothed | solver time s | penalty time / this |", "|---" * 9 + "|"]
    for r in rows:
        lines.append(f"| `{r['method']}` | {r['solver']} | {r['solved']} | "
                     f"{r['bearings_raw']:.3f} | {r['bearings_smoothed']:.3f} | "
                     f"{r['joints_raw']:.3f} | {r['joints_smoothed']:.3f} | "
                     f"{r['seconds']:.3f} | {result.wall_s / max(r['seconds'], 1e-9):.0f} |")
    score = {r["method"]: r["bearings_smoothed"] + r["joints_smoothed"] for r in rows}
    best = min(score.values())
    closest = [f"`{m}`" for m, v in score.items() if v <= best + 1e-3]
    lines += ["", f"- closest to the penalty simulation (smoothed, bearings + joints, ties "
              f"within 1e-3): {', '.join(closest)}; a distance of 0 would mean the convex "
              "program picks the very member of the rigid solution set that the compliant, "
              "clearance-bearing line picks. What remains is the released line's own choice "
              "(its rattle, the cross-pins' play, the bearings' axial split under impacts), "
              "not a failure of either."]
    if skipped:
        lines.append(f"- left out, they do not apply to `{op.scene.name}`: {'; '.join(skipped)}")
    return ("Compliance vs penalty", path, lines)


def _status_lines(hist: dict[str, History]) -> list[str]:
    return [f"- `{m}` ({h.solver}): {h.solved}/{len(h.statuses)} instants solved, "
            f"{h.seconds:.2f} s of {'wall' if m == 'penalty' else 'solver'} time"
            for m, h in hist.items()]


def _report(scene: Scene, motion: Motion, sections, quick: bool, fig15: list[str], methods,
            formats, runs: _Runs, seconds: float) -> str:
    penalty_s = list(runs.penalty_costs().values())
    children = sum(os.times()[2:4]) - runs.children0
    cpu = time.process_time() - runs.cpu0 + children
    lines = [
        "# cardan repro: the paper's Figs. 11-15",
        "",
        f"- date: {datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d %H:%M} UTC",
        f"- machine: {machine()}",
        f"- versions: {versions()}",
        f"- scene: `{scene.name}` ({scene.description}); Fig. 15: "
        + (", ".join(f"`{s}`" for s in fig15) or "not drawn"),
        f"- instants: {len(motion.t)} from {motion.t[0]:g} to {motion.t[-1]:g} s"
        + (" (quick run)" if quick else ""),
        "- methods (formulations; each figure's notes name the backend that drew it): "
        + ", ".join(f"`{m}`" for m in methods if m not in (PENALTY, ENGINE))
        + (", `penalty`: the released scene's penalty-contact simulation"
           if runs.penalties else "")
        + (", `engine`: MuJoCo's forward simulation (its own section)"
           if ENGINE in methods else ""),
        f"- **timings** (measured by this run): total wall {seconds:.1f} s (target <= 120 s "
        "for all figures with the penalty simulation); motion "
        + ", ".join(f"{1e3 * s:.0f} ms" for _, _, s, _ in runs.motions)
        + " (target <= 50 ms for 1001 instants); penalty simulation "
        + (", ".join(penalty_s)
           + f" s per simulated second (target <= {PENALTY_TARGET_S:g})" if penalty_s
           else "not run")
        + f"; CPU time of the whole run {cpu:.1f} s ({children:.1f} s of it in the "
        "penalty simulations' worker processes)",
        "",
        "## Runs",
        "",
        *runs.lines(),
        "",
        "Each figure's CSV holds one column per quantity and method; the PNG is drawn from "
        "it. An instant whose record is not `solved` is an empty cell in the CSV, as is a "
        "rigid-set bound not computed there; `inf` (`-inf`) in a `*_set_max` (`*_set_min`) "
        "column means that side of the rigid set is open (unbounded). Every verdict on the "
        "paper's text states its criterion; a verdict that the two halves of the run do not "
        "both give is **undecided**.",
    ]
    for title, csv, notes in sections:
        lines += ["", f"## {title}", ""]
        if csv is not None:
            images = formats if csv.name.startswith(("fig", "engine")) else ()
            lines += [", ".join(f"`{csv.with_suffix(s).name}`"
                                for s in (".csv", *(f".{f}" for f in images))), ""]
        lines += notes
    return "\n".join(lines) + "\n"


def _engine_work(scene: Scene, times: np.ndarray, progress) -> dict:
    """MuJoCo on the run's first :data:`ENGINE_S` under the softness settings its figure
    draws: the study (every component against its interval and the formulations at
    :data:`ENGINE_INSTANTS` instants), the figure's rigid band, and the wall time of it.
    """
    settings = [s for s in SETTINGS if s.label in FIGURE_SETTINGS]
    window = times[times <= times[0] + ENGINE_S + 1e-12]
    progress(f"repro: MuJoCo on the first {window[-1] - window[0]:g} s, {len(settings)} "
             "softness settings ...")
    start = time.perf_counter()
    op = build_operator(simulate(scene, window))
    runs = engine_runs(op, settings)
    settled = np.flatnonzero(op.t >= op.t[0] + settle_s(runs))
    picks = np.linspace(0, len(settled) - 1, min(ENGINE_INSTANTS, len(settled)))
    result = compare(op, runs, settled[picks.round().astype(int)])
    bounds = set_bounds(op, bearing_quantities(op), ENGINE_BOUND_INSTANTS)
    return {"result": result, "bounds": bounds, "wall_s": time.perf_counter() - start,
            "version": engine_mujoco.mujoco_version()}


def _engine_section(work: dict, runs: _Runs, out: Path, formats):
    """The report's MuJoCo section and its figure: what the engine says about the input
    shaft's bearing loads, where that lies in the rigid set, how far softness settings
    move it, and what it cost beside the penalty simulation.
    """
    result, bounds = work["result"], work["bounds"]
    op, runs_e = result.op, result.runs
    csv = figures.engine_figure(op, {k: r.forces for k, r in runs_e.items()}, bounds, out,
                                formats)
    settle = settle_s(runs_e)
    lines = [
        f"MuJoCo {work['version']}, forward simulation of `{op.scene.name}` from its start "
        f"over {op.t[-1] - op.t[0]:g} s ({len(op.t)} instants), every bearing a soft "
        "`connect` equality, under the softness settings drawn (`solref`/`solimp`; the "
        "relative softness of the input and output shafts' bearings). A MuJoCo user reads "
        "the `default` curve. Statistics after the engine's settling "
        f"({settle:g} s; {len(result.sampled)} instants for the table); a load is inside "
        f"the rigid band within {ENGINE_RTOL:g} of the largest load. `cardan engine` "
        "runs the full study (more settings, more instants).",
        *_engine_load_lines(op, result, bounds, settle), "",
        "Every component against its rigid interval and the formulations:", "",
        *agreement_lines(result)[2:], "",
        *_engine_cost_lines(work, runs)]
    return ("MuJoCo beside the rigid set: input shaft bearing loads", csv, lines)


def _engine_load_lines(op: Operator, result, bounds, settle: float) -> list[str]:
    """Per bearing load of the figure: what MuJoCo reads, inside the band or not, and
    how far the settings move it against the band's width.
    """
    ok = op.t >= op.t[0] + settle
    loads = {k: figures.bearing_loads(op, r.forces) for k, r in result.runs.items()}
    first = next(iter(loads))
    lines = []
    for q, (lo, hi) in bounds.items():
        values = np.array([loads[k][q] for k in loads])
        slack = ENGINE_RTOL * max(np.nanmax(np.abs(values)), 1.0)
        checked = ok & ~np.isnan(lo)
        inside = np.all((values[:, checked] >= lo[checked] - slack)
                        & (values[:, checked] <= hi[checked] + slack), axis=0)
        width = float(np.median(hi[checked] - lo[checked])) if checked.any() else np.nan
        moved = float(np.max(np.ptp(values[:, ok], axis=0))) if ok.any() else np.nan
        share = (f" ({100 * moved / width:.0f} % of the band's median width "
                 f"{width:.1f} N)" if np.isfinite(width) and width > slack else
                 " (the band is unbounded)" if not np.isfinite(width) else
                 " (the band is one value: the load is determinate)")
        lines.append(
            f"- {q}: MuJoCo (`{first}`) reads {np.nanmin(loads[first][q][ok]):.1f} to "
            f"{np.nanmax(loads[first][q][ok]):.1f} N; every setting inside the rigid band at "
            f"{inside.sum()} of {checked.sum()} instants checked; the settings move it by "
            f"up to {moved:.1f} N{share}")
    moves = softness_spread(result)
    det = result.determinate
    lines.append(f"- all components: the settings move the determinate ones by up to "
                 f"{number_text(np.nanmax(moves[det], initial=0.0), '.3g')}, the "
                 f"indeterminate ones by up to "
                 f"{number_text(np.nanmax(moves[~det], initial=0.0), '.3g')} (N, N m): "
                 "the engine's softness, not the machine, picks the member of the set")
    return lines


def _engine_cost_lines(work: dict, runs: _Runs) -> list[str]:
    """MuJoCo's cost per simulated second beside the penalty simulation's (same run)."""
    runs_e = work["result"].runs
    span = max(work["result"].op.t[-1] - work["result"].op.t[0], 1e-12)
    per = ", ".join(f"`{k}` {r.wall_s / span:.2f}" for k, r in runs_e.items())
    pen = runs.penalty_costs()
    beside = ("; the penalty simulation " + ", ".join(f"`{n}` {c}" for n, c in pen.items())
              + " s per simulated second (in worker processes, at the same time)"
              if pen else "; no penalty simulation in this run")
    return [f"- cost (this run): MuJoCo {per} s of wall time per simulated second "
            f"({next(iter(runs_e.values())).steps / span:.0f} RK4 steps per second){beside}; "
            f"MuJoCo's whole part of this report, the rigid comparisons included, "
            f"{work['wall_s']:.1f} s"]
