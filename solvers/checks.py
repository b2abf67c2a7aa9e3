"""The check pass: adapters' outcomes judged into a run's :class:`~.record.Results`.

:func:`finalize_all` judges the outcomes of many instants at once (one vectorized pass
per problem structure): the forces by ``problem.to_forces``, their residuals by
``problem.checks`` (``ForceChecks``), the package's optimality (:mod:`.optimality`)
and the solver's (:mod:`.qp_measures`), and the status by the one rule of
:mod:`.record` (:func:`~.record.judge`). A per-instant loop
calls it once at its end (``registry.check``); :func:`finalize` is its one-instant case,
so every path, whatever its length, follows one rule by the same arithmetic.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np
from cardan_forces.formulations.problems import LCP, LS, NLS, QP, map_all, residuals_batch

from .optimality import multipliers, stacked_measures, unique_optimum
from .qp_measures import MEASURES, from_parts
from .record import (
    Optimality,
    Outcome,
    Record,
    Residuals,
    Results,
    Status,
    as_status,
    judge,
    judged_notes,
    statuses,
)
from .stacking import Stacked, Stacks, checks_key, conic_key, groups, kind_key, stack_conic


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
    status = judge(started.status, optimality, views.duals)
    columns = _columns(problems, solver, outcomes, started, status, answered,
                       Residuals(**{k: found[k] for k in Residuals.KEYS}, reference=reference),
                       optimality, views, extra_setup_s)
    columns["message"] = _messages(started, status, optimality, found)
    checks_s = np.full(T, (time.perf_counter() - began) / T if T else 0.0)
    before = np.zeros(T) if elapsed_s is None else np.asarray(elapsed_s, float)
    return Results(**columns, checks_s=checks_s, wall_s=before + checks_s)


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
    (:func:`~.optimality.unique_optimum`, decided once per ``P`` object: instants of one
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
    gave none), and the solver's absolute ones (:func:`~.qp_measures.from_parts`)
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
    solver's (:func:`~.qp_measures.from_parts`, of the same parts) of those whose
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
    package changed the solver's status, where it did (:func:`~.record.judged_notes`;
    ``residual``: key -> (T,) array, never NaN: a non-finite answer's are ``inf``).
    """
    messages = list(started.messages)
    judged = judged_notes(started.status, status, residual, optimality)
    for k in sorted(started.notes.keys() | judged.keys()):
        notes = started.notes.get(k, [messages[k]] if messages[k] else [])
        messages[k] = "; ".join([*notes, judged[k]] if k in judged else notes)
    return messages
