"""The solution record: what every solver call returns, judged by the package (DESIGN §3).

An adapter reports an :class:`Outcome` in the solver's own variable ``z``;
:func:`finalize` maps it to forces with ``problem.to_forces``, measures the residuals
with ``problem.checks`` and decides the final :class:`Status`. The solver's word is only
an upper bound: a reported success whose residuals exceed :data:`ACCEPT` becomes
``inaccurate``, and a success with NaN or inf output becomes ``failed``.

:func:`finalize_all` judges the outcomes of many instants at once (one vectorized pass
per problem structure: residuals, the package's optimality and the solver's); a
per-instant loop calls it once at its end (``registry.solve_unchecked``, ``check``),
and :func:`finalize` is its one-instant case, so every path follows one rule.

Why one module this long: the record's types (:class:`Status`, :class:`Residuals`,
:class:`Optimality`) and the rule that fills them are the package's one status rule,
kept in one place so that no caller judges a solve another way.
"""

from __future__ import annotations

import collections
import enum
import functools
import itertools
import math
import operator
import time
from collections.abc import Iterator, Mapping
from dataclasses import MISSING, dataclass, field, fields
from typing import ClassVar

import numpy as np
from cardan_forces.formulations.problems import (
    LCP,
    LS,
    NLS,
    QP,
    RESIDUALS,
    map_all,
    residuals_batch,
)

from .optimality import (
    Stacked,
    compiled_views,
    conic_key,
    multipliers,
    stack_conic,
    stacked_measures,
    unique_optimum,
)
from .qp_measures import from_parts


class Status(str, enum.Enum):
    """Every status a record can carry, ordered from best to worst (a run over several
    instants carries its worst: ``max``); only ``SOLVED`` means the forces are trusted.

    A ``str`` enum: ``Status.SOLVED == "solved"``, and it prints, hashes and goes to
    JSON as its value, so statuses read back from CSV or JSON compare as they did.
    """

    SOLVED = "solved"
    INACCURATE = "inaccurate"
    UNBOUNDED = "unbounded"
    INFEASIBLE = "infeasible"
    FAILED = "failed"

    @property
    def has_answer(self) -> bool:
        """Whether the record carries forces (``SOLVED`` or ``INACCURATE``)."""
        return self in _ANSWERED

    @classmethod
    def answered(cls) -> tuple[str, ...]:
        """The values of the statuses with an answer (for ``np.isin`` on status arrays)."""
        return tuple(s.value for s in cls if s.has_answer)

    @property
    def rank(self) -> int:
        """Position from best (0) to worst."""
        return list(Status).index(self)

    def __lt__(self, other) -> bool:
        return self.rank < Status(other).rank

    def __le__(self, other) -> bool:
        return self.rank <= Status(other).rank

    def __gt__(self, other) -> bool:
        return self.rank > Status(other).rank

    def __ge__(self, other) -> bool:
        return self.rank >= Status(other).rank

    def __str__(self) -> str:
        return self.value

    def __format__(self, spec: str) -> str:
        return format(self.value, spec)


_SOLVED, _INACCURATE = Status.SOLVED, Status.INACCURATE
"""The members the status rule compares with, looked up once (an enum's class attribute
costs a Python call each time)."""
_AS_SOLVED, _AS_INACCURATE = np.array(_SOLVED, object), np.array(_INACCURATE, object)
"""The same as 0-d object arrays, for numpy: ``np.where`` puts the members themselves in
its result (a bare member it turns into a string through the enum's ``__str__``), and a
comparison does not ask the enum class for numpy's hooks (a Python call each)."""
_ANSWERED = frozenset({_SOLVED, _INACCURATE})

ACCEPT = 1e-6
"""Largest relative residual (equilibrium, sign, complementarity, cone) of a solved record."""


