"""The report's verdicts on the paper's text about Figs. 11-15, with their statistics.

Each statement of the paper (the clearances hardly affect the velocities; the ADAMS
forces vary at a higher frequency and are slightly smaller than its method's; the radial
bearing loads agree in order of magnitude and the axial one differs greatly; under
horizontal gravity the other way round) is judged against the penalty simulation by a
stated criterion on the settled instants, and again on each half of the run
(:func:`_verdict`); "larger" by a sign test over blocks of the smoothing window
(:func:`_sign_test`). Kept together so that every criterion and threshold reads in one
place.
"""

from __future__ import annotations

import numpy as np
from cardan_forces.driveline.determinacy import determinacy
from cardan_forces.driveline.dynamics import Motion
from cardan_forces.driveline.equilibrium import Operator
from cardan_forces.driveline.kinematics import kinematics
from cardan_forces.driveline.scene import Scene
from cardan_forces.experiments.environment import number_text
from cardan_forces.formulations import BASELINE, SELECTION
from scipy.stats import binomtest

from . import figures
from .figures import PENALTY, SMOOTH_S, moving_average
from .histories import History

SETTLED_S = 0.1
"""Penalty comparisons start here: from rest the input shaft first turns through the
joints' play (~0.07 s on ``paper-penalty``), a transient the rigid model has not."""
SIGNIFICANCE = 0.05
"""Two-sided level of the sign test behind "larger" / "smaller" verdicts."""
ZERO_RTOL = 1e-4
"""A force (or a difference of forces) within this share of the run's largest load
counts as zero in a verdict (0.1 N at 1 kN): a solved answer of an interior-point
backend may leave an idle end face a few hundredths of a newton (its relative
residuals and gap are only held to 1e-6 of the equilibrium's scale), and a verdict
must not turn on a value the report prints as 0.0."""


def _zero(forces: np.ndarray) -> float:
    """The force below which ``forces`` (N) count as zero (:data:`ZERO_RTOL`)."""
    finite = np.abs(forces[np.isfinite(forces)])
    return ZERO_RTOL * float(finite.max(initial=0.0))


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
    (the data cannot tell; a half without an instant has no value). Returns the verdict
    and the values, for the report.
    """
    idx = np.flatnonzero(ok)
    halves = [np.isin(np.arange(len(ok)), part) for part in np.array_split(idx, 2)]
    whole, *parts = (stat(mask) if mask.any() else np.nan for mask in (ok, *halves))
    verdict = _classify(whole, agree, disagree)
    if verdict != "undecided" and any(_classify(v, agree, disagree) != verdict
                                      for v in parts):
        verdict = "undecided"
    first, second = (number_text(v, ".3g", "no instant") for v in parts)
    return verdict, f"{number_text(whole, '.3g')} (first half {first}, second half {second})"


def _sign_test(differences: list[np.ndarray], scale: list[np.ndarray], block: int):
    """Sign test of ``differences`` (N) pooled over quantities, on means over blocks of
    ``block`` instants (neighbouring instants of a smoothed curve are not independent;
    blocks of the smoothing window are taken as independent samples). Ties (|mean|
    within :data:`ZERO_RTOL` of the largest ``scale``, e.g. both forces zero) are
    dropped. Returns the share of positive blocks, their number, the two-sided p value
    and the median relative difference.
    """
    means, rel = [], []
    tie = _zero(np.concatenate([np.ravel(s) for s in scale])) if scale else 0.0
    for d, s in zip(differences, scale):
        n = len(d) // block * block
        m = d[:n].reshape(-1, block).mean(axis=1)
        r = m / np.maximum(s[:n].reshape(-1, block).mean(axis=1), 1e-9)
        keep = np.isfinite(m) & (np.abs(m) > tie)
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
    if PENALTY in mags and BASELINE in mags:
        return lines + _frequency_note(op, mags) + _larger_note(op, mags)
    return lines + ["- the paper's text on Fig. 13 (penalty vs the paper's method): not "
                    "judged, the run draws only " + ", ".join(f"`{m}`" for m in mags)]


def _both_faces_note(op: Operator, hist: dict[str, History]) -> list[str]:
    """Where a method lets both end faces of one trunnion pair push at once (the paper's
    complementarity, eqs. 39, 46, does not hold): a force no contact can make.
    """
    lines, clean = [], []
    rigid = {m: h for m, h in hist.items() if m != PENALTY}
    tol = max((_zero(h.forces) for h in rigid.values()), default=0.0)
    for m, h in rigid.items():
        both = np.max([np.minimum(h.forces[:, a], h.forces[:, b]) for a, b in op.pairs],
                      axis=0) if op.pairs else np.zeros(len(op.t))
        hit = np.isfinite(both) & (both > tol)
        if hit.any():
            k = int(np.nanargmax(both))
            lines.append(f"- `{m}`: both end faces of a pair push at once at {hit.sum()} of "
                         f"{len(both)} instants (up to {both[k]:.3g} N each, t = "
                         f"{op.t[k]:.3f} s): it does not impose the faces' complementarity "
                         "(eqs. 39, 46), so its curves are a comparison, not a physical "
                         "selection (the figures' legend says so)")
        else:
            clean.append(f"`{m}`")
    if clean:
        lines.append(f"- {', '.join(clean)}: no pair of end faces pushes at once (above "
                     f"{tol:.2g} N, {ZERO_RTOL:g} of the largest load)")
    return lines


def _frequency_note(op: Operator, mags) -> list[str]:
    """The paper: the ADAMS forces vary at a higher frequency than its method's."""
    def rough(ok):
        r = {m: np.nanmedian([np.nanmean(np.abs(np.diff(values[ok], 2)))
                              for values in mags[m].values()]) for m in (BASELINE, "penalty")}
        return r["penalty"] / r[BASELINE]

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
    share, n, p, rel = _sign_test([mags[BASELINE][k][ok] - smooth[k] for k in smooth],
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
        lines.append(f"- {q}: the rigid set is unbounded at "
                     f"{number_text(100 * unbounded, '.0f', 'none')} % of the instants "
                     f"checked; the rigid methods differ by up to "
                     f"{number_text(spread, '.1f')} N")
    if PENALTY not in loads or BASELINE not in loads:
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
        return max(abs(np.log10(np.median(avg[q][ok]) / np.median(loads[BASELINE][q][ok])))
                   for q in avg if q.endswith("_radial"))

    def axial(ok):  # median |difference| over the median paper-method axial load (>= 1 N)
        return (np.median(np.abs(avg["axial"][ok] - loads[BASELINE]["axial"][ok]))
                / max(np.median(np.abs(loads[BASELINE]["axial"][ok])), 1.0))

    # settled instants where the average is defined (its window fits) and both are known
    known = [np.isfinite(v) for source in (avg, loads[BASELINE]) for v in source.values()]
    ok = _settled(op.t) & np.logical_and.reduce(known)
    if not ok.any():
        return [f"- penalty against the paper method: no settled instant where the "
                f"{SMOOTH_S:g} s average is defined (the run is too short)"], {}
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


def _gravity(scene: Scene) -> str:
    return "gravity (" + ", ".join(f"{g:g}" for g in scene.gravity_m_s2) + ") m/s^2"


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
