"""Backend ``numpy-kkt``: the weighted least-norm solution of an :class:`LS` by SVD.

With ``W = diag(w)`` and ``y = W^{1/2} x`` the problem ``min 1/2 x'Wx s.t. A x = b``
becomes ``min ||y|| s.t. (A W^{-1/2}) y = b``, whose answer is
``y = pinv(A W^{-1/2}) b``. Singular values below ``max(m, n) * eps * sigma_max``
(the rank tolerance of ``numpy.linalg.matrix_rank``; option ``rtol`` replaces the
factor ``max(m, n) * eps``) count as zero, so a redundant equilibrium (rank-deficient
``A``) is handled exactly. A direct method: ``tol`` is ignored.
"""

from __future__ import annotations

import time

import numpy as np
from cardan_forces.formulations.problems import LS

from .backend import Backend
from .record import Outcome, Status

EXTRAS: dict[str, str | None] = {"numpy-kkt": None}


def solve_ls(problem: LS, tol: float | None = None, initvals=None,
             rtol: float | None = None) -> Outcome:
    """Least norm by SVD of the column-scaled equilibrium matrix."""
    start = time.perf_counter()
    A = np.asarray(problem.A, float)
    b = np.asarray(problem.b, float)
    w = np.ones(problem.n) if problem.weights is None else np.asarray(problem.weights, float)
    scale = 1.0 / np.sqrt(w)
    setup_done = time.perf_counter()
    U, sigma, Vt = np.linalg.svd(A * scale, full_matrices=False)
    rtol = max(A.shape) * np.finfo(float).eps if rtol is None else rtol
    cutoff = rtol * sigma.max(initial=0.0)
    rank = int(np.sum(sigma > cutoff))
    y = Vt[:rank].T @ ((U[:, :rank].T @ b) / sigma[:rank])
    z = scale * y
    # W z = A' mu with mu = U S^-1 V' y; in the conic form (P z + A'y = 0) the dual is -mu
    mu = U[:, :rank] @ ((Vt[:rank] @ y) / sigma[:rank])
    return Outcome(
        Status.SOLVED, z, y=-mu,
        message=f"rank {rank} of {min(A.shape)}",
        objective=0.5 * float(z @ (w * z)),
        setup_s=setup_done - start,
        solve_s=time.perf_counter() - setup_done,
    )


def backends() -> list[Backend]:
    """The SVD backend (NumPy is a core dependency, always present)."""
    return [Backend(name="numpy-kkt", family="numpy", distributions=("numpy",), accepts=(LS,),
                    solve=solve_ls)]
