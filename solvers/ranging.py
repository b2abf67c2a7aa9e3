"""LP ranging: the least and the greatest of several linear forms over one polyhedron.

An interval of the rigid solution set (DESIGN §2, "Solution sets") is two LPs per
force component over the same feasible set ``{A x = b, G x <= h, lb <= x <= ub}``;
only the objective changes between them. HiGHS's simplex kept warm does exactly
that: the model is passed once, a feasible basis found once (the objective 0), and
each bound is the previous optimal basis re-optimised for a new cost vector
(``changeColsCost``, then ``run``): a few pivots instead of a cold solve, and no
record built per LP. Over a sequence of LPs of one shape (the instants of a run) the
feasible basis of the one before starts the next (``start``), and its rays are tried
as rays of the next (an end-face pair's ray, ``e_F3 + e_F4``, is one at every
instant).

Many ends need no LP at all, because an answer already found proves them
(:class:`_Proofs`): a verified point with ``c'z`` at the least value the bounds
``lb``/``ub`` allow is a minimum of ``c'x`` (an end face found at zero), and a
verified ray ``d`` of the set (``A d = 0``, ``G d <= 0``, ``d`` inside the bounds' own
directions) with ``c'd < 0`` makes ``c'x`` unbounded below (one pair mode opens both
of its end faces). On ``propshaft``, with the rays handed on between instants, 7
simplex runs per instant are left of 25.

Each answer is judged here, not trusted: an optimum whose primal residuals exceed
:data:`~cardan_forces.solvers.record.ACCEPT` (relative to the problem's scale) is
``failed``, so that the caller solves that bound again cold through the registry
(:func:`~cardan_forces.solvers.registry.solve`). ``highspy`` is a core dependency
(SciPy's bundled HiGHS, presolving an LP with a zero objective, returned a point 4e4 N
off ``A x = b`` on a frictionless slip joint line and called it optimal); an install
without it has :data:`HAVE_HIGHSPY` False and solves every bound cold.
"""

from __future__ import annotations

import ctypes
import functools
import os
import sys
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse
from cardan_forces.formulations.problems import LP, LastMade

from .record import ACCEPT, Status

try:
    import highspy
except ImportError:  # the optional extra ``highs``
    highspy = None

HAVE_HIGHSPY = highspy is not None
"""Whether the warm-started ranging is available (the ``highs`` extra)."""


@functools.cache
def without_banner() -> None:
    """Make the process's first HiGHS solver with its file descriptor 1 on /dev/null:
    highspy prints its banner on stdout then (once per process), which the Python API
    would show and ``--json`` output must not hold.
    """
    sys.stdout.flush()
    saved = os.dup(1)
    try:
        with open(os.devnull, "w") as null:
            os.dup2(null.fileno(), 1)
            highspy.Highs()
            ctypes.CDLL(None).fflush(None)  # the banner leaves C's buffer while 1 is null
    except (OSError, AttributeError, TypeError):  # no C library to flush: it may show
        pass
    finally:
        os.dup2(saved, 1)
        os.close(saved)

RAY_MARGIN = 1e3 * ACCEPT
"""Least share ``-c'd / (|c|_1 |d|_inf)`` by which a verified ray must decrease ``c'x``
to prove it unbounded without an LP: far above the ray's own residuals (``ACCEPT``), so
that rounding cannot fake a direction."""


@dataclass(frozen=True)
class Ranges:
    """``feasible``: the status of the feasibility solve (objective 0); per objective
    row ``k``: ``low[k]``/``high[k]`` the least/greatest value (NaN where that side has
    none) and ``statuses[k]`` = (status of the min, status of the max); ``lps``: the
    simplex runs it took; ``basis``: the feasible basis found (HiGHS's, for the
    ``start`` of the next LP of the same shape; ``None`` where the set is empty);
    ``rays``: the verified rays of the set it used (rows, ``|d|_inf = 1``).
    """

    feasible: Status
    low: np.ndarray
    high: np.ndarray
    statuses: tuple[tuple[Status, Status], ...]
    lps: int = 0
    basis: object = field(default=None, repr=False, compare=False)
    rays: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)), repr=False,
                             compare=False)


_STATUS = {} if highspy is None else {
    highspy.HighsModelStatus.kOptimal: Status.SOLVED,
    highspy.HighsModelStatus.kUnbounded: Status.UNBOUNDED,
    highspy.HighsModelStatus.kInfeasible: Status.INFEASIBLE,
}
"""HiGHS model statuses this module believes; any other is ``failed``."""


