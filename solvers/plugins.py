"""Backends of other packages are untrusted: what the registry checks of them.

A backend added by :func:`~.registry.register` (at run time, or from an entry point of
the group ``cardan_forces.solvers``) is validated once, when it is registered
(:func:`validate`): a declaration the package cannot use is an :class:`InvalidBackend`
naming the field and what it must be. Its answers are checked before the package judges
them (:func:`outcome_fault`), and :func:`blame` adds the plugin's name to the reason of
any failure, so a broken plugin gives failed records that say whose they are while
every other backend runs. The package's own adapters are trusted and pay for none of it.
"""

from __future__ import annotations

import dataclasses
import math
import numbers

import numpy as np
from cardan_forces.formulations.batch import ConicBatch, LeastNormBatch
from cardan_forces.formulations.problems import LCP, LP, LS, NLS, QP, Conic

from .record import BatchOutcome, Outcome, Status

PROBLEMS = (LS, QP, LP, Conic, LCP, NLS)
"""The problem classes a backend may accept (``cardan_forces.formulations.problems``)."""
BATCHES = (LeastNormBatch, ConicBatch)
"""The batch classes a batched backend may accept (``cardan_forces.formulations.batch``)."""

ORIGINS: dict[str, str] = {}
"""Where each registered (not built-in) backend comes from, by backend name."""


class InvalidBackend(TypeError, ValueError):
    """A backend whose declaration the registry cannot use; the message names the field.

    Both a ``TypeError`` (a field of the wrong type) and a ``ValueError`` (a name
    already taken, an empty one).
    """


def validate(backend) -> None:
    """Raise :class:`InvalidBackend` listing every field of ``backend`` (a
    :class:`~.backend.Backend`) that is not what the registry relies on.
    """
    faults = [*_identity_faults(backend), *_class_faults(backend), *_callable_faults(backend),
              *_setting_faults(backend)]
    if faults:
        raise InvalidBackend(f"backend {backend.name!r} cannot be registered: "
                             + "; ".join(faults))


def _identity_faults(b):
    """Name, family, distributions and extra: the words every listing prints."""
    if not isinstance(b.name, str) or b.name.split() != [b.name]:
        yield f"name must be a non-empty str without spaces, not {b.name!r}"
    if not isinstance(b.family, str):
        yield f"family must be a str, not {b.family!r}"
    if not (_tuple_of(b.distributions, str) and all(b.distributions)):
        yield ("distributions must be a tuple of installed distribution names (str), "
               f"not {b.distributions!r}")
    if b.extra is not None and not isinstance(b.extra, str):
        yield f"extra must be None or a pip extra (str), not {b.extra!r}"


def _class_faults(b):
    """``accepts`` and ``batch_accepts``: tuples of the package's own classes."""
    for field, known in (("accepts", PROBLEMS), ("batch_accepts", BATCHES)):
        value = getattr(b, field)
        if not _tuple_of(value, type) or not all(issubclass(c, known) for c in value):
            names = ", ".join(c.__name__ for c in known)
            yield (f"{field} must be a tuple of classes among {names} (import them from "
                   f"{known[0].__module__}), not {value!r}")


def _callable_faults(b):
    """``solve``, ``batch`` and ``supports``, and that there is something to call."""
    for field in ("solve", "batch"):
        value = getattr(b, field)
        if value is not None and not callable(value):
            yield f"{field} must be None or callable, not {value!r}"
    if not callable(b.supports):
        yield f"supports must be callable, not {b.supports!r}"
    if b.solve is None and b.batch is None:
        yield "it gives neither solve nor batch"
    if b.solve is not None and b.accepts == ():
        yield "solve is given but accepts names no problem class"
    if b.batch is not None and b.batch_accepts == ():
        yield "batch is given but batch_accepts names no batch class"


def _setting_faults(b):
    """Tolerance parameters, their floor, warm start and the qpbenchmark profile."""
    if not _tuple_of(b.tolerances, str):
        yield f"tolerances must be a tuple of the solver's parameter names, not {b.tolerances!r}"
    if not _real(b.smallest_tol) or not math.isfinite(b.smallest_tol) or b.smallest_tol < 0:
        yield f"smallest_tol must be a finite number >= 0, not {b.smallest_tol!r}"
    if not isinstance(b.warm_start, bool):
        yield f"warm_start must be True or False, not {b.warm_start!r}"
    if b.qpbenchmark is not None and not callable(getattr(b.qpbenchmark, "options", None)):
        yield (f"qpbenchmark must be None or a settings.Profile (what the harness "
               f"calls is its options(setting)), not {b.qpbenchmark!r}")


