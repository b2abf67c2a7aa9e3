"""``cardan sweep``: parameter studies, articulation angle x input torque amplitude x
formulation (DESIGN §4).

A point is a variant of one scene (every joint at the angle, the input torque's
amplitude set) simulated at ``--instants`` instants over its window; each requested
formulation is solved at every instant with one backend and summed up in one row:
worst status, worst equilibrium residual, peak loads over time, cost. Points run in a
local process pool, or on a Dask distributed cluster given ``--scheduler``. Each
finished point's rows are appended to ``sweep.csv`` at once, so a killed sweep loses
only the points in flight and a rerun computes only the rows the CSV lacks.
"""

from __future__ import annotations

import csv
import io
import json
import math
import os
import signal
import sys
import time
from collections.abc import Callable, Iterator
from concurrent.futures import ProcessPoolExecutor, as_completed
from contextlib import closing
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
from cardan_forces.driveline.dynamics import simulate
from cardan_forces.driveline.equilibrium import Operator, build_operator
from cardan_forces.driveline.kinematics import Geometry, kinematics
from cardan_forces.driveline.loading import builtin_names, load_scene, scene_from_dict
from cardan_forces.driveline.scene import Scene
from cardan_forces.experiments.environment import number_text
from cardan_forces.formulations import FORMULATIONS
from cardan_forces.formulations.convex import NotApplicable
from cardan_forces.solvers import Record, backends_for, solve
from cardan_forces.solvers import get as get_backend

KEY = ("scene", "stop_s", "instants", "angle_deg", "amplitude_N_m", "formulation", "solver")
"""Columns that name a row: a rerun skips every row whose key is in the CSV."""

PEAKS = ("peak_joint1_N", "peak_joint2_N", "peak_input_radial_N", "peak_input_axial_N",
         "peak_output_radial_N", "peak_input_out_of_plane_N")
"""Peak loads over the solved instants (N), see :func:`peaks`."""

COLUMNS = (*KEY, "status", "n_solved", "max_equilibrium", *PEAKS, "speed_ratio_shaft2_max",
           "speed_ratio_output_max", "simulate_s", "solve_s", "total_s", "message")

FORMATS = {"max_equilibrium": ".2e", "simulate_s": ".4g", "solve_s": ".4g", "total_s": ".4g"}
"""CSV number formats other than 10 significant digits."""

PREFERRED = {
    "paper": ("scipy-fsolve", "scipy-root-lm"),
    "min_norm": ("numpy-kkt",),
    "min_norm_scaled": ("numpy-kkt",),
    "positive": ("qpsolvers-daqp", "clarabel"),
    "compliance": ("qpsolvers-daqp", "clarabel"),
    "lcp": ("lcp-lemke",),
}
"""Backend per formulation when no ``--solver`` is given: the first present that takes
the problem; otherwise ``clarabel``, then the first backend that takes it.
"""

INSTANTS, QUICK_INSTANTS, QUICK_STOP_S = 21, 6, 0.5
"""Instants per point by default; ``--quick``: 6 instants over the first 0.5 s."""


class SweepError(ValueError):
    """A sweep request that cannot be carried out (exit code 2)."""


# ---------------------------------------------------------------------------- one point


def point_scene(task: dict) -> Scene:
    """The scene of one point: ``task["scene"]`` with every joint at ``angle_deg`` (when
    ``joints`` is given) and the input torque's ``amplitude_N_m`` (when ``set_amplitude``).
    """
    over: dict = {"extends": task["scene"], "name": f"sweep-{task['angle_deg']:g}deg-"
                  f"{task['amplitude_N_m']:g}Nm"}
    if task["joints"]:
        over["joints"] = [{**j, "articulation_deg": task["angle_deg"]} for j in task["joints"]]
    if task["set_amplitude"]:
        over["torque"] = {"input": {"amplitude_N_m": task["amplitude_N_m"]}}
    return scene_from_dict(over, source=f"<sweep point of {task['scene']}>")