def ranges(lp: LP, objectives: np.ndarray, start: Ranges | None = None) -> Ranges:
    """Min and max of ``objectives[k] @ z`` over ``lp``'s feasible set (``lp.c`` unused).

    ``objectives``: ``(k, n)``. When the set is empty (or the feasibility solve
    fails) every row is NaN with that status. ``start``: the ranges of an LP of the
    same shape (the instant before), whose feasible basis starts this one's
    feasibility solve and whose rays, where they are rays of this set too, prove
    ends; the answers do not depend on it (each is verified, and an LP's optimal
    value is unique). Needs :data:`HAVE_HIGHSPY`.
    """
    objectives = np.atleast_2d(np.asarray(objectives, float))
    k, n = objectives.shape
    h = _model(lp)
    start = start if start is not None and start.rays.shape[1:] == (n,) else None
    if start is not None and start.basis is not None:
        h.setBasis(start.basis)
    feasible, _, point = _run(h, lp, np.zeros(n))
    low, high = np.full(k, np.nan), np.full(k, np.nan)
    if feasible is not Status.SOLVED:
        return Ranges(feasible, low, high, ((feasible, feasible),) * k, 1,
                      rays=np.zeros((0, n)))
    basis, proofs, lps = h.getBasis(), _Proofs(lp, point), 1
    for ray in () if start is None else start.rays:
        proofs.add(Status.UNBOUNDED, ray)
    statuses = []
    for r, c in enumerate(objectives):
        sides = []
        for sign, ends in ((1.0, low), (-1.0, high)):
            status, value = proofs.settle(sign * c)
            if status is None:
                status, value, found = _run(h, lp, sign * c)
                proofs.add(status, found)
                lps += 1
            ends[r] = sign * value
            sides.append(status)
        statuses.append(tuple(sides))
    return Ranges(feasible, low, high, tuple(statuses), lps, basis, proofs.rays)


class _Proofs:
    """What the answers found so far prove about other objectives over one LP's set:
    verified points (rows of ``points``) and verified rays (rows of ``rays``, scaled to
    ``|d|_inf = 1``).
    """

    def __init__(self, lp: LP, point: np.ndarray):
        self.lp = lp
        _, self.lb, self.ub = _rows(lp)
        self.points, self.rays = point[None], np.zeros((0, lp.n))

    def settle(self, c: np.ndarray) -> tuple[Status | None, float]:
        """``min c'x`` where a point or a ray already proves it: ``(solved, the bounds'
        least value of c'x)`` for a point at that value, ``(unbounded, NaN)`` for a ray
        along which ``c'x`` falls; ``(None, NaN)``: an LP must tell.
        """
        scale = float(np.abs(c).sum())
        if np.any(self.rays @ c < -RAY_MARGIN * scale):
            return Status.UNBOUNDED, np.nan
        used = c != 0
        floor = float(np.where(c > 0, self.lb, self.ub)[used] @ c[used])
        if np.isfinite(floor) and np.any(self.points @ c <= floor):
            return Status.SOLVED, floor
        return None, np.nan

    def add(self, status: Status, found: np.ndarray | None) -> None:
        """Keep a solved LP's (verified) point, or an unbounded one's ray once verified."""
        if found is None:
            return
        if status is Status.SOLVED:
            self.points = np.vstack([self.points, found])
        elif status is Status.UNBOUNDED and _is_ray(self.lp, found):
            self.rays = np.vstack([self.rays, found / np.abs(found).max()])


def _is_ray(lp: LP, d: np.ndarray) -> bool:
    """``d`` is a direction of ``lp``'s set within :data:`ACCEPT` of ``|d|_inf`` (times
    each row's norm): ``A d = 0``, ``G d <= 0``, ``d >= 0`` where the lower bound is
    finite and ``d <= 0`` where the upper one is.
    """
    size = float(np.abs(d).max(initial=0.0))
    if not np.isfinite(size) or size == 0.0:
        return False
    return _worst(lp, d / size, ray=True) <= ACCEPT


def _worst(lp: LP, z: np.ndarray, ray: bool = False) -> float:
    """The largest violation of ``lp``'s constraints at ``z``, a row's over its norm:
    ``|A z - b|``, ``G z - h``, ``lb - z``, ``z - ub``; with ``ray``, of the set's
    directions (right-hand sides 0, finite bounds 0).
    """
    rows, lb, ub = _rows(lp)
    worst = [lb - z if not ray else np.where(np.isfinite(lb), -z, -np.inf),
             z - ub if not ray else np.where(np.isfinite(ub), z, -np.inf)]
    for (M, rhs, norms), equal in zip(rows, (True, False)):
        if norms is not None:
            r = M @ z - (0.0 if ray else rhs)
            worst.append((np.abs(r) if equal else r) / norms)
    return max(float(np.max(w, initial=-np.inf)) for w in worst)


