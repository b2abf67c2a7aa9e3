"""The study layer: solution-set intervals, solve-over-time and the default backend.

Every experiment (``bench``, ``hard``, ``sweep``, ``report``) and the paper's figures
(``paper_repro``) answer questions over the instants of an operator. They do it through
this module, so that each piece of that knowledge has one home:

- :func:`default_backend`: which backend solves a formulation when none is asked for
  (the formulation record's ``backends``, then ``FALLBACK``, then any backend that takes
  it; :mod:`cardan_forces.formulations.registry`), so
  a missing optional package changes the backend, never the outcome;
- :func:`solve_over_time`: one formulation with one backend at every instant, as one
  :class:`History` (a package-judged record per instant; by default through the
  package's own NumPy batches where the formulation's backends list one, the same on
  any install);
- :func:`intervals`, :func:`value_range`, :func:`interval_history`: the rigid solution
  set's interval ``[min, max]`` of each force component (DESIGN §2, "Solution sets"),
  consistent by construction: a determinate component's interval is its one value, and
  ``min <= max`` always.
"""

from __future__ import annotations

import dataclasses
import functools
import gc
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
from cardan_forces.driveline.determinacy import determinacy
from cardan_forces.driveline.equilibrium import Operator
from cardan_forces.formulations import FALLBACK, FORMULATIONS
from cardan_forces.formulations.batch import batch_kind, build_problems, make_batch
from cardan_forces.formulations.sets import feasibility_problem, interval_slack, range_problems
from cardan_forces.solvers import Record, Residuals, Status, backends_for, failed_record, solve
from cardan_forces.solvers import get as get_backend
from cardan_forces.solvers.ranging import HAVE_HIGHSPY, Ranges, ranges
from cardan_forces.solvers.record import Results
from cardan_forces.solvers.registry import (
    Pending,
    SolverNotFound,
    batches,
    check,
    solve_batch,
    solve_unchecked,
    takes,
)
from cardan_forces.solvers.stacking import Stacks

# ---------------------------------------------------------------------------- backends

class NoBackend(ValueError):
    """No installed backend takes a formulation's problem."""


def default_backend(formulation: str, problem, wanted: Sequence[str] | None = None) -> str:
    """The backend that solves ``problem`` (of ``formulation``): the first of ``wanted``
    (default: the formulation's own, then :data:`FALLBACK`, then any) that is installed
    and takes it; :class:`NoBackend` if none does.
    """
    own = FORMULATIONS[formulation].backends if formulation in FORMULATIONS else ()
    order = list(wanted) if wanted else [*own, FALLBACK]
    chosen = next((s for s in order if takes(s, problem)), None)  # loads only these
    if chosen is None and not wanted:
        chosen = next(iter(backends_for(problem)), None)
    if chosen is None:
        usable = backends_for(problem)
        raise NoBackend(f"formulation {formulation}: no backend of {', '.join(order)} takes "
                        f"it; backends that do: {', '.join(usable) or 'none installed'}")
    return chosen


# ---------------------------------------------------------------------------- histories