def _tuple_of(value, cls) -> bool:
    return isinstance(value, tuple) and all(isinstance(v, cls) for v in value)


def _real(value) -> bool:
    return isinstance(value, numbers.Real) and not isinstance(value, bool)


def outcome_fault(outcome) -> str:
    """Why a registered backend's ``outcome`` cannot be judged ("" when it can): not an
    :class:`~.record.Outcome`, or fields the checks cannot read (a status that is no
    str, ``z``, ``y`` not one row of numbers, a message that is no str, times that are
    no numbers). A str status the package does not know is judged ``failed`` later.
    """
    if not isinstance(outcome, Outcome):
        return f"solve returned {type(outcome).__name__}, not an Outcome"
    if not isinstance(outcome.status, str):
        return f"Outcome.status is {outcome.status!r}, not a Status or its value (str)"
    for field in ("z", "y"):
        why = _row_fault(getattr(outcome, field))
        if why:
            return f"Outcome.{field} {why}"
    if not isinstance(outcome.message, str):
        return f"Outcome.message is {type(outcome.message).__name__}, not str"
    if outcome.iterations is not None and not isinstance(outcome.iterations, numbers.Integral):
        return f"Outcome.iterations is {outcome.iterations!r}, not an int or None"
    if outcome.objective is not None and not _real(outcome.objective):
        return f"Outcome.objective is {outcome.objective!r}, not a number or None"
    if not (_real(outcome.setup_s) and _real(outcome.solve_s)):
        return "Outcome.setup_s and solve_s must be numbers (s)"
    return ""


def batch_fault(outcome, T: int) -> str:
    """:func:`outcome_fault` of a batched backend's answer for ``T`` instants."""
    if not isinstance(outcome, BatchOutcome):
        return f"batch returned {type(outcome).__name__}, not a BatchOutcome"
    try:
        rows = [np.asarray(outcome.z, float), np.asarray(outcome.status, object),
                np.asarray(outcome.iterations)]
    except (TypeError, ValueError) as exc:
        return f"BatchOutcome fields are not arrays: {exc}"
    if any(r.ndim == 0 or len(r) != T for r in rows) or rows[0].ndim != 2:
        return f"BatchOutcome z, status and iterations must have {T} rows (z: (T, n))"
    return ""


def _row_fault(value) -> str:
    if value is None:
        return ""
    try:
        row = np.asarray(value, float)
    except (TypeError, ValueError):
        return f"is {type(value).__name__}, not an array of numbers"
    return "" if row.ndim == 1 else f"has shape {row.shape}, expected one dimension"


def blame(solver: str, message: str) -> str:
    """``message`` after where backend ``solver`` comes from, when it is not the
    package's (first: a table that shortens the reason keeps whose fault it is).
    """
    origin = ORIGINS.get(solver)
    return message if origin is None else f"{origin}: {message}"


def blamed(results):
    """``results`` (:class:`~.record.Results` of a registered backend) with where it
    comes from before the message of each failed instant that does not say it yet.
    """
    origin = ORIGINS[results.solver]
    failed = results.status == Status.FAILED
    message = tuple(f"{origin}: {m}" if bad and not m.startswith(origin) else m
                    for bad, m in zip(failed.tolist(), results.message))
    return dataclasses.replace(results, message=message)


def plugin_origin(point) -> str:
    """The plugin's name: the distribution that declares the entry point, and the entry
    point (``cardan solvers`` reports what it points at).
    """
    dist = getattr(point, "dist", None)
    return (f"plugin {dist.name} ({point.name})" if dist is not None
            else f"plugin entry point {point.name}")


def runtime_origin(backend) -> str:
    """The words that name a backend registered at run time: the module of its solve."""
    given = backend.solve if backend.solve is not None else backend.batch
    return f"registered from {getattr(given, '__module__', None) or '?'}"