def run_point(task: dict) -> list[dict]:
    """Simulate one point and solve its ``methods`` (``[formulation, backend]`` pairs):
    one row per method. Never raises: a scene, motion or solver error is a ``failed``
    row with an ``inf`` residual (an empty CSV cell) and the reason. A top-level
    function of plain data, so that a process pool and Dask can ship it.
    """
    start = time.perf_counter()
    base = {k: task[k] for k in KEY if k in task}
    try:
        scene = point_scene(task)
        t = np.linspace(scene.time.start_s, task["stop_s"], task["instants"])
        motion = simulate(scene, t)
        op = build_operator(motion)
    except Exception as exc:  # every point ends as rows, never as a crash
        return [_failed({**base, "formulation": f, "solver": s}, exc, time.perf_counter() - start)
                for f, s in task["methods"]]
    simulate_s = time.perf_counter() - start
    ratios = speed_ratios(motion.geometry)
    rows = []
    for formulation, solver in task["methods"]:
        key = {**base, "formulation": formulation, "solver": solver}
        began = time.perf_counter()
        try:
            records = [solve(FORMULATIONS[formulation](op, i), solver) for i in range(len(t))]
        except Exception as exc:  # NotApplicable to this variant, a backend that rejects it
            rows.append(_failed(key, exc, simulate_s))
            continue
        rows.append({**key, **summarize(records), **peaks(op, motion.geometry, records),
                     **ratios, "simulate_s": simulate_s,
                     "solve_s": time.perf_counter() - began})
    total_s = time.perf_counter() - start
    return [{**row, "total_s": total_s} for row in rows]


def _failed(key: dict, exc: Exception, simulate_s: float) -> dict:
    return {**key, "status": "failed", "n_solved": 0, "max_equilibrium": math.inf,
            "simulate_s": simulate_s, "solve_s": 0.0, "total_s": simulate_s,
            "message": f"{type(exc).__name__}: {exc}"}


def summarize(records: list[Record]) -> dict:
    """Worst status, solved count, worst equilibrium residual, the first complaint."""
    worst = max(records, key=lambda r: r.status)
    return {"status": worst.status, "n_solved": sum(r.solved for r in records),
            "max_equilibrium": max(r.residuals["equilibrium"] for r in records),
            "message": worst.message}


def peaks(op: Operator, geometry: Geometry, records: list[Record]) -> dict[str, float]:
    """Peak loads (N) over the solved instants, NaN where none is or the scene lacks the part.

    - ``peak_joint1_N``, ``peak_joint2_N``: the largest contact force on the first and
      second joint's cross-pin, F1-F8 (a radial force as the length of its 2-vector);
    - ``peak_input_radial_N``, ``peak_output_radial_N``: the largest radial bearing load
      on the first and last shaft (normal to its axis);
    - ``peak_input_axial_N``: the first shaft's axial load, its bearings summed (as the
      paper merges them);
    - ``peak_input_out_of_plane_N``: the first shaft's largest bearing load normal to the
      articulation plane, determinate in the paper's scenes (the others mostly are not:
      they are the chosen formulation's member of the rigid solution set).
    """
    x = np.array([r.x[: len(op.names)] for r in records if r.solved])
    if not len(x):
        return dict.fromkeys(PEAKS, math.nan)
    scene = op.scene
    out = {}
    for k, name in enumerate(("peak_joint1_N", "peak_joint2_N")):
        groups = [list(c.columns) for c in op.of_kind("trunnion-radial", "end-face")
                  if c.joint == k]
        out[name] = _max(np.linalg.norm(x[:, cols], axis=1) for cols in groups)
    bearings = op.of_kind("bearing-locating", "bearing-floating")
    for k, radial in ((0, "peak_input_radial_N"), (len(scene.shafts) - 1,
                                                   "peak_output_radial_N")):
        axis = geometry.axes[k]
        loads = [op.bearing_force(c, x) for c in bearings if c.shaft == k]
        out[radial] = _max(np.linalg.norm(f - np.outer(f @ axis, axis), axis=1) for f in loads)
        if k == 0:
            out["peak_input_axial_N"] = _max([np.abs(sum(f @ axis for f in loads))]) \
                if loads else math.nan
            out["peak_input_out_of_plane_N"] = _max(np.abs(f @ geometry.plane_normal)
                                                    for f in loads)
    return out


def _max(arrays) -> float:
    values = [float(np.max(a)) for a in arrays]
    return max(values) if values else math.nan


