"""Compiled right-hand side and Jacobian of the penalty-contact simulation.

The same Newton-Euler equations and contact law (paper eqs. 75-78) as the NumPy model
of :mod:`cardan_forces.driveline.penalty`, written as loops over bodies and contacts
and compiled by numba: one state costs a few thousand flops, so a right-hand side takes
microseconds instead of the ~0.2 ms that array calls on 5 bodies and 28 contacts cost
in the interpreter.

**Jacobian by complex step.** Every operation here is analytic in the state except the
contact's on/off switches, which test the real part only; so ``f(y + i h e_k)`` has
imaginary part ``h df/dy_k`` to round-off, without the cancellation of a finite
difference. Columns of bodies that share no contact neighbour are stepped together
(the colouring of the contact graph), so a Jacobian costs one complex right-hand side
per colour group (3 for a chain), and is exact where a forward difference loses half
the digits.

Without numba the functions below still run (as plain Python, slowly); the simulation
then uses the NumPy model instead (:data:`HAVE_NUMBA`).
"""

from __future__ import annotations

import numpy as np

from .compiled import HAVE_NUMBA, harmonic, njit

__all__ = ["HAVE_NUMBA", "contact_forces", "jacobian", "rhs"]

COMPLEX_STEP = 1e-30
"""Imaginary step per unit of a state's tolerance scale; far below round-off, so the
derivative is exact to the precision of the right-hand side."""


@njit(cache=True)
def _rotation(q, out):
    """Rotation matrix (body to global) of a quaternion (w, x, y, z) of any norm."""
    w, x, y, z = q[0], q[1], q[2], q[3]
    n = w * w + x * x + y * y + z * z
    out[0, 0] = (w * w + x * x - y * y - z * z) / n
    out[1, 1] = (w * w - x * x + y * y - z * z) / n
    out[2, 2] = (w * w - x * x - y * y + z * z) / n
    out[0, 1] = 2.0 * (x * y - w * z) / n
    out[1, 0] = 2.0 * (x * y + w * z) / n
    out[0, 2] = 2.0 * (x * z + w * y) / n
    out[2, 0] = 2.0 * (x * z - w * y) / n
    out[1, 2] = 2.0 * (y * z - w * x) / n
    out[2, 1] = 2.0 * (y * z + w * x) / n


@njit(cache=True)
def _cross_add(a, b, scale, out):
    """``out += scale * (a x b)`` for 3-vectors."""
    out[0] += scale * (a[1] * b[2] - a[2] * b[1])
    out[1] += scale * (a[2] * b[0] - a[0] * b[2])
    out[2] += scale * (a[0] * b[1] - a[1] * b[0])


@njit(cache=True)
def _law(d, rate, stiffness, exponent, c_max, d_max):
    """Paper eqs. 75 and 78 for one contact (N); on/off by the real parts only."""
    if d.real <= 0.0:
        return 0.0 * d
    x = d / d_max
    if x.real > 1.0:
        x = 1.0 + 0.0 * d
    if exponent == 1.0:
        power = d
    elif exponent == 1.5:  # the paper's Hertz exponent: a square root, not a power
        power = d * np.sqrt(d)
    else:
        power = d**exponent
    f = stiffness * power + c_max * x * x * (3.0 - 2.0 * x) * rate
    return f if f.real > 0.0 else 0.0 * f


@njit(cache=True)
def _frames(y, rest_centre, which, centre, vel, rot, rate, omega):
    """Into the arrays (row ``nb``: the ground, left as it is), for the bodies ``k``
    with ``which[k]``: centre, velocity, rotation, its rate ``R [w]x`` and the global
    angular velocity ``R w``, from the state ``y`` (layout of :class:`penalty._Model`).
    """
    nb = rest_centre.shape[0]
    for k in range(nb):
        if not which[k]:
            continue
        _rotation(y[3 * nb + 4 * k:3 * nb + 4 * k + 4], rot[k])
        w = y[10 * nb + 3 * k:10 * nb + 3 * k + 3]
        for i in range(3):
            centre[k, i] = rest_centre[k, i] + y[3 * k + i]
            vel[k, i] = y[7 * nb + 3 * k + i]
            rate[k, i] = 0.0
            _cross_add(rot[k, i], w, 1.0, rate[k, i])
            omega[k, i] = rot[k, i, 0] * w[0] + rot[k, i, 1] * w[1] + rot[k, i, 2] * w[2]


