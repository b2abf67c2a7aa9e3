"""``cardan bench``: throughput and accuracy-vs-time of every formulation x backend.

The operator over all instants is built once; so is every formulation's problem at
every instant (reported as one-time setup), so a run's time per instant is the
package's ``solve`` — conversion, the solver, the checks — split in every row.

- **Throughput** over the scene's instants in time order: ``cold`` (every instant from
  the formulation's own start), ``warm`` (the previous answer as start, for backends
  that declare a warm start) and ``batched`` (backends that solve a formulation's batch
  at once: NumPy for the least-norm family, moreau for the conic forms). A per-instant
  run stops after ``--budget-s`` seconds once it has covered 150 instants
  (``LEAST_INSTANTS``; the paper's baseline, its default backend warm-started, never
  stops).
- **Accuracy vs time** on evenly spaced instants over the tolerance ladder and each
  backend's defaults, accuracy measured by the package's relative optimality measures
  (:mod:`.bench_metrics`): success per level, Pareto fronts, Dolan-Moré performance
  profiles with shifted geometric mean ratios, on the solver's own time and end to end.
- **Two accuracy views on the same solves** (:mod:`.qpbench_harness`): the QPs of those
  instants (least norms as QPs) through every qpsolvers backend at qpbenchmark's four
  settings, each solve scored by *solver optimality* (qpbenchmark's absolute measures
  measures, :mod:`cardan_forces.solvers.judge`, and success rule) and by *force accuracy*
  (the package's physics), with the failing rule named. ``--harness qpbenchmark`` also
  exports them as a test set and runs qpbenchmark itself, its success and runtime
  tables beside the package's.

Running: :mod:`.bench_run`; metrics: :mod:`.bench_metrics`; output: :mod:`.bench_report`;
the targets a developer's check holds a run to: :mod:`.bench_targets`.
Results go to ``--out``: long-format CSVs, PNGs and ``report.md``; ``--json`` prints one
strict-JSON object. A backend whose solver could not be built here (a generated solver:
no working compiler, an unwritable cache) has failed rows with the reason, and the run
names it on stderr and ends with exit code 1.
"""

from __future__ import annotations

import argparse
import importlib.util
import math
import sys
import time
from pathlib import Path

import numpy as np
from cardan_forces.driveline.dynamics import simulate
from cardan_forces.driveline.equilibrium import build_operator
from cardan_forces.driveline.loading import load_scene
from cardan_forces.experiments.arguments import UsageError, formulation_name
from cardan_forces.experiments.environment import json_text
from cardan_forces.formulations import FORMULATIONS
from cardan_forces.formulations import batch as fbatch
from cardan_forces.formulations.convex import NotApplicable
from cardan_forces.formulations.problems import LS, QP, Conic
from cardan_forces.solvers import available
from cardan_forces.solvers import get as get_backend
from cardan_forces.solvers.qocogen_ import UNBUILT

from . import bench_metrics as metrics
from . import bench_report as out
from . import bench_run as runs
from . import export as exporting
from . import files, progress
from . import qpbench_harness as harness
from .bench_targets import target_levels
from .images import FORMATS, format_list


def measure(op, backends: dict[str, list[str]], samples, ladder, budget_s: float) -> dict:
    """Throughput and accuracy rows of every planned formulation x backend, formulation
    by formulation (its problems built once, then dropped).
    """
    rows, acc_rows, stages, references, setup, conic = [], [], {}, {}, {}, set()
    problems, forces = {}, {}
    for name, solvers in progress.bar(backends.items(), "bench", len(backends), "formulation"):
        runs.progress(f"bench: building {name} at {len(op.t)} instants ...")
        prepared = runs.prepare(op, name, np.arange(len(op.t)))
        setup[name] = prepared.build_s
        if isinstance(prepared.problems[0], Conic):
            conic.add(name)
        new, batched = runs.throughput(prepared, solvers, budget_s)
        rows += new
        stages.update({(name, solver): parts for solver, parts in batched.items()})
        found = runs.references(prepared, samples)
        new, references[name] = runs.accuracy(prepared, solvers, samples, ladder, budget_s,
                                              found)
        acc_rows += new
        if isinstance(prepared.problems[0], (LS, QP, Conic)):
            problems |= {f"{name}_{int(i):04d}": prepared.problems[int(i)] for i in samples}
            forces |= {f"{name}_{i:04d}": x for i, (x, _) in (found[0] or {}).items()}
    return {"rows": rows, "acc_rows": acc_rows, "stages": stages, "references": references,
            "setup": setup, "conic": conic, "view_problems": problems,
            "view_references": forces}


