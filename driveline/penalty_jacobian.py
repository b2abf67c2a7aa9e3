"""Compiled Jacobian of the penalty simulation's right-hand side, by the chain rule.

Per contact in touch, the force law's derivative with respect to the contact's local
kinematics (offset, axes, relative velocity), by hand (:func:`_push_rates`: the law's
rates in ``d`` and ``d'`` times theirs in the kinematics); times the derivatives of
those kinematics with respect to the 13 states of each of the contact's two bodies
(:func:`_local_rates`); a bushing's torsion spring, a pure couple, from the rates of
its four axes and of the bodies' angular velocities (:func:`_twist_rows`); then the
Newton-Euler equations differentiated by hand (:func:`_body_rates`). Exact where a
forward difference loses half the digits (the tests hold it to the NumPy model's
complex-step Jacobian, :meth:`penalty_model._Model.jacobian`). Its scratch is one
:class:`JacobianScratch` made once per run.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .harmonic import harmonic
from .penalty_contact import (
    LINE,
    RADIAL,
    SPRING,
    TWIST,
    Local,
    _contacts_into,
    _line,
    _local,
    _push,
    _twist,
    kernel,
    new_contact_state,
    new_local,
)


class JacobianScratch(NamedTuple):
    """What :func:`_jacobian_into` fills besides the Jacobian: the rotations' rates
    ``drot`` (nb + 1, 4, 3, 3; the ground's stay zero), the net moments' rates
    ``dmoment`` (nb, 3, n), a contact's :class:`Local` kinematics, its ``grad`` (3, 12)
    and ``rates`` (9, 12) (:func:`_push_rates`), ``dloc`` (18, 26) and its state
    indices ``cols`` (26,) (:func:`_local_rates`), ``rows`` (3, 3, 26)
    (:func:`_contact_rows`).
    """

    drot: np.ndarray
    dmoment: np.ndarray
    local: Local
    grad: np.ndarray
    rates: np.ndarray
    dloc: np.ndarray
    cols: np.ndarray
    rows: np.ndarray


@kernel()
def _linked(nb, topology):
    """``linked[k, j]``: body ``k``'s accelerations can depend on body ``j``'s states (the
    same body, or the two share a contact; the ground, ``nb``, has none). Every other
    block of the Jacobian's velocity and rate rows is zero: on ``paper`` half of them.
    """
    linked = np.eye(nb, dtype=np.bool_)
    for c in range(topology.shape[0]):
        a, b = topology[c, 0], topology[c, 1]
        if a < nb and b < nb:
            linked[a, b] = linked[b, a] = True
    return linked



@kernel(inline="always")
def _rotation_rates(q, rot, out):
    """``dR/dq_k`` into ``out`` (4, 3, 3): the rotation of a quaternion (w, x, y, z) of
    any norm, ``R = Q(q) / |q|^2``, so ``dR/dq_k = (dQ/dq_k - 2 q_k R) / |q|^2``.
    """
    w, x, y, z = q[0], q[1], q[2], q[3]
    n = w * w + x * x + y * y + z * z
    out[0, 0, 0], out[0, 0, 1], out[0, 0, 2] = w, -z, y
    out[0, 1, 0], out[0, 1, 1], out[0, 1, 2] = z, w, -x
    out[0, 2, 0], out[0, 2, 1], out[0, 2, 2] = -y, x, w
    out[1, 0, 0], out[1, 0, 1], out[1, 0, 2] = x, y, z
    out[1, 1, 0], out[1, 1, 1], out[1, 1, 2] = y, -x, -w
    out[1, 2, 0], out[1, 2, 1], out[1, 2, 2] = z, w, -x
    out[2, 0, 0], out[2, 0, 1], out[2, 0, 2] = -y, x, w
    out[2, 1, 0], out[2, 1, 1], out[2, 1, 2] = x, y, z
    out[2, 2, 0], out[2, 2, 1], out[2, 2, 2] = -w, z, -y
    out[3, 0, 0], out[3, 0, 1], out[3, 0, 2] = -z, -w, x
    out[3, 1, 0], out[3, 1, 1], out[3, 1, 2] = w, -z, y
    out[3, 2, 0], out[3, 2, 1], out[3, 2, 2] = x, y, z
    for k in range(4):
        for i in range(3):
            for j in range(3):
                out[k, i, j] = 2.0 * (out[k, i, j] - q[k] * rot[i, j]) / n


@kernel()
def jacobian(t, y, model):
    """``df/dy`` (exact to round-off) by the chain rule: per contact in touch, the
    derivative of its force on ``a`` with respect to its local kinematics (``p, ea, ub,
    rel``: :func:`_push_rates`), times their derivatives with respect to
    the 13 states of each of its two bodies (:func:`_local_rates`, :func:`_contact_rows`);
    then the bodies' Newton-Euler equations differentiated by hand (:func:`_body_rates`).
    Arguments as :func:`rhs` (``model``: :class:`~.penalty_contact.ModelArrays`). A
    contact out of touch (no push in the contacts' evaluation) is skipped before its
    kinematics; one on the ground has only ``a``'s 13 columns.
    """
    n, nb = y.shape[0], model.mass.shape[0]
    jac = np.empty((n, n))
    _jacobian_into(t, y, model, jac, _linked(nb, model.topology),
                   new_contact_state(y, nb, model.topology.shape[0]),
                   new_jacobian_scratch(nb, n))
    return jac


@kernel()
def new_jacobian_scratch(nb, n):
    """A zeroed :class:`JacobianScratch` for ``nb`` bodies and ``n`` states. Made once
    per run by the integrator: its Jacobians then allocate nothing.
    """
    return JacobianScratch(drot=np.zeros((nb + 1, 4, 3, 3)), dmoment=np.zeros((nb, 3, n)),
                           local=new_local(np.float64), grad=np.zeros((3, 12)),
                           rates=np.zeros((9, 12)), dloc=np.zeros((18, 26)),
                           cols=np.zeros(26, dtype=np.int64), rows=np.zeros((3, 3, 26)))


@kernel()
def _jacobian_into(t, y, model, jac, linked, state, own):
    """:func:`jacobian` into ``jac`` (the integrator's own array: no new matrix per
    Jacobian), with ``model`` the :class:`~.penalty_contact.ModelArrays`, ``linked`` the
    bodies' :func:`_linked`, ``state`` the contacts' :class:`ContactState` (shared with
    the right-hand side: each evaluation fills it anew) and ``own`` a
    :class:`JacobianScratch`, all made once per run.
    """
    mass, topology, geometry, laws, d_max = (model.mass, model.topology, model.geometry,
                                             model.laws, model.d_max)
    nb, m = mass.shape[0], topology.shape[0]
    _contacts_into(y, model.rest_centre, topology, geometry, laws, d_max, state)
    pushes, moment, frames = state.push, state.moment, state.frames
    rot = frames.rot
    # dloc: d(p, ea, ub, rel, arm, arm_b)/d(states of a, then b); rows: d(force on a,
    # moment on a, moment on b); dmoment: d(net moment on body k)/dy, global
    drot, dmoment, work, grad = own.drot, own.dmoment, own.local, own.grad
    rates, dloc, cols, rows = own.rates, own.dloc, own.cols, own.rows
    for k in range(nb):
        _rotation_rates(y[3 * nb + 4 * k:3 * nb + 4 * k + 4], rot[k], drot[k])
    jac[:] = 0.0
    dmoment[:] = 0.0
    for c in range(m):
        ka, kb, kind = topology[c, 0], topology[c, 1], topology[c, 2]
        if kind <= RADIAL and pushes[c] <= 0.0:
            continue  # out of touch (or pulled off by the damping): no force, no rate
        radial, spring = kind == RADIAL, kind == SPRING
        width = 13 if kb == nb else 26  # the ground's columns stay zero
        _local(frames, ka, kb, geometry, c, work)
        if kind == TWIST:
            _local_rates(y, nb, ka, kb, geometry[c], frames, drot, work, dloc, cols)
            _twist_rows(y, nb, ka, kb, laws[c], frames, drot, work, dloc, width, rows)
        elif kind == LINE:
            _line(work.p, work.ub, work.rel, laws[c], work.normal)
            _line_rates(work.p, work.ub, work.rel, laws[c], grad)
            _local_rates(y, nb, ka, kb, geometry[c], frames, drot, work, dloc, cols)
            _contact_rows(grad, dloc, work, width, rows)
        else:
            depth, push = _push(work.p, work.ea, work.ub, work.rel, radial, spring, laws[c],
                                d_max, work.normal)
            _push_rates(work.p, work.ea, work.ub, work.rel, radial, spring, laws[c], d_max,
                        depth, push, grad, rates)
            _local_rates(y, nb, ka, kb, geometry[c], frames, drot, work, dloc, cols)
            _contact_rows(grad, dloc, work, width, rows)
        for k in range(width):
            col = cols[k]
            if col < 0:
                continue
            for i in range(3):
                jac[7 * nb + 3 * ka + i, col] += rows[0, i, k] / mass[ka]
                dmoment[ka, i, col] += rows[1, i, k]
                if kb < nb:
                    jac[7 * nb + 3 * kb + i, col] -= rows[0, i, k] / mass[kb]
                    dmoment[kb, i, col] += rows[2, i, k]
    _body_rates(t, y, model.inertia, model.input_torque, model.load_torque,
                model.load_bodies, model.loads, frames.centre, rot, drot, moment, dmoment,
                jac, linked)


@kernel(inline="always")
def _contact_rows(grad, dloc, work, width, rows):
    """One contact's rates in the first ``width`` states of its bodies (``dloc``'s
    columns) into ``rows``: of its force on ``a`` (``grad`` times ``dloc``), of its
    moments on ``a`` (``arm x F``) and on ``b`` (``-(p + arm_b) x F``). ``work``: the
    contact's :class:`Local` rows, its force on ``a`` in ``normal``. Loops over whole
    rows of contiguous arrays (no views of columns), which the compiler vectorizes: ``grad`` times
    ``dloc`` row by row of ``dloc``, each sum in the order of ``k``; the zeros of
    ``dloc`` (two thirds of it) add ``+-0`` to sums that start at ``+0`` and so can
    never be ``-0``: the same sums as skipping them, without a branch per element.
    """
    dforce, dmom_a, dmom_b = rows[0], rows[1], rows[2]
    for i in range(3):
        for col in range(width):
            dforce[i, col] = 0.0
    for k in range(12):
        g0, g1, g2 = grad[0, k], grad[1, k], grad[2, k]
        for col in range(width):
            rate = dloc[k, col]
            dforce[0, col] += g0 * rate
            dforce[1, col] += g1 * rate
            dforce[2, col] += g2 * rate
    arm, f = work.arm, work.normal
    point = work.spare  # the contact point from b's centre, p + arm_b
    for i in range(3):
        point[i] = work.p[i] + work.arm_b[i]
    for i in range(3):
        a, b = (i + 1) % 3, (i + 2) % 3  # (u x v)_i = u_a v_b - u_b v_a
        for col in range(width):
            # M_a = arm x F: arm x dF - F x d(arm); M_b = -(p + arm_b) x F
            dmom_a[i, col] = ((arm[a] * dforce[b, col] - arm[b] * dforce[a, col])
                              - (f[a] * dloc[12 + b, col] - f[b] * dloc[12 + a, col]))
            dmom_b[i, col] = (-(point[a] * dforce[b, col] - point[b] * dforce[a, col])
                              + (f[a] * (dloc[b, col] + dloc[15 + b, col])
                                 - f[b] * (dloc[a, col] + dloc[15 + a, col])))


@kernel(inline="always")
def _twist_rows(y, nb, ka, kb, law, frames, drot, work, dloc, width, rows):
    """One :data:`~.penalty_contact.TWIST`'s rates in the first ``width`` states of its
    bodies into ``rows`` (as :func:`_contact_rows`): no force; its couple ``-h g`` on
    ``a`` and ``+h g`` on ``b`` (:func:`~.penalty_contact._twist`), by hand: ``dh = K
    dtheta + c (dg . omega + g . domega)``, ``dtheta`` and ``dg`` from the rates of its
    four axes (``dloc``'s rows of ``ea``, ``ub``, ``arm`` = ``R_a s`` and ``arm_b`` =
    ``R_b j``, :func:`_local_rates`), ``omega = omega_a - omega_b`` (global,
    ``R w``). ``work``: the contact's :class:`Local` (``normal`` takes ``g``, the spare
    rows ``dg`` and ``domega``).
    """
    ea, ub, sa, jb, g = work.ea, work.ub, work.arm, work.arm_b, work.normal
    dg, spin = work.spare, work.spare_b
    rot, omega = frames.rot, frames.omega
    _, h = _twist(ea, ub, sa, jb, omega, ka, kb, law, g)
    dforce, dmom_a, dmom_b = rows[0], rows[1], rows[2]
    for col in range(width):
        dtheta = 0.0
        for i in range(3):
            dtheta += 0.5 * (dloc[3 + i, col] * ub[i] + ea[i] * dloc[6 + i, col]
                             - dloc[12 + i, col] * jb[i] - sa[i] * dloc[15 + i, col])
        for i in range(3):
            j, k = (i + 1) % 3, (i + 2) % 3
            dg[i] = 0.5 * (dloc[3 + j, col] * ub[k] - dloc[3 + k, col] * ub[j]
                           + ea[j] * dloc[6 + k, col] - ea[k] * dloc[6 + j, col]
                           - dloc[12 + j, col] * jb[k] + dloc[12 + k, col] * jb[j]
                           - sa[j] * dloc[15 + k, col] + sa[k] * dloc[15 + j, col])
        body, local, sign = (ka, col, 1.0) if col < 13 else (kb, col - 13, -1.0)
        w = 10 * nb + 3 * body
        for i in range(3):
            if 3 <= local < 7:  # d(R w)/dq
                spin[i] = sign * (drot[body, local - 3, i, 0] * y[w]
                                  + drot[body, local - 3, i, 1] * y[w + 1]
                                  + drot[body, local - 3, i, 2] * y[w + 2])
            elif local >= 10:  # d(R w)/dw
                spin[i] = sign * rot[body, i, local - 10]
            else:
                spin[i] = 0.0
        drate = 0.0
        for i in range(3):
            drate += dg[i] * (omega[ka, i] - omega[kb, i]) + g[i] * spin[i]
        dh = law[1] * dtheta + law[3] * drate
        for i in range(3):
            dforce[i, col] = 0.0
            dmom_a[i, col] = -(dh * g[i] + h * dg[i])
            dmom_b[i, col] = dh * g[i] + h * dg[i]


@kernel(inline="always")
def _line_rates(p, ub, rel, law, grad):
    """``d(force on a)/d(p, ea, ub, rel)`` of a :data:`~.penalty_contact.LINE` into
    ``grad`` (3, 12), by hand from ``F = -K (p - (p.u) u) - c (rel - (rel.u) u)``:
    ``-K (I - u u^T)`` in ``p``, ``K ((p.u) I + u p^T) + c ((rel.u) I + u rel^T)`` in
    ``u``, ``-c (I - u u^T)`` in ``rel``, none in ``ea``.
    """
    stiffness, damping = law[1], law[3]
    along = p[0] * ub[0] + p[1] * ub[1] + p[2] * ub[2]
    slide = rel[0] * ub[0] + rel[1] * ub[1] + rel[2] * ub[2]
    for i in range(3):
        for j in range(3):
            eye = 1.0 if i == j else 0.0
            grad[i, j] = -stiffness * (eye - ub[i] * ub[j])
            grad[i, 3 + j] = 0.0
            grad[i, 6 + j] = (stiffness * (along * eye + ub[i] * p[j])
                              + damping * (slide * eye + ub[i] * rel[j]))
            grad[i, 9 + j] = -damping * (eye - ub[i] * ub[j])


@kernel(inline="always")
def _push_rates(p, ea, ub, rel, radial, spring, law, d_max, d, f, grad, rates):
    """``d(force on a)/d(p, ea, ub, rel)`` of one contact in touch (:func:`_push` gave
    its penetration ``d`` and push ``f > 0``; a spring's any ``d`` and ``f``) into
    ``grad`` (3, 12), by hand: the law's rates in ``d`` and ``d'`` (eqs. 75, 78; a
    spring's ``K`` and ``c``) times those of ``d`` and ``d'`` in the local
    kinematics. ``rates``: (9, 12) scratch (rows 0-2 ``dr``, 3-5 ``dn``, 6 ``dd``,
    7 ``dd'``, 8 the normal ``n``).
    """
    stiffness, exponent, c_max = law[1], law[2], law[3]
    dr, dn, dd, drate, n = rates[0:3], rates[3:6], rates[6], rates[7], rates[8]
    rates[:] = 0.0
    if radial:  # r = p - (p.ea / ub.ea) ub, n = r / |r|, d = |r| - clearance
        s = p[0] * ea[0] + p[1] * ea[1] + p[2] * ea[2]
        t = ub[0] * ea[0] + ub[1] * ea[1] + ub[2] * ea[2]
        ratio = s / t
        for i in range(3):
            n[i] = p[i] - ratio * ub[i]
        rho = np.sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2])
        for i in range(3):
            n[i] /= rho
            for j in range(3):
                dr[i, j] = (1.0 if i == j else 0.0) - ub[i] * ea[j] / t
                dr[i, 3 + j] = -ub[i] * (p[j] / t - s * ub[j] / (t * t))
                dr[i, 6 + j] = (-ratio if i == j else 0.0) + ub[i] * s * ea[j] / (t * t)
        for k in range(9):  # dn = (I - n n^T) dr / rho; dd = n^T dr
            dd[k] = n[0] * dr[0, k] + n[1] * dr[1, k] + n[2] * dr[2, k]
            for i in range(3):
                dn[i, k] = (dr[i, k] - n[i] * dd[k]) / rho
            drate[k] = rel[0] * dn[0, k] + rel[1] * dn[1, k] + rel[2] * dn[2, k]
        for i in range(3):
            drate[9 + i] = n[i]
    else:  # n = ub, d = p.ub - offset, d' = ub.rel
        for i in range(3):
            n[i] = ub[i]
            dd[i], dd[6 + i] = ub[i], p[i]
            drate[6 + i], drate[9 + i] = rel[i], ub[i]
    rate = n[0] * rel[0] + n[1] * rel[1] + n[2] * rel[2]
    x = d / d_max
    if spring or x > 1.0:
        damping, slope = c_max, 0.0
    else:
        damping, slope = c_max * x * x * (3.0 - 2.0 * x), c_max * 6.0 * x * (1.0 - x) / d_max
    if spring or exponent == 1.0:
        along_d = stiffness
    elif exponent == 1.5:
        along_d = 1.5 * stiffness * np.sqrt(d)
    else:
        along_d = exponent * stiffness * d ** (exponent - 1.0)
    along_d, along_rate = along_d + slope * rate, damping
    axis = n if radial else ea
    for k in range(12):
        df = along_d * dd[k] + along_rate * drate[k]
        for i in range(3):
            grad[i, k] = -axis[i] * df - (f * dn[i, k] if radial else 0.0)
    if not radial:
        for i in range(3):
            grad[i, 3 + i] -= f  # force = -f ea


@kernel(inline="always")
def _local_rates(y, nb, ka, kb, g, frames, drot, work, dloc, cols):
    """``d(p, ea, ub, rel, arm, arm_b)`` of one contact (:func:`_local`, its
    :class:`Local` ``work``; its spare rows scratch) with respect to the 13 states of
    ``a`` (local columns 0-12: displacement, quaternion, velocity, rate) and of ``b``
    (13-25), into ``dloc`` (18, 26); ``cols``: their state indices (-1: the ground's).
    Elements are indexed one by one, with no views of rows in the loops (each view costs
    the array's reference count twice).
    """
    rot, omega = frames.rot, frames.omega
    p, spin, turned = work.p, work.spare, work.spare_b
    dloc[:] = 0.0
    cols[:] = -1
    for side in range(2):
        k, sign, off, gp = (ka, 1.0, 0, 0) if side == 0 else (kb, -1.0, 13, 6)
        if k == nb:
            continue  # the ground does not move; its point g[gp:gp+3], axis g[gp+3:gp+6]
        for i in range(3):
            cols[off + i] = 3 * k + i
            cols[off + 7 + i] = 7 * nb + 3 * k + i
            cols[off + 10 + i] = 10 * nb + 3 * k + i
        for i in range(4):
            cols[off + 3 + i] = 3 * nb + 4 * k + i
        w = 10 * nb + 3 * k
        spin[0] = 0.0 + (y[w + 1] * g[gp + 2] - y[w + 2] * g[gp + 1])  # w x point, body
        spin[1] = 0.0 + (y[w + 2] * g[gp] - y[w] * g[gp + 2])
        spin[2] = 0.0 + (y[w] * g[gp + 1] - y[w + 1] * g[gp])
        for i in range(3):
            dloc[i, off + i] = sign  # p
            dloc[9 + i, off + 7 + i] = sign  # rel
            for kq in range(4):
                d0, d1, d2 = drot[k, kq, i, 0], drot[k, kq, i, 1], drot[k, kq, i, 2]
                at_point = d0 * g[gp] + d1 * g[gp + 1] + d2 * g[gp + 2]
                dloc[i, off + 3 + kq] = sign * at_point
                dloc[12 + 3 * side + i, off + 3 + kq] = at_point  # arm, arm_b
                dloc[3 + 3 * side + i, off + 3 + kq] = d0 * g[gp + 3] + d1 * g[gp + 4] \
                    + d2 * g[gp + 5]  # ea, ub
                dloc[9 + i, off + 3 + kq] = sign * (d0 * spin[0] + d1 * spin[1] + d2 * spin[2])
        for j in range(3):  # d(R (w x point))/dw_j = R (e_j x point)
            a, b = (j + 1) % 3, (j + 2) % 3
            for i in range(3):  # e_j x point = point[a] e_b - point[b] e_a
                dloc[9 + i, off + 10 + j] = sign * (rot[k, i, b] * g[gp + a]
                                                    - rot[k, i, a] * g[gp + b])
        if side == 1:  # rel has - (R_b w_b) x p: its rates in q_b and w_b
            for kq in range(4):  # (dR/dq) w, by hand: a 3 x 3 product through BLAS costs more
                for i in range(3):
                    turned[i] = drot[k, kq, i, 0] * y[w] + drot[k, kq, i, 1] * y[w + 1] \
                        + drot[k, kq, i, 2] * y[w + 2]
                _cross_into(p[0], p[1], p[2], turned[0], turned[1], turned[2], dloc,
                            off + 3 + kq)
            for j in range(3):
                _cross_into(p[0], p[1], p[2], rot[k, 0, j], rot[k, 1, j], rot[k, 2, j], dloc,
                            off + 10 + j)
    if kb < nb:  # and - omega_b x dp
        o0, o1, o2 = omega[kb, 0], omega[kb, 1], omega[kb, 2]
        for col in range(26):
            dloc[9, col] += -(o1 * dloc[2, col] - o2 * dloc[1, col])
            dloc[10, col] += -(o2 * dloc[0, col] - o0 * dloc[2, col])
            dloc[11, col] += -(o0 * dloc[1, col] - o1 * dloc[0, col])


@kernel(inline="always")
def _cross_into(a0, a1, a2, b0, b1, b2, dloc, col):
    """``dloc[9:12, col] += a x b`` (the relative velocity's rows), element by element."""
    dloc[9, col] += a1 * b2 - a2 * b1
    dloc[10, col] += a2 * b0 - a0 * b2
    dloc[11, col] += a0 * b1 - a1 * b0


@kernel(inline="always")
def _body_rates(t, y, inertias, input_torque, load_torque, load_bodies, loads, centre, rot,
                drot, moment, dmoment, jac, linked):
    """The rows of ``x' = v``, ``q' = q (0, w) / 2`` and ``w' = J^-1 (R^T M - w x J w)``
    (with the line's torques and their rates added to ``dmoment``: a pure torque's
    through the body's rotation, a mesh force's moment ``(p - centre) x F`` through its
    centre); ``moment``: the net contact moments; ``dmoment`` is zero outside the
    columns of the ``linked`` bodies (:func:`_linked`); the model's arrays as
    :class:`~.penalty_contact.ModelArrays` names them.
    """
    nb = inertias.shape[0]
    total = moment[:nb].copy()
    for e in range(2):  # the input end, then the load end (as penalty_contact._bodies)
        k = load_bodies[e]
        h = harmonic(input_torque, t) if e == 0 else harmonic(load_torque, t)
        spin = h * loads[e, 0]
        for i in range(3):
            a, b = (i + 1) % 3, (i + 2) % 3
            fa = h * loads[e, 4 + a] + abs(h) * loads[e, 7 + a]
            fb = h * loads[e, 4 + b] + abs(h) * loads[e, 7 + b]
            total[k, i] += (spin * rot[k, i, 1] + (loads[e, 1 + a] - centre[k, a]) * fb
                            - (loads[e, 1 + b] - centre[k, b]) * fa)
            dmoment[k, i, 3 * k + a] -= fb
            dmoment[k, i, 3 * k + b] += fa
            for kq in range(4):
                dmoment[k, i, 3 * nb + 4 * k + kq] += spin * drot[k, kq, i, 1]
    for k in range(nb):
        u, q, v, w = 3 * k, 3 * nb + 4 * k, 7 * nb + 3 * k, 10 * nb + 3 * k
        inertia = inertias[k]
        wk, qk = y[w:w + 3], y[q:q + 4]
        for i in range(3):
            jac[u + i, v + i] = 1.0
            a, b = (i + 1) % 3, (i + 2) % 3
            for j in range(nb):  # R^T dM
                if not linked[k, j]:
                    continue
                for first, size in ((3 * j, 3), (3 * nb + 4 * j, 4), (7 * nb + 3 * j, 3),
                                    (10 * nb + 3 * j, 3)):
                    for col in range(first, first + size):
                        jac[w + i, col] += (rot[k, 0, i] * dmoment[k, 0, col]
                                            + rot[k, 1, i] * dmoment[k, 1, col]
                                            + rot[k, 2, i] * dmoment[k, 2, col]) / inertia[i]
            for kq in range(4):  # (dR/dq)^T M on the body's own quaternion
                jac[w + i, q + kq] += (drot[k, kq, 0, i] * total[k, 0]
                                       + drot[k, kq, 1, i] * total[k, 1]
                                       + drot[k, kq, 2, i] * total[k, 2]) / inertia[i]
            # -(w x J w)_i = -(w_a J_b w_b - w_b J_a w_a): its rates in w_a and w_b
            jac[w + i, w + a] -= (inertia[b] - inertia[a]) * wk[b] / inertia[i]
            jac[w + i, w + b] -= (inertia[b] - inertia[a]) * wk[a] / inertia[i]
        # q' = q (0, w) / 2: scalar part -v.w / 2, vector part (s w + v x w) / 2
        for j in range(3):
            jac[q, q + 1 + j] = -0.5 * wk[j]
            jac[q, w + j] = -0.5 * qk[1 + j]
            jac[q + 1 + j, q] = 0.5 * wk[j]
            jac[q + 1 + j, w + j] += 0.5 * qk[0]
            a, b = (j + 1) % 3, (j + 2) % 3  # (v x w)_j = v_a w_b - v_b w_a
            jac[q + 1 + j, q + 1 + a] += 0.5 * wk[b]
            jac[q + 1 + j, q + 1 + b] -= 0.5 * wk[a]
            jac[q + 1 + j, w + b] += 0.5 * qk[1 + a]
            jac[q + 1 + j, w + a] -= 0.5 * qk[1 + b]