class _Measures(Mapping):
    """Read-only mapping over the dataclass fields that are present (not ``None``), so a
    record's measures read as before: ``r.residuals["equilibrium"]``, ``.get``,
    ``.items()``. A field holds a float (one record) or an array (a batch, one value per
    instant).
    """

    __slots__ = ()

    def __getitem__(self, key: str):
        value = getattr(self, key, None) if key in self._names() else None
        if value is None:
            raise KeyError(key)
        return value

    def __iter__(self) -> Iterator[str]:
        return (name for name in self._names() if getattr(self, name) is not None)

    def __len__(self) -> int:
        return sum(1 for _ in self)

    @classmethod
    def _names(cls) -> tuple[str, ...]:
        return tuple(f.name for f in fields(cls))

    def at(self, k: int):
        """Instant ``k`` of a batch's measures, as floats."""
        return type(self)(**{name: float(value[k]) for name, value in self.items()})


@dataclass(frozen=True, eq=False, slots=True)
class Residuals(_Measures):
    """The package's residuals of an answer, relative to ``||b||`` (``ForceChecks``):
    ``equilibrium`` ``||Ax - b||``, ``sign`` (an end face pulling), ``complementarity``
    (both faces of a pair pushing), ``cone`` (a friction or contact cone left); ``inf``
    for a record without forces. ``reference`` is ``||x - x_ref|| / max(||x_ref||,
    1e-12)``, present only when a reference was given; it is not a check.
    """

    equilibrium: float | np.ndarray
    sign: float | np.ndarray
    complementarity: float | np.ndarray
    cone: float | np.ndarray
    reference: float | np.ndarray | None = None

    KEYS: ClassVar[tuple[str, ...]] = RESIDUALS
    """The checked residuals, in the order tables show them: the keys
    ``ForceChecks.residuals`` computes, one field each."""

    def worst(self) -> tuple[str, float]:
        """The largest checked residual of one record and its name."""
        name = max(self.KEYS, key=lambda k: getattr(self, k))
        return name, getattr(self, name)

    def largest(self) -> np.ndarray:
        """The largest checked residual per instant of a batch."""
        return np.max(np.array([getattr(self, k) for k in self.KEYS]), axis=0)


@dataclass(frozen=True, eq=False, slots=True)
class Optimality(_Measures):
    """Optimality of an answer (:mod:`~.optimality`): ``primal`` (the worst residual),
    ``dual`` (stationarity and dual-cone violation), ``gap`` (duality gap, or objective
    gap to a given optimal value) and ``distance`` (to the reference, only where the
    optimum is unique). A measure the record has none of is ``None`` and absent from the
    mapping (the paper's root finding has only ``primal``).
    """

    primal: float | np.ndarray | None = None
    dual: float | np.ndarray | None = None
    gap: float | np.ndarray | None = None
    distance: float | np.ndarray | None = None

    def within(self, level: float):
        """Every measure present <= ``level`` (per instant for a batch); ``False`` for
        a record without measures.
        """
        present = list(self.values())
        if not present:
            return False
        return np.all([np.asarray(v) <= level for v in present], axis=0)

    def confirms(self) -> bool | np.ndarray:
        """Primal, dual and gap all within :data:`ACCEPT` (``False`` if one is absent)."""
        if self.primal is None or self.dual is None or self.gap is None:
            return False
        return np.all([np.asarray(v, float) <= ACCEPT for v in (self.primal, self.dual,
                                                                  self.gap)], axis=0)


@dataclass(frozen=True)
class Outcome:
    """What an adapter hands back: the solver's own status mapped to :class:`Status`.

    ``z`` is the solver's variable (``None`` when it returned none); ``y`` the solver's
    multipliers in the rows of the problem's conic form (``convert(problem, (Conic,))``,
    Clarabel's sign convention ``P z + q + A'y = 0``), ``None`` when the solver gives
    none; ``setup_s`` is the time spent building matrices and solver objects,
    ``solve_s`` the time in the solver.
    """

    status: str
    z: np.ndarray | None
    iterations: int | None = None
    message: str = ""
    objective: float | None = None
    setup_s: float = 0.0
    solve_s: float = 0.0
    y: np.ndarray | None = None


