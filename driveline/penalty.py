"""Penalty-contact simulation of the released drive line: the paper's ADAMS model.

Wang & Qi check their method against an ADAMS model in which every joint is released
and replaced by contact forces with clearances (DESIGN §1). Here the shafts and the
cross-pins are free rigid bodies (6 DOF each) held only by contact forces of the form
of the paper's eqs. 75-78,

    f = K d^n + step(d, 0, 0, d_max, c_max) d'       for d > 0, else 0       (75)
    step = c_max (d/d_max)^2 (3 - 2 d/d_max)  (0 < d < d_max),  c_max beyond  (78)

with ``d`` the penetration beyond the clearance and ``d'`` its rate; a contact only
pushes (``f >= 0``). The contacts:

Each contact is added by its element's kind (:mod:`.elements`; the kinds' modules
hold these laws); those of the built-in kinds:

- **trunnion in its bore** (4 per cross-pin): ``d`` = distance of the trunnion's axis
  point at ``±hs`` from the yoke's bore axis, measured in the trunnion's cross-section,
  minus ``rb - rs``; the force acts along that offset, normal to the trunnion axis,
  at that point. ``K`` from :func:`~cardan_forces.driveline.contact.hertz_stiffness` (eqs. 76-77),
  ``n`` = the scene's exponent (1.5);
- **end face** (4 per cross-pin): ``d`` = the trunnion end's (``±ht``) distance along
  the bore axis beyond the housing bottom at ``hb``; the force acts along the trunnion
  axis at the end point; the same ``K``, ``n``;
- **bearing** (per bearing point of a shaft, against its fixed ground position): radially
  as a trunnion with clearance ``bearing_clearance_m``; a locating bearing also axially
  both ways with the same clearance, a floating one not (as in the rigid model); linear,
  ``K = bearing_stiffness_N_m``, ``n = 1``;
- **slip joint** (frictionless spline between the two segments of its shaft): shear and
  bending by two radial contacts without clearance a pitch radius either side of the
  joint, torque by two teeth at the pitch radius; no axial contact; linear, as stiff as
  a bearing (:mod:`.elements.slip`).

Every contact is built from the equilibrium operator's links (where each column acts,
along what), so the bodies are the operator's (a shaft cut by a slip joint is two
segments, each with its share of the shaft's mass and inertias).

So each reported force is exactly one of the equilibrium operator's columns
(:mod:`cardan_forces.driveline.equilibrium`) at the current configuration: radial forces normal to
the pin's own trunnion axis, end-face forces along it, all on the cross-pin's axis.

**Damping units.** "c_max = 1 % of K" (the paper, after ADAMS) is unit-free only for
``n = 1``. We read it in ADAMS's default mm-N-s units, the units of the paper's Table 2
and of ``d_max = 0.01 mm``: ``c_max = fraction * K * L^(n - 1)`` with ``L = 1 mm``
(:data:`DAMPING_LENGTH_UNIT_M`). For the paper's joints (K = 4.6e10 N/m^1.5) that is
1.5e7 N s/m; the SI reading would be sqrt(1000) = 31.6 times larger (and drives the
integrator to 1e-9 s steps). Bearings (``n = 1``): ``0.01 s * K`` either way.

**What to expect** on ``paper-penalty``: from rest the input shaft turns through the
play (~0.07 s) before it meets the rest of the line; the impacts make the light
intermediate shaft (J2 = 0.0152 kg m^2) rattle, nearly elastically since the step
damping vanishes at small depths. Twice a revolution the cross-pins' axial load
reverses and they cross their 1.5 mm axial play. These impacts, not the stiffness, set
the step size (~10 us) and the cost.

**Bodies.** Shafts: the scene's mass and principal inertias (J2 about the axis).
Cross-pins: always the scene's ``[crosspin]`` mass and inertia about (e1, e2, e3) (a
free body needs mass), whether or not the scene lists ``crosspin_inertia``. Gravity
when the scene has it; the input torque about the input shaft's current axis, the load
torque against the output shaft's. The simulation is dynamic whatever the effects.

**State and integrator.** Per body: centre displacement from its rest position, a
quaternion (body to global, renormalized where used), centre velocity, angular
velocity in body axes; 13 numbers per body. Quaternions: no singularity for the
shafts' unbounded spin, a polynomial right-hand side, and no re-basing (a rotation-
vector increment would restart the integrator). Tolerances are absolute (``rtol`` at
its floor): the O(1) quaternion components are controlled like positions, to
``atol_m`` times 1 m, not to ``rtol`` times 1, since penetrations are micrometres. The
problem is stiff (a 0.05 kg pin on a contact of ~1e8 N/m with up to 1.5e7 N s/m), so
it is integrated by an implicit method of the BDF family (that of ADAMS's GSTIFF): by
default ``BDF-numba``, SciPy's variable-order BDF compiled with the right-hand side and
its Jacobian (:mod:`~cardan_forces.driveline.penalty_kernels`: a few microseconds per
state instead of ~0.1 ms of array calls, and no Python between steps); without numba,
SciPy's LSODA (ODEPACK's, stepped in Fortran) on the NumPy model here
(``kernel="numpy"``). LSODA, SciPy's ``BDF`` and ``Radau`` take either kernel on
request, calling it back through Python. Both Jacobians are exact to
round-off, where a forward difference loses half the digits: the compiled one by the
chain rule (each contact's force law, the geometry and the Newton-Euler equations
differentiated by hand), the NumPy one by complex steps with the columns
of bodies that share no contact neighbour stepped together (shaft, pin, shaft, ...
along the chain: 3 groups of 13 columns); the tests hold the two to each other. The
NumPy right-hand side evaluates every contact's geometry and relative
velocity with one sparse product, since all are linear in the bodies' centres,
velocities, rotation matrices and their rates. LSODA runs through ``odeint`` (its
stepping loop in Fortran); ``BDF`` and ``Radau`` are stepped as ``solve_ivp`` does
(:mod:`~cardan_forces.driveline.penalty_integrators`). Either way progress is reported
and a failure turned into a status.

**Cost.** The step count is set by the impacts (~10 us steps while a cross-pin
rattles, about 85,000 steps per simulated second on ``paper-penalty`` with the
compiled BDF, 136,000 with LSODA); per step about two right-hand sides, a Jacobian
every 7 steps (after a Newton iteration fails: in the first 2 s of ``paper-penalty``
5 failures in 6 began with the same contacts in touch as the Jacobian, so it is the
forces of the touching contacts, stiff and damped, that outrun it, more than contacts
opening or closing) and a factorization every 3 (after a Jacobian or a change of step
by more than 30 %). Nearly every step's error test is a cross-pin's angular velocity; where the
pins slide on eq. 75's ``f = 0`` while pressed, the clamp's kink makes steps fail.
``propshaft`` (8 bodies, 104 states) takes twice the steps (mean 4.5 us): the
end faces of its cross-pins carry the axial load of the slip joint's segments, pressed
by ~0.5 um, and eq. 75's ``f >= 0`` switches them on and off while still pressed
(100 times in 20 ms), whenever the damping term outweighs the spring's ~16 N. Its
Jacobian is exact (tested as ``paper``'s); the spline's contacts do not switch.

**Why one module this long.** The NumPy model (bodies, contacts from the operator's
links, right-hand side and Jacobian) is the oracle the compiled kernels are tested
against, and it is read as one piece with this docstring's physics; the integrator
drivers are apart (:mod:`~cardan_forces.driveline.penalty_integrators`).
"""

