"""Running ``cardan bench``: every formulation x backend x mode over an operator's instants.

Each formulation's problems are built once per operator (:func:`prepare`, reported as
one-time setup); a per-instant run then takes its problem and spends its time in the
package's ``solve`` only, split into conversion (the package's and the adapter's
matrices), solver, and checks (residuals and optimality). Batched backends solve the
formulation's batch (:mod:`cardan_forces.formulations.batch`) at once.

Rows are dicts, one per run and instant (a failed run is a row with ``inf`` measures).
"""

from __future__ import annotations

import contextlib
import gc
import math
import time
from dataclasses import dataclass, field

import numpy as np
from cardan_forces.experiments.progress import line
from cardan_forces.experiments.study import solve_over_time
from cardan_forces.formulations import BASELINE, FORMULATIONS, default_backends
from cardan_forces.formulations import batch as fbatch
from cardan_forces.formulations.convex import NotApplicable
from cardan_forces.formulations.problems import LCP, LS, NLS, QP
from cardan_forces.solvers import Residuals, available, backends_for, solve
from cardan_forces.solvers import get as get_backend
from cardan_forces.solvers.judge import objective_value
from cardan_forces.solvers.registry import batch_backends, solve_batch
from cardan_forces.solvers.settings import REFERENCE_TOL
from cardan_forces.solvers.stacking import Stacks, stack_all

TIME_FLOOR_S = 1e-12
"""Least time (s) a count of instants is divided by: a run too short for the clock still
has a finite rate."""

LADDER = (1e-2, 1e-4, 1e-6, 1e-8, 1e-10)
QUICK_LADDER = (1e-4, 1e-8)
SAMPLES, QUICK_SAMPLES = 15, 5
"""Evenly spaced instants of the accuracy runs."""
QUICK_INSTANTS = 41
BUDGET_S = 0.5
"""Seconds after which a per-instant run stops (not the paper's baseline), once it has
:data:`LEAST_INSTANTS`: the bench's largest cost is per-instant runs x formulations."""
LEAST_INSTANTS = 150
"""Instants a per-instant throughput run covers at least, past the budget (the slowest
backends cover only tens in it): its success rate rests on 150 instants (one failure
is 0.7 %, not 3 % of 30), and its checks' constant cost per pass (the pass is
vectorized over the run's instants) is shared by enough of them to show their cost
per instant."""
REPEATS = 200
BATCH_BUDGET_S = 0.5
"""A batched run is repeated for this long (at most ``REPEATS`` times) after one
warm-up run (numba compiles on a process's first call); its time is the fastest repeat
(timeit's rule: other processes only ever add time, so the fastest is the code's own).
The budget, not the count, bounds a quick backend's repeats: on a shared machine a
burst of other work can outlast many short runs."""

QUICK_SOLVERS = (*default_backends(), "qpsolvers-osqp", "lcp-pgs", "numpy-batched", "moreau")
"""The backends of ``--quick``: every formulation's default ones and, beside them, a
first-order QP solver, projected Gauss-Seidel, the batched least norm and moreau."""

MEASURES = ("primal", "dual", "gap", "distance")
SPLIT = ("build_s", "convert_s", "solve_s", "checks_s")
"""Time per instant: taking the problem, conversion and setup, the solver, the checks."""
CHECK_PASSES = 3
"""Check passes over a per-instant throughput run's answers: a row's ``checks_s`` is the
fastest (timeit's rule, as a batched run's time: the pass is the same work each time,
and other processes only ever add time; one pass measured once can read twice what it
did in the run before for the same row), ``checks_first_s`` the first, cold after the solver's
run, which the row's end-to-end ``time_s`` holds (its excess over the fastest is in the
report's "other")."""


def progress(message: str) -> None:
    """A bench progress line on stderr (none with ``--quiet``): :func:`.progress.line`."""
    line(message)


@dataclass
class Prepared:
    """One formulation built once per operator: its problems at every instant, the
    build time, and its batches (built on demand, with their build time). ``stacks``:
    the problems' check data stacked once (:func:`~cardan_forces.solvers.stacking.stack_all`,
    part of the build), which every per-instant run's checks read instead of stacking
    each instant's matrices again.
    """

    name: str
    op: object
    instants: np.ndarray
    problems: list
    build_s: float
    batch_s: dict = field(default_factory=dict)
    stacks: Stacks | None = None

    def batch(self, kind: str, instants=None):
        """The ``"least_norm"`` or ``"conic"`` batch at ``instants`` (default all)."""
        chosen = self.instants if instants is None else np.asarray(instants, int)
        began = time.perf_counter()
        if kind == "least_norm":
            out = fbatch.least_norm_batch(self.op, self.name, chosen)
        else:
            out = fbatch.conic_batch([self.problems[int(i)] for i in chosen], chosen)
        self.batch_s.setdefault(kind, time.perf_counter() - began)
        return out