def views(problems: dict, references: dict, solvers: list[str], folder: Path,
          with_qpbenchmark: bool) -> dict:
    """The two-view harness on ``problems`` (QPs, least norms and conic problems) with
    the backends among ``solvers`` that declare qpbenchmark's settings (``references``:
    reference forces by problem name, for the distance where the optimum is unique); with
    ``with_qpbenchmark``, the QPs exported into ``folder/qpbenchmark`` and qpbenchmark
    itself run on them.
    """
    backends = harness.backends_with_profiles(solvers)
    rows = harness.run_package(problems, solvers, references=references)
    runs.progress(f"bench: {len(rows)} solves scored in both views")
    qps = {k: p for k, p in problems.items() if exporting.as_qp(p) is not None}
    theirs = []
    if with_qpbenchmark and qps and backends:
        target = folder / "qpbenchmark"
        target.mkdir(parents=True, exist_ok=True)
        path = exporting.write_qpbenchmark(target, "cardan_bench",
                                           {k: exporting.as_qp(p) for k, p in qps.items()},
                                           "cardan bench QPs")
        results = target / "qpbenchmark_results.csv"
        results.unlink(missing_ok=True)
        runs.progress(f"bench: qpbenchmark itself on {path} ...")
        theirs = harness.run_qpbenchmark(path, [b.split("-", 1)[1] for b in backends], results)
    return {"views": harness.side_by_side(harness.package_tables(rows), theirs),
            "view_rows": rows, "view_count": len({r["problem"] for r in rows}),
            "qpbenchmark_ran": bool(theirs)}


def check_harness(op, backends: dict[str, list[str]]) -> None:
    """:class:`UsageError` (one line, before any solve) unless the planned ``backends``
    (per formulation) give qpbenchmark something to run, as :func:`views` runs it: a
    QP (a least norm as a QP) among the formulations and a qpsolvers backend with
    qpbenchmark's settings among the backends. Conic problems and batched backends are
    scored in the package's views only; the message says which part is missing.
    """
    first = {name: fbatch.build_problems(op, name, [0])[0] for name in backends}
    chosen = sorted({s for solvers in backends.values() for s in solvers})
    if not any(exporting.as_qp(p) is not None for p in first.values()):
        kinds = ", ".join(f"{name}: {type(p).__name__}" for name, p in first.items())
        raise UsageError(f"--harness qpbenchmark: the selection has no QP ({kinds}; "
                         "qpbenchmark runs QPs and least norms, not conic problems or "
                         f"LCPs): choose one of {', '.join(_qp_formulations(op))}")
    if not harness.backends_with_profiles(chosen):
        usable = harness.backends_with_profiles(available())
        raise UsageError(f"--harness qpbenchmark: none of the chosen backends "
                         f"({', '.join(chosen)}) is a qpbenchmark solver (batched, conic "
                         "and other backends are scored by the package alone): choose "
                         f"one of {', '.join(usable) or 'none installed'}")


def _qp_formulations(op) -> list[str]:
    """The formulations whose problems on ``op`` are QPs or least norms."""
    found = []
    for name in FORMULATIONS:
        try:
            problem = fbatch.build_problems(op, name, [0])[0]
        except NotApplicable:
            continue
        found += [name] if exporting.as_qp(problem) is not None else []
    return found