from __future__ import annotations

import sys
import time as _time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy import sparse
from scipy.integrate import BDF, LSODA, Radau
from scipy.spatial.transform import Rotation

from . import penalty_kernels as kernels
from .compiled import harmonic_law
from .contact import hertz_stiffness
from .dynamics import simulate
from .elements import shaft_segments
from .equilibrium import body_references, build_operator
from .penalty_integrators import RTOL, Marks, run_compiled, run_odeint, run_stepped, timed
from .scene import Scene, SceneError

COMPILED = "BDF-numba"
DAMPING_LENGTH_UNIT_M = 1e-3
"""Length unit in which ``c_max = fraction * K`` is read (ADAMS's mm; see the module)."""

METHODS = {"BDF": BDF, "Radau": Radau, "LSODA": LSODA, COMPILED: None}
"""Integrators: SciPy's (stepped from Python or, LSODA, from Fortran, calling the
right-hand side back through Python) and ``BDF-numba``, the same BDF as SciPy's
compiled end to end around the compiled kernels (:mod:`penalty_kernels`)."""
FALLBACK = "LSODA"
"""The integrator of ``method="auto"`` without numba, and where the compiled one fails
(its message then says both)."""
KERNELS = ("numba", "numpy")
"""Right-hand sides: compiled (:mod:`penalty_kernels`) or the NumPy array model."""