@njit(cache=True)
def _new_frames(y, nb):
    """Zeroed frame arrays for ``nb`` bodies and the ground (rotation: identity)."""
    rot = np.zeros((nb + 1, 3, 3), dtype=y.dtype)
    for i in range(3):
        rot[nb, i, i] = 1.0
    return (np.zeros((nb + 1, 3), dtype=y.dtype), np.zeros((nb + 1, 3), dtype=y.dtype), rot,
            np.zeros((nb + 1, 3, 3), dtype=y.dtype), np.zeros((nb + 1, 3), dtype=y.dtype))


@njit(cache=True)
def _contacts(frames, topology, geometry, laws, d_max, use, depth, push, on_a, force, moment,
              work):
    """Add every contact with ``use[c]`` to the bodies' net ``force`` and ``moment``
    (global, about their centres) and write its penetration, push and force on ``a``.
    The geometry of :meth:`penalty._Model.contacts`, one contact at a time; ``work``:
    a (7, 3) scratch array.
    """
    centre, vel, rot, rate, omega = frames
    p, ea, ub, rel, arm, arm_b, n = work[0], work[1], work[2], work[3], work[4], work[5], work[6]
    for c in range(topology.shape[0]):
        if not use[c]:
            continue
        ka, kb, radial = topology[c, 0], topology[c, 1], topology[c, 2] == 1
        s, e, j, u = geometry[c, 0:3], geometry[c, 3:6], geometry[c, 6:9], geometry[c, 9:12]
        for i in range(3):
            arm[i] = rot[ka, i, 0] * s[0] + rot[ka, i, 1] * s[1] + rot[ka, i, 2] * s[2]
            arm_b[i] = rot[kb, i, 0] * j[0] + rot[kb, i, 1] * j[1] + rot[kb, i, 2] * j[2]
            ea[i] = rot[ka, i, 0] * e[0] + rot[ka, i, 1] * e[1] + rot[ka, i, 2] * e[2]
            ub[i] = rot[kb, i, 0] * u[0] + rot[kb, i, 1] * u[1] + rot[kb, i, 2] * u[2]
            p[i] = centre[ka, i] + arm[i] - centre[kb, i] - arm_b[i]
            rel[i] = (vel[ka, i] - vel[kb, i]
                      + rate[ka, i, 0] * s[0] + rate[ka, i, 1] * s[1] + rate[ka, i, 2] * s[2]
                      - rate[kb, i, 0] * j[0] - rate[kb, i, 1] * j[1] - rate[kb, i, 2] * j[2])
        _cross_add(omega[kb], p, -1.0, rel)
        if radial:
            # the bore axis meets the trunnion's cross-section plane at p - r
            ratio = (p[0] * ea[0] + p[1] * ea[1] + p[2] * ea[2]) / (
                ub[0] * ea[0] + ub[1] * ea[1] + ub[2] * ea[2])
            for i in range(3):
                n[i] = p[i] - ratio * ub[i]
            rho = np.sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2])
            if rho.real < 1e-300:
                rho = 1e-300 + 0.0 * rho
            for i in range(3):
                n[i] = n[i] / rho
            d = rho - laws[c, 0]
        else:
            for i in range(3):
                n[i] = ub[i]
            d = p[0] * ub[0] + p[1] * ub[1] + p[2] * ub[2] - laws[c, 0]
        f = _law(d, n[0] * rel[0] + n[1] * rel[1] + n[2] * rel[2], laws[c, 1], laws[c, 2],
                 laws[c, 3], d_max)
        depth[c], push[c] = d, f
        for i in range(3):
            on_a[c, i] = -f * (n[i] if radial else ea[i])
            force[ka, i] += on_a[c, i]
            force[kb, i] -= on_a[c, i]
            p[i] += arm_b[i]  # the contact point from b's centre
        _cross_add(arm, on_a[c], 1.0, moment[ka])
        _cross_add(p, on_a[c], -1.0, moment[kb])


