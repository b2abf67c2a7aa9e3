"""``cardan sweep``: parameter studies, articulation angle x input torque amplitude x
formulation (DESIGN §4).

A point (:mod:`.sweep_point`) is a variant of one scene (every joint at the angle, the
input torque's amplitude set) simulated at ``--instants`` instants over its window; each
requested formulation is solved at every instant with one backend (the study layer's
default unless ``--solver`` says otherwise) and summed up in one typed row. Points run
in a local process pool, or on a Dask distributed cluster given ``--scheduler``
(:mod:`.sweep_exec`); each finished point's rows are appended to ``sweep.csv`` at once
(:mod:`.sweep_store`), so a killed sweep loses only the points in flight and a rerun
computes only the rows the CSV lacks (one row per key: a second run into the folder
resumes, and says how many points it found there; the key holds the SHA-256 of the
scene's content, so an edited scene's rows are computed apart, never taken from the
rows of the scene before the edit). One sweep at a time writes into a
folder; its local workers end with it, however it ends; a Dask run left without workers
ends after ``--timeout`` s, keeping its rows.

Every request is checked against the scene's limits before any work: the angles and
amplitudes, the window (instants, span, the revolutions and torque periods it implies)
and the size of the grid (:data:`MAX_POINTS`, :data:`MAX_SOLVES`).
"""

from __future__ import annotations

import dataclasses
import math
import os
import sys
import time
from collections.abc import Callable
from contextlib import closing
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from cardan_forces.driveline.dynamics import simulate
from cardan_forces.driveline.equilibrium import build_operator
from cardan_forces.driveline.loading import builtin_names, load_scene
from cardan_forces.driveline.scene import LIMITS, MAX_ARTICULATION_DEG, Scene, SceneError
from cardan_forces.experiments.arguments import formulation_name
from cardan_forces.experiments.environment import json_text, number_text
from cardan_forces.experiments.study import NoBackend, default_backend
from cardan_forces.formulations import FORMULATIONS
from cardan_forces.formulations.convex import NotApplicable
from cardan_forces.solvers import Status
from cardan_forces.solvers import get as get_backend

from . import files, progress, sweep_exec
from .sweep_point import (
    KEY,
    PEAKS,
    Point,
    Row,
    SweepError,
    point_scene,
    run_point,
    scene_digest,
    variant,
)
from .sweep_store import COLUMNS, FORMATS, append, key_of, locked, read_rows, spell

__all__ = ["COLUMNS", "KEY", "PEAKS", "Point", "Row", "SweepError", "plan", "point_scene",
           "run_point", "sweep"]

INSTANTS, QUICK_INSTANTS, QUICK_STOP_S = 21, 6, 0.5
"""Instants per point by default; ``--quick``: 6 instants over the first 0.5 s."""

MAX_POINTS = 1000
"""Most points (angles x amplitudes) of one sweep: each simulates a scene and solves
every formulation at every instant (seconds each), so a larger grid is refused up front
instead of running for hours."""

MAX_SOLVES = 200_000
"""Most solves of one sweep (points x formulations x instants)."""

MAX_WORKERS = 1024
"""Most local worker processes."""


# ---------------------------------------------------------------------------- the request


@dataclass(frozen=True)
class Study:
    """A sweep request, checked: the grid, the backend per formulation, the window."""

    scene: str
    angles: tuple[float, ...]
    amplitudes: tuple[float, ...]
    set_angle: bool
    set_amplitude: bool
    methods: tuple[tuple[str, str], ...]
    stop_s: float
    instants: int
    digest: str = ""

    def point(self, angle: float, amplitude: float, methods=None) -> Point:
        """The work item of one point (``methods``: default all)."""
        return Point(self.scene, self.stop_s, self.instants, angle, amplitude,
                     self.set_angle, self.set_amplitude, tuple(methods or self.methods),
                     self.digest)

    def points(self) -> list[tuple[float, float]]:
        return [(a, m) for a in self.angles for m in self.amplitudes]

    def keys(self, angle: float, amplitude: float) -> list[tuple[str, ...]]:
        """The row keys of one point, in :data:`KEY` order, as the CSV spells them."""
        return [(self.scene, spell(self.stop_s), str(self.instants), spell(angle),
                 spell(amplitude), f, s, self.digest) for f, s in self.methods]


