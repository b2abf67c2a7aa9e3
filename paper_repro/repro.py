"""``cardan repro``: the paper's Figs. 11-15 and a report, on the embedded scenes.

Figs. 11-12 come from the motion; 13-15 from contact-force histories of the paper's
method and the convex formulations (:mod:`paper_repro.histories`), with the rigid
solution set's interval shaded where a bearing load is not unique. The report states
versions, machine, settings, and per figure what the numbers say next to the paper's
text.
"""

from __future__ import annotations

import datetime
import importlib.metadata
import platform
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from driveline.determinacy import determinacy
from driveline.dynamics import Motion, simulate
from driveline.equilibrium import Operator, build_operator
from driveline.scene import Scene, load_scene
from experiments.analysis import value_range

from . import figures
from .histories import METHODS, History, history

FIGURES = (11, 12, 13, 14, 15)
BOUND_INSTANTS = 41
"""Instants (evenly spread) at which Figs. 14-15's solution-set intervals are computed."""


def _cpu() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def _versions() -> str:
    names = ("numpy", "scipy", "cvxpy", "clarabel", "qpsolvers", "osqp", "daqp", "matplotlib")
    found = []
    for name in names:
        try:
            found.append(f"{name} {importlib.metadata.version(name)}")
        except importlib.metadata.PackageNotFoundError:
            pass
    return ", ".join(found)


def bearing_bounds(op: Operator, shaft: str = "input") -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Intervals of Fig. 14's loads over the rigid set at ``BOUND_INSTANTS`` instants (NaN
    elsewhere). Axial: the exact range of the sum of both bearings' x. Radial: the range
    of the radial length allowed by the y and z component intervals (their box hull).
    """
    T = len(op.t)
    picks = np.unique(np.linspace(0, T - 1, min(BOUND_INSTANTS, T)).round().astype(int))
    out = {q: (np.full(T, np.nan), np.full(T, np.nan))
           for q in ("far_radial", "near_radial", "axial")}
    eye = np.eye(len(op.names))

    def span(i, c):
        r = value_range(op, i, c)
        return (-np.inf if r["min"] is None else r["min"],
                np.inf if r["max"] is None else r["max"])

    for i in picks:
        axial = eye[op.index(f"bearing.{shaft}.far.x")] + eye[op.index(f"bearing.{shaft}.near.x")]
        out["axial"][0][i], out["axial"][1][i] = span(i, axial)
        for side in ("far", "near"):
            ranges = [span(i, eye[op.index(f"bearing.{shaft}.{side}.{a}")]) for a in "yz"]
            closest = [0.0 if lo <= 0.0 <= hi else min(abs(lo), abs(hi)) for lo, hi in ranges]
            farthest = [max(abs(lo), abs(hi)) for lo, hi in ranges]
            out[f"{side}_radial"][0][i] = np.hypot(*closest)
            out[f"{side}_radial"][1][i] = np.hypot(*farthest)
    return out


def _histories(op: Operator, progress) -> dict[str, History]:
    return {m: history(op, m, progress=progress) for m in METHODS}


def _fig13_notes(op: Operator, hist: dict[str, History]) -> list[str]:
    mags = {m: figures.joint_magnitudes(op.names, h.forces) for m, h in hist.items()}
    det = determinacy(op, len(op.t) // 2).determinate
    unique = [n for n, d in zip(op.names, det) if d and n.startswith("uj1.")]
    lines = [f"- components of joint 1 that the rigid model determines (at t = "
             f"{op.t[len(op.t) // 2]:.3f} s): {', '.join(unique) or 'none'}; all others "
             "depend on the selection rule."]
    for k in range(1, 9):
        label = f"F{k}"
        spread = np.nanmax([np.nanmax(np.abs(mags[m][label] - mags["positive"][label]))
                            for m in mags])
        peak = np.nanmax([np.nanmax(mags[m][label]) for m in mags])
        lines.append(f"- |{label}|: peak {peak:.1f} N over the methods; largest difference "
                     f"from `positive`: {spread:.1f} N")
    return lines


def _fig14_notes(op: Operator, hist: dict[str, History], bounds) -> list[str]:
    lines = []
    for q in ("far_radial", "near_radial", "axial"):
        lo, hi = bounds[q]
        ok = ~np.isnan(lo)
        unbounded = np.mean(np.isinf(hi[ok]) | np.isinf(lo[ok]))
        values = {m: figures.bearing_loads(op.names, h.forces)[q] for m, h in hist.items()}
        spread = np.nanmax([np.nanmax(np.abs(v - values["positive"])) for v in values.values()])
        lines.append(f"- {q}: the rigid set is unbounded at {100 * unbounded:.0f} % of the "
                     f"instants checked; the methods differ by up to {spread:.1f} N")
    return lines


def run_repro(scene_name: str = "paper", figs=FIGURES, out: str | Path = "results",
              quick: bool = False, fig15_scene: str = "paper-fig15",
              progress: Callable[[str], None] = print) -> Path:
    """Write the requested figures (CSV + PNG) and ``report.md`` into ``out``."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    started = time.perf_counter()
    scene = load_scene(scene_name)
    times = scene.time.instants()
    if quick:
        times = times[times <= scene.time.start_s + 0.5]
    progress(f"repro: simulating {scene.name} over {len(times)} instants ...")
    motion = simulate(scene, times)
    sections = []
    if 11 in figs:
        csv = figures.fig11(motion, out)
        diff = np.max(np.abs(motion.omega[-1] - motion.omega[0]))
        sections.append(("Fig. 11: input and output angular velocity", csv, [
            f"- the output turns with the input: max |omega_out - omega_in| = {diff:.1e} rad/s "
            "(paper: uniform output in the Z arrangement with equal angles, eq. 4)",
            f"- input speed at t = {motion.t[-1]:g} s: {motion.omega[0][-1]:.3f} rad/s"]))
    if 12 in figs:
        csv = figures.fig12(motion, out)
        ratio = motion.omega[1][1:] / motion.omega[0][1:]
        sections.append(("Fig. 12: intermediate shaft angular velocity", csv, [
            f"- omega_intermediate / omega_input oscillates in [{ratio.min():.4f}, "
            f"{ratio.max():.4f}] (eq. 3: [cos g1, 1/cos g1] = "
            f"[{np.cos(np.radians(30)):.4f}, {1 / np.cos(np.radians(30)):.4f}] for 30 deg)"]))
    if any(f in figs for f in (13, 14)):
        sections += _contact_figures(motion, figs, out, progress)
    if 15 in figs:
        sections += _fig15(load_scene(fig15_scene), times, out, progress)
    report = _report(scene, motion, sections, quick, fig15_scene,
                     time.perf_counter() - started)
    path = out / "report.md"
    path.write_text(report)
    progress(f"repro: report -> {path} ({time.perf_counter() - started:.1f} s in all)")
    return path


