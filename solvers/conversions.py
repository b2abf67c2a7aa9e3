"""Exact reformulations that let a backend solve a problem class it does not take directly.

The chain is LS -> QP -> Conic and LP -> Conic; each step keeps ``checks``,
``formulation`` and ``to_forces``, so the record is judged on the original forces.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from cardan_forces.formulations.problems import LP, LS, QP, Conic


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
