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
from .conversions import Reduced, eliminate_equalities
from .optimality import blocks
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


@dataclasses.dataclass(frozen=True)
class Folded:
    """Two-row second-order cones ``|s1| <= s0`` whose ``s1`` is, at every instant, the
    slack of a nonnegative row of the same problem (``sign = 1``) or its negative
    (``sign = -1``): there ``sign s1 >= 0``, so the cone is the one linear row
    ``s0 - sign s1 >= 0`` (the same feasible set, one row and one cone fewer). In
    ``min_max`` these are the end faces' ``|x| <= t`` next to ``x >= 0``: folded, the
    generated QOCO solve took 14% less time with the same iterations and measures (the
    paper's 1001 instants, best of five interleaved). The full form keeps the cones
    (folded there, moreau's full form was left ``AlmostSolved`` at one instant).

    ``apex``, ``member``, ``sign``: per folded cone its two rows (of the problem's cone
    rows) and the sign; ``rest`` the rows kept as they are; ``cones`` the folded
    problem's, the new rows first, joined to a leading nonnegative block; ``runs`` the
    kept rows as ``(source, target)`` slices of consecutive rows. The folded
    row's multiplier ``w >= 0`` is the cone's ``(w, -sign w)``: the same terms in
    stationarity and complementarity.
    """

    apex: np.ndarray
    member: np.ndarray
    sign: np.ndarray
    rest: np.ndarray
    cones: tuple
    runs: tuple = ()

    def rows(self, A: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The folded problem's rows from the cone rows ``A`` (T, m, k), ``b`` (T, m):
        written into one array each, the kept rows copied run by run (an index array
        would copy them twice).
        """
        f = len(self.apex)
        out_A = np.empty((A.shape[0], f + len(self.rest), A.shape[2]))
        out_b = np.empty((b.shape[0], f + len(self.rest)))
        np.subtract(A[:, self.apex], self.sign[:, None] * A[:, self.member], out=out_A[:, :f])
        np.subtract(b[:, self.apex], self.sign * b[:, self.member], out=out_b[:, :f])
        for source, target in self.runs:
            out_A[:, target], out_b[:, target] = A[:, source], b[:, source]
        return out_A, out_b

    def duals(self, y: np.ndarray) -> np.ndarray:
        """The cone rows' multipliers (T, m) from the folded problem's (T, m')."""
        f = len(self.apex)
        out = np.empty((len(y), f + len(self.member) + len(self.rest)))
        out[:, self.rest], out[:, self.apex] = y[:, f:], y[:, :f]
        out[:, self.member] = -self.sign * y[:, :f]
        return out


def _key(A: np.ndarray, b: np.ndarray, row: int, sign: float) -> tuple:
    """One instant's row ``sign (A[row], b[row])`` as a dictionary key (``+ 0.0``: no
    negative zero).
    """
    return tuple((sign * A[row] + 0.0).tolist()) + (sign * b[row] + 0.0,)


def fold(A: np.ndarray, b: np.ndarray, cones) -> Folded | None:
    """The :class:`Folded` plan of the cone rows ``A`` (T, m, n), ``b`` (T, m) under
    ``cones`` (no zero cone), or None where no two-row cone folds. Rows are matched at
    the first instant and confirmed at every instant, to the bit.
    """
    parts = blocks(cones)
    nonneg = {_key(A[0], b[0], r, 1.0): r for kind, _, rows in parts if kind == "nonneg"
              for r in range(rows.start, rows.stop)}
    apex, member, sign = [], [], []
    for kind, size, rows in parts:
        if kind != "soc" or size != 2:
            continue
        for s in (1.0, -1.0):
            k = nonneg.get(_key(A[0], b[0], rows.start + 1, s))
            if k is not None and np.array_equal(s * A[:, rows.start + 1], A[:, k]) \
                    and np.array_equal(s * b[:, rows.start + 1], b[:, k]):
                apex.append(rows.start)
                member.append(rows.start + 1)
                sign.append(s)
                break
    if not apex:
        return None
    rest = np.setdiff1d(np.arange(A.shape[1]), apex + member)
    kept = [(kind, size) for kind, size, rows in parts if rows.start not in apex]
    lead = kept.pop(0)[1] if kept and kept[0][0] == "nonneg" else 0
    breaks = np.flatnonzero(np.diff(rest) != 1) + 1
    starts, stops = np.r_[0, breaks], np.r_[breaks, len(rest)]
    runs = tuple((slice(rest[i], rest[j - 1] + 1), slice(len(apex) + i, len(apex) + j))
                 for i, j in zip(starts.tolist(), stops.tolist()))
    return Folded(np.array(apex), np.array(member), np.array(sign), rest,
                  (("nonneg", len(apex) + lead), *kept), runs)


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
        red, plan, (A, b, cones) = _reduce(
            problem.P, problem.q[None], np.asarray(problem.A, float)[None],
            np.asarray(problem.b, float)[None], problem.cones,
            None if problem.null_space is None else problem.null_space[None])
        inner = Conic(checks=problem.checks, formulation=problem.formulation, P=red.P[0],
                      q=red.q[0], A=A[0], b=b[0], cones=cones)
        reduced_s = time.perf_counter() - start
        out = solve(inner, tol=tol, **_defaults(name, inner.cones, options))
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


def _batched(solve_batch, name: str):
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
        out = solve_batch(inner, tol=tol, **_defaults(name, inner.cones, options))
        lifting = time.perf_counter()
        z, y = _lift(red, plan, np.asarray(out.z, float), out.y)
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