def _contact_figures(motion: Motion, figs, out: Path, progress) -> list:
    op = build_operator(motion)
    hist = _histories(op, progress)
    forces = {m: h.forces for m, h in hist.items()}
    sections = []
    if 13 in figs:
        csv = figures.fig13(op.t, op.names, forces, out, motion.scene.name)
        sections.append(("Fig. 13: contact forces of joint 1", csv,
                         _fig13_notes(op, hist) + _status_lines(hist)))
    if 14 in figs:
        progress("repro: fig 14 solution-set intervals ...")
        bounds = bearing_bounds(op)
        csv = figures.fig14(op.t, op.names, forces, bounds, out, motion.scene.name)
        sections.append(("Fig. 14: input shaft bearing loads", csv,
                         _fig14_notes(op, hist, bounds)))
    return sections


def _fig15(scene: Scene, times: np.ndarray, out: Path, progress) -> list:
    progress(f"repro: fig 15 on {scene.name} ...")
    op = build_operator(simulate(scene, times))
    hist = _histories(op, progress)
    bounds = bearing_bounds(op)
    csv = figures.fig14(op.t, op.names, {m: h.forces for m, h in hist.items()}, bounds, out,
                        scene.name, number=15)
    return [(f"Fig. 15: input shaft bearing loads, gravity {scene.gravity_m_s2} m/s^2", csv,
             _fig14_notes(op, hist, bounds))]


def _status_lines(hist: dict[str, History]) -> list[str]:
    return [f"- `{m}` ({h.solver}): {h.solved}/{len(h.statuses)} instants solved, "
            f"{h.seconds:.2f} s of solver time" for m, h in hist.items()]


def _report(scene: Scene, motion: Motion, sections, quick: bool, fig15_scene: str,
            seconds: float) -> str:
    lines = [
        "# cardan repro: the paper's Figs. 11-15",
        "",
        f"- date: {datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d %H:%M} UTC",
        f"- machine: {_cpu()}, Python {platform.python_version()}",
        f"- versions: {_versions()}",
        f"- scene: `{scene.name}` ({scene.description}); Fig. 15: `{fig15_scene}`",
        f"- instants: {len(motion.t)} from {motion.t[0]:g} to {motion.t[-1]:g} s"
        + (" (quick run)" if quick else ""),
        "- methods (formulation: backend): "
        + ", ".join(f"`{m}`: {s}" for m, s in METHODS.items()),
        f"- wall time: {seconds:.1f} s",
        "",
        "Each figure's CSV holds one column per quantity and method; the PNG is drawn from "
        "it. An instant whose record is not `solved` is NaN in the CSV.",
    ]
    for title, csv, notes in sections:
        lines += ["", f"## {title}", "", f"`{csv.name}`, `{csv.with_suffix('.png').name}`", ""]
        lines += notes
    return "\n".join(lines) + "\n"