@njit(cache=True)
def contact_forces(y, bodies, topology, geometry, laws, d_max):
    """Per contact: penetration ``d`` (m), push ``f >= 0`` (N), the force on body ``a``
    (global, N); per body the net contact force and moment about its centre (global);
    the frames (:func:`_frames`).

    ``bodies`` (nb, 7): mass, principal inertias, rest centre. ``topology`` (m, 3): body
    ``a``, body ``b`` (the ground: nb), radial (1) or face (0). ``geometry`` (m, 12):
    ``s``, ``e`` (on ``a``), ``j``, ``u`` (on ``b``), body coordinates. ``laws`` (m, 4):
    offset (clearance), stiffness, exponent, ``c_max``.
    """
    nb, m = bodies.shape[0], topology.shape[0]
    frames = _new_frames(y, nb)
    _frames(y, bodies[:, 4:], np.ones(nb, dtype=np.bool_), *frames)
    depth, push = np.zeros(m, dtype=y.dtype), np.zeros(m, dtype=y.dtype)
    on_a = np.zeros((m, 3), dtype=y.dtype)
    force = np.zeros((nb + 1, 3), dtype=y.dtype)
    moment = np.zeros((nb + 1, 3), dtype=y.dtype)
    _contacts(frames, topology, geometry, laws, d_max, np.ones(m, dtype=np.bool_), depth, push,
              on_a, force, moment, np.zeros((7, 3), dtype=y.dtype))
    return depth, push, on_a, force, moment, frames


@njit(cache=True)
def _bodies(t, y, rot, force, moment, n_shafts, bodies, loads, dy, work):
    """Newton-Euler equations of every body into ``dy``, given the net contact force and
    moment; the torques added here (``moment`` is changed); ``work``: (2, 3) scratch.
    """
    nb = bodies.shape[0]
    torque_in, torque_load = harmonic(loads[3:7], t), harmonic(loads[7:11], t)
    for i in range(3):  # a shaft's axis is its body frame's second column
        moment[0, i] += torque_in * rot[0, i, 1]
        moment[n_shafts - 1, i] -= torque_load * rot[n_shafts - 1, i, 1]
    jw, dw = work[0], work[1]
    for k in range(nb):
        q = y[3 * nb + 4 * k:3 * nb + 4 * k + 4]
        w = y[10 * nb + 3 * k:10 * nb + 3 * k + 3]
        for i in range(3):
            dy[3 * k + i] = y[7 * nb + 3 * k + i]
            dy[7 * nb + 3 * k + i] = force[k, i] / bodies[k, 0] + loads[i]
            jw[i] = bodies[k, 1 + i] * w[i]
            dw[i] = rot[k, 0, i] * moment[k, 0] + rot[k, 1, i] * moment[k, 1] \
                + rot[k, 2, i] * moment[k, 2]
        _cross_add(w, jw, -1.0, dw)
        for i in range(3):
            dy[10 * nb + 3 * k + i] = dw[i] / bodies[k, 1 + i]
        dy[3 * nb + 4 * k] = -0.5 * (q[1] * w[0] + q[2] * w[1] + q[3] * w[2])
        for i in range(3):
            dy[3 * nb + 4 * k + 1 + i] = 0.5 * q[0] * w[i]
        _cross_add(q[1:], w, 0.5, dy[3 * nb + 4 * k + 1:3 * nb + 4 * k + 4])


