"""Exact reformulations that let a backend solve a problem class it does not take directly.

The chain is LS -> QP -> Conic and LP -> Conic; each step keeps ``checks``,
``formulation`` and ``to_forces``, so the record is judged on the original forces. A
QP's multipliers in qpsolvers' convention map to its conic form's rows by
:func:`qp_duals`.

The reduced form (:func:`eliminate_equalities`) is a reformulation for speed: a conic
problem without its equality rows, solved in the null space of those rows; its answers
are lifted back (:meth:`Reduced.lift`) to the full problem's variable and multipliers,
where the package judges them as any other.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
from cardan_forces.formulations.problems import LP, LS, QP, Conic

from cardan_forces.util.rank import RANK_RTOL, numerical_ranks


def lp_as_conic(lp: LP) -> Conic:
    """The LP in Clarabel's standard form (zero cone for ``A z = b``, then nonnegative)."""
    n = lp.n
    conic = QP(
        checks=lp.checks, formulation=lp.formulation, to_forces=lp.to_forces,
        P=np.zeros((n, n)), q=lp.c, A=lp.A, b=lp.b, G=lp.G, h=lp.h, lb=lp.lb, ub=lp.ub,
    ).as_conic()
    return dataclasses.replace(conic, P=None)


NEXT_STEP = {LS: (QP, LS.as_qp), QP: (Conic, QP.as_conic), LP: (Conic, lp_as_conic)}
"""One conversion step per problem class that has one: (target class, function)."""


def qp_duals(qp, y, z, z_box) -> np.ndarray:
    """Multipliers ``y, z, z_box`` (qpsolvers', ``P x + q + A'y + G'z + z_box = 0``) of
    ``qp`` (a package ``QP``) as the multipliers of ``qp.as_conic()``'s rows: ``(y, z,
    -z_box^- on finite lb, z_box^+ on finite ub)`` (``v^- = min(v, 0)``, ``v^+ =
    max(v, 0)``), which give the same stationarity and gap terms.
    """
    parts = [np.asarray(v, float) for v, rows in ((y, qp.A), (z, qp.G)) if rows is not None]
    for bound, part in ((qp.lb, np.minimum), (qp.ub, np.maximum)):
        if bound is not None:
            keep = np.isfinite(bound)
            sign = -1.0 if part is np.minimum else 1.0
            parts.append(sign * part(np.asarray(z_box, float), 0.0)[keep])
    return np.concatenate(parts) if parts else np.zeros(0)


def reachable(cls: type, accepts: tuple[type, ...]) -> bool:
    """Whether a problem of class ``cls`` can be converted into one of ``accepts``."""
    while not issubclass(cls, accepts):
        if cls not in NEXT_STEP:
            return False
        cls = NEXT_STEP[cls][0]
    return True


def convert(problem, accepts: tuple[type, ...]):
    """Apply conversion steps until ``problem`` is one of ``accepts`` (None if impossible)."""
    if not reachable(type(problem), accepts):
        return None
    while not isinstance(problem, accepts):
        problem = NEXT_STEP[type(problem)][1](problem)
    return problem