@dataclass(frozen=True)
class History:
    """One formulation solved by one backend over instants: forces ``(T, n)`` in the
    operator's names (N, N m), NaN where an instant was not ``solved``; the statuses;
    the solver's seconds (setup + solve, summed); each instant's wall time of the
    package's ``solve`` (s); and the run's :class:`~cardan_forces.solvers.record.Results`
    (``None`` for a history that has none, the penalty simulation's).
    """

    formulation: str
    solver: str
    t: np.ndarray
    forces: np.ndarray
    statuses: tuple[Status, ...]
    seconds: float
    instants: tuple[int, ...] = ()
    wall_s: tuple[float, ...] = ()
    results: Results | None = field(default=None, repr=False)
    checks_s: float | None = None
    """The fastest of the check passes over the deferred answers, per instant (s), where
    :func:`solve_over_time` ran more than one (``check_passes``); ``None`` otherwise.
    The results' own ``checks_s`` is the first pass, the one the run's wall time holds."""

    @functools.cached_property
    def records(self) -> tuple[Record, ...]:
        """Each instant's record, made from :attr:`results` when first asked for."""
        return () if self.results is None else tuple(self.results)

    @property
    def solved(self) -> int:
        """Instants whose forces are trusted."""
        return sum(s is Status.SOLVED for s in self.statuses)

    @property
    def status(self) -> Status:
        """The worst status over the instants (``failed`` for an empty history)."""
        return max(self.statuses, default=Status.FAILED)

    def answers(self) -> np.ndarray:
        """Forces ``(T, n)`` of every instant with an answer (``inaccurate`` too)."""
        n = self.forces.shape[1]
        if self.results is None:
            return np.zeros((0, n))
        return np.array([x[:n] if s.has_answer else np.full(n, np.nan)
                         for x, s in zip(self.results.x, self.results.status)]).reshape(-1, n)

    def worst(self, keys: Sequence[str]) -> dict[str, float]:
        """The largest of each residual over the instants (``inf`` where one failed or
        has none of it).
        """
        found = self.results.residuals if self.results is not None else {}
        return {k: float(np.nan_to_num(found[k], nan=math.inf).max(initial=-math.inf))
                if k in found and len(found[k]) else math.inf for k in keys}

    def jumps(self) -> np.ndarray:
        """Per instant ``max_j |x_j(t_i) - x_j(t_{i-1})| / max_{i,j} |x_{i,j}|`` over the
        answered forces: 0 at the first instant, ``inf`` next to an instant without
        forces. The largest is the history's "max jump" (continuity in time).
        """
        x = self.answers()
        finite = np.all(np.isfinite(x), axis=1)
        scale = np.abs(x[finite]).max() if finite.any() else np.inf
        with np.errstate(invalid="ignore"):
            step = np.abs(np.diff(x, axis=0)).max(axis=1, initial=0.0) / max(scale, 1e-300)
        return np.concatenate([[0.0], np.where(finite[1:] & finite[:-1], step, np.inf)])[
            : len(x)]


def solve_over_time(op: Operator, formulation: str, solver: str | None = None, *,
                    instants: Sequence[int] | None = None, tol: float | None = None,
                    problem: Callable[[int], object] | None = None, warm: bool = False,
                    restart: bool = False, budget_s: float = math.inf,
                    least: int = 1, references: dict | None = None,
                    progress: Callable[[str], None] | None = None,
                    stacks: Stacks | None = None, check_passes: int = 1) -> History:
    """``formulation`` solved with ``solver`` at ``instants`` of ``op`` (default all),
    in order. By default the first of the formulation's backends that solves the
    instants as one batch does (:func:`_batched`: the package's own NumPy batches, the
    same answers on any install), else :func:`default_backend` per instant;
    a batch-only ``solver`` solves them as one batch too. A run with its own
    ``problem``, ``references`` or a finite ``budget_s`` goes per instant.

    ``problem(i)`` gives instant ``i``'s problem (default: built by the formulation);
    ``warm``: each instant starts from the previous answer, and with ``restart`` a
    failed warm start is solved again cold (the paper's nonsmooth system can fall off a
    branch, its Sgn of eqs. 35-36); ``budget_s``: stop after this long, once ``least``
    instants (at least one) are solved; ``references``: ``{i: (forces, optimal
    value)}`` for the records' distance and objective gap; ``stacks``:
    ``problem(i)``'s check data stacked beforehand at every instant ``i`` of ``op``
    (:func:`~cardan_forces.solvers.stacking.stack_all`), so the checks do not stack each
    instant's matrices;
    ``check_passes``: times the deferred answers are checked (the records are the first
    pass's; the fastest pass's time per instant is ``History.checks_s``, a benchmark's
    measure of the checks' own cost: the pass is the same work each time, and other
    processes only ever add time). An exception becomes a ``failed`` record, never a
    crash.
    """
    picks = list(range(len(op.t)) if instants is None else instants)
    batch_only = solver is not None and get_backend(solver).solve is None
    whole = problem is None and references is None and math.isinf(budget_s)
    if (solver is None or batch_only) and whole:
        batched = _batched(op, formulation, picks, (solver,) if batch_only else None)
        if batched is not None:
            return batched
    make = problem or (lambda i: FORMULATIONS[formulation](op, i))
    solver = solver or default_backend(formulation, make(picks[0]))
    get_backend(solver)  # an unknown or absent backend is an error, not failed records
    records, walls, start, previous = [], [], time.perf_counter(), None
    for k, i in enumerate(picks):
        if len(records) >= max(least, 1) and time.perf_counter() - start > budget_s:
            break
        began = time.perf_counter()
        record = _solve_one(op, formulation, make, int(i), solver, tol,
                            previous if warm else None, references, defer=not restart)
        if restart and previous is not None and not record.solved:
            record = _solve_one(op, formulation, make, int(i), solver, tol, None, references)
        walls.append(time.perf_counter() - began)
        records.append(record)
        answered = record.status.has_answer and record.z is not None
        previous = np.asarray(record.z, float) if answered else None
        if progress and (k + 1) % 200 == 0:
            progress(f"{formulation} ({solver}) {k + 1}/{len(picks)} instants")
    results, walls, fastest = _checked(records, walls, stacks, picks, check_passes)
    history = history_of(op, formulation, solver, picks[: len(records)], results, walls)
    return history if fastest is None else dataclasses.replace(history, checks_s=fastest)


