"""The named state of the ``newton`` family's compiled method (:mod:`._newton_kernels`).

Plain named tuples of arrays (numba passes and builds them as it does tuples and reads
their fields by name): what the kernel is given (:class:`Contacts`, :class:`Params`),
one instant's data (:class:`Data`) and what an instant works in (:class:`Scratch`).
Kept apart from the kernels so that the NumPy side builds them without numba.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np


class Contacts(NamedTuple):
    """The contacts' structure (:class:`._newton_numpy.Groups` as the kernel takes it)."""

    members: np.ndarray
    """(G, w) columns of ``E`` per contact, zero-padded."""
    mask: np.ndarray
    """(G, w) 1 where ``members`` is real."""
    signed: np.ndarray
    """(G,) booleans: a pushing column (a group of one with ``f >= 0``)."""
    n: np.ndarray
    """(G,) the law's exponent (1 linear, 3/2 Hertz)."""


class Params(NamedTuple):
    """The method's settings (:mod:`._newton_numpy`'s constants and the call's options)."""

    tol: float
    max_iter: int
    soften: float
    null_rtol: float
    reg_rtol: float
    ls_rtol: float
    ls_max: int
    stall: float
    extrapolation: int
    warm_iter: int


class Data(NamedTuple):
    """One instant's numbers."""

    Et: np.ndarray
    """(nv, m) ``E'``: a column of ``E`` is a contiguous row."""
    span: np.ndarray
    """(nv, 2) the rows ``[lo, hi)`` where each column can be nonzero."""
    e: np.ndarray
    """(m,) the equilibrium's right-hand side."""
    k: np.ndarray
    """(G,) each contact's stiffness (or power coefficient)."""
    g: np.ndarray
    """(G,) each contact's gap."""


class Scratch(NamedTuple):
    """What an instant works in, allocated once per call (``m`` rows, ``nv`` columns,
    ``G`` contacts of width ``w``).
    """

    H0: np.ndarray
    """(m, m) the nominal Hessian (a cold start's first step)."""
    H: np.ndarray
    """(m, m) the Hessian of a step."""
    L: np.ndarray
    """(m, m) the lower Cholesky factor of the step's matrix."""
    V: np.ndarray
    """(m, m) the left null space of ``E`` in its first ``nk`` columns."""
    dependent: np.ndarray
    """(m,) booleans: a factor's rows skipped as dependent."""
    rhs: np.ndarray
    """(m,) a right-hand side."""
    du: np.ndarray
    """(m,) the step (or a start's other candidate)."""
    grad: np.ndarray
    """(m,) the projected gradient."""
    d: np.ndarray
    """(nv,) the deformations ``E'u``."""
    f: np.ndarray
    """(nv,) the forces at ``d``."""
    delta: np.ndarray
    """(nv,) ``E'du``."""
    weights: np.ndarray
    """(nv,) each column's slope in ``H0``."""
    ratio: np.ndarray
    """(G,) each contact's ``r / s``."""
    slope: np.ndarray
    """(G,) each contact's ``r'``."""
    U: np.ndarray
    """(G, w) each contact's direction."""
    z: np.ndarray
    """(m,) a Hessian term's row (``E_q u``)."""
    dg: np.ndarray
    """(w,) one contact's deformations."""
    Dq: np.ndarray
    """(G, w) each contact's deformations at a line search's start."""
    Lq: np.ndarray
    """(G, w) each contact's deformations along the step."""
    lengths: np.ndarray
    """(G,) ``||Lq||^2`` per contact."""
    B: np.ndarray
    """(nv + G, m) the Hessian's rank-one terms, scaled by their roots."""
    ranges: np.ndarray
    """(nv + G, 2) each term's rows ``[lo, hi)``."""
    dense: bool
    """Sum the terms by one BLAS product (else by rank-one updates over their rows)."""