_rows = LastMade(lambda lp: (
    tuple((M, rhs, None if M is None or not len(M) else
           np.maximum(np.abs(np.asarray(M, float)).sum(1), 1e-300))
          for M, rhs in ((lp.A, lp.b), (lp.G, lp.h))),
    np.full(lp.n, -np.inf) if lp.lb is None else np.asarray(lp.lb, float),
    np.full(lp.n, np.inf) if lp.ub is None else np.asarray(lp.ub, float)))
"""An LP's constraint rows with their norms, and its bounds (``-inf``/``inf`` where
none), made once per LP: every LP run at an instant checks its answer with them."""


def _model(lp: LP):
    """A quiet HiGHS instance holding ``lp``'s constraints (rows: ``A`` equal to ``b``,
    then ``G`` at most ``h``), simplex without presolve so that it tells an unbounded
    objective from an empty set and keeps its basis between runs.
    """
    n = lp.n
    A = np.zeros((0, n)) if lp.A is None else np.asarray(lp.A, float)
    G = np.zeros((0, n)) if lp.G is None else np.asarray(lp.G, float)
    b = np.zeros(0) if lp.b is None else np.asarray(lp.b, float)
    g = np.zeros(0) if lp.h is None else np.asarray(lp.h, float)
    M = np.vstack([A, G])
    model = highspy.HighsLp()
    model.num_col_, model.num_row_ = n, M.shape[0]
    model.col_cost_ = np.zeros(n)
    _, lb, ub = _rows(lp)
    model.col_lower_, model.col_upper_ = _finite(lb), _finite(ub)
    model.row_lower_ = _finite(np.concatenate([b, np.full(len(g), -np.inf)]))
    model.row_upper_ = _finite(np.concatenate([b, g]))
    csc = scipy.sparse.csc_matrix(M)
    model.a_matrix_.format_ = highspy.MatrixFormat.kColwise
    model.a_matrix_.start_ = csc.indptr.astype(np.int32)
    model.a_matrix_.index_ = csc.indices.astype(np.int32)
    model.a_matrix_.value_ = csc.data.astype(float)
    without_banner()
    h = highspy.Highs()
    for option, value in OPTIONS.items():
        h.setOptionValue(option, value)
    h.passModel(model)
    return h


OPTIONS = {"output_flag": False, "presolve": "off", "solver": "simplex",
           "simplex_strategy": 4, "threads": 1}
"""HiGHS options of the ranging: quiet; simplex without presolve (it tells an unbounded
objective from an empty set and keeps its basis between runs); primal simplex (a new
cost vector leaves the basis primal feasible); one thread (the LPs are small, and a
thread pool costs more than it saves on them)."""


def _finite(v) -> np.ndarray:
    """``v`` with infinities as HiGHS spells them."""
    return np.clip(np.asarray(v, float), -highspy.kHighsInf, highspy.kHighsInf)


def _run(h, lp: LP, c: np.ndarray) -> tuple[Status, float, np.ndarray | None]:
    """Minimise ``c @ z`` from the basis ``h`` holds: (status, value; NaN unless
    solved, and what it found: the point ``z`` of an optimum, HiGHS's ray of an
    unbounded objective, else ``None``). An optimum that does not satisfy the
    constraints within :data:`ACCEPT` of the problem's scale is ``failed``.
    """
    h.changeColsCost(len(c), np.arange(len(c), dtype=np.int32), c)
    if h.run() == highspy.HighsStatus.kError and h.getOptions().threads == 1:
        h.setOptionValue("threads", 0)  # HiGHS's threads already started, at its count
        h.run()
    status = _STATUS.get(h.getModelStatus(), Status.FAILED)
    if status is Status.UNBOUNDED:
        _, has_ray, ray = h.getPrimalRay()
        return status, np.nan, np.asarray(ray, float) if has_ray else None
    if status is not Status.SOLVED:
        return status, np.nan, None
    z = np.asarray(h.getSolution().col_value, float)
    if not _feasible(lp, z):
        return Status.FAILED, np.nan, None
    return Status.SOLVED, float(c @ z), z


def _feasible(lp: LP, z: np.ndarray) -> bool:
    """Every constraint of ``lp`` holds at ``z`` within :data:`ACCEPT` times the scale
    ``max(|b|_inf, |z|_inf)`` (times each row's norm).
    """
    scale = max(float(np.abs(z).max(initial=0.0)),
                0.0 if lp.b is None else float(np.abs(lp.b).max(initial=0.0)), 1e-300)
    return _worst(lp, z) <= ACCEPT * scale
