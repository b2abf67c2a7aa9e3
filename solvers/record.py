"""The solution record: what every solver call returns, judged by the package (DESIGN §3).

An adapter reports an :class:`Outcome` in the solver's own variable ``z``;
:func:`finalize` maps it to forces with ``problem.to_forces``, measures the residuals
with ``problem.checks`` and decides the final status. The solver's word is only an
upper bound: a reported success whose residuals exceed :data:`ACCEPT` becomes
``"inaccurate"``, and a success with NaN or inf output becomes ``"failed"``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

STATUSES = ("solved", "inaccurate", "unbounded", "infeasible", "failed")
"""Every status a record can carry, from best to worst (a run over several instants
carries its worst); only ``"solved"`` means the forces are trusted."""

ACCEPT = 1e-6
"""Largest relative residual (equilibrium, sign, complementarity, cone) of a solved record."""

_WITH_ANSWER = ("solved", "inaccurate")


@dataclass(frozen=True)
class Outcome:
    """What an adapter hands back: the solver's own status mapped to :data:`STATUSES`.

    ``z`` is the solver's variable (``None`` when it returned none); ``setup_s`` is the
    time spent building matrices and solver objects, ``solve_s`` the time in the solver.
    """

    status: str
    z: np.ndarray | None
    iterations: int | None = None
    message: str = ""
    objective: float | None = None
    setup_s: float = 0.0
    solve_s: float = 0.0


@dataclass(frozen=True)
class Record:
    """One solver's answer to one problem, with residuals measured by the package.

    ``x`` holds the named forces (N) in ``names`` order: finite when the status is
    ``"solved"`` or ``"inaccurate"``, all NaN otherwise (``z`` keeps whatever the solver
    returned). ``residuals`` are relative (see ``ForceChecks.residuals``), ``inf`` for a
    record without forces; ``"reference"`` is ``||x - x_ref|| / max(||x_ref||, 1e-12)``,
    present only when a reference was given. ``iterations`` is the solver's own count,
    ``None`` when it reports none (MINPACK, SVD).
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


def finalize(
    problem,
    solver: str,
    outcome: Outcome,
    reference: np.ndarray | None = None,
    extra_setup_s: float = 0.0,
) -> Record:
    """Turn an adapter's outcome into a record, deciding the final status from residuals."""
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
    if status == "solved" and residuals[worst] > ACCEPT:
        status = "inaccurate"
        notes.append(f"{worst} residual {residuals[worst]:.1e} > {ACCEPT:.0e}")
    if reference is not None:
        residuals["reference"] = _reference_distance(x, reference)
    objective = outcome.objective if status in _WITH_ANSWER else None
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
    )
