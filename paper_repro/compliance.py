"""The compliance formulations against the penalty simulation, in ``cardan repro``.

The methods of :data:`.methods.COMPLIANCE_VS_PENALTY` planned as jobs on the released scene's
rigid operator (the same clearances, seen as gaps; a method that does not apply is left
out with its reason), and the report's section and CSV of their distance from the
penalty simulation per contact group. A comparison beside the paper's figures, so a
module of its own.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from cardan_forces.driveline.equilibrium import build_operator
from cardan_forces.driveline.scene import Scene
from cardan_forces.experiments import files

from .figures import SMOOTH_S, moving_average
from .histories import history, released
from .methods import COMPLIANCE_VS_PENALTY
from .request import _refusal
from .runs import _cost, _Job, _Runs
from .verdicts import SETTLED_S, _settled


def _compliance_plan(runs: _Runs, scene: Scene):
    """The methods of :data:`.methods.COMPLIANCE_VS_PENALTY` on the released scene's rigid
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