def speed_ratios(geometry: Geometry) -> dict[str, float]:
    """Largest speed of the second and the last shaft per unit input speed over one input
    revolution at 0.5 deg steps: ``1 / cos γ`` behind one joint at γ (Cardan fluctuation).
    """
    ratio = kinematics(geometry, np.linspace(0.0, 2.0 * math.pi, 721)).ratio
    return {"speed_ratio_shaft2_max": float(ratio[1].max()),
            "speed_ratio_output_max": float(ratio[-1].max())}


# ---------------------------------------------------------------------------- the study


@dataclass(frozen=True)
class Study:
    """A sweep request, checked: the grid, the backend per formulation, the window."""

    scene: str
    joints: tuple[dict, ...]  # the scene's joints as TOML tables; empty: angles untouched
    angles: tuple[float, ...]
    amplitudes: tuple[float, ...]
    set_amplitude: bool
    methods: tuple[tuple[str, str], ...]
    stop_s: float
    instants: int

    def keys(self, angle: float, amplitude: float) -> list[tuple[str, ...]]:
        """The row keys of one point, in :data:`KEY` order, as the CSV spells them."""
        return [(self.scene, _num(self.stop_s), str(self.instants), _num(angle), _num(amplitude),
                 f, s) for f, s in self.methods]

    def points(self) -> list[tuple[float, float]]:
        return [(a, m) for a in self.angles for m in self.amplitudes]

    def task(self, angle: float, amplitude: float, methods) -> dict:
        """The plain-data work item of :func:`run_point`."""
        return {"scene": self.scene, "stop_s": self.stop_s, "instants": self.instants,
                "angle_deg": angle, "amplitude_N_m": amplitude, "joints": list(self.joints),
                "set_amplitude": self.set_amplitude, "methods": [list(m) for m in methods]}


def grid(values: list[str] | None) -> list[float]:
    """``--angle``/``--amplitude`` values: numbers or ``a:b:n`` (n values from a to b)."""
    out: list[float] = []
    for value in values or ():
        parts = value.split(":")
        try:
            if len(parts) == 1:
                new = [float(value)]
            elif len(parts) == 3 and int(parts[2]) >= 1:
                new = list(np.linspace(float(parts[0]), float(parts[1]), int(parts[2])))
            else:
                raise ValueError
        except ValueError:
            raise SweepError(f"{value!r}: expected a number or a:b:n (n >= 1 values from a "
                             "to b)") from None
        if not all(math.isfinite(v) for v in new):
            raise SweepError(f"{value!r}: values must be finite")
        for v in new:  # once each, as the CSV spells it
            if _num(float(v)) not in map(_num, out):
                out.append(float(v))
    return out


def plan(args) -> Study:
    """Check the request and pick each formulation's backend (on the scene at its start)."""
    scene = load_scene(args.scene)
    spec = args.scene if args.scene in builtin_names() else str(Path(args.scene).resolve())
    angles = grid((args.angle or []) + (args.angles or []))
    amplitudes = grid(args.amplitude)
    torque = scene.input_torque
    if amplitudes and torque.frequency_hz == 0.0:
        raise SweepError(f"scene {scene.name}: the input torque is constant; --amplitude "
                         "needs a harmonic input torque (frequency_hz > 0)")
    stop_s = QUICK_STOP_S if args.quick and args.stop is None else \
        scene.time.stop_s if args.stop is None else args.stop
    instants = args.instants if args.instants is not None else \
        QUICK_INSTANTS if args.quick else INSTANTS
    if not stop_s > scene.time.start_s:
        raise SweepError(f"--stop {stop_s}: must be after the scene's start "
                         f"{scene.time.start_s} s")
    if instants < 1 or args.workers < 1:
        raise SweepError("--instants and --workers must be at least 1")
    return Study(
        scene=spec,
        joints=tuple(asdict(j) for j in scene.joints) if angles else (),
        angles=tuple(angles or [scene.joints[0].articulation_deg]),
        amplitudes=tuple(amplitudes or [torque.amplitude_N_m]),
        set_amplitude=bool(amplitudes),
        methods=tuple(_methods(scene, args.formulation, args.solver)),
        stop_s=float(stop_s),
        instants=instants,
    )