@njit(cache=True)
def rhs(t, y, n_shafts, bodies, topology, geometry, laws, loads):
    """Newton-Euler equations of every body at time ``t`` (s), state ``y``:
    ``x' = v``, ``q' = q (0, w) / 2``, ``m v' = F + m g``, ``J w' + w x J w = R^T M``
    (body axes). ``loads``: gravity (3), the input torque law (4: mean, amplitude,
    frequency, phase) about the first shaft's axis, the load torque law (4) against the
    last shaft's, ``d_max``.
    """
    _, _, _, force, moment, frames = contact_forces(y, bodies, topology, geometry, laws,
                                                    loads[11])
    dy = np.empty_like(y)
    _bodies(t, y, frames[2], force, moment, n_shafts, bodies, loads, dy,
            np.zeros((2, 3), dtype=y.dtype))
    return dy


@njit(cache=True)
def jacobian(t, y, step, column, sparsity, n_shafts, bodies, topology, geometry, laws, loads):
    """``df/dy`` by complex steps (``step``: imaginary step per state); state ``k`` is
    stepped in the call ``column[k]`` (states of bodies far apart share a call);
    ``sparsity[row, k]`` says which rows state ``k`` moves.

    A call recomputes only what a step changes: the stepped bodies' frames and the
    contacts in touch on them (a contact out of touch stays so under an infinitesimal
    step); the other contacts' forces are real, so they add only to the real part.
    """
    n, nb, m = y.shape[0], bodies.shape[0], topology.shape[0]
    depth, _, _, force, moment, real = contact_forces(y, bodies, topology, geometry, laws,
                                                      loads[11])
    frames = _new_frames(y.astype(np.complex128), nb)
    stepped = np.ones(nb, dtype=np.bool_)
    _restore(real, frames, stepped)
    scratch = (np.zeros(m, dtype=np.complex128), np.zeros(m, dtype=np.complex128),
               np.zeros((m, 3), dtype=np.complex128))
    jac = np.zeros((n, n))
    use = np.zeros(m, dtype=np.bool_)
    yc, dy = y.astype(np.complex128), np.zeros(n, dtype=np.complex128)
    df, dm = np.zeros((nb + 1, 3), dtype=np.complex128), np.zeros((nb + 1, 3), dtype=np.complex128)
    total_f, total_m = np.zeros_like(df), np.zeros_like(dm)
    work, body_work = np.zeros((7, 3), dtype=np.complex128), np.zeros((2, 3), dtype=np.complex128)
    for g in range(column.max() + 1):
        stepped[:] = False
        for k in range(n):
            yc[k] = y[k] + (1j * step[k] if column[k] == g else 0.0)
            if column[k] == g:
                stepped[_body_of(k, nb)] = True
        for c in range(m):
            ka, kb = topology[c, 0], topology[c, 1]
            use[c] = depth[c] > 0.0 and (stepped[ka] or (kb < nb and stepped[kb]))
        _frames(yc, bodies[:, 4:], stepped, *frames)
        df[:], dm[:] = 0.0, 0.0
        _contacts(frames, topology, geometry, laws, loads[11], use, *scratch, df, dm, work)
        for b in range(nb + 1):
            for i in range(3):
                total_f[b, i] = force[b, i] + 1j * df[b, i].imag
                total_m[b, i] = moment[b, i] + 1j * dm[b, i].imag
        _bodies(t, yc, frames[2], total_f, total_m, n_shafts, bodies, loads, dy, body_work)
        for k in range(n):
            if column[k] == g:
                for row in range(n):
                    if sparsity[row, k]:
                        jac[row, k] = dy[row].imag / step[k]
        _restore(real, frames, stepped)
    return jac


@njit(cache=True)
def _restore(real, frames, which):
    """Copy the bodies ``k`` with ``which[k]`` from the frames ``real`` into ``frames``."""
    for k in range(which.shape[0]):
        if which[k]:
            frames[0][k], frames[1][k], frames[4][k] = real[0][k], real[1][k], real[4][k]
            frames[2][k], frames[3][k] = real[2][k], real[3][k]


@njit(cache=True)
def _body_of(k, nb):
    """The body of state ``k`` (3 displacement, 4 quaternion, 3 velocity, 3 rate each)."""
    if k < 3 * nb:
        return k // 3
    if k < 7 * nb:
        return (k - 3 * nb) // 4
    if k < 10 * nb:
        return (k - 7 * nb) // 3
    return (k - 10 * nb) // 3
