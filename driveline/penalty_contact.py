"""Compiled contact geometry, contact law and right-hand side of the penalty simulation.

The same Newton-Euler equations and contact law (paper eqs. 75-78) as the NumPy model
of :mod:`cardan_forces.driveline.penalty_model`, written as loops over bodies and
contacts and compiled by numba (:mod:`.penalty_kernels` tells the whole story). The
state of one evaluation lives in named tuples of arrays made once per run
(:class:`Frames`, :class:`Local`, :class:`ContactState`): the integrator's right-hand
sides then allocate nothing. The model itself is one named tuple, :class:`ModelArrays`,
the kernels' one model argument, read by field name.

Every kernel of the penalty modules is compiled by :data:`kernel`: its disk cache is
keyed also by the contents of all of them (:data:`KERNEL_FILES`), so an edit of any
one compiles every kernel that may have inlined it again.
"""

from __future__ import annotations

from functools import partial
from typing import NamedTuple

import numpy as np

from cardan_forces.util.compiled import njit

from .harmonic import harmonic

KERNEL_FILES = ("harmonic.py", "penalty_contact.py", "penalty_jacobian.py",
                "penalty_linear.py", "penalty_bdf.py")
"""The source files of the penalty kernels (beside this one): each kernel's cache is
keyed by all of their contents, as one file was before."""

kernel = partial(njit, cache=True, depends=KERNEL_FILES)
"""The penalty modules' ``njit``: cached, and compiled again when any of
:data:`KERNEL_FILES` changes."""

FACE, RADIAL, SPRING, TWIST, LINE = 0, 1, 2, 3, 4
"""A contact's kind (the third column of :attr:`ModelArrays.topology`): a unilateral
end face or radial contact (eqs. 75-78), a bilateral linear spring along a face's axis,
a bilateral linear torsion spring, a bilateral linear point-on-line spring
(:class:`~.penalty_model._Contacts` defines each)."""


class ModelArrays(NamedTuple):
    """The released line's model as the compiled kernels take it (one argument, its
    fields read by name; made by :class:`~.penalty_model.Model`).

    Per body (``nb``: shaft segments first, then cross-pins): ``mass`` (kg), principal
    ``inertia`` (nb, 3) (kg m^2, body axes), ``rest_centre`` (nb, 3) (m, global). Per
    contact, one row each: ``topology`` (m, 3) int: body ``a``, body ``b`` (the ground:
    ``nb``), its kind (:data:`FACE`, :data:`RADIAL`, :data:`SPRING`, :data:`TWIST`,
    :data:`LINE`);
    ``geometry`` (m, 12): ``s``, ``e`` (point and axis on ``a``), ``j``, ``u`` (on
    ``b``), body coordinates (m; a twist's four axes); ``laws`` (m, 4): offset (the
    clearance, m), stiffness, exponent, ``c_max`` of the contact law (eqs. 75-78; a
    spring's or twist's ``K`` and ``c``). Loads: ``gravity`` (3,) (m/s^2),
    ``input_torque`` and ``load_torque`` (4,): mean, amplitude, frequency, phase of the
    line's input and load torques ``h`` (N m, :func:`~.harmonic.harmonic`); per end of
    the line (row 0 the input, row 1 the load) the body its torque acts on,
    ``load_bodies`` (2,) int, and how, ``loads`` (2, 10): ``spin``, then a point ``p``
    (3, m, global, fixed in space), ``lin`` (3) and ``abs`` (3) (N per N m, global): a
    pure torque ``h spin`` (N m) about the body's current axis and a force ``F = h lin
    + |h| abs`` (N) at ``p`` (a gear mesh's, :meth:`~.elements.base.Loads.load`;
    zero where the torque acts as a torque); ``d_max`` the depth of full damping (m).
    """

    mass: np.ndarray
    inertia: np.ndarray
    rest_centre: np.ndarray
    topology: np.ndarray
    geometry: np.ndarray
    laws: np.ndarray
    gravity: np.ndarray
    input_torque: np.ndarray
    load_torque: np.ndarray
    load_bodies: np.ndarray
    loads: np.ndarray
    d_max: float


class Frames(NamedTuple):
    """Per body (row ``nb``: the ground, which does not move), global: its centre (m),
    velocity (m/s), rotation body to global, the rotation's rate ``R [w]x`` and the
    angular velocity ``R w`` (rad/s).
    """

    centre: np.ndarray
    vel: np.ndarray
    rot: np.ndarray
    rate: np.ndarray
    omega: np.ndarray


