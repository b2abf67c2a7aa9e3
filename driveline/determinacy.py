"""Which contact forces the rigid model determines, the least-norm answer, and the one
rank test that says whether contacts hold a line (held, mechanism or locked).

At one instant, the solution set of ``A x = b`` is ``x_min_norm + N y`` with ``N`` an
orthonormal null-space basis. A component is *determinate* when its row of ``N``
vanishes: no redundant force can change it. Both come from one SVD.

The least-norm answer minimizes ``||x||`` with all columns in N; it depends on that
choice of units and scaling (a compliance answer does not). It is one member of the
set, not "the" force of an indeterminate component.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from cardan_forces.util.rank import RANK_RTOL, numerical_rank

if TYPE_CHECKING:
    from .equilibrium import Operator

DETERMINATE_TOL = 1e-8
"""A component is determinate when its null-space row norm is below this (the basis
is orthonormal, so rows have norms in [0, 1])."""


@dataclass(frozen=True)
class Determinacy:
    """Rank, null space and least-norm solution of ``A x = b`` at one instant."""

    t: float
    names: tuple[str, ...]
    rank: int
    singular_values: np.ndarray
    null_basis: np.ndarray
    null_row_norms: np.ndarray
    min_norm: np.ndarray
    residual: float

    @property
    def nullity(self) -> int:
        return self.null_basis.shape[1]

    @property
    def determinate(self) -> np.ndarray:
        return self.null_row_norms < DETERMINATE_TOL

    def to_json(self) -> dict:
        """``{"t", "rank", "nullity", "residual", "tolerances", "components": {name:
        {"determinate", "min_norm"}}}``.
        """
        return {
            "t": self.t,
            "rank": self.rank,
            "nullity": self.nullity,
            "residual": self.residual,
            "tolerances": {"rank_rtol": RANK_RTOL, "determinate_tol": DETERMINATE_TOL},
            "components": {
                name: {"determinate": bool(det), "min_norm": float(value)}
                for name, det, value in zip(self.names, self.determinate, self.min_norm)
            },
        }


def equilibrated(A: np.ndarray) -> np.ndarray:
    """``A`` with columns, then rows, scaled to unit norm (zero ones kept zero), so that
    a rank does not depend on units (moments in N m over lengths from 1e-6 m to 1e3 m).
    """
    col = np.linalg.norm(A, axis=0)
    A = A / np.where(col > 0, col, 1.0)
    row = np.linalg.norm(A, axis=1)
    return A / np.where(row > 0, row, 1.0)[:, None]


def left_null_space(A: np.ndarray) -> np.ndarray:
    """An orthonormal basis (rows x free) of the left null space of the equilibrated
    ``A``: for an equilibrium operator (6 rows per body), the body motions along which
    no contact does work.
    """
    u, s, _ = np.linalg.svd(equilibrated(A))
    return u[:, numerical_rank(s):]


@dataclass(frozen=True)
class Hold:
    """How contacts hold a line meant to turn with one degree of freedom: ``null`` is the
    basis of its free motions (rows x free, :func:`left_null_space`); one free motion
    (the rotation) is held, more a mechanism, none locked.
    """

    null: np.ndarray

    @property
    def free(self) -> int:
        """Free motions: rows minus the rank of the equilibrated operator."""
        return self.null.shape[1]


def holding(A: np.ndarray) -> Hold:
    """The free motions that the equilibrium operator ``A`` (rows x contact columns, six
    rows per body) leaves.
    """
    return Hold(left_null_space(A))


def determinacy(op: Operator, i: int) -> Determinacy:
    """Rank, null-space basis, determinate flags and least-norm forces at instant ``i``."""
    A, b = op.A[i], op.b[i]
    u, s, vt = np.linalg.svd(A)
    rank = numerical_rank(s)
    null = vt[rank:].T
    x = vt[:rank].T @ ((u[:, :rank].T @ b) / s[:rank])
    return Determinacy(
        t=float(op.t[i]),
        names=op.names,
        rank=rank,
        singular_values=s,
        null_basis=null,
        null_row_norms=np.linalg.norm(null, axis=1),
        min_norm=x,
        residual=float(np.linalg.norm(A @ x - b) / max(np.linalg.norm(b), 1e-300)),
    )