@contextlib.contextmanager
def frozen():
    """The objects alive now (the bench's prebuilt problems and stacks, the rows of the
    runs before) left out of the garbage collector's scans while a timed run goes
    (``gc.freeze``): a full collection scanning them fell inside whichever instant or
    check pass allocated at the time, a multiple of the checks' own time in a run.
    Garbage is still collected; they are put back after.
    """
    gc.freeze()
    try:
        yield
    finally:
        gc.unfreeze()


def prepare(op, name: str, instants) -> Prepared:
    """Build the formulation's problem at every instant once (timed)."""
    began = time.perf_counter()
    problems = fbatch.build_problems(op, name, instants)
    stacks = stack_all(problems)
    return Prepared(name, op, np.asarray(instants, int), problems, time.perf_counter() - began,
                    stacks=stacks)


def batch_kind(solver: str, prepared: Prepared) -> str | None:
    """Which batch of the formulation the batched backend ``solver`` takes on this
    scene, if any (:func:`~cardan_forces.formulations.batch.batch_kind`).
    """
    return fbatch.batch_kind(get_backend(solver).batch_accepts, prepared.name,
                             prepared.problems[0])


def plan(op, formulations=None, solvers=None, quick=False) -> dict[str, list[str]]:
    """Backends per formulation: per-instant ones that take its problem, then batched
    ones that take its batch; limited to ``solvers`` if given, to :data:`QUICK_SOLVERS`
    when ``quick``. Without ``formulations``, every one the scene calls for. A
    formulation no chosen backend takes is left out (and said so); if that leaves none,
    :class:`NotApplicable` names the backends that would take each, before any solve.
    """
    out, usable = {}, {}
    wanted = QUICK_SOLVERS if quick and solvers is None else solvers
    for name in formulations or FORMULATIONS:
        try:
            problems = fbatch.build_problems(op, name, [0, 1])
        except NotApplicable:
            if formulations:
                raise
            continue
        usable[name] = backends_for(problems[0]) + _batched(op, name, problems)
        out[name] = usable[name] if wanted is None else [s for s in usable[name] if s in wanted]
    left = [name for name, chosen in out.items() if not chosen]
    if left and len(left) == len(out):
        raise NotApplicable(f"no chosen backend ({', '.join(wanted)}) takes " + "; ".join(
            f"{name} (backends that do: {', '.join(usable[name]) or 'none here'})"
            for name in left))
    for name in left:
        progress(f"bench: {name} left out: none of {', '.join(wanted)} takes it")
        del out[name]
    return out


def _batched(op, name: str, problems) -> list[str]:
    """The batched backends that solve the batch of the formulation's ``problems`` (at
    instants 0 and 1) that :func:`batch_kind` gives them.
    """
    found = []
    for kind in fbatch.batch_kinds(name, problems[0]):
        batch = fbatch.make_batch(kind, op, name, problems, [0, 1])
        found += [s for s in batch_backends(batch) if s not in found and fbatch.batch_kind(
            get_backend(s).batch_accepts, name, problems[0]) == kind]
    return found


def _row(formulation, solver, mode, instant, t, status, time_s, split, residuals,
         optimality, iterations=None, message="") -> dict:
    return {"formulation": formulation, "solver": solver, "mode": mode,
            "instant": int(instant), "t_s": float(t), "status": status, "time_s": time_s,
            "checks_first_s": split["checks_s"],
            **split, **{k: float(residuals.get(k, math.inf)) for k in Residuals.KEYS},
            **{k: float(optimality[k]) if k in optimality else math.nan for k in MEASURES},
            "iterations": iterations, "message": message}


