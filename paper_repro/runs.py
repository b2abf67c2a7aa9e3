"""The simulations and jobs of one ``cardan repro`` run, and the processes they run in.

:class:`_Runs` makes each penalty simulation once per scene (in worker processes when
there are workers, else here on first use) and lists what it made, what for and at what
cost. The rigid-model work of Figs. 13-15 (each method's history, the rigid set's bounds)
is a list of :class:`_Job` queued for the same workers behind the penalty simulations,
dearest first, so that they end together while the main process draws. The one part of
the run that knows about processes, kept apart from the figures and the report.
"""

from __future__ import annotations

import functools
import os
import signal
import time
from collections.abc import Callable
from concurrent.futures import Future, ProcessPoolExecutor
from dataclasses import dataclass
from multiprocessing import get_all_start_methods, get_context

import numpy as np
from cardan_forces.driveline.dynamics import Motion, simulate
from cardan_forces.driveline.equilibrium import Operator, build_operator
from cardan_forces.driveline.penalty import PenaltyResult
from cardan_forces.driveline.scene import Scene
from cardan_forces.experiments.progress import bar

from .histories import history, released, run_penalty
from .methods import JOB_COST
from .request import FIG15_SCENES
from .rigid_set import bearing_quantities, joint_quantities, set_bounds

BOUNDS_JOB_COST = 0.2
"""Relative CPU cost of a figure's rigid-set bounds, on the scale of the formulations'
methods' (:data:`.methods.JOB_COST`): jobs are queued for the
worker processes dearest first, so that they end together."""


class _Runs:
    """The simulations of one ``cardan repro`` run: each penalty simulation made once per
    scene and reused by every figure that shows it, and a list of what was made, what
    for, and how long it took (for the report).

    With ``workers`` > 0 the penalty simulations (the slow part: seconds per simulated
    second each, one per scene) run in that many worker processes, started at once
    (:meth:`start`), while this process solves the rigid-model methods; with 0 each is
    run here on first use.
    """

    def __init__(self, times: np.ndarray, penalty: bool, progress, workers: int = 0):
        self.times, self.penalty, self.progress = times, penalty, progress
        self.workers = workers
        self.penalties: dict[str, PenaltyResult] = {}
        self.pending: dict[str, Future] = {}
        self.pool: ProcessPoolExecutor | None = None
        self.uses: dict[str, list[str]] = {}
        self.motions: list[tuple[str, int, float, str]] = []
        self.load_s: float | None = None
        self.kernel_s: float | None = None
        self.cpu0 = time.process_time()
        self.children0 = sum(os.times()[2:4])  # CPU of ended worker processes

    def start(self, scenes: list[Scene]) -> None:
        """Start the penalty simulations of ``scenes`` (one per released scene) in the
        worker processes; they ignore SIGINT (the main process handles a Ctrl-C).
        """
        todo = {released(s).name: s for s in scenes} if self.penalty else {}
        if not self.workers or not todo:
            return
        start = time.perf_counter()  # compiled kernels loaded here are inherited by fork
        run_penalty(next(iter(todo.values())), self.times[:2])
        self.kernel_s = time.perf_counter() - start
        context = get_context("fork") if "fork" in get_all_start_methods() else None
        self.pool = ProcessPoolExecutor(max_workers=min(self.workers, len(todo)),
                                        mp_context=context, initializer=signal.signal,
                                        initargs=(signal.SIGINT, signal.SIG_IGN))
        self.progress(f"repro: penalty simulations of {', '.join(todo)} started in "
                      f"{self.pool._max_workers} worker processes ...")
        self.pending = {name: self.pool.submit(run_penalty, s, self.times)
                        for name, s in todo.items()}

    def submit(self, fn, *args) -> Future | None:
        """``fn(*args)`` in a worker process (after the penalty simulations), or ``None``
        when there are no workers (the caller then runs it here).
        """
        return None if self.pool is None else self.pool.submit(fn, *args)

    def close(self, interrupted: bool = False) -> None:
        """End the worker processes: at once when ``interrupted`` (the simulations still
        running are lost), else after they finish.
        """
        if self.pool is None:
            return
        workers = list((self.pool._processes or {}).values())  # no public handle (< 3.14)
        self.pool.shutdown(wait=not interrupted, cancel_futures=interrupted)
        if interrupted:
            for process in workers:
                process.terminate()
                process.join(timeout=5.0)
        self.pool = None

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

    def penalty_costs(self) -> dict[str, str]:
        """Each penalty simulation's cost: wall (and CPU) seconds per simulated second."""
        out = {}
        for name, r in self.penalties.items():
            span = max(r.t[-1] - r.t[0], 1e-12)
            out[name] = f"{r.wall_s / span:.2f} ({r.cpu_s / span:.2f} of CPU)"
        return out

    def penalty_result(self, scene: Scene, purpose: str) -> PenaltyResult | None:
        """The penalty simulation of ``released(scene)``: from its worker, or run here on
        first use; reused after.
        """
        if not self.penalty:
            return None
        name = released(scene).name
        if name not in self.penalties:
            if name in self.pending:
                self.progress(f"repro: waiting for the penalty simulation of {name} ...")
                self.penalties[name] = self.pending.pop(name).result()
            else:
                self.progress(f"repro: penalty simulation of {name} ({purpose}) ...")
                self.penalties[name] = run_penalty(scene, self.times, self.progress)
        self.uses.setdefault(name, []).append(purpose)
        return self.penalties[name]

    def lines(self) -> list[str]:
        """What was simulated, what for, and its cost."""
        out = [f"- the first motion's set-up (once per process; it loads the compiled kernels "
               f"where numba is installed): {1e3 * (self.load_s or 0.0):.0f} ms"]
        if self.kernel_s is not None:
            out.append(f"- the penalty kernels loaded (or compiled) once, before the worker "
                       f"processes start (they inherit them): {self.kernel_s:.1f} s")
        out += [f"- motion of `{name}` ({n} instants, 1-DOF): {1e3 * s:.0f} ms, for {why}"
                for name, n, s, why in self.motions]
        out += [f"- penalty simulation `{name}` (made once, used for "
                f"{', '.join(self.uses[name])}): {r.cost_text()}"
                for name, r in self.penalties.items()]
        if not self.penalty:
            out.append("- penalty simulations: not made (`--no-penalty`: the figures show the "
                       "rigid-model methods alone)")
        elif not self.penalties:
            out.append("- penalty simulations: not made (no figure asked for shows one)")
        return out


