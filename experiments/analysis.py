"""Solving formulations at one instant: every formulation x solver (``cardan solve``).

Solution-set intervals live in the study layer (:mod:`cardan_forces.experiments.study`).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable

from cardan_forces.driveline.equilibrium import Operator
from cardan_forces.formulations import FORMULATIONS
from cardan_forces.formulations import formulation as registered
from cardan_forces.formulations.convex import NotApplicable
from cardan_forces.solvers import Record, backends_for, solve
from cardan_forces.solvers.settings import REFERENCE_TOL


def solve_all(
    op: Operator,
    i: int,
    formulations: Iterable[str] | None = None,
    solvers: Iterable[str] | None = None,
    tol: float | None = None,
    progress: Callable[[str], None] | None = None,
    built: dict | None = None,
) -> list[Record]:
    """Every requested formulation with every requested backend that accepts it.

    The reference of each record is the ``clarabel`` answer of the same formulation at
    :data:`~cardan_forces.solvers.settings.REFERENCE_TOL` where that backend takes it.
    ``built``: the problems at instant ``i`` already built (:func:`build_all`), so none is
    built twice.
    """
    names = [registered(f).name for f in formulations or FORMULATIONS]  # a typo: its hint
    built = built if built is not None else build_all(op, i, names)
    records = []
    for formulation in names:
        problem = built[formulation]
        if isinstance(problem, NotApplicable):
            if formulations is not None:
                raise problem
            continue  # not called for by this scene (e.g. friction without friction)
        usable = backends_for(problem)
        chosen = usable if solvers is None else [s for s in solvers if s in usable]
        reference = None
        if "clarabel" in usable:
            ref = solve(problem, "clarabel", tol=REFERENCE_TOL)
            reference = ref.x if ref.status == "solved" else None
        for solver in chosen:
            if progress:
                progress(f"solve: {formulation} with {solver}")
            records.append(solve(problem, solver, tol=tol, reference=reference))
    return records


def build_all(op: Operator, i: int, names: Iterable[str]) -> dict:
    """Each formulation's problem at instant ``i``, or the :class:`NotApplicable` that
    says why the scene does not call for it.
    """
    built = {}
    for name in names:
        try:
            built[name] = FORMULATIONS[name](op, i)
        except NotApplicable as err:
            built[name] = err
    return built
