"""One tolerance, translated into a solver's own parameter names.

``tol=None`` means "the solver's defaults": :func:`options_for` then returns nothing and
no adapter touches a numerical setting. A given ``tol`` sets every parameter the backend
declares (``Backend.tolerances``, in its adapter file) to ``tol``, clamped to the range
the solver accepts. Direct methods (SVD, quadprog, Lemke) declare none; ``tol`` is
ignored for them.
"""

from __future__ import annotations

TIME_LIMIT_S = 20.0
"""Wall-time limit of one solve for solvers whose own iteration limit does not bound the
time (HiGHS's QP ran for minutes on one near-90-degree instant): the adapter passes it
as the solver's own time limit, so a stalled solve ends as a failed record, never a
hang. Options given to a solve override it."""

TIKHONOV_DEFAULT = 1e-10
"""Relative Tikhonov weight of ``scipy-lsq_linear`` when no ``tol`` is given."""


def options_for(parameters: tuple[str, ...], tol: float | None,
                smallest: float = 0.0) -> dict[str, float]:
    """``{parameter: tol}`` for each of ``parameters`` (empty when ``tol`` is None);
    ``smallest``: the least value the solver accepts (HiGHS rejects smaller ones).
    """
    if tol is None:
        return {}
    return dict.fromkeys(parameters, max(float(tol), smallest))


def tikhonov_weight(tol: float | None) -> float:
    """Relative weight ``mu / sigma_max^2`` of the penalty in ``scipy-lsq_linear``.

    The penalty biases the answer by about ``mu`` relative to the squared singular values
    of the (scaled) equilibrium matrix, so the weight follows the requested tolerance.
    """
    return TIKHONOV_DEFAULT if tol is None else float(tol)
