"""One tolerance, translated into each solver's own parameter names.

``tol=None`` means "the solver's defaults": :func:`options_for` then returns nothing and
no adapter touches a numerical setting. A given ``tol`` sets every parameter listed for
that solver to ``tol`` (clamped to the range the solver accepts). Direct methods
(SVD, quadprog, Lemke) have no tolerance; their entry is empty and ``tol`` is ignored.
Keys are solver names, shared by every wrapper of that solver (``"osqp"`` serves both
``qpsolvers-osqp`` and ``cvxpy-osqp``).
"""

from __future__ import annotations

TOLERANCE_PARAMETERS: dict[str, tuple[str, ...]] = {
    "clarabel": ("tol_gap_abs", "tol_gap_rel", "tol_feas"),
    "daqp": ("primal_tol",),
    "ecos": ("abstol", "reltol", "feastol"),
    "fsolve": ("xtol",),
    "highs": ("primal_feasibility_tolerance", "dual_feasibility_tolerance"),
    "lcp-fb-newton": ("tol",),
    "lcp-lemke": (),
    "lcp-pgs": ("tol",),
    "lsq_linear": ("tol",),
    "numpy-kkt": (),
    "osqp": ("eps_abs", "eps_rel"),
    "piqp": ("eps_abs", "eps_rel"),
    "proxqp": ("eps_abs",),
    "quadprog": (),
    "root-lm": ("xtol", "ftol"),
    "scs": ("eps_abs", "eps_rel"),
}

SMALLEST: dict[str, float] = {"highs": 1e-10}
"""Smallest value a solver accepts for its tolerances (HiGHS rejects smaller ones)."""

TIKHONOV_DEFAULT = 1e-10
"""Relative Tikhonov weight of ``scipy-lsq_linear`` when no ``tol`` is given."""


def options_for(solver: str, tol: float | None) -> dict[str, float]:
    """The solver's own keyword arguments for tolerance ``tol`` (empty when ``tol`` is None).

    A ``tol`` for a solver missing from :data:`TOLERANCE_PARAMETERS` raises ``KeyError``
    (a failed record in :func:`cardan_forces.solvers.solve`) rather than being silently ignored.
    """
    if tol is None:
        return {}
    value = max(float(tol), SMALLEST.get(solver, 0.0))
    return dict.fromkeys(TOLERANCE_PARAMETERS[solver], value)


def tikhonov_weight(tol: float | None) -> float:
    """Relative weight ``mu / sigma_max^2`` of the penalty in ``scipy-lsq_linear``.

    The penalty biases the answer by about ``mu`` relative to the squared singular values
    of the (scaled) equilibrium matrix, so the weight follows the requested tolerance.
    """
    return TIKHONOV_DEFAULT if tol is None else float(tol)