def run_instants(prepared: Prepared, solver: str, instants, *, mode="cold", tol=None,
                 budget_s=math.inf, least=1, references=None, check_passes=1) -> list[dict]:
    """One backend on the prepared problems at ``instants`` in order, one row each,
    stopping after ``budget_s`` once ``least`` instants are done.

    ``mode="warm"``: the previous instant's answer is the start. ``references`` maps an
    instant to ``(forces, optimal value)`` of a high-precision solve. ``check_passes``:
    the answers checked that many times, ``checks_s`` the fastest (:data:`CHECK_PASSES`),
    ``checks_first_s`` the first.
    """
    history = solve_over_time(prepared.op, prepared.name, solver, instants=instants, tol=tol,
                              problem=prepared.problems.__getitem__, warm=mode == "warm",
                              budget_s=budget_s, least=least, references=references,
                              stacks=prepared.stacks, check_passes=check_passes)
    rows = []
    for i, t, wall, record in zip(history.instants, history.t, history.wall_s,
                                  history.records):
        split = {"build_s": 0.0, "convert_s": record.setup_s,  # built once, in prepare
                 "solve_s": record.solve_s, "checks_s": record.checks_s}
        row = _row(prepared.name, solver, mode, i, t, record.status, wall, split,
                   record.residuals, record.optimality, record.iterations, record.message)
        if history.checks_s is not None:  # the run's pass, every row's share of it
            row["checks_s"] = history.checks_s  # (a failed build's row: no solve to check)
        rows.append(row)
    return rows


ONCE_STAGES = ("compile",)
"""Stages a batched backend pays once per structure (a generated solver compiled, then
cached): their time in the untimed warm-up run is reported apart, in seconds, as
``"<stage>, once"``."""


def run_batched(prepared: Prepared, solver: str, instants=None, tol=None,
                references=None, repeats: int = REPEATS) -> tuple[list[dict], dict[str, float]]:
    """A batched backend on the formulation's batch: rows (the fastest wall time of up
    to ``repeats`` runs within :data:`BATCH_BUDGET_S` after a warm-up run, spread evenly
    over the instants) and its stage times per instant (with the one-time stages of
    :data:`ONCE_STAGES`, in s).
    """
    batch = prepared.batch(batch_kind(solver, prepared), instants)
    ref = None
    if references is not None:
        ref = np.array([references[int(i)][0] for i in batch.instants])
    warm_up = solve_batch(batch, solver, tol=tol, reference=ref)  # not timed
    runs, spent = [], 0.0
    while len(runs) < repeats and (spent < BATCH_BUDGET_S or len(runs) < 1):
        began = time.perf_counter()
        result = solve_batch(batch, solver, tol=tol, reference=ref)
        runs.append((time.perf_counter() - began, result))
        spent += runs[-1][0]
    wall, result = min(runs, key=lambda run: run[0])
    T = len(batch.instants)
    setup, solve, checks = result.setup_s[0], result.solve_s[0], result.checks_s[0]
    other = wall / T - setup - solve - checks  # per instant, as the results' times
    split = {"build_s": 0.0, "convert_s": setup + max(other, 0.0), "solve_s": solve,
             "checks_s": checks}
    rows = [_row(prepared.name, solver, "batched", i, prepared.op.t[i], result.status[k],
                 wall / T, split, {key: v[k] for key, v in result.residuals.items()},
                 {key: v[k] for key, v in result.optimality.items()},
                 result.iterations[k], result.message[k])
            for k, i in enumerate(batch.instants)]
    stages = {stage: seconds / T for stage, seconds in result.stages.items()}
    once = {f"{stage}, once": seconds for stage, seconds in warm_up.stages.items()
            if stage in ONCE_STAGES and seconds > 0}
    return rows, stages | {"checks": checks} | once


def _is_batched(solver: str) -> bool:
    return get_backend(solver).solve is None


def baseline(solvers: list[str]) -> tuple[str, str] | None:
    """The paper's run that goes over every instant, ``(backend, mode)``: its default
    backend (its :class:`~cardan_forces.formulations.Formulation`'s), warm-started
    where it can be (the paper's method as the paper runs it, the fair baseline).
    """
    chosen = _preferred(BASELINE, solvers)
    if chosen is None:
        return None
    return chosen, "warm" if get_backend(chosen).warm_start else "cold"


def _preferred(formulation: str, solvers: list[str]) -> str | None:
    """The first of the formulation's default backends among ``solvers``
    (:class:`~cardan_forces.formulations.Formulation`'s ``backends``), else the first of
    ``solvers``; ``None`` when there are none.
    """
    return next((s for s in FORMULATIONS[formulation].backends if s in solvers),
                solvers[0] if solvers else None)


