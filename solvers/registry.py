"""Registry of solver backends and the one entry point :func:`solve`.

Each adapter module (``<family>_.py``) exposes ``EXTRAS`` (every backend name it can
provide and the pip extra that installs it, ``None`` for core dependencies) and
``backends()``, which imports its package and returns ``[]`` when it is missing. A
missing package therefore makes its backends absent, never an import error, and asking
for one raises :class:`SolverNotFound` with the install hint.

A backend declares everything the rest of the package asks about it (:class:`Backend`):
its tolerance parameters, whether it warm-starts, whether it solves batches, the
distributions it runs on. Adding a backend is one adapter file and one entry in
:data:`ADAPTERS`; no list elsewhere changes.

Backends of other packages: :func:`register` adds one at run time, and a distribution
that declares an entry point in the group :data:`ENTRY_POINTS` (pointing at a
:class:`Backend`, a list of them, or a function returning either) has its backends
registered when the registry first loads, so they appear in ``cardan solvers`` and
every command without editing this package. A plugin that fails to load is left out
and reported by :func:`plugin_errors`; it never breaks the registry.
"""

from __future__ import annotations

import dataclasses
import functools
import importlib
import importlib.metadata
import operator
import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from . import settings
from .batch import BatchOutcome, BatchRecord, finalize_batch, supports_batch
from .conversions import convert, reachable
from .record import Outcome, Record, Stacks, Status, finalize_all

if TYPE_CHECKING:  # settings_profiles looks backends up here: a type-only import
    from .settings_profiles import Profile

ADAPTERS = ("numpy_kkt_", "scipy_", "qpsolvers_", "cvxpy_", "clarabel_", "qoco_", "lcp_",
            "numpy_batched_", "moreau_", "reduced_")
"""Adapter modules of this package, loaded lazily by :func:`available`."""


class SolverNotFound(LookupError):
    """The named backend is not registered (unknown, or its package is not installed)."""


class UnsupportedProblem(TypeError):
    """The backend cannot take this problem class, even after conversion."""


def _always(problem) -> bool:
    return True


@dataclass(frozen=True, kw_only=True)
class Backend:
    """One named way to solve problems, and what it declares about itself.

    ``solve(problem, tol, initvals, **options) -> Outcome`` receives a problem of one of
    the ``accepts`` classes for which ``supports(problem)`` holds (e.g. no power cone
    for ECOS); ``None`` for a backend that only batches. ``distributions`` are the
    installed distributions it runs on (its version), ``extra`` the pip extra that
    installs it (``None``: core dependency). ``tolerances`` are the solver's own
    parameters a requested tolerance sets (empty: a direct method, ``tol`` ignored),
    clamped below at ``smallest_tol``; ``warm_start`` whether ``initvals`` reach the
    solver; ``batch(batch, tol, **options) -> BatchOutcome`` solves all instants of a
    formulation's batch of one of the ``batch_accepts`` classes at once.
    ``qpbenchmark``: how it takes qpbenchmark's four settings (:mod:`.settings_profiles`;
    ``None``: it does not).
    """

    name: str
    family: str
    distributions: tuple[str, ...]
    extra: str | None = None
    accepts: tuple[type, ...] = ()
    solve: Callable[..., Outcome] | None = None
    supports: Callable[[object], bool] = _always
    tolerances: tuple[str, ...] = ()
    smallest_tol: float = 0.0
    warm_start: bool = False
    batch: Callable | None = None
    batch_accepts: tuple[type, ...] = ()
    qpbenchmark: Profile | None = None

    @property
    def version(self) -> str:
        """``"name version"`` of its distributions, joined by ``" + "``."""
        return dist_version(*self.distributions)

    def options(self, tol: float | None) -> dict[str, float]:
        """The solver's own keyword arguments for tolerance ``tol`` (none for ``None``)."""
        return settings.options_for(self.tolerances, tol, self.smallest_tol)


