"""Compiled right-hand side and Jacobian of the penalty-contact simulation.

The same Newton-Euler equations and contact law (paper eqs. 75-78) as the NumPy model
of :mod:`cardan_forces.driveline.penalty`, written as loops over bodies and contacts
and compiled by numba: one state costs a few thousand flops, so a right-hand side takes
microseconds instead of the ~0.2 ms that array calls on 5 bodies and 28 contacts cost
in the interpreter.

**Jacobian by the chain rule.** Per contact in touch, the force law's derivative with
respect to the contact's local kinematics (offset, axes, relative velocity), by hand
(:func:`_push_rates`: the law's rates in ``d`` and ``d'`` times theirs in the
kinematics); times the derivatives of those kinematics with respect to the 13 states
of each of the contact's two bodies, by hand; then the Newton-Euler equations
differentiated by hand. Exact where a forward difference loses half the digits (the
tests hold it to the NumPy model's complex-step Jacobian).

**Integrator.** At the end, SciPy's variable-order BDF written as numba loops
(:func:`start`, :func:`advance`): the whole integration runs compiled, the kernels
called with no Python in between (why, and how it differs from SciPy's, above
:data:`MAX_ORDER`).

**Inlined calls.** A compiled call takes and drops a reference to every array it is
handed, one atomic count each way, and the integrator hands its scratch down as
tuples of dozens of arrays: a few hundred counts a step, about as dear as the
arithmetic of a Newton iteration. So the kernels the step calls many times
(right-hand side, Newton iteration and solve, the Jacobian's and the factorization's
parts, the step itself) are inlined (``inline="always"``), leaving as calls only
:func:`_factor` and :func:`_jacobian_into`, made less than once a step: a right-hand
side 1.3, a Newton solve 1.4, a Jacobian 1.2 times cheaper, the same numbers to the
bit. Compiling takes longer (about 90 s of CPU instead of 40, once).

**Numbers, not exceptions.** Compiled with NumPy's error model (:mod:`.compiled`): a
division by zero gives an infinity or a NaN, and the integrator ends with a failed
status and its reason, as SciPy's does; it never raises from compiled code.

Without numba the functions below still run (as plain Python, slowly); the simulation
then uses the NumPy model and SciPy's integrators instead (:data:`HAVE_NUMBA`).

**Why one module this long.** numba's on-disk cache checks only the source file of the
function it compiled: with the kernels in another file, an edit there would leave the
cached integrator calling the old kernels. So the integrator sits beside them.
"""

from __future__ import annotations

import numpy as np

from .compiled import HAVE_NUMBA, harmonic, njit

__all__ = ["HAVE_NUMBA", "advance", "contact_forces", "jacobian", "rhs", "start"]

COMPLEX_STEP = 1e-30
"""Imaginary step (per unit of a quantity's scale) of the NumPy model's Jacobian; far
below round-off, so the derivative is exact to the precision of the function."""


@njit(cache=True, inline="always")
def _rotation(state, at, out):
    """Rotation matrix (body to global) of the quaternion (w, x, y, z), of any norm, at
    ``state[at:at + 4]``, into the (3, 3) ``out``.
    """
    w, x, y, z = state[at], state[at + 1], state[at + 2], state[at + 3]
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


@njit(cache=True, inline="always")
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


@njit(cache=True, inline="always")
def _frames(y, rest_centre, centre, vel, rot, rate, omega):
    """Into the arrays (row ``nb``: the ground, left as it is), per body: centre,
    velocity, rotation, its rate ``R [w]x`` and the global angular velocity ``R w``,
    from the state ``y`` (layout of :class:`penalty._Model`).
    """
    nb = rest_centre.shape[0]
    for k in range(nb):  # element by element: no views of rows in the loop
        _rotation(y, 3 * nb + 4 * k, rot[k])
        w = 10 * nb + 3 * k
        w0, w1, w2 = y[w], y[w + 1], y[w + 2]
        for i in range(3):
            centre[k, i] = rest_centre[k, i] + y[3 * k + i]
            vel[k, i] = y[7 * nb + 3 * k + i]
            r0, r1, r2 = rot[k, i, 0], rot[k, i, 1], rot[k, i, 2]
            rate[k, i, 0] = 0.0 + 1.0 * (r1 * w2 - r2 * w1)  # row i of R [w]x
            rate[k, i, 1] = 0.0 + 1.0 * (r2 * w0 - r0 * w2)
            rate[k, i, 2] = 0.0 + 1.0 * (r0 * w1 - r1 * w0)
            omega[k, i] = r0 * w0 + r1 * w1 + r2 * w2


@njit(cache=True)
def _new_frames(y, nb):
    """Zeroed frame arrays for ``nb`` bodies and the ground (rotation: identity)."""
    vectors = np.zeros((3, nb + 1, 3), dtype=y.dtype)  # one allocation each: the
    matrices = np.zeros((2, nb + 1, 3, 3), dtype=y.dtype)  # right-hand side is ~3 us
    rot = matrices[0]
    for i in range(3):
        rot[nb, i, i] = 1.0
    return vectors[0], vectors[1], rot, matrices[1], vectors[2]


@njit(cache=True, inline="always")
def _local(frames, ka, kb, geometry, c, work):
    """Into ``work`` rows 0-5, for contact ``c`` between bodies ``ka`` and ``kb`` with
    geometry row ``geometry[c]`` (``s, e, j, u``): the offset ``p`` of a's point from
    b's, the axes ``ea`` (on a) and ``ub`` (on b), the relative velocity ``rel`` of a's
    material point at ``p`` against b's, and the arms of the points from a's and b's
    centres. Element by element, no views of rows: in the right-hand side's loop over
    contacts each view costs its array's reference count twice.
    """
    _offset(frames, ka, kb, geometry, c, work)
    _relative(frames, ka, kb, geometry, c, work)


@njit(cache=True, inline="always")
def _offset(frames, ka, kb, geometry, c, work):
    """:func:`_local`'s geometry: ``p``, ``ea``, ``ub`` and the arms (not ``rel``)."""
    centre, rot = frames[0], frames[2]
    for i in range(3):  # rows: 0 p, 1 ea, 2 ub, 4 arm, 5 arm_b (kept in registers)
        a0, a1, a2 = rot[ka, i, 0], rot[ka, i, 1], rot[ka, i, 2]
        b0, b1, b2 = rot[kb, i, 0], rot[kb, i, 1], rot[kb, i, 2]
        arm = a0 * geometry[c, 0] + a1 * geometry[c, 1] + a2 * geometry[c, 2]
        arm_b = b0 * geometry[c, 6] + b1 * geometry[c, 7] + b2 * geometry[c, 8]
        work[1, i] = a0 * geometry[c, 3] + a1 * geometry[c, 4] + a2 * geometry[c, 5]
        work[2, i] = b0 * geometry[c, 9] + b1 * geometry[c, 10] + b2 * geometry[c, 11]
        work[4, i], work[5, i] = arm, arm_b
        work[0, i] = centre[ka, i] + arm - centre[kb, i] - arm_b


@njit(cache=True, inline="always")
def _relative(frames, ka, kb, geometry, c, work):
    """:func:`_local`'s relative velocity ``rel`` (row 3), after :func:`_offset`."""
    vel, rate, omega = frames[1], frames[3], frames[4]
    for i in range(3):
        work[3, i] = (vel[ka, i] - vel[kb, i]
                      + rate[ka, i, 0] * geometry[c, 0] + rate[ka, i, 1] * geometry[c, 1]
                      + rate[ka, i, 2] * geometry[c, 2]
                      - rate[kb, i, 0] * geometry[c, 6] - rate[kb, i, 1] * geometry[c, 7]
                      - rate[kb, i, 2] * geometry[c, 8])
    # - omega_b x p
    work[3, 0] += -1.0 * (omega[kb, 1] * work[0, 2] - omega[kb, 2] * work[0, 1])
    work[3, 1] += -1.0 * (omega[kb, 2] * work[0, 0] - omega[kb, 0] * work[0, 2])
    work[3, 2] += -1.0 * (omega[kb, 0] * work[0, 1] - omega[kb, 1] * work[0, 0])