_TAU_S = 1e-3
"""Time scale turning the position tolerance into velocity tolerances."""


@dataclass(frozen=True)
class PenaltyResult:
    """The penalty simulation sampled at ``t`` (s).

    ``omega[k]``: shaft ``k``'s angular velocity about its own current axis (rad/s).
    ``forces``: the equilibrium operator's 36 names and sign conventions (N): bearing
    forces on the shafts in the global frame; joint contact forces on the cross-pins in
    each pin's own current frame (``e1`` its driving trunnion axis, ``e2`` its driven
    one, ``e3 = e1 x e2``); end faces as pushes >= 0. ``penetration``: the deepest
    contact penetration (m) at each instant (negative: no contact). ``status`` is 0 on
    success, -1 on failure (then ``message`` says why and samples after the failure
    are NaN). ``nfev`` counts right-hand-side evaluations (a vectorized Jacobian call
    counts as one), ``njev`` Jacobians, ``nlu`` LU factorizations, ``nsteps`` steps.
    ``kernel``: ``numba`` (compiled right-hand side and Jacobian) or ``numpy``;
    ``rhs_s`` and ``jacobian_s``: wall time spent in them where the integrator calls
    them from Python (the rest of ``wall_s`` is the integrator's own work and the
    set-up; NaN under ``BDF-numba``, whose calls are not timed one by one); ``cpu_s``:
    the process's CPU time over ``wall_s`` (below it where other jobs share the cores).
    ``compile_s``: loading (or, the first time, compiling) the compiled code, before
    ``wall_s`` starts and not part of it (0 once loaded in this process).
    """

    scene: Scene
    t: np.ndarray
    omega: np.ndarray
    forces: dict[str, np.ndarray]
    penetration: np.ndarray
    wall_s: float
    nfev: int
    njev: int
    nlu: int
    nsteps: int
    method: str
    status: int
    message: str
    kernel: str = "numpy"
    rhs_s: float = np.nan
    jacobian_s: float = np.nan
    cpu_s: float = 0.0
    compile_s: float = 0.0

    @property
    def success(self) -> bool:
        return self.status == 0

    @property
    def integrator(self) -> str:
        """Who integrated: ``numba-BDF`` (compiled end to end) or ``scipy-<method>``."""
        return "numba-BDF" if self.method == COMPILED else f"scipy-{self.method}"

    def cost_text(self) -> str:
        """Where the simulation's time went, in one sentence for a report: seconds per
        simulated second (wall and CPU), steps, and per step what was measured; the
        compiled code's loading stated apart (it is not in ``wall_s``).
        """
        span = max(float(self.t.max() - self.t.min()), 1e-12)
        steps = max(self.nsteps, 1)
        text = (f"{self.wall_s:.1f} s wall ({self.cpu_s:.1f} s of CPU) for {span:g} s "
                f"simulated = {self.wall_s / span:.2f} s per simulated second "
                f"({self.cpu_s / span:.2f} of CPU), {self.method}, {self.kernel} kernels; "
                f"{self.nsteps / span:.0f} steps per simulated second (mean step "
                f"{1e6 * span / steps:.1f} us), {1e6 * self.wall_s / steps:.1f} us per step "
                f"with {self.nfev / steps:.2f} right-hand sides, {self.njev / steps:.2f} "
                f"Jacobians and {self.nlu / steps:.2f} LU factorizations a step")
        if np.isfinite(self.rhs_s) and np.isfinite(self.jacobian_s):
            text += (f" (right-hand sides {1e6 * self.rhs_s / steps:.1f} us, Jacobians "
                     f"{1e6 * self.jacobian_s / steps:.1f} us a step)")
        text += (f"; compiled code loaded in {self.compile_s:.1f} s before, not counted"
                 if self.compile_s > 0 else "")
        return f"{text}; {self.message}"


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
    the axis ``u``, in body coordinates (the ground's: global). ``radial``: ``d`` is the
    distance of the point from ``b``'s axis line in ``a``'s cross-section, minus
    ``offset`` (the clearance), the force normal to ``e``; else a face: ``d`` is the
    point's height over ``j`` along ``u`` (outward) minus ``offset``, the force along
    ``-e``. ``stiffness``, ``exponent``, ``c_max``: eqs. 75-78.
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


class ContactRows:
    """The penalty contacts (rows of :class:`_Contacts`) while each link's kind adds its
    own (:meth:`~.elements.base.ElementKind.penalty`): geometry from the operator's
    columns (where each acts, along what), the law from the kind.

    ``scene``, ``op``: the model's; :meth:`law` the eqs. 75-78 parameters of a
    stiffness (:meth:`hertz` of a joint's Hertz contacts); :meth:`add` one contact of a
    link between its two bodies (the ground for ``other`` None); :meth:`centre` a
    body's rest centre. ``parts[k]``: the contacts of link ``k``.
    """

    def __init__(self, model: _Model, damping_length_unit_m: float):
        self.model, self.scene, self.op = model, model.scene, model.operator
        self.unit = damping_length_unit_m
        self.rows: list[tuple] = []
        self.parts: list[list[int]] = []

    def law(self, stiffness: float, exponent: float = 1.0) -> tuple[float, float, float]:
        """``(K, n, c_max)``: ``c_max`` the scene's fraction of ``K`` read in the
        damping length unit (module doc).
        """
        c = self.scene.contact.damping_fraction_of_stiffness * stiffness
        return stiffness, exponent, c * self.unit ** (exponent - 1.0)

    def hertz(self, joint) -> tuple[float, float, float]:
        """:meth:`law` of a joint's Hertz contacts: ``K`` of eqs. 76-77, the scene's
        exponent.
        """
        return self.law(hertz_stiffness(self.scene, joint), self.scene.contact.exponent)

    def centre(self, body: int) -> np.ndarray:
        return self.model.rest_centre[body]

    def add(self, link, point_a, axis_a, point_b, axis_b, offset, radial, law) -> None:
        """One contact of ``link``: ``point_a``/``axis_a`` on its body, ``point_b``/
        ``axis_b`` on the other (global, at the start), as :class:`_Contacts` reads them.
        """
        model = self.model
        a = link.body
        b = model.n_bodies if link.other is None else link.other
        self.rows.append((a, b, model.local(a, point_a), model.local(a, vector=axis_a),
                          model.local(b, point_b), model.local(b, vector=axis_b), offset,
                          radial, *law))
        self.parts[-1].append(len(self.rows) - 1)


def _contact_rows(model: _Model, damping_length_unit_m: float):
    """The penalty contacts of every link of the operator, each added by the link's kind
    (its module says which contacts and which law: bearings linear with the bearing
    clearance, a Cardan joint's trunnions and end faces Hertz, eqs. 76-77, a slip
    joint's spline linear); returned with, per link, the indices of its contacts.
    """
    rows = ContactRows(model, damping_length_unit_m)
    for link in model.operator.contacts:
        rows.parts.append([])
        link.element_kind.penalty(link, rows)
    return rows.rows, rows.parts


class _Model:
    """Bodies (the operator's: shaft bodies, then cross-pins), contacts and the
    right-hand side.

    The contacts are built from the equilibrium operator's links at the start
    (:func:`_contact_rows`), so every element the operator takes, this model takes; the
    forces it reports are the operator's columns (:meth:`link_values`).
    """

    def __init__(self, scene: Scene, damping_length_unit_m: float):
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
        rows, self.parts = _contact_rows(self, damping_length_unit_m)
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
        self.kernel_args = self._packed(scene)

    def _start_frames(self) -> np.ndarray:
        """(bodies, 3, 3): each body's frame at the start (body to global). Shaft bodies:
        columns (n1, axis, n3) turned by the shaft's angle, so a shaft's axis is its
        second body axis; cross-pins: (e1, e2, e3).
        """
        geo, kin = self.motion.geometry, self.motion.kin
        frames = []
        for g in self.segments:
            a = geo.axes[g.shaft]
            rest = np.column_stack([np.cross(a, geo.plane_normal), a, geo.plane_normal])
            frames.append(Rotation.from_rotvec(kin.phi[g.shaft, 0] * a).as_matrix() @ rest)
        frames += [np.column_stack([kin.e1[j, 0], kin.e2[j, 0], kin.e3[j, 0]])
                   for j in range(len(self.scene.joints))]
        return np.array(frames)

    def local(self, body: int, point: np.ndarray | None = None,
              vector: np.ndarray | None = None) -> np.ndarray:
        """A global point or vector at the start in ``body``'s coordinates (the ground,
        index ``n_bodies``: global).
        """
        if body == self.n_bodies:
            return point if vector is None else vector
        frame = self.start_frames[body]
        return frame.T @ (point - self.rest_centre[body] if vector is None else vector)

    def _packed(self, scene: Scene) -> tuple:
        """The model as the compiled kernels take it (:mod:`penalty_kernels`)."""
        c, law = self.c, harmonic_law
        return (
            self.n_shafts,
            np.column_stack([self.mass, self.inertia, self.rest_centre]),
            np.column_stack([c.a, c.b, c.radial]).astype(np.int64),
            np.column_stack([c.s, c.e, c.j, c.u]),
            np.column_stack([c.offset, c.stiffness, c.exponent, c.c_max]).astype(float),
            np.array([*self.gravity, *law(scene.input_torque), *law(scene.load_torque),
                      self.d_max], float),
        )

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
        rates += list(m.pin_omega[:, 0])
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
        body ``a`` (3, m, k) and the arms of the contact point from ``a``'s and ``b``'s
        centres (3, 2m, k).
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
        r = offset - ((offset * e).sum(0) / (axis * e).sum(0)) * axis
        rho = np.sqrt((r * r).sum(0))
        radial = c.radial[:, None]
        normal = np.where(radial, r / np.maximum(rho, 1e-300), axis)
        d = np.where(radial, rho, (offset * axis).sum(0)) - c.offset[:, None]
        f = contact_law(d, (normal * relative).sum(0), c.stiffness[:, None],
                        c.exponent[:, None], c.c_max[:, None], self.d_max)
        force = -f * np.where(radial, normal, e)
        return d, f, force, np.concatenate([arm, offset + arm_j], axis=1)

    def link_values(self, force: np.ndarray, arms: np.ndarray, rot: np.ndarray) -> np.ndarray:
        """The operator's columns (n, k) from the contacts' forces on body ``a`` (3, m, k),
        their arms from ``a``'s centre (3, 2m, k) and the bodies' rotations: per link, the
        net force of its contacts on the link's body and their net moment about the
        link's point, along each column's direction (turning with the cross-pin for a
        link in the pin's frame, fixed otherwise, as the operator's columns).
        """
        op, k = self.operator, force.shape[-1]
        out = np.empty((len(op.names), k))
        for link, rows in zip(op.contacts, self.parts):
            body = link.body
            net = force[:, rows].sum(axis=1)
            point = self.local(body, op.points[0, link.columns[0]])
            lever = np.einsum("ijk,j->ik", rot[body], point)
            moment = _cross(arms[:, rows] - lever[:, None], force[:, rows]).sum(axis=1)
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
        _, q, v, w, rot, _ = bodies
        nb, ns, k = self.n_bodies, self.n_shafts, y.shape[1]
        _, _, f, arms = self.contacts(bodies)
        force = self.gather_force @ f
        moment = self.gather_moment @ _cross(arms, np.concatenate([f, f], axis=1))
        moment[:, 0] += self.scene.input_torque(t) * rot[0, :, 1]
        moment[:, ns - 1] -= self.scene.load_torque(t) * rot[ns - 1, :, 1]
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
        ``atol_m`` on displacements and quaternions, ``atol_m / 1 ms`` on speeds.
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
        return kernels.rhs(t, y, *self.kernel_args)

    def jacobian_compiled(self, t: float, y: np.ndarray) -> np.ndarray:
        """:meth:`jacobian` by the compiled kernel (exact, by the chain rule)."""
        return kernels.jacobian(t, y, *self.kernel_args)


def simulate_penalty(
    scene: Scene,
    times,
    progress: Callable[[float], None] | None = None,
    *,
    method: str = "auto",
    atol_m: float = 1e-8,
    progress_every_s: float = 0.1,
    damping_length_unit_m: float = DAMPING_LENGTH_UNIT_M,
    kernel: str = "auto",
) -> PenaltyResult:
    """Integrate the released drive line from the scene's start to ``max(times)`` and
    sample it at ``times`` (s).

    Starts from the rigid model's state at the start: shafts at rest positions, turned
    and spinning as :func:`~cardan_forces.driveline.dynamics.simulate` says, cross-pins centred in
    their clearances. ``method``: one of :data:`METHODS`. ``atol_m`` is the absolute
    tolerance on positions (m; velocities get ``atol_m / 1 ms``): 1e-7 and 1e-8 give the
    same statistics of forces and speeds on ``paper-penalty``. ``damping_length_unit_m``:
    the unit of "c_max = 1 % of K" (module docstring). ``progress(t)`` is called every
    ``progress_every_s`` of simulated time. ``kernel``: ``numba`` (compiled, see
    :mod:`~cardan_forces.driveline.penalty_kernels`), ``numpy`` (the array model, no
    compiler needed) or ``auto`` (numba where installed). With ``method="auto"`` a
    failed compiled integration is run again by :data:`FALLBACK` (the message says
    both). A failed integration returns ``status = -1`` and its message; it raises only
    for bad arguments.
    """
    if not scene.has("penalty_dynamics"):
        raise ValueError(
            f"scene {scene.name!r} does not call for 'penalty_dynamics' (its effects: "
            f"{', '.join(sorted(scene.effects)) or 'none'}); add it to the scene's effects "
            "to run the penalty-contact simulation"
        )
    if any(s.friction_coefficient > 0 for s in scene.slip_joints):
        raise SceneError(
            f"scene {scene.name!r}: the penalty-contact simulation models a slip joint's "
            "spline as frictionless; set its friction_coefficient to 0")
    if kernel == "auto":
        kernel = "numba" if kernels.HAVE_NUMBA else "numpy"
    if kernel not in KERNELS or (kernel == "numba" and not kernels.HAVE_NUMBA):
        raise ValueError(f"kernel {kernel!r} not available; available: "
                         f"{', '.join(k for k in KERNELS if k != 'numba' or kernels.HAVE_NUMBA)}")
    fallback = method == "auto" and kernel == "numba"
    if method == "auto":
        method = COMPILED if kernel == "numba" else FALLBACK
    if method not in METHODS:
        raise ValueError(f"unknown method {method!r}; known: {', '.join(METHODS)}")
    if method == COMPILED and kernel != "numba":
        raise ValueError(f"method {COMPILED!r} runs the compiled kernels; kernel {kernel!r} "
                         "asked for")
    t = np.atleast_1d(np.asarray(times, float))
    t0 = scene.time.start_s
    if np.any(t < t0):
        raise ValueError(f"instants before the scene's start {t0} s")
    compile_s = _load_compiled(scene, kernel, method, damping_length_unit_m)
    start, cpu = _time.perf_counter(), _time.process_time()
    model = _Model(scene, damping_length_unit_m)
    run = _integrate(model, method, kernel, t, atol_m, progress, progress_every_s)
    if run.status != 0 and fallback:
        first = run.message
        method = FALLBACK
        run = _integrate(model, method, kernel, t, atol_m, progress, progress_every_s)
        run.message = f"{COMPILED} failed ({first}); {FALLBACK}: {run.message}"
    status, message, counts, clock, states = (run.status, run.message, run.counts,
                                              run.clock, run.states)
    forces, omega, depth = _sample(model, states)
    return PenaltyResult(
        scene=scene, t=t, omega=omega, forces=forces, penetration=depth,
        wall_s=_time.perf_counter() - start, nfev=counts[3], njev=counts[1],
        nlu=counts[2], nsteps=counts[0], method=method, status=status, message=message,
        kernel=kernel, rhs_s=clock["rhs"], jacobian_s=clock["jacobian"],
        cpu_s=_time.process_time() - cpu, compile_s=compile_s,
    )


@dataclass
class _Run:
    """One integration's outcome: status (0 or -1), message, counts (steps, Jacobians,
    LU factorizations, right-hand sides), the kernels' clocks and the sampled states.
    """

    status: int
    message: str
    counts: tuple
    clock: dict
    states: np.ndarray


def _integrate(model: _Model, method: str, kernel: str, t: np.ndarray, atol_m: float,
               progress, progress_every_s: float) -> _Run:
    """Integrate ``model`` from the scene's start with ``method``, sampled at ``t``."""
    t0 = model.scene.time.start_s
    y0 = model.initial_state()
    atol, step = model.tolerances(atol_m)
    states = np.full((len(t), model.n_state), np.nan)
    states[t == t0] = y0
    clock = {"rhs": np.nan, "jacobian": np.nan}
    if t.max() <= t0:
        return _Run(0, "no motion asked for", (0, 0, 0, 0), clock, states)
    marks = Marks(progress, t0, float(t.max()), progress_every_s)
    if method == COMPILED:
        status, message, counts = run_compiled(model, t0, y0, t, atol, states, marks)
        return _Run(status, message, counts, clock, states)
    clock = {"rhs": 0.0, "jacobian": 0.0}
    fun, jac = timed(model, kernel, step, clock)
    integrate = run_odeint if method == "LSODA" else run_stepped
    status, message, counts = integrate(METHODS[method], fun, jac, t0, y0, t, atol, states,
                                        marks)
    return _Run(status, message, (*counts, model.n_calls), clock, states)


def _load_compiled(scene: Scene, kernel: str, method: str, damping_length_unit_m: float
                   ) -> float:
    """Load (from numba's cache) or compile the compiled code ``method`` and ``kernel``
    call, on a short run of ``scene``'s model: seconds taken, 0 once done in this
    process. Kept out of the simulation's own clocks.
    """
    key = (kernel, method == COMPILED)
    if kernel != "numba" or key in _LOADED:
        return 0.0
    _announce_compile()
    begin = _time.perf_counter()
    model = _Model(scene, damping_length_unit_m)
    y0, t0 = model.initial_state(), scene.time.start_s
    kernels.rhs(t0, y0, *model.kernel_args)
    model.jacobian_compiled(t0, y0)
    if method == COMPILED:
        atol, _ = model.tolerances(1e-8)
        run = kernels.start(t0, y0, t0 + 1e-6, atol, RTOL, model.kernel_args)
        kernels.advance(run, t0, t0 + 1e-6, atol, RTOL, model.kernel_args, np.zeros(0),
                        np.zeros((0, len(y0))))
    _LOADED.add(key)
    return _time.perf_counter() - begin


_LOADED: set[tuple[str, bool]] = set()


def _announce_compile() -> None:
    """Say on stderr, before the first compilation, that the penalty simulation's
    kernels are compiled now (once per installation and CPU, cached by numba), since the
    run is silent meanwhile. Silent where numba's cache already holds the integrator.
    """
    index = _cache_index()
    if index is None or index.exists():
        return
    print(f"cardan: compiling the penalty simulation's kernels with numba for this CPU "
          f"(once; a few minutes on a small machine; cached in {index.parent}; "
          f"'cardan compile' does it ahead)", file=sys.stderr, flush=True)


def _cache_index() -> Path | None:
    """The cache index file numba keeps of the compiled integrator, ``None`` where this numba
    does not say (its cache's layout is not public API).
    """
    try:
        return Path(kernels.advance._cache._cache_file._index_path)
    except AttributeError:
        return None


def cache_folder() -> str:
    """Where numba caches the penalty simulation's kernels (for messages)."""
    index = _cache_index()
    return str(index.parent) if index is not None else "numba's cache folder"


def _sample(model: _Model, states: np.ndarray):
    """Named forces (the equilibrium operator's columns, :meth:`_Model.link_values`),
    shaft speeds about their own axes and the deepest penetration at sampled states
    (T, n).
    """
    bodies = model.bodies(states.T)
    depth, _, force, arms = model.contacts(bodies)
    rot, omega = bodies[4:]
    first = [next(g for g, s in enumerate(model.segments) if s.shaft == k)
             for k in range(len(model.scene.shafts))]
    speeds = (omega[first] * rot[first, :, 1]).sum(axis=1)
    values = model.link_values(force, arms, rot)
    return dict(zip(model.operator.names, values)), speeds, depth.max(axis=0)