def dist_version(*dists: str) -> str:
    """``"name version"`` of installed distributions, joined by ``" + "``."""
    parts = []
    for dist in dists:
        try:
            parts.append(f"{dist} {importlib.metadata.version(dist)}")
        except importlib.metadata.PackageNotFoundError:
            parts.append(f"{dist} ?")
    return " + ".join(parts)


_CACHE: dict[str, Backend] = {}
_KNOWN: dict[str, str | None] = {}
_PLUGIN_ERRORS: dict[str, str] = {}

ENTRY_POINTS = "cardan_forces.solvers"
"""Entry-point group of other packages' backends (see :func:`register`)."""


def _load() -> None:
    if _CACHE:
        return
    known, found = {}, {}
    for module_name in ADAPTERS:
        known.update(_adapter(module_name).EXTRAS)
        found.update((backend.name, backend) for backend in _adapter_backends(module_name))
    _KNOWN.update(known | {name: backend.extra for name, backend in found.items()})
    _CACHE.update(found)
    _load_plugins()


_BY_ADAPTER: dict[str, list[Backend]] = {}


def _adapter(module_name: str):
    return importlib.import_module(f"{__package__}.{module_name}")


def _adapter_backends(module_name: str) -> list[Backend]:
    """One adapter's backends, its package imported on first use (once)."""
    if module_name not in _BY_ADAPTER:
        _BY_ADAPTER[module_name] = _adapter(module_name).backends()
    return _BY_ADAPTER[module_name]


def _one(name: str) -> Backend | None:
    """``name``'s backend before the whole registry is loaded: from the one adapter that
    declares it, without importing the others' packages (a command that solves with one
    backend does not pay for cvxpy); ``None`` where that does not settle it.
    """
    return None if _CACHE else _declared(name)


@functools.cache
def _declared(name: str) -> Backend | None:
    """:func:`_one`'s lookup, once per name (a solve asks at every instant)."""
    owners = [m for m in ADAPTERS if name in _adapter(m).EXTRAS]
    if len(owners) != 1:
        return None
    return next((b for b in _adapter_backends(owners[0]) if b.name == name), None)


def register(backend: Backend) -> Backend:
    """Add ``backend`` (a :class:`Backend`) to the registry, so :func:`solve`, every
    command and ``cardan solvers`` know it; returns it. Its ``solve`` receives a problem
    of one of its ``accepts`` classes and returns an :class:`Outcome`; the package
    judges the answer as it judges its own backends'. A name already taken by another
    backend is a ``ValueError`` (registering the same object again is harmless).
    """
    if not isinstance(backend, Backend):
        raise TypeError(f"register() takes a Backend, not {type(backend).__name__}")
    _load()
    if _CACHE.get(backend.name, backend) is not backend:
        raise ValueError(f"backend {backend.name!r} is already registered")
    _CACHE[backend.name] = backend
    _KNOWN[backend.name] = backend.extra
    return backend


def plugin_errors() -> dict[str, str]:
    """Entry points of :data:`ENTRY_POINTS` that could not be registered, with why."""
    _load()
    return dict(_PLUGIN_ERRORS)


def _load_plugins() -> None:
    """Register the backends every installed entry point of :data:`ENTRY_POINTS` gives;
    one that raises, gives no backend or a taken name is recorded, not registered.
    """
    for point in importlib.metadata.entry_points(group=ENTRY_POINTS):
        try:
            given = point.load()
            if callable(given) and not isinstance(given, Backend):
                given = given()
            backends = [given] if isinstance(given, Backend) else list(given)
            for backend in backends:
                register(backend)
        except Exception as exc:  # a broken plugin is reported, never fatal
            _PLUGIN_ERRORS[f"{point.name} ({point.value})"] = f"{type(exc).__name__}: {exc}"


def available() -> dict[str, Backend]:
    """All registered backends by name, in registration order."""
    _load()
    return dict(_CACHE)


def known_backends() -> dict[str, str | None]:
    """Every backend name this package can provide, installed or not, with its pip extra.

    ``None`` marks a core dependency (``pip install cardan-forces`` brings it).
    """
    _load()
    return dict(_KNOWN)


