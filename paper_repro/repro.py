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

This module runs the command (:func:`run_repro`) and holds the names that other code
takes from it. Its parts live beside it: what may be asked and what is refused
(:mod:`cardan_forces.paper_repro.request`), the run's simulations and jobs on worker
processes (:mod:`cardan_forces.paper_repro.runs`), the rigid set's intervals
(:mod:`cardan_forces.paper_repro.rigid_set`), the figures' sections
(:mod:`cardan_forces.paper_repro.sections`, :mod:`cardan_forces.paper_repro.compliance`,
:mod:`cardan_forces.paper_repro.engine_section`), the verdicts on the paper's text
(:mod:`cardan_forces.paper_repro.verdicts`) and ``report.md``
(:mod:`cardan_forces.paper_repro.report`).
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from pathlib import Path

from cardan_forces.driveline.equilibrium import build_operator
from cardan_forces.driveline.loading import load_scene

from .compliance import _compliance_plan
from .engine_section import _engine_section, _engine_work
from .figures import PENALTY
from .methods import METHODS
from .report import _report, _write_report
from .request import ALL_METHODS, ENGINE, FIG15_SCENES, FIGURES, check_request, default_methods
from .runs import _rigid_jobs, _rigid_result, _run_jobs, _Runs
from .sections import _fig15, _main_figures

__all__ = ["ALL_METHODS", "ENGINE", "FIG15_SCENES", "FIGURES", "METHODS", "check_request",
           "default_methods", "run_repro"]
"""What ``cardan repro``'s callers take from here: its figures and methods, the methods
drawn unless told, the check of a request, and the run."""

QUICK_S = 0.15
"""Window of ``--quick`` (s from the start)."""


def run_repro(scene_name: str = "paper", figs=FIGURES, out: str | Path = "results/repro",
              quick: bool = False, fig15_scenes=FIG15_SCENES,
              progress: Callable[[str], None] = print, methods=None,
              formats=("png",), workers: int | None = None) -> Path:
    """Write the requested figures (CSV, and an image per format of ``formats``) and
    ``report.md`` into ``out``. ``methods``: what the figures draw (of
    :data:`ALL_METHODS`, default :func:`default_methods`; ``penalty`` runs the
    penalty-contact simulation, once per scene); ``fig15_scenes``: Fig. 15's scenes,
    one figure each; ``workers``: processes for the penalty simulations (default: the
    CPUs; 0: in this process, one by one).
    A method or figure that cannot draw the scene is refused before any long work.
    """
    out, started = Path(out), time.perf_counter()
    methods = default_methods() if methods is None else methods
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
    return _write_report(out, report, sections, formats, progress, started)