@dataclass(frozen=True)
class _Job:
    """A piece of rigid-model work: ``fn(op, *args)`` on the operator ``op`` (a worker
    process builds its own from ``op.scene`` and the run's instants); ``key`` names it
    (the same key: the same work, done once), ``cost_s`` orders the queue.
    """

    key: tuple
    cost_s: float
    fn: Callable
    op: Operator
    args: tuple


def _rigid_jobs(scene: Scene, op: Operator, figs, rigid) -> list[_Job]:
    """The rigid-model work of Figs. 13-15 on ``scene`` as jobs: each method's history
    and the rigid set's bounds (13: joint 1's contacts; 14: the first shaft's bearings,
    for Figs. 14 and 15); none without such a figure.
    """
    if not figs:
        return []
    jobs = [_Job((scene, m, None), _cost(m), history, op, (m,)) for m in rigid]
    for number in (13, 14):
        if number in figs or (number == 14 and 15 in figs):
            jobs.append(_Job((scene, number), BOUNDS_JOB_COST, _bounds, op, (number,)))
    return jobs


def _cost(method: str) -> float:
    """A method's relative job cost (:data:`.methods.JOB_COST`; 1 for one not named)."""
    return JOB_COST.get(method, 1.0)


def _bounds(op: Operator, number: int) -> dict:
    """The rigid set's bounds of Fig. 13 (joint 1's contacts) or 14-15 (the bearings)."""
    return set_bounds(op, joint_quantities(op) if number == 13 else bearing_quantities(op))


@functools.lru_cache(maxsize=len(FIG15_SCENES) + 2)
def _operator_of(scene: Scene, times: tuple[float, ...]) -> Operator:
    """``scene``'s operator at ``times``, built once per scene in a worker process for
    all its jobs on that scene.
    """
    return build_operator(simulate(scene, np.array(times)))


def _in_worker(fn: Callable, scene: Scene, times: tuple[float, ...], *args):
    """What a worker process runs for a :class:`_Job`: ``fn`` on ``scene``'s operator."""
    return fn(_operator_of(scene, times), *args)


def _run_jobs(runs: _Runs, jobs: list[_Job]) -> dict:
    """``key -> Future`` of each job (one per key): queued for the worker processes
    behind the penalty simulations, longest first, so that the workers end together
    while this process draws; without workers, done here at once.
    """
    unique = {job.key: job for job in reversed(jobs)}  # the first of a key stays
    order = sorted(unique.values(), key=lambda job: -job.cost_s)
    if runs.pool is None:
        order = bar(order, "repro", unit="job")
    instants, out = tuple(float(t) for t in runs.times), {}
    for job in order:
        future = runs.submit(_in_worker, job.fn, job.op.scene, instants, *job.args)
        if future is None:
            future = Future()
            future.set_result(job.fn(job.op, *job.args))
        out[job.key] = future
    return out


def _rigid_result(runs: _Runs, futures: dict, scene: Scene, figs, rigid) -> dict:
    """The rigid-model work of :func:`_rigid_jobs` on ``scene`` as the figures take it:
    ``{"hist": {method: History}, 13: bounds, 14: bounds}`` (what ``figs`` need).
    """
    if not figs:
        return {"hist": {}}
    keys = [(scene, m, None) for m in rigid] + [(scene, n) for n in (13, 14)
                                                 if (scene, n) in futures]
    if not all(futures[k].done() for k in keys):
        runs.progress(f"repro: waiting for the rigid-model work on {scene.name} ...")
    work = {"hist": {m: futures[(scene, m, None)].result() for m in rigid}}
    return work | {k[1]: futures[k].result() for k in keys[len(rigid):]}
