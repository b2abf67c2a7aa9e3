"""Which contact forces the rigid model determines, and the least-norm answer.

At one instant, the solution set of ``A x = b`` is ``x_min_norm + N y`` with ``N`` an
orthonormal null-space basis. A component is *determinate* when its row of ``N``
vanishes: no redundant force can change it. Both come from one SVD.

The least-norm answer minimizes ``||x||`` with all columns in N; it depends on that
choice of units and scaling (a compliance answer does not). It is one member of the
set, not "the" force of an indeterminate component.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .equilibrium import Operator

RANK_RTOL = 1e-9
"""Singular values below ``RANK_RTOL * sigma_max`` count as zero."""

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


def determinacy(op: Operator, i: int) -> Determinacy:
    """Rank, null-space basis, determinate flags and least-norm forces at instant ``i``."""
    A, b = op.A[i], op.b[i]
    u, s, vt = np.linalg.svd(A)
    rank = int(np.sum(s > RANK_RTOL * s[0]))
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