@dataclass(frozen=True, slots=True)
class Record:
    """One solver's answer to one problem, with residuals measured by the package.

    ``x`` holds the named forces (N) in ``names`` order: finite when the status has an
    answer, all NaN otherwise (``z`` keeps whatever the solver returned). ``residuals``
    and ``optimality`` are :class:`Residuals` and :class:`Optimality` (a plain dict is
    converted). ``iterations`` is the solver's own count, ``None`` when it reports none
    (MINPACK, SVD). ``duals`` says where the multipliers ``y`` (conic rows, as
    :class:`Outcome`'s) that the optimality was measured with came from: ``"solver"``,
    ``"recovered"`` (least squares on the active constraints), ``"lcp"`` (the LCP's own
    ``w``) or ``"none"``; ``gap_kind`` whether ``gap`` is the duality gap or the
    objective gap to a given optimal value. ``checks_s`` is the time of these checks.

    Two views of the same answer: ``optimality`` is the package's (relative to the
    data, :mod:`.optimality`), ``solver_optimality`` the solver's (absolute primal,
    dual residual and duality gap of the problem the backend received, with the
    solver's own multipliers, :mod:`.qp_measures`; ``None`` where the solver gave no
    multipliers or the problem has no conic form). ``solver_status`` is the status the
    adapter reported, before the package judged it. Times (s): ``solve_s`` the solver's
    own, ``setup_s`` conversion and setup, ``checks_s`` the checks, ``wall_s`` the
    package's whole call (end to end; 0 for a record not made by ``solve``).
    """

    formulation: str
    solver: str
    status: Status
    x: np.ndarray
    names: tuple[str, ...]
    iterations: int | None
    setup_s: float
    solve_s: float
    residuals: Residuals
    message: str = ""
    z: np.ndarray | None = field(default=None, repr=False)
    objective: float | None = None
    optimality: Optimality = field(default_factory=Optimality)
    duals: str = "none"
    gap_kind: str = ""
    checks_s: float = 0.0
    y: np.ndarray | None = field(default=None, repr=False)
    solver_status: Status | None = None
    solver_optimality: Optimality | None = None
    wall_s: float = 0.0
    t: float | None = None
    """The instant (s) the record answers, where a solve over time set it (else None)."""

    def __post_init__(self) -> None:
        object.__setattr__(self, "status", Status(self.status))
        if not isinstance(self.residuals, Residuals):
            object.__setattr__(self, "residuals", Residuals(**self.residuals))
        if not isinstance(self.optimality, Optimality):
            object.__setattr__(self, "optimality", Optimality(**self.optimality))

    def within(self, level: float) -> bool:
        """Success at accuracy ``level``: an answer, and every measure it has <= level."""
        return self.status.has_answer and bool(self.optimality.within(level))

    @property
    def solved(self) -> bool:
        """Whether the forces can be trusted (status ``SOLVED``)."""
        return self.status is Status.SOLVED

    def forces(self) -> dict[str, float]:
        """The forces by name (N or N·m as the names say)."""
        return {name: float(v) for name, v in zip(self.names, self.x)}

    def to_json(self) -> dict:
        """A JSON-safe dict; non-finite floats become the strings ``"inf"``, ``"-inf"``, ``"nan"``.

        Strings rather than ``None`` keep the information and read back with ``float()``.
        """
        return {
            "formulation": self.formulation,
            "solver": self.solver,
            "status": self.status.value,
            "residuals": {k: _json_float(v) for k, v in self.residuals.items()},
            "forces": {k: _json_float(v) for k, v in self.forces().items()},
            "setup_s": _json_float(self.setup_s),
            "solve_s": _json_float(self.solve_s),
            "iterations": self.iterations,
            "message": self.message,
            "optimality": {k: _json_float(v) for k, v in self.optimality.items()},
            "duals": self.duals,
            "gap_kind": self.gap_kind,
            "solver_status": None if self.solver_status is None else str(self.solver_status),
            "solver_optimality": None if self.solver_optimality is None else {
                k: _json_float(v) for k, v in self.solver_optimality.items()},
            "checks_s": _json_float(self.checks_s),
            "wall_s": _json_float(self.wall_s),
        }