@njit(cache=True, inline="always")
def _depth(p, ea, ub, radial, clearance, normal):
    """Penetration ``d`` of one contact, its normal into ``normal``: radial contacts
    along the offset of the bore axis from the trunnion point in the trunnion's
    cross-section, faces along ``ub``.
    """
    if radial:
        # the bore axis meets the trunnion's cross-section plane at p - r
        ratio = (p[0] * ea[0] + p[1] * ea[1] + p[2] * ea[2]) / (
            ub[0] * ea[0] + ub[1] * ea[1] + ub[2] * ea[2])
        for i in range(3):
            normal[i] = p[i] - ratio * ub[i]
        rho = np.sqrt(normal[0] * normal[0] + normal[1] * normal[1] + normal[2] * normal[2])
        if rho.real < 1e-300:
            rho = 1e-300 + 0.0 * rho
        for i in range(3):
            normal[i] = normal[i] / rho
        return rho - clearance
    for i in range(3):
        normal[i] = ub[i]
    return p[0] * ub[0] + p[1] * ub[1] + p[2] * ub[2] - clearance


@njit(cache=True, inline="always")
def _push(p, ea, ub, rel, radial, law, d_max, force):
    """Penetration ``d`` and push ``f`` of one contact (eqs. 75-78), and its force on
    body ``a`` into ``force``: radial contacts along their normal (:func:`_depth`),
    faces along ``-ea``.
    """
    d = _depth(p, ea, ub, radial, law[0], force)  # the normal, for now
    return d, _pressed(d, ea, rel, radial, law, d_max, force)


@njit(cache=True, inline="always")
def _pressed(d, ea, rel, radial, law, d_max, force):
    """:func:`_push` of a contact whose penetration ``d`` and normal (in ``force``,
    :func:`_depth`'s) are known: its push ``f``, and its force on ``a`` into ``force``.
    """
    f = _law(d, force[0] * rel[0] + force[1] * rel[1] + force[2] * rel[2], law[1], law[2],
             law[3], d_max)
    for i in range(3):
        force[i] = -f * (force[i] if radial else ea[i])
    return f


@njit(cache=True, inline="always")
def _contacts(frames, topology, geometry, laws, d_max, depth, push, on_a, force, moment, work):
    """Add every contact to the bodies' net ``force`` and ``moment``
    (global, about their centres) and write its penetration, push and force on ``a``.
    The geometry of :meth:`penalty._Model.contacts`, one contact at a time, the relative
    velocity and the law only for those that touch; ``work``: a (7, 3) scratch array,
    its rows' views taken once (:func:`_local`).
    """
    p, ea, ub, rel, arm, arm_b, normal = work[0], work[1], work[2], work[3], work[4], \
        work[5], work[6]
    for c in range(topology.shape[0]):
        ka, kb, radial = topology[c, 0], topology[c, 1], topology[c, 2] == 1
        _offset(frames, ka, kb, geometry, c, work)
        depth[c] = _depth(p, ea, ub, radial, laws[c, 0], normal)
        if depth[c].real <= 0.0:  # out of touch: no force (eq. 75)
            push[c] = 0.0
            for i in range(3):
                on_a[c, i] = 0.0
            continue
        _relative(frames, ka, kb, geometry, c, work)
        push[c] = _pressed(depth[c], ea, rel, radial, laws[c], d_max, normal)
        for i in range(3):
            on_a[c, i] = normal[i]  # now the force on a
            force[ka, i] += normal[i]
            force[kb, i] -= normal[i]
            p[i] += arm_b[i]  # the contact point from b's centre
        for i in range(3):  # moment on a: arm x F; on b: -(p + arm_b) x F
            j, k = (i + 1) % 3, (i + 2) % 3
            moment[ka, i] += 1.0 * (arm[j] * normal[k] - arm[k] * normal[j])
            moment[kb, i] += -1.0 * (p[j] * normal[k] - p[k] * normal[j])


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
    scratch = _scratch(y, bodies.shape[0], topology.shape[0])
    _contacts_into(y, bodies, topology, geometry, laws, d_max, scratch)
    pushes, loads, on_a, frames = scratch[0], scratch[1], scratch[2], scratch[4]
    return pushes[0], pushes[1], on_a, loads[0], loads[1], frames


@njit(cache=True)
def _scratch(y, nb, m):
    """The arrays one evaluation of the contacts fills (of ``y``'s type): pushes (2, m:
    penetration, push), loads (2, nb + 1, 3: net force, moment), forces on ``a`` (m, 3),
    a (9, 3) scratch (rows 0-6 :func:`_contacts`', 7-8 :func:`_bodies`'), the frames
    (:func:`_new_frames`). Made once per run by the integrator: its right-hand sides
    then allocate nothing.
    """
    return (np.zeros((2, m), dtype=y.dtype), np.zeros((2, nb + 1, 3), dtype=y.dtype),
            np.zeros((m, 3), dtype=y.dtype), np.zeros((9, 3), dtype=y.dtype),
            _new_frames(y, nb))


@njit(cache=True, inline="always")
def _contacts_into(y, bodies, topology, geometry, laws, d_max, scratch):
    """:func:`contact_forces` into ``scratch`` (:func:`_scratch`)."""
    pushes, loads, on_a, work, frames = scratch
    loads[:] = 0.0
    _frames(y, bodies[:, 4:], frames[0], frames[1], frames[2], frames[3], frames[4])
    _contacts(frames, topology, geometry, laws, d_max, pushes[0], pushes[1], on_a, loads[0],
              loads[1], work)


@njit(cache=True, inline="always")
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
    for k in range(nb):  # element by element: no views of rows in the loop
        q, w = 3 * nb + 4 * k, 10 * nb + 3 * k
        w0, w1, w2 = y[w], y[w + 1], y[w + 2]
        for i in range(3):
            dy[3 * k + i] = y[7 * nb + 3 * k + i]
            dy[7 * nb + 3 * k + i] = force[k, i] / bodies[k, 0] + loads[i]
            jw[i] = bodies[k, 1 + i] * y[w + i]
            dw[i] = rot[k, 0, i] * moment[k, 0] + rot[k, 1, i] * moment[k, 1] \
                + rot[k, 2, i] * moment[k, 2]
        dw[0] += -1.0 * (w1 * jw[2] - w2 * jw[1])  # - w x J w
        dw[1] += -1.0 * (w2 * jw[0] - w0 * jw[2])
        dw[2] += -1.0 * (w0 * jw[1] - w1 * jw[0])
        for i in range(3):
            dy[w + i] = dw[i] / bodies[k, 1 + i]
        q0, q1, q2, q3 = y[q], y[q + 1], y[q + 2], y[q + 3]
        dy[q] = -0.5 * (q1 * w0 + q2 * w1 + q3 * w2)
        for i in range(3):
            dy[q + 1 + i] = 0.5 * q0 * y[w + i]
        dy[q + 1] += 0.5 * (q2 * w2 - q3 * w1)  # + (q_v x w) / 2
        dy[q + 2] += 0.5 * (q3 * w0 - q1 * w2)
        dy[q + 3] += 0.5 * (q1 * w1 - q2 * w0)


@njit(cache=True)
def rhs(t, y, n_shafts, bodies, topology, geometry, laws, loads):
    """Newton-Euler equations of every body at time ``t`` (s), state ``y``:
    ``x' = v``, ``q' = q (0, w) / 2``, ``m v' = F + m g``, ``J w' + w x J w = R^T M``
    (body axes). ``loads``: gravity (3), the input torque law (4: mean, amplitude,
    frequency, phase) about the first shaft's axis, the load torque law (4) against the
    last shaft's, ``d_max``.
    """
    dy = np.empty_like(y)
    _rhs_into(t, y, (n_shafts, bodies, topology, geometry, laws, loads),
              _scratch(y, bodies.shape[0], topology.shape[0]), dy)
    return dy


