"""The solution record: what every solver call returns, judged by the package (DESIGN §3).

An adapter reports an :class:`Outcome` in the solver's own variable ``z``;
:func:`finalize` maps it to forces with ``problem.to_forces``, measures the residuals
with ``problem.checks`` and decides the final status. The solver's word is only an
upper bound: a reported success whose residuals exceed :data:`ACCEPT` becomes
``"inaccurate"``, and a success with NaN or inf output becomes ``"failed"``.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np
from cardan_forces.formulations.problems import Conic

from .conversions import convert
from .optimality import measures, recover, unique_optimum

STATUSES = ("solved", "inaccurate", "unbounded", "infeasible", "failed")
"""Every status a record can carry, from best to worst (a run over several instants
carries its worst); only ``"solved"`` means the forces are trusted."""

ACCEPT = 1e-6
"""Largest relative residual (equilibrium, sign, complementarity, cone) of a solved record."""

_WITH_ANSWER = ("solved", "inaccurate")


@dataclass(frozen=True)
class Outcome:
    """What an adapter hands back: the solver's own status mapped to :data:`STATUSES`.

    ``z`` is the solver's variable (``None`` when it returned none); ``duals`` the
    solver's multipliers in the rows of the problem's conic form (``convert(problem,
    (Conic,))``, Clarabel's sign convention ``P z + q + A'y = 0``), ``None`` when the
    solver gives none; ``setup_s`` is the time spent building matrices and solver
    objects, ``solve_s`` the time in the solver.
    """

    status: str
    z: np.ndarray | None
    iterations: int | None = None
    message: str = ""
    objective: float | None = None
    setup_s: float = 0.0
    solve_s: float = 0.0
    duals: np.ndarray | None = None


@dataclass(frozen=True)
class Record:
    """One solver's answer to one problem, with residuals measured by the package.

    ``x`` holds the named forces (N) in ``names`` order: finite when the status is
    ``"solved"`` or ``"inaccurate"``, all NaN otherwise (``z`` keeps whatever the solver
    returned). ``residuals`` are relative (see ``ForceChecks.residuals``), ``inf`` for a
    record without forces; ``"reference"`` is ``||x - x_ref|| / max(||x_ref||, 1e-12)``,
    present only when a reference was given. ``iterations`` is the solver's own count,
    ``None`` when it reports none (MINPACK, SVD). ``optimality`` holds the three
    measures of :mod:`cardan_forces.solvers.optimality` (``primal``: the worst residual;
    ``dual``; ``gap``) and ``distance`` (to the reference, only where the optimum is
    unique); a measure the record has none of is absent (the paper's root finding has
    only ``primal``). ``duals`` says where the multipliers came from: ``"solver"``,
    ``"recovered"`` (least squares on the active constraints), ``"lcp"`` (the LCP's own
    ``w``) or ``"none"``; ``gap_kind`` whether ``gap`` is the duality gap or the
    objective gap to a given optimal value. ``checks_s`` is the time of these checks.
    """

    formulation: str
    solver: str
    status: str
    x: np.ndarray
    names: tuple[str, ...]
    iterations: int | None
    setup_s: float
    solve_s: float
    residuals: dict[str, float]
    message: str = ""
    z: np.ndarray | None = field(default=None, repr=False)
    objective: float | None = None
    optimality: dict[str, float] = field(default_factory=dict)
    duals: str = "none"
    gap_kind: str = ""
    checks_s: float = 0.0

    def within(self, level: float) -> bool:
        """Success at accuracy ``level``: an answer, and every measure it has <= level."""
        return (self.status in _WITH_ANSWER and bool(self.optimality)
                and all(v <= level for v in self.optimality.values()))

    @property
    def solved(self) -> bool:
        """Whether the forces can be trusted (status ``"solved"``)."""
        return self.status == "solved"

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
            "status": self.status,
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
    """A ``"failed"`` record: NaN forces, ``inf`` residuals, the reason in ``message``."""
    outcome = Outcome("failed", None, message=message, setup_s=setup_s, solve_s=solve_s)
    return finalize(problem, solver, outcome, reference=reference)


def judge(status, worst):
    """The package's status rule, elementwise: a reported ``"solved"`` whose worst
    residual exceeds :data:`ACCEPT` becomes ``"inaccurate"`` (every path, per instant or
    batched, decides by this one rule).
    """
    status, worst = np.asarray(status, object), np.asarray(worst, float)
    return np.where((status == "solved") & ~(worst <= ACCEPT), "inaccurate", status)


def confirm(status, optimality: dict, duals: str):
    """The second half of the status rule, elementwise: a solver's ``"inaccurate"``
    (Clarabel's ``AlmostSolved``, a stalled iteration) becomes ``"solved"`` where the
    package's own measures (primal, dual residual with the solver's or recovered
    multipliers, and gap) are all within :data:`ACCEPT`. Without multipliers nothing is
    confirmed: the status stays as the solver and :func:`judge` left it.
    """
    status = np.asarray(status, object)
    if duals == "none" or not {"primal", "dual", "gap"} <= set(optimality):
        return status
    within = np.all([np.asarray(optimality[k], float) <= ACCEPT
                     for k in ("primal", "dual", "gap")], axis=0)
    return np.where((status == "inaccurate") & within, "solved", status)


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
    status, notes = outcome.status, [outcome.message] if outcome.message else []
    if status not in STATUSES:
        status, notes = "failed", [*notes, f"unknown status {outcome.status!r}"]
    x = np.full(len(names), np.nan)
    if status in _WITH_ANSWER:
        try:
            if outcome.z is None:
                raise ValueError("solver returned no solution")
            candidate = np.asarray(problem.to_forces(np.asarray(outcome.z, float)), float)
            if candidate.shape != x.shape:
                raise ValueError(f"forces have shape {candidate.shape}, expected {x.shape}")
            if not np.all(np.isfinite(candidate)):
                raise ValueError("solver returned NaN or inf")
            x = candidate
        except Exception as exc:  # any bad output is a failure, never a crash
            status, notes = "failed", [*notes, f"{type(exc).__name__}: {exc}"]
    residuals = problem.checks.residuals(x)
    worst = max(residuals, key=residuals.get)
    decided = str(judge(status, residuals[worst]))
    if decided != status:
        notes.append(f"{worst} residual {residuals[worst]:.1e} > {ACCEPT:.0e}")
    status = decided
    if reference is not None:
        residuals["reference"] = _reference_distance(x, reference)
    answered = status in _WITH_ANSWER
    optimality, duals, gap_kind = _optimality(problem, outcome if answered else None,
                                              residuals[worst], optimal_value)
    if reference is not None and unique_optimum(problem):
        optimality["distance"] = residuals["reference"]
    confirmed = str(confirm(status, optimality, duals))
    if confirmed != status:
        notes.append("confirmed by the package's primal, dual and gap measures")
    status = confirmed
    objective = outcome.objective if answered else None
    return Record(
        formulation=problem.formulation,
        solver=solver,
        status=status,
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
    )


def _optimality(problem, outcome, primal: float, optimal_value):
    """``(measures, duals source, gap kind)`` of an answered outcome (``None``: none)."""
    from cardan_forces.formulations.problems import LCP, NLS

    if outcome is None:
        return {"primal": math.inf, "dual": math.inf, "gap": math.inf}, "none", ""
    if isinstance(problem, NLS):
        return {"primal": primal}, "none", ""
    z = np.asarray(outcome.z, float)
    if isinstance(problem, LCP):
        w = np.asarray(problem.M, float) @ z + np.asarray(problem.q, float)
        unit = max(float(np.abs(problem.q).max(initial=0.0)), float(np.abs(z).max(initial=0.0)),
                   1e-300)
        return {"primal": primal, "dual": max(0.0, -float(w.min(initial=0.0))) / unit,
                "gap": abs(float(z @ w)) / unit ** 2}, "lcp", "complementarity"
    conic = convert(problem, (Conic,))
    if conic is None:
        return {"primal": primal}, "none", ""
    source = "solver" if outcome.duals is not None else "recovered"
    y = outcome.duals if source == "solver" else recover(conic.P, conic.q, conic.A, conic.b,
                                                          conic.cones, z)
    found = measures(conic.P, conic.q[None], np.asarray(conic.A, float)[None],
                     np.asarray(conic.b, float)[None], conic.cones, z[None],
                     np.asarray(y, float)[None])
    gap, kind = float(found["gap"][0]), "duality"
    if source != "solver" and optimal_value is not None:
        objective = float(found["objective"][0])
        gap = abs(objective - optimal_value) / max(abs(optimal_value), 1e-300)
        kind = "objective"
    return {"primal": primal, "dual": float(found["dual"][0]), "gap": gap}, source, kind