def get(name: str) -> Backend:
    """The backend called ``name``; :class:`SolverNotFound` with an install hint if absent."""
    found = _one(name)
    if found is not None:
        return found
    _load()
    if name in _CACHE:
        return _CACHE[name]
    if name in _KNOWN:
        extra = _KNOWN[name]
        target = "cardan-forces" if extra is None else f"cardan-forces[{extra}]"
        raise SolverNotFound(f"backend {name!r} needs a package that is not installed: "
                             f'pip install "{target}"')
    raise SolverNotFound(f"unknown backend {name!r}; available: {', '.join(_CACHE)}")


def backends_for(problem) -> list[str]:
    """Names of the backends that can solve ``problem`` (directly or after conversion)."""
    converted = {}
    return [b.name for b in available().values() if _takes(b, problem, converted)]


def takes(name: str, problem) -> bool:
    """Whether backend ``name`` is installed and can solve ``problem`` (as
    :func:`backends_for` would list it), loading only what that asks.
    """
    try:
        return _takes(get(name), problem, {})
    except SolverNotFound:
        return False


def _takes(backend: Backend, problem, converted: dict) -> bool:
    """``backend`` solves ``problem``; ``converted``: the conversions made so far, by
    the classes they were made for (shared between backends that accept the same).
    """
    if backend.solve is None or not reachable(type(problem), backend.accepts):
        return False
    key = backend.accepts
    if key not in converted:
        try:
            converted[key] = convert(problem, key)
        except Exception:  # a conversion that fails rules the backend out
            converted[key] = None
    return converted[key] is not None and bool(backend.supports(converted[key]))


@dataclass(frozen=True)
class Pending:
    """A solve whose checks are still to come (:func:`solve_unchecked`): the adapter's
    outcome, the problem it received and what the checks need. :func:`check` turns a
    list of them into records in one vectorized pass (a few microseconds per instant),
    so a loop over instants pays the checks once, not per call.
    """

    problem: object
    solver: str
    outcome: Outcome
    received: object
    reference: np.ndarray | None
    optimal_value: float | None
    convert_s: float
    elapsed_s: float

    @property
    def status(self) -> Status:
        """The provisional status: the solver's, ``failed`` for an answer without a
        finite ``z`` (the checks may still turn ``solved`` into ``inaccurate`` or back).
        """
        try:
            status = Status(self.outcome.status)
        except ValueError:
            return Status.FAILED
        z = self.outcome.z
        finite = z is not None and bool(np.all(np.isfinite(np.asarray(z, float))))
        return status if finite or not status.has_answer else Status.FAILED

    @property
    def z(self) -> np.ndarray | None:
        """The solver's variable."""
        return self.outcome.z


_PENDING = operator.attrgetter("problem", "outcome", "reference", "optimal_value",
                               "convert_s", "received", "elapsed_s")
"""What :func:`check` reads of a :class:`Pending`, in :func:`finalize_all`'s order."""


def check(pending: list[Pending], stacks: Stacks | None = None) -> list[Record]:
    """The package-judged records of deferred solves, as :func:`solve` returns them
    (``stacks``: their problems' data stacked beforehand, :func:`.record.stack_all`).
    """
    if not pending:
        return []
    problems, outcomes, references, optimal_values, convert_s, received, elapsed_s = zip(
        *map(_PENDING, pending))
    return finalize_all(problems, pending[0].solver, outcomes, references=references,
                        optimal_values=optimal_values, extra_setup_s=convert_s,
                        received=received, elapsed_s=elapsed_s, stacks=stacks)


