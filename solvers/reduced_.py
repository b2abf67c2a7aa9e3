"""Backends ``<conic backend>-reduced``: a conic backend on the reduced form of a problem.

The equality (zero-cone) rows are eliminated per instant, ``z = z0 + N y``
(:func:`~.conversions.eliminate_equalities`), so the interior-point solver iterates on
fewer unknowns and no equality rows, with a structure (sizes, cones) that is the same at
every instant of a formulation. Its answer and multipliers are lifted back to the full
problem (:meth:`~.conversions.Reduced.lift`), which the package then judges by its own
residuals and optimality measures, as for every backend. The reduction is part of the
timed solve (``setup_s``, batched: the ``reduce`` and ``lift`` stages).

The reduced form also folds a two-row cone that one of its nonnegative rows makes
linear (:class:`Folded`): the same feasible set with fewer rows and cones, so every
backend sees the same reduced problem.

The registry applies :func:`variant` to every backend that declares it takes the
reduced form (``Backend.reducible``, or ``reduced_only`` for a backend made for it
alone); this module knows no backend by name and imports no adapter.
"""

from __future__ import annotations

import dataclasses
import functools
import time
from typing import TYPE_CHECKING

import numpy as np
from cardan_forces.formulations.batch import ConicBatch
from cardan_forces.formulations.problems import Conic

from .conversions import Reduced, eliminate_equalities
from .record import BatchOutcome, Outcome
from .stacking import blocks, cone_layout

if TYPE_CHECKING:  # the registry imports this module to apply it
    from .backend import Backend


def _defaults(backend: Backend, cones, options: dict) -> dict:
    """The options for the wrapped backend: no equilibration on the cone kinds it
    declares (``Backend.unscaled``), under the caller's options.
    """
    off = any(kind in backend.unscaled for kind, _ in cones)
    return ({"equilibrate_enable": False} if off else {}) | options


