"""Solving formulations at one instant: solution sets and formulation x solver sweeps."""

from __future__ import annotations

from collections.abc import Callable, Iterable

import numpy as np
from cardan_forces.driveline.equilibrium import Operator
from cardan_forces.formulations import FORMULATIONS
from cardan_forces.formulations.convex import NotApplicable
from cardan_forces.formulations.sets import range_problems
from cardan_forces.solvers import Record, backends_for, solve

INTERVAL_SOLVER = "scipy-highs"


def intervals(op: Operator, i: int, solver: str = INTERVAL_SOLVER) -> dict[str, dict]:
    """``{name: {"min": float | None, "max": float | None, "status": str}}``.

    ``None`` marks an unbounded side; a side whose LP fails is ``None`` with the status
    saying so (never a number that was not checked).
    """
    eye = np.eye(len(op.names))
    return {name: value_range(op, i, eye[j], solver)
            for j, name in enumerate(op.names)}


def value_range(op: Operator, i: int, c: np.ndarray, solver: str = INTERVAL_SOLVER) -> dict:
    """``{"min", "max", "status"}`` of ``c'x`` over the rigid set at instant ``i``."""
    ends, statuses = [], []
    for problem in range_problems(op, i, c):
        record = solve(problem, solver)
        statuses.append(record.status)
        ends.append(float(c @ record.x) if record.status == "solved" else None)
    status = "solved" if all(s in ("solved", "unbounded") for s in statuses) else "/".join(
        statuses)
    return {"min": ends[0], "max": ends[1], "status": status}


def solve_all(
    op: Operator,
    i: int,
    formulations: Iterable[str] | None = None,
    solvers: Iterable[str] | None = None,
    tol: float | None = None,
    progress: Callable[[str], None] | None = None,
) -> list[Record]:
    """Every requested formulation with every requested backend that accepts it.

    The reference of each record is the ``clarabel`` answer of the same formulation at
    tolerance 1e-10 where that backend takes it.
    """
    names = list(formulations or FORMULATIONS)
    unknown = [f for f in names if f not in FORMULATIONS]
    if unknown:
        raise KeyError(f"unknown formulation(s) {', '.join(unknown)}; known: "
                       f"{', '.join(FORMULATIONS)}")
    records = []
    for formulation in names:
        try:
            problem = FORMULATIONS[formulation](op, i)
        except NotApplicable:
            if formulations is not None:
                raise
            continue  # not called for by this scene (e.g. friction without friction)
        usable = backends_for(problem)
        chosen = usable if solvers is None else [s for s in solvers if s in usable]
        reference = None
        if "clarabel" in usable:
            ref = solve(problem, "clarabel", tol=1e-10)
            reference = ref.x if ref.status == "solved" else None
        for solver in chosen:
            if progress:
                progress(f"solve: {formulation} with {solver}")
            records.append(solve(problem, solver, tol=tol, reference=reference))
    return records


def median_times(records: list[Record]) -> dict[str, float]:
    """Median setup + solve time (s) per backend."""
    by: dict[str, list[float]] = {}
    for r in records:
        by.setdefault(r.solver, []).append(r.setup_s + r.solve_s)
    return {k: float(np.median(v)) for k, v in by.items()}