class Local(NamedTuple):
    """One contact's local kinematics (3-vectors, global; :func:`_local`): the offset
    ``p`` of a's point from b's, the axes ``ea`` (on a) and ``ub`` (on b), the relative
    velocity ``rel``, the arms of the points from a's and b's centres, the contact's
    normal (then its force on a), and two spare rows (a body's ``J w`` and its rate in
    :func:`_bodies`; the contact point from b's centre, ``w x point`` and
    ``(dR/dq) w`` in the Jacobian). Rows of one (9, 3) array.
    """

    p: np.ndarray
    ea: np.ndarray
    ub: np.ndarray
    rel: np.ndarray
    arm: np.ndarray
    arm_b: np.ndarray
    normal: np.ndarray
    spare: np.ndarray
    spare_b: np.ndarray


class ContactState(NamedTuple):
    """What one evaluation of the contacts fills (:func:`_contacts_into`): per contact
    its penetration ``depth`` (m), ``push`` (N) and force on ``a`` (``on_a``, global,
    N); per body (and the ground, row ``nb``) the net contact ``force`` (N) and
    ``moment`` about its centre (N m, global); the ``local`` kinematics of the contact
    at hand and the bodies' ``frames``.
    """

    depth: np.ndarray
    push: np.ndarray
    force: np.ndarray
    moment: np.ndarray
    on_a: np.ndarray
    local: Local
    frames: Frames

@kernel(inline="always")
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


@kernel(inline="always")
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


@kernel(inline="always")
def _twist(ea, ub, sa, jb, omega, ka, kb, law, g):
    """A :data:`TWIST` contact: its ``theta = (ea.ub - sa.jb) / 2`` (rad) and moment
    ``K theta + c theta'`` (N m), ``theta' = g . (omega_a - omega_b)``, with ``g = (ea x
    ub - sa x jb) / 2`` into ``g`` (:class:`~.penalty_model._Contacts`; the couple on
    ``a`` is ``-moment g``).
    """
    theta = 0.5 * (ea[0] * ub[0] + ea[1] * ub[1] + ea[2] * ub[2]
                   - sa[0] * jb[0] - sa[1] * jb[1] - sa[2] * jb[2])
    rate = 0.0 * theta
    for i in range(3):
        j, k = (i + 1) % 3, (i + 2) % 3
        g[i] = 0.5 * (ea[j] * ub[k] - ea[k] * ub[j] - sa[j] * jb[k] + sa[k] * jb[j])
        rate += g[i] * (omega[ka, i] - omega[kb, i])
    return theta, law[1] * theta + law[3] * rate


@kernel(inline="always")
def _line(p, ub, rel, law, force):
    """A :data:`LINE` contact: the offset ``r = p - (p.ub) ub`` of ``a``'s point from
    ``b``'s line (``ub`` unit), its force on ``a`` ``-(K r + c (rel - (rel.ub) ub))``
    into ``force``; returns ``|r|`` (m) and the force's size (N).
    """
    along = p[0] * ub[0] + p[1] * ub[1] + p[2] * ub[2]
    slide = rel[0] * ub[0] + rel[1] * ub[1] + rel[2] * ub[2]
    depth, size = 0.0 * along, 0.0 * along
    for i in range(3):
        r = p[i] - along * ub[i]
        force[i] = -(law[1] * r + law[3] * (rel[i] - slide * ub[i]))
        depth += r * r
        size += force[i] * force[i]
    return np.sqrt(depth), np.sqrt(size)


@kernel(inline="always")
def _frames(y, rest_centre, frames):
    """Into ``frames`` (:class:`Frames`; row ``nb``, the ground, left as it is) from the
    state ``y`` (layout of :class:`penalty_model._Model`).
    """
    centre, vel, rot = frames.centre, frames.vel, frames.rot
    rate, omega = frames.rate, frames.omega
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


@kernel()
def _new_frames(y, nb):
    """Zeroed :class:`Frames` for ``nb`` bodies and the ground (rotation: identity)."""
    vectors = np.zeros((3, nb + 1, 3), dtype=y.dtype)  # one allocation each: the
    matrices = np.zeros((2, nb + 1, 3, 3), dtype=y.dtype)
    rot = matrices[0]
    for i in range(3):
        rot[nb, i, i] = 1.0
    return Frames(centre=vectors[0], vel=vectors[1], rot=rot, rate=matrices[1],
                  omega=vectors[2])