@dataclasses.dataclass(frozen=True)
class Folded:
    """Two-row second-order cones ``|s1| <= s0`` whose ``s1`` is, at every instant, the
    slack of a nonnegative row of the same problem (``sign = 1``) or its negative
    (``sign = -1``): there ``sign s1 >= 0``, so the cone is the one linear row
    ``s0 - sign s1 >= 0`` (the same feasible set, one row and one cone fewer). In
    ``min_max`` these are the end faces' ``|x| <= t`` next to ``x >= 0``: folded, the
    generated QOCO solve takes less time with the same iterations and measures. The
    full form keeps the cones (folded, moreau's full form solves fewer instants).

    ``apex``, ``member``, ``sign``: per folded cone its two rows (of the problem's cone
    rows) and the sign; ``order`` the rows the folded problem starts from (the apexes,
    then the rows kept as they are); ``cones`` the folded problem's, the new rows first,
    joined to a leading nonnegative block. The folded row's multiplier ``w >= 0`` is the
    cone's ``(w, -sign w)``: the same terms in stationarity and complementarity.
    """

    apex: np.ndarray
    member: np.ndarray
    sign: np.ndarray
    order: np.ndarray
    cones: tuple

    def rows(self, A: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The folded problem's rows from the cone rows ``A`` (T, m, k), ``b`` (T, m)."""
        f = len(self.apex)
        out_A, out_b = np.take(A, self.order, axis=1), np.take(b, self.order, axis=1)
        out_A[:, :f] -= self.sign[:, None] * A[:, self.member]
        out_b[:, :f] -= self.sign * b[:, self.member]
        return out_A, out_b

    def duals(self, y: np.ndarray) -> np.ndarray:
        """The cone rows' multipliers (T, m) from the folded problem's (T, m')."""
        f = len(self.apex)
        out = np.empty((len(y), len(self.order) + f))
        out[:, self.order] = y
        out[:, self.member] = -self.sign * y[:, :f]
        return out


@functools.lru_cache(maxsize=64)
def _candidates(cones) -> tuple[np.ndarray, np.ndarray]:
    """The rows of the nonnegative blocks of ``cones`` and the apex rows of its two-row
    second-order cones (each member the row after it), read from :func:`cone_layout`.
    """
    _, nonneg, apex, _, mask, _, _ = cone_layout(tuple(cones))
    return nonneg, apex[mask.sum(axis=1) == 1]


@functools.lru_cache(maxsize=64)
def _plan(cones, apex: tuple, sign: tuple) -> Folded:
    """The :class:`Folded` of ``cones`` with the two-row cones at ``apex`` folded."""
    parts = blocks(cones)
    folded = set(apex) | {r + 1 for r in apex}
    rest = [r for r in range(parts[-1][2].stop) if r not in folded]
    kept = [(kind, size) for kind, size, rows in parts if rows.start not in apex]
    lead = kept.pop(0)[1] if kept and kept[0][0] == "nonneg" else 0
    arrays = [np.array(apex, int), np.array(apex, int) + 1, np.array(sign),
              np.array(list(apex) + rest, int)]
    for array in arrays:
        array.flags.writeable = False  # shared by every batch of this structure
    return Folded(*arrays, (("nonneg", len(apex) + lead), *kept))


@functools.lru_cache(maxsize=256)
def _matches(members: bytes, bounds: bytes, width: int):
    """Which member rows (``members``, rows of ``width`` numbers with their right-hand
    side) equal a nonnegative row (``bounds``) or its negative: ``(found, partner,
    sign)``, indices into the members and the bounds. Cached by the rows' bytes, so the
    instants of a per-instant run, whose rows repeat, match once.
    """
    member = np.frombuffer(members).reshape(-1, 1, width)
    bound = np.frombuffer(bounds).reshape(1, -1, width)
    same, opposite = np.all(member == bound, axis=2), np.all(member == -bound, axis=2)
    sign = np.where(same.any(axis=1), 1.0, np.where(opposite.any(axis=1), -1.0, 0.0))
    partner = np.where(same.any(axis=1), same.argmax(axis=1), opposite.argmax(axis=1))
    found = np.flatnonzero(sign)
    out = (found, partner[found], sign[found])
    for array in out:
        array.flags.writeable = False  # cached: shared by every call with these rows
    return out


def matched(A0: np.ndarray, b0: np.ndarray, cones) -> tuple[np.ndarray, np.ndarray,
                                                               np.ndarray]:
    """The two-row cones of ``cones`` (no zero cone) whose member row, at one instant
    (its cone rows ``A0`` (m, n), ``b0`` (m,)), equals a nonnegative row or its negative,
    to the bit: ``(apex, partner, sign)``, the cones' apex rows, the nonnegative rows
    they match and the signs (empty where none does).
    """
    nonneg, apexes = _candidates(cones)
    if not len(nonneg) or not len(apexes):
        return apexes[:0], nonneg[:0], np.zeros(0)
    first = np.concatenate([A0, b0[:, None]], axis=1)
    found, partner, sign = _matches(first[apexes + 1].tobytes(), first[nonneg].tobytes(),
                                    first.shape[1])
    return apexes[found], nonneg[partner], sign


def plan(cones, apex: np.ndarray, sign: np.ndarray) -> Folded | None:
    """The :class:`Folded` of ``cones`` with the two-row cones at ``apex`` folded with
    ``sign`` (None where none is).
    """
    if not len(apex):
        return None
    return _plan(cones, tuple(np.asarray(apex).tolist()), tuple(np.asarray(sign).tolist()))


def fold(A: np.ndarray, b: np.ndarray, cones) -> Folded | None:
    """The :class:`Folded` plan of the cone rows ``A`` (T, m, n), ``b`` (T, m) under
    ``cones`` (no zero cone), or None where no two-row cone folds. A cone's member row
    is matched to a nonnegative row at the first instant (:func:`matched`) and confirmed
    at every other instant, to the bit.
    """
    apexes, partner, sign = matched(A[0], b[0], cones)
    if len(A) > 1 and len(apexes):
        confirmed = (np.all(A[:, apexes + 1] == sign[:, None] * A[:, partner], axis=(0, 2))
                     & np.all(b[:, apexes + 1] == sign * b[:, partner], axis=0))
        apexes, sign = apexes[confirmed], sign[confirmed]
    return plan(cones, apexes, sign)


def _reduce(P, q, A, b, cones, null_space):
    """The reduced form of the stacked problems and the problem a solver sees there:
    ``(red, plan, (A, b, cones))``, ``plan`` the :class:`Folded` one or None.
    """
    red = eliminate_equalities(P, q, A, b, cones, null_space)
    plan = fold(red.A_in, np.asarray(b, float)[:, red.rows_in], red.cones)
    return red, plan, (red.A, red.b, red.cones) if plan is None else (
        *plan.rows(red.A, red.b), plan.cones)


def _lift(red: Reduced, plan: Folded | None, z: np.ndarray, y: np.ndarray | None):
    """The full problem's answers from the solver's on the (folded) reduced form."""
    return red.lift(z, y if plan is None or y is None else plan.duals(y))


def _has_equalities(problem) -> bool:
    return any(kind == "zero" for kind, _ in problem.cones)


def _per_instant(solve, backend: Backend):
    """``solve`` (a per-instant conic backend's) on the reduced problem with
    :func:`_defaults`, lifted back (the wrapped backends take no start, so
    ``initvals`` is not passed on).
    """

    def run(problem: Conic, tol=None, initvals=None, **options) -> Outcome:
        start = time.perf_counter()
        red, plan, (A, b, cones) = _reduce(
            problem.P, problem.q[None], np.asarray(problem.A, float)[None],
            np.asarray(problem.b, float)[None], problem.cones,
            None if problem.null_space is None else problem.null_space[None])
        inner = Conic(checks=problem.checks, formulation=problem.formulation, P=red.P[0],
                      q=red.q[0], A=A[0], b=b[0], cones=cones)
        reduced_s = time.perf_counter() - start
        out = solve(inner, tol=tol, **_defaults(backend, inner.cones, options))
        lifted = time.perf_counter()
        if out.z is None:
            return dataclasses.replace(out, setup_s=out.setup_s + reduced_s)
        z, y = _lift(red, plan, np.asarray(out.z, float)[None],
                     None if out.y is None else np.asarray(out.y, float)[None])
        objective = None if out.objective is None else out.objective + float(red.offset[0])
        return dataclasses.replace(
            out, z=z[0], y=None if y is None else y[0], objective=objective,
            setup_s=out.setup_s + reduced_s + time.perf_counter() - lifted)

    return run


def _batched(solve_batch, backend: Backend):
    """``solve_batch`` (a batched conic backend's) on the reduced batch with
    :func:`_defaults`, lifted back.
    """

    def run(batch: ConicBatch, tol=None, **options) -> BatchOutcome:
        start = time.perf_counter()
        red, plan, (A, b, cones) = _reduce(batch.P, batch.q, batch.A, batch.b,
                                           batch.cones, batch.null_space)
        inner = dataclasses.replace(batch, P=red.P, q=red.q, A=A, b=b, cones=cones,
                                    problems=(), null_space=None)
        reduced = time.perf_counter()
        out = solve_batch(inner, tol=tol, **_defaults(backend, inner.cones, options))
        lifting = time.perf_counter()
        z, y = _lift(red, plan, np.asarray(out.z, float), out.y)
        done = time.perf_counter()
        stages = {"reduce": reduced - start, **out.stages, "lift": done - lifting}
        return dataclasses.replace(out, z=z, y=y, stages=stages,
                                   setup_s=out.setup_s + (reduced - start) + (done - lifting))

    return run


SUFFIX = "-reduced"
"""A reduced variant's name is its backend's and this."""


def variant(backend: Backend) -> Backend:
    """``backend`` on the reduced form of the problems it takes that have equality rows,
    named ``<name>-reduced`` (it takes no start: the reduced unknowns are not the
    problem's).
    """
    supports = backend.supports
    return dataclasses.replace(
        backend, name=backend.name + SUFFIX,
        solve=None if backend.solve is None else _per_instant(backend.solve, backend),
        batch=None if backend.batch is None else _batched(backend.batch, backend),
        supports=lambda problem: _has_equalities(problem) and supports(problem),
        warm_start=False, reducible=False, reduced_only=False)