def grid(values: list[str] | None, flag: str = "--angle") -> list[float]:
    """``--angle``/``--amplitude`` values: numbers or ``a:b:n`` (n values from a to b),
    each once as the CSV spells it; at most :data:`MAX_POINTS` of them.
    """
    out: dict[str, float] = {}
    for value in values or ():
        new = _values(value, flag)
        if not all(math.isfinite(v) for v in new):
            raise SweepError(f"{value!r}: values must be finite")
        out.update((spell(v), v) for v in new if spell(v) not in out)
        if len(out) > MAX_POINTS:
            raise SweepError(f"{flag}: {len(out)} values or more; at most {MAX_POINTS}")
    return list(out.values())


def _values(value: str, flag: str) -> list[float]:
    """The values of one ``value`` (a number or ``a:b:n``), its count checked first."""
    parts = value.split(":")
    try:
        if len(parts) == 1:
            return [float(value)]
        if len(parts) != 3 or int(parts[2]) < 1:
            raise ValueError
        first, last, count = float(parts[0]), float(parts[1]), int(parts[2])
    except ValueError:
        raise SweepError(f"{value!r}: expected a number or a:b:n (n >= 1 values from a "
                         "to b)") from None
    if count > MAX_POINTS:
        raise SweepError(f"{flag} {value}: {count} values; at most {MAX_POINTS}")
    return [float(v) for v in np.linspace(first, last, count)]


def _within(values: list[float], most: float, words: str) -> None:
    """Each of ``values`` at most ``most`` in magnitude; else ``words`` (a format of
    ``value`` and ``most``) says why.
    """
    for value in values:
        if not abs(value) <= most:
            raise SweepError(words.format(value=value, most=most))


def plan(args) -> Study:
    """Check the request against the scene's limits and pick each formulation's backend,
    before any work.
    """
    scene = load_scene(args.scene)
    spec = args.scene if args.scene in builtin_names() else str(Path(args.scene).resolve())
    angles = grid((args.angle or []) + (args.angles or []))
    amplitudes = grid(args.amplitude, "--amplitude")
    _within(angles, MAX_ARTICULATION_DEG,
            "--angle {value:g}: |articulation| must be at most {most:g} deg")
    _within(amplitudes, LIMITS["torque_N_m"][1],
            "--amplitude {value:g}: must be at most {most:g} N m in magnitude")
    if amplitudes and scene.input_torque.frequency_hz == 0.0:
        raise SweepError(f"scene {scene.name}: the input torque is constant; --amplitude "
                         "needs a harmonic input torque (frequency_hz > 0)")
    stop_s = QUICK_STOP_S if args.quick and args.stop is None else \
        scene.time.stop_s if args.stop is None else args.stop
    instants = args.instants if args.instants is not None else \
        QUICK_INSTANTS if args.quick else INSTANTS
    if not (math.isfinite(stop_s) and stop_s > scene.time.start_s):
        raise SweepError(f"--stop {stop_s}: must be after the scene's start "
                         f"{scene.time.start_s} s")
    if instants < 1:
        raise SweepError(f"--instants {instants}: must be at least 1")
    if not 1 <= args.workers <= MAX_WORKERS:
        raise SweepError(f"--workers {args.workers}: must be in [1, {MAX_WORKERS}]")
    if not (math.isfinite(args.timeout) and args.timeout > 0):
        raise SweepError(f"--timeout {args.timeout}: must be a finite number of seconds > 0")
    study = Study(
        scene=spec,
        angles=tuple(angles or [scene.joints[0].articulation_deg]),
        amplitudes=tuple(amplitudes or [scene.input_torque.amplitude_N_m]),
        set_angle=bool(angles), set_amplitude=bool(amplitudes),
        methods=(), stop_s=float(stop_s), instants=instants, digest=scene_digest(scene))
    _check_size(study, len(args.formulation or FORMULATIONS))
    _check_window(scene, study)
    return dataclasses.replace(study, methods=tuple(_methods(scene, args.formulation,
                                                             args.solver)))


def _check_size(study: Study, formulations: int) -> None:
    points = len(study.points())
    if points > MAX_POINTS:
        raise SweepError(f"{points} points (angles x amplitudes): at most {MAX_POINTS}")
    solves = points * formulations * study.instants
    if solves > MAX_SOLVES:
        raise SweepError(f"{points} points x {formulations} formulations x {study.instants} "
                         f"instants = {solves} solves: at most {MAX_SOLVES}")


