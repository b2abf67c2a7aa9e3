"""The penalty simulation's NumPy model (:mod:`.penalty`): the free bodies of the
released line, their contacts, the Newton-Euler right-hand side and its Jacobian.

It is the oracle the compiled kernels (:mod:`.penalty_kernels`) are tested against
and the right-hand side of SciPy's integrators without numba. State: per body its
centre's displacement from rest, a quaternion, its centre's velocity and its angular
velocity in body axes (13 numbers). Every contact's geometry and relative velocity is
linear in the bodies' centres, velocities, rotation matrices and their rates, so one
sparse product evaluates them all (:meth:`Model.contacts`); the Jacobian is taken by
complex steps with the columns of bodies that share no contact neighbour stepped
together. The physics, the contact law (eqs. 75-78) and what each contact is are
:mod:`.penalty`'s docstring and the element kinds' modules.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import sparse
from scipy.spatial.transform import Rotation

from . import penalty_kernels as kernels
from .dynamics import simulate
from .elements import shaft_segments
from .elements.base import Loads, segment_of
from .elements.bodies import frames_of
from .elements.registry import scene_elements
from .equilibrium import body_references, build_operator
from .harmonic import harmonic_law
from .penalty_contact import LINE, RADIAL, SPRING, TWIST
from .scene import Scene

_TAU_S = 1e-3
"""Time scale turning the position tolerance into velocity tolerances."""


def contact_law(d, rate, stiffness, exponent, c_max, d_max):
    """Paper eqs. 75 and 78: ``max(0, K d^n + step(d, 0, 0, d_max, c_max) d')`` for
    ``d > 0``, 0 otherwise (N), vectorized.
    """
    depth = np.maximum(d, 0.0)
    x = np.minimum(depth / d_max, 1.0)
    return np.maximum(stiffness * depth**exponent + c_max * x * x * (3.0 - 2.0 * x) * rate, 0.0)


def _quadratic_rotation() -> np.ndarray:
    """(16, 10): the products ``q_i q_j`` of a quaternion (w, x, y, z) to the nine
    entries of ``|q|^2 R(q) = (w^2 - v.v) I + 2 v v^T + 2 w [v]x`` (row-major) and
    ``|q|^2``: ``R`` of a quaternion of any norm in two array operations.
    """
    m = np.zeros((4, 4, 10))
    entries = {
        0: {(0, 0): 1, (1, 1): 1, (2, 2): -1, (3, 3): -1},
        1: {(1, 2): 2, (0, 3): -2}, 2: {(1, 3): 2, (0, 2): 2},
        3: {(1, 2): 2, (0, 3): 2}, 4: {(0, 0): 1, (1, 1): -1, (2, 2): 1, (3, 3): -1},
        5: {(2, 3): 2, (0, 1): -2}, 6: {(1, 3): 2, (0, 2): -2}, 7: {(2, 3): 2, (0, 1): 2},
        8: {(0, 0): 1, (1, 1): -1, (2, 2): -1, (3, 3): 1},
        9: {(0, 0): 1, (1, 1): 1, (2, 2): 1, (3, 3): 1},
    }
    for column, terms in entries.items():
        for (i, j), value in terms.items():
            m[i, j, column] = value
    return m.reshape(16, 10)


def _quaternion_rate() -> np.ndarray:
    """(12, 4): the products ``q_i w_j`` to ``q' = q (0, w) / 2`` (w in body axes)."""
    m = np.zeros((4, 3, 4))
    for j in range(3):
        m[j + 1, j, 0] = -0.5  # w' = -x . w / 2
        m[0, j, j + 1] = 0.5  # v' = (s w + v x w) / 2
    for i, j, k in ((0, 1, 2), (1, 2, 0), (2, 0, 1)):
        m[i + 1, j, k + 1] = 0.5
        m[j + 1, i, k + 1] = -0.5
    return m.reshape(12, 4)


_ROTATION = _quadratic_rotation()
_QUATERNION_RATE = _quaternion_rate()


_NEXT, _LAST = np.array([1, 2, 0]), np.array([2, 0, 1])


def _cross(a: np.ndarray, b: np.ndarray, axis: int = 0) -> np.ndarray:
    """``a x b`` with the components along ``axis`` (cheaper than ``np.cross`` here)."""
    return (a.take(_NEXT, axis) * b.take(_LAST, axis)
            - a.take(_LAST, axis) * b.take(_NEXT, axis))


_FEATURES = 27
"""Per body, the columns of the contact map: centre, velocity, rotation matrix and its
rate (row-major), angular velocity, all global."""


@dataclass(frozen=True)
class _Contacts:
    """Every contact, between a body ``a`` and a body ``b`` (the ground: index = number
    of bodies).

    Body ``a`` carries the point ``s`` and the axis ``e``, body ``b`` the point ``j`` and
    the axis ``u``, in body coordinates (the ground's: global). ``radial`` is the
    contact's kind (:mod:`.penalty_contact`'s codes): ``RADIAL``: ``d`` is the distance
    of the point from ``b``'s axis line in ``a``'s cross-section, minus ``offset`` (the
    clearance), the force normal to ``e``; ``FACE``: ``d`` is the point's height over
    ``j`` along ``u`` (outward) minus ``offset``, the force along ``-e``; both
    unilateral, ``stiffness``, ``exponent``, ``c_max`` of eqs. 75-78. ``SPRING``: a
    face's ``d`` and force, bilateral and linear, ``f = K d + c_max d'``. ``TWIST``: a
    torsion spring between the two bodies, ``s``, ``e`` two axes on ``a`` and ``j``,
    ``u`` two on ``b`` (their points unused): ``d = theta = (e.u - s.j) / 2`` (global
    vectors; the sine of the relative angle about ``e x u`` for a rotation about it),
    a pure couple ``-(K theta + c_max theta') g`` on ``a`` and its opposite on ``b``,
    ``g = (e x u - s x j) / 2`` (``d theta`` per rotation of ``a``, so the couple
    derives from ``K theta^2 / 2``) and ``theta' = g . (omega_a - omega_b)``.
    ``LINE``: ``a``'s point ``s`` held on ``b``'s line through ``j`` along the unit
    ``u`` (``e`` unused), both ways and linear: ``r = w - (w.u) u`` its offset from the
    line (``w`` the points' offset), ``d = |r|``, the force on ``a`` ``-(K r + c_max
    (v - (v.u) u))`` (``v`` the points' relative velocity), ``f`` its size: free
    along the line.
    """

    a: np.ndarray
    b: np.ndarray
    s: np.ndarray
    e: np.ndarray
    j: np.ndarray
    u: np.ndarray
    offset: np.ndarray
    radial: np.ndarray
    stiffness: np.ndarray
    exponent: np.ndarray
    c_max: np.ndarray


class Model:
    """Bodies (the operator's: shaft bodies, then cross-pins), contacts and the
    right-hand side.

    The contacts are built from the equilibrium operator's links at the start by
    ``contact_rows(model, damping_length_unit_m)`` (:func:`.penalty._contact_rows`: each
    link's kind adds its own; with each link's contacts, ``parts``, and the contacts
    whose body ``a`` is the link's other body, ``flipped``), so every element the
    operator takes, this model takes; the forces it reports are the operator's columns
    (:meth:`link_values`).
    """

    def __init__(self, scene: Scene, damping_length_unit_m: float, contact_rows):
        motion = simulate(scene, [scene.time.start_s])
        op = build_operator(motion)
        segments = shaft_segments(scene)
        ns, nb = len(segments), len(op.bodies)
        self.scene, self.motion, self.operator = scene, motion, op
        self.n_shafts, self.n_bodies, self.segments = ns, nb, segments
        self.n_state, self.n_calls = 13 * nb, 0
        cp = scene.crosspin
        self.mass = np.array([g.fraction * scene.shafts[g.shaft].mass_kg for g in segments]
                             + [cp.mass_kg] * (nb - ns))
        self.inertia = np.array([g.fraction * np.array(scene.shafts[g.shaft].inertia_kg_m2)
                                 for g in segments] + [cp.inertia_kg_m2] * (nb - ns))
        self.rest_centre = body_references(motion.geometry, segments)
        self.gravity = np.array(scene.gravity_m_s2) if scene.has("gravity") else np.zeros(3)
        self.start_frames = self._start_frames()
        self.load_bodies, self.loads = self._line_loads()
        rows, self.parts, self.flipped = contact_rows(self, damping_length_unit_m)
        c = self.c = _Contacts(*(np.array(column) for column in zip(*rows)))
        self.d_max = scene.contact.damping_full_depth_m
        self.contact_map, self.contact_bias = self._contact_map()
        # the contact force acts +F on a, -F on b; the ground's row is dropped
        m = len(c.a)
        signed = np.concatenate([np.eye(nb + 1)[:nb, c.a], -np.eye(nb + 1)[:nb, c.b]], axis=1)
        self.gather_force, self.gather_moment = signed[:, :m] + signed[:, m:], signed
        self.links = np.eye(nb, dtype=bool)
        inner = c.b < nb
        self.links[c.a[inner], c.b[inner]] = self.links[c.b[inner], c.a[inner]] = True
        self.jacobian_columns = self._colour()
        self.arrays = self._packed(scene)

    def _start_frames(self) -> np.ndarray:
        """(bodies, 3, 3): each body's frame at the start (body to global). Shaft bodies:
        columns (n1, axis, n3) turned by the shaft's angle, so a shaft's axis is its
        second body axis; cross-pins (of the joints that have one): (e1, e2, e3).
        """
        geo, kin = self.motion.geometry, self.motion.kin
        frames = []
        for g in self.segments:
            a = geo.axes[g.shaft]
            rest = np.column_stack([np.cross(a, geo.plane_normal), a, geo.plane_normal])
            frames.append(Rotation.from_rotvec(kin.phi[g.shaft, 0] * a).as_matrix() @ rest)
        frames += [np.column_stack([kin.e1[j, 0], kin.e2[j, 0], kin.e3[j, 0]])
                   for j in np.flatnonzero(kin.pinned)]
        return np.array(frames)

    def _line_loads(self) -> tuple[np.ndarray, np.ndarray]:
        """Where and how the line's input and load torques act (:class:`ModelArrays`'
        ``load_bodies`` and ``loads``): as pure torques about the first body's axis and
        against the last's, or, at an end whose shaft holds an element of a ``Loads``
        kind (a gear mesh), as that element's force (:meth:`~.elements.base.Loads.load`)
        on the body holding it, as in the rigid model's load terms. The mesh point and
        the force's directions are the rigid model's at rest, fixed in space: the mating
        gear is held by its own bearings, and the shafts' axes move by micrometres and
        microradians here. The force is ``F(T) = T lin + |T| abs``, the kind's loads
        being proportional to the torque's size with a part that turns with its sign
        (the tangential and a helix's axial force) and one that does not (the separating
        force): ``lin`` and ``abs`` from ``F(1)`` and ``F(-1)``. ``T`` is the torque
        the mesh takes off its shaft, the load torque on the last shaft and minus the
        input torque on the first (``sign``).
        """
        scene, geo = self.scene, self.motion.geometry
        last = len(scene.shafts) - 1
        bodies = np.array([0, self.n_shafts - 1], np.int64)
        loads = np.zeros((2, 10))
        loads[:, 0] = 1.0, -1.0  # torques: the input's with the rotation, the load's against
        for kind, element, k, _ in scene_elements(scene):
            if not isinstance(kind, Loads) or k not in (0, last):
                continue
            end, sign = (0, -1.0) if k == 0 else (1, 1.0)
            point, force = kind.load(element, np.array([1.0, -1.0]), frames_of(geo)[k],
                                     geo.centres[k])
            bodies[end] = segment_of(self.segments, k, element.offset_m)
            loads[end] = (0.0, *point, *(sign * (force[0] - force[1]) / 2),
                          *((force[0] + force[1]) / 2))
        return bodies, loads

    def line_loads(self, t: float, centre: np.ndarray, rot: np.ndarray
                   ) -> tuple[np.ndarray, np.ndarray]:
        """The line's torques at ``t`` (s) as forces (bodies, 3, k) and moments about the
        bodies' current centres (bodies, 3, k), global (N, N m), from the bodies'
        centres (bodies, 3, k) and rotations (bodies, 3, 3, k) (:meth:`_line_loads`).
        """
        force, moment = np.zeros(centre.shape, centre.dtype), np.zeros(centre.shape,
                                                                          centre.dtype)
        torques = self.scene.input_torque(t), self.scene.load_torque(t)
        for body, load, h in zip(self.load_bodies, self.loads, torques):
            f = h * load[4:7] + abs(h) * load[7:10]
            force[body] += f[:, None]
            moment[body] += (h * load[0] * rot[body, :, 1]
                             + _cross(load[1:4, None] - centre[body], f[:, None]))
        return force, moment

    def local(self, body: int, point: np.ndarray | None = None,
              vector: np.ndarray | None = None) -> np.ndarray:
        """A global point or vector at the start in ``body``'s coordinates (the ground,
        index ``n_bodies``: global).
        """
        if body == self.n_bodies:
            return point if vector is None else vector
        frame = self.start_frames[body]
        return frame.T @ (point - self.rest_centre[body] if vector is None else vector)

    def _packed(self, scene: Scene) -> kernels.ModelArrays:
        """The model as the compiled kernels take it (:mod:`penalty_kernels`), fields by
        name; each array contiguous and of one dtype (one compiled signature).
        """
        c = self.c

        def floats(*columns):
            return np.ascontiguousarray(np.column_stack(columns), dtype=float)

        return kernels.ModelArrays(
            mass=np.array(self.mass, float),
            inertia=floats(self.inertia), rest_centre=floats(self.rest_centre),
            topology=np.ascontiguousarray(np.column_stack([c.a, c.b, c.radial]), np.int64),
            geometry=floats(c.s, c.e, c.j, c.u),
            laws=floats(c.offset, c.stiffness, c.exponent, c.c_max),
            gravity=np.array(self.gravity, float),
            input_torque=np.array(harmonic_law(scene.input_torque), float),
            load_torque=np.array(harmonic_law(scene.load_torque), float),
            load_bodies=np.ascontiguousarray(self.load_bodies, np.int64),
            loads=np.ascontiguousarray(self.loads, float),
            d_max=float(self.d_max))

    def _contact_map(self) -> tuple[sparse.csr_matrix, np.ndarray]:
        """The sparse linear map (and constant) from the bodies' :data:`_FEATURES` to,
        per contact, 7 vectors (7, 3, m): the offset ``w`` of ``a``'s point ``p`` from
        ``b``'s point ``J``, the axes ``e`` (on ``a``) and ``u`` (on ``b``), the velocity
        of ``a``'s material point at ``p`` less that of ``b``'s at ``J``, the arm of ``p``
        from ``a``'s centre, the arm of ``J`` from ``b``'s centre, ``b``'s angular
        velocity. Every one is linear in a body's centre, velocity, rotation ``R`` and
        rate ``R'`` (``R s``, ``R' s``), so one sparse product evaluates them all.
        """
        c, nb = self.c, self.n_bodies
        m = len(c.a)
        entries: dict[tuple[int, int], float] = {}
        bias = np.zeros((7, 3, m))

        def put(quantity, i, k, body, feature, value):
            key = ((quantity * 3 + i) * m + k, _FEATURES * body + feature)
            entries[key] = entries.get(key, 0.0) + value

        for k, (a, b) in enumerate(zip(c.a, c.b)):
            for i in range(3):
                put(0, i, k, a, i, 1.0)  # w = c_a + R_a s - c_b - R_b j
                put(3, i, k, a, 3 + i, 1.0)  # v_a + R'_a s - v_b - R'_b j
                for j in range(3):
                    put(0, i, k, a, 6 + 3 * i + j, c.s[k, j])
                    put(1, i, k, a, 6 + 3 * i + j, c.e[k, j])
                    put(3, i, k, a, 15 + 3 * i + j, c.s[k, j])
                    put(4, i, k, a, 6 + 3 * i + j, c.s[k, j])
                if b == nb:  # the ground: R = I, at rest
                    bias[0, i, k], bias[2, i, k], bias[5, i, k] = -c.j[k, i], c.u[k, i], c.j[k, i]
                    continue
                put(0, i, k, b, i, -1.0)
                put(3, i, k, b, 3 + i, -1.0)
                put(6, i, k, b, 24 + i, 1.0)
                for j in range(3):
                    put(0, i, k, b, 6 + 3 * i + j, -c.j[k, j])
                    put(2, i, k, b, 6 + 3 * i + j, c.u[k, j])
                    put(3, i, k, b, 15 + 3 * i + j, -c.j[k, j])
                    put(5, i, k, b, 6 + 3 * i + j, c.j[k, j])
        rows, cols = np.array(list(entries)).T
        matrix = sparse.csr_matrix((list(entries.values()), (rows, cols)),
                                   shape=(21 * m, _FEATURES * nb))
        return matrix, bias.reshape(-1, 1)

    # ------------------------------------------------------------------ state layout

    def initial_state(self) -> np.ndarray:
        """Rest positions (cross-pins centred in their clearances), orientations and
        speeds of the rigid model at the start, centres at rest.
        """
        m, nb = self.motion, self.n_bodies
        rates = [m.omega[g.shaft, 0] * m.geometry.axes[g.shaft] for g in self.segments]
        rates += list(m.pin_omega[np.flatnonzero(m.kin.pinned), 0])
        return np.concatenate([
            np.zeros(3 * nb),
            Rotation.from_matrix(self.start_frames).as_quat()[:, [3, 0, 1, 2]].ravel(),
            np.zeros(3 * nb),
            np.concatenate([f.T @ w for f, w in zip(self.start_frames, rates)]),
        ])

    # ------------------------------------------------------------------ contacts

    def bodies(self, y: np.ndarray):
        """State columns ``y`` (n, k) as (bodies, ., k) arrays: displacement, quaternion,
        velocity, body-axis rate, rotation matrix (bodies, 3, 3, k) and global angular
        velocity.
        """
        nb, k = self.n_bodies, y.shape[1]
        u, q = y[:3 * nb].reshape(nb, 3, k), y[3 * nb:7 * nb].reshape(nb, 4, k)
        v, w = y[7 * nb:10 * nb].reshape(nb, 3, k), y[10 * nb:].reshape(nb, 3, k)
        quadratic = _ROTATION.T @ (q[:, :, None] * q[:, None]).reshape(nb, 16, k)
        rot = (quadratic[:, :9] / quadratic[:, 9:]).reshape(nb, 3, 3, k)
        return u, q, v, w, rot, (rot * w[:, None]).sum(axis=2)

    def contacts(self, bodies: tuple[np.ndarray, ...]):
        """From :meth:`bodies`: penetration ``d`` (m, k), push ``f`` (m, k), force on
        body ``a`` (3, m, k), the arms of the contact point from ``a``'s and ``b``'s
        centres (3, 2m, k) and the pure couple on ``a`` (3, m, k; a ``TWIST``'s, zero
        for the others). A ``TWIST``'s ``d`` is its ``theta`` (rad) and ``f`` its
        moment (N m) (:class:`_Contacts`).
        """
        u, _, v, w, rot, omega = bodies
        c, nb, k = self.c, self.n_bodies, u.shape[-1]
        rate = _cross(rot, w[:, None], axis=2)  # R' = R [w]x: each row of R times w
        features = np.concatenate([self.rest_centre[:, :, None] + u, v, rot.reshape(nb, 9, k),
                                   rate.reshape(nb, 9, k), omega], axis=1)
        vectors = self.contact_map @ features.reshape(-1, k) + self.contact_bias
        offset, e, axis, moving, arm, arm_j, omega_b = vectors.reshape(7, 3, -1, k)
        relative = moving - _cross(omega_b, offset)
        # radial: the bore axis meets the trunnion's cross-section plane at p - r
        kind = c.radial[:, None]
        radial = kind == RADIAL
        across = np.where(radial, (axis * e).sum(0), 1.0)  # a twist's axes are normal
        r = offset - ((offset * e).sum(0) / across) * axis
        rho = np.sqrt((r * r).sum(0))
        normal = np.where(radial, r / np.maximum(rho, 1e-300), axis)
        d = np.where(radial, rho, (offset * axis).sum(0)) - c.offset[:, None]
        rate = (normal * relative).sum(0)
        stiffness, c_max = c.stiffness[:, None], c.c_max[:, None]
        f = contact_law(d, rate, stiffness, c.exponent[:, None], c_max, self.d_max)
        f = np.where(kind == SPRING, stiffness * d + c_max * rate, f)
        # TWIST: e, u, arm (= R_a s) and arm_j (= R_b j) are its four axes
        twist = kind == TWIST
        omega_a = np.concatenate([omega, np.zeros((1, 3, k))])[c.a].transpose(1, 0, 2)
        theta = 0.5 * ((e * axis).sum(0) - (arm * arm_j).sum(0))
        g = 0.5 * (_cross(e, axis) - _cross(arm, arm_j))
        moment = stiffness * theta + c_max * (g * (omega_a - omega_b)).sum(0)
        d, f = np.where(twist, theta, d), np.where(twist, moment, f)
        force = np.where(twist, 0.0, -f * np.where(radial, normal, e))
        couple = np.where(twist, -moment * g, 0.0)
        # LINE: a's point held on b's line through J along u (= axis, unit), both ways
        line = kind == LINE
        held = offset - (offset * axis).sum(0) * axis
        pull = -(stiffness * held + c_max * (relative - (relative * axis).sum(0) * axis))
        force = np.where(line, pull, force)
        d = np.where(line, np.sqrt((held * held).sum(0)), d)
        f = np.where(line, np.sqrt((pull * pull).sum(0)), f)
        return d, f, force, np.concatenate([arm, offset + arm_j], axis=1), couple

    def link_values(self, force: np.ndarray, arms: np.ndarray, couple: np.ndarray,
                    rot: np.ndarray) -> np.ndarray:
        """The operator's columns (n, k) from the contacts' forces on body ``a`` (3, m, k),
        their arms from ``a``'s centre (3, 2m, k), their pure couples on ``a`` (3, m, k)
        and the bodies' rotations: per link, the net force of its contacts on the link's
        body and their net moment about the link's point, along each column's direction
        (turning with the cross-pin for a link in the pin's frame, fixed otherwise, as
        the operator's columns).
        """
        op, k, m = self.operator, force.shape[-1], len(self.c.a)
        # on the link's body: a flipped contact's opposite force, at the point from b's centre
        sign = np.where(self.flipped, -1.0, 1.0)[:, None]
        on_body, turning = force * sign, couple * sign
        at = np.where(self.flipped[:, None], arms[:, m:], arms[:, :m])
        out = np.empty((len(op.names), k))
        for link, rows in zip(op.contacts, self.parts):
            body = link.body
            net = on_body[:, rows].sum(axis=1)
            point = self.local(body, op.points[0, link.columns[0]])
            lever = np.einsum("ijk,j->ik", rot[body], point)
            moment = (_cross(at[:, rows] - lever[:, None], on_body[:, rows]).sum(axis=1)
                      + turning[:, rows].sum(axis=1))
            for c in link.columns:
                direction = op.directions[0, c]
                if link.frame == "pin":
                    direction = np.einsum("ijk,j->ik", rot[body],
                                          self.local(body, vector=direction))
                else:
                    direction = np.broadcast_to(direction[:, None], (3, k))
                pure = np.isnan(op.points[0, c, 0])
                out[c] = ((moment if pure else net) * direction).sum(axis=0)
        return out

    # ------------------------------------------------------------------ dynamics

    def rhs(self, t: float, y: np.ndarray) -> np.ndarray:
        """Newton-Euler equations of every body, batched over the columns of ``y``
        (n, k): ``m v' = F + m g``, ``J w' + w x J w = R^T M`` (body axes), ``x' = v``,
        ``q' = q (0, w) / 2``.
        """
        self.n_calls += 1
        bodies = self.bodies(y)
        u, q, v, w, rot, _ = bodies
        nb, k = self.n_bodies, y.shape[1]
        _, _, f, arms, couple = self.contacts(bodies)
        applied, turning = self.line_loads(t, self.rest_centre[:, :, None] + u, rot)
        force = self.gather_force @ f + applied.transpose(1, 0, 2)
        moment = (self.gather_moment @ _cross(arms, np.concatenate([f, f], axis=1))
                  + self.gather_force @ couple + turning.transpose(1, 0, 2))
        torque = (rot * moment.transpose(1, 0, 2)[:, :, None]).sum(axis=1)
        inertia = self.inertia[:, :, None]
        dw = (torque - _cross(w, inertia * w, axis=1)) / inertia
        dq = _QUATERNION_RATE.T @ (q[:, :, None] * w[:, None]).reshape(nb, 12, k)
        dv = force.transpose(1, 0, 2) / self.mass[:, None, None] + self.gravity[:, None]
        return np.concatenate([v.reshape(-1, k), dq.reshape(-1, k), dv.reshape(-1, k),
                               dw.reshape(-1, k)])

    def _colour(self) -> tuple[np.ndarray, np.ndarray]:
        """Jacobian colouring: for each state, the column of the vectorized difference
        call that perturbs it, and the sparsity (rows x states).

        Bodies go into groups that no contact links at distance <= 2 (greedy, along the
        chain shaft, pin, shaft, ...: three groups for a chain); perturbing one group's
        states changes disjoint rows of the right-hand side.
        """
        nb, ns = self.n_bodies, self.n_shafts
        reach = (self.links.astype(int) @ self.links.astype(int)) > 0
        chain = [body for k in range(ns) for body in (k, ns + k) if body < nb]
        groups: list[list[int]] = []
        for body in chain:
            for g in groups:
                if not reach[body, g].any():
                    g.append(body)
                    break
            else:
                groups.append([body])
        colour = np.empty(nb, dtype=int)
        for g, members in enumerate(groups):
            colour[members] = g
        # state layout: 3 displacement, 4 quaternion, 3 velocity, 3 rate per body
        body_of = np.concatenate([np.repeat(np.arange(nb), size) for size in (3, 4, 3, 3)])
        local = np.concatenate([np.tile(np.arange(size), nb) + first
                                for size, first in ((3, 0), (4, 3), (3, 7), (3, 10))])
        return 13 * colour[body_of] + local, self.links[body_of][:, body_of]

    def tolerances(self, atol_m: float) -> tuple[np.ndarray, np.ndarray]:
        """Absolute tolerances and the Jacobian's complex steps per state component:
        ``atol_m`` on displacements and quaternions, ``atol_m / 0.001 s`` on speeds.
        """
        nb = self.n_bodies
        atol = np.concatenate([np.full(7 * nb, atol_m), np.full(6 * nb, atol_m / _TAU_S)])
        return atol, kernels.COMPLEX_STEP * atol / atol_m

    def jacobian(self, t: float, y: np.ndarray, step: np.ndarray) -> np.ndarray:
        """Complex-step Jacobian (``step``: imaginary step per state), all coloured groups
        in one vectorized call: exact to round-off, as :func:`penalty_kernels.jacobian`.
        """
        column, sparsity = self.jacobian_columns
        shifts = np.zeros((self.n_state, column.max() + 1))
        shifts[np.arange(self.n_state), column] = step
        f = self.rhs(t, y[:, None] + 1j * shifts)
        return np.where(sparsity, f.imag[:, column] / step, 0.0)

    # ------------------------------------------------------------------ compiled

    def rhs_compiled(self, t: float, y: np.ndarray) -> np.ndarray:
        """:meth:`rhs` at one state by the compiled kernel."""
        self.n_calls += 1
        return kernels.rhs(t, y, self.arrays)

    def jacobian_compiled(self, t: float, y: np.ndarray) -> np.ndarray:
        """:meth:`jacobian` by the compiled kernel (exact, by the chain rule)."""
        return kernels.jacobian(t, y, self.arrays)