@njit(cache=True, inline="always")
def _rhs_into(t, y, args, scratch, dy):
    """:func:`rhs` into ``dy``, with ``args`` its model arguments and the scratch
    arrays of :func:`_scratch`.
    """
    n_shafts, bodies, loads = args[0], args[1], args[5]
    _contacts_into(y, bodies, args[2], args[3], args[4], loads[11], scratch)
    load = scratch[1]
    _bodies(t, y, scratch[4][2], load[0], load[1], n_shafts, bodies, loads, dy,
            scratch[3][7:9])


@njit(cache=True, inline="always")
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


@njit(cache=True)
def jacobian(t, y, n_shafts, bodies, topology, geometry, laws, loads):
    """``df/dy`` (exact to round-off) by the chain rule: per contact in touch, the
    derivative of its force on ``a`` with respect to its local kinematics (``p, ea, ub,
    rel``: :func:`_push_rates`), times their derivatives with respect to
    the 13 states of each of its two bodies (:func:`_local_rates`, :func:`_contact_rows`);
    then the bodies' Newton-Euler equations differentiated by hand (:func:`_body_rates`).
    Arguments as :func:`rhs`. A contact out of touch (no push in the contacts'
    evaluation) is skipped before its kinematics; one on the ground has only ``a``'s 13
    columns.
    """
    n, nb = y.shape[0], bodies.shape[0]
    jac = np.empty((n, n))
    _jacobian_into(t, y, (n_shafts, bodies, topology, geometry, laws, loads), jac,
                   _linked(nb, topology), _scratch(y, nb, topology.shape[0]),
                   _jacobian_scratch(nb, n))
    return jac


@njit(cache=True)
def _jacobian_scratch(nb, n):
    """The arrays :func:`_jacobian_into` fills: the rotations' rates (nb + 1, 4, 3, 3;
    the ground's stay zero), the net moments' rates (nb, 3, n), a (9, 3) scratch
    (:func:`_local`'s rows), a contact's ``grad`` (3, 12) and ``rates`` (9, 12)
    (:func:`_push_rates`), ``dloc`` (18, 26) and its state indices (26,)
    (:func:`_local_rates`), ``rows`` (3, 3, 26) (:func:`_contact_rows`). Made once per
    run by the integrator: its Jacobians then allocate nothing.
    """
    return (np.zeros((nb + 1, 4, 3, 3)), np.zeros((nb, 3, n)), np.zeros((9, 3)),
            np.zeros((3, 12)), np.zeros((9, 12)), np.zeros((18, 26)),
            np.zeros(26, dtype=np.int64), np.zeros((3, 3, 26)))


@njit(cache=True)
def _jacobian_into(t, y, args, jac, linked, scratch, own):
    """:func:`jacobian` into ``jac`` (the integrator's own array: no new matrix per
    Jacobian), with ``args`` the model arguments of :func:`rhs` as one tuple,
    ``linked`` the bodies' :func:`_linked`, ``scratch`` the contacts' arrays
    (:func:`_scratch`, shared with the right-hand side: each evaluation fills them
    anew) and ``own`` :func:`_jacobian_scratch`'s, all made once per run.
    """
    n_shafts, bodies, topology, geometry, laws, loads = args
    nb, m = bodies.shape[0], topology.shape[0]
    _contacts_into(y, bodies, topology, geometry, laws, loads[11], scratch)
    pushes, moment, frames = scratch[0][1], scratch[1][1], scratch[4]
    rot = frames[2]
    # d(p, ea, ub, rel, arm, arm_b)/d(states of a, then b); d(force on a, moment on a,
    # moment on b); dmoment: d(net moment on body k)/dy, global
    drot, dmoment, work, grad, rates, dloc, cols, rows = own
    for k in range(nb):
        _rotation_rates(y[3 * nb + 4 * k:3 * nb + 4 * k + 4], rot[k], drot[k])
    jac[:] = 0.0
    dmoment[:] = 0.0
    for c in range(m):
        if pushes[c] <= 0.0:
            continue  # out of touch (or pulled off by the damping): no force, no rate
        ka, kb, radial = topology[c, 0], topology[c, 1], topology[c, 2] == 1
        _local(frames, ka, kb, geometry, c, work)
        depth, push = _push(work[0], work[1], work[2], work[3], radial, laws[c], loads[11],
                            work[6])
        _push_rates(work[0], work[1], work[2], work[3], radial, laws[c], loads[11], depth,
                    push, grad, rates)
        _local_rates(y, nb, ka, kb, geometry[c], frames, drot, work, dloc, cols)
        width = 13 if kb == nb else 26  # the ground's columns stay zero
        _contact_rows(grad, dloc, work, width, rows)
        for k in range(width):
            col = cols[k]
            if col < 0:
                continue
            for i in range(3):
                jac[7 * nb + 3 * ka + i, col] += rows[0, i, k] / bodies[ka, 0]
                dmoment[ka, i, col] += rows[1, i, k]
                if kb < nb:
                    jac[7 * nb + 3 * kb + i, col] -= rows[0, i, k] / bodies[kb, 0]
                    dmoment[kb, i, col] += rows[2, i, k]
    _body_rates(t, y, nb, n_shafts, bodies, loads, rot, drot, moment, dmoment, jac, linked)


@njit(cache=True, inline="always")
def _contact_rows(grad, dloc, work, width, rows):
    """One contact's rates in the first ``width`` states of its bodies (``dloc``'s
    columns) into ``rows``: of its force on ``a`` (``grad`` times ``dloc``), of its
    moments on ``a`` (``arm x F``) and on ``b`` (``-(p + arm_b) x F``). ``work`` holds
    :func:`_local`'s rows and the force (row 6). Loops over whole rows of contiguous
    arrays (no views of columns), which the compiler vectorizes: ``grad`` times
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
    arm, f = work[4], work[6]
    point = work[7]  # the contact point from b's centre, p + arm_b
    for i in range(3):
        point[i] = work[0, i] + work[5, i]
    for i in range(3):
        a, b = (i + 1) % 3, (i + 2) % 3  # (u x v)_i = u_a v_b - u_b v_a
        for col in range(width):
            # M_a = arm x F: arm x dF - F x d(arm); M_b = -(p + arm_b) x F
            dmom_a[i, col] = ((arm[a] * dforce[b, col] - arm[b] * dforce[a, col])
                              - (f[a] * dloc[12 + b, col] - f[b] * dloc[12 + a, col]))
            dmom_b[i, col] = (-(point[a] * dforce[b, col] - point[b] * dforce[a, col])
                              + (f[a] * (dloc[b, col] + dloc[15 + b, col])
                                 - f[b] * (dloc[a, col] + dloc[15 + a, col])))


@njit(cache=True, inline="always")
def _push_rates(p, ea, ub, rel, radial, law, d_max, d, f, grad, rates):
    """``d(force on a)/d(p, ea, ub, rel)`` of one contact in touch (:func:`_push` gave
    its penetration ``d`` and push ``f > 0``) into ``grad`` (3, 12), by hand: the law's
    rates in ``d`` and ``d'`` (eqs. 75, 78) times those of ``d`` and ``d'`` in the local
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
    if x > 1.0:
        damping, slope = c_max, 0.0
    else:
        damping, slope = c_max * x * x * (3.0 - 2.0 * x), c_max * 6.0 * x * (1.0 - x) / d_max
    if exponent == 1.0:
        spring = stiffness
    elif exponent == 1.5:
        spring = 1.5 * stiffness * np.sqrt(d)
    else:
        spring = exponent * stiffness * d ** (exponent - 1.0)
    along_d, along_rate = spring + slope * rate, damping
    axis = n if radial else ea
    for k in range(12):
        df = along_d * dd[k] + along_rate * drate[k]
        for i in range(3):
            grad[i, k] = -axis[i] * df - (f * dn[i, k] if radial else 0.0)
    if not radial:
        for i in range(3):
            grad[i, 3 + i] -= f  # force = -f ea