def _check_window(scene: Scene, study: Study) -> None:
    """The scene over the sweep's window, at every amplitude and the largest angle,
    meets the scene limits (instants, span, revolutions, torque periods).
    """
    angle = max(study.angles, key=abs)
    for amplitude in study.amplitudes:
        try:
            variant(scene, study.point(angle, amplitude))
        except SceneError as err:
            raise SweepError(f"--stop {study.stop_s:g} s, --instants {study.instants} at "
                             f"{angle:g} deg and {amplitude:g} N m: "
                             f"{' '.join(str(err).split())}") from None


def _methods(scene: Scene, formulations: list[str] | None, solvers: list[str] | None):
    """``(formulation, backend)`` pairs: the first ``--solver`` that takes the problem,
    else the study layer's default; a formulation the scene does not call for is left
    out unless asked for by name.
    """
    for name in solvers or ():
        get_backend(name)  # an unknown or absent backend: one clear error before any work
    op = build_operator(simulate(scene, [scene.time.start_s]))
    for formulation in formulations or FORMULATIONS:
        try:
            problem = FORMULATIONS[formulation](op, 0)
            yield formulation, default_backend(formulation, problem, solvers)
        except NotApplicable as err:
            if formulations:
                raise SweepError(str(err)) from None
        except NoBackend as err:
            raise SweepError(str(err)) from None


# ---------------------------------------------------------------------------- the sweep


@dataclass(frozen=True)
class SweepResult:
    """What one run of a sweep did: the study's rows and the run's cost."""

    rows: tuple[Row, ...]
    computed: int
    resumed: int
    lost: tuple[str, ...]
    wall_s: float
    backend: str


def sweep(study: Study, out: Path, workers: int, client=None,
          progress: Callable[[str], None] | None = None,
          no_workers_s: float = sweep_exec.NO_WORKERS_S) -> SweepResult:
    """Compute the rows of ``study`` that ``out/sweep.csv`` lacks, appending each point's
    rows as it finishes; ``client``: a Dask client (``None``: a process pool of
    ``workers``), given up after ``no_workers_s`` s without a worker.
    """
    out.mkdir(parents=True, exist_ok=True)
    with locked(out):
        return _sweep(study, out / "sweep.csv", workers, client, progress, no_workers_s)


def _sweep(study: Study, path: Path, workers: int, client, progress, no_workers_s: float
           ) -> SweepResult:
    """:func:`sweep` with the folder held."""
    done = {key_of(r) for r in read_rows(path)}
    tasks = []
    for angle, amplitude in study.points():
        missing = [m for m, key in zip(study.methods, study.keys(angle, amplitude))
                   if key not in done]
        if missing:
            tasks.append(study.point(angle, amplitude, missing))
    n_points = len(study.points())
    resumed = n_points - len(tasks)
    if client is None:
        backend = f"processes ({min(workers, len(tasks)) or workers} workers)"
    else:
        threads = sweep_exec.worker_threads(client, no_workers_s)
        backend = f"dask at {client.scheduler.address} " \
                  f"({'?' if threads is None else threads} worker threads)"
    say = progress or (lambda _: None)
    say(f"sweep: {n_points} points x {len(study.methods)} formulations, {resumed} resumed "
        f"from {path}, {len(tasks)} to run on {backend}")
    start, lost = time.perf_counter(), []
    if tasks:
        lost = _run(tasks, path, workers, client, say, resumed, n_points, no_workers_s)
    wanted = {key: i for i, key in enumerate(k for p in study.points() for k in study.keys(*p))}
    rows = sorted((r for r in read_rows(path) if key_of(r) in wanted),
                  key=lambda r: wanted[key_of(r)])
    return SweepResult(tuple(rows), len(tasks) - len(lost), resumed, tuple(lost),
                       time.perf_counter() - start, backend)


def _run(tasks: list[Point], path: Path, workers: int, client, say, resumed: int,
         n_points: int, no_workers_s: float) -> list[str]:
    """Run ``tasks``, appending rows to ``path``; the points lost to dead workers."""
    start, lost, costs_s = time.perf_counter(), [], []
    results = sweep_exec.pool(tasks, workers) if client is None else \
        sweep_exec.dask(client, tasks, no_workers_s)
    with closing(results), open(path, "a", newline="", encoding="utf-8") as f:
        if f.tell() == 0:
            append(f, [], header=True)
        for k, (task, rows) in enumerate(progress.bar(results, "sweep", len(tasks), "point"),
                                         1):
            point = f"{task.angle_deg:g} deg, {task.amplitude_N_m:g} N m"
            if isinstance(rows, Exception):
                lost.append(f"{point}: {type(rows).__name__}: {rows}")
            else:
                append(f, rows)
                costs_s.append(max(r.total_s for r in rows))
            elapsed = time.perf_counter() - start
            per = f", {np.mean(costs_s):.2f} s/point" if costs_s else ""
            say(f"sweep: {resumed + k}/{n_points} points ({resumed} resumed){per}, "
                f"eta {elapsed / k * (len(tasks) - k):.0f} s")
    return lost


