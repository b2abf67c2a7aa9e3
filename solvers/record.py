"""The solution record: what every solver call returns, judged by the package (DESIGN §3).

An adapter reports an :class:`Outcome` in the solver's own variable ``z``;
:func:`finalize` maps it to forces with ``problem.to_forces``, measures the residuals
with ``problem.checks`` and decides the final :class:`Status`. The solver's word is only
an upper bound: a reported success whose residuals exceed :data:`ACCEPT` becomes
``inaccurate``, and a success with NaN or inf output becomes ``failed``.
"""

from __future__ import annotations

import enum
import math
import time
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field, fields
from typing import ClassVar

import numpy as np
from cardan_forces.formulations.problems import RESIDUALS, Conic

from .conversions import convert
from .optimality import measures, recover, unique_optimum


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
"""Largest relative residual (equilibrium, sign, complementarity, cone) of a solved record."""


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
    return np.where((status == Status.SOLVED) & ~(worst <= ACCEPT), Status.INACCURATE, status)


def confirm(status, optimality: Optimality, duals: str):
    """The second half of the status rule, elementwise: a solver's ``inaccurate``
    (Clarabel's ``AlmostSolved``, a stalled iteration) becomes ``solved`` where the
    package's own measures (primal, dual residual with the solver's or recovered
    multipliers, and gap) are all within :data:`ACCEPT`. Without multipliers nothing is
    confirmed: the status stays as the solver and :func:`judge` left it.
    """
    status = np.asarray(status, object)
    if duals == "none":
        return status
    return np.where((status == Status.INACCURATE) & optimality.confirms(), Status.SOLVED,
                    status)


def _forces(problem, outcome: Outcome, n: int) -> tuple[np.ndarray, str]:
    """The forces of an answered outcome, or NaN and why they are not to be had."""
    try:
        if outcome.z is None:
            raise ValueError("solver returned no solution")
        x = np.asarray(problem.to_forces(np.asarray(outcome.z, float)), float)
        if x.shape != (n,):
            raise ValueError(f"forces have shape {x.shape}, expected {(n,)}")
        if not np.all(np.isfinite(x)):
            raise ValueError("solver returned NaN or inf")
    except Exception as exc:  # any bad output is a failure, never a crash
        return np.full(n, np.nan), f"{type(exc).__name__}: {exc}"
    return x, ""


def finalize(
    problem,
    solver: str,
    outcome: Outcome,
    reference: np.ndarray | None = None,
    extra_setup_s: float = 0.0,
    optimal_value: float | None = None,
) -> Record:
    """Turn an adapter's outcome into a record, deciding the final status from residuals
    and measuring optimality (``optimal_value``: the problem's optimal objective from a
    high-precision solve, for the objective gap of a record without solver duals).
    """
    began = time.perf_counter()
    names = problem.checks.names
    notes = [outcome.message] if outcome.message else []
    try:
        status = Status(outcome.status)
    except ValueError:
        status, notes = Status.FAILED, [*notes, f"unknown status {outcome.status!r}"]
    x = np.full(len(names), np.nan)
    if status.has_answer:
        x, why = _forces(problem, outcome, len(names))
        if why:
            status, notes = Status.FAILED, [*notes, why]
    found = problem.checks.residuals(x)
    worst = max(Residuals.KEYS, key=found.get)
    decided = Status(judge(status, found[worst]).item())
    if decided != status:
        notes.append(f"{worst} residual {found[worst]:.1e} > {ACCEPT:.0e}")
    status = decided
    distance = None if reference is None else _reference_distance(x, reference)
    residuals = Residuals(**found, reference=distance)
    answered = status.has_answer
    optimality, duals, gap_kind, y = _optimality(problem, outcome if answered else None,
                                                 found[worst], optimal_value)
    if reference is not None and unique_optimum(problem):
        optimality = Optimality(**optimality, distance=distance)
    confirmed = Status(confirm(status, optimality, duals).item())
    if confirmed != status:
        notes.append("confirmed by the package's primal, dual and gap measures")
    objective = outcome.objective if answered else None
    return Record(
        formulation=problem.formulation,
        solver=solver,
        status=confirmed,
        x=x,
        names=tuple(names),
        iterations=None if outcome.iterations is None else int(outcome.iterations),
        setup_s=outcome.setup_s + extra_setup_s,
        solve_s=outcome.solve_s,
        residuals=residuals,
        message="; ".join(notes),
        z=None if outcome.z is None else np.asarray(outcome.z),
        objective=None if objective is None else float(objective),
        optimality=optimality,
        duals=duals,
        gap_kind=gap_kind,
        checks_s=time.perf_counter() - began,
        y=y,
    )


def _optimality(problem, outcome, primal: float, optimal_value):
    """``(measures, duals source, gap kind, multipliers)`` of an answered outcome
    (``None``: none).
    """
    from cardan_forces.formulations.problems import LCP, NLS

    if outcome is None:
        return Optimality(primal=math.inf, dual=math.inf, gap=math.inf), "none", "", None
    if isinstance(problem, NLS):
        return Optimality(primal=primal), "none", "", None
    z = np.asarray(outcome.z, float)
    if isinstance(problem, LCP):
        w = np.asarray(problem.M, float) @ z + np.asarray(problem.q, float)
        unit = max(float(np.abs(problem.q).max(initial=0.0)), float(np.abs(z).max(initial=0.0)),
                   1e-300)
        return Optimality(primal=primal, dual=max(0.0, -float(w.min(initial=0.0))) / unit,
                          gap=abs(float(z @ w)) / unit ** 2), "lcp", "complementarity", w
    conic = convert(problem, (Conic,))
    if conic is None:
        return Optimality(primal=primal), "none", "", None
    source = "solver" if outcome.y is not None else "recovered"
    y = np.asarray(outcome.y if source == "solver" else
                   recover(conic.P, conic.q, conic.A, conic.b, conic.cones, z), float)
    found = measures(conic.P, conic.q[None], np.asarray(conic.A, float)[None],
                     np.asarray(conic.b, float)[None], conic.cones, z[None], y[None])
    gap, kind = float(found["gap"][0]), "duality"
    if source != "solver" and optimal_value is not None:
        objective = float(found["objective"][0])
        gap = abs(objective - optimal_value) / max(abs(optimal_value), 1e-300)
        kind = "objective"
    return (Optimality(primal=primal, dual=float(found["dual"][0]), gap=gap), source, kind, y)