@njit(cache=True, inline="always")
def _local_rates(y, nb, ka, kb, g, frames, drot, work, dloc, cols):
    """``d(p, ea, ub, rel, arm, arm_b)`` of one contact (:func:`_local`, its rows in
    ``work``; rows 7-8 scratch) with respect to the 13 states of ``a`` (local columns
    0-12: displacement, quaternion, velocity, rate) and of ``b`` (13-25), into ``dloc``
    (18, 26); ``cols``: their state indices (-1: the ground's). Elements are indexed
    one by one, with no views of rows in the loops (each view costs the array's
    reference count twice).
    """
    rot, omega = frames[2], frames[4]
    p, spin, turned = work[0], work[7], work[8]
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


@njit(cache=True, inline="always")
def _cross_into(a0, a1, a2, b0, b1, b2, dloc, col):
    """``dloc[9:12, col] += a x b`` (the relative velocity's rows), element by element."""
    dloc[9, col] += a1 * b2 - a2 * b1
    dloc[10, col] += a2 * b0 - a0 * b2
    dloc[11, col] += a0 * b1 - a1 * b0


@njit(cache=True, inline="always")
def _body_rates(t, y, nb, n_shafts, bodies, loads, rot, drot, moment, dmoment, jac,
                linked):
    """The rows of ``x' = v``, ``q' = q (0, w) / 2`` and ``w' = J^-1 (R^T M - w x J w)``
    (with the torques' rates added to ``dmoment``); ``moment``: the net contact moments;
    ``dmoment`` is zero outside the columns of the ``linked`` bodies (:func:`_linked`).
    """
    torque_in, torque_load = harmonic(loads[3:7], t), harmonic(loads[7:11], t)
    total = moment[:nb].copy()
    for i in range(3):
        total[0, i] += torque_in * rot[0, i, 1]
        total[n_shafts - 1, i] -= torque_load * rot[n_shafts - 1, i, 1]
    for k in range(nb):
        u, q, v, w = 3 * k, 3 * nb + 4 * k, 7 * nb + 3 * k, 10 * nb + 3 * k
        for kq in range(4):
            for i in range(3):
                if k == 0:
                    dmoment[k, i, q + kq] += torque_in * drot[k, kq, i, 1]
                if k == n_shafts - 1:
                    dmoment[k, i, q + kq] -= torque_load * drot[k, kq, i, 1]
        inertia = bodies[k, 1:4]
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


# ------------------------------------------------------------------ the integrator
# The penalty simulation's implicit integrator, compiled end to end by numba (in this
# module because numba's cache knows only a function's own file: an integrator cached
# elsewhere would keep stale copies of the kernels it calls).
#
# SciPy's variable-order BDF (``solve_ivp(method="BDF")``: the numerical differentiation
# formulas of Shampine & Reichelt, *The MATLAB ODE suite*, SIAM J. Sci. Comput. 18
# (1997), orders 1-3 here (:data:`MAX_ORDER`), quasi-constant step size, the
# backward-difference array ``D`` rescaled on every change of step) written as numba
# loops, so that every step calls the compiled right-hand side and Jacobian above with
# no Python in between. The LU factorization of ``I - c J`` works on what is left after
# the rows whose structure is known are eliminated (:func:`_factor`: 30 x 30 on
# ``paper`` instead of 65 x 65), block tridiagonal along the chain of bodies (shaft,
# pin, shaft, ...): factored block by block, 6 x 6 blocks with pivoting inside each
# (:func:`_factor_chain`; LAPACK's ``getrf`` where the bodies form no chain). Measured
# on ``paper``: a factorization 5.1 -> 2.7 us, a Newton solve 1.1 -> 0.9 us; the
# rounding differs from ``getrf``'s, and over six runs of each started 1e-15 apart the
# forces' 0.1 s averages, their spread and peaks and the step counts did not differ
# beyond the runs' own spread (the rattle is chaotic). SUNDIALS CVODE's
# rules where they save work: the LU is kept while ``c`` changes by less than 30 %
# (:data:`LU_KEEP`), and a first Newton correction already within tolerance is accepted
# (:func:`_newton`). The rows of the velocities and rates skip the blocks of bodies that
# share no contact (:func:`_linked`), and a Newton iteration restarted after a fresh
# Jacobian reuses the right-hand side at the prediction. Measured and not taken (5 s of
# ``paper-penalty``, or 2.5 s of it and of ``paper-fig15-axial``): CVODE's scaling of a
# kept LU's correction by ``2 / (1 + c / c_lu)`` (no fewer Jacobians or iterations; with
# a 50 % band 30 % more error-test failures and 11 % more steps), a step safety factor
# of 0.8 instead of 0.9 (45 % fewer error-test failures, 8 % more steps, the same
# time), refactoring before re-evaluating the Jacobian after a failed iteration (no
# fewer Jacobians), and a hand-written LU (no faster than ``getrf`` at 30 x 30).
#
# Why not a library: ODEPACK and SUNDIALS reach these kernels only
# through a Python callback per call (``odeint``, ``scikit-sundae``), ``numbalsoda`` does
# not build for this Python, and ``diffrax`` spends 0.2-0.3 ms a step on a 65-state
# system even with a trivial right-hand side, where the penalty model needs ~20 us.
#
# Same error control as SciPy's ``BDF``: the local error estimate of every component
# below ``atol + rtol |y|``. One difference: the Newton iteration stops at
# :data:`NEWTON_TOL` (SciPy's value for ordinary tolerances) of that error scale, where
# SciPy would tie it to ``sqrt(rtol)`` (1e-5 at the floor ``rtol = 1e-10`` that the
# penalty model's absolute control uses); a converged Newton iterate within 3 % of the
# error tolerance does not move the accepted solution beyond that tolerance, and the
# tighter rule costs a Jacobian every two steps. CVODE's rules instead (stop at 0.1,
# give up only on a growing correction) took 17 % fewer Jacobians and 9 % more
# right-hand sides over 5 s of ``paper-penalty``: no fewer steps, no less time.
#
# A step allocates nothing: its vectors, the rescaling's matrices and the right-hand
# side's frames and contact arrays are made once by :func:`start` (``work``), since on
# 65 states a NumPy temporary costs as much as the arithmetic it holds.

MAX_ORDER = 3
"""The highest order of the formulas (SciPy's: 5). The rattle's forces have kinks (a
contact closing, eq. 75's ``f >= 0`` switching while pressed) every few dozen steps;
orders 4 and 5 extrapolate across them worse and fail the error test more often. With
orders up to 3, the same error control on ``paper-penalty`` takes ~7 % fewer steps, each
cheaper (fewer differences to predict and rescale), and the forces' 0.1 s averages and
the speeds differ from the order-5 run's no more than two order-5 runs whose starts
differ by 1e-15 differ from each other (the rattle is chaotic). Up to order 2 it takes
45 % more steps (each 20 % cheaper), up to order 4 1 % more, each dearer (5 s of
``paper-penalty``)."""
NEWTON_MAXITER = 4
NEWTON_TOL = 0.03
"""Newton's stopping tolerance, in units of the error tolerance (see above)."""
MIN_FACTOR, MAX_FACTOR = 0.2, 10.0
LU_KEEP = 0.3
"""The LU of ``I - c J`` is kept while ``c`` stays within 30 % of the ``c`` it was
factored with (SUNDIALS CVODE's rule, ``dgmax``); SciPy refactors on every change of
step. A Newton iteration with the kept matrix converges to the same solution, a little
slower, and its rate test rejects it where it would not converge."""

_KAPPA = np.array([0.0, -0.1850, -1.0 / 9.0, -0.0823, -0.0415, 0.0])[:MAX_ORDER + 1]
_GAMMA = np.concatenate([[0.0], np.cumsum(1.0 / np.arange(1, MAX_ORDER + 1))])
_ALPHA = (1.0 - _KAPPA) * _GAMMA
_ERROR_CONST = _KAPPA * _GAMMA + 1.0 / np.arange(1, MAX_ORDER + 2)
_COEFFS = np.stack([_GAMMA, _ALPHA, _ERROR_CONST])
"""Rows: gamma, alpha, error constants of the NDF of each order (SciPy's ``BDF``)."""