@kernel(inline="always")
def _local(frames, ka, kb, geometry, c, work):
    """Into ``work`` (:class:`Local`: ``p`` ... ``arm_b``), for contact ``c`` between
    bodies ``ka`` and ``kb`` with geometry row ``geometry[c]`` (``s, e, j, u``): the
    offset ``p`` of a's point from b's, the axes ``ea`` (on a) and ``ub`` (on b), the
    relative velocity ``rel`` of a's material point at ``p`` against b's, and the arms
    of the points from a's and b's centres.
    """
    _offset(frames.centre, frames.rot, ka, kb, geometry, c, work.p, work.ea, work.ub,
            work.arm, work.arm_b)
    _relative(frames.vel, frames.rate, frames.omega, ka, kb, geometry, c, work.p, work.rel)


@kernel(inline="always")
def _offset(centre, rot, ka, kb, geometry, c, p, ea, ub, arm_a, arm_b):
    """:func:`_local`'s geometry: ``p``, ``ea``, ``ub`` and the arms (not ``rel``), from
    the frames' ``centre`` and ``rot``. Element by element, and the arrays handed in
    (not a named tuple's fields taken here): in the right-hand side's loop over contacts
    each view or field taken costs its array's reference count twice.
    """
    for i in range(3):  # the arms' components kept in registers
        a0, a1, a2 = rot[ka, i, 0], rot[ka, i, 1], rot[ka, i, 2]
        b0, b1, b2 = rot[kb, i, 0], rot[kb, i, 1], rot[kb, i, 2]
        to_a = a0 * geometry[c, 0] + a1 * geometry[c, 1] + a2 * geometry[c, 2]
        to_b = b0 * geometry[c, 6] + b1 * geometry[c, 7] + b2 * geometry[c, 8]
        ea[i] = a0 * geometry[c, 3] + a1 * geometry[c, 4] + a2 * geometry[c, 5]
        ub[i] = b0 * geometry[c, 9] + b1 * geometry[c, 10] + b2 * geometry[c, 11]
        arm_a[i], arm_b[i] = to_a, to_b
        p[i] = centre[ka, i] + to_a - centre[kb, i] - to_b


@kernel(inline="always")
def _relative(vel, rate, omega, ka, kb, geometry, c, p, rel):
    """:func:`_local`'s relative velocity ``rel``, after :func:`_offset` (``p``), from
    the frames' ``vel``, ``rate`` and ``omega``.
    """
    for i in range(3):
        rel[i] = (vel[ka, i] - vel[kb, i]
                  + rate[ka, i, 0] * geometry[c, 0] + rate[ka, i, 1] * geometry[c, 1]
                  + rate[ka, i, 2] * geometry[c, 2]
                  - rate[kb, i, 0] * geometry[c, 6] - rate[kb, i, 1] * geometry[c, 7]
                  - rate[kb, i, 2] * geometry[c, 8])
    # - omega_b x p
    rel[0] += -1.0 * (omega[kb, 1] * p[2] - omega[kb, 2] * p[1])
    rel[1] += -1.0 * (omega[kb, 2] * p[0] - omega[kb, 0] * p[2])
    rel[2] += -1.0 * (omega[kb, 0] * p[1] - omega[kb, 1] * p[0])


@kernel(inline="always")
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


@kernel(inline="always")
def _push(p, ea, ub, rel, radial, spring, law, d_max, force):
    """Penetration ``d`` and push ``f`` of one contact (eqs. 75-78; a :data:`SPRING`'s
    bilateral law if ``spring``), and its force on body ``a`` into ``force``: radial
    contacts along their normal (:func:`_depth`), faces and springs along ``-ea``.
    """
    d = _depth(p, ea, ub, radial, law[0], force)  # the normal, for now
    return d, _pressed(d, ea, rel, radial, spring, law, d_max, force)


@kernel(inline="always")
def _pressed(d, ea, rel, radial, spring, law, d_max, force):
    """:func:`_push` of a contact whose penetration ``d`` and normal (in ``force``,
    :func:`_depth`'s) are known: its push ``f``, and its force on ``a`` into ``force``.
    """
    rate = force[0] * rel[0] + force[1] * rel[1] + force[2] * rel[2]
    if spring:
        f = law[1] * d + law[3] * rate
    else:
        f = _law(d, rate, law[1], law[2], law[3], d_max)
    for i in range(3):
        force[i] = -f * (force[i] if radial else ea[i])
    return f