def costs(rows) -> dict[str, float]:
    """Seconds per point (the wall time of its worker call; the slowest of its rows where
    they came from several runs): mean and max, and the mean simulation share.
    """
    by: dict[tuple, list[Row]] = {}
    for r in rows:
        by.setdefault((r.angle_deg, r.amplitude_N_m), []).append(r)
    total = [max(r.total_s for r in g) for g in by.values()]
    simulated = [max(r.simulate_s for r in g) for g in by.values()]
    if not total:
        return {"points": 0, "mean_s": math.nan, "max_s": math.nan, "simulate_mean_s": math.nan}
    return {"points": len(total), "mean_s": float(np.mean(total)), "max_s": max(total),
            "simulate_mean_s": float(np.mean(simulated))}


# ---------------------------------------------------------------------------- reports


SHOWN = ("angle_deg", "amplitude_N_m", "formulation", "solver", "status", "n_solved",
         "max_equilibrium", *PEAKS, "total_s")
"""Columns of the printed and Markdown tables (peaks to 6 significant digits)."""


def _shown(row: Row) -> dict[str, str]:
    def text(k):
        value = getattr(row, k)
        if k in PEAKS:
            return number_text(value, ".6g")
        return number_text(value, FORMATS[k]) if k in FORMATS else spell(value)
    return {k: text(k) for k in SHOWN}


def write_md(result: SweepResult, study: Study, path: Path) -> None:
    """``sweep.md``: settings, the cost per point, the table, the failed rows."""
    c = costs(result.rows)
    failed = [r for r in result.rows if r.status is not Status.SOLVED]
    lines = [
        "# Sweep", "", _settings(study), "",
        f"Backend: {result.backend}. This run computed {result.computed} points and resumed "
        f"{result.resumed} in {result.wall_s:.1f} s.", "",
        "## Cost per point", "",
        f"{c['points']} points: mean {number_text(c['mean_s'], '.3f')} s, max "
        f"{number_text(c['max_s'], '.3f')} s of worker time each (simulation and operator: "
        f"mean {number_text(c['simulate_mean_s'], '.3f')} s).", "",
        "## Rows", "",
        "Peaks in N over the solved instants; most are not determinate in the rigid model: "
        "each is the formulation's member of the solution set (the out-of-plane bearing "
        "load is determinate in the paper's scenes).", "",
        "| " + " | ".join(SHOWN) + " |", "|---" * len(SHOWN) + "|",
    ]
    lines += ["| " + " | ".join(_shown(r).values()) + " |" for r in result.rows]
    lines += ["", "## Rows not solved at every instant", ""]
    lines += [f"- {r.angle_deg:g} deg, {r.amplitude_N_m:g} N m, {r.formulation} "
              f"({r.solver}): {r.status}, {r.message}" for r in failed] or ["none"]
    files.write_text(path, "\n".join([*lines, ""]))


def _settings(study: Study) -> str:
    angles = ", ".join(f"{a:g}" for a in study.angles)
    return (f"Scene {study.scene}, {study.instants} instants over its start .. "
            f"{study.stop_s:g} s; angles (deg, every joint) "
            f"{angles if study.set_angle else angles + ' (the scene as it is)'}; input torque "
            f"amplitudes (N m) {', '.join(f'{a:g}' for a in study.amplitudes)}; "
            "formulation (backend): " + ", ".join(f"{f} ({s})" for f, s in study.methods))


def _typed(row: Row) -> dict:
    """A row for JSON: undefined numbers (``inf``, NaN) as ``None``."""
    out = {}
    for k in COLUMNS:
        value = getattr(row, k)
        out[k] = value.value if isinstance(value, Status) else None if isinstance(
            value, float) and not math.isfinite(value) else value
    return out


# ---------------------------------------------------------------------------- CLI


