"""Solver backends behind one interface (DESIGN §3).

>>> from solvers import solve, backends_for
>>> record = solve(problem, "clarabel", tol=1e-9)      # doctest: +SKIP
>>> record.status, record.forces(), record.residuals   # doctest: +SKIP

Every call returns a :class:`Record` whose status the package decides from its own
residuals; solver failures are records, never exceptions.
"""

from .record import ACCEPT, STATUSES, Record, failed_record
from .registry import (
    Backend,
    SolverNotFound,
    UnsupportedProblem,
    available,
    backends_for,
    get,
    known_backends,
    solve,
)

__all__ = [
    "ACCEPT",
    "STATUSES",
    "Backend",
    "Record",
    "SolverNotFound",
    "UnsupportedProblem",
    "available",
    "backends_for",
    "failed_record",
    "get",
    "known_backends",
    "solve",
]