# integer state (``ints``) and float state (``floats``) of a run, kept between calls
I_ORDER, I_EQUAL, I_LU, I_JAC_CURRENT, I_STEPS, I_FEV, I_JEV, I_NLU, I_STATUS, I_OUT = range(10)
F_T, F_H, F_C, F_RATE = range(4)
RUNNING, FINISHED, STEP_TOO_SMALL, NOT_FINITE = 0, 1, 2, 3
MESSAGES = {FINISHED: "finished", STEP_TOO_SMALL: "required step size is less than spacing "
            "between numbers", NOT_FINITE: "the right-hand side is not finite"}

if HAVE_NUMBA:
    from numba import types
    from numba.np.linalg import _LAPACK, F_INT_nptype

    _getrf = _LAPACK().numba_xxgetrf(types.float64)
else:  # pragma: no cover - the caller uses SciPy's integrators instead
    F_INT_nptype, _getrf = np.int32, None


@njit(cache=True)
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


@njit(cache=True)
def _factor(jac, c, lu, pivots, blocks, coupling, linked, chain):
    """Factor ``M = I - c J`` for :func:`_solve`, eliminating first what the equations'
    structure gives (state layout of :class:`penalty._Model`): the displacement rows
    read ``x_u - c x_v = b_u`` and each body's quaternion rows involve only its own
    quaternion and rate, ``A_k x_q - c J_qw x_w = b_q`` (``A_k = I - c J_qq``, 4 x 4).
    What is left is the ``6 nb`` rows of the velocities and rates,
    ``M_rr + c M_ru E_v + c M_rq A^-1 J_qw``, factored by LAPACK's ``getrf`` into ``lu``
    (held transposed: LAPACK's column-major view of it is the matrix); ``blocks`` gets
    the ``A_k^-1``, ``coupling`` (nb, 4, 3) the ``A_k^-1 J_qw``. A 30 x 30 factorization
    on ``paper`` instead of 65 x 65. ``linked`` (:func:`_linked`): the bodies whose
    states a body's rows can depend on; the others' columns are zero and skipped.
    ``chain`` (:func:`_new_chain`): where the bodies form a chain, the reduced matrix is
    block tridiagonal in the chain's order and is factored block by block
    (:func:`_factor_chain`) instead of by ``getrf``; ``lu`` and ``pivots`` are then unused.
    Returns 0, or ``k > 0`` where a pivot is zero.
    """
    nb = blocks.shape[0]
    r0, m = 7 * nb, 6 * nb
    for k in range(nb):  # J_qq = Omega(w) / 2 is skew with Omega^2 = -|w|^2 I, so
        q = 3 * nb + 4 * k  # (I - c J_qq)^-1 = (I + c J_qq) / (1 + c^2 |w|^2 / 4)
        scale = 1.0 / (1.0 + c * c * (jac[q, q + 1] ** 2 + jac[q, q + 2] ** 2
                                      + jac[q, q + 3] ** 2))
        for i in range(4):
            for j in range(4):
                blocks[k, i, j] = scale * ((1.0 if i == j else 0.0) + c * jac[q + i, q + j])
    for k in range(nb):  # A^-1 J_qw, for every row below
        q, w = 3 * nb + 4 * k, 3 * nb + 3 * k
        for i4 in range(4):
            for e in range(3):
                g = 0.0
                for j4 in range(4):
                    g += blocks[k, i4, j4] * jac[q + j4, r0 + w + e]
                coupling[k, i4, e] = g
    if chain[0].shape[0] > 0:
        return _factor_chain(jac, c, coupling, linked, chain)
    for i in range(m):
        row, body = r0 + i, (i % (3 * nb)) // 3
        for j in range(m):
            lu[j, i] = -c * jac[row, r0 + j]
        lu[i, i] += 1.0
        for k in range(nb):
            if not linked[body, k]:
                continue
            for e in range(3):  # x_u = b_u + c x_v: M_ru's columns onto x_v's
                lu[3 * k + e, i] += -c * jac[row, 3 * k + e] * c
            q, w = 3 * nb + 4 * k, 3 * nb + 3 * k
            for e in range(3):  # x_q = A^-1 (b_q + c J_qw x_w)
                total = 0.0
                for i4 in range(4):
                    total += -c * jac[row, q + i4] * coupling[k, i4, e]
                lu[w + e, i] += total * c
    return _getrf(ord("d"), m, m, lu.ctypes, m, pivots.ctypes)


@njit(cache=True, inline="always")
def _solve(jac, c, lu, pivots, blocks, coupling, linked, chain, b, work):
    """``b <- (I - c J)^-1 b`` from :func:`_factor`'s elimination and factors (``lu``,
    ``pivots``, ``blocks``, ``coupling``; ``linked``, ``chain`` as there); ``work``: two rows of
    scratch as long as ``b``.
    """
    nb = blocks.shape[0]
    r0, m = 7 * nb, 6 * nb
    xq, r = work[0], work[1]
    for k in range(nb):  # A^-1 b_q
        q = 3 * nb + 4 * k
        for i in range(4):
            xq[4 * k + i] = (blocks[k, i, 0] * b[q] + blocks[k, i, 1] * b[q + 1]
                             + blocks[k, i, 2] * b[q + 2] + blocks[k, i, 3] * b[q + 3])
    for body in range(nb):  # the body's six rows at once: six independent sums
        v, w = r0 + 3 * body, r0 + 3 * nb + 3 * body
        t0 = t1 = t2 = t3 = t4 = t5 = 0.0
        for k in range(nb):
            if linked[body, k]:
                for j in range(3 * k, 3 * k + 3):
                    bj = b[j]
                    t0 += jac[v, j] * bj
                    t1 += jac[v + 1, j] * bj
                    t2 += jac[v + 2, j] * bj
                    t3 += jac[w, j] * bj
                    t4 += jac[w + 1, j] * bj
                    t5 += jac[w + 2, j] * bj
        for k in range(nb):
            if linked[body, k]:
                for j in range(4 * k, 4 * k + 4):
                    xj, col = xq[j], 3 * nb + j
                    t0 += jac[v, col] * xj
                    t1 += jac[v + 1, col] * xj
                    t2 += jac[v + 2, col] * xj
                    t3 += jac[w, col] * xj
                    t4 += jac[w + 1, col] * xj
                    t5 += jac[w + 2, col] * xj
        # b_r - M_ru b_u - M_rq A^-1 b_q, M = -c J off the diagonal
        i, e = v - r0, w - r0
        r[i], r[i + 1], r[i + 2] = b[v] + c * t0, b[v + 1] + c * t1, b[v + 2] + c * t2
        r[e], r[e + 1], r[e + 2] = b[w] + c * t3, b[w + 1] + c * t4, b[w + 2] + c * t5
    if chain[0].shape[0] > 0:
        _solve_chain(chain, r)
    else:
        _lu_solve(lu, pivots, r[:m])
    for i in range(m):
        b[r0 + i] = r[i]
    for j in range(3 * nb):
        b[j] += c * r[j]  # x_u = b_u + c x_v
    for k in range(nb):
        q, w = 3 * nb + 4 * k, 3 * nb + 3 * k
        for i in range(4):
            total = xq[4 * k + i]
            for e in range(3):  # x_q = A^-1 (b_q + c J_qw x_w)
                total += c * coupling[k, i, e] * r[w + e]
            b[q + i] = total


