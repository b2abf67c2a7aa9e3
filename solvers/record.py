"""The solution record: what an adapter hands back and what a judged run holds (DESIGN §3).

Data only. An adapter reports an :class:`Outcome` (a batched backend a
:class:`BatchOutcome`) in the solver's own variable ``z``; the judge (:mod:`.judge`)
maps it to forces, measures it and decides its :class:`Status`. What a status means:
``solved`` exactly where the package's own measures of the answer, primal residual,
dual residual and gap, are all within :data:`ACCEPT` (only the primal residual for a
root finding, which has no multipliers), else ``inaccurate``; a success with NaN or inf
output is ``failed``.

A run's results are columns, :class:`Results` (one array or tuple per field, one entry
per instant); a per-instant :class:`Record` is made from them on demand.
"""

from __future__ import annotations

import dataclasses
import enum
import math
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field, fields
from typing import ClassVar

import numpy as np
from cardan_forces.formulations.problems import RESIDUALS


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
        return self in (Status.SOLVED, Status.INACCURATE)

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


ACCEPT = 1e-6
"""Largest relative measure of a solved record: each residual (equilibrium, sign,
complementarity, cone), the dual residual and the gap (:mod:`.judge` measures them,
its status rule compares them with this level)."""


class _Measures(Mapping):
    """Read-only mapping over the dataclass fields that are present (not ``None``), so a
    record's measures read as before: ``r.residuals["equilibrium"]``, ``.get``,
    ``.items()``. A field holds a float (one record) or an array (a batch, one value per
    instant).
    """

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


@dataclass(frozen=True, eq=False)
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


