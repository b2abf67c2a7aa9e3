"""Problem classes that solvers understand (DESIGN §2).

Every formulation turns one instant of a driveline into one of these objects. A
problem carries its own data in the solver's variable ``z`` and two things that
let the package judge any answer without trusting the solver:

- ``checks``: the rigid equilibrium ``A x = b`` in the named Cartesian contact
  forces ``x`` (N), the unilateral components, the complementary pairs and the
  cones the forces must satisfy;
- ``to_forces``: the map from the solver's variable ``z`` to those forces ``x``
  (a slice for most formulations, a nonlinear map for the paper's polar unknowns).

Classes:

- :class:`LS`    min 1/2 x'Wx            s.t. A x = b
- :class:`QP`    min 1/2 z'Pz + q'z      s.t. A z = b, G z <= h, lb <= z <= ub
- :class:`LP`    min c'z                 s.t. A z = b, G z <= h, lb <= z <= ub
- :class:`Conic` min 1/2 z'Pz + q'z      s.t. A z + s = b, s in K (Clarabel's standard form)
- :class:`LCP`   find z >= 0, w = M z + q >= 0, z'w = 0
- :class:`NLS`   F(z) = 0, F square, with its Jacobian and a start
"""

from __future__ import annotations

import functools
import operator
import weakref
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

SCALE_FLOOR_N = 1e-12
"""Least force scale (N) a residual, a recast's unknowns or a distance is made relative
to: an unloaded line (``b = 0``) keeps them absolute instead of dividing by zero; far
below any load a scene carries, so a loaded line is never floored."""


class ProblemError(ValueError):
    """A problem whose data are malformed (shapes, NaN, inconsistent sizes)."""


@dataclass(frozen=True)
class SecondOrderCone:
    """Cone ``||x[members]|| <= scale * x[apex] + sum(w * x[k] for k, w in apex_terms)``
    on the named forces (the apex may be any linear form of them).
    """

    apex: int
    members: tuple[int, ...]
    scale: float = 1.0
    apex_terms: tuple[tuple[int, float], ...] = ()

    def apex_row(self, n: int) -> np.ndarray:
        """Coefficients of the apex's linear form over ``n`` unknowns."""
        row = np.zeros(n)
        row[self.apex] += self.scale
        for k, w in self.apex_terms:
            row[k] += w
        return row


@dataclass(frozen=True)
class ForceChecks:
    """What any set of contact forces ``x`` must satisfy, checked by the package.

    ``A x = b`` are the Newton-Euler (d'Alembert) rows of all bodies; rows in N and
    N·m, columns the named force components in N. ``unilateral`` marks components
    that may only push (>= 0). ``pairs`` are index pairs ``(i, j)`` with
    ``0 <= x_i ⟂ x_j >= 0`` (the two end faces of one trunnion pair, paper eqs.
    39, 46). ``cones`` are second-order cones the formulation imposes.
    """

    A: np.ndarray
    b: np.ndarray
    names: tuple[str, ...]
    unilateral: np.ndarray
    pairs: tuple[tuple[int, int], ...] = ()
    cones: tuple[SecondOrderCone, ...] = ()

    def __post_init__(self) -> None:
        if type(self.names) is not tuple:  # a record carries them as they are
            object.__setattr__(self, "names", tuple(self.names))
        A, b = np.asarray(self.A, float), np.asarray(self.b, float)
        if A.ndim != 2 or b.shape != (A.shape[0],):
            raise ProblemError(f"equilibrium shapes do not match: A {A.shape}, b {b.shape}")
        if len(self.names) != A.shape[1] or np.shape(self.unilateral) != (A.shape[1],):
            raise ProblemError("names and unilateral must have one entry per column of A")
        if not (np.all(np.isfinite(A)) and np.all(np.isfinite(b))):
            raise ProblemError("equilibrium data contain NaN or inf")

    @property
    def scale(self) -> float:
        """Force scale used to make residuals relative: ``||b||`` (at least
        :data:`SCALE_FLOOR_N`).
        """
        return max(float(np.linalg.norm(self.b)), SCALE_FLOOR_N)

    def residuals(self, x: np.ndarray) -> dict[str, float]:
        """Relative residuals of ``x``; ``inf`` everywhere when ``x`` is not finite.

        - ``equilibrium``: ``||A x - b|| / ||b||``
        - ``sign``: largest pull of a unilateral component, over ``||b||``
        - ``complementarity``: largest ``min(x_i, x_j)`` over the pairs, over ``||b||``
        - ``cone``: largest cone violation, over ``||b||``
        """
        x = np.asarray(x, float)
        if x.shape != (len(self.names),):
            return dict.fromkeys(RESIDUALS, float("inf"))
        found = residuals_batch(self.A[None], self.b[None], x[None], self.unilateral,
                                self.pairs, self.cones)
        return {k: float(v[0]) for k, v in found.items()}