def _batched(op: Operator, formulation: str, picks: list,
             wanted: Sequence[str] | None = None) -> History | None:
    """``formulation`` at ``picks`` by the first of ``wanted`` (default: its record's
    backends) that solves them as one batch of the kind the scene's problem forms
    (:func:`~cardan_forces.formulations.batch.batch_kind`: ``numpy-batched`` takes the
    least norms, ``newton-batched`` the contact energies, with a clearance too; both
    NumPy, so every install gives the same answers), judged as any run; ``None``
    where none does: the run then goes per instant.
    """
    record = FORMULATIONS.get(formulation)
    if record is None:
        return None
    first, made = record(op, int(picks[0])), {}
    for name in wanted or record.backends:
        backend = _installed(name)
        kind = backend and backend.batch and batch_kind(backend.batch_accepts, formulation,
                                                          first)
        if not kind:
            continue
        if kind not in made:
            problems = build_problems(op, formulation, picks) if kind == "conic" else ()
            made[kind] = make_batch(kind, op, formulation, problems, picks)
        if batches(name, made[kind]):
            began = time.perf_counter()
            results = solve_batch(made[kind], name)
            wall = (time.perf_counter() - began) / len(picks)
            return history_of(op, formulation, name, picks, results, [wall] * len(picks))
    return None


def _installed(name: str):
    """Backend ``name``, ``None`` where it is not installed."""
    try:
        return get_backend(name)
    except SolverNotFound:
        return None


def _checked(records: list, walls: list, stacks, picks,
             passes: int = 1) -> tuple[Results, list[float], float | None]:
    """The deferred solves among ``records`` checked at once (:func:`check`), as the
    run's results, each instant's wall time with its share of the checks (``stacks``:
    the problems' data stacked beforehand, one row per instant, taken at the checked
    ones' ``picks``), and the fastest of ``passes`` checks of them per instant (``None``
    for one pass, or where none was deferred); the results and the wall times are the
    first pass's.

    The solves' young garbage is collected first (``gc.collect(1)``) and that time is
    the solves', spread over the instants: some backends leave hundreds of tracked
    objects an instant, and the collection they made due fell inside the checks
    (a first pass dearer than the next on the same answers).
    """
    deferred = [k for k, r in enumerate(records) if isinstance(r, Pending)]
    if not deferred:
        return Results.of(records), walls, None
    began = time.perf_counter()
    gc.collect(1)
    garbage_s = (time.perf_counter() - began) / len(walls)
    rows = None if stacks is None else stacks.take([picks[k] for k in deferred])
    pending = [records[k] for k in deferred]
    checked = check(pending, rows)
    fastest = None if passes < 2 else min([float(checked.checks_s[0])] + [
        float(check(pending, rows).checks_s[0]) for _ in range(passes - 1)])
    walls = [w + garbage_s for w in walls]
    for k, checks_s in zip(deferred, checked.checks_s.tolist()):
        walls[k] += checks_s
    if len(deferred) < len(records):  # some were checked at once (a restart's): merged
        found = dict(zip(deferred, checked))
        checked = Results.of([found.get(k, r) for k, r in enumerate(records)])
    return checked, walls, fastest


def _solve_one(op: Operator, formulation: str, make, i: int, solver: str, tol, initvals,
               references, defer: bool = False) -> Record | Pending:
    """One instant's record, or with ``defer`` its solve with the checks to come."""
    ref, best = (None, None) if references is None else references.get(i, (None, None))
    try:
        problem = make(i)
    except Exception as exc:  # a problem that cannot be built at this instant
        return _failed(op, formulation, solver, exc)
    try:
        return (solve_unchecked if defer else solve)(problem, solver, tol=tol,
                                                      initvals=initvals, reference=ref,
                                                      optimal_value=best)
    except Exception as exc:  # a backend that rejects this instant's problem
        return failed_record(problem, solver, f"{type(exc).__name__}: {exc}")


