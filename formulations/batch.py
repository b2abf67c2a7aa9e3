"""A formulation over many instants: one structure, the numbers per instant (DESIGN §3).

A formulation's structure (unknowns, sparsity, cones) is the same at every instant of
an operator; only the numbers change. This module builds it once per operator:

- :func:`build_problems`: the per-instant problems, built once and reused by every run
  (a per-instant run then spends no time building);
- :func:`least_norm_batch`: the least-norm family (``min_norm``, ``min_norm_scaled``,
  ``positive``, ``lcp``, ``compliance`` as a QP) as one stacked problem on the
  operator's own rows, ``min 1/2 x'Wx s.t. A x = b`` (and end faces ``>= 0``), forces
  in N; built from the operator in a few vectorized lines;
- :func:`conic_batch`: any LS, QP or conic formulation as stacked arrays in Clarabel's
  standard form, ``P`` shared when it is the same at every instant;
- :func:`batch_kinds`, :func:`batch_kind`: which of the two a formulation forms on a
  scene, decided by its problem there (a clearance makes ``compliance`` a conic
  problem, which has no least-norm batch), and which one a batched backend takes.

Each batch carries :class:`CheckBatch`, the stacked ``ForceChecks`` its answers are
judged by (:func:`~cardan_forces.formulations.problems.residuals_batch`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import FORMULATIONS
from .problems import LCP, LS, QP, Conic, ForceChecks, residuals_batch


@dataclass(frozen=True)
class CheckBatch:
    """The ``ForceChecks`` of T instants: ``A`` (T, m, n), ``b`` (T, m) stacked; the
    signs, pairs and cones (the same at every instant, else ``per_instant`` holds them).
    """

    A: np.ndarray
    b: np.ndarray
    names: tuple[str, ...]
    unilateral: np.ndarray
    pairs: tuple = ()
    cones: tuple = ()
    per_instant: tuple[ForceChecks, ...] | None = None

    def residuals(self, X: np.ndarray) -> dict[str, np.ndarray]:
        """Residuals of T answers ``X`` (T, n), as ``ForceChecks.residuals``."""
        if self.per_instant is None:
            return residuals_batch(self.A, self.b, X, self.unilateral, self.pairs, self.cones)
        rows = [c.residuals(x) for c, x in zip(self.per_instant, X)]
        return {k: np.array([r[k] for r in rows]) for k in rows[0]}


def stack_checks(checks: list[ForceChecks]) -> CheckBatch:
    """Stack per-instant checks that share names, signs and pairs."""
    first = checks[0]
    same = all(c.names == first.names and np.array_equal(c.unilateral, first.unilateral)
               and c.pairs == first.pairs for c in checks)
    if not same:
        raise ValueError("the checks change structure between instants")
    cones_equal = all(c.cones == first.cones for c in checks)
    return CheckBatch(A=np.array([c.A for c in checks]), b=np.array([c.b for c in checks]),
                      names=first.names, unilateral=np.asarray(first.unilateral, bool),
                      pairs=first.pairs, cones=first.cones,
                      per_instant=None if cones_equal else tuple(checks))


@dataclass(frozen=True)
class LeastNormBatch:
    """``min 1/2 x'Wx s.t. A x = b`` (and ``x[signed] >= 0``) at T instants, x in N.

    ``A`` (T, m, n) are the operator's rows (dependent along the motion), ``weights``
    (T, n) the diagonal of ``W`` (``None``: the plain norm), ``signed`` the columns held
    ``>= 0`` (empty for ``min_norm``).
    """

    formulation: str
    instants: np.ndarray
    A: np.ndarray
    b: np.ndarray
    weights: np.ndarray | None
    signed: np.ndarray
    checks: CheckBatch


@dataclass(frozen=True)
class ConicBatch:
    """``min 1/2 z'Pz + q'z s.t. A z + s = b, s in K`` at T instants with one structure.

    ``P`` is (n, n) when the same at every instant, else (T, n, n) (or ``None``); ``q``
    (T, n), ``A`` (T, m, n), ``b`` (T, m); ``problems`` the per-instant :class:`Conic`
    problems (their ``to_forces`` map ``z`` to forces); ``null_space`` (T, n, k) their
    formulation's null-space bases of the zero-cone rows (``Conic.null_space``), or
    None when not every instant has one.
    """

    formulation: str
    instants: np.ndarray
    P: np.ndarray | None
    q: np.ndarray
    A: np.ndarray
    b: np.ndarray
    cones: tuple
    problems: tuple
    checks: CheckBatch
    null_space: np.ndarray | None = None


def _instants(op, instants) -> np.ndarray:
    return np.arange(len(op.t)) if instants is None else np.asarray(instants, int)


def build_problems(op, formulation: str, instants=None) -> list:
    """The formulation's problem at each instant (default all), built once."""
    return [FORMULATIONS[formulation](op, int(i)) for i in _instants(op, instants)]


