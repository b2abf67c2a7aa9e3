"""Judging a solver's answer: the package's measures, qpbenchmark's, and the status rule.

An adapter reports an :class:`~.record.Outcome` (a batched backend a
:class:`~.record.BatchOutcome`): the solver's variable ``z``, its multipliers ``y`` in
the rows of the problem's conic form, its own status. This module turns outcomes into
the columns of :class:`~.record.Results`, and every path goes through it:
:func:`finalize_all` judges the outcomes of T instants at once (one vectorized pass per
problem structure; a per-instant loop calls it once at its end, ``registry.check``),
:func:`finalize` is its one-instant case and :func:`finalize_batch` a batched backend's,
so every answer is judged by one rule with the same arithmetic. The solver's word is
not taken:

1. the forces are ``problem.to_forces(z)`` (N); an answer with NaN or inf forces is
   ``failed``;
2. the package's view: the force residuals (``ForceChecks.residuals``) and the
   optimality relative to the data (below);
3. the solver's view: qpbenchmark's measures of the same answer, absolute, on the
   problem as the backend received it, with the solver's own multipliers (below);
4. the status, by the one rule (:func:`judged_status`): an answer is ``solved`` exactly
   where the package's primal residual, dual residual and gap are all within
   :data:`~.record.ACCEPT` (only the primal residual for a root finding, which has no
   multipliers), else ``inaccurate``.

The package's measures (relative). Every convex problem the package builds reaches
Clarabel's standard form (``LS -> QP -> Conic``, ``LP -> Conic``), ``min 1/2 z'Pz + q'z
s.t. A z + s = b, s in K``, whose optimality conditions with multipliers ``y`` are

- primal feasibility: ``s = b - A z in K`` (the package's force residuals, ``ForceChecks``);
- dual feasibility: ``P z + q + A'y = 0`` (stationarity of the Lagrangian) and
  ``y in K*`` (the dual cone);
- zero duality gap: ``(1/2 z'Pz + q'z) - (-1/2 z'Pz - b'y) = 0``.

``dual`` is the largest of the stationarity residual ``||Pz + q + A'y||_inf`` relative to
the largest of ``||Pz||_inf, ||q||_inf, ||A'y||_inf`` and the dual-cone violation
relative to ``||y||_inf``; ``gap`` is the duality gap relative to the larger objective.
Both are dimensionless, so a level such as 1e-6 means the same for a problem in N and
for one in units of the load. In formulas, with ``r = P z + q + A'y``:

- ``primal = max(equilibrium, sign, complementarity, cone)`` of the forces, each over
  ``||b_eq||_2`` (``ForceChecks.residuals``);
- ``dual = max(||r||_inf / max(||Pz||_inf, ||q||_inf, ||A'y||_inf),
  viol_K*(y) / ||y||_inf)``;
- ``gap = |p - d| / max(|p|, |d|)``, ``p = 1/2 z'Pz + q'z``, ``d = -1/2 z'Pz - b'y``
  (or ``|p - p*| / |p*|`` against a high-precision optimal value ``p*`` where the
  multipliers are recovered);
- both 0 where ``P z + q = 0`` (a feasibility problem's ``min 0``): ``y = 0`` satisfies
  stationarity and closes the gap, so a feasible ``z`` is optimal whatever multipliers
  the solver returned (relative to terms that vanish, theirs would measure only
  rounding);
- for an LCP ``w = M z + q``: ``dual = max(0, -min w)`` and ``gap = |z'w|``, relative to
  ``max(||q||_inf, ||z||_inf)`` and its square.

Where a backend returns no multipliers they are recovered (:func:`recover`) by a
nonnegative least-squares solve of stationarity on the constraints active at ``z``: a
row of the nonnegative cone with ``s_i = 0``, a cone block on its boundary (one
multiplier along the block's normal there), a block at its apex (the whole block).

qpbenchmark's measures (absolute): the *solver-optimality* view. It asks only whether
the solver solved the problem it was given, in that problem's own units, with the
solver's own multipliers, exactly as `qpbenchmark
<https://github.com/qpsolvers/qpbenchmark>`_ 2.7 scores a solve through qpsolvers'
``Solution`` methods. For a QP ``min 1/2 x'Px + q'x s.t. Ax = b, Gx <= h, lb <= x <= ub``
with multipliers ``y, z, z_box`` (``Px + q + A'y + G'z + z_box = 0``):

- primal residual ``r_p = max(0, ||Ax - b||_inf, max(Gx - h), max(lb - x), max(x - ub))``;
- dual residual ``r_d = ||Px + q + A'y + G'z + z_box||_inf``;
- duality gap ``r_g = |x'Px + q'x + b'y + h'z + lb'z_box^- + ub'z_box^+|``
  (``v^- = min(v, 0)``, ``v^+ = max(v, 0)``, infinite bounds left out).

All three are in the units of the data (N, N², ...). The same QP in Clarabel's standard
form (:meth:`QP.as_conic`, multipliers ``y_c = (y, z, -z_box^- on finite lb, z_box^+ on
finite ub)``, :func:`~.conversions.qp_duals`) gives the very same numbers: ``A_c'y_c =
A'y + G'z + z_box`` and ``b_c'y_c = b'y + h'z + lb'z_box^- + ub'z_box^+``. So one
function, :func:`conic_residuals`, measures both: for a QP it is qpbenchmark's three
measures; for a conic problem their analogue, the absolute KKT residuals of the standard
form, with the cone's violation in the primal residual (``dist(b - Az, K)``, per block)
and the dual cone's in the dual residual (a QP's multipliers are not sign-checked, as
qpbenchmark does not check them). Both views are made of the same parts
(:class:`Parts`), computed once.

Where the two views differ and why: qpbenchmark's are absolute, so on a least norm in
newtons (objective near 1e9) no exact solver meets a 1e-9 gap while on a small
objective the relative measure is the stricter; the package's ``primal`` is taken on the
forces and includes end-face complementarity, which the physics asks and the QP does
not; the bench's success also asks the distance to a reference where the optimum is
unique.

Arrays are batched: ``q`` (T, n), ``A`` (T, m, n) (or (m, n) for the solver's view),
``b`` (T, m), ``z`` (T, n), ``y`` (T, m); ``P`` (n, n), (T, n, n) or ``None``.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, fields

import numpy as np
from cardan_forces.formulations.batch import LeastNormBatch
from cardan_forces.formulations.problems import (
    LCP,
    LS,
    NLS,
    QP,
    SCALE_FLOOR_N,
    Conic,
    LastMade,
    map_all,
    residuals_batch,
)

from .conversions import convert
from .record import (
    ACCEPT,
    BatchOutcome,
    Optimality,
    Outcome,
    Record,
    Residuals,
    Results,
    Status,
    as_status,
    as_statuses,
    statuses,
)
from .stacking import (
    Stacked,
    Stacks,
    blocks,
    checks_key,
    cone_layout,
    cone_spans,
    conic_key,
    groups,
    kind_key,
    stack_conic,
    stacked_batch,
    times_P,
)

ACTIVE_RTOL = 1e-7
"""A constraint counts as active when its slack is below this, relative to
``max(1, ||b||_inf, ||A z||_inf)``."""

TINY = 1e-300
"""Floor of the denominators of the relative measures (a zero term measures zero)."""

MEASURES = ("primal", "dual", "gap")
"""The three measures of each view, in the order tables show them."""

_AS_SOLVED = np.array(Status.SOLVED, object)
_AS_INACCURATE = np.array(Status.INACCURATE, object)
"""Two members as 0-d object arrays, for numpy: ``np.where`` then puts the members
themselves in its result (a bare member, a ``str``, it would turn into a string)."""


# ------------------------------------------------------------------ the passes

def failed_record(
    problem,
    solver: str,
    message: str,
    setup_s: float = 0.0,
    solve_s: float = 0.0,
    reference: np.ndarray | None = None,
) -> Record:
    """A ``failed`` record: NaN forces, ``inf`` residuals, the reason in ``message``."""
    outcome = Outcome(Status.FAILED, None, message=message, setup_s=setup_s, solve_s=solve_s)
    return finalize(problem, solver, outcome, reference=reference)


def finalize(
    problem,
    solver: str,
    outcome: Outcome,
    reference: np.ndarray | None = None,
    extra_setup_s: float = 0.0,
    optimal_value: float | None = None,
    received=None,
) -> Record:
    """Turn an adapter's outcome into a record, measuring its residuals and optimality
    and deciding the final status from them (``optimal_value``: the problem's optimal
    objective from a high-precision solve, for the objective gap of a record without
    solver duals; ``received``: the problem the backend received, for the
    solver-optimality view).
    One instant of :func:`finalize_all`: one rule for every path.
    """
    return finalize_all([problem], solver, [outcome], references=[reference],
                        optimal_values=[optimal_value], extra_setup_s=[extra_setup_s],
                        received=None if received is None else [received])[0]


def finalize_all(problems, solver: str, outcomes, *, references=None, optimal_values=None,
                 extra_setup_s=None, received=None, elapsed_s=None,
                 stacks: Stacks | None = None) -> Results:
    """Judge T outcomes at once into their :class:`~.record.Results`: :func:`finalize`
    of each, with the residuals and the optimality measured by one vectorized pass per
    problem structure; ``checks_s`` is this call's time over T.

    ``received[k]``: the problem the backend received (after conversion; default the
    problem), for the solver-optimality view; ``elapsed_s[k]``: seconds spent before the
    checks (conversion and solver), giving ``wall_s``. The other lists are per instant
    as :func:`finalize`'s arguments; ``stacks``: the problems' data stacked beforehand
    (:func:`stack_all`; ignored unless it holds exactly ``problems``).
    """
    began, T = time.perf_counter(), len(problems)
    references = references if references is not None else [None] * T
    received = received if received is not None else problems
    stacks = stacks if stacks is not None and stacks.holds(problems) else None
    started = _start_all(problems, outcomes, None if stacks is None else stacks.A.shape[2])
    found = _residuals(problems, started.x if started.X is None else started.X, stacks)
    primal = np.array([found[key] for key in Residuals.KEYS]).reshape(-1, T).max(
        axis=0, initial=-math.inf)
    started.fail_nonfinite(np.flatnonzero(~np.isfinite(primal)).tolist())
    answered = np.array([s.has_answer for s in started.status], bool).reshape(T)
    views = _optimality_all(problems, outcomes, answered, primal,
                            optimal_values if optimal_values is not None else [None] * T,
                            received, stacks)
    reference, distance = _distances(problems, started.x, references)
    optimality = Optimality(primal=views.primal, dual=views.dual, gap=views.gap,
                            distance=distance)
    status = judged_status(started.status, optimality, views.duals)
    columns = _columns(problems, solver, outcomes, started, status, answered,
                       Residuals(**{k: found[k] for k in Residuals.KEYS}, reference=reference),
                       optimality, views, extra_setup_s)
    columns["message"] = _messages(started, status, optimality, found)
    checks_s = np.full(T, (time.perf_counter() - began) / T if T else 0.0)
    before = np.zeros(T) if elapsed_s is None else np.asarray(elapsed_s, float)
    return Results(**columns, checks_s=checks_s, wall_s=before + checks_s)


def finalize_batch(batch, solver: str, outcome: BatchOutcome,
                   reference: np.ndarray | None = None) -> Results:
    """Judge a batched outcome like :func:`finalize_all` judges T instants.

    ``reference`` (T, n): reference forces, giving ``distance`` where the optimum is
    unique (:func:`unique_optimum`). The results' forces ``x`` and the
    solver's ``z`` and ``y`` are (T, .) arrays (every instant has the batch's names);
    a measure no instant has is ``None``; the times are the batch's over T.
    """
    began = time.perf_counter()
    status = np.asarray(outcome.status, object).copy()
    answered = np.isin(status.astype(str), Status.answered())
    x = _batch_forces(batch, outcome, answered)
    bad = answered & ~np.all(np.isfinite(x), axis=1)
    status[bad], answered[bad] = Status.FAILED, False
    x[bad] = np.nan
    residuals = Residuals(**batch.checks.residuals(x))
    optimality, source, y = _batch_optimality(batch, outcome, x, answered, residuals.largest())
    if reference is not None:
        ref = np.asarray(reference, float)
        distance = (np.linalg.norm(x - ref, axis=1)
                    / np.maximum(np.linalg.norm(ref, axis=1), SCALE_FLOOR_N))
        distance[~answered] = np.inf
        residuals = Residuals(**residuals, reference=distance)
        if _unique_batch(batch):
            optimality = Optimality(**optimality, distance=distance)
    reported, status = status, judged_status(status, optimality, source)
    messages = list(outcome.messages) or [""] * len(x)
    for k, note in judged_notes(reported, status, residuals, optimality).items():
        messages[k] = "; ".join(filter(None, (messages[k], note)))
    T = len(x)
    per = np.array([outcome.setup_s, outcome.solve_s, time.perf_counter() - began]) / T
    return Results(
        solver=solver, formulation=(batch.formulation,) * T, names=(batch.checks.names,) * T,
        status=as_statuses(status, Status.FAILED), x=x,
        residuals=residuals, optimality=optimality, solver_optimality=Optimality(),
        iterations=tuple(np.asarray(outcome.iterations, int).tolist()),
        objective=(None,) * T, message=tuple(messages),
        duals=(source,) * T, gap_kind=("duality",) * T,
        solver_status=as_statuses(outcome.status),
        setup_s=np.full(T, per[0]), solve_s=np.full(T, per[1]), checks_s=np.full(T, per[2]),
        wall_s=np.full(T, per.sum()), z=np.asarray(outcome.z),
        y=(None,) * T if y is None else y, stages=dict(outcome.stages))


# ------------------------------------------------------------- the status rule

def judged_status(status, optimality: Optimality, duals):
    """The package's status rule, elementwise: the one place a record is made ``solved``
    (every path, per instant or batched, decides by it).

    An answer (the solver's ``solved`` or ``inaccurate``) is ``solved`` exactly where
    its primal residual, dual residual and gap are all within :data:`ACCEPT`
    (:func:`_optimal`), whatever the solver said: feasibility alone does not
    make an answer the optimum, and a stalled solver's iterate may be one. Where the
    record has no multipliers (``duals`` ``"none"``: a root finding, whose only measure
    is its residual), a reported ``solved`` stays so while its primal residual is
    within :data:`ACCEPT` and nothing can confirm a reported ``inaccurate``. Every other
    answer is ``inaccurate``; a status without an answer is kept. ``duals``: where the
    multipliers came from, one source for all or one per instant.
    """
    status = np.asarray(status, object)
    reported = status == _AS_SOLVED
    answered = reported | (status == _AS_INACCURATE)
    primal = np.asarray(optimality.primal if optimality.primal is not None else np.inf,
                        float)
    optimal = np.where(np.asarray(duals, object) != "none", _optimal(optimality),
                       reported & (primal <= ACCEPT))
    return np.where(answered, np.where(optimal, _AS_SOLVED, _AS_INACCURATE), status)


def _optimal(optimality: Optimality) -> bool | np.ndarray:
    """Primal, dual and gap all within :data:`~.record.ACCEPT` (``False`` if one is
    absent or NaN): the optimality conditions of the module docstring hold.
    """
    if optimality.primal is None or optimality.dual is None or optimality.gap is None:
        return False
    return np.all([np.asarray(v, float) <= ACCEPT for v in (optimality.primal,
                                                              optimality.dual,
                                                              optimality.gap)], axis=0)


def judged_notes(reported, status, residuals, optimality: Optimality) -> dict[int, str]:
    """Why :func:`judged_status` changed the statuses it changed, ``{instant: note}``: a reported
    ``inaccurate`` confirmed, or what keeps an answer from ``solved``: its worst
    residual where that is above :data:`ACCEPT`, else its dual residual or its gap, the
    first above it (``residuals``: each of :attr:`Residuals.KEYS` as a (T,) array).
    """
    status = np.asarray(status, object)
    changed = np.flatnonzero(status != np.asarray(reported, object)).tolist()
    return {k: "confirmed by the package's primal, dual and gap measures"
            if status[k] is Status.SOLVED else _above(k, residuals, optimality)
            for k in changed}


def _above(k: int, residuals, optimality: Optimality) -> str:
    key = max(Residuals.KEYS, key=lambda name: residuals[name][k])
    if not residuals[key][k] <= ACCEPT:
        return f"{key} residual {residuals[key][k]:.1e} > {ACCEPT:.0e}"
    measured = {"dual residual": float(optimality.dual[k]), "gap": float(optimality.gap[k])}
    name = next((n for n, v in measured.items() if not v <= ACCEPT), "gap")
    return f"{name} {measured[name]:.1e} > {ACCEPT:.0e}"


# --------------------------------------------------- one pass over T instants

def _columns(problems, solver: str, outcomes, started: _Started, status, answered,
             residuals: Residuals, optimality: Optimality, views: _Views,
             extra_setup_s) -> dict:
    """The columns of :class:`~.record.Results` the pass found, but its messages and
    times (``status``: the final statuses; ``answered``: where the judged status has
    an answer).
    """
    extra = np.zeros(len(problems)) if extra_setup_s is None else np.asarray(
        extra_setup_s, float)
    return {
        "solver": solver, "formulation": tuple(p.formulation for p in problems),
        "names": tuple(p.checks.names for p in problems), "status": status,
        "x": tuple(started.x), "residuals": residuals, "optimality": optimality,
        "solver_optimality": Optimality(**views.solver),
        "iterations": tuple(None if o.iterations is None else int(o.iterations)
                            for o in outcomes),
        "objective": tuple(float(o.objective) if a and o.objective is not None else None
                           for o, a in zip(outcomes, answered.tolist())),
        "duals": tuple(views.duals.tolist()), "gap_kind": tuple(views.kinds.tolist()),
        "solver_status": statuses(started.solver_status),
        "setup_s": np.array([o.setup_s for o in outcomes], float).reshape(-1) + extra,
        "solve_s": np.array([o.solve_s for o in outcomes], float).reshape(-1),
        "z": tuple(None if o.z is None else np.asarray(o.z) for o in outcomes),
        "y": tuple(views.y)}


@dataclass
class _Started:
    """Status, forces and notes of T outcomes before the checks (:func:`_start_all`):
    ``messages`` the outcomes' own, ``notes`` the notes of the instants the start added
    one to (their message first), kept apart so the others cost nothing; ``X``: the
    forces as one (T, n) array where every answer was mapped at once (``x`` its rows).
    """

    solver_status: list
    status: list
    x: list
    messages: list
    notes: dict = field(default_factory=dict)
    X: np.ndarray | None = None

    def note(self, k: int, text: str) -> None:
        """Add ``text`` to instant ``k``'s notes."""
        first = [self.messages[k]] if self.messages[k] else []
        self.notes[k] = [*self.notes.get(k, first), text]

    def fail_nonfinite(self, candidates) -> None:
        """Mark ``failed`` the answers among ``candidates`` whose forces are NaN or inf."""
        for k in candidates:
            if self.status[k].has_answer and not np.all(np.isfinite(self.x[k])):
                self.status[k] = Status.FAILED
                self.x[k] = np.full(len(self.x[k]), np.nan)
                self.note(k, "ValueError: solver returned NaN or inf")


def _start_all(problems, outcomes, n: int | None = None) -> _Started:
    """:class:`_Started` of every outcome: its status (an unknown one is ``failed``)
    and, where it has an answer, its forces by ``problem.to_forces`` (``n``: the number
    of forces of every problem, where one structure fixes it).
    """
    T = len(problems)
    status = [as_status(o.status) for o in outcomes]
    started = _Started([], [], [None] * T, [o.message or "" for o in outcomes])
    answered = [k for k, s in enumerate(status) if s is not None and s.has_answer]
    X = _stacked_forces(problems, outcomes, answered, n)
    if X is not None and len(answered) == T:  # all mapped at once: nothing per instant
        started.X, started.x = X, list(X)
    else:
        _start_each(problems, outcomes, status, started,
                    {} if X is None else dict(zip(answered, X)), n)
    started.solver_status, started.status = status, list(status)  # the judging turns status
    return started


def _start_each(problems, outcomes, status: list, started: _Started, mapped: dict,
                n: int | None) -> None:
    """:func:`_start_all` instant by instant: an unknown status becomes ``failed``, an
    answer takes its forces from ``mapped`` (``{instant: x}``, those mapped at once) or
    its own ``to_forces``, a missing answer NaN forces.
    """
    for k, first in enumerate(status):
        if first is None:
            status[k] = Status.FAILED
            started.note(k, f"unknown status {outcomes[k].status!r}")
        elif first.has_answer:
            x, why = ((mapped[k], "") if k in mapped else
                      _forces(problems[k], outcomes[k], n or len(problems[k].checks.names)))
            started.x[k] = x
            if why:
                status[k] = Status.FAILED
                started.note(k, why)
    for k in [k for k, x in enumerate(started.x) if x is None]:
        started.x[k] = np.full(n or len(problems[k].checks.names), np.nan)


def _stacked_forces(problems, outcomes, rows: list, n: int | None) -> np.ndarray | None:
    """The forces (len(rows), n) of the answers at ``rows`` by one call, where their
    problems' maps offer one: a ``to_forces`` whose type has ``stacked(maps, Z)`` (the
    points ``Z`` (T, n_z) of the instants of ``maps`` to their forces (T, n), as the
    paper method's map: one vectorized pass instead of a call per instant). ``None``
    where they do not, or where it fails: then each instant is mapped alone, with its
    own error.
    """
    if n is None or not rows:
        return None
    try:
        Z = np.array([outcomes[k].z for k in rows], float)
    except (TypeError, ValueError):  # a missing or ragged answer: found and told per instant
        return None
    X = map_all([problems[k].to_forces for k in rows], Z) if Z.ndim == 2 else None
    return X if X is not None and X.shape == (len(rows), n) else None


def _reference_distance(x: np.ndarray, reference: np.ndarray) -> float:
    ref = np.asarray(reference, float)
    if ref.shape != x.shape or not np.all(np.isfinite(x)):
        return math.inf
    return float(np.linalg.norm(x - ref)) / max(float(np.linalg.norm(ref)), 1e-12)


def _distances(problems, X, references) -> tuple[np.ndarray, np.ndarray]:
    """``||x - x_ref|| / ||x_ref||`` where a reference is given (else NaN), for the
    residuals, and the same only where the optimum is one point, for the optimality
    (:func:`unique_optimum`, decided once per ``P`` object: instants of one
    structure share theirs).
    """
    unique: dict = {}
    distance, where_unique = np.full(len(problems), np.nan), np.full(len(problems), np.nan)
    for k, ref in enumerate(references):
        if ref is None:
            continue
        distance[k] = _reference_distance(X[k], ref)
        P = getattr(problems[k], "P", None)
        key = (type(problems[k]), id(P))  # the problems hold their P while this runs
        if key not in unique:
            unique[key] = unique_optimum(problems[k])
        if unique[key]:
            where_unique[k] = distance[k]
    return distance, where_unique


def _forces(problem, outcome: Outcome, n: int) -> tuple[np.ndarray, str]:
    """The forces of an answered outcome, or NaN and why they are not to be had
    (non-finite forces are found by :func:`finalize_all` for all instants at once).
    """
    try:
        if outcome.z is None:
            raise ValueError("solver returned no solution")
        x = np.asarray(problem.to_forces(np.asarray(outcome.z, float)), float)
        if x.shape != (n,):
            raise ValueError(f"forces have shape {x.shape}, expected {(n,)}")
    except Exception as exc:  # any bad output is a failure, never a crash
        return np.full(n, np.nan), f"{type(exc).__name__}: {exc}"
    return x, ""


def _residuals(problems, X, stacks: Stacks | None) -> dict[str, np.ndarray]:
    """``ForceChecks.residuals`` of every answer (``X``: a list of T force vectors, or
    their (T, n) array), one ``residuals_batch`` per structure (the one of ``stacks``
    where given).
    """
    if stacks is not None:
        c = problems[0].checks
        return residuals_batch(stacks.A, stacks.b, np.asarray(X, float), c.unilateral,
                               c.pairs, c.cones)
    out = {k: np.full(len(X), np.inf) for k in Residuals.KEYS}
    for idx in groups(problems, checks_key):
        c = problems[idx[0]].checks
        found = residuals_batch(np.array([problems[k].checks.A for k in idx]),
                                np.array([problems[k].checks.b for k in idx]),
                                np.array([X[k] for k in idx]), c.unilateral, c.pairs,
                                c.cones)
        for key, value in found.items():
            out[key][idx] = value
    return out


@dataclass
class _Views:
    """The optimality views of T answers, filled group by group (NaN: a measure an
    instant has none of): the package's ``primal``, ``dual``, ``gap``, where the
    multipliers came from (``duals``) and what the gap is (``kinds``), the multipliers
    ``y``, and the solver's view ``solver`` (``{"primal", "dual", "gap"}`` of (T,)).
    """

    primal: np.ndarray
    dual: np.ndarray
    gap: np.ndarray
    duals: np.ndarray
    kinds: np.ndarray
    y: list
    solver: dict


def _optimality_all(problems, outcomes, answered, primal, optimal_values, received,
                    stacks: Stacks | None) -> _Views:
    """The package's optimality (relative) and the solver's (absolute, where the
    problem has a conic form) of T answers.
    """
    T, unanswered = len(problems), ~answered
    views = _Views(primal=primal.copy(), dual=np.full(T, np.nan), gap=np.full(T, np.nan),
                   duals=np.full(T, "none", object), kinds=np.full(T, "", object),
                   y=[None] * T, solver={key: np.full(T, np.nan) for key in MEASURES})
    views.primal[unanswered] = math.inf
    views.dual[unanswered], views.gap[unanswered] = math.inf, math.inf
    live = np.flatnonzero(answered).tolist()
    if stacks is not None and stacks.conic is not None:
        if live:
            st = stacks.conic if len(live) == T else stacks.conic.take(live)
            _conic(problems, outcomes, live, views, optimal_values, received, st)
        return views
    for idx in groups([problems[k] for k in live], kind_key):
        idx = [live[j] for j in idx.tolist()]
        problem = problems[idx[0]]
        if isinstance(problem, LCP):
            _lcp(problems, outcomes, idx, views)
        elif not isinstance(problem, NLS) and conic_key(problem) is not None:
            _conic(problems, outcomes, idx, views, optimal_values, received)
    return views


def _lcp(problems, outcomes, idx, views: _Views) -> None:
    """The LCP's own measures: ``w = Mz + q``, dual ``max(0, -min w)`` and gap
    ``|z'w|``, relative to ``max(||q||_inf, ||z||_inf)`` (and its square).
    """
    M = np.array([np.asarray(problems[k].M, float) for k in idx])
    q = np.array([np.asarray(problems[k].q, float) for k in idx])
    z = np.array([np.asarray(outcomes[k].z, float) for k in idx])
    w = np.einsum("tij,tj->ti", M, z) + q
    unit = np.maximum.reduce([np.abs(q).max(axis=1, initial=0.0),
                              np.abs(z).max(axis=1, initial=0.0), np.full(len(idx), 1e-300)])
    views.dual[idx] = np.maximum(0.0, -w.min(axis=1, initial=0.0)) / unit
    views.gap[idx] = np.abs(np.einsum("ti,ti->t", z, w)) / unit ** 2
    views.duals[idx], views.kinds[idx] = "lcp", "complementarity"
    for k, row in zip(idx, w):
        views.y[k] = row


def _conic(problems, outcomes, idx: list, views: _Views, optimal_values, received,
           st: Stacked | None = None) -> None:
    """Optimality of answers to problems with one conic form (:func:`stack_conic`):
    the package's relative measures with the solver's multipliers (recovered where it
    gave none), and the solver's absolute ones (:func:`from_parts`)
    where it gave them. ``st``: the problems at ``idx`` stacked beforehand.
    """
    st = st if st is not None else stack_conic([problems[k] for k in idx])
    chosen = [outcomes[k] for k in idx]
    z = np.array([o.z for o in chosen], float)
    y, given = multipliers(st, z, [o.y for o in chosen])
    found, solver = _measured(st, z, y, given, isinstance(received[idx[0]], (LS, QP)))
    gap, kinds = found["gap"], np.full(len(idx), "duality", object)
    if not given.all():  # where the solver gave no multipliers, an objective gap
        best = np.array([np.nan if optimal_values[k] is None else optimal_values[k]
                         for k in idx])
        objective_gap = ~given & ~np.isnan(best)
        gap = np.where(objective_gap, np.abs(found["objective"] - best)
                       / np.maximum(np.abs(best), 1e-300), gap)
        kinds[objective_gap] = "objective"
    at = np.array(idx)
    views.dual[at], views.gap[at], views.kinds[at] = found["dual"], gap, kinds
    views.duals[at] = np.where(given, "solver", "recovered")
    for k, row in zip(idx, y):
        views.y[k] = row
    if solver is not None:
        for key in MEASURES:
            views.solver[key][at[given]] = solver[key]


def _measured(st: Stacked, z, y, given, as_qp: bool) -> tuple[dict, dict | None]:
    """The package's measures of the answers ``z`` with multipliers ``y``, and the
    solver's (:func:`from_parts`, of the same parts) of those whose
    multipliers the solver gave (``given``; ``None`` for none; ``as_qp``: the backend
    received a QP or a least norm, whose multipliers are not sign-checked).
    """
    with np.errstate(invalid="ignore", over="ignore"):  # a NaN answer's measures are inf
        found, parts = stacked_measures(st, z, y)
        if not given.any():
            return found, None
        if not given.all():
            st, z, parts = st.take(np.flatnonzero(given)), z[given], parts.take(given)
        return found, from_parts(parts, st.b - st.Az(z), st.cones,
                                 check_dual_cone=not as_qp)


def _messages(started: _Started, status, optimality: Optimality,
              residual: dict) -> list[str]:
    """Each record's message: the outcome's, with the start's notes and why the
    package changed the solver's status, where it did (:func:`judged_notes`;
    ``residual``: key -> (T,) array, never NaN: a non-finite answer's are ``inf``).
    """
    messages = list(started.messages)
    judged = judged_notes(started.status, status, residual, optimality)
    for k in sorted(started.notes.keys() | judged.keys()):
        notes = started.notes.get(k, [messages[k]] if messages[k] else [])
        messages[k] = "; ".join([*notes, judged[k]] if k in judged else notes)
    return messages


# ------------------------------------------------------------ a batched answer

def _batch_forces(batch, outcome: BatchOutcome, answered: np.ndarray) -> np.ndarray:
    if isinstance(batch, LeastNormBatch):
        return np.where(answered[:, None], outcome.z, np.nan)
    X = np.full((len(outcome.z), len(batch.checks.names)), np.nan)
    rows = np.flatnonzero(answered)
    maps = [batch.problems[k].to_forces for k in rows]
    mapped = map_all(maps, outcome.z[rows])
    if mapped is not None:
        X[rows] = mapped
        return X
    for k, f in zip(rows, maps):
        X[k] = f(outcome.z[k])
    return X


def _least_norm_measures(batch: LeastNormBatch, x: np.ndarray, y: np.ndarray):
    """Optimality of ``min 1/2 x'Wx, A x = b, x_signed >= 0`` with conic multipliers ``y``
    (rows ``A``, then ``-e_j`` per signed column).
    """
    m = batch.A.shape[1]
    signed = np.flatnonzero(batch.signed)
    Wx = x if batch.weights is None else batch.weights * x
    Aty = (y[:, None, :m] @ batch.A)[:, 0]
    Aty[:, signed] -= y[:, m:]
    bty = np.einsum("tm,tm->t", batch.b, y[:, :m])
    cone = np.maximum(0.0, -y[:, m:]).max(axis=1, initial=0.0)
    return combine(Wx, np.zeros_like(x), Aty, bty, x, y, cone)


def _batch_optimality(batch, outcome: BatchOutcome, x: np.ndarray, answered, primal):
    if not answered.any():
        inf = np.full(len(answered), np.inf)
        return Optimality(primal=primal, dual=inf, gap=inf.copy()), "none", None
    z = np.where(answered[:, None], outcome.z, 0.0)
    if isinstance(batch, LeastNormBatch):
        found = _least_norm_measures(batch, np.where(answered[:, None], x, 0.0),
                                     outcome.y)
        source = "solver"
    else:
        source = "solver" if outcome.y is not None else "recovered"
        st = _stacked_batch_of(batch)
        y = outcome.y
        if y is None:
            given = [None if a else np.zeros(st.b.shape[1]) for a in answered]
            y = multipliers(st, z, given)[0]  # an unanswered instant's measures are inf
        found = stacked_measures(st, z, y)[0]
    for value in (primal, found["dual"], found["gap"]):
        value[~answered] = np.inf
    return (Optimality(primal=primal, dual=found["dual"], gap=found["gap"]), source,
            outcome.y if isinstance(batch, LeastNormBatch) else y)


_stacked_batch_of = LastMade(lambda batch: stacked_batch(batch.P, batch.q, batch.A,
                                                        batch.b, batch.cones))
"""A conic batch's :func:`~.stacking.stacked_batch` form, made once per batch (a bench
judges one batch many times; finding its patterns costs a pass)."""


def _unique_batch(batch) -> bool:
    if isinstance(batch, LeastNormBatch):
        return True
    return unique_optimum(batch.problems[0]) if np.ndim(batch.P) != 3 else False


# -------------------------------------------- the package's measures (relative)

def inf_norm(v: np.ndarray) -> np.ndarray:
    """``||v||_inf`` along the last axis (0 for none, NaN where ``v`` has a NaN), from
    the largest and the least entry: two reductions that write no (T, n) temporary.
    """
    return np.maximum(v.max(axis=-1, initial=0.0), -v.min(axis=-1, initial=0.0))


def below_zero(v: np.ndarray, spans) -> np.ndarray:
    """``max(0, -min v)`` over the rows ``spans`` (slices) of each instant: how far the
    entries that must be nonnegative go below zero.
    """
    worst = np.zeros(len(v))
    for rows in spans:
        worst = np.maximum(worst, -v[:, rows].min(axis=1))
    return worst


def cone_violation(cones, v: np.ndarray, dual: bool = False) -> np.ndarray:
    """How far each instant's ``v`` (T, m) is outside the cone ``K`` of ``cones`` (a
    slack ``s = b - A z``), or with ``dual`` outside its dual ``K*`` (multipliers
    ``y``): absolute, (T,), >= 0. ``|v_i|`` on zero rows (their dual is free); ``-v_i``
    on nonnegative rows and ``||v_1:|| - v_0`` on a second-order block (both cones are
    self-dual); on a power block ``|w| - u^a x^(1-a)``, or a negative ``u`` or ``x``
    (its dual: ``(u/a)^a (x/(1-a))^(1-a) >= |w|``).
    """
    zeros, nonnegs = cone_spans(tuple(cones))
    _, _, apex, members, mask, pows, alphas = cone_layout(tuple(cones))
    worst = below_zero(v, nonnegs)
    for rows in () if dual else zeros:
        worst = np.maximum(worst, inf_norm(v[:, rows]))
    if len(apex):
        spread = v[:, members] * mask
        spread = np.sqrt(np.einsum("tkj,tkj->tk", spread, spread))
        worst = np.maximum(worst, (spread - v[:, apex]).max(axis=1))
    if len(pows):
        u, x, w = v[:, pows[:, 0]], v[:, pows[:, 1]], v[:, pows[:, 2]]
        su, sx = (alphas, 1.0 - alphas) if dual else (1.0, 1.0)
        mean = (np.maximum(u, 0.0) / su) ** alphas * (np.maximum(x, 0.0) / sx) ** (1.0 - alphas)
        worst = np.maximum(worst, np.maximum(np.abs(w) - mean, -np.minimum(u, x)).max(axis=1))
    return np.maximum(worst, 0.0)


def measures(P, q, A, b, cones, z, y) -> dict[str, np.ndarray]:
    """``{"dual", "gap", "objective"}`` per instant ((T,) arrays; see the module docstring).

    ``objective`` is the primal objective ``1/2 z'Pz + q'z`` (for an objective gap).
    """
    return stacked_measures(stacked_batch(P, q, A, b, cones), z, y)[0]


def stacked_measures(st: Stacked, z: np.ndarray, y: np.ndarray) -> tuple[dict, Parts]:
    """:func:`measures` of answers ``z`` with multipliers ``y`` to the stacked problems
    ``st``, and the :class:`Parts` they were made of (the solver's view is made of the
    same, :func:`from_parts`, so each is computed once).
    """
    parts = Parts.of(times_P(st.P, z), st.q, st.Aty(y), np.einsum("tm,tm->t", st.b, y), z,
                     y, cone_violation(st.cones, y, dual=True))
    return _combined(parts, st.q, y), parts


def combine(Pz, q, Aty, bty, z, y, cone_violation) -> dict[str, np.ndarray]:
    """The measures from their parts (``P z``, ``q``, ``A'y``, ``b'y``, the dual-cone
    violation), for a backend whose problem form gives them more cheaply than
    :func:`measures`' dense products.
    """
    return _combined(Parts.of(Pz, q, Aty, bty, z, y, cone_violation), q, y)


@dataclass(frozen=True)
class Parts:
    """What the measures of T answers ``z`` with multipliers ``y`` are made of, (T,)
    arrays but the products: ``Pz`` and ``Aty`` (T, n); ``dual_cone``, the dual cone's
    violation of ``y`` (``None`` where not measured); ``stationarity``
    ``||Pz + q + A'y||_inf``; ``quad`` ``z'Pz``, ``linear`` ``q'z``, ``bty`` ``b'y``;
    ``bad``: where ``z`` or ``y`` is not finite. The package's view (relative) and the
    solver's (absolute, :func:`from_parts`) are both made of them.
    """

    Pz: np.ndarray
    Aty: np.ndarray
    dual_cone: np.ndarray
    stationarity: np.ndarray
    quad: np.ndarray
    linear: np.ndarray
    bty: np.ndarray
    bad: np.ndarray

    @classmethod
    def of(cls, Pz, q, Aty, bty, z, y, dual_cone) -> Parts:
        """The parts from the products and the dual cone's violation (``None``: not
        measured, for a QP's multipliers).
        """
        bad = ~(np.isfinite(z).all(axis=1) & np.isfinite(y).all(axis=1))
        residual = Pz + q
        residual += Aty
        return cls(Pz, Aty, dual_cone, inf_norm(residual), np.einsum("ti,ti->t", z, Pz),
                   np.einsum("ti,ti->t", q, z), bty, bad)

    def take(self, rows) -> Parts:
        """The parts of the answers at ``rows`` (indices or a mask)."""
        return Parts(*(getattr(self, f.name)[rows] for f in fields(self)))


def _combined(parts: Parts, q, y) -> dict[str, np.ndarray]:
    """The package's measures (the module docstring's formulas) from their parts."""
    stationarity = parts.stationarity / np.maximum(
        np.maximum(inf_norm(parts.Pz), inf_norm(q)), np.maximum(inf_norm(parts.Aty), TINY))
    cone = parts.dual_cone / np.maximum(inf_norm(y), TINY)
    primal = 0.5 * parts.quad + parts.linear
    dual_obj = -0.5 * parts.quad - parts.bty
    gap = np.abs(primal - dual_obj) / np.maximum(np.maximum(np.abs(primal), np.abs(dual_obj)),
                                                 TINY)
    dual = np.maximum(stationarity, cone)
    unforced = inf_norm(parts.Pz + q) == 0.0  # y = 0 certifies it (a feasibility problem)
    dual[unforced], gap[unforced] = 0.0, 0.0
    dual[parts.bad], gap[parts.bad] = np.inf, np.inf
    return {"dual": dual, "gap": gap, "objective": primal}


def _normal(kind: str, alpha: float, s: np.ndarray) -> np.ndarray | None:
    """The outward normal of a cone block's boundary at ``s`` (a direction in K*
    orthogonal to ``s``), or ``None`` at the apex.
    """
    if kind == "soc":
        return None if not np.any(s) else np.concatenate([[s[0]], -s[1:]])
    x, v, w = s
    if x <= 0 or v <= 0:
        return None
    mean = x ** alpha * v ** (1.0 - alpha)
    return np.array([alpha * mean / x, (1.0 - alpha) * mean / v, -np.sign(w)])


def recover(P, q, A, b, cones, z) -> np.ndarray:
    """Multipliers ``y`` (m,) for one instance: nonnegative least squares of
    ``A_act' y_act = -(P z + q)`` on the constraints active at ``z`` (see the module
    docstring); zero on inactive rows.
    """
    from scipy.optimize import lsq_linear

    z, b = np.asarray(z, float), np.asarray(b, float)
    A = np.asarray(A, float)
    s = b - A @ z
    level = ACTIVE_RTOL * max(1.0, float(inf_norm(b)), float(inf_norm(A @ z)))
    columns, lower, owners = [], [], []  # owners: (rows, direction or None)
    for kind, alpha, rows in blocks(cones):
        block = s[rows]
        if kind == "zero":
            cols = [A[r] for r in range(rows.start, rows.stop)]
            columns += cols
            lower += [-np.inf] * len(cols)
            owners += [(slice(r, r + 1), None) for r in range(rows.start, rows.stop)]
        elif kind == "nonneg":
            for r in np.flatnonzero(block <= level) + rows.start:
                columns.append(A[r])
                lower.append(0.0)
                owners.append((slice(r, r + 1), None))
        else:
            margin = (block[0] - np.linalg.norm(block[1:]) if kind == "soc" else
                      np.clip(block[0], 0, None) ** alpha * np.clip(block[1], 0, None)
                      ** (1 - alpha) - abs(block[2]))
            if margin > level:
                continue
            normal = _normal(kind, alpha, block) if inf_norm(block) > level else None
            if normal is None:  # apex: every multiplier of the block, checked by K* later
                for r in range(rows.start, rows.stop):
                    columns.append(A[r])
                    lower.append(-np.inf)
                    owners.append((slice(r, r + 1), None))
            else:
                columns.append(normal @ A[rows])
                lower.append(0.0)
                owners.append((rows, normal))
    y = np.zeros(len(b))
    if not columns:
        return y
    target = -(times_P(P, z[None])[0] + np.asarray(q, float))
    M = np.array(columns).T
    coef = lsq_linear(M, target, bounds=(np.array(lower), np.inf), method="bvls").x
    for value, (rows, normal) in zip(coef, owners):
        y[rows] = value if normal is None else value * normal
    return y


def multipliers(st: Stacked, z: np.ndarray, given: list) -> tuple[np.ndarray, np.ndarray]:
    """``y`` (T, m) of answers ``z`` (T, n) to the stacked problems ``st``: the solver's
    ``given[k]`` where it has one of length m, else recovered (:func:`recover`); and the
    mask of the instants whose multipliers the solver gave. The one place both the
    per-instant checks and a batch's find their multipliers.
    """
    m = st.b.shape[1]
    mask = [g is not None and len(g) == m for g in given]
    y = np.array(given if all(mask) else [
        given[k] if mask[k] else recover(st.Pk(k), st.q[k], st.A(k), st.b[k], st.cones, z[k])
        for k in range(len(z))], float).reshape(len(z), m)
    return y, np.array(mask, bool)


def unique_optimum(problem) -> bool:
    """Whether the problem's optimum is one point, known from its data: a least norm
    (positive weights) or a positive definite ``P`` (strictly convex objective).
    A distance to a reference point means something only then.
    """
    if isinstance(problem, LS):
        return True
    if isinstance(problem, (QP, Conic)) and problem.P is not None:
        try:
            np.linalg.cholesky(np.asarray(problem.P, float))
        except np.linalg.LinAlgError:
            return False
        return True
    return False


def objective_value(problem, z) -> float | None:
    """The objective ``1/2 z'Pz + q'z`` of an LS, QP, LP or conic problem at ``z`` (in
    its conic form; the same value along every conversion), ``None`` for the others.
    """
    conic = convert(problem, (Conic,))
    if conic is None or z is None:
        return None
    z = np.asarray(z, float)
    return float(0.5 * z @ times_P(conic.P, z[None])[0] + np.asarray(conic.q, float) @ z)


# ------------------------------------------ qpbenchmark's measures (absolute)

def conic_residuals(P, q, A, b, cones, z, y, *, check_dual_cone: bool) -> dict:
    """Absolute primal, dual and gap of answers to a conic problem, per instant.

    Answers ``z`` with multipliers ``y`` (Clarabel's convention ``Pz + q + A'y = 0``) to
    ``min 1/2 z'Pz + q'z s.t. Az + s = b, s in K``; ``(T,)`` arrays:

    - ``primal = dist-like violation of b - Az in K``
      (:func:`cone_violation`);
    - ``dual = ||Pz + q + A'y||_inf``, and the dual cone's violation of ``y`` when
      ``check_dual_cone`` (conic problems; not for a QP, as qpbenchmark);
    - ``gap = |z'Pz + q'z + b'y|``.

    ``inf`` where the answer or the multipliers are missing or not finite.
    """
    A = np.asarray(A, float)
    z, y = np.asarray(z, float), np.asarray(y, float)
    bad = ~(np.all(np.isfinite(z), axis=1) & np.all(np.isfinite(y), axis=1))
    z, y = np.where(bad[:, None], 0.0, z), np.where(bad[:, None], np.nan, y)
    Az = z @ A.T if A.ndim == 2 else np.matmul(A, z[:, :, None])[:, :, 0]
    Aty = y @ A if A.ndim == 2 else np.matmul(y[:, None, :], A)[:, 0]
    return residuals_from(times_P(P, z), q, Az, Aty, b, cones, z, y,
                          check_dual_cone=check_dual_cone)


def residuals_from(Pz, q, Az, Aty, b, cones, z, y, *, check_dual_cone: bool) -> dict:
    """:func:`conic_residuals` from the products ``P z``, ``A z`` and ``A'y`` (for
    stacked data whose products are cheaper than dense ones, e.g. a QP's bound rows).
    """
    z, y, b, q = (np.asarray(v, float) for v in (z, y, b, q))
    with np.errstate(invalid="ignore", over="ignore"):
        parts = Parts.of(Pz, q, Aty, np.einsum("tm,tm->t", b, y), z, y,
                         cone_violation(cones, y, dual=True) if check_dual_cone else None)
    return from_parts(parts, b - Az, cones, check_dual_cone=check_dual_cone)


def from_parts(parts: Parts, slack: np.ndarray, cones, *, check_dual_cone: bool) -> dict:
    """:func:`conic_residuals` from the :class:`Parts` of the package's
    measures of the same answers (:func:`stacked_measures`) and the slack
    ``b - A z``: the same three numbers without computing their parts again.
    """
    dual = (np.maximum(parts.stationarity, parts.dual_cone) if check_dual_cone
            else parts.stationarity.copy())
    with np.errstate(invalid="ignore", over="ignore"):
        out = {"primal": cone_violation(cones, slack), "dual": dual,
               "gap": np.abs(parts.quad + parts.linear + parts.bty)}
    for value in out.values():
        value[parts.bad] = np.inf
    return out


def qp_residuals(qp, found: bool, x, y, z, z_box) -> dict[str, float]:
    """The three measures of qpbenchmark for one qpsolvers answer ``x``.

    With qpsolvers' multipliers ``y, z, z_box`` (each ``None`` where qpsolvers gave
    none) to ``qp`` (a package ``QP``), by the formulas of the module docstring, term for term as
    ``qpsolvers.Solution.primal_residual``, ``dual_residual`` and ``duality_gap``:
    ``inf`` when the solver did not report ``found``, without ``x``, or without a
    multiplier that the problem's constraints need.
    """
    if not found or x is None:
        return dict.fromkeys(MEASURES, np.inf)
    x, P, q = np.asarray(x, float), np.asarray(qp.P, float), np.asarray(qp.q, float)
    parts = {"A": (qp.A, qp.b, y), "G": (qp.G, qp.h, z)}
    primal = [0.0] + [float(np.max(bound - x)) for bound in (qp.lb,) if bound is not None]
    primal += [float(np.max(x - bound)) for bound in (qp.ub,) if bound is not None]
    stationarity, gap, missing = P @ x + q, x @ P @ x + q @ x, False
    for key, (M, v, mult) in parts.items():
        if M is None:
            continue
        r = np.asarray(M, float) @ x - np.asarray(v, float)
        primal.append(float(np.max(np.abs(r) if key == "A" else r)))
        if mult is None:
            missing = True
            continue
        stationarity = stationarity + np.asarray(M, float).T @ np.asarray(mult, float)
        gap += float(np.asarray(v, float) @ np.asarray(mult, float))
    if qp.lb is not None or qp.ub is not None:
        if z_box is None:
            missing = True
        else:
            zb = np.asarray(z_box, float)
            stationarity = stationarity + zb
            for bound, part in ((qp.lb, np.minimum(zb, 0.0)), (qp.ub, np.maximum(zb, 0.0))):
                if bound is not None:
                    keep = np.isfinite(bound)
                    gap += float(np.asarray(bound, float)[keep] @ part[keep])
    dual = np.inf if missing else float(np.abs(stationarity).max(initial=0.0))
    return {"primal": max(primal), "dual": dual, "gap": np.inf if missing else abs(gap)}


def solver_optimality(received, z, y) -> dict[str, float]:
    """The three measures of one answer ``z`` (``y``: multipliers in the rows of the
    received problem's conic form, ``None``: none given) to the problem a backend
    received (an ``LS``, ``QP`` or ``Conic``): qpbenchmark's for a QP or least norm, the
    conic KKT analogue for a conic problem. ``inf`` without an answer or multipliers
    (qpbenchmark's value for a missing dual).
    """
    conic = convert(received, (Conic,))
    if z is None or y is None or conic is None:
        return dict.fromkeys(MEASURES, np.inf)
    found = conic_residuals(conic.P, np.asarray(conic.q, float)[None], conic.A,
                            np.asarray(conic.b, float)[None], conic.cones,
                            np.asarray(z, float)[None], np.asarray(y, float)[None],
                            check_dual_cone=not isinstance(received, (LS, QP)))
    return {k: float(v[0]) for k, v in found.items()}