@njit(cache=True)
def _chain_order(linked):
    """The bodies in the order of the chain their contacts make (a body shares contacts
    with at most two others, and no loop: shaft, pin, shaft, ... ; a body or chain
    linked to none is appended as its own chain), or an empty array where they do not
    form one. In that order the rows of :func:`_factor` that remain are block
    tridiagonal, one 6 x 6 block (velocity, rate) per body.
    """
    nb = linked.shape[0]
    degree = np.zeros(nb, dtype=np.int64)
    for k in range(nb):
        for j in range(nb):
            if j != k and linked[k, j]:
                degree[k] += 1
    order, seen, size = np.zeros(nb, dtype=np.int64), np.zeros(nb, dtype=np.bool_), 0
    for first in range(nb):
        if seen[first] or degree[first] > 1:
            continue  # each chain is walked from one of its ends
        body = first
        while body >= 0:
            order[size], seen[body], size = body, True, size + 1
            nxt = -1
            for j in range(nb):
                if j != body and linked[body, j] and not seen[j]:
                    nxt = j
            body = nxt
    if size < nb or np.any(degree > 2):
        return order[:0]  # a body with three neighbours, or a loop
    return order


@njit(cache=True)
def _new_chain(linked):
    """:func:`_factor_chain`'s arrays: the chain's order (:func:`_chain_order`; empty:
    no chain, ``getrf`` instead), per block position the factored diagonal block, the
    block below it and ``D^-1`` times the block right of it (nb, 3, 6, 6), the diagonal
    blocks' row swaps (nb, 6) and a scratch (nb, 6) for :func:`_solve_chain`.
    """
    nb = linked.shape[0]
    return (_chain_order(linked), np.zeros((nb, 3, 6, 6)), np.zeros((nb, 6), dtype=np.int64),
            np.zeros((nb, 6)))


@njit(cache=True, inline="always")
def _reduced(nb, body, local):
    """Index in :func:`_factor`'s reduced rows of body ``body``'s velocity (``local``
    0-2) or rate (3-5) component.
    """
    return 3 * body + local if local < 3 else 3 * nb + 3 * body + local - 3


@njit(cache=True, inline="always")
def _fill_block(jac, c, coupling, row_body, col_body, out):
    """The 6 x 6 block of :func:`_factor`'s reduced matrix at the rows of ``row_body``
    and the columns of ``col_body`` into ``out``: the same sums, in the same order, as
    the dense path forms.
    """
    nb = coupling.shape[0]
    r0 = 7 * nb
    for a in range(6):
        i = _reduced(nb, row_body, a)
        row = r0 + i
        for e in range(6):
            j = _reduced(nb, col_body, e)
            value = -c * jac[row, r0 + j]
            if i == j:
                value += 1.0
            if e < 3:  # x_u = b_u + c x_v
                value += -c * jac[row, 3 * col_body + e] * c
            else:  # x_q = A^-1 (b_q + c J_qw x_w)
                q, total = 3 * nb + 4 * col_body, 0.0
                for i4 in range(4):
                    total += -c * jac[row, q + i4] * coupling[col_body, i4, e - 3]
                value += total * c
            out[a, e] = value


@njit(cache=True, inline="always")
def _lu6(a, pivots):
    """LU factorization with partial pivoting of the 6 x 6 ``a`` in place (unit lower
    and upper triangles), its row swaps into ``pivots``; 0, or ``k + 1`` where the
    ``k``-th pivot is zero.
    """
    info = 0
    for k in range(6):
        p = k
        for i in range(k + 1, 6):
            if abs(a[i, k]) > abs(a[p, k]):
                p = i
        pivots[k] = p
        if p != k:
            for j in range(6):
                a[k, j], a[p, j] = a[p, j], a[k, j]
        if a[k, k] == 0.0:
            info = k + 1 if info == 0 else info
            continue
        for i in range(k + 1, 6):
            a[i, k] /= a[k, k]
            f = a[i, k]
            for j in range(k + 1, 6):
                a[i, j] -= f * a[k, j]
    return info


@njit(cache=True, inline="always")
def _lu6_solve(a, pivots, x):
    """``x <- a^-1 x`` from :func:`_lu6`'s factors, for every column of the (6, k)
    ``x``: :func:`_lu6_solve_vector` of each (the columns do not mix).
    """
    for col in range(x.shape[1]):
        _lu6_solve_vector(a, pivots, x[:, col])


@njit(cache=True, inline="always")
def _lu6_solve_vector(a, pivots, x):
    """``x <- a^-1 x`` from :func:`_lu6`'s factors for one vector ``x`` (6,)."""
    for k in range(6):
        p = pivots[k]
        if p != k:
            x[k], x[p] = x[p], x[k]
    for i in range(1, 6):
        total = x[i]
        for j in range(i):
            total -= a[i, j] * x[j]
        x[i] = total
    for i in range(5, -1, -1):
        total = x[i]
        for j in range(i + 1, 6):
            total -= a[i, j] * x[j]
        x[i] = total / a[i, i]


@njit(cache=True, inline="always")
def _factor_chain(jac, c, coupling, linked, chain):
    """Block LU of :func:`_factor`'s reduced matrix, block tridiagonal in the chain's
    order (:func:`_chain_order`): ``D'_p = D_p - A_p X_{p-1}`` factored with partial
    pivoting inside the block, ``X_p = D'_p^-1 C_p``. About 5 x 700 multiply-adds on
    ``paper`` (five bodies) where ``getrf`` of the dense 30 x 30 spends 9,000 and a
    library call. Pivoting stays within a body's block: the test of the Newton solve
    holds its backward error to round-off at the steps' values of ``c``.
    """
    order, tri, pivots = chain[0], chain[1], chain[2]
    nb, info = order.shape[0], 0
    for p in range(nb):
        body, diag, below, right = order[p], tri[p, 0], tri[p, 1], tri[p, 2]
        _fill_block(jac, c, coupling, body, body, diag)
        if p > 0 and linked[body, order[p - 1]]:
            _fill_block(jac, c, coupling, body, order[p - 1], below)
            ahead = tri[p - 1, 2]
            for i in range(6):
                for j in range(6):
                    total = diag[i, j]
                    for k in range(6):
                        total -= below[i, k] * ahead[k, j]
                    diag[i, j] = total
        else:
            below[:] = 0.0
        found = _lu6(diag, pivots[p])
        if found and not info:
            info = 6 * p + found
        if p + 1 < nb and linked[body, order[p + 1]]:
            _fill_block(jac, c, coupling, body, order[p + 1], right)
            _lu6_solve(diag, pivots[p], right)
        else:
            right[:] = 0.0
    return info


@njit(cache=True, inline="always")
def _solve_chain(chain, r):
    """``r <- S^-1 r`` for :func:`_factor_chain`'s factors of the reduced matrix ``S``
    (``r`` in the reduced rows' order): forward ``y_p = D'_p^-1 (r_p - A_p y_{p-1})``,
    back ``x_p = y_p - X_p x_{p+1}``.
    """
    order, tri, pivots, ys = chain
    nb = order.shape[0]
    for p in range(nb):
        body, y = order[p], ys[p]
        for a in range(6):
            total = r[_reduced(nb, body, a)]
            if p > 0:
                for k in range(6):
                    total -= tri[p, 1, a, k] * ys[p - 1, k]
            y[a] = total
        _lu6_solve_vector(tri[p, 0], pivots[p], y)
    for p in range(nb - 2, -1, -1):
        for a in range(6):
            total = ys[p, a]
            for k in range(6):
                total -= tri[p, 2, a, k] * ys[p + 1, k]
            ys[p, a] = total
    for p in range(nb):
        for a in range(6):
            r[_reduced(nb, order[p], a)] = ys[p, a]


@njit(cache=True)
def _lu_solve(lu, pivots, b):
    """``b <- M^-1 b`` from LAPACK's ``getrf`` factors of ``M`` (held transposed): row
    swaps, then the unit lower and the upper triangle, column by column.
    """
    n = b.shape[0]
    for k in range(n):
        p = pivots[k] - 1
        if p != k:
            b[k], b[p] = b[p], b[k]
    for j in range(n):
        bj = b[j]
        if bj != 0.0:
            for i in range(j + 1, n):
                b[i] -= lu[j, i] * bj
    for j in range(n - 1, -1, -1):
        b[j] /= lu[j, j]
        bj = b[j]
        for i in range(j):
            b[i] -= lu[j, i] * bj


