"""The named state of ``numpy-batched``'s compiled least norm (:mod:`._batched_kernels`).

Plain named tuples of arrays (numba passes and builds them as it does tuples, and reads
their fields by name): what the kernel is given (:class:`Layout`, :class:`Params`),
what one group of instants works in (:class:`Group` and its parts) and what it gives
back (:class:`Answers`). Kept apart from the kernels so that the NumPy side builds them
without numba.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np


class Params(NamedTuple):
    """The compiled least norm's tolerances (:func:`._batched_kernels.least_norm`)."""

    gram_rtol: float
    refine_rtol: float
    max_iter: int
    lcp_rtol: float
    lcp_delta: float


class Layout(NamedTuple):
    """The compiled kernel's view of the rows' nonzero pattern (:func:`_make_layout`),
    body blocks in chain order (``nb`` bodies, ``nf`` signed columns, the faces).
    """

    starts: np.ndarray
    """(nb,) each body block's first row."""
    own: np.ndarray
    """(nb, p) the columns touching each body, zero-padded."""
    n_own: np.ndarray
    """(nb,) how many columns touch each body."""
    sh_a: np.ndarray
    """(nb - 1, s) the positions in ``own[k]`` of the columns touching bodies ``k`` and
    ``k + 1``, zero-padded."""
    sh_b: np.ndarray
    """(nb - 1, s) their positions in ``own[k + 1]``."""
    n_sh: np.ndarray
    """(nb - 1,) how many columns each neighbouring pair shares."""
    upos: np.ndarray
    """(nb, nf) the position of face ``j`` in ``own[k]``, -1 where absent."""
    first: np.ndarray
    """(nf,) the first body each face touches (the faces sorted by it)."""
    ncols: np.ndarray
    """(nb,) one plus the number of faces touching bodies up to ``k``."""

class ActiveSetScratch(NamedTuple):
    """What one instant's active-set LCP (:func:`_lcp`) works in, ``k`` faces."""

    pinned: np.ndarray
    """(k,) booleans: the faces pinned at this step."""
    nxt: np.ndarray
    """(k,) booleans: the faces pinned at the next step."""
    S: np.ndarray
    """(k, k + 1): the pinned block and its right-hand side, eliminated in place."""
    idx: np.ndarray
    """(k,) integers: the pinned faces' indices."""


class LcpScratch(NamedTuple):
    """One instant's LCP, copied out of its group's lane (:func:`_lcps`)."""

    M: np.ndarray
    """(nf, nf)."""
    q: np.ndarray
    """(nf,)."""
    lam: np.ndarray
    """(nf,) its solution."""
    active: ActiveSetScratch


class Refinement(NamedTuple):
    """What a group's step of iterative refinement (:func:`_refined`) works in."""

    Z: np.ndarray
    """(m, 1 + nf, W): ``K^-1 [b, U]``, refined."""
    R: np.ndarray
    """(m, 1 + nf, W): the right-hand sides ``[b, U]``."""
    dZ: np.ndarray
    """(m, 1 + nf, W): the correction ``K^-1 (R - B B' Z)``."""
    v: np.ndarray
    """(n, W): ``B' Z_c``."""
    w: np.ndarray
    """(m, W): ``B B' Z_c``."""
    every: np.ndarray
    """(nb,): every body block carries all ``1 + nf`` columns (for :func:`_down`)."""


class Group(NamedTuple):
    """The arrays one group of :data:`W` instants works in (:func:`_group`), instants
    on the last axis; ``nb`` bodies, ``p`` columns at most per body, ``nf`` faces.
    """

    G: np.ndarray
    """(6 nb, p, W): the block rows of ``B = A W^-1/2`` (:func:`_rows`)."""
    L: np.ndarray
    """(6 nb, 6, W): Cholesky factors of the pivots (:func:`_factor`)."""
    H: np.ndarray
    """(6 nb, 6, W): the factor's off-diagonal blocks."""
    Z: np.ndarray
    """(m, 1 + nf, W): ``C^-1 [b, U]``."""
    y: np.ndarray
    """(m, 1, W): the multipliers ``mu``."""
    y1: np.ndarray
    """(m, 1, W): the faces' share of ``mu``."""
    v: np.ndarray
    """(n, W): ``B' mu`` and the forces before scaling."""
    w: np.ndarray
    """(m, W): ``B B' mu``."""
    M: np.ndarray
    """(nf, nf, W): the faces' LCP matrix from the factor."""
    q: np.ndarray
    """(nf, W): its vector."""
    Mr: np.ndarray
    """(nf, nf, W): the LCP matrix from the refined solve."""
    qr: np.ndarray
    """(nf, W): its vector."""
    refine: np.ndarray
    """(W,) booleans: the instants that take a refinement step."""
    lam: np.ndarray
    """(nf, W): the faces' forces (scaled)."""
    refined: Refinement
    lcp: LcpScratch


class Answers(NamedTuple):
    """What :func:`least_norm` gives, per instant (T rows)."""

    x: np.ndarray
    """(T, n) the forces."""
    mu: np.ndarray
    """(T, m) the multipliers of ``A x = b``."""
    lam: np.ndarray
    """(T, nf) the end faces' LCP solution."""
    iterations: np.ndarray
    """(T,) active-set steps."""
    settled: np.ndarray
    """(T,) booleans: whether the active set settled."""