def _json_float(value: float) -> float | str:
    value = float(value)
    return value if math.isfinite(value) else str(value)


def _reference_distance(x: np.ndarray, reference: np.ndarray) -> float:
    ref = np.asarray(reference, float)
    if ref.shape != x.shape or not np.all(np.isfinite(x)):
        return math.inf
    return float(np.linalg.norm(x - ref)) / max(float(np.linalg.norm(ref)), 1e-12)


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


def judge(status, worst):
    """The package's status rule, elementwise: a reported ``solved`` whose worst
    residual exceeds :data:`ACCEPT` becomes ``inaccurate`` (every path, per instant or
    batched, decides by this one rule).
    """
    status, worst = np.asarray(status, object), np.asarray(worst, float)
    return np.where((status == _AS_SOLVED) & ~(worst <= ACCEPT), _AS_INACCURATE, status)


def confirm(status, optimality: Optimality, duals: str):
    """The second half of the status rule, elementwise: a solver's ``inaccurate``
    (Clarabel's ``AlmostSolved``, a stalled iteration) becomes ``solved`` where the
    package's own measures (primal, dual residual with the solver's or recovered
    multipliers, and gap) are all within :data:`ACCEPT`. Without multipliers nothing is
    confirmed: the status stays as the solver and :func:`judge` left it (``duals``:
    where the multipliers came from, one source for all or one per instant).
    """
    status = np.asarray(status, object)
    with_duals = np.asarray(duals, object) != "none"
    return np.where((status == _AS_INACCURATE) & optimality.confirms() & with_duals,
                    _AS_SOLVED, status)


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


def _groups(items, key) -> list[np.ndarray]:
    """Indices of ``items`` grouped by ``key(item)``, groups in order of appearance."""
    out: dict = {}
    for k, item in enumerate(items):
        out.setdefault(key(item), []).append(k)
    return [np.array(v, int) for v in out.values()]


def _checks_key(problem) -> tuple:
    c = problem.checks
    return np.shape(c.A), np.asarray(c.unilateral, bool).tobytes(), c.pairs, c.cones


@dataclass(frozen=True)
class Stacks:
    """The data the checks of T problems of one structure read, stacked once
    (:func:`stack_all`): the force checks' ``A`` (T, m, n) and ``b`` (T, m), and the
    problems' conic form (:class:`~.optimality.Stacked`, ``None`` for an LCP or a
    nonlinear system; its ``P`` (n, n) where the same at every instant). A caller that
    checks the same problems again (a bench running several backends over one
    formulation's instants) hands them to :func:`finalize_all` instead of having each
    pass stack every instant's matrices.
    """

    problems: tuple
    A: np.ndarray
    b: np.ndarray
    conic: Stacked | None

    def holds(self, problems) -> bool:
        """Whether these are the stacks of exactly ``problems`` (the same objects)."""
        return len(problems) == len(self.problems) and all(
            map(operator.is_, problems, self.problems))

    def take(self, rows) -> Stacks:
        """The stacks of the problems at positions ``rows``."""
        rows = np.asarray(rows, int)
        return Stacks(tuple(self.problems[k] for k in rows), self.A[rows], self.b[rows],
                      None if self.conic is None else self.conic.take(rows))


