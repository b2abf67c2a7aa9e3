"""``report.md`` of a ``cardan repro`` run.

Its head (date, machine, versions, scene, methods, the run's timings and what was
simulated), the figures' sections in order, and the files an earlier run left in the
same folder: :data:`OUTPUTS` names the files a run writes, so that those not written this
time are listed rather than passed off as this report's.
"""

from __future__ import annotations

import datetime
import os
import time
from pathlib import Path

from cardan_forces.driveline.dynamics import Motion
from cardan_forces.driveline.scene import Scene
from cardan_forces.experiments import files
from cardan_forces.experiments.environment import machine, versions

from .figures import PENALTY
from .request import ENGINE
from .runs import _Runs

PENALTY_TARGET_S = 1.0
"""The penalty simulation's target cost: wall seconds per simulated second."""
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
        + ", ".join(f"{s:.3f} s" for _, _, s, _ in runs.motions)
        + " (target <= 0.05 s for 1001 instants); penalty simulation "
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
        "rigid-set bound not computed there or on an open side; `*_set_open` says which "
        "(0 closed, 1 open above, -1 open below, 2 open on both sides). Every verdict on the "
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


def _write_report(out: Path, report: str, sections, formats, progress, started: float
                  ) -> Path:
    """Write ``report`` into ``out/report.md`` with the list of the files an earlier run
    left beside this run's (:data:`OUTPUTS`), and say what was written; ``started``: the
    run's start (:func:`time.perf_counter`), for the total time said.
    """
    written = _written(sections, formats)
    stale = files.stale(out, [*written, out / "report.md"], OUTPUTS)
    path = files.write_text(out / "report.md", report + _stale_lines(stale))
    progress(f"repro: report -> {path} ({time.perf_counter() - started:.1f} s in all)")
    files.say_written("repro", [*written, path], note=f"{len(stale)} file(s) of an earlier "
                      "run left beside them, listed in report.md" if stale else "")
    return path