def throughput(prepared: Prepared, solvers: list[str], budget_s: float):
    """Rows of every backend x mode on all instants, and the batched stage times.
    Per-instant runs stop after ``budget_s`` once they have :data:`LEAST_INSTANTS`,
    except the paper's baseline (:func:`baseline`), which goes over every instant. Each
    run goes with everything alive before it :func:`frozen`.
    """
    rows, stages = [], {}
    full = baseline(solvers) if prepared.name == BASELINE else None
    _warm_up(prepared, solvers)
    for solver in solvers:
        if _is_batched(solver):
            with frozen():
                new, stages[solver] = run_batched(prepared, solver)
            rows += new
            _report_progress(new)
            continue
        modes = ("cold", "warm") if get_backend(solver).warm_start else ("cold",)
        for mode in modes:
            limit = math.inf if (solver, mode) == full else budget_s
            with frozen():
                new = run_instants(prepared, solver, prepared.instants, mode=mode,
                                   budget_s=limit, least=LEAST_INSTANTS,
                                   check_passes=CHECK_PASSES)
            rows += new
            _report_progress(new)
    return rows, stages


WARM_UP_INSTANTS = 50
"""Instants of the untimed run before a formulation's timed ones (:func:`_warm_up`)."""


def _warm_up(prepared: Prepared, solvers: list[str]) -> None:
    """One untimed run of the formulation's first per-instant backend (its default where
    it is among ``solvers``) over :data:`WARM_UP_INSTANTS` instants: a process's first
    pass over a formulation's code and arrays (cold code, fresh memory) cost its checks
    more than the next pass did, on whichever backend came first. Every other
    per-instant backend solves one instant untimed: a compiled backend's first call
    compiles (or loads) its kernels, which no timed row should hold.
    """
    per_instant = [s for s in solvers if not _is_batched(s)]
    chosen = _preferred(prepared.name, per_instant)
    if chosen is not None:
        run_instants(prepared, chosen, prepared.instants[:WARM_UP_INSTANTS])
    for solver in per_instant:
        if solver != chosen:
            run_instants(prepared, solver, prepared.instants[:1])


def _report_progress(rows: list[dict]) -> None:
    r = rows[0]
    rate = len(rows) / max(sum(x["time_s"] for x in rows), TIME_FLOOR_S)
    solved = sum(x["status"] == "solved" for x in rows)
    progress(f"bench: {r['formulation']:16s} {r['solver']:20s} {r['mode']:7s} "
              f"{len(rows):5d} instants {rate:10.1f}/s, {solved} solved")


def references(prepared: Prepared, samples) -> tuple[dict | None, str, int]:
    """High-precision answers at ``samples``: ``{instant: (forces, optimal value)}``, the
    method's name, and the number of samples where it is not ``solved``.

    Least norm: the SVD (``numpy-kkt``); QP: quadprog's dual active set where installed,
    else Clarabel at :data:`~cardan_forces.solvers.settings.REFERENCE_TOL`; conic: Clarabel
    at it. The paper's root finding and the
    LCP have no objective (their optimality is their own residuals): none.
    """
    problem = prepared.problems[int(samples[0])]
    if isinstance(problem, (NLS, LCP)):
        return None, "none (own residuals)", 0
    if isinstance(problem, LS):
        solver, tol = "numpy-kkt", None
    elif isinstance(problem, QP) and "qpsolvers-quadprog" in available():
        solver, tol = "qpsolvers-quadprog", None
    else:
        solver, tol = "clarabel", REFERENCE_TOL
    refs, unsolved = {}, 0
    for i in samples:
        record = solve(prepared.problems[int(i)], solver, tol=tol)
        unsolved += not record.solved
        if record.status.has_answer:
            refs[int(i)] = (record.x, objective_value(prepared.problems[int(i)], record.z))
    return refs, solver if tol is None else f"{solver} tol {tol:g}", unsolved


def tolerances(solver: str, ladder) -> list[float | None]:
    """The solver's defaults, then the ladder where the backend declares tolerances."""
    return [None, *ladder] if get_backend(solver).tolerances else [None]


def accuracy(prepared: Prepared, solvers: list[str], samples, ladder, budget_s: float,
             found=None):
    """Rows of every backend x tolerance at ``samples`` (less those without a
    reference answer), and the reference used ``(name, samples where not solved)``;
    ``found``: :func:`references` at ``samples`` if already computed.
    """
    refs, name, unsolved = found or references(prepared, samples)
    usable = samples if refs is None else np.array([i for i in samples if int(i) in refs])
    rows = []
    for solver in solvers:
        for tol in tolerances(solver, ladder):
            if _is_batched(solver):
                new = run_batched(prepared, solver, usable, tol=tol, references=refs,
                                  repeats=3)[0]
            else:
                new = run_instants(prepared, solver, usable, tol=tol, budget_s=budget_s,
                                   references=refs)
            rows += [r | {"tol": "default" if tol is None else tol} for r in new]
        progress(f"bench: accuracy {prepared.name:16s} {solver:20s} done")
    return rows, (name, unsolved)