def least_norm_batch(op, formulation: str, instants=None) -> LeastNormBatch:
    """The least-norm family as one stacked problem (``ValueError`` for the others):
    weights from the formulation record's ``batch_weights`` (unit without), end faces
    signed unless its problems are least squares (which let them pull).
    """
    instants = _instants(op, instants)
    record = FORMULATIONS[formulation]
    first = record(op, int(instants[0]))
    if "least_norm" not in batch_kinds(formulation, first):
        raise ValueError(f"{formulation!r} is not a diagonal least norm on this scene")
    A, b = op.A[instants], op.b[instants]
    weights = record.batch_weights(A, first) if record.batch_weights else None
    c = first.checks
    signed = (np.zeros(len(op.names), bool) if isinstance(first, LS)
              else np.asarray(op.unilateral, bool))
    checks = CheckBatch(A=A, b=b, names=c.names, unilateral=np.asarray(c.unilateral, bool),
                        pairs=c.pairs, cones=c.cones)
    return LeastNormBatch(formulation, instants, A, b, weights, signed, checks)


def _diagonal(problem) -> bool:
    """A least squares, an LCP or a QP with a diagonal ``P`` (not a conic form)."""
    if isinstance(problem, QP):
        return not np.any(problem.P - np.diag(np.diag(problem.P)))
    return isinstance(problem, (LS, LCP))


def as_conic(problem):
    """An LS, QP or Conic problem in Clarabel's standard form (``None`` for others)."""
    if isinstance(problem, LS):
        problem = problem.as_qp()
    if isinstance(problem, QP):
        problem = problem.as_conic()
    return problem if isinstance(problem, Conic) else None


def conic_batch(problems: list, instants) -> ConicBatch:
    """Stack per-instant problems of one formulation into a :class:`ConicBatch`
    (``ValueError`` when they are not conic-convertible or change structure).
    """
    conics = [as_conic(p) for p in problems]
    if any(c is None for c in conics):
        raise ValueError("the problems have no conic form")
    first = conics[0]
    if any(c.cones != first.cones or np.shape(c.A) != np.shape(first.A) for c in conics):
        raise ValueError("the cones or sizes change between instants")
    P = None
    if first.P is not None:
        Ps = np.array([np.asarray(c.P, float) for c in conics])
        P = Ps[0] if np.all(Ps == Ps[0]) else Ps
    return ConicBatch(
        formulation=problems[0].formulation, instants=np.asarray(instants, int), P=P,
        q=np.array([np.asarray(c.q, float) for c in conics]),
        A=np.array([np.asarray(c.A, float) for c in conics]),
        b=np.array([np.asarray(c.b, float) for c in conics]), cones=first.cones,
        problems=tuple(conics), checks=stack_checks([p.checks for p in problems]),
        null_space=_null_spaces(conics))


def _null_spaces(conics: list) -> np.ndarray | None:
    """The problems' null-space bases stacked (None unless every one has one, all of
    one shape: the reduced structure must not change between instants).
    """
    bases = [c.null_space for c in conics]
    if any(N is None or np.shape(N) != np.shape(bases[0]) for N in bases):
        return None
    return np.array(bases)


BATCHES = {"least_norm": LeastNormBatch, "conic": ConicBatch}
"""The batches a formulation's problems may form, by kind."""


def batch_kinds(formulation: str, problem) -> tuple[str, ...]:
    """The kinds of batch (:data:`BATCHES`) the formulation's problems form on a scene,
    the preferred first, decided by ``problem``, its problem at an instant of that
    scene: ``"least_norm"`` where the formulation's record allows it and the problem is
    a diagonal least norm there (not ``compliance`` with a clearance: a conic problem),
    ``"conic"`` where the problem has a conic form. Empty for neither (the paper's
    root finding).
    """
    kinds = []
    if FORMULATIONS[formulation].least_norm_batch and _diagonal(problem):
        kinds.append("least_norm")
    if as_conic(problem) is not None:
        kinds.append("conic")
    return tuple(kinds)


def batch_kind(accepts, formulation: str, problem) -> str | None:
    """The batch a batched backend whose ``batch_accepts`` is ``accepts`` takes of the
    formulation on a scene: the first of :func:`batch_kinds` of a class it accepts,
    ``None`` where it accepts none of them (it does not take the formulation there).
    """
    return next((kind for kind in batch_kinds(formulation, problem)
                 if issubclass(BATCHES[kind], tuple(accepts))), None)


def make_batch(kind: str, op, formulation: str, problems: list, instants):
    """The formulation's batch of ``kind`` at ``instants`` of ``op`` (``problems``: its
    problems at those instants, which the conic batch stacks).
    """
    if kind == "least_norm":
        return least_norm_batch(op, formulation, instants)
    return conic_batch(list(problems), instants)