def add_parser(subparsers) -> None:
    """Register ``cardan sweep``."""
    p = subparsers.add_parser("sweep", help="parameter study: articulation angle x input "
                              "torque amplitude x formulation (resumable CSV)")
    p.add_argument("scene", nargs="?", default="paper", help="built-in name or TOML path")
    p.add_argument("--angle", action="append", metavar="DEG",
                   help="articulation of every joint (repeatable; a:b:n for n values from a "
                        "to b); default the scene's own")
    p.add_argument("--angles", action="append", metavar="A:B:N", help="the same, a:b:n form")
    p.add_argument("--amplitude", action="append", metavar="NM",
                   help="input torque amplitude in N m (repeatable, or a:b:n); default the "
                        "scene's own")
    p.add_argument("--formulation", action="append", type=formulation_name,
                   choices=list(FORMULATIONS),
                   help="one formulation (repeatable); default all the scene calls for")
    p.add_argument("--solver", action="append",
                   help="backend (repeatable; each formulation takes the first that accepts "
                        "it); default a preferred one per formulation")
    p.add_argument("--instants", type=int, metavar="N",
                   help=f"instants per point (default {INSTANTS}; --quick {QUICK_INSTANTS})")
    p.add_argument("--stop", type=float, metavar="S",
                   help="end of each point's window in s (default the scene's stop)")
    p.add_argument("--quick", action="store_true",
                   help=f"{QUICK_INSTANTS} instants over the first {QUICK_STOP_S:g} s")
    p.add_argument("--out", type=files.folder, default="results/sweep",
                   help="folder for sweep.csv and sweep.md (default results/sweep)")
    p.add_argument("--workers", type=int, default=os.cpu_count() or 1,
                   help="local worker processes (default: one per CPU; not with --scheduler)")
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help='run on this Dask scheduler instead (pip install -e ".[dask]")')
    p.add_argument("--timeout", type=float, default=sweep_exec.NO_WORKERS_S,
                   help="seconds to wait for the Dask scheduler, and for a worker when the "
                        "scheduler has none left (then the run ends, keeping its rows; "
                        "default %(default)g)")
    p.add_argument("--json", action="store_true", help="print the rows as JSON")
    p.set_defaults(func=run)


def run(args) -> int:
    """Run the sweep: table (or JSON) on stdout, progress on stderr; 1 if points were
    lost to dead workers (a rerun retries them), 2 for a request that cannot run.
    """
    try:
        study = plan(args)
        client = sweep_exec.connect(args.scheduler, args.timeout) \
            if args.scheduler is not None else None
    except SweepError as err:
        print(f"cardan: error: {err}", file=sys.stderr)
        return 2
    try:
        result = sweep(study, Path(args.out), args.workers, client,
                       progress=progress.line, no_workers_s=args.timeout)
    except SweepError as err:
        print(f"cardan: error: {' '.join(str(err).split())}", file=sys.stderr)
        return 2
    finally:
        if client is not None:
            sweep_exec.close(client, args.timeout)
    write_md(result, study, Path(args.out) / "sweep.md")
    _say_lost(result.lost)
    if args.json:
        print(json_text({"settings": _settings(study), "backend": result.backend,
                         "cost": costs(result.rows),
                         "rows": [_typed(r) for r in result.rows]}))
    else:
        c = costs(result.rows)
        print(f"{_settings(study)}\ncost per point: mean {number_text(c['mean_s'], '.3f')} "
              f"s, max {number_text(c['max_s'], '.3f')} s; {result.backend}")
        table = [dict(zip(SHOWN, SHOWN)), *map(_shown, result.rows)]
        width = {k: max(len(r[k]) for r in table) for k in SHOWN}
        for r in table:
            print(" ".join(r[k].rjust(width[k]) for k in SHOWN))
    files.say_written("sweep", [Path(args.out) / "sweep.csv", Path(args.out) / "sweep.md"],
                      note=f"resumed: {result.resumed} point(s) were there, "
                           f"{result.computed} computed now" if result.resumed else "")
    return 1 if result.lost else 0


def _say_lost(lost: tuple[str, ...], listed: int = 5) -> None:
    """The points lost to this run on stderr: each, or past ``listed`` of them the
    reasons with their counts (a cluster that lost its workers loses every point alike).
    """
    if len(lost) <= listed:
        for message in lost:
            print(f"sweep: lost {message}", file=sys.stderr)
        return
    reasons: dict[str, int] = {}
    for message in lost:
        reason = message.split(": ", 1)[-1]
        reasons[reason] = reasons.get(reason, 0) + 1
    for reason, count in reasons.items():
        print(f"sweep: lost {count} point(s): {reason}", file=sys.stderr)