@njit(cache=True, inline="always")
def _norm(x, scale):
    """RMS norm of ``x / scale``."""
    s = 0.0
    for i in range(x.shape[0]):
        s += (x[i] / scale[i]) ** 2
    return np.sqrt(s / x.shape[0])


@njit(cache=True, inline="always")
def _scaled_norm(factor, x, scale):
    """RMS norm of ``factor x / scale`` (no temporary for ``factor x``)."""
    s = 0.0
    for i in range(x.shape[0]):
        s += (factor * x[i] / scale[i]) ** 2
    return np.sqrt(s / x.shape[0])


@njit(cache=True, inline="always")
def _r_matrix(order, factor, m):
    """SciPy's ``compute_R`` into ``m``: the map of backward differences for a step
    times ``factor``.
    """
    m[0, :order + 1] = 1.0
    for i in range(1, order + 1):
        m[i, 0] = 0.0
        for j in range(1, order + 1):
            m[i, j] = (i - 1 - factor * j) / i
    for i in range(1, order + 1):
        for j in range(order + 1):
            m[i, j] *= m[i - 1, j]


@njit(cache=True, inline="always")
def _change_d(d, order, factor, work):
    """Rescale the differences ``d`` for a step size times ``factor`` (in place):
    ``D <- (R U)^T D`` over the first ``order + 1`` rows, as SciPy's ``change_D``;
    ``work``: :func:`start`'s scratch (matrices, the old differences).
    """
    r, u, ru, old = work[1][0], work[1][1], work[1][2], work[2]
    _r_matrix(order, factor, r)
    _r_matrix(order, 1.0, u)
    for i in range(order + 1):
        for j in range(order + 1):
            total = 0.0
            for k in range(order + 1):
                total += r[i, k] * u[k, j]
            ru[i, j] = total
    n = d.shape[1]
    for i in range(order + 1):
        for k in range(n):
            old[i, k] = d[i, k]
    for i in range(order + 1):
        row = d[i]
        row[:] = 0.0
        for j in range(order + 1):
            weight = ru[j, i]
            if weight != 0.0:
                for k in range(n):
                    row[k] += weight * old[j, k]


@njit(cache=True)
def initial_step(t0, y0, t_bound, atol, rtol, ints, args):
    """SciPy's ``select_initial_step`` for a first-order estimate (Hairer, Norsett and
    Wanner, Solving ODEs I, sec. II.4); returns it and ``f(t0, y0)``. Its two
    right-hand sides are :func:`rhs`'s (one compiled copy; the integrator's own is
    inlined into its Newton iteration).
    """
    scale = atol + rtol * np.abs(y0)
    n_shafts, bodies, topology, geometry, laws, loads = args
    ints[I_FEV] += 2
    f0 = rhs(t0, y0, n_shafts, bodies, topology, geometry, laws, loads)
    d0, d1 = _norm(y0, scale), _norm(f0, scale)
    h0 = 1e-6 if d0 < 1e-5 or d1 < 1e-5 else 0.01 * d0 / d1
    h0 = min(h0, t_bound - t0)
    f1 = rhs(t0 + h0, y0 + h0 * f0, n_shafts, bodies, topology, geometry, laws, loads)
    d2 = _norm(f1 - f0, scale) / h0
    if d1 <= 1e-15 and d2 <= 1e-15:
        h1 = max(1e-6, h0 * 1e-3)
    else:
        h1 = (0.01 / max(d1, d2)) ** 0.5
    return min(100.0 * h0, h1, t_bound - t0), f0


# rows of the integrator's vector scratch (``work[0]``)
W_PREDICT, W_SCALE, W_PSI, W_Y, W_D, W_DY, W_F, W_F_PREDICT, W_SOLVE = range(9)


@njit(cache=True)
def start(t0, y0, t_bound, atol, rtol, args):
    """A run's state at ``t0``: (floats, ints, differences ``D``, Jacobian, LU factors,
    pivots, quaternion blocks: :func:`_factor`, scratch), for :func:`advance`. The
    scratch (vectors by the ``W_`` rows, :func:`_change_d`'s matrices and rows, the
    right-hand side's :func:`_scratch`, :func:`_factor`'s coupling, the bodies'
    :func:`_linked`, the block factors of :func:`_new_chain`, the Jacobian's
    :func:`_jacobian_scratch`) is made here once: a step allocates nothing.
    """
    n, nb = y0.shape[0], args[1].shape[0]
    linked = _linked(nb, args[2])
    work = (np.zeros((W_SOLVE + 2, n)), np.zeros((3, MAX_ORDER + 1, MAX_ORDER + 1)),
            np.zeros((MAX_ORDER + 1, n)), _scratch(y0, nb, args[2].shape[0]),
            np.zeros((nb, 4, 3)), linked, _new_chain(linked), _jacobian_scratch(nb, n))
    ints = np.zeros(10, dtype=np.int64)
    ints[I_ORDER] = 1
    h, f0 = initial_step(t0, y0, t_bound, atol, rtol, ints, args)
    d = np.zeros((MAX_ORDER + 3, n))
    d[0], d[1] = y0, f0 * h
    ints[I_JEV] += 1
    jac = np.empty((n, n))
    _jacobian_into(t0, y0, args, jac, linked, work[3], work[7])
    ints[I_JAC_CURRENT] = 1
    floats = np.array([t0, h, h, 1.0])
    m = 6 * nb
    return (floats, ints, d, jac, np.zeros((m, m)), np.zeros(m, dtype=F_INT_nptype),
            np.zeros((nb, 4, 4)), work)


@njit(cache=True, inline="always")
def _newton(t_new, c, jac, lu, pivots, blocks, floats, ints, args, work, again):
    """SciPy's ``solve_bdf_system``: the simplified Newton iteration of one step from
    the prediction (``work`` rows ``W_PREDICT``, ``W_PSI``, ``W_SCALE``) into ``y``
    (``W_Y``) and ``d = y - y_predict`` (``W_D``); (converged, iterations). As CVODE
    (and unlike SciPy), a first correction already below the tolerance times the last
    rate seen with this LU is accepted without a second evaluation. ``again``: the
    iteration restarts from the same prediction (after a fresh Jacobian), whose
    right-hand side is kept in row ``W_F_PREDICT`` from the first start.
    """
    vec = work[0]
    y_predict, scale, psi = vec[W_PREDICT], vec[W_SCALE], vec[W_PSI]
    y, d, dy, f = vec[W_Y], vec[W_D], vec[W_DY], vec[W_F]
    n = y.shape[0]
    for i in range(n):
        y[i], d[i] = y_predict[i], 0.0
    dy_norm_old, converged, iterations = -1.0, False, 0
    while iterations < NEWTON_MAXITER:
        iterations += 1
        if iterations == 1 and again:
            f[:] = vec[W_F_PREDICT]
        else:
            ints[I_FEV] += 1
            _rhs_into(t_new, y, args, work[3], f)
            if iterations == 1:
                vec[W_F_PREDICT, :] = f
        finite = True
        for i in range(n):
            finite &= np.isfinite(f[i])
            dy[i] = c * f[i] - psi[i] - d[i]
        if not finite:
            break
        _solve(jac, c, lu, pivots, blocks, work[4], work[5], work[6], dy, vec[W_SOLVE:])
        dy_norm = _norm(dy, scale)
        rate = dy_norm / dy_norm_old if dy_norm_old > 0.0 else -1.0
        if rate >= 0.0 and (rate >= 1.0 or rate ** (NEWTON_MAXITER - iterations + 1)
                            / (1.0 - rate) * dy_norm > NEWTON_TOL):
            break
        for i in range(n):
            y[i] += dy[i]
            d[i] += dy[i]
        if rate >= 0.0:
            floats[F_RATE] = rate
        if dy_norm == 0.0 or (rate >= 0.0 and rate / (1.0 - rate) * dy_norm < NEWTON_TOL) or (
                rate < 0.0 and min(1.0, floats[F_RATE]) * dy_norm < NEWTON_TOL):
            converged = True
            break
        dy_norm_old = dy_norm
    return converged, iterations


