"""Solver backends behind one interface (DESIGN §3).

>>> from solvers import solve, backends_for
>>> record = solve(problem, "clarabel", tol=1e-9)      # doctest: +SKIP
>>> record.status, record.forces(), record.residuals   # doctest: +SKIP

Every call returns a :class:`Record` whose status the package decides from its own
residuals, with its optimality measured from the problem data (typed: :class:`Status`,
:class:`Residuals`, :class:`Optimality`); solver failures are
records, never exceptions. :func:`solve_batch` solves all instants of a formulation's
batch (``cardan_forces.formulations.batch``) with a batched backend. :func:`register`
adds a backend of one's own (or an entry point in the group ``cardan_forces.solvers``),
validated when registered (:class:`InvalidBackend` names the field it refuses).
"""

from .judge import failed_record
from .plugins import InvalidBackend
from .record import ACCEPT, Optimality, Outcome, Record, Residuals, Status
from .registry import (
    Backend,
    SolverNotFound,
    UnsupportedProblem,
    available,
    backends_for,
    batch_backends,
    get,
    known_backends,
    plugin_errors,
    register,
    solve,
    solve_batch,
)

__all__ = [
    "ACCEPT",
    "Backend",
    "InvalidBackend",
    "Optimality",
    "Outcome",
    "Record",
    "Residuals",
    "SolverNotFound",
    "Status",
    "UnsupportedProblem",
    "available",
    "backends_for",
    "batch_backends",
    "failed_record",
    "get",
    "known_backends",
    "plugin_errors",
    "register",
    "solve",
    "solve_batch",
]
