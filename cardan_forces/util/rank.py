"""The package's one rank rule: singular values below :data:`RANK_RTOL` times the largest
count as zero. Every rank uses it: the determinacy, the support, release and sliding
checks (``driveline.determinacy``), the rigid set's LPs and the conic forms' equality
rows (``formulations``), the reduced forms' elimination of equality rows and the paper
system's Jacobian note (``solvers``).
"""

from __future__ import annotations

import numpy as np

RANK_RTOL = 1e-9
"""Singular values below ``RANK_RTOL * sigma_max`` count as zero: decades above the
rounding of a factorization (about 1e-16 of ``sigma_max`` times the matrix's size), so
rounding never adds to a rank, and decades below an independent direction (on the
built-in scenes' operators and conic equality rows, raw or equilibrated, the smallest
is above 1e-3 of the largest), so none is lost."""


def numerical_rank(s: np.ndarray) -> int:
    """Singular values ``s`` (descending) above :data:`RANK_RTOL` times the largest."""
    return int(np.sum(s > RANK_RTOL * s[0])) if s.size and s[0] > 0 else 0


def numerical_ranks(s: np.ndarray) -> np.ndarray:
    """:func:`numerical_rank` of each row of ``s`` (..., k), each row descending."""
    s = np.asarray(s, float)
    return np.sum(s > RANK_RTOL * s[..., :1], axis=-1)