def evaluate(measured: dict, ladder) -> dict:
    """Every metric of the report from the measured rows: measurements only (the targets
    a developer holds the bench to are :func:`~.bench_targets.targets`').
    """
    summary = metrics.summarize(measured["rows"], measured["setup"])
    success = metrics.success(measured["acc_rows"],
                              sorted({*ladder, *target_levels()}, reverse=True))
    return measured | {
        "summary": summary, "points": metrics.pareto(measured["acc_rows"]),
        "success": success, "profiles": metrics.profiles(measured["acc_rows"], ladder),
        "overhead": metrics.overhead(summary),
    }


def run(args) -> int:
    """``cardan bench``: write the CSVs, the PNGs and the report into ``args.out``."""
    for name in args.solver or ():
        get_backend(name)  # unknown or absent: SolverNotFound before any work
    scene = load_scene(args.scene)
    times = scene.time.instants()
    if args.quick:
        times = times[:runs.QUICK_INSTANTS]
    ladder = runs.QUICK_LADDER if args.quick else runs.LADDER
    folder = Path(args.out)
    folder.mkdir(parents=True, exist_ok=True)
    started = time.perf_counter()
    runs.progress(f"bench: simulating {scene.name} over {len(times)} instants ...")
    motion = simulate(scene, times)
    simulated = time.perf_counter()
    op = build_operator(motion)
    operator_s = time.perf_counter() - simulated
    samples = np.unique(np.linspace(0, len(times) - 1, runs.QUICK_SAMPLES if args.quick
                                    else runs.SAMPLES).round().astype(int))
    backends = runs.plan(op, args.formulation, args.solver, args.quick)
    if args.harness == "qpbenchmark":
        check_harness(op, backends)
    measured = measure(op, backends, samples, ladder, args.budget_s)
    measured |= views(measured["view_problems"], measured["view_references"],
                      sorted({s for v in backends.values() for s in v}), folder,
                      args.harness == "qpbenchmark")
    results = evaluate(measured, ladder)
    softened = _regularization(folder, args.format) if args.regularization else []
    written = _write(folder, results, {
        "scene": scene.name, "instants": len(times), "span": f"{times[0]:g}..{times[-1]:g} s",
        "budget_s": args.budget_s, "samples": len(samples), "ladder": ladder,
        "quick": args.quick, "simulate_s": simulated - started, "operator_s": operator_s,
        "wall_s": time.perf_counter() - started}, args.format)
    if softened:  # its section in the report, its files among the run's
        report = folder / "report.md"
        image = next((p.name for p in softened if p.suffix in (".png", ".svg")), None)
        figure = f"\n![what regularization costs]({image})\n" if image else ""
        files.write_text(report, report.read_text() + "\n"
                         + (folder / "regularization.md").read_text() + figure)
        written += softened
    removed = files.stale(folder, written, [f"{stem}{page}.{f}" for stem in FIGURES
                                             for f in FORMATS for page in ("", "-[0-9]*")])
    for path in removed:  # an earlier run's figure in another format: not this run's
        path.unlink()
    runs.progress(f"bench: done in {time.perf_counter() - started:.0f} s")
    files.say_written("bench", written, removed)
    if args.json:
        print(json_text(out.json_object(results)))
    else:
        for e in results["summary"]:
            print(f"{e['formulation']:16s} {e['solver']:20s} {e['mode']:7s} "
                  f"{e['instants_per_s']:10.1f}/s  solved {100 * e['success_rate']:5.1f}%")
    unbuilt = _unbuilt(results["rows"] + results["acc_rows"])
    for solver, why in unbuilt.items():
        print(f"bench: {solver} did not run: {why} (its rows are failed records)",
              file=sys.stderr)
    return 1 if unbuilt else 0


def _unbuilt(rows: list[dict]) -> dict[str, str]:
    """The backends whose solver could not be built here (a generated solver), each with
    its reason: their rows are failures of the machine, not results of the solver.
    """
    return {r["solver"]: r["message"][r["message"].index(UNBUILT):] for r in rows
            if UNBUILT in (r["message"] or "")}


FIGURES = ("bench_pareto", "bench_profiles")
"""The figures' names (without format) in the output folder (a figure of several pages
is ``<name>-1``, ``<name>-2``, ... in PNG and SVG, :func:`.images.save_pages`)."""


