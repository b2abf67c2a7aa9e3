"""``cardan repro``: the paper's Figs. 11-15 and a report, on the embedded scenes.

Figs. 11-12 come from the motion; 13-15 from contact-force histories of the paper's
method and the convex formulations (:mod:`cardan_forces.paper_repro.histories`), with the rigid
solution set's interval shaded where a bearing load is not unique. Every figure also
carries the penalty-contact simulation of the same scene with its joints released
(the paper's ADAMS model, :mod:`cardan_forces.driveline.penalty`), and the report compares it with
the ``compliance`` formulations on the same stiffness and clearances. The report
states versions, machine, settings, and per figure what the numbers say next to the
paper's text.
"""

from __future__ import annotations

import datetime
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
from cardan_forces.driveline.determinacy import determinacy
from cardan_forces.driveline.dynamics import Motion, simulate
from cardan_forces.driveline.equilibrium import Operator, build_operator
from cardan_forces.driveline.kinematics import kinematics
from cardan_forces.driveline.loading import load_scene
from cardan_forces.driveline.penalty import PenaltyResult
from cardan_forces.driveline.scene import Scene
from cardan_forces.experiments.environment import machine, versions
from cardan_forces.experiments.study import value_range
from scipy.stats import binomtest

from . import figures
from .figures import SMOOTH_S, moving_average
from .histories import METHODS, History, history, penalty_history, released, run_penalty

FIGURES = (11, 12, 13, 14, 15)
BOUND_INSTANTS = 41
"""Instants (evenly spread) at which Figs. 14-15's solution-set intervals are computed."""
QUICK_S = 0.15
"""Window of ``--quick`` (s from the start)."""
SETTLED_S = 0.1
"""Penalty comparisons start here: from rest the input shaft first turns through the
joints' play (~0.07 s on ``paper-penalty``), a transient the rigid model has not."""
SIGNIFICANCE = 0.05
"""Two-sided level of the sign test behind "larger" / "smaller" verdicts."""
COMPLIANCE_VS_PENALTY = {"compliance": "clarabel", "compliance_hertz": "clarabel",
                         "positive": "qpsolvers-daqp", "min_norm": "numpy-kkt"}
"""Methods compared with the penalty simulation, on the released scene's operator (the
same effects, so the compliance formulations see the same clearances as gaps)."""


