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
every command without editing this package. Such backends are untrusted
(:mod:`.plugins`): one that fails to load (whatever it raises, ``SystemExit`` included)
or declares what the registry cannot use is left out and reported by
:func:`plugin_errors`; one whose ``supports``, ``solve`` or ``batch`` raises or answers
what cannot be judged gives failed records naming the plugin. It never breaks the
registry, nor the other backends' rows.
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import importlib
import importlib.metadata
import sys
import time
import warnings
from dataclasses import dataclass

import numpy as np
from cardan_forces.formulations.batch import ConicBatch

from cardan_forces.util.names import did_you_mean

from . import plugins, reduced_, settings
from .backend import Backend
from .conversions import convert, reachable
from .judge import failed_record, finalize_all, finalize_batch
from .plugins import InvalidBackend, blame
from .record import BatchOutcome, Outcome, Record, Results, Status
from .stacking import Stacks

ADAPTERS = ("numpy_kkt_", "scipy_", "qpsolvers_", "cvxpy_", "clarabel_", "qoco_", "lcp_",
            "numpy_batched_", "moreau_", "qocogen_", "newton_", "reduced_ipm_")
"""Adapter modules of this package, loaded lazily by :func:`available`."""


class SolverNotFound(KeyError):
    """The named backend is not registered (unknown, or its package is not installed).

    A ``KeyError`` (a ``LookupError``) whose message is printed as written, unquoted.
    """

    def __str__(self) -> str:
        return str(self.args[0]) if self.args else "backend not found"


class UnsupportedProblem(TypeError):
    """The backend cannot take this problem class, even after conversion."""


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
        _BY_ADAPTER[module_name] = _with_reductions(_adapter(module_name).backends())
    return _BY_ADAPTER[module_name]


def _with_reductions(found: list[Backend]) -> list[Backend]:
    """An adapter's backends as registered: each it declares (but one made for the
    reduced form alone), then the reduced variant of each that takes it.
    """
    return ([b for b in found if not b.reduced_only]
            + [reduced_.variant(b) for b in found if b.reducible or b.reduced_only])


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
    judges the answer as it judges its own backends'. A declaration the registry cannot
    use (:func:`.plugins.validate`) or a name already taken by another backend is an
    :class:`~.plugins.InvalidBackend` (a ``TypeError`` and a ``ValueError``) naming the
    field; registering the same object again is harmless.
    """
    if not isinstance(backend, Backend):
        raise InvalidBackend(f"register() takes a Backend, not {type(backend).__name__}")
    plugins.validate(backend)
    _load()
    if _CACHE.get(backend.name, backend) is not backend:
        raise InvalidBackend(f"backend {backend.name!r} is already registered")
    _CACHE[backend.name] = backend
    _KNOWN[backend.name] = backend.extra
    plugins.ORIGINS.setdefault(backend.name, plugins.runtime_origin(backend))
    return backend


def plugin_errors() -> dict[str, str]:
    """Entry points of :data:`ENTRY_POINTS` that could not be registered, with why."""
    _load()
    return dict(_PLUGIN_ERRORS)


def _load_plugins(points=None) -> None:
    """Register the backends every entry point of :data:`ENTRY_POINTS` gives (``points``:
    those to load, default the installed ones); one that raises anything but
    ``KeyboardInterrupt`` (``SystemExit`` too), gives no backend, an invalid one or a
    taken name is recorded in :func:`plugin_errors`, not registered. What a plugin
    prints while it loads goes to stderr (``--json`` stays JSON on stdout).
    """
    with contextlib.redirect_stdout(sys.stderr):
        try:
            points = list(importlib.metadata.entry_points(group=ENTRY_POINTS)
                          if points is None else points)
        except Exception as exc:  # broken installed metadata: no plugins, said once
            _PLUGIN_ERRORS[ENTRY_POINTS] = f"{type(exc).__name__}: {exc}"
            points = []
        for point in points:
            _load_plugin(point)


def _load_plugin(point) -> None:
    """Register the backends of one entry point, each on its own (one bad backend does
    not keep its siblings out); failures joined into its :func:`plugin_errors` entry.
    """
    label, why = f"{point.name} ({point.value})", []
    try:
        given = _given(point)
    except KeyboardInterrupt:
        raise
    except BaseException as exc:  # noqa: BLE001 - a plugin's SystemExit ends no command
        given, why = [], [f"{type(exc).__name__}: {exc}"]
    for backend in given:
        try:
            register(backend)
        except KeyboardInterrupt:
            raise
        except BaseException as exc:  # noqa: BLE001 - a Backend subclass runs its code
            why.append(f"{type(exc).__name__}: {exc}")
        else:
            plugins.ORIGINS[backend.name] = plugins.plugin_origin(point)
    if why:
        _PLUGIN_ERRORS[label] = "; ".join(why)


def _given(point) -> list:
    """The backends an entry point gives: a :class:`Backend`, a list or tuple of them,
    or a function returning either.
    """
    given = point.load()
    if callable(given) and not isinstance(given, Backend):
        given = given()
    if isinstance(given, Backend):
        return [given]
    if isinstance(given, (list, tuple)):
        return list(given)
    raise InvalidBackend(f"it gives {type(given).__name__}, not a Backend, a list of them "
                         "or a function returning either")


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
    near = did_you_mean(name, {**_CACHE, **_KNOWN})
    raise SolverNotFound(f"unknown backend {name!r}" + (near or f"; available: "
                                                         f"{', '.join(_CACHE)}"))


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
    A ``supports`` that raises does not rule the backend out: its solve is then a
    failed record that says why (:func:`solve_unchecked`).
    """
    if backend.solve is None or not reachable(type(problem), backend.accepts):
        return False
    key = backend.accepts
    if key not in converted:
        try:
            converted[key] = convert(problem, key)
        except Exception:  # a conversion that fails rules the backend out
            converted[key] = None
    return converted[key] is not None and _supports(backend, converted[key]) is not False


