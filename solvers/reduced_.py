"""Backends ``<conic backend>-reduced``: a conic backend on the reduced form of a problem.

The equality (zero-cone) rows are eliminated per instant, ``z = z0 + N y``
(:func:`~.conversions.eliminate_equalities`), so the interior-point solver iterates on
fewer unknowns and no equality rows, with a structure (sizes, cones) that is the same at
every instant of a formulation. Its answer and multipliers are lifted back to the full
problem (:meth:`~.conversions.Reduced.lift`), which the package then judges by its own
residuals and optimality measures, as for every backend. The reduction is part of the
timed solve (``setup_s``, batched: the ``reduce`` and ``lift`` stages).

Which backends get a reduced variant is :data:`WRAPPED`: data, one line each.
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np
from cardan_forces.formulations.batch import ConicBatch
from cardan_forces.formulations.problems import Conic

from . import clarabel_, moreau_, qoco_, qocogen_
from .batch import BatchOutcome
from .conversions import eliminate_equalities, reduced_conic
from .record import Outcome
from .registry import Backend

WRAPPED = {"clarabel": clarabel_, "qoco": qoco_, "qoco-batched": qoco_, "moreau": moreau_,
           "moreau-warm": moreau_, "qocogen": qocogen_}
"""Backend name -> its adapter module; each gets a ``<name>-reduced`` variant (``qocogen``
only this one: its module is no adapter of the registry's own)."""

UNSCALED = {"clarabel": ("soc", "pow"), "moreau": ("pow",), "moreau-warm": ("pow",)}
"""Backend -> the cone kinds on which its reduced variant runs without equilibration
(``equilibrate_enable=False`` unless the caller sets it). The reduced data are the
formulation's (in units of the load) seen through an orthonormal basis. Measured on
the paper's 1001 instants: Clarabel's and moreau's Ruiz scaling nearly doubled the
iterations on ``compliance_hertz`` (20 against 11); Clarabel per instant, without it,
took 9.1 iterations instead of 13.7 on ``min_max`` (its worst dual residual 7e-10
instead of 1e-6) and 7.4 instead of 8.4 on ``socp_face``, but left 23 ``positive`` instants
inaccurate instead of 21 (so it keeps it on linear cones alone); moreau without it
missed one ``socp_face`` instant, so it keeps it there."""


def _defaults(backend: str, cones, options: dict) -> dict:
    """The options for the wrapped backend: no equilibration where :data:`UNSCALED`
    says so, under the caller's options.
    """
    off = any(kind in UNSCALED.get(backend, ()) for kind, _ in cones)
    return ({"equilibrate_enable": False} if off else {}) | options


EXTRAS: dict[str, str | None] = {f"{name}-reduced": module.EXTRAS[name]
                                 for name, module in WRAPPED.items()}


def _has_equalities(problem) -> bool:
    return any(kind == "zero" for kind, _ in problem.cones)


def _per_instant(solve, name: str):
    """``solve`` (a per-instant conic backend's) on the reduced problem with
    :func:`_defaults`, lifted back (the wrapped backends take no start, so
    ``initvals`` is not passed on).
    """

    def run(problem: Conic, tol=None, initvals=None, **options) -> Outcome:
        start = time.perf_counter()
        inner, red = reduced_conic(problem)
        reduced_s = time.perf_counter() - start
        out = solve(inner, tol=tol, **_defaults(name, inner.cones, options))
        lifted = time.perf_counter()
        if out.z is None:
            return dataclasses.replace(out, setup_s=out.setup_s + reduced_s)
        z, y = red.lift(np.asarray(out.z, float)[None],
                        None if out.y is None else np.asarray(out.y, float)[None])
        objective = None if out.objective is None else out.objective + float(red.offset[0])
        return dataclasses.replace(
            out, z=z[0], y=None if y is None else y[0], objective=objective,
            setup_s=out.setup_s + reduced_s + time.perf_counter() - lifted)

    return run


def _batched(solve_batch, name: str):
    """``solve_batch`` (a batched conic backend's) on the reduced batch with
    :func:`_defaults`, lifted back.
    """

    def run(batch: ConicBatch, tol=None, **options) -> BatchOutcome:
        start = time.perf_counter()
        red = eliminate_equalities(batch.P, batch.q, batch.A, batch.b, batch.cones,
                                   batch.null_space)
        inner = dataclasses.replace(batch, P=red.P, q=red.q, A=red.A, b=red.b,
                                    cones=red.cones, problems=(), null_space=None)
        reduced = time.perf_counter()
        out = solve_batch(inner, tol=tol, **_defaults(name, inner.cones, options))
        lifting = time.perf_counter()
        z, y = red.lift(np.asarray(out.z, float), out.y)
        done = time.perf_counter()
        stages = {"reduce": reduced - start, **out.stages, "lift": done - lifting}
        return dataclasses.replace(out, z=z, y=y, stages=stages,
                                   setup_s=out.setup_s + (reduced - start) + (done - lifting))

    return run


def _variant(backend: Backend) -> Backend:
    supports, name = backend.supports, backend.name
    return dataclasses.replace(
        backend, name=f"{backend.name}-reduced",
        solve=None if backend.solve is None else _per_instant(backend.solve, name),
        batch=None if backend.batch is None else _batched(backend.batch, name),
        supports=lambda problem: _has_equalities(problem) and supports(problem),
        warm_start=False)


def backends() -> list[Backend]:
    """The reduced variant of every installed backend of :data:`WRAPPED`."""
    return [_variant(b) for module in WRAPPED.values() for b in module.backends()
            if b.name in WRAPPED]
