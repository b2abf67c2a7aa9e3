"""The report's sections of Figs. 11-15 in ``cardan repro``.

Each figure drawn (:mod:`cardan_forces.paper_repro.figures`) from the motion, the
rigid-model methods' histories, the rigid set's bounds and the penalty simulation, with
its notes and verdicts (:mod:`cardan_forces.paper_repro.verdicts`). A section is
``(title, CSV path or None, lines)``, which :mod:`cardan_forces.paper_repro.report`
writes into ``report.md`` in order.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from cardan_forces.driveline.dynamics import Motion
from cardan_forces.driveline.equilibrium import Operator
from cardan_forces.driveline.scene import Scene

from . import figures
from .compliance import _compliance_vs_penalty
from .figures import PENALTY
from .histories import History, penalty_history
from .runs import _Runs
from .verdicts import (
    SETTLED_S,
    _bearing_notes,
    _fig13_notes,
    _fig15_summary,
    _gravity,
    _speed_notes,
)


def _main_figures(runs: _Runs, scene: Scene, motion: Motion, op: Operator, figs, work,
                  compliance, out: Path, formats) -> list:
    """Figs. 11-14 on the run's scene and the compliance comparison: report sections."""
    shown = [f"Fig. {f}" for f in figs if f in (11, 12, 13, 14)]
    pen = (runs.penalty_result(scene, ", ".join(shown) + " and the compliance comparison")
           if shown else None)
    pen_omega = None if pen is None else pen.omega
    sections = []
    if 11 in figs:
        csv, caption = figures.fig11(motion, out, pen_omega, formats,
                                      settled_s=SETTLED_S)
        diff = np.max(np.abs(motion.omega[-1] - motion.omega[0]))
        sections.append(("Fig. 11: input and output angular velocity", csv, [*caption,
            f"- the output turns with the input: max |omega_out - omega_in| = {diff:.1e} rad/s "
            "(paper: uniform output in the Z arrangement with equal angles, eq. 4)",
            f"- input speed at t = {motion.t[-1]:g} s: {motion.omega[0][-1]:.3f} rad/s",
            *_speed_notes(motion, pen, (0, -1))]))
    if 12 in figs:
        csv, caption = figures.fig12(motion, out, pen_omega, formats,
                                      settled_s=SETTLED_S)
        ratio = motion.omega[1][1:] / motion.omega[0][1:]
        g1 = scene.joints[0].articulation_deg
        sections.append(("Fig. 12: intermediate shaft angular velocity", csv, [*caption,
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


def _contact_figures(op: Operator, figs, work, out: Path, formats, penalty) -> list:
    hist = dict(work["hist"]) | ({} if penalty is None else {PENALTY: penalty})
    forces = {m: h.forces for m, h in hist.items()}
    sections = []
    if 13 in figs:
        csv, caption = figures.fig13(op, forces, work[13], out, formats,
                                      settled_s=SETTLED_S)
        sections.append(("Fig. 13: contact forces of joint 1", csv,
                         caption + _fig13_notes(op, hist) + _status_lines(hist)))
    if 14 in figs:
        bounds = work[14]
        csv, caption = figures.fig14(op, forces, bounds, out, formats=formats,
                                      settled_s=SETTLED_S)
        sections.append(("Fig. 14: input shaft bearing loads", csv,
                         caption + _bearing_notes(op, hist, bounds, 14)[0]))
    return sections


def _status_lines(hist: dict[str, History]) -> list[str]:
    return [f"- `{m}` ({h.solver}): {h.solved}/{len(h.statuses)} instants solved, "
            f"{h.seconds:.2f} s of {'wall' if m == 'penalty' else 'solver'} time"
            for m, h in hist.items()]


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
        csv, caption = figures.fig14(op, {m: h.forces for m, h in hist.items()}, bounds,
                                     out, number=15, stem=f"fig15_{scene.name}",
                                     subtitle=f", {_gravity(scene)}", formats=formats,
                                     settled_s=SETTLED_S)
        notes, verdict = _bearing_notes(op, hist, bounds, 15)
        sections.append((f"Fig. 15 on `{scene.name}`: input shaft bearing loads, "
                         f"{_gravity(scene)}", csv, caption + notes))
        verdicts.append((scene, verdict))
    if len(verdicts) > 1 or any(v for _, v in verdicts):
        sections.append(_fig15_summary(verdicts))
    return sections