def _methods(scene: Scene, formulations: list[str] | None, solvers: list[str] | None):
    """``(formulation, backend)`` pairs: the first ``--solver`` that takes the problem,
    else :data:`PREFERRED`; a formulation the scene does not call for is left out unless
    asked for by name.
    """
    for name in solvers or ():
        get_backend(name)  # an unknown or absent backend: one clear error before any work
    op = build_operator(simulate(scene, [scene.time.start_s]))
    for formulation in formulations or FORMULATIONS:
        try:
            usable = backends_for(FORMULATIONS[formulation](op, 0))
        except NotApplicable as err:
            if formulations:
                raise SweepError(str(err)) from None
            continue
        wanted = solvers or [*PREFERRED.get(formulation, ()), "clarabel", *usable]
        chosen = next((s for s in wanted if s in usable), None)
        if chosen is None:
            raise SweepError(f"formulation {formulation}: no backend of {', '.join(wanted)} "
                             f"takes it; backends that do: {', '.join(usable) or 'none'}")
        yield formulation, chosen


# ---------------------------------------------------------------------------- CSV


def _num(value, spec: str = ".10g") -> str:
    """How the CSV spells a number: 10 significant digits unless ``spec`` says otherwise;
    an empty cell where it is undefined (``inf``/``nan``).
    """
    if isinstance(value, str):
        return value
    if isinstance(value, (int, np.integer)):
        return str(int(value))
    return number_text(float(value), spec, "")


def _value(cell: str) -> float:
    """A CSV number cell read back: NaN for an empty (undefined) cell."""
    return float(cell) if cell else math.nan


def read_rows(path: Path) -> list[dict]:
    """The rows of an existing ``sweep.csv`` (none if absent). A line cut short by a
    killed sweep is dropped and the file rewritten without it.
    """
    if not path.exists():
        return []
    text = path.read_text()
    whole = text if text.endswith("\n") else text[: text.rfind("\n") + 1]
    reader = csv.DictReader(io.StringIO(whole))
    if reader.fieldnames is not None and tuple(reader.fieldnames) != COLUMNS:
        raise SweepError(f"{path} was written with other columns; choose another --out")
    rows = [r for r in reader if None not in r and None not in r.values()]
    if whole != text or len(rows) != whole.count("\n") - 1:
        with open(path, "w", newline="") as f:
            _write(f, rows, header=True)
    return rows


def _write(f, rows: list[dict], header: bool = False) -> None:
    """Append ``rows`` (and the header) to ``f`` in one write, flushed: an interrupt
    lands before or after a point's rows, never inside a line.
    """
    text = io.StringIO()
    w = csv.DictWriter(text, COLUMNS, lineterminator="\n")
    if header:
        w.writeheader()
    w.writerows({k: " ".join(row[k].split())[:300] if k == "message"
                 else _num(row.get(k, math.nan), FORMATS.get(k, ".10g")) for k in COLUMNS}
                for row in rows)
    f.write(text.getvalue())
    f.flush()


# ---------------------------------------------------------------------------- executors


def _pool(tasks: list[dict], workers: int) -> Iterator[tuple[dict, list[dict] | Exception]]:
    """Run ``tasks`` in a local process pool; yield each with its rows or the error.

    The workers ignore SIGINT (a Ctrl-C reaches the whole process group): the main
    process alone handles it, and on an interrupt (or the generator closed early) drops
    the queued points and ends the workers at once, losing only the points in flight.
    """
    pool = ProcessPoolExecutor(max_workers=min(workers, len(tasks)),
                               initializer=signal.signal,
                               initargs=(signal.SIGINT, signal.SIG_IGN))
    try:
        owner = {pool.submit(run_point, task): task for task in tasks}
        for future in as_completed(owner):
            try:
                yield owner[future], future.result()
            except Exception as exc:  # a worker that died: the point is retried next run
                yield owner[future], exc
    except BaseException:
        _stop(pool)
        raise
    pool.shutdown()


def _stop(pool: ProcessPoolExecutor) -> None:
    """Cancel the queued points and terminate the workers instead of letting them finish
    their points (``shutdown`` alone waits for those at exit).
    """
    workers = list((pool._processes or {}).values())  # no public handle before Python 3.14
    pool.shutdown(wait=False, cancel_futures=True)
    for process in workers:
        process.terminate()
    for process in workers:
        process.join(timeout=5.0)


def connect(address: str, timeout: float):
    """A Dask client on the scheduler at ``address``; :class:`SweepError` if dask is
    missing or the scheduler does not answer within ``timeout`` s.
    """
    try:
        from dask.distributed import Client
    except ImportError:
        raise SweepError('--scheduler needs dask.distributed: pip install -e ".[dask]"') \
            from None
    try:
        return Client(address, timeout=timeout)
    except (OSError, ValueError) as err:
        raise SweepError(f"cannot reach the Dask scheduler at {address}: {err}") from None


