"""The member of the rigid set a physics engine picks, predicted without simulating.

Both engines hold every bearing by a softened constraint on a rigid kinematic tree
(:mod:`~cardan_forces.driveline.engine_mujoco`,
:mod:`~cardan_forces.driveline.engine_drake`). Once the line has settled, each bearing
row ``i`` behaves as a linear spring of compliance ``c_i`` (m/N) between the shaft and
the ground, and the tree joints are exact. By Menabrea's theorem the forces of a
redundant structure of linear springs on rigid members minimise the complementary
energy over the statically admissible forces:

    min_x  1/2 sum_k c_k ||F_k(x)||^2   s.t.  A x = b                          (1)

with ``F_k(x)`` bearing ``k``'s force on its shaft (N, the force rows of its block of
``A``), the same ``c_k`` on its three rows. The joints' columns carry no energy; what
(1) leaves free of them is the end-face pairs' split, resolved by complementarity on
their net push as the engines' forces are read. Only the ratios of the ``c_k`` matter.

- **MuJoCo** (documentation, *Computation*, "Soft constraints" and "Solver
  parameters"): a row's force solves ``a1 + d (b v + k r) = (1 - d) a0``, with
  regulariser ``R = (1 - d)/d * A_hat`` (``A_hat`` the diagonal approximation of
  ``J M^-1 J'``: for a ``connect``, the translational ``body_invweight0`` of its two
  bodies, the world's 0), ``k = d / (dmax^2 timeconst^2 dampratio^2)``, ``b = 2 /
  (dmax timeconst)``. At rest (``a1 = v = 0``) the force is ``f = -k r / R``: a spring
  of compliance

      c = R / k = (1 - d) / d^2 * dmax^2 * timeconst^2 * dampratio^2 * A_hat     (2)

  with ``d = dmin`` (a settled bearing sags far less than ``solimp``'s width; a width
  below the sag makes ``d = dmax``, again common to all rows). Between bearings only
  ``A_hat`` and a shaft's time-constant scale differ, so MuJoCo's member is (1) with
  ``c_k = s_k^2 A_hat_k`` (``s_k`` the ``scaled`` factor of its shaft).
- **Drake's SAP** (Castro et al., "An unconstrained convex formulation of compliant
  contact", IEEE T-RO 2022, section V; ``SapHolonomicConstraint``): a ball constraint
  is near-rigid, with regulariser ``R_i = beta^2 / (4 pi^2) w_i`` (``beta = 0.1``) and
  relaxation time one step ``dt``, so ``v_hat = -g / (2 dt)``; its impulse
  ``gamma = (v_hat - v_c) / R`` is at rest the force ``gamma / dt = -g / (2 dt^2 R)``: a
  spring of compliance

      c = 2 dt^2 beta^2 / (4 pi^2) * w_i                                      (3)

  the same factor for every row: the step does not move the member, and Drake's is (1)
  with ``c_k = w_k``, the Delassus estimate of the bearing's ball constraint in the
  line's configuration at the instant
  (:func:`~cardan_forces.driveline.engine_drake.delassus_estimates`).
"""

from __future__ import annotations

import numpy as np


def compliances_mujoco(op, softness) -> dict[str, float]:
    """``c_k`` of eq. (2) by bearing contact name, up to the common factor: ``s_k^2``
    times the ``A_hat`` of the bearing's ``connect`` (MuJoCo's compiled
    ``body_invweight0`` of the shaft body it holds; nothing is simulated).
    """
    import mujoco
    from cardan_forces.driveline import engine_mujoco

    model = mujoco.MjModel.from_xml_string(engine_mujoco.build_mjcf(op, softness))
    scale = dict(softness.scaled)
    out = {}
    for link in op.bearings():
        name = link.name
        e = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_EQUALITY, name)
        a_hat = sum(model.body_invweight0[b, 0] for b in (model.eq_obj1id[e],
                                                          model.eq_obj2id[e]))
        out[name] = scale.get(op.scene.shafts[link.shaft].name, 1.0) ** 2 * float(a_hat)
    return out


def compliances_drake(op, angles) -> list[dict[str, float]]:
    """``c_k`` of eq. (3) by bearing contact name, up to the common factor, at each of
    the first shaft's ``angles`` (rad, increasing: the rigid motion's at the instants
    predicted): SAP's Delassus estimate ``w_k`` of the bearing's ball constraint, which
    changes as the line turns (the mass matrix's diagonal and the Jacobian do).
    """
    from cardan_forces.driveline import engine_drake

    return engine_drake.delassus_estimates(op, angles)


def predicted(op, i: int, compliance: dict[str, float]) -> np.ndarray:
    """The member (1) of the rigid set at instant ``i`` (N, N m; the operator's column
    order) for bearing compliances ``compliance`` (by contact name, any common unit).

    Solved on the null space of ``A``: ``x = x0 + N z`` with ``x0`` the least-norm
    solution, ``z`` the least-norm minimiser of ``||S (x0 + N z)||`` where ``S`` stacks
    ``sqrt(c_k)`` times each bearing's force rows; the pairs then complementary on
    their net push.
    """
    A, b = op.A[i], op.b[i]
    x0 = np.linalg.lstsq(A, b, rcond=None)[0]
    _, s, vt = np.linalg.svd(A)
    rank = int(np.sum(s > s[0] * 1e-10))
    null = vt[rank:].T
    rows = []
    for link in op.bearings():
        S = np.zeros((3, A.shape[1]))
        S[:, link.columns] = A[6 * link.body: 6 * link.body + 3, link.columns]
        rows.append(np.sqrt(compliance[link.name]) * S)
    S = np.vstack(rows)
    z = np.linalg.lstsq(S @ null, -S @ x0, rcond=None)[0]
    x = x0 + null @ z
    for a, c in op.pairs:
        net = x[c] - x[a]
        x[a], x[c] = max(-net, 0.0), max(net, 0.0)
    return x