def _failed(op: Operator, formulation: str, solver: str, exc: Exception) -> Record:
    """A ``failed`` record for an instant whose problem could not be built."""
    return Record(formulation=formulation, solver=solver, status=Status.FAILED,
                  x=np.full(len(op.names), np.nan), names=op.names, iterations=None,
                  setup_s=0.0, solve_s=0.0, residuals=Residuals(*[math.inf] * 4),
                  message=f"{type(exc).__name__}: {exc}")


def history_of(op: Operator, formulation: str, solver: str, instants: Sequence[int],
               records: Results | Sequence[Record], walls: Sequence[float] = ()) -> History:
    """The :class:`History` of the results (or the records) solved at ``instants`` of
    ``op``, told their instants (``Results.t``).
    """
    t = np.asarray(op.t)[list(instants)]
    results = (records if isinstance(records, Results) else Results.of(list(records))).at(t)
    n = len(op.names)
    forces = np.full((len(results), n), np.nan)
    for k, (x, status) in enumerate(zip(results.x, results.status)):
        if status is Status.SOLVED:
            forces[k] = x[:n]
    return History(formulation, solver, t, forces, tuple(results.status),
                   float(np.sum(results.setup_s + results.solve_s)),
                   tuple(int(i) for i in instants), tuple(walls), results)


# ---------------------------------------------------------------------------- intervals

INTERVAL_SOLVER = "scipy-highs"
"""The LP backend of the intervals (HiGHS: it tells unbounded from infeasible)."""


def value_range(op: Operator, i: int, c: np.ndarray, solver: str = INTERVAL_SOLVER) -> dict:
    """``{"min", "max", "status"}`` of ``c'x`` over the rigid set at instant ``i``
    (:func:`joined_ends` says what the ends become): by the warm ranging as
    :func:`intervals` does, else by :func:`cold_range`.
    """
    return value_ranges(op, i, np.asarray(c, float)[None], solver)[0]


def value_ranges(op: Operator, i: int, C: np.ndarray, solver: str = INTERVAL_SOLVER
                 ) -> list[dict]:
    """:func:`value_range` of each row of ``C`` at instant ``i``, from one warm ranging
    (one model and one feasibility solve for them all).
    """
    C = np.atleast_2d(np.asarray(C, float))
    if solver == INTERVAL_SOLVER and HAVE_HIGHSPY:
        found = ranges(feasibility_problem(op, i), C)
        return [_warm_range(op, i, c, found, k, solver) for k, c in enumerate(C)]
    return [cold_range(op, i, c, solver) for c in C]


def cold_range(op: Operator, i: int, c: np.ndarray, solver: str = INTERVAL_SOLVER) -> dict:
    """:func:`value_range` by two cold LPs through the registry, one per end: the
    reference the warm ranging falls back to.
    """
    ends, statuses = [], []
    for lp in range_problems(op, i, c):
        record = solve(lp, solver)
        statuses.append(record.status)
        ends.append(float(c @ record.x) if record.solved else None)
    return joined_ends(op, i, c, ends, statuses)


def joined_ends(op: Operator, i: int, c: np.ndarray, ends: Sequence[float | None],
                statuses: Sequence[Status]) -> dict:
    """``{"min", "max", "status"}`` from the two LP ends of ``c'x`` and their statuses.

    ``None`` marks an unbounded side, or a side whose LP failed (``status`` then says
    which). Ends that cross by less than :func:`interval_slack` (the LP tolerance scaled
    to the problem) are one value, their mean; ends that cross by more are not
    reported (status ``inconsistent``): ``min <= max`` always.
    """
    fine = all(s in (Status.SOLVED, Status.UNBOUNDED) for s in statuses)
    status = Status.SOLVED.value if fine else "/".join(s.value for s in statuses)
    lo, hi = ends
    if lo is not None and hi is not None and lo > hi:
        if lo - hi > interval_slack(op, i, c):
            return {"min": None, "max": None, "status": "inconsistent"}
        lo = hi = 0.5 * (lo + hi)
    return {"min": lo, "max": hi, "status": status}


