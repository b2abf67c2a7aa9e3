"""QOCO's problem form, shared by the adapters of QOCO (``qoco_``) and of the QOCO
solvers generated per structure (``qocogen_``), so that neither imports the other.

QOCO's form is ``min 1/2 x'Px + c'x s.t. A x = b, G x <=_C h`` with ``C = R+^l x
SOC(q_1) x ...``: the package's zero-cone rows are ``A``, the others ``G`` (nonnegative
rows first, then the second-order blocks, each apex first as in the package's form).
"""

from __future__ import annotations

import numpy as np
from cardan_forces.formulations.problems import Conic

from .stacking import blocks

CLAIM_TOL = 1e-5
"""QOCO has no certificate of infeasibility or unboundedness (no homogeneous
embedding): on an unbounded LP its iterates diverge and it reports solved, its tolerances
being relative to them, with a dual residual near 1. A solved whose own absolute dual
residual or gap exceeds this (QOCO's default ``abstol_inacc``; the package's problems
are scaled to O(1)) is reported inaccurate."""



def supports(problem: Conic) -> bool:
    """Zero, nonnegative and second-order cones only (QOCO has no power cone)."""
    return all(kind in ("zero", "nonneg", "soc") for kind, _ in problem.cones)


def layout(cones) -> tuple[np.ndarray, np.ndarray, int, list[int]]:
    """QOCO's row order: the zero-cone rows, the nonnegative rows, then each second-order
    block (stable within a kind); ``(equality rows, cone rows, l, q)``.
    """
    rows = {"zero": [], "nonneg": [], "soc": []}
    for kind, _, block in blocks(cones):
        rows[kind].extend(range(block.start, block.stop))
    sizes = [int(size) for kind, size in cones if kind == "soc"]
    return (np.array(rows["zero"], int), np.array(rows["nonneg"] + rows["soc"], int),
            len(rows["nonneg"]), sizes)


def csc_ones(mask: np.ndarray):
    """CSC pattern of a (r, c) boolean ``mask``: a matrix of ones on it (a placeholder
    that no value can thin out) and the (row, col) of its entries in CSC order, which is
    the order QOCO's updates (and the generated solver's) take the values in.
    """
    import scipy.sparse as spa

    cols, rows = np.nonzero(mask.T)
    indptr = np.concatenate([[0], np.cumsum(np.bincount(cols, minlength=mask.shape[1]))])
    return spa.csc_matrix((np.ones(len(rows)), rows, indptr), shape=mask.shape), rows, cols