def _supports(backend: Backend, problem) -> bool | str:
    """``backend.supports(problem)``, or why it could not say (what it raised)."""
    try:
        return bool(backend.supports(problem))
    except KeyboardInterrupt:
        raise
    except BaseException as exc:  # noqa: BLE001 - a plugin's fault is its record's
        return blame(backend.name, f"supports() raised {type(exc).__name__}: {exc}")


@dataclass(frozen=True)
class Pending:
    """A solve whose checks are still to come (:func:`solve_unchecked`): the adapter's
    outcome, the problem it received and what the checks need. :func:`check` turns a
    list of them into records in one vectorized pass, so a loop over instants pays the
    checks' fixed cost once, not per call.
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


def check(pending: list[Pending], stacks: Stacks | None = None) -> Results:
    """The package-judged results of deferred solves, as :func:`solve` judges one
    (``stacks``: their problems' data stacked beforehand, :func:`.stacking.stack_all`).
    A registered backend's failed instants name where it comes from; an answer of one
    that the checks cannot read fails alone (:func:`_check_each`).
    """
    if not pending:
        return Results.of([])
    solver = pending[0].solver
    try:
        results = finalize_all(
            [p.problem for p in pending], solver, [p.outcome for p in pending],
            references=[p.reference for p in pending],
            optimal_values=[p.optimal_value for p in pending],
            extra_setup_s=[p.convert_s for p in pending],
            received=[p.received for p in pending],
            elapsed_s=[p.elapsed_s for p in pending], stacks=stacks)
    except Exception as exc:
        if solver not in plugins.ORIGINS:
            raise  # the package's own backends: a fault of the checks, not hidden
        return _check_each(pending, exc)
    return results if solver not in plugins.ORIGINS else plugins.blamed(results)


def _check_each(pending: list[Pending], exc: Exception) -> Results:
    """:func:`check` of a registered backend's answers one by one, after the pass over
    all of them raised ``exc``: each that raises alone is a failed record saying why.
    """
    if len(pending) > 1:
        return Results.of([record for p in pending for record in check([p])])
    p = pending[0]
    why = f"answer could not be checked: {type(exc).__name__}: {exc}"
    return Results.of([failed_record(p.problem, p.solver, blame(p.solver, why),
                                     reference=p.reference)])


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
        raise UnsupportedProblem(f"{solver} takes {_names(backend.accepts)}, "
                                 f"not {type(problem).__name__}")
    start = time.perf_counter()

    def pending(outcome, received, convert_s=0.0):
        return Pending(problem, solver, outcome, received, reference, optimal_value,
                       convert_s, time.perf_counter() - start)

    def failed(message, received, convert_s=0.0):
        elapsed = time.perf_counter() - start
        return pending(Outcome(Status.FAILED, None, message=blame(solver, message),
                               setup_s=convert_s, solve_s=elapsed - convert_s), received)

    try:
        converted = convert(problem, backend.accepts)
    except Exception as exc:
        return failed(f"conversion failed: {type(exc).__name__}: {exc}", problem,
                      time.perf_counter() - start)
    supported = _supports(backend, converted)
    if isinstance(supported, str):
        return failed(supported, converted)
    if not supported:
        raise UnsupportedProblem(f"{solver} does not support this {type(converted).__name__}")
    convert_s = time.perf_counter() - start
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            outcome = backend.solve(converted, tol=tol, initvals=initvals, **options)
        except KeyboardInterrupt:
            raise
        except BaseException as exc:  # Rust panics (pyo3) derive from BaseException
            return failed(f"{type(exc).__name__}: {exc}", converted, convert_s)
    if solver in plugins.ORIGINS and (why := plugins.outcome_fault(outcome)):
        return failed(why, converted, convert_s)
    if caught:
        outcome = dataclasses.replace(outcome, message=with_warnings(outcome.message, caught))
    return pending(outcome, converted, convert_s)


def _names(classes) -> str:
    """Class names joined by "/" (``"QP/Conic"``)."""
    return "/".join(c.__name__ for c in classes) or "no problem class"


def with_warnings(message: str, caught) -> str:
    """``message`` with the distinct texts of the warnings ``caught`` while a solver ran
    (``warnings.catch_warnings(record=True)``), joined by ``"; "``: a solver's notes stay
    with its solve instead of reaching stderr.
    """
    return "; ".join(filter(None, [message, *dict.fromkeys(str(w.message) for w in caught)]))


def batch_backends(batch) -> list[str]:
    """Names of the backends that solve ``batch`` (a formulation's batch) as one batch
    (one whose ``supports`` raises included: its batch is then a failed one).
    """
    return [b.name for b in available().values() if _batches(b, batch) is not False]


def batches(name: str, batch) -> bool:
    """Whether backend ``name`` is installed and solves ``batch`` as one batch, loading
    only what that asks (as :func:`takes` for one problem).
    """
    try:
        return _batches(get(name), batch) is True
    except SolverNotFound:
        return False


def _batches(backend: Backend, batch) -> bool | str:
    """Whether ``backend`` solves ``batch`` as one batch, or why it could not say."""
    if backend.batch is None or not isinstance(batch, backend.batch_accepts):
        return False
    return _supports(backend, batch)


def solve_batch(batch, solver: str, tol: float | None = None,
                reference: np.ndarray | None = None, **options) -> Results:
    """Solve every instant of ``batch`` at once with backend ``solver``: the results of
    all instants as columns, judged as :func:`solve` judges one (failures are records).
    """
    backend = get(solver)
    supported = _batches(backend, batch)
    if supported is False:
        raise UnsupportedProblem(f"{solver} does not solve a {type(batch).__name__} batch")
    T = len(batch.instants)
    start = time.perf_counter()
    try:
        outcome = (_failed_batch(supported, batch, start) if isinstance(supported, str)
                   else backend.batch(batch, tol=tol, **options))
    except KeyboardInterrupt:
        raise
    except BaseException as exc:  # noqa: BLE001 - a failing solver is a failed batch
        outcome = _failed_batch(blame(solver, f"{type(exc).__name__}: {exc}"), batch, start)
    if solver in plugins.ORIGINS and (why := plugins.batch_fault(outcome, T)):
        outcome = _failed_batch(blame(solver, why), batch, start)
    try:
        return finalize_batch(batch, solver, outcome, reference=reference)
    except Exception as exc:
        if solver not in plugins.ORIGINS:
            raise  # the package's own backends: a fault of the checks, not hidden
        why = blame(solver, f"answer could not be checked: {type(exc).__name__}: {exc}")
        return finalize_batch(batch, solver, _failed_batch(why, batch, start),
                              reference=reference)


def _failed_batch(message: str, batch, start: float) -> BatchOutcome:
    """``batch``'s instants all failed, each with ``message``, begun at ``start``; the
    variable NaN in the batch's own width (the forces of a :class:`LeastNormBatch`).
    """
    T = len(batch.instants)
    width = batch.q.shape[1] if isinstance(batch, ConicBatch) else len(batch.checks.names)
    return BatchOutcome(status=np.full(T, Status.FAILED, object),
                        z=np.full((T, width), np.nan), y=None, iterations=np.zeros(T, int),
                        setup_s=0.0, solve_s=time.perf_counter() - start,
                        messages=(message,) * T)


def profile(backend: str) -> settings.Profile | None:
    """The profile backend ``backend`` declares (its ``Backend.qpbenchmark``), ``None``
    for one without, or not installed.
    """
    try:
        return get(backend).qpbenchmark
    except SolverNotFound:
        return None


def qpbenchmark_options(backend: str, setting: str) -> dict:
    """The keyword arguments backend ``backend`` gets at qpbenchmark setting ``setting``
    (``KeyError`` for a backend without a profile or an unknown setting).
    """
    found = profile(backend)
    if found is None:
        raise KeyError(f"backend {backend!r} declares no qpbenchmark settings")
    return found.options(setting)


def has_profile(backend: str) -> bool:
    """Whether ``backend`` declares how it takes qpbenchmark's settings."""
    return profile(backend) is not None