def bearing_bounds(op: Operator, shaft: int = 0) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Intervals of Fig. 14's loads (:func:`figures.bearing_loads`) over the rigid set at
    ``BOUND_INSTANTS`` instants (NaN elsewhere), in the shaft's frame. Axial: the exact
    range of the sum of the bearings' axial loads. Radial: the range of the radial
    length allowed by the in-plane and normal component intervals (their box hull).
    """
    T = len(op.t)
    picks = np.unique(np.linspace(0, T - 1, min(BOUND_INSTANTS, T)).round().astype(int))
    rows = {c.label: op.bearing_matrix(c) for c in op.bearings(shaft)}
    out = {q: (np.full(T, np.nan), np.full(T, np.nan))
           for q in [f"{label}_radial" for label in rows] + ["axial"]}

    def span(i, c):  # None: unbounded on that side; a failed LP is not computed (NaN)
        r = value_range(op, i, c)
        if r["status"] != "solved":
            return np.nan, np.nan
        return (-np.inf if r["min"] is None else r["min"],
                np.inf if r["max"] is None else r["max"])

    for i in picks:
        out["axial"][0][i], out["axial"][1][i] = span(i, sum(m[2] for m in rows.values()))
        for label, matrix in rows.items():
            ranges = [span(i, matrix[a]) for a in (0, 1)]
            closest = [0.0 if lo <= 0.0 <= hi else min(abs(lo), abs(hi)) for lo, hi in ranges]
            farthest = [max(abs(lo), abs(hi)) for lo, hi in ranges]
            out[f"{label}_radial"][0][i] = np.hypot(*closest)
            out[f"{label}_radial"][1][i] = np.hypot(*farthest)
    return out


def _histories(op: Operator, progress, penalty: History | None) -> dict[str, History]:
    hist = {m: history(op, m, progress=progress) for m in METHODS}
    if penalty is not None:
        hist["penalty"] = penalty
    return hist


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
    return verdict, f"{whole:.3g} (first half {parts[0]:.3g}, second half {parts[1]:.3g})"


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
    rigid = [m for m in mags if m != "penalty"]
    for label in mags["positive"]:
        spread = np.nanmax([np.nanmax(np.abs(mags[m][label] - mags["positive"][label]))
                            for m in rigid])
        peak = np.nanmax([np.nanmax(mags[m][label]) for m in rigid])
        lines.append(f"- |{label}|: peak {peak:.1f} N over the rigid methods; largest "
                     f"difference from `positive`: {spread:.1f} N")
    if "penalty" in mags:
        lines += _frequency_note(op, mags) + _larger_note(op, mags)
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


def _bearing_notes(op: Operator, hist: dict[str, History], bounds, number: int) -> list[str]:
    lines = []
    loads = {m: figures.bearing_loads(op, h.forces) for m, h in hist.items()}
    for q in ("far_radial", "near_radial", "axial"):
        lo, hi = bounds[q]
        ok = ~np.isnan(lo)
        unbounded = np.mean(np.isinf(hi[ok]) | np.isinf(lo[ok]))
        spread = np.nanmax([np.nanmax(np.abs(loads[m][q] - loads["positive"][q]))
                            for m in loads if m != "penalty"])
        lines.append(f"- {q}: the rigid set is unbounded at {100 * unbounded:.0f} % of the "
                     f"instants checked; the rigid methods differ by up to {spread:.1f} N")
    if "penalty" not in loads:
        return lines
    return lines + _penalty_bearing_notes(op, loads, number)


def _penalty_bearing_notes(op: Operator, loads, number: int) -> list[str]:
    """The paper's Fig. 14/15 text against the penalty simulation, each verdict with its
    criterion (thresholds below), checked on both halves of the run.
    """
    avg = {q: moving_average(loads["penalty"][q], op.t) for q in loads["penalty"]}

    def radial(ok):  # the larger |log10| of the penalty / paper ratio of median loads
        return max(abs(np.log10(np.nanmedian(avg[q][ok]) / np.nanmedian(loads["paper"][q][ok])))
                   for q in ("far_radial", "near_radial"))

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
    return lines


class _Runs:
    """The simulations of one ``cardan repro`` run: each penalty simulation made once per
    scene and reused by every figure that shows it, and a list of what was made, what
    for, and how long it took (for the report).
    """

    def __init__(self, times: np.ndarray, penalty: bool, progress):
        self.times, self.penalty, self.progress = times, penalty, progress
        self.penalties: dict[str, PenaltyResult] = {}
        self.uses: dict[str, list[str]] = {}
        self.motions: list[tuple[str, int, float, str]] = []
        self.load_s: float | None = None
        self.cpu0 = time.process_time()

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

    def penalty_result(self, scene: Scene, purpose: str) -> PenaltyResult | None:
        """The penalty simulation of ``released(scene)``: run on first use, reused after."""
        if not self.penalty:
            return None
        name = released(scene).name
        if name not in self.penalties:
            self.progress(f"repro: penalty simulation of {name} ({purpose}) ...")
            self.penalties[name] = run_penalty(scene, self.times, self.progress)
        self.uses.setdefault(name, []).append(purpose)
        return self.penalties[name]

    def lines(self) -> list[str]:
        """What was simulated, what for, and its cost."""
        out = [f"- the first motion's set-up (once per process; it loads the compiled kernels "
               f"where numba is installed): {1e3 * (self.load_s or 0.0):.0f} ms"]
        out += [f"- motion of `{name}` ({n} instants, 1-DOF): {1e3 * s:.0f} ms, for {why}"
                for name, n, s, why in self.motions]
        for name, r in self.penalties.items():
            span = max(r.t[-1] - r.t[0], 1e-12)
            steps = max(r.nsteps, 1)
            rest = max(r.wall_s - r.rhs_s - r.jacobian_s, 0.0)
            out.append(
                f"- penalty simulation `{name}` (made once, used for "
                f"{', '.join(self.uses[name])}): {r.wall_s:.1f} s wall ({r.cpu_s:.1f} s of "
                f"CPU) for {span:g} s simulated = **{r.wall_s / span:.2f} s per simulated "
                f"second** ({r.cpu_s / span:.2f} of CPU; target <= 2), "
                f"{r.method}, {r.kernel} kernels; {r.nsteps / span:.0f} steps per simulated "
                f"second (mean step {1e6 * span / steps:.1f} us, set by the impacts in the "
                f"clearances), {1e6 * r.wall_s / steps:.1f} us per step: right-hand sides "
                f"{1e6 * r.rhs_s / steps:.1f} us ({r.nfev / steps:.2f} per step), Jacobians "
                f"{1e6 * r.jacobian_s / steps:.1f} us ({r.njev / steps:.2f} per step), the "
                f"integrator's own work and LU factorizations ({r.nlu} in all) and the set-up "
                f"{1e6 * rest / steps:.1f} us; {r.message}")
        if not self.penalty:
            out.append("- penalty simulations: not made (`--no-penalty`: the figures show the "
                       "rigid-model methods alone)")
        elif not self.penalties:
            out.append("- penalty simulations: not made (no figure asked for shows one)")
        return out


def run_repro(scene_name: str = "paper", figs=FIGURES, out: str | Path = "results",
              quick: bool = False, fig15_scene: str = "paper-fig15",
              progress: Callable[[str], None] = print, penalty: bool = True) -> Path:
    """Write the requested figures (CSV + PNG) and ``report.md`` into ``out``;
    ``penalty``: also run the penalty-contact simulation (once per scene) and overlay it.
    """
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    started = time.perf_counter()
    scene = load_scene(scene_name)
    times = scene.time.instants()
    if quick:
        times = times[times <= scene.time.start_s + QUICK_S + 1e-12]
    runs = _Runs(times, penalty, progress)
    progress(f"repro: simulating {scene.name} over {len(times)} instants ...")
    shown = [f"Fig. {f}" for f in figs if f in (11, 12, 13, 14)]
    motion = runs.motion(scene, ", ".join(shown) or "the report")
    op = build_operator(motion)
    sections = []
    pen = (runs.penalty_result(scene, ", ".join(shown) + " and the compliance comparison")
           if shown else None)
    if 11 in figs:
        csv = figures.fig11(motion, out, None if pen is None else pen.omega)
        diff = np.max(np.abs(motion.omega[-1] - motion.omega[0]))
        sections.append(("Fig. 11: input and output angular velocity", csv, [
            f"- the output turns with the input: max |omega_out - omega_in| = {diff:.1e} rad/s "
            "(paper: uniform output in the Z arrangement with equal angles, eq. 4)",
            f"- input speed at t = {motion.t[-1]:g} s: {motion.omega[0][-1]:.3f} rad/s",
            *_speed_notes(motion, pen, (0, -1))]))
    if 12 in figs:
        csv = figures.fig12(motion, out, None if pen is None else pen.omega)
        ratio = motion.omega[1][1:] / motion.omega[0][1:]
        g1 = scene.joints[0].articulation_deg
        sections.append(("Fig. 12: intermediate shaft angular velocity", csv, [
            f"- omega_intermediate / omega_input oscillates in [{ratio.min():.4f}, "
            f"{ratio.max():.4f}] (eq. 3: [cos g1, 1/cos g1] = "
            f"[{np.cos(np.radians(g1)):.4f}, {1 / np.cos(np.radians(g1)):.4f}] for "
            f"g1 = {g1:g} deg)",
            *_speed_notes(motion, pen, (1,))]))
    if any(f in figs for f in (13, 14)):
        sections += _contact_figures(op, figs, out, progress,
                                     None if pen is None else penalty_history(pen, op.names))
    if pen is not None:
        sections.append(_compliance_vs_penalty(runs, scene, pen, out, progress))
    if 15 in figs:
        sections += _fig15(runs, load_scene(fig15_scene), out, progress)
    report = _report(scene, motion, sections, quick, fig15_scene, runs,
                     time.perf_counter() - started)
    path = out / "report.md"
    path.write_text(report)
    progress(f"repro: report -> {path} ({time.perf_counter() - started:.1f} s in all)")
    return path


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


def _contact_figures(op: Operator, figs, out: Path, progress, penalty) -> list:
    hist = _histories(op, progress, penalty)
    forces = {m: h.forces for m, h in hist.items()}
    sections = []
    if 13 in figs:
        csv = figures.fig13(op, forces, out)
        sections.append(("Fig. 13: contact forces of joint 1", csv,
                         _fig13_notes(op, hist) + _status_lines(hist)))
    if 14 in figs:
        progress("repro: fig 14 solution-set intervals ...")
        bounds = bearing_bounds(op)
        csv = figures.fig14(op, forces, bounds, out)
        sections.append(("Fig. 14: input shaft bearing loads", csv,
                         _bearing_notes(op, hist, bounds, 14)))
    return sections


def _fig15(runs: _Runs, scene: Scene, out: Path, progress):
    progress(f"repro: fig 15 on {scene.name} ...")
    op = build_operator(runs.motion(scene, "Fig. 15"))
    pen = runs.penalty_result(scene, "Fig. 15")
    hist = _histories(op, progress, None if pen is None else penalty_history(pen, op.names))
    bounds = bearing_bounds(op)
    csv = figures.fig14(op, {m: h.forces for m, h in hist.items()}, bounds, out, number=15)
    return [(f"Fig. 15: input shaft bearing loads, gravity {scene.gravity_m_s2} m/s^2", csv,
             _bearing_notes(op, hist, bounds, 15))]


def _compliance_vs_penalty(runs: _Runs, scene: Scene, result, out: Path, progress):
    """The compliance formulations (and two rigid selections for contrast) on the released
    scene's rigid operator vs the penalty simulation: relative distance per contact group
    and instant, raw and both smoothed over ``SMOOTH_S``; cost of each.
    """
    progress("repro: compliance vs penalty ...")
    op = build_operator(runs.motion(released(scene), "the compliance comparison"))
    bearings = np.zeros(len(op.names), bool)
    bearings[[c for link in op.bearings() for c in link.columns]] = True
    groups = {"bearings": bearings, "joints": ~bearings}
    pen = np.column_stack([result.forces[n] for n in op.names])
    ok = _settled(op.t) & np.all(np.isfinite(pen), axis=1)
    rows = []
    for method, solver in COMPLIANCE_VS_PENALTY.items():
        h = history(op, method, solver)
        row = {"method": method, "solver": solver, "solved": f"{h.solved}/{len(h.statuses)}",
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
    path.write_text(",".join(keys) + "\n" + "".join(
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
    return ("Compliance vs penalty", path, lines)


def _status_lines(hist: dict[str, History]) -> list[str]:
    return [f"- `{m}` ({h.solver}): {h.solved}/{len(h.statuses)} instants solved, "
            f"{h.seconds:.2f} s of {'wall' if m == 'penalty' else 'solver'} time"
            for m, h in hist.items()]


def _report(scene: Scene, motion: Motion, sections, quick: bool, fig15_scene: str,
            runs: _Runs, seconds: float) -> str:
    penalty_s = [(r.wall_s / max(r.t[-1] - r.t[0], 1e-12), r.cpu_s / max(r.t[-1] - r.t[0], 1e-12))
                 for r in runs.penalties.values()]
    lines = [
        "# cardan repro: the paper's Figs. 11-15",
        "",
        f"- date: {datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d %H:%M} UTC",
        f"- machine: {machine()}",
        f"- versions: {versions()}",
        f"- scene: `{scene.name}` ({scene.description}); Fig. 15: `{fig15_scene}`",
        f"- instants: {len(motion.t)} from {motion.t[0]:g} to {motion.t[-1]:g} s"
        + (" (quick run)" if quick else ""),
        "- methods (formulations; each figure's notes name the backend that drew it): "
        + ", ".join(f"`{m}`" for m in METHODS)
        + (", `penalty`: the released scene's penalty-contact simulation"
           if runs.penalties else ""),
        f"- **timings** (measured by this run): total wall {seconds:.1f} s (target <= 120 s "
        "for all figures with the penalty simulation); motion "
        + ", ".join(f"{1e3 * s:.0f} ms" for _, _, s, _ in runs.motions)
        + " (target <= 50 ms for 1001 instants); penalty simulation "
        + (", ".join(f"{w:.2f} ({c:.2f} of CPU)" for w, c in penalty_s)
           + " s per simulated second (target <= 2)" if penalty_s else "not run")
        + f"; CPU time of the whole run {time.process_time() - runs.cpu0:.1f} s",
        "",
        "## Runs",
        "",
        *runs.lines(),
        "",
        "Each figure's CSV holds one column per quantity and method; the PNG is drawn from "
        "it. An instant whose record is not `solved` is NaN in the CSV. Every verdict on the "
        "paper's text states its criterion; a verdict that the two halves of the run do not "
        "both give is **undecided**.",
    ]
    for title, csv, notes in sections:
        files = f"`{csv.name}`" + (f", `{csv.with_suffix('.png').name}`"
                                   if csv.name.startswith("fig") else "")
        lines += ["", f"## {title}", "", files, ""]
        lines += notes
    return "\n".join(lines) + "\n"