def _dask(client, tasks: list[dict]) -> Iterator[tuple[dict, list[dict] | Exception]]:
    """Run ``tasks`` on a Dask cluster; yield each with its rows or the error."""
    from dask.distributed import as_completed as dask_completed

    futures = [client.submit(run_point, task, pure=False) for task in tasks]
    owner = {future.key: task for future, task in zip(futures, tasks)}
    for future in dask_completed(futures):
        try:
            yield owner[future.key], future.result()
        except Exception as exc:  # a lost worker: the point is retried next run
            yield owner[future.key], exc


# ---------------------------------------------------------------------------- the sweep


@dataclass(frozen=True)
class SweepResult:
    """What one run of a sweep did: the study's rows (CSV strings) and the run's cost."""

    rows: tuple[dict, ...]
    computed: int
    resumed: int
    lost: tuple[str, ...]
    wall_s: float
    backend: str


def sweep(study: Study, out: Path, workers: int, client=None,
          progress: Callable[[str], None] | None = None) -> SweepResult:
    """Compute the rows of ``study`` that ``out/sweep.csv`` lacks, appending each point's
    rows as it finishes; ``client``: a Dask client (``None``: a process pool of
    ``workers``).
    """
    out.mkdir(parents=True, exist_ok=True)
    path = out / "sweep.csv"
    done = {tuple(r[k] for k in KEY) for r in read_rows(path)}
    tasks = []
    for angle, amplitude in study.points():
        missing = [m for m, key in zip(study.methods, study.keys(angle, amplitude))
                   if key not in done]
        if missing:
            tasks.append(study.task(angle, amplitude, missing))
    n_points = len(study.points())
    resumed = n_points - len(tasks)
    if client is None:
        backend = f"processes ({min(workers, len(tasks)) or workers} workers)"
    else:
        backend = f"dask at {client.scheduler.address} ({sum(client.nthreads().values())} " \
                  "worker threads)"
    say = progress or (lambda _: None)
    say(f"sweep: {n_points} points x {len(study.methods)} formulations, {resumed} resumed "
        f"from {path}, {len(tasks)} to run on {backend}")
    start, lost, costs = time.perf_counter(), [], []
    if tasks:
        results = _pool(tasks, workers) if client is None else _dask(client, tasks)
        with closing(results), open(path, "a", newline="") as f:  # closing: stop the pool
            if f.tell() == 0:
                _write(f, [], header=True)
            for k, (task, rows) in enumerate(results, 1):
                point = f"{task['angle_deg']:g} deg, {task['amplitude_N_m']:g} N m"
                if isinstance(rows, Exception):
                    lost.append(f"{point}: {type(rows).__name__}: {rows}")
                else:
                    _write(f, rows)
                    costs.append(max(r["total_s"] for r in rows))
                elapsed = time.perf_counter() - start
                per = f", {np.mean(costs):.2f} s/point" if costs else ""
                say(f"sweep: {resumed + k}/{n_points} points ({resumed} resumed){per}, "
                    f"eta {elapsed / k * (len(tasks) - k):.0f} s")
    wanted = {key: i for i, key in enumerate(k for p in study.points() for k in study.keys(*p))}
    rows = sorted((r for r in read_rows(path) if tuple(r[k] for k in KEY) in wanted),
                  key=lambda r: wanted[tuple(r[k] for k in KEY)])
    return SweepResult(tuple(rows), len(tasks) - len(lost), resumed, tuple(lost),
                   time.perf_counter() - start, backend)


def costs(rows) -> dict[str, float]:
    """Seconds per point (the wall time of its worker call; the slowest of its rows where
    they came from several runs): mean and max, and the mean simulation share.
    """
    by: dict[tuple, list[dict]] = {}
    for r in rows:
        by.setdefault((r["angle_deg"], r["amplitude_N_m"]), []).append(r)
    total = [max(float(r["total_s"]) for r in g) for g in by.values()]
    simulated = [max(float(r["simulate_s"]) for r in g) for g in by.values()]
    if not total:
        return {"points": 0, "mean_s": math.nan, "max_s": math.nan, "simulate_mean_s": math.nan}
    return {"points": len(total), "mean_s": float(np.mean(total)), "max_s": max(total),
            "simulate_mean_s": float(np.mean(simulated))}