@dataclass(frozen=True)
class Reduced:
    """Conic problems (T stacked, one structure) with their zero-cone rows eliminated.

    Every ``z`` with ``A_eq z = b_eq`` is ``z = z0 + N y`` (``z0`` the least-norm
    solution, ``N`` an orthonormal basis of the null space of ``A_eq``), so
    ``min 1/2 z'Pz + q'z, A z + s = b, s in K`` becomes, over ``y``,
    ``min 1/2 y'(N'PN)y + (N'(P z0 + q))'y, A_in N y + s = b_in - A_in z0, s in K_in``:
    the same optimum, fewer unknowns, no equality rows, and a structure (sizes, cones)
    fixed per formulation while ``z0`` and ``N`` change per instant.

    ``P`` (T, k, k), ``q`` (T, k), ``A`` (T, m_in, k), ``b`` (T, m_in), ``cones`` the
    reduced problem's; ``z0`` (T, n), ``N`` (T, n, k); ``factors`` ``(Q, R, U)`` with
    ``A_eq' = Q R U'`` (``Q`` (T, n, s) orthonormal, ``R`` (T, s, s) upper triangular
    and invertible, or (T, s) its diagonal when diagonal, ``U``
    (T, r, s) orthonormal or None for the identity; ``s`` the rank), which give the
    pseudo-inverse of ``A_eq'`` and so the equality rows' multipliers;
    ``rows_eq`` / ``rows_in`` the full problem's row indices of each part; ``offset``
    (T,) the objective at ``z0`` (the reduced objective plus it is the full one);
    ``P_full`` (T, n, n), or its diagonal (T, n) when every instant's is diagonal,
    ``q_full`` (T, n) and ``A_in`` (T, m_in, n) the full problem's data that
    :meth:`lift` reads.
    """

    P: np.ndarray
    q: np.ndarray
    A: np.ndarray
    b: np.ndarray
    cones: tuple
    z0: np.ndarray
    N: np.ndarray
    factors: tuple
    rows_eq: np.ndarray
    rows_in: np.ndarray
    offset: np.ndarray
    P_full: np.ndarray
    q_full: np.ndarray
    A_in: np.ndarray

    def lift(self, y: np.ndarray, dual_in: np.ndarray | None):
        """The full problem's ``z`` (T, n) from the reduced answers ``y`` (T, k), and its
        multipliers (T, m) from the reduced ones ``dual_in`` (None: none): the equality
        rows' by least squares on stationarity ``P z + q + A_eq' l + A_in' u = 0``
        (exact at an optimum; the least-norm ``l`` where the rows are dependent).
        """
        z = self.z0 + _mv(self.N, y)
        if dual_in is None:
            return z, None
        g = -(_times(self.P_full, z) + self.q_full + (dual_in[:, None] @ self.A_in)[:, 0])
        Q, R, U = self.factors
        v = _mv(np.transpose(Q, (0, 2, 1)), g)
        lam = v / R if R.ndim == 2 else _triangular(R, v)
        lam = lam if U is None else _mv(U, lam)
        duals = np.empty((len(z), len(self.rows_eq) + len(self.rows_in)))
        duals[:, self.rows_eq], duals[:, self.rows_in] = lam, dual_in
        return z, duals