@kernel(inline="always")
def _contacts(frames, topology, geometry, laws, d_max, depth, push, on_a, force, moment, work):
    """Add every contact to the bodies' net ``force`` and ``moment``
    (global, about their centres) and write its penetration, push and force on ``a``.
    The geometry of :meth:`penalty._Model.contacts`, one contact at a time, the relative
    velocity and the law only for those that touch; ``work``: the :class:`Local` rows.
    Every field is taken once, before the loop.
    """
    p, ea, ub, rel, arm, arm_b, normal = work.p, work.ea, work.ub, work.rel, work.arm, \
        work.arm_b, work.normal
    centre, vel, rot = frames.centre, frames.vel, frames.rot
    rate, omega = frames.rate, frames.omega
    for c in range(topology.shape[0]):
        ka, kb, kind = topology[c, 0], topology[c, 1], topology[c, 2]
        radial, spring = kind == RADIAL, kind == SPRING
        _offset(centre, rot, ka, kb, geometry, c, p, ea, ub, arm, arm_b)
        if kind == TWIST:  # a pure couple: arm and arm_b are its axes R_a s, R_b j
            depth[c], push[c] = _twist(ea, ub, arm, arm_b, omega, ka, kb, laws[c], normal)
            for i in range(3):
                on_a[c, i] = 0.0
                moment[ka, i] -= push[c] * normal[i]
                moment[kb, i] += push[c] * normal[i]
            continue
        if kind == LINE:
            _relative(vel, rate, omega, ka, kb, geometry, c, p, rel)
            depth[c], push[c] = _line(p, ub, rel, laws[c], normal)
        else:
            depth[c] = _depth(p, ea, ub, radial, laws[c, 0], normal)
            if depth[c].real <= 0.0 and not spring:  # out of touch: no force (eq. 75)
                push[c] = 0.0
                for i in range(3):
                    on_a[c, i] = 0.0
                continue
            _relative(vel, rate, omega, ka, kb, geometry, c, p, rel)
            push[c] = _pressed(depth[c], ea, rel, radial, spring, laws[c], d_max, normal)
        for i in range(3):
            on_a[c, i] = normal[i]  # now the force on a
            force[ka, i] += normal[i]
            force[kb, i] -= normal[i]
            p[i] += arm_b[i]  # the contact point from b's centre
        for i in range(3):  # moment on a: arm x F; on b: -(p + arm_b) x F
            j, k = (i + 1) % 3, (i + 2) % 3
            moment[ka, i] += 1.0 * (arm[j] * normal[k] - arm[k] * normal[j])
            moment[kb, i] += -1.0 * (p[j] * normal[k] - p[k] * normal[j])


@kernel()
def contact_forces(y, model):
    """Per contact: penetration ``d`` (m), push ``f >= 0`` (N), the force on body ``a``
    (global, N); per body the net contact force and moment about its centre (global);
    the :class:`Frames`. ``model``: :class:`ModelArrays`.
    """
    state = new_contact_state(y, model.mass.shape[0], model.topology.shape[0])
    _contacts_into(y, model.rest_centre, model.topology, model.geometry, model.laws,
                   model.d_max, state)
    return state.depth, state.push, state.on_a, state.force, state.moment, state.frames


@kernel()
def new_contact_state(y, nb, m):
    """A zeroed :class:`ContactState` (of ``y``'s type) for ``nb`` bodies and ``m``
    contacts. Made once per run by the integrator: its right-hand sides then allocate
    nothing.
    """
    pushes, loads = np.zeros((2, m), dtype=y.dtype), np.zeros((2, nb + 1, 3), dtype=y.dtype)
    return ContactState(depth=pushes[0], push=pushes[1], force=loads[0], moment=loads[1],
                        on_a=np.zeros((m, 3), dtype=y.dtype),
                        local=new_local(y.dtype), frames=_new_frames(y, nb))


@kernel()
def new_local(dtype):
    """A zeroed :class:`Local` of ``dtype``: the rows of one (9, 3) array."""
    rows = np.zeros((9, 3), dtype=dtype)
    return Local(p=rows[0], ea=rows[1], ub=rows[2], rel=rows[3], arm=rows[4],
                 arm_b=rows[5], normal=rows[6], spare=rows[7], spare_b=rows[8])


@kernel(inline="always")
def _contacts_into(y, rest_centre, topology, geometry, laws, d_max, state):
    """:func:`contact_forces` into ``state`` (:class:`ContactState`), the model's arrays
    handed one by one (:class:`ModelArrays`' fields).
    """
    state.force[:] = 0.0
    state.moment[:] = 0.0
    _frames(y, rest_centre, state.frames)
    _contacts(state.frames, topology, geometry, laws, d_max, state.depth, state.push,
              state.on_a, state.force, state.moment, state.local)