@njit(cache=True, inline="always")
def _predict(d, order, alpha, gamma, atol, rtol, vec):
    """The prediction ``y_predict`` of the next step, its error scale and ``psi`` (the
    differences' share of the BDF equation) into ``vec``'s rows.
    """
    y_predict, scale, psi = vec[W_PREDICT], vec[W_SCALE], vec[W_PSI]
    for i in range(d.shape[1]):
        y_predict[i], psi[i] = d[0, i], 0.0
        for j in range(1, order + 1):
            y_predict[i] += d[j, i]
            psi[i] += d[j, i] * (gamma[j] / alpha[order])
        scale[i] = atol[i] + rtol * abs(y_predict[i])


@njit(cache=True, inline="always")
def _attempt(floats, ints, d, jac, lu, pivots, blocks, t_bound, atol, rtol, args, work):
    """SciPy's ``BDF._step_impl`` up to the accepted step: shrink the step until Newton
    converges (with a fresh Jacobian once per step) and the error test passes; returns
    (t_new, Newton iterations) with the new state, its difference from the prediction
    and its error scale in ``work[0]``'s rows ``W_Y``, ``W_D``, ``W_SCALE``; or
    ``t_new = nan`` with the status set when the step would fall below the spacing of
    floats at ``t``.
    """
    t, h_abs, order = floats[F_T], floats[F_H], ints[I_ORDER]
    gamma, alpha, error_const = _COEFFS[0], _COEFFS[1], _COEFFS[2]
    vec = work[0]
    min_step = 10.0 * abs(np.nextafter(t, np.inf) - t)
    if h_abs < min_step:
        _change_d(d, order, min_step / h_abs, work)
        h_abs, ints[I_EQUAL] = min_step, 0
    while True:
        if not h_abs >= min_step:  # also a NaN step: a state gone bad
            ints[I_STATUS] = STEP_TOO_SMALL if h_abs < min_step else NOT_FINITE
            return np.nan, 0
        t_new = t + h_abs
        if t_new > t_bound:
            t_new = t_bound
            _change_d(d, order, (t_new - t) / h_abs, work)
            ints[I_EQUAL] = 0
        h_abs = t_new - t
        _predict(d, order, alpha, gamma, atol, rtol, vec)
        c, again = h_abs / alpha[order], False
        while True:
            if ints[I_LU] == 0 or abs(c / floats[F_C] - 1.0) > LU_KEEP:
                _factor(jac, c, lu, pivots, blocks, work[4], work[5], work[6])
                ints[I_NLU] += 1
                ints[I_LU], floats[F_C], floats[F_RATE] = 1, c, 1.0
            converged, n_iter = _newton(t_new, c, jac, lu, pivots, blocks, floats, ints,
                                        args, work, again)
            if converged or ints[I_JAC_CURRENT] == 1:
                break
            _jacobian_into(t_new, vec[W_PREDICT], args, jac, work[5], work[3], work[7])
            ints[I_JEV] += 1
            ints[I_LU], ints[I_JAC_CURRENT], again = 0, 1, True
        if not converged:
            h_abs *= 0.5
            _change_d(d, order, 0.5, work)
            ints[I_EQUAL], ints[I_LU] = 0, 0
            continue
        safety = 0.9 * (2 * NEWTON_MAXITER + 1) / (2 * NEWTON_MAXITER + n_iter)
        y_new, scale = vec[W_Y], vec[W_SCALE]
        for i in range(y_new.shape[0]):
            scale[i] = atol[i] + rtol * abs(y_new[i])
        error_norm = _scaled_norm(error_const[order], vec[W_D], scale)
        if error_norm <= 1.0:
            floats[F_H] = h_abs
            return t_new, n_iter
        factor = max(MIN_FACTOR, safety * error_norm ** (-1.0 / (order + 1)))
        h_abs *= factor
        _change_d(d, order, factor, work)  # the LU stays: Newton converged with it
        ints[I_EQUAL] = 0


@njit(cache=True, inline="always")
def _step(floats, ints, d, jac, lu, pivots, blocks, t_bound, atol, rtol, args, work):
    """One accepted step of SciPy's ``BDF``: :func:`_attempt`, then the differences
    updated and, after ``order + 1`` steps of one size, the order and step chosen
    from the error estimates of the orders either side.
    """
    ints[I_JAC_CURRENT] = 0
    t_new, n_iter = _attempt(floats, ints, d, jac, lu, pivots, blocks, t_bound, atol, rtol,
                             args, work)
    if np.isnan(t_new):
        return
    order, error_const = ints[I_ORDER], _COEFFS[2]
    dd, scale = work[0][W_D], work[0][W_SCALE]
    ints[I_STEPS] += 1
    ints[I_EQUAL] += 1
    floats[F_T] = t_new
    for k in range(dd.shape[0]):
        d[order + 2, k] = dd[k] - d[order + 1, k]
        d[order + 1, k] = dd[k]
    for i in range(order, -1, -1):
        for k in range(dd.shape[0]):
            d[i, k] += d[i + 1, k]
    if ints[I_EQUAL] < order + 1:
        return
    safety = 0.9 * (2 * NEWTON_MAXITER + 1) / (2 * NEWTON_MAXITER + n_iter)
    norm = _scaled_norm(error_const[order], dd, scale)
    down = _scaled_norm(error_const[order - 1], d[order], scale) if order > 1 else np.inf
    up = _scaled_norm(error_const[order + 1], d[order + 2], scale) \
        if order < MAX_ORDER else np.inf
    best, delta = -1.0, 0
    for k, value in enumerate((down, norm, up)):  # the first largest, as argmax
        factor = np.inf if value == 0.0 else value ** (-1.0 / (order + k))
        if factor > best:
            best, delta = factor, k - 1
    ints[I_ORDER] = order + delta
    factor = min(MAX_FACTOR, safety * best)
    floats[F_H] *= factor
    _change_d(d, order + delta, factor, work)
    ints[I_EQUAL] = 0


@njit(cache=True)
def _dense(d, t, h, order, tq, out):
    """SciPy's ``BdfDenseOutput`` at ``tq``: the interpolating polynomial of the last
    step from its backward differences (step ``h``, ending at ``t``).
    """
    out[:] = d[0]
    p = 1.0
    for i in range(order):
        p *= (tq - (t - h * i)) / (h * (1 + i))
        out += d[i + 1] * p


@njit(cache=True)
def advance(run, t_stop, t_bound, atol, rtol, args, t_out, out):
    """Step the run (:func:`start`'s arrays) until ``t >= t_stop`` (or ``t_bound``, the
    end, where the status becomes finished), filling the rows of ``out`` at the sorted
    instants ``t_out`` as they are passed; the status and counters are in ``run[1]``.
    A time or step that is not a number (the right-hand side at the start was not
    finite) or a step that falls below the spacing of numbers ends the run with that
    status: it never raises and never loops on a NaN.
    """
    floats, ints, d, jac, lu, pivots, blocks, work = run
    if not (np.isfinite(floats[F_T]) and np.isfinite(floats[F_H])):
        ints[I_STATUS] = NOT_FINITE
    while ints[I_STATUS] == RUNNING and floats[F_T] < t_stop:
        _step(floats, ints, d, jac, lu, pivots, blocks, t_bound, atol, rtol, args, work)
        if ints[I_STATUS] != RUNNING:
            break
        t = floats[F_T]
        while ints[I_OUT] < t_out.shape[0] and t_out[ints[I_OUT]] <= t:
            _dense(d, t, floats[F_H], ints[I_ORDER], t_out[ints[I_OUT]], out[ints[I_OUT]])
            ints[I_OUT] += 1
        if t >= t_bound:
            ints[I_STATUS] = FINISHED
