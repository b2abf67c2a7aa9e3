"""Records of a batched solve: all instants of a formulation at once (DESIGN §3).

A batched backend returns a :class:`BatchOutcome` for a formulation's batch
(:mod:`cardan_forces.formulations.batch`); :func:`finalize_batch` judges it with the
same residual code (``residuals_batch``), the same status rule (:func:`~.record.judge`)
and the same optimality measures (:mod:`.optimality`) as a per-instant record, into the
:class:`~.record.Results` a per-instant run gives (one column per field; ``results[k]``
instant ``k``'s :class:`~.record.Record`; the backend's own split of the batch's time
in ``stages``).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
from cardan_forces.formulations.batch import ConicBatch, LeastNormBatch
from cardan_forces.formulations.problems import SCALE_FLOOR_N, LastMade, map_all

from .optimality import combine, multipliers, stacked_measures, unique_optimum
from .record import (
    Optimality,
    Residuals,
    Results,
    Status,
    as_statuses,
    judge,
    judged_notes,
)
from .stacking import stacked_batch


@dataclass(frozen=True)
class BatchOutcome:
    """What a batched backend hands back, per instant (T rows).

    ``z`` is the solver's variable (the forces in N for a :class:`LeastNormBatch`);
    ``y`` the multipliers in the batch's conic rows (Clarabel's sign convention; for
    a :class:`LeastNormBatch` the rows ``A x = b`` then ``-x_j <= 0`` for the signed
    columns), ``None`` if the solver gives none; ``stages`` seconds per stage of the
    whole batch; ``messages`` one per instant (or empty).
    """

    status: np.ndarray
    z: np.ndarray
    y: np.ndarray | None
    iterations: np.ndarray
    setup_s: float
    solve_s: float
    stages: dict[str, float] = field(default_factory=dict)
    messages: tuple[str, ...] = ()


def _forces(batch, outcome: BatchOutcome, answered: np.ndarray) -> np.ndarray:
    if isinstance(batch, LeastNormBatch):
        return np.where(answered[:, None], outcome.z, np.nan)
    X = np.full((len(outcome.z), len(batch.checks.names)), np.nan)
    rows = np.flatnonzero(answered)
    maps = [batch.problems[k].to_forces for k in rows]
    mapped = map_all(maps, outcome.z[rows])
    if mapped is not None:
        X[rows] = mapped
        return X
    for k, f in zip(rows, maps):
        X[k] = f(outcome.z[k])
    return X


def _least_norm_measures(batch: LeastNormBatch, x: np.ndarray, y: np.ndarray):
    """Optimality of ``min 1/2 x'Wx, A x = b, x_signed >= 0`` with conic multipliers ``y``
    (rows ``A``, then ``-e_j`` per signed column).
    """
    m = batch.A.shape[1]
    signed = np.flatnonzero(batch.signed)
    Wx = x if batch.weights is None else batch.weights * x
    Aty = (y[:, None, :m] @ batch.A)[:, 0]
    Aty[:, signed] -= y[:, m:]
    bty = np.einsum("tm,tm->t", batch.b, y[:, :m])
    cone = np.maximum(0.0, -y[:, m:]).max(axis=1, initial=0.0)
    return combine(Wx, np.zeros_like(x), Aty, bty, x, y, cone)


def _optimality(batch, outcome: BatchOutcome, x: np.ndarray, answered, primal):
    if not answered.any():
        inf = np.full(len(answered), np.inf)
        return Optimality(primal=primal, dual=inf, gap=inf.copy()), "none", None
    z = np.where(answered[:, None], outcome.z, 0.0)
    if isinstance(batch, LeastNormBatch):
        found = _least_norm_measures(batch, np.where(answered[:, None], x, 0.0),
                                     outcome.y)
        source = "solver"
    else:
        source = "solver" if outcome.y is not None else "recovered"
        st = _stacked(batch)
        y = outcome.y
        if y is None:
            given = [None if a else np.zeros(st.b.shape[1]) for a in answered]
            y = multipliers(st, z, given)[0]  # an unanswered instant's measures are inf
        found = stacked_measures(st, z, y)[0]
    for value in (primal, found["dual"], found["gap"]):
        value[~answered] = np.inf
    return (Optimality(primal=primal, dual=found["dual"], gap=found["gap"]), source,
            outcome.y if isinstance(batch, LeastNormBatch) else y)


_stacked = LastMade(lambda batch: stacked_batch(batch.P, batch.q, batch.A, batch.b,
                                                batch.cones))
"""A conic batch's :func:`~.stacking.stacked_batch` form, made once per batch (a bench
judges one batch many times; finding its patterns costs a pass)."""


def _unique(batch) -> bool:
    if isinstance(batch, LeastNormBatch):
        return True
    return unique_optimum(batch.problems[0]) if np.ndim(batch.P) != 3 else False


def finalize_batch(batch, solver: str, outcome: BatchOutcome,
                   reference: np.ndarray | None = None) -> Results:
    """Judge a batched outcome like :func:`~.checks.finalize_all` judges T instants.

    ``reference`` (T, n): reference forces, giving ``distance`` where the optimum is
    unique (:func:`~.optimality.unique_optimum`). The results' forces ``x`` and the
    solver's ``z`` and ``y`` are (T, .) arrays (every instant has the batch's names);
    a measure no instant has is ``None``; the times are the batch's over T.
    """
    began = time.perf_counter()
    status = np.asarray(outcome.status, object).copy()
    answered = np.isin(status.astype(str), Status.answered())
    x = _forces(batch, outcome, answered)
    bad = answered & ~np.all(np.isfinite(x), axis=1)
    status[bad], answered[bad] = Status.FAILED, False
    x[bad] = np.nan
    residuals = Residuals(**batch.checks.residuals(x))
    optimality, source, y = _optimality(batch, outcome, x, answered, residuals.largest())
    if reference is not None:
        ref = np.asarray(reference, float)
        distance = (np.linalg.norm(x - ref, axis=1)
                    / np.maximum(np.linalg.norm(ref, axis=1), SCALE_FLOOR_N))
        distance[~answered] = np.inf
        residuals = Residuals(**residuals, reference=distance)
        if _unique(batch):
            optimality = Optimality(**optimality, distance=distance)
    reported, status = status, judge(status, optimality, source)
    messages = list(outcome.messages) or [""] * len(x)
    for k, note in judged_notes(reported, status, residuals, optimality).items():
        messages[k] = "; ".join(filter(None, (messages[k], note)))
    T = len(x)
    per = np.array([outcome.setup_s, outcome.solve_s, time.perf_counter() - began]) / T
    return Results(
        solver=solver, formulation=(batch.formulation,) * T, names=(batch.checks.names,) * T,
        status=as_statuses(status, Status.FAILED), x=x,
        residuals=residuals, optimality=optimality, solver_optimality=Optimality(),
        iterations=tuple(np.asarray(outcome.iterations, int).tolist()),
        objective=(None,) * T, message=tuple(messages),
        duals=(source,) * T, gap_kind=("duality",) * T,
        solver_status=as_statuses(outcome.status),
        setup_s=np.full(T, per[0]), solve_s=np.full(T, per[1]), checks_s=np.full(T, per[2]),
        wall_s=np.full(T, per.sum()), z=np.asarray(outcome.z),
        y=(None,) * T if y is None else y, stages=dict(outcome.stages))


def supports_batch(backend, batch) -> bool:
    """Whether ``backend`` solves ``batch`` as one batch."""
    return backend.batch is not None and isinstance(batch, backend.batch_accepts) and (
        backend.supports(batch))


__all__ = ["BatchOutcome", "ConicBatch", "LeastNormBatch", "finalize_batch",
           "supports_batch"]