@kernel(inline="always")
def _bodies(t, y, centre, rot, force, moment, mass, inertia, gravity, input_torque,
            load_torque, load_bodies, loads, dy, jw, dw):
    """Newton-Euler equations of every body into ``dy``, given the net contact force and
    moment; the line's torques added here (``force`` and ``moment`` are changed: the
    :class:`ModelArrays` ``loads``, each end's force at its fixed point ``p`` taken
    about the body's current ``centre``); the model's arrays as :class:`ModelArrays`
    names them; ``jw``, ``dw``: (3,) scratch.
    """
    nb = mass.shape[0]
    for e in range(2):  # the input end, then the load end
        k = load_bodies[e]
        h = harmonic(input_torque, t) if e == 0 else harmonic(load_torque, t)
        for i in range(3):  # a shaft's axis is its body frame's second column
            jw[i] = h * loads[e, 4 + i] + abs(h) * loads[e, 7 + i]  # the force F
            force[k, i] += jw[i]
            moment[k, i] += h * loads[e, 0] * rot[k, i, 1]
        for i in range(3):  # (p - centre) x F
            a, b = (i + 1) % 3, (i + 2) % 3
            moment[k, i] += ((loads[e, 1 + a] - centre[k, a]) * jw[b]
                             - (loads[e, 1 + b] - centre[k, b]) * jw[a])
    for k in range(nb):  # element by element: no views of rows in the loop
        q, w = 3 * nb + 4 * k, 10 * nb + 3 * k
        w0, w1, w2 = y[w], y[w + 1], y[w + 2]
        for i in range(3):
            dy[3 * k + i] = y[7 * nb + 3 * k + i]
            dy[7 * nb + 3 * k + i] = force[k, i] / mass[k] + gravity[i]
            jw[i] = inertia[k, i] * y[w + i]
            dw[i] = rot[k, 0, i] * moment[k, 0] + rot[k, 1, i] * moment[k, 1] \
                + rot[k, 2, i] * moment[k, 2]
        dw[0] += -1.0 * (w1 * jw[2] - w2 * jw[1])  # - w x J w
        dw[1] += -1.0 * (w2 * jw[0] - w0 * jw[2])
        dw[2] += -1.0 * (w0 * jw[1] - w1 * jw[0])
        for i in range(3):
            dy[w + i] = dw[i] / inertia[k, i]
        q0, q1, q2, q3 = y[q], y[q + 1], y[q + 2], y[q + 3]
        dy[q] = -0.5 * (q1 * w0 + q2 * w1 + q3 * w2)
        for i in range(3):
            dy[q + 1 + i] = 0.5 * q0 * y[w + i]
        dy[q + 1] += 0.5 * (q2 * w2 - q3 * w1)  # + (q_v x w) / 2
        dy[q + 2] += 0.5 * (q3 * w0 - q1 * w2)
        dy[q + 3] += 0.5 * (q1 * w1 - q2 * w0)


@kernel()
def rhs(t, y, model):
    """Newton-Euler equations of every body at time ``t`` (s), state ``y``:
    ``x' = v``, ``q' = q (0, w) / 2``, ``m v' = F + m g``, ``J w' + w x J w = R^T M``
    (body axes), of the model ``model`` (:class:`ModelArrays`).
    """
    dy = np.empty_like(y)
    _rhs_into(t, y, model, new_contact_state(y, model.mass.shape[0],
                                             model.topology.shape[0]), dy)
    return dy


@kernel(inline="always")
def _rhs_into(t, y, model, state, dy):
    """:func:`rhs` into ``dy``, ``state`` a :class:`ContactState` to fill: the steps of
    :func:`_contacts_into` with its fields taken once here (each level a tuple is
    handed down costs a reference count per array, and this runs at every Newton
    iteration).
    """
    force, moment, frames, local = state.force, state.moment, state.frames, state.local
    force[:] = 0.0
    moment[:] = 0.0
    _frames(y, model.rest_centre, frames)
    _contacts(frames, model.topology, model.geometry, model.laws, model.d_max, state.depth,
              state.push, state.on_a, force, moment, local)
    _bodies(t, y, frames.centre, frames.rot, force, moment, model.mass, model.inertia,
            model.gravity, model.input_torque, model.load_torque, model.load_bodies,
            model.loads, dy, local.spare, local.spare_b)