def solve(
    problem,
    solver: str,
    tol: float | None = None,
    initvals: np.ndarray | None = None,
    reference: np.ndarray | None = None,
    optimal_value: float | None = None,
    **options,
) -> Record:
    """Solve ``problem`` with backend ``solver`` and return the package-judged record.

    ``tol`` is translated by :mod:`cardan_forces.solvers.settings` (None: the solver's defaults);
    ``initvals`` is a start in the solver's variable (ignored where the backend cannot
    warm-start); ``reference`` is the force vector the record is compared with;
    ``optimal_value`` the problem's optimal objective (for the objective gap of a
    backend without duals);
    ``options`` go to the backend unchanged and override ``tol``. Solver failures of any
    kind (exceptions, NaN, iteration limits) come back as records; only an unknown
    backend (:class:`SolverNotFound`) or a problem class it cannot take
    (:class:`UnsupportedProblem`) raise. :func:`solve_unchecked` and :func:`check` do
    the same in two steps, the checks of many instants at once.
    """
    return check([solve_unchecked(problem, solver, tol, initvals, reference, optimal_value,
                                  **options)])[0]


def solve_unchecked(problem, solver: str, tol: float | None = None,
                    initvals: np.ndarray | None = None, reference: np.ndarray | None = None,
                    optimal_value: float | None = None, **options) -> Pending:
    """:func:`solve` without the checks: the backend's outcome, for :func:`check`."""
    backend = get(solver)
    if backend.solve is None or not reachable(type(problem), backend.accepts):
        raise UnsupportedProblem(f"{solver} takes {[c.__name__ for c in backend.accepts]}, "
                                 f"not {type(problem).__name__}")
    start = time.perf_counter()

    def pending(outcome, received, convert_s=0.0):
        return Pending(problem, solver, outcome, received, reference, optimal_value,
                       convert_s, time.perf_counter() - start)

    try:
        converted = convert(problem, backend.accepts)
    except Exception as exc:
        return pending(Outcome(Status.FAILED, None, setup_s=time.perf_counter() - start,
                               message=f"conversion failed: {type(exc).__name__}: {exc}"),
                       problem)
    if not backend.supports(converted):
        raise UnsupportedProblem(f"{solver} does not support this {type(converted).__name__}")
    convert_s = time.perf_counter() - start
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            outcome = backend.solve(converted, tol=tol, initvals=initvals, **options)
        except (KeyboardInterrupt, SystemExit):
            raise
        except BaseException as exc:  # Rust panics (pyo3) derive from BaseException
            elapsed = time.perf_counter() - start
            return pending(Outcome(Status.FAILED, None, message=f"{type(exc).__name__}: {exc}",
                                   setup_s=convert_s, solve_s=elapsed - convert_s), converted)
    if caught:
        outcome = dataclasses.replace(outcome, message=with_warnings(outcome.message, caught))
    return pending(outcome, converted, convert_s)


def with_warnings(message: str, caught) -> str:
    """``message`` with the distinct texts of the warnings ``caught`` while a solver ran
    (``warnings.catch_warnings(record=True)``), joined by ``"; "``: a solver's notes stay
    with its solve instead of reaching stderr.
    """
    return "; ".join(filter(None, [message, *dict.fromkeys(str(w.message) for w in caught)]))


def batch_backends(batch) -> list[str]:
    """Names of the backends that solve ``batch`` (a formulation's batch) as one batch."""
    return [b.name for b in available().values() if supports_batch(b, batch)]


def solve_batch(batch, solver: str, tol: float | None = None,
                reference: np.ndarray | None = None, **options) -> BatchRecord:
    """Solve every instant of ``batch`` at once with backend ``solver``: the records of
    all instants as arrays, judged as :func:`solve` judges one (failures are records).
    """
    backend = get(solver)
    if not supports_batch(backend, batch):
        raise UnsupportedProblem(f"{solver} does not solve a {type(batch).__name__} batch")
    T = len(batch.instants)
    start = time.perf_counter()
    try:
        outcome = backend.batch(batch, tol=tol, **options)
    except (KeyboardInterrupt, SystemExit):
        raise
    except BaseException as exc:  # noqa: BLE001 - a failing solver is a failed batch
        outcome = BatchOutcome(status=np.full(T, Status.FAILED, object), z=np.zeros((T, 0)),
                               y=None, iterations=np.zeros(T, int), setup_s=0.0,
                               solve_s=time.perf_counter() - start,
                               messages=(f"{type(exc).__name__}: {exc}",) * T)
    return finalize_batch(batch, solver, outcome, reference=reference)