RESIDUALS = ("equilibrium", "sign", "complementarity", "cone")


@functools.lru_cache(maxsize=64)
def _cone_arrays(cones: tuple, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Cones as arrays: apex rows (k, n), member indices padded to the longest (k, w)
    and their mask (k, w), so all cones are checked in one vectorized step.
    """
    width = max(len(c.members) for c in cones)
    members = np.zeros((len(cones), width), int)
    mask = np.zeros((len(cones), width))
    for k, c in enumerate(cones):
        members[k, :len(c.members)] = c.members
        mask[k, :len(c.members)] = 1.0
    return np.array([c.apex_row(n) for c in cones]), members, mask
"""The keys of :meth:`ForceChecks.residuals`."""


def residuals_batch(A: np.ndarray, b: np.ndarray, X: np.ndarray, unilateral, pairs=(),
                    cones=()) -> dict[str, np.ndarray]:
    """:meth:`ForceChecks.residuals` of T answers at once (the one residual code of the
    package): ``A`` (T, m, n) or (m, n), ``b`` (T, m), ``X`` (T, n); (T,) arrays, ``inf``
    where an answer is not finite.
    """
    X = np.asarray(X, float)
    T = len(X)
    bad = ~np.all(np.isfinite(X), axis=1)
    if bad.any():
        X = np.where(bad[:, None], 0.0, X)
    scale = np.maximum(np.linalg.norm(b, axis=-1), SCALE_FLOOR_N)
    xu = X[:, np.asarray(unilateral, bool)]
    sign = np.maximum(0.0, -xu.min(axis=1, initial=np.inf)) if xu.shape[1] else np.zeros(T)
    pair = np.asarray(pairs, int).reshape(-1, 2)
    comp = np.maximum(0.0, np.minimum(X[:, pair[:, 0]], X[:, pair[:, 1]])).max(
        axis=1, initial=0.0)
    cone = np.zeros(T)
    if cones:
        apex, members, mask = _cone_arrays(tuple(cones), X.shape[1])
        spread = X[:, members] * mask
        spread = np.sqrt(np.einsum("tkj,tkj->tk", spread, spread))
        cone = np.maximum(0.0, (spread - X @ apex.T).max(axis=1))
    AX = X @ A.T if np.ndim(A) == 2 else (A @ X[:, :, None])[:, :, 0]
    out = {
        "equilibrium": np.linalg.norm(AX - b, axis=1) / scale,
        "sign": sign / scale,
        "complementarity": comp / scale,
        "cone": cone / scale,
    }
    for value in out.values():
        value[bad] = np.inf
    return out


def _identity(z: np.ndarray) -> np.ndarray:
    return np.asarray(z, float)


def map_all(maps: list, Z: np.ndarray) -> np.ndarray | None:
    """The forces (T, n) of the points ``Z`` (T, n_z), row ``k`` by ``maps[k]``, in one
    call where the maps offer one: ``to_forces`` maps of one type whose type has
    ``stacked(maps, Z)`` (:class:`Scaled`, the paper method's map) and of one structure.
    ``None`` where they do not: then each instant is mapped alone.
    """
    stacked = getattr(type(maps[0]), "stacked", None) if len(maps) else None
    if stacked is None or len(set(map(type, maps))) != 1:
        return None
    try:
        return np.asarray(stacked(maps, Z), float)
    except (ValueError, IndexError):  # maps of other structures, points of other sizes
        return None


_STRUCTURE, _SCALE = operator.attrgetter("n", "signed"), operator.attrgetter("scale")


@dataclass(frozen=True)
class Scaled:
    """The map of a problem whose first ``n`` unknowns are the forces in units of
    ``scale`` (N; all unknowns where ``n`` is None): ``x = scale * z[:n]``. ``signed``:
    end-face pairs ``(a, b)`` carried as one signed force in column ``a``, with
    ``F_a = max(z_a, 0)``, ``F_b = max(-z_a, 0)`` (the conic compliance's pairs).
    Called on one point; :meth:`stacked` maps the points of a run's instants at once
    (the judge's hook, ``solvers.judge``), one product instead of a call each.
    """

    scale: float
    n: int | None = None
    signed: tuple[tuple[int, int], ...] = ()

    def __call__(self, z) -> np.ndarray:
        return self._split(self.scale * np.asarray(z, float)[:self.n])

    @staticmethod
    def stacked(maps: list[Scaled], Z: np.ndarray) -> np.ndarray:
        """The forces (T, n) of the points ``Z`` (T, n_z), row ``k`` by ``maps[k]``; the
        maps share ``n`` and ``signed`` (instants of one structure).
        """
        first = maps[0]
        if len(set(map(_STRUCTURE, maps))) != 1:
            raise ValueError("the maps are of different structures")
        scale = np.fromiter(map(_SCALE, maps), float, len(maps))
        return first._split(scale[:, None] * np.asarray(Z, float)[:, :first.n])

    def _split(self, x: np.ndarray) -> np.ndarray:
        """``x`` (..., n) with each signed pair's force put on its pushing face."""
        if self.signed:
            a, b = np.array(self.signed).T
            x[..., b] = np.maximum(-x[..., a], 0.0)
            x[..., a] = np.maximum(x[..., a], 0.0)
        return x


@dataclass(frozen=True)
class _Problem:
    """Fields shared by every problem class."""

    checks: ForceChecks
    formulation: str = ""
    to_forces: Callable[[np.ndarray], np.ndarray] = field(default=_identity, repr=False)


def _as_array(name: str, value, shape: tuple[int, ...] | None = None) -> np.ndarray:
    arr = np.asarray(value, float)
    if shape is not None and arr.shape != shape:
        raise ProblemError(f"{name} has shape {arr.shape}, expected {shape}")
    if np.any(np.isnan(arr)):
        raise ProblemError(f"{name} contains NaN")
    return arr


@dataclass(frozen=True)
class LS(_Problem):
    """Equality-constrained least norm: min 1/2 x'Wx s.t. A x = b, W = diag(weights) > 0."""

    A: np.ndarray = None
    b: np.ndarray = None
    weights: np.ndarray | None = None

    def __post_init__(self) -> None:
        m, n = np.shape(self.A)
        _as_array("A", self.A)
        _as_array("b", self.b, (m,))
        if self.weights is not None:
            w = _as_array("weights", self.weights, (n,))
            if np.any(w <= 0):
                raise ProblemError("least-norm weights must be positive")

    @property
    def n(self) -> int:
        return np.shape(self.A)[1]

    def as_qp(self) -> QP:
        """The same problem as a :class:`QP`."""
        w = np.ones(self.n) if self.weights is None else np.asarray(self.weights, float)
        return QP(
            checks=self.checks, formulation=self.formulation, to_forces=self.to_forces,
            P=np.diag(w), q=np.zeros(self.n), A=self.A, b=self.b,
        )


@dataclass(frozen=True)
class QP(_Problem):
    """min 1/2 z'Pz + q'z  s.t.  A z = b,  G z <= h,  lb <= z <= ub (absent parts are None)."""

    P: np.ndarray = None
    q: np.ndarray = None
    A: np.ndarray | None = None
    b: np.ndarray | None = None
    G: np.ndarray | None = None
    h: np.ndarray | None = None
    lb: np.ndarray | None = None
    ub: np.ndarray | None = None

    def __post_init__(self) -> None:
        n = np.shape(self.q)[0]
        _as_array("P", self.P, (n, n))
        _as_array("q", self.q, (n,))
        for mat, vec, label in ((self.A, self.b, "A/b"), (self.G, self.h, "G/h")):
            if (mat is None) != (vec is None):
                raise ProblemError(f"{label}: give both or neither")
            if mat is not None:
                _as_array(label, mat, (np.shape(vec)[0], n))
                _as_array(label, vec)
        for vec, label in ((self.lb, "lb"), (self.ub, "ub")):
            if vec is not None:
                _as_array(label, vec, (n,))

    @property
    def n(self) -> int:
        return np.shape(self.q)[0]

    def as_conic(self) -> Conic:
        """The same problem in Clarabel's standard form (zero cone, then nonnegative)."""
        rows, rhs, cones = [], [], []
        if self.A is not None:
            rows.append(np.asarray(self.A, float))
            rhs.append(np.asarray(self.b, float))
            cones.append(("zero", len(self.b)))
        ineq_rows, ineq_rhs = [], []
        if self.G is not None:
            ineq_rows.append(np.asarray(self.G, float))
            ineq_rhs.append(np.asarray(self.h, float))
        eye = np.eye(self.n)
        if self.lb is not None:
            keep = np.isfinite(self.lb)
            ineq_rows.append(-eye[keep])
            ineq_rhs.append(-np.asarray(self.lb, float)[keep])
        if self.ub is not None:
            keep = np.isfinite(self.ub)
            ineq_rows.append(eye[keep])
            ineq_rhs.append(np.asarray(self.ub, float)[keep])
        if ineq_rows:
            rows.extend(ineq_rows)
            rhs.extend(ineq_rhs)
            cones.append(("nonneg", sum(len(r) for r in ineq_rhs)))
        return Conic(
            checks=self.checks, formulation=self.formulation, to_forces=self.to_forces,
            P=self.P, q=self.q, A=np.vstack(rows) if rows else np.zeros((0, self.n)),
            b=np.concatenate(rhs) if rhs else np.zeros(0), cones=tuple(cones),
        )


@dataclass(frozen=True)
class LP(_Problem):
    """min c'z  s.t.  A z = b,  G z <= h,  lb <= z <= ub (absent parts are None).

    An unbounded LP is a legitimate answer here (an interval end at infinity).
    """

    c: np.ndarray = None
    A: np.ndarray | None = None
    b: np.ndarray | None = None
    G: np.ndarray | None = None
    h: np.ndarray | None = None
    lb: np.ndarray | None = None
    ub: np.ndarray | None = None

    def __post_init__(self) -> None:
        _as_array("c", self.c)

    @property
    def n(self) -> int:
        return np.shape(self.c)[0]


@dataclass(frozen=True)
class Conic(_Problem):
    """min 1/2 z'Pz + q'z  s.t.  A z + s = b,  s in K.

    ``cones`` lists the blocks of K in row order as ``(kind, size)``:
    ``("zero", m)``, ``("nonneg", m)``, ``("soc", m)`` (first entry the apex), or
    ``("pow", alpha)`` (3 rows: ``x^alpha * y^(1-alpha) >= |z|``, x, y >= 0).

    ``null_space``: an orthonormal basis (n, k) of the null space of the zero-cone rows,
    given by a formulation that has it from its own factorization, whose zero-cone rows
    are then mutually orthogonal (None: not known); the reduced form
    (:func:`~cardan_forces.solvers.conversions.eliminate_equalities`) uses it instead
    of factoring the rows again.
    """

    P: np.ndarray | None = None
    q: np.ndarray = None
    A: np.ndarray = None
    b: np.ndarray = None
    cones: tuple[tuple[str, float], ...] = ()
    null_space: np.ndarray | None = None

    def __post_init__(self) -> None:
        n = np.shape(self.q)[0]
        m = np.shape(self.b)[0]
        _as_array("A", self.A, (m, n))
        rows = 0
        for kind, size in self.cones:
            if kind not in ("zero", "nonneg", "soc", "pow"):
                raise ProblemError(f"unknown cone kind {kind!r}")
            rows += 3 if kind == "pow" else int(size)
        if rows != m:
            raise ProblemError(f"cones cover {rows} rows, A has {m}")

    @property
    def n(self) -> int:
        return np.shape(self.q)[0]


@dataclass(frozen=True)
class LCP(_Problem):
    """Find z >= 0 with w = M z + q >= 0 and z'w = 0."""

    M: np.ndarray = None
    q: np.ndarray = None

    def __post_init__(self) -> None:
        n = np.shape(self.q)[0]
        _as_array("M", self.M, (n, n))
        _as_array("q", self.q, (n,))

    @property
    def n(self) -> int:
        return np.shape(self.q)[0]


@dataclass(frozen=True)
class NLS(_Problem):
    """Square nonlinear system F(z) = 0 with Jacobian ``jac`` and start ``z0``."""

    fun: Callable[[np.ndarray], np.ndarray] = None
    jac: Callable[[np.ndarray], np.ndarray] | None = None
    z0: np.ndarray = None

    @property
    def n(self) -> int:
        return np.shape(self.z0)[0]


class LastMade:
    """The one thing last made from an owner (an operator, a batch: objects that hold
    arrays and so cannot be dict keys), remembered by the owner's identity with a weak
    reference, so a new owner at a freed one's address is told apart. A loop over the
    instants of one owner makes its structure once.
    """

    def __init__(self, make: Callable):
        self._make, self._last = make, None

    def __call__(self, owner, *also):
        """``make(owner, *also)``, made again only for another owner or other ``also``."""
        last = self._last
        if last is None or last[0]() is not owner or any(
                a is not b for a, b in zip(last[1], also)):
            last = self._last = (weakref.ref(owner), also, self._make(owner, *also))
        return last[2]