def stack_all(problems) -> Stacks | None:
    """:class:`Stacks` of ``problems``, or ``None`` when their checks or their conic
    forms differ in structure (then :func:`finalize_all` groups them itself).
    """
    problems = list(problems)
    if not problems or len(_groups(problems, _checks_key)) != 1:
        return None
    kinds = _groups(problems, _kind_key)
    if len(kinds) != 1:
        return None
    first = problems[0]
    conic = None
    if not isinstance(first, (LCP, NLS)) and conic_key(first) is not None:
        conic = stack_conic(problems)
    return Stacks(tuple(problems), np.array([p.checks.A for p in problems], float),
                  np.array([p.checks.b for p in problems], float), conic)


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
    for idx in _groups(problems, _checks_key):
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
    """The optimality views of T answers, filled group by group."""

    primal: np.ndarray
    dual: np.ndarray
    gap: np.ndarray
    duals: np.ndarray
    kinds: np.ndarray
    y: list
    solver: list  # the solver-optimality Optimality per instant, None where it does not apply


def finalize_all(problems, solver: str, outcomes, *, references=None, optimal_values=None,
                 extra_setup_s=None, received=None, elapsed_s=None,
                 stacks: Stacks | None = None) -> list[Record]:
    """Judge T outcomes at once: :func:`finalize` of each, with the residuals and the
    optimality measured by one vectorized pass per problem structure, so the checks
    cost microseconds per instant; ``checks_s`` is this call's time over T (the
    measures and the records' assembly).

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
    primal = np.array([found[key] for key in Residuals.KEYS]).max(axis=0)
    started.fail_nonfinite(np.flatnonzero(~np.isfinite(primal)).tolist())
    status = judge(started.status, primal)
    inaccurate = status == _AS_INACCURATE
    answered = (status == _AS_SOLVED) | inaccurate
    views = _optimality_all(problems, outcomes, answered, primal,
                            optimal_values if optimal_values is not None else [None] * T,
                            received, stacks)
    distance = _distances(problems, started.x, references)
    confirmed = (confirm(status, Optimality(primal=views.primal, dual=views.dual,
                                            gap=views.gap), views.duals)
                 if inaccurate.any() else status)  # it turns only inaccurate ones
    records = _records(problems, solver, outcomes, started, status, confirmed, answered,
                       found, distance, views, extra_setup_s)
    checks_s = (time.perf_counter() - began) / T if T else 0.0
    setters = _setters(Record)  # the times are known once all records are built
    _fill(setters["checks_s"], records, itertools.repeat(checks_s, T))
    _fill(setters["wall_s"], records, [before + checks_s for before in (
        elapsed_s if elapsed_s is not None else [0.0] * T)])
    return records


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


_STATUS, _MESSAGE = operator.attrgetter("status"), operator.attrgetter("message")
_TO_FORCES, _Z = operator.attrgetter("to_forces"), operator.attrgetter("z")
_FORMULATION, _NAMES = operator.attrgetter("formulation"), operator.attrgetter("checks.names")
_ITERATIONS, _OBJECTIVE = operator.attrgetter("iterations"), operator.attrgetter("objective")
_SETUP_S, _SOLVE_S = operator.attrgetter("setup_s"), operator.attrgetter("solve_s")
"""What the check pass reads of the outcomes and the problems, each in one C call."""
_STATUS_OF = {**{s.value: s for s in Status}, **{s: s for s in Status}}
"""A status as an adapter gives it (the value or the member) -> :class:`Status`, one
dict lookup (an enum call costs as much as the rest of an instant's start)."""


def _start_all(problems, outcomes, n: int | None = None) -> _Started:
    """:class:`_Started` of every outcome: its status (an unknown one is ``failed``)
    and, where it has an answer, its forces by ``problem.to_forces`` (``n``: the number
    of forces of every problem, where one structure fixes it).
    """
    T = len(problems)
    status = list(map(_STATUS_OF.get, map(_STATUS, outcomes)))
    started = _Started([], [], [None] * T, [m or "" for m in map(_MESSAGE, outcomes)])
    answered = [k for k, s in enumerate(status) if s in _ANSWERED]
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
        elif first in _ANSWERED:
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
        Z = np.array(list(map(_Z, map(outcomes.__getitem__, rows))), float)
    except (TypeError, ValueError):  # a missing or ragged answer: found and told per instant
        return None
    maps = list(map(_TO_FORCES, map(problems.__getitem__, rows)))
    X = map_all(maps, Z) if Z.ndim == 2 else None
    return X if X is not None and X.shape == (len(rows), n) else None


def _distances(problems, X, references) -> tuple[list, list]:
    """``||x - x_ref|| / ||x_ref||`` where a reference is given (else ``None``), for the
    residuals, and the same only where the optimum is one point, for the optimality
    (:func:`~.optimality.unique_optimum`, decided once per ``P`` object: instants of one
    structure share theirs).
    """
    unique: dict = {}
    distance, where_unique = [None] * len(problems), [None] * len(problems)
    for k, ref in enumerate(references):
        if ref is None:
            continue
        distance[k] = _reference_distance(X[k], ref)
        P = getattr(problems[k], "P", None)
        key = (type(problems[k]), id(P))  # the problems hold their P while this runs
        if key not in unique:
            unique[key] = unique_optimum(problems[k])
        where_unique[k] = distance[k] if unique[key] else None
    return distance, where_unique


@functools.cache
def _defaults(cls) -> tuple:
    """``(name, make)`` of the fields of dataclass ``cls``: ``make()`` gives the
    field's default (its factory's product, or its value).
    """
    return tuple((f.name, f.default_factory if f.default is MISSING else
                  functools.partial(lambda value: value, f.default)) for f in fields(cls))


def _instances(cls, columns: dict, T: int, shared: dict | None = None) -> list:
    """T instances of the frozen, slotted dataclass ``cls`` from ``columns`` (field -> T
    values) and ``shared`` (field -> the one value of every instance; fields in neither
    take their defaults). Each field is filled for all instances at once by its slot's
    setter, in C (``map`` drained by a ``deque``), instead of through the frozen
    ``__init__``'s one ``object.__setattr__`` per field (6 us a record). Slots, not a
    ``__dict__``: a record is 200 bytes instead of 1.3 kB, and a check pass over many
    instants writes that much less memory (so the types take no weak reference, have no
    ``vars()``, and assigning a name that is no field raises ``TypeError``). The values
    must already be of the fields' types (no ``__post_init__``); the instances compare,
    print, pickle and refuse assignment to a field as any other.
    """
    shared, setters = shared or {}, _setters(cls)
    out = list(map(object.__new__, itertools.repeat(cls, T)))
    for name, make in _defaults(cls):
        if name not in columns:
            value = shared[name] if name in shared else make()
            _fill(setters[name], out, itertools.repeat(value, T))
    for name, column in columns.items():
        _fill(setters[name], out, column)
    return out


@functools.cache
def _setters(cls) -> dict:
    """The slot setter of each field of the slotted dataclass ``cls``."""
    return {f.name: getattr(cls, f.name).__set__ for f in fields(cls)}


def _fill(setter, instances: list, values) -> None:
    """``setter(instance, value)`` for each pair, run in C."""
    collections.deque(map(setter, instances, values), maxlen=0)


def at_instants(records, t) -> list[Record]:
    """Copies of ``records`` told the instants ``t`` (s) they answer (``Record.t``), made
    as :func:`_instances` makes them (``dataclasses.replace`` re-runs the frozen
    ``__init__``: 6 us a record).
    """
    if len(records) != len(t):
        raise ValueError(f"{len(records)} records, {len(t)} instants")
    columns = {name: list(map(operator.attrgetter(name), records))
               for name, _ in _defaults(Record) if name != "t"}
    return _instances(Record, {**columns, "t": [float(v) for v in t]}, len(records))


def _records(problems, solver, outcomes, started: _Started, status, confirmed, answered,
             found, distance, views: _Views, extra_setup_s) -> list[Record]:
    """The T records of :func:`finalize_all`, assembled column by column (``answered``:
    where the status has an answer; ``distance``: :func:`_distances`' pair).
    """
    T = len(problems)
    residual = {key: found[key].tolist() for key in Residuals.KEYS}
    optimality = _instances(Optimality, {
        "primal": _floats(views.primal), "dual": _floats(views.dual),
        "gap": _floats(views.gap), "distance": distance[1]}, T)
    residuals = _instances(Residuals, {**residual, "reference": distance[0]}, T)
    extra = extra_setup_s if extra_setup_s is not None else [0.0] * T
    z, iterations, objective = (list(map(get, outcomes)) for get in (_Z, _ITERATIONS,
                                                                      _OBJECTIVE))
    return _instances(Record, {
        "formulation": list(map(_FORMULATION, problems)),
        "status": confirmed.tolist(),
        "x": started.x,
        "names": list(map(_NAMES, problems)),
        "iterations": [v if v is None or type(v) is int else int(v) for v in iterations],
        "setup_s": list(map(operator.add, map(_SETUP_S, outcomes), extra)),
        "solve_s": list(map(_SOLVE_S, outcomes)), "residuals": residuals,
        "message": _messages(started, status, confirmed, found),
        "z": [v if v is None or type(v) is np.ndarray else np.asarray(v) for v in z],
        "objective": [float(v) if a and v is not None else None
                      for v, a in zip(objective, answered.tolist())],
        "optimality": optimality, "duals": views.duals.tolist(),
        "gap_kind": views.kinds.tolist(), "y": views.y,
        "solver_status": started.solver_status, "solver_optimality": views.solver}, T,
        {"solver": solver})


def _floats(values: np.ndarray) -> list:
    """``values`` as floats, ``None`` for NaN (a measure the record has none of)."""
    out = values.tolist()
    return [None if v != v else v for v in out] if np.isnan(values).any() else out


def _messages(started: _Started, status, confirmed, residual: dict) -> list[str]:
    """Each record's message: the outcome's, with the start's notes and why the
    package changed the solver's status, where it did (``residual``: key -> (T,) array;
    they are never NaN, a non-finite answer's are ``inf``).
    """
    messages = list(started.messages)
    judged = status != np.array(started.status, object)
    turned = confirmed != status
    changed = np.flatnonzero(judged | turned).tolist()
    if not changed and not started.notes:
        return messages
    worst = np.argmax([residual[key] for key in Residuals.KEYS], axis=0).tolist()
    for k in sorted(started.notes.keys() | set(changed)):
        notes = started.notes.get(k, [messages[k]] if messages[k] else [])
        if judged[k]:
            key = Residuals.KEYS[worst[k]]
            notes = [*notes, f"{key} residual {residual[key][k]:.1e} > {ACCEPT:.0e}"]
        if turned[k]:
            notes = [*notes, "confirmed by the package's primal, dual and gap measures"]
        messages[k] = "; ".join(notes)
    return messages


def finalize(
    problem,
    solver: str,
    outcome: Outcome,
    reference: np.ndarray | None = None,
    extra_setup_s: float = 0.0,
    optimal_value: float | None = None,
    received=None,
) -> Record:
    """Turn an adapter's outcome into a record, deciding the final status from residuals
    and measuring optimality (``optimal_value``: the problem's optimal objective from a
    high-precision solve, for the objective gap of a record without solver duals;
    ``received``: the problem the backend received, for the solver-optimality view).
    One instant of :func:`finalize_all`: one rule for every path.
    """
    return finalize_all([problem], solver, [outcome], references=[reference],
                        optimal_values=[optimal_value], extra_setup_s=[extra_setup_s],
                        received=None if received is None else [received])[0]


def _optimality_all(problems, outcomes, answered, primal, optimal_values, received,
                    stacks: Stacks | None) -> _Views:
    """The package's optimality (relative) and the solver's (absolute, where the
    problem has a conic form) of T answers; NaN marks a measure a record has none of.
    """
    T, unanswered = len(problems), ~answered
    views = _Views(primal=primal.copy(), dual=np.full(T, np.nan), gap=np.full(T, np.nan),
                   duals=np.full(T, "none", object), kinds=np.full(T, "", object),
                   y=[None] * T, solver=[None] * T)
    views.primal[unanswered] = math.inf
    views.dual[unanswered], views.gap[unanswered] = math.inf, math.inf
    live = np.flatnonzero(answered).tolist()
    if stacks is not None and stacks.conic is not None:
        if live:
            st = stacks.conic if len(live) == T else stacks.conic.take(live)
            _conic(problems, outcomes, live, views, optimal_values, received, st)
        return views
    for idx in _groups([problems[k] for k in live], _kind_key):
        idx = [live[j] for j in idx.tolist()]
        problem = problems[idx[0]]
        if isinstance(problem, LCP):
            _lcp(problems, outcomes, idx, views)
        elif not isinstance(problem, NLS) and conic_key(problem) is not None:
            _conic(problems, outcomes, idx, views, optimal_values, received)
    return views


def _kind_key(problem) -> tuple:
    if isinstance(problem, (LCP, NLS)):
        return type(problem), len(problem.checks.names)
    return "conic", conic_key(problem)


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
    _place(views.y, idx, list(w))


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
    every = len(idx) == len(views.y)  # then slices and whole lists, not indices
    at = slice(None) if every else np.array(idx)
    views.dual[at], views.gap[at], views.kinds[at] = found["dual"], gap, kinds
    views.duals[at] = "solver" if given.all() else np.where(given, "solver", "recovered")
    _place(views.y, idx, list(y))
    if solver is not None:
        solver_views = _instances(Optimality, {key: solver[key].tolist() for key in
                                               ("primal", "dual", "gap")}, len(solver["gap"]))
        _place(views.solver, list(itertools.compress(idx, given.tolist())), solver_views)


KERNEL_LEAST = 32
"""Instants from which a check pass measures optimality through the compiled kernel
(:func:`~.optimality.compiled_views`, where numba is installed). Below it the NumPy
path's fixed cost is small, and a short pass (one ``solve``) never loads the kernels
(a process's first long pass does, from numba's cache: about 10 ms, counted in its
``checks_s``; compiling them, once after installing, takes a few seconds). The two paths
agree to rounding, not to the bit: a measure within rounding of :data:`ACCEPT` could be
judged apart by a short and a long pass."""


def _measured(st: Stacked, z, y, given, as_qp: bool) -> tuple[dict, dict | None]:
    """The package's measures of the answers ``z`` with multipliers ``y``, and the
    solver's (:func:`~.qp_measures.from_parts`) of those whose multipliers the solver
    gave (``given``; ``None`` for none; ``as_qp``: the backend received a QP or a least
    norm, whose multipliers are not sign-checked). Compiled from :data:`KERNEL_LEAST`
    instants on, else NumPy's (one set of parts serving both views).
    """
    both = (compiled_views(st, z, y, check_dual_cone=not as_qp)
            if len(z) >= KERNEL_LEAST else None)
    if both is not None:
        found, solver = both
        return found, ({k: v[given] for k, v in solver.items()} if given.any() else None)
    found, parts = stacked_measures(st, z, y)
    if not given.any():
        return found, None
    if not given.all():
        st, z, parts = st.take(np.flatnonzero(given)), z[given], parts.take(given)
    return found, from_parts(parts, st.b - st.Az(z), st.cones, check_dual_cone=not as_qp)


def _place(out: list, idx: list, values: list) -> None:
    """``out[idx[j]] = values[j]`` for every j, at once where ``idx`` is every place."""
    if len(idx) == len(out):
        out[:] = values
    else:
        for k, value in zip(idx, values):
            out[k] = value