def _mv(M: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Stacked matrix-vector products ``M[t] @ v[t]`` (matmul: einsum is slower on
    these shapes).
    """
    return (M @ v[..., None])[..., 0]


def _times(P: np.ndarray, v: np.ndarray) -> np.ndarray:
    """``P[t] @ v[t]`` for ``P`` stacked (T, n, n) or diagonal (T, n)."""
    return P * v if P.ndim == 2 else _mv(P, v)


def _diagonal(P: np.ndarray) -> np.ndarray | None:
    """The diagonal of ``P`` ((n, n) or (T, n, n)) if every matrix is diagonal, else
    None: one count of nonzeros, cheaper than the dense products it saves.
    """
    d = np.diagonal(P, axis1=-2, axis2=-1)
    return d if np.count_nonzero(P) == np.count_nonzero(d) else None


def _part(M: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """``M[:, rows]``: a view, not a copy, when ``rows`` are one ascending run (the
    zero cone first, as in every formulation here).
    """
    if len(rows) and rows[-1] - rows[0] == len(rows) - 1:
        return M[:, rows[0]:rows[-1] + 1]
    return M[:, rows]


def _triangular(R: np.ndarray, v: np.ndarray, transposed: bool = False) -> np.ndarray:
    """``w`` with ``R w = v`` (``R' w = v`` if ``transposed``) for upper-triangular ``R``
    (T, s, s) and ``v`` (T, s): substitution one row at a time over all instants at
    once (for s ~ 30, faster than ``np.linalg.solve``'s LU of every instant).
    """
    w = np.zeros_like(v)
    for i in range(R.shape[-1]) if transposed else reversed(range(R.shape[-1])):
        known = (R[:, :i, i], w[:, :i]) if transposed else (R[:, i, i + 1:], w[:, i + 1:])
        w[:, i] = (v[:, i] - np.einsum("tj,tj->t", *known)) / R[:, i, i]
    return w


def zero_rows(cones) -> tuple[np.ndarray, np.ndarray, tuple]:
    """Row indices of the zero-cone blocks, of the others, and the others' cones."""
    eq, rest, kept, row = [], [], [], 0
    for kind, size in cones:
        count = 3 if kind == "pow" else int(size)
        (eq if kind == "zero" else rest).extend(range(row, row + count))
        if kind != "zero":
            kept.append((kind, size))
        row += count
    return np.array(eq, int), np.array(rest, int), tuple(kept)


def _null_space(A_eq: np.ndarray, b_eq: np.ndarray):
    """``(z0, N, factors)`` per instant: the least-norm solution of ``A_eq z = b_eq``,
    an orthonormal basis of the null space of ``A_eq`` and ``(Q, R, U)`` with ``A_eq' =
    Q R U'`` (see :class:`Reduced`). From one complete QR of the stacked ``A_eq'``;
    where the rows are dependent (the QR's diagonal, or the singular values, under the
    package's rank rule :data:`~cardan_forces.util.rank.RANK_RTOL`), from the SVD at the rank
    every instant shares (``ValueError`` if the rank changes: the reduced structure
    would).
    """
    r = A_eq.shape[1]
    At = np.transpose(A_eq, (0, 2, 1))
    Q, R = np.linalg.qr(At, mode="complete")
    diag = np.abs(np.diagonal(R[:, :r], axis1=1, axis2=2))
    if not r or np.all(diag.min(axis=1) > RANK_RTOL * diag.max(axis=1)):
        factors = (Q[:, :, :r], R[:, :r], None)
        w = _triangular(R[:, :r], b_eq, transposed=True)
        return _mv(Q[:, :, :r], w), Q[:, :, r:], factors
    V, s, Ut = np.linalg.svd(At)
    ranks = numerical_ranks(s)
    if np.any(ranks != ranks[0]):
        raise ValueError("the zero-cone rows change rank between instants: no reduced form")
    k = int(ranks[0])
    U = np.transpose(Ut[:, :k], (0, 2, 1))
    z0 = _mv(V[:, :, :k], _mv(Ut[:, :k], b_eq) / s[:, :k])
    return z0, V[:, :, k:], (V[:, :, :k], s[:, :k, None] * np.eye(k), U)


def _given_null_space(A_eq: np.ndarray, b_eq: np.ndarray, N: np.ndarray):
    """:func:`_null_space`'s ``(z0, N, factors)`` from a formulation's orthonormal basis
    ``N`` of mutually orthogonal rows (``Conic.null_space``), without a factorization:
    ``A_eq' = Q R`` with ``Q`` the rows over their norms and ``R`` the norms (diagonal).
    """
    s = np.sqrt(np.einsum("tij,tij->ti", A_eq, A_eq))
    Q = np.transpose(A_eq, (0, 2, 1)) / s[:, None, :]
    return _mv(Q, b_eq / s), N, (Q, s, None)


def eliminate_equalities(P, q, A, b, cones, null_space=None) -> Reduced:
    """The stacked conic problems ``(P, q, A, b)`` (``P`` (n, n), (T, n, n) or None;
    ``q`` (T, n), ``A`` (T, m, n), ``b`` (T, m)) in their reduced form (:class:`Reduced`);
    ``null_space`` (T, n, k): the formulation's bases (``Conic.null_space``), used when
    they fit the rows' count (``k = n - rows``), else the rows are factored here.
    """
    A, b, q = np.asarray(A, float), np.asarray(b, float), np.asarray(q, float)
    T, _, n = A.shape
    P = np.zeros((n, n)) if P is None else np.asarray(P, float)
    d = _diagonal(P)
    P = np.broadcast_to(P, (T, n, n)) if d is None else np.broadcast_to(d, (T, n))
    eq, rest, kept = zero_rows(cones)
    A_in, A_eq, b_eq = _part(A, rest), _part(A, eq), _part(b, eq)
    if null_space is not None and np.shape(null_space) == (T, n, n - len(eq)):
        z0, N, factors = _given_null_space(A_eq, b_eq, null_space)
    else:
        z0, N, factors = _null_space(A_eq, b_eq)
    Pz0 = _times(P, z0)
    Nt = np.transpose(N, (0, 2, 1))
    return Reduced(
        P=(Nt @ P @ N) if d is None else (Nt * P[:, None, :]) @ N, q=_mv(Nt, Pz0 + q),
        A=A_in @ N, b=_part(b, rest) - _mv(A_in, z0), cones=kept, z0=z0, N=N,
        factors=factors, rows_eq=eq, rows_in=rest,
        offset=np.einsum("tn,tn->t", z0, 0.5 * Pz0 + q), P_full=P, q_full=q, A_in=A_in)
