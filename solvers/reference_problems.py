"""Small problems with answers known in closed form, shared by every solver's tests.

Each :class:`Reference` pairs a problem with the status a correct solver reports and,
when solved, the exact forces. The forces are named ``x0, x1, ...``; every problem has
an equilibrium row with a nonzero right-hand side, so relative residuals are meaningful.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from cardan_forces.formulations.problems import (
    LCP,
    LP,
    LS,
    NLS,
    QP,
    Conic,
    ForceChecks,
    SecondOrderCone,
)

from .record import Status


@dataclass(frozen=True)
class Reference:
    """A problem, the status it should get and its exact forces (None unless solved)."""

    name: str
    problem: object
    status: Status = Status.SOLVED
    x: np.ndarray | None = None


def _checks(A, b, unilateral, names=None, **kw) -> ForceChecks:
    A = np.atleast_2d(np.asarray(A, float))
    names = names or tuple(f"x{i}" for i in range(A.shape[1]))
    return ForceChecks(A=A, b=np.asarray(b, float), names=tuple(names),
                       unilateral=np.asarray(unilateral, bool), **kw)


def _ls() -> list[Reference]:
    # x = A'(AA')^{-1} b and, weighted, W^{-1}A'(AW^{-1}A')^{-1} b, worked by hand.
    A, b = np.array([[1.0, 1, 0], [0, 1, 1]]), np.array([1.0, 2])
    checks = _checks(A, b, [False] * 3)
    return [
        Reference("ls_min_norm", LS(checks=checks, formulation="ref", A=A, b=b),
                  x=np.array([0.0, 1, 1])),
        Reference("ls_weighted", LS(checks=checks, formulation="ref", A=A, b=b,
                                    weights=np.array([1.0, 4, 1])),
                  x=np.array([0.5, 0.5, 1.5])),
        # Rank-deficient (third row = first + second): same answer as ls_min_norm.
        Reference("ls_redundant", LS(checks=_checks(np.vstack([A, A.sum(0)]), [1.0, 2, 3],
                                                    [False] * 3),
                                     formulation="ref", A=np.vstack([A, A.sum(0)]),
                                     b=np.array([1.0, 2, 3])),
                  x=np.array([0.0, 1, 1])),
    ]


def _qp() -> list[Reference]:
    ones = np.ones((1, 3))
    simplex = _checks(ones, [1.0], [True] * 3)
    plane = _checks(ones, [3.0], [False] * 3)
    return [
        # Projection of (1.2, 0.6, -1) onto the simplex: shift by 0.4, clip x2 at 0.
        Reference("qp_active_bound",
                  QP(checks=simplex, formulation="ref", P=np.eye(3),
                     q=-np.array([1.2, 0.6, -1.0]), A=ones, b=np.array([1.0]),
                     lb=np.zeros(3)),
                  x=np.array([0.8, 0.2, 0.0])),
        # Same projection of (1.2, -0.2, -1) with x1 free (lb -inf): shift 0, clip x2 at 0.
        Reference("qp_free_component",
                  QP(checks=_checks(ones, [1.0], [True, False, True]), formulation="ref",
                     P=np.eye(3), q=-np.array([1.2, -0.2, -1.0]), A=ones, b=np.array([1.0]),
                     lb=np.array([0.0, -np.inf, 0.0])),
                  x=np.array([1.2, -0.2, 0.0])),
        # min ||x||^2 on x0+x1+x2 = 3 with x0 - x1 <= -1 active: x = (1,1,1) - 0.5 (1,-1,0).
        Reference("qp_active_inequality",
                  QP(checks=plane, formulation="ref", P=np.eye(3), q=np.zeros(3), A=ones,
                     b=np.array([3.0]), G=np.array([[1.0, -1, 0]]), h=np.array([-1.0])),
                  x=np.array([0.5, 1.5, 1.0])),
        Reference("qp_infeasible",
                  QP(checks=_checks([[1.0, 1]], [-1.0], [True, True]), formulation="ref",
                     P=np.eye(2), q=np.zeros(2), A=np.array([[1.0, 1]]), b=np.array([-1.0]),
                     lb=np.zeros(2)),
                  status=Status.INFEASIBLE),
    ]


def _lp() -> list[Reference]:
    # max x0 + x1 s.t. x0 + 2 x1 <= 4 (slack x2), 3 x0 + x1 <= 6: vertex (8/5, 6/5).
    A, b = np.array([[1.0, 2, 1]]), np.array([4.0])
    checks = _checks(A, b, [True] * 3)
    ray = _checks([[1.0, -1]], [1.0], [True, True])
    return [
        Reference("lp_vertex",
                  LP(checks=checks, formulation="ref", c=np.array([-1.0, -1, 0]), A=A, b=b,
                     G=np.array([[3.0, 1, 0]]), h=np.array([6.0]), lb=np.zeros(3)),
                  x=np.array([1.6, 1.2, 0.0])),
        Reference("lp_unbounded",
                  LP(checks=ray, formulation="ref", c=np.array([-1.0, 0]),
                     A=np.array([[1.0, -1]]), b=np.array([1.0]), lb=np.zeros(2)),
                  status=Status.UNBOUNDED),
        Reference("lp_infeasible",
                  LP(checks=_checks([[1.0, 1]], [-1.0], [True, True]), formulation="ref",
                     c=np.array([1.0, 1]), A=np.array([[1.0, 1]]), b=np.array([-1.0]),
                     lb=np.zeros(2)),
                  status=Status.INFEASIBLE),
    ]


def _lcp_forces(M: np.ndarray, q: np.ndarray):
    """Forces ``(z, w)`` with checks ``w - M z = q``, all >= 0, ``z_i`` complementary to ``w_i``."""
    n = len(q)
    names = tuple(f"z{i}" for i in range(n)) + tuple(f"w{i}" for i in range(n))
    checks = _checks(np.hstack([-M, np.eye(n)]), q, [True] * (2 * n), names=names,
                     pairs=tuple((i, n + i) for i in range(n)))
    return checks, lambda z: np.concatenate([z, M @ z + q])


def _lcp() -> list[Reference]:
    M = np.array([[4.0, 1, 0], [1, 4, 1], [0, 1, 4]])
    q = np.array([-4.0, 2, -8])  # z = (1, 0, 2), w = (0, 5, 0)
    checks, forces = _lcp_forces(M, q)
    M1, q1 = np.array([[-1.0]]), np.array([-1.0])  # w = -z - 1 < 0 for every z >= 0
    checks1, forces1 = _lcp_forces(M1, q1)
    return [
        Reference("lcp_mixed", LCP(checks=checks, formulation="ref", to_forces=forces, M=M, q=q),
                  x=np.array([1.0, 0, 2, 0, 5, 0])),
        Reference("lcp_infeasible",
                  LCP(checks=checks1, formulation="ref", to_forces=forces1, M=M1, q=q1),
                  status=Status.INFEASIBLE),
    ]


def _nls() -> list[Reference]:
    # x0 + x1 = 3, x0^2 + x1^2 = 5: roots (1, 2) and (2, 1); the start picks (1, 2).
    checks = _checks([[1.0, 1]], [3.0], [False, False])
    polynomial = NLS(
        checks=checks, formulation="ref",
        fun=lambda z: np.array([z[0] + z[1] - 3.0, z[0] ** 2 + z[1] ** 2 - 5.0]),
        jac=lambda z: np.array([[1.0, 1.0], [2 * z[0], 2 * z[1]]]),
        z0=np.array([0.8, 2.3]),
    )
    # The paper's device: the LCP lcp_mixed as the Fischer-Burmeister system Phi(z) = 0.
    M = np.array([[4.0, 1, 0], [1, 4, 1], [0, 1, 4]])
    q = np.array([-4.0, 2, -8])
    lcp_checks, forces = _lcp_forces(M, q)

    def fb(z):
        w = M @ z + q
        return np.hypot(z, w) - z - w

    def fb_jac(z):
        w = M @ z + q
        r = np.maximum(np.hypot(z, w), 1e-300)
        return np.diag(z / r - 1.0) + (w / r - 1.0)[:, None] * M

    return [
        Reference("nls_polynomial", polynomial, x=np.array([1.0, 2.0])),
        Reference("nls_fischer_burmeister",
                  NLS(checks=lcp_checks, formulation="ref", to_forces=forces, fun=fb, jac=fb_jac,
                      z0=np.array([1.0, 1.0, 1.0])),
                  x=np.array([1.0, 0, 2, 0, 5, 0])),
    ]


def _conic() -> list[Reference]:
    # min t s.t. u + v = 2, ||(u, v)|| <= t: u = v = 1, t = sqrt 2.
    soc_checks = _checks([[0.0, 1, 1]], [2.0], [True, False, False],
                         cones=(SecondOrderCone(apex=0, members=(1, 2)),))
    soc = Conic(checks=soc_checks, formulation="ref", q=np.array([1.0, 0, 0]),
                A=np.vstack([[0.0, 1, 1], -np.eye(3)]), b=np.array([2.0, 0, 0, 0]),
                cones=(("zero", 1), ("soc", 3)))
    # max w s.t. x = 4, y = 1, sqrt(x y) >= |w| (power cone, alpha 1/2): w = 2.
    pow_checks = _checks([[1.0, 0, 0], [0, 1, 0]], [4.0, 1], [True, True, False])
    power = Conic(checks=pow_checks, formulation="ref", q=np.array([0.0, 0, -1]),
                  A=np.vstack([[1.0, 0, 0], [0, 1, 0], -np.eye(3)]),
                  b=np.array([4.0, 1, 0, 0, 0]), cones=(("zero", 2), ("pow", 0.5)))
    return [
        Reference("conic_soc", soc, x=np.array([np.sqrt(2.0), 1, 1])),
        Reference("conic_pow", power, x=np.array([4.0, 1, 2])),
    ]


def references() -> list[Reference]:
    """All reference problems, in a stable order."""
    return [*_ls(), *_qp(), *_lp(), *_lcp(), *_nls(), *_conic()]