@dataclass(frozen=True, eq=False)
class Optimality(_Measures):
    """Optimality of an answer (:mod:`~.judge`): ``primal`` (the worst residual),
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


@dataclass(frozen=True)
class BatchOutcome:
    """What a batched backend hands back, per instant (T rows).

    ``z`` is the solver's variable (the forces in N for a
    :class:`~cardan_forces.formulations.batch.LeastNormBatch`);
    ``y`` the multipliers in the batch's conic rows (Clarabel's sign convention; for
    a least-norm batch the rows ``A x = b`` then ``-x_j <= 0`` for the signed
    columns), ``None`` if the solver gives none; ``stages`` seconds per stage of the
    whole batch; ``messages`` one per instant (or empty).
    """

    status: np.ndarray
    z: np.ndarray
    y: np.ndarray | None
    iterations: np.ndarray
    setup_s: float
    solve_s: float
    stages: dict[str, float] = field(default_factory=dict)
    messages: tuple[str, ...] = ()


@dataclass(frozen=True)
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

    Two views of the same answer, both measured by :mod:`.judge`: ``optimality`` is the
    package's (relative to the data), ``solver_optimality`` the solver's (absolute
    primal, dual residual and duality gap of the problem the backend received, with the
    solver's own multipliers; ``None`` where the solver gave no multipliers or the
    problem has no conic form). ``solver_status`` is the status the
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


@dataclass(frozen=True, eq=False)
class Results(Sequence):
    """A run's results as columns: T answers of one ``solver``, one entry per instant in
    each field (see :class:`Record` for what each means). Arrays where the values are
    numbers: ``status`` and ``solver_status`` (T,) of :class:`Status` (``solver_status``
    ``None`` where not known), the times (s) (T,) floats; ``residuals``,
    ``optimality`` and ``solver_optimality`` hold (T,) arrays, NaN marking a measure an
    instant has none of (a missing ``reference``, a ``distance`` where the optimum is
    not unique, a ``solver_optimality`` without the solver's multipliers), ``None`` a
    measure no instant has. Tuples where the values are objects of their own shape
    (forces ``x``, ``z``, ``y``, names); a batched run, whose instants share one shape,
    holds ``x``, ``z`` and ``y`` as (T, .) arrays, its times as the batch's over T and
    ``stages``, the backend's own split of the whole batch's time (s; empty for a run
    instant by instant).

    It is a sequence of records: ``results[k]`` is instant ``k``'s :class:`Record`, made
    when asked for.
    """

    solver: str
    formulation: tuple[str, ...]
    names: tuple[tuple[str, ...], ...]
    status: np.ndarray
    x: tuple[np.ndarray, ...] | np.ndarray
    residuals: Residuals
    optimality: Optimality
    solver_optimality: Optimality
    iterations: tuple[int | None, ...]
    objective: tuple[float | None, ...]
    message: tuple[str, ...]
    duals: tuple[str, ...]
    gap_kind: tuple[str, ...]
    solver_status: np.ndarray
    setup_s: np.ndarray
    solve_s: np.ndarray
    checks_s: np.ndarray
    wall_s: np.ndarray
    z: tuple[np.ndarray | None, ...] | np.ndarray
    y: tuple[np.ndarray | None, ...] | np.ndarray
    t: np.ndarray | None = None
    """The instants (s) the answers are for, where a solve over time set them."""
    stages: Mapping[str, float] = field(default_factory=dict)

    def __len__(self) -> int:
        return len(self.status)

    def __getitem__(self, k):
        if isinstance(k, slice):
            return [self.record(j) for j in range(len(self))[k]]
        return self.record(k)

    def record(self, k: int) -> Record:
        """Instant ``k`` as a :class:`Record`."""
        k = range(len(self))[k]
        solver_view = _present(self.solver_optimality, k)
        return Record(
            formulation=self.formulation[k], solver=self.solver, status=self.status[k],
            x=self.x[k], names=self.names[k], iterations=self.iterations[k],
            setup_s=float(self.setup_s[k]), solve_s=float(self.solve_s[k]),
            residuals=Residuals(**_present(self.residuals, k, Residuals.KEYS)),
            message=self.message[k], z=self.z[k], objective=self.objective[k],
            optimality=Optimality(**_present(self.optimality, k)), duals=self.duals[k],
            gap_kind=self.gap_kind[k], checks_s=float(self.checks_s[k]), y=self.y[k],
            solver_status=self.solver_status[k],
            solver_optimality=Optimality(**solver_view) if solver_view else None,
            wall_s=float(self.wall_s[k]), t=None if self.t is None else float(self.t[k]))

    def within(self, level: float) -> np.ndarray:
        """Per instant, :meth:`Record.within`: an answer, and every measure the instant
        has <= ``level`` (NaN: a measure it has none of).
        """
        answered = np.array([s.has_answer for s in self.status], bool).reshape(len(self))
        present = [np.asarray(v, float) for v in self.optimality.values()]
        if not present:
            return np.zeros(len(self), bool)
        v = np.array(present)
        has = ~np.isnan(v)
        return answered & np.all((v <= level) | ~has, axis=0) & has.any(axis=0)

    def at(self, t) -> Results:
        """The same results told the instants ``t`` (s) they answer."""
        t = np.asarray(t, float)
        if t.shape != (len(self),):
            raise ValueError(f"{len(self)} answers, {t.size} instants")
        return dataclasses.replace(self, t=t)

    @classmethod
    def of(cls, records: Sequence[Record]) -> Results:
        """The columns of ``records`` (all of one solver, or the first's named)."""
        def column(name):
            return tuple(getattr(r, name) for r in records)

        def floats(name):
            return np.array(column(name), float).reshape(len(records))

        def measures(kind, of):
            return kind(**{f.name: np.array([np.nan if m is None or m.get(f.name) is None
                                             else m[f.name] for m in of], float)
                           for f in fields(kind)})

        t = column("t")
        return cls(
            solver=records[0].solver if records else "", formulation=column("formulation"),
            names=column("names"), status=statuses(column("status")), x=column("x"),
            residuals=measures(Residuals, column("residuals")),
            optimality=measures(Optimality, column("optimality")),
            solver_optimality=measures(Optimality, column("solver_optimality")),
            iterations=column("iterations"), objective=column("objective"),
            message=column("message"), duals=column("duals"),
            gap_kind=column("gap_kind"), solver_status=statuses(column("solver_status")),
            setup_s=floats("setup_s"), solve_s=floats("solve_s"),
            checks_s=floats("checks_s"), wall_s=floats("wall_s"), z=column("z"),
            y=column("y"), t=None if None in t else np.array(t, float))


def as_status(given) -> Status | None:
    """A status as an adapter gives it (the value or the member), ``None`` if unknown."""
    try:
        return Status(given)
    except (ValueError, TypeError):
        return None


def as_statuses(given, default: Status | None = None) -> np.ndarray:
    """:func:`as_status` of each of ``given`` (``default`` where unknown) as
    :func:`statuses` holds them, each distinct value converted once (a batch's T
    instants share a few).
    """
    given = list(given)
    known = {value: as_status(value) or default for value in set(given)}
    return statuses([known[value] for value in given])


def statuses(values) -> np.ndarray:
    """Statuses (or ``None``) as a (T,) object array of the members themselves (numpy
    would make an array of ``Status``, a ``str``, an array of strings).
    """
    out = np.empty(len(values), object)
    out[:] = list(values)
    return out


def _present(columns: _Measures, k: int, keep=()) -> dict[str, float]:
    """Instant ``k`` of measures held as columns, as floats, without the NaN ones (the
    measures the instant has none of) but those named in ``keep``.
    """
    found = {name: float(value[k]) for name, value in columns.items()}
    return {name: value for name, value in found.items() if value == value or name in keep}


def _json_float(value: float) -> float | str:
    value = float(value)
    return value if math.isfinite(value) else str(value)