def intervals(op: Operator, i: int, solver: str = INTERVAL_SOLVER) -> dict[str, dict]:
    """``{name: {"min", "max", "status"}}`` for every named component at instant ``i``.

    A determinate component (its null-space row vanishes) takes no LP: its interval is
    its one value, ``min = max`` = the least-norm value, when the rigid set is not
    empty; otherwise every component is ``None`` with the feasibility LP's status.
    The others' ends come from :func:`~cardan_forces.solvers.ranging.ranges` (one warm
    HiGHS model per instant, only the objective changing) when ``solver`` is
    :data:`INTERVAL_SOLVER` and ``highspy`` is installed; an end it does not answer
    (a failed or unverified solve) is solved again cold (:func:`cold_range`), as is
    every end with another ``solver``.
    """
    return _intervals_at(op, i, determinacy(op, i), solver)[0]


def _intervals_at(op: Operator, i: int, det, solver: str,
                  start: Ranges | None = None) -> tuple[dict[str, dict], Ranges | None]:
    """:func:`intervals` with instant ``i``'s determinacy ``det`` already known, and the
    warm ranging behind it (``None`` without one), whose basis and rays ``start`` the
    next instant's (:func:`~cardan_forces.solvers.ranging.ranges`).
    """
    free = np.flatnonzero(~det.determinate)
    eye = np.eye(len(op.names))
    warm = solver == INTERVAL_SOLVER and HAVE_HIGHSPY
    found = ranges(feasibility_problem(op, i), eye[free], start) if warm else None
    feasible = found.feasible if warm else None
    if feasible is not Status.SOLVED:  # a set the warm model calls empty is asked again
        feasible = solve(feasibility_problem(op, i), solver).status
    out = {}
    for j, name in enumerate(op.names):
        if feasible is not Status.SOLVED:
            out[name] = {"min": None, "max": None, "status": feasible.value}
        elif det.determinate[j]:
            value = float(det.min_norm[j])
            out[name] = {"min": value, "max": value, "status": "solved"}
        else:
            out[name] = _warm_range(op, i, eye[j], found, int(np.searchsorted(free, j)),
                                    solver)
    return out, found


def _warm_range(op: Operator, i: int, c: np.ndarray, found, k: int, solver: str) -> dict:
    """Row ``k`` of the warm ranging ``found`` as :func:`joined_ends` has it; solved
    cold (:func:`cold_range`) when that row is absent or an end was not answered.
    """
    if found is None or found.feasible is not Status.SOLVED:
        return cold_range(op, i, c, solver)
    statuses = found.statuses[k]
    if any(s not in (Status.SOLVED, Status.UNBOUNDED) for s in statuses):
        return cold_range(op, i, c, solver)
    ends = [None if s is not Status.SOLVED else float(v)
            for s, v in zip(statuses, (found.low[k], found.high[k]))]
    return joined_ends(op, i, c, ends, statuses)


@dataclass(frozen=True)
class IntervalHistory:
    """Intervals over instants: ``min``, ``max`` ``(T, n)`` (N, N m; NaN where a side is
    unbounded or not computed), ``determinate`` ``(T, n)``, ``t`` (s).
    """

    t: np.ndarray
    min: np.ndarray
    max: np.ndarray
    determinate: np.ndarray


def interval_history(op: Operator, instants: Sequence[int] | None = None,
                     progress: Callable[[str], None] | None = None) -> IntervalHistory:
    """:func:`intervals` at ``instants`` of ``op`` (default all), each instant's warm
    ranging started from the feasible basis and the rays of the one before (the same
    answers, verified, in fewer LPs and pivots).
    """
    picks = list(range(len(op.t)) if instants is None else instants)
    shape = (len(picks), len(op.names))
    lo, hi, det = np.full(shape, np.nan), np.full(shape, np.nan), np.zeros(shape, bool)
    start = None
    for k, i in enumerate(picks):
        if progress:
            progress(f"intervals: instant {k + 1}/{len(picks)}")
        found = determinacy(op, i)
        det[k] = found.determinate
        entries, ranged = _intervals_at(op, i, found, INTERVAL_SOLVER, start)
        start = ranged if ranged is not None and ranged.basis is not None else start
        for j, entry in enumerate(entries.values()):
            lo[k, j] = math.nan if entry["min"] is None else entry["min"]
            hi[k, j] = math.nan if entry["max"] is None else entry["max"]
    return IntervalHistory(np.asarray(op.t)[picks], lo, hi, det)