def _regularization(folder: Path, formats) -> list[Path]:
    """The newton family's softening study on paper and propshaft (what the physics
    engines' regularization costs in distance from the rigid set, against time),
    written into ``folder``; its paths.
    """
    from . import regularization

    return regularization.study(folder, formats=formats)


def _write(folder: Path, results: dict, settings: dict, formats=("png",)) -> list[Path]:
    """Every output of the run into ``folder``, each replacing the file of an earlier
    run whole (:mod:`.files`); the paths written.
    """
    tables = {"bench_throughput.csv": (results["rows"], out.THROUGHPUT_COLUMNS),
              "bench_accuracy.csv": (results["acc_rows"], out.ACCURACY_COLUMNS),
              "bench_profiles.csv": (out.profile_rows(results["profiles"]),
                                     out.PROFILE_COLUMNS),
              "bench_views.csv": (results["view_rows"], out.VIEW_COLUMNS)}
    for name, (rows, columns) in tables.items():
        out.write_csv(folder / name, rows, columns)
    styles = out.backend_styles([p["solver"] for p in results["points"]]
                                + [p["solver"] for p in results["profiles"]])
    scene = settings["scene"]
    images = out.plot_pareto(results["points"], folder / FIGURES[0], formats, styles, scene)
    images += out.plot_profiles(results["profiles"], folder / FIGURES[1], formats, styles, scene)
    report = files.write_text(folder / "report.md", out.report(results, settings))
    return [*(folder / name for name in tables), *images, report]


def _seconds(text: str) -> float:
    """A positive, finite number of seconds (argparse type)."""
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"expected a positive number of seconds, got {text!r}")
    return value


def add_parser(subparsers) -> None:
    """Register ``cardan bench`` on the command line's subparsers."""
    p = subparsers.add_parser("bench", help="throughput and accuracy-vs-time of formulations "
                                            "x backends")
    p.add_argument("scene", nargs="?", default="paper", help="built-in name or TOML path")
    p.add_argument("--out", type=files.folder, default="results/bench",
                   help="output folder (default results/bench/)")
    p.add_argument("--quick", action="store_true",
                   help=f"first {runs.QUICK_INSTANTS} instants, {len(runs.QUICK_LADDER)} "
                        "tolerances, a few backends (tests, CI)")
    p.add_argument("--json", action="store_true", help="print the summary as one JSON object")
    p.add_argument("--formulation", action="append", type=formulation_name,
                   choices=list(FORMULATIONS),
                   help="one formulation (repeatable); default all")
    p.add_argument("--solver", action="append",
                   help="one backend (repeatable; batched ones too, e.g. numpy-batched); "
                        "default all")
    p.add_argument("--budget-s", type=_seconds, default=runs.BUDGET_S,
                   help=f"seconds per per-instant run before it stops, once it has "
                        f"{runs.LEAST_INSTANTS} instants (default {runs.BUDGET_S:g})")
    p.add_argument("--format", type=format_list, default=("png",), metavar="FORMATS",
                   help="image formats of the figures, comma-separated among "
                        f"{','.join(FORMATS)} (default png)")
    p.add_argument("--harness", type=_harness,
                   help="also run qpbenchmark itself on the bench's QPs (value: qpbenchmark; "
                        'needs pip install "cardan-forces[bench]")')
    p.add_argument("--regularization", action="store_true",
                   help="also what softening costs: the newton family's answers against "
                        "rigid ones on paper and propshaft (regularization.csv/.md/.png)")
    p.set_defaults(func=run)


def _harness(text: str) -> str:
    """``qpbenchmark``, when it is installed (argparse type)."""
    if text != "qpbenchmark":
        raise argparse.ArgumentTypeError(f"the only harness is qpbenchmark, got {text!r}")
    if importlib.util.find_spec("qpbenchmark") is None:
        raise argparse.ArgumentTypeError('qpbenchmark is not installed: pip install '
                                         '"cardan-forces[bench]"')
    return text