SHOWN = ("angle_deg", "amplitude_N_m", "formulation", "solver", "status", "n_solved",
         "max_equilibrium", *PEAKS, "total_s")
"""Columns of the printed and Markdown tables (peaks to 6 significant digits)."""


def _shown(row: dict) -> dict[str, str]:
    return {k: number_text(_value(row[k]), ".6g") if k in PEAKS else
            number_text(_value(row[k]), FORMATS[k]) if k in FORMATS else row[k]
            for k in SHOWN}


def write_md(result: SweepResult, study: Study, path: Path) -> None:
    """``sweep.md``: settings, the cost per point, the table, the failed rows."""
    c = costs(result.rows)
    failed = [r for r in result.rows if r["status"] != "solved"]
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
    lines += [f"- {r['angle_deg']} deg, {r['amplitude_N_m']} N m, {r['formulation']} "
              f"({r['solver']}): {r['status']}, {r['message']}" for r in failed] or ["none"]
    path.write_text("\n".join([*lines, ""]))


def _settings(study: Study) -> str:
    angles = ", ".join(f"{a:g}" for a in study.angles)
    return (f"Scene {study.scene}, {study.instants} instants over its start .. "
            f"{study.stop_s:g} s; angles (deg, every joint) "
            f"{angles if study.joints else angles + ' (the scene as it is)'}; input torque "
            f"amplitudes (N m) {', '.join(f'{a:g}' for a in study.amplitudes)}; "
            "formulation (backend): " + ", ".join(f"{f} ({s})" for f, s in study.methods))


def _typed(row: dict) -> dict:
    """A CSV row for JSON: numbers as numbers, undefined ones (an empty cell, or
    ``inf``/``nan`` in a CSV of an older run) as ``None``.
    """
    text = ("scene", "formulation", "solver", "status", "message")
    out = {}
    for k, v in row.items():
        value = v if k in text else _value(v)
        out[k] = v if k in text else None if not math.isfinite(value) else \
            int(value) if k in ("instants", "n_solved") else value
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
    p.add_argument("--formulation", action="append", choices=list(FORMULATIONS),
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
    p.add_argument("--out", default="results/sweep",
                   help="folder for sweep.csv and sweep.md (default results/sweep)")
    p.add_argument("--workers", type=int, default=os.cpu_count() or 1,
                   help="local worker processes (default: one per CPU; not with --scheduler)")
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help='run on this Dask scheduler instead (pip install -e ".[dask]")')
    p.add_argument("--timeout", type=float, default=10.0,
                   help="seconds to wait for the Dask scheduler (default 10)")
    p.add_argument("--json", action="store_true", help="print the rows as JSON")
    p.set_defaults(func=run)


def run(args) -> int:
    """Run the sweep: table (or JSON) on stdout, progress on stderr; 1 if points were
    lost to dead workers (a rerun retries them), 2 for a request that cannot run.
    """
    try:
        study = plan(args)
        client = connect(args.scheduler, args.timeout) if args.scheduler else None
    except SweepError as err:
        print(f"cardan: error: {err}", file=sys.stderr)
        return 2
    try:
        result = sweep(study, Path(args.out), args.workers, client,
                       progress=lambda m: print(m, file=sys.stderr, flush=True))
    finally:
        if client is not None:
            client.close()
    write_md(result, study, Path(args.out) / "sweep.md")
    for message in result.lost:
        print(f"sweep: lost {message}", file=sys.stderr)
    if args.json:
        print(json.dumps({"settings": _settings(study), "backend": result.backend,
                          "cost": costs(result.rows),
                          "rows": [_typed(r) for r in result.rows]}, indent=2))
    else:
        c = costs(result.rows)
        print(f"{_settings(study)}\ncost per point: mean {number_text(c['mean_s'], '.3f')} "
              f"s, max {number_text(c['max_s'], '.3f')} s; {result.backend}")
        table = [dict(zip(SHOWN, SHOWN)), *map(_shown, result.rows)]
        width = {k: max(len(r[k]) for r in table) for k in SHOWN}
        for r in table:
            print(" ".join(r[k].rjust(width[k]) for k in SHOWN))
    return 1 if result.lost else 0
