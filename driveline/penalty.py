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
  a bearing (:mod:`.elements.slip`);
- **disc coupling** (:mod:`.elements.disc_coupling`): a bushing (:meth:`ContactRows.bushing`);
- **constant-velocity joint** (:mod:`.elements.cv`): a bushing between two shafts that
  turn about different axes, homokinetic in twist and free in bending: three pairs of
  springs at its centre (:meth:`ContactRows.spring`) and one twist about the bisector
  (:meth:`ContactRows.twist`), bilateral and linear;
- **centring ball** (:mod:`.elements.centring`): the ball's centre held on the bore's
  axis, both ways, free along it (:meth:`ContactRows.line`), bilateral and linear.

**Bushing.** A linear six-way spring-damper between a link's two bodies at a point,
bilateral (it pulls as it pushes, with no clearance and no step): along each axis
``x_i`` of a frame fixed in both bodies at the start, a spring ``f_i = k_i d_i + c_i
d_i'`` with ``d_i`` the offset of the body's point from the other's along the other's
``x_i``, acting on the body along its own ``x_i``; about each axis a torsion spring
``M_i = kr_i theta_i + cr_i theta_i'`` with ``theta_i = (x_j.x_k' - x_k.x_j') / 2``
(``x'`` the other body's axes, ``(i, j, k)`` cyclic: the small rotation's component),
a pure couple along ``d theta_i`` per rotation (from the energy ``kr_i theta_i^2 /
2``): turned by ``phi`` about ``x_i``, ``theta_i = sin(phi)`` and the couple ``kr_i
sin(phi) cos(phi)``, ``kr_i phi`` to within ``phi^2`` (:class:`~.penalty_model._Contacts`,
``SPRING`` and ``TWIST``). A small-rotation law: its couple peaks at ``kr_i / 2`` at 45
degrees, so a load that would wind it further has no equilibrium (the softest disc
coupling the kind accepts, 1e2 N m/rad in torsion, under ``propshaft``'s 2.5 kN m: its
segments spin apart and the run fails). Damping: the
scene's fraction of each stiffness, as eqs. 75-78's ``c_max`` of a linear contact
(``c = fraction * k``, 0.01 s by default), at every deflection: a bilateral spring has
no moment of first touch for eq. 78's step to soften.

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
the step size and the cost.

**Bodies.** Shafts: the scene's mass and principal inertias (J2 about the axis).
Cross-pins: always the scene's ``[crosspin]`` mass and inertia about (e1, e2, e3) (a
free body needs mass), whether or not the scene lists ``crosspin_inertia``. Gravity
when the scene has it; the input torque about the input shaft's current axis, the load
torque against the output shaft's, or, at an end whose shaft holds a gear mesh, the
mesh force at the mesh point instead (:meth:`~.penalty_model.Model._line_loads`: fixed
in space, its moment taken about the body's current centre). The simulation is
dynamic whatever the effects.

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
its Jacobian (:mod:`~cardan_forces.driveline.penalty_kernels`: loops instead of array
calls on a few bodies, and no Python between steps); without numba,
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

**Cost.** The step count is set by the impacts (short steps while a cross-pin
rattles; the compiled BDF takes fewer steps than LSODA); per step about two
right-hand sides, a Jacobian
every 7 steps (after a Newton iteration fails: in the first 2 s of ``paper-penalty``
5 failures in 6 began with the same contacts in touch as the Jacobian, so it is the
forces of the touching contacts, stiff and damped, that outrun it, more than contacts
opening or closing) and a factorization every 3 (after a Jacobian or a change of step
by more than 30 %). Nearly every step's error test is a cross-pin's angular velocity; where the
pins slide on eq. 75's ``f = 0`` while pressed, the clamp's kink makes steps fail.
``propshaft`` (8 bodies, 104 states) takes about twice the steps: the
end faces of its cross-pins carry the axial load of the slip joint's segments, pressed
by ~0.5 um, and eq. 75's ``f >= 0`` switches them on and off while still pressed
(100 times in 0.02 s of simulated time), whenever the damping term outweighs the spring's ~16 N. Its
Jacobian is exact (tested as ``paper``'s); the spline's contacts do not switch.
``propshaft-disc``'s bushing adds stiff modes (decay rates up to ~1.7e5 1/s: its
segments' motion on the disc's damping) but no switching and no oscillation to resolve:
the implicit steps pass over them, and the line takes about ``propshaft``'s steps, with
the same Jacobians and factorizations a step.

**Where.** This module holds the physics above, the contacts' builder and the run;
the NumPy model (bodies, contact map, right-hand side and Jacobian), the oracle the
compiled kernels are tested against, is :mod:`~cardan_forces.driveline.penalty_model`;
the integrator drivers are :mod:`~cardan_forces.driveline.penalty_integrators`.
"""

from __future__ import annotations

import sys
import time as _time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.integrate import BDF, LSODA, Radau

from . import penalty_kernels as kernels
from .contact import hertz_stiffness
from .elements.base import PENALTY_SIMULATION
from .elements.registry import refusals
from .penalty_integrators import RTOL, Marks, run_compiled, run_odeint, run_stepped, timed
from .penalty_model import Model, contact_law
from .scene import Scene, SceneError

__all__ = ["COMPILED", "ContactRows", "DAMPING_LENGTH_UNIT_M", "FALLBACK", "KERNELS", "METHODS",
           "PenaltyResult", "RELEASED", "cache_folder", "contact_law", "released",
           "simulate_penalty"]

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

RELEASED = frozenset({"clearance", "crosspin_inertia", "penalty_dynamics"})
"""Effects that turn a scene into its penalty-contact (ADAMS-style) counterpart."""


def released(scene: Scene) -> Scene:
    """``scene`` with every joint released (``paper`` gives ``paper-penalty``'s model):
    the same bodies, loads and clearances, contacts by penalty forces (eqs. 75-78).
    SceneError (from the scene's validation) when the scene is quasi-static.
    """
    if scene.has("penalty_dynamics"):
        return scene
    return scene.with_changes(
        name=f"{scene.name}-penalty", effects=scene.effects | RELEASED,
        description=f"{scene.description}; joints released (penalty contacts)")


@dataclass(frozen=True)
class PenaltyResult:
    """The penalty simulation sampled at ``t`` (s).

    ``omega[k]``: shaft ``k``'s angular velocity about its own current axis (rad/s).
    ``forces``: the equilibrium operator's names and sign conventions (N; N m for a
    moment column, such as a disc coupling's bending and torque): bearing
    forces on the shafts in the global frame; joint contact forces on the cross-pins in
    each pin's own current frame (``e1`` its driving trunnion axis, ``e2`` its driven
    one, ``e3 = e1 x e2``); end faces as pushes >= 0. ``penetration``: the deepest
    penetration of a unilateral contact (m) at each instant (negative: none touches;
    a bushing's deflection is none). ``status`` is 0 on
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


class ContactRows:
    """The penalty contacts (rows of :class:`~.penalty_model._Contacts`) while each
    link's kind adds its own (:meth:`~.elements.base.ElementKind.penalty`): geometry from
    the operator's columns (where each acts, along what), the law from the kind.

    ``scene``, ``op``: the model's; :meth:`law` the eqs. 75-78 parameters of a
    stiffness (:meth:`hertz` of a joint's Hertz contacts); :meth:`add` one contact of a
    link between its two bodies (the ground for ``other`` None), :meth:`bushing` a
    six-way spring-damper, :meth:`spring` and :meth:`twist` one bilateral row of a
    coupling between bodies that turn about different axes (a CV joint's);
    :meth:`centre` a body's rest centre. ``parts[k]``: the contacts of link ``k``;
    ``flipped[c]``: contact ``c``'s body ``a`` is its link's other body (its force on
    the link's body is the opposite of its force on ``a``).
    """

    def __init__(self, model: _Model, damping_length_unit_m: float):
        self.model, self.scene, self.op = model, model.scene, model.operator
        self.unit = damping_length_unit_m
        self.rows: list[tuple] = []
        self.parts: list[list[int]] = []
        self.flipped: list[bool] = []

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
        model, (a, b) = self.model, self._bodies(link)
        self._row(a, b, model.local(a, point_a), model.local(a, vector=axis_a),
                  model.local(b, point_b), model.local(b, vector=axis_b), offset,
                  kernels.RADIAL if radial else kernels.FACE, law)

    def bushing(self, link, point, frame, k_trans, k_rot) -> None:
        """A bushing (module doc) of ``link`` at ``point`` (global, at the start) in
        ``frame`` (three orthonormal global axes, right-handed, at the start; fixed in
        both bodies): translational stiffness ``k_trans[i]`` (N/m) along axis ``i``,
        rotational ``k_rot[i]`` (N m/rad) about it, damping by :meth:`law`. Six rows:
        three springs, three twists, in the frame's order.
        """
        model, (a, b) = self.model, self._bodies(link)

        def on(body, vector):
            return model.local(body, vector=np.asarray(vector, float))

        for axis, k in zip(frame, k_trans):
            self._row(a, b, model.local(a, point), on(a, axis), model.local(b, point),
                      on(b, axis), 0.0, kernels.SPRING, self.law(k))
        for i, k in enumerate(k_rot):  # theta_i = (R_a x_j . R_b x_k - R_a x_k . R_b x_j) / 2
            x_j, x_k = frame[(i + 1) % 3], frame[(i + 2) % 3]
            self._row(a, b, on(a, x_k), on(a, x_j), on(b, x_j), on(b, x_k), 0.0,
                      kernels.TWIST, self.law(k))

    def spring(self, link, point, axis, axis_other, law, flip: bool = False) -> None:
        """A bilateral linear spring (``SPRING``) of ``link`` at ``point`` (global, at the
        start, a point of both bodies): its deflection the offset of the link's body's
        point from the other's along ``axis_other`` (fixed in the other body), its force
        on the body along ``-axis`` (fixed in the body), ``law`` as :meth:`law`'s. With
        ``flip`` the roles swap: the deflection is the other's point's offset along
        ``axis`` (fixed in the body), the force on the other along ``-axis_other``.
        """
        model, (a, b) = self.model, self._bodies(link)
        e, u = np.asarray(axis, float), np.asarray(axis_other, float)
        if flip:
            a, b, e, u = b, a, u, e
        self._row(a, b, model.local(a, point), model.local(a, vector=e),
                  model.local(b, point), model.local(b, vector=u), 0.0, kernels.SPRING, law,
                  flip)

    def line(self, link, point, axis, law) -> None:
        """A point held on a line (``LINE``) of ``link``, both ways: the other body's
        point at ``point`` (global, at the start) on the link's body's line through
        ``point`` along the unit ``axis`` (fixed in the body), free along it (a flipped
        row: its ``a`` is the other body). ``law`` as :meth:`law`'s.
        """
        model, (line, other) = self.model, self._bodies(link)
        u = np.asarray(axis, float)
        self._row(other, line, model.local(other, point), model.local(other, vector=u),
                  model.local(line, point), model.local(line, vector=u), 0.0, kernels.LINE,
                  law, True)

    def twist(self, link, axes, axes_other, law) -> None:
        """A bilateral torsion spring (``TWIST``) of ``link``: ``theta = (x1.y2 -
        x2.y1) / 2`` (rad) with ``axes = (x1, x2)`` fixed in the link's body and
        ``axes_other = (y1, y2)`` in the other (global, at the start), a pure couple
        along ``d theta`` per rotation of the body (:class:`~.penalty_model._Contacts`),
        ``law`` as :meth:`law`'s.
        """
        model, (a, b) = self.model, self._bodies(link)
        (x1, x2), (y1, y2) = np.asarray(axes, float), np.asarray(axes_other, float)
        self._row(a, b, model.local(a, vector=x2), model.local(a, vector=x1),
                  model.local(b, vector=y1), model.local(b, vector=y2), 0.0, kernels.TWIST,
                  law)

    def _bodies(self, link) -> tuple[int, int]:
        """``link``'s body and its other (the ground, ``n_bodies``, for None)."""
        return link.body, self.model.n_bodies if link.other is None else link.other

    def _row(self, a, b, s, e, j, u, offset, kind, law, flip: bool = False) -> None:
        self.rows.append((a, b, s, e, j, u, offset, kind, *law))
        self.parts[-1].append(len(self.rows) - 1)
        self.flipped.append(flip)


def _contact_rows(model: _Model, damping_length_unit_m: float):
    """The penalty contacts of every link of the operator, each added by the link's kind
    (its module says which contacts and which law: bearings linear with the bearing
    clearance, a Cardan joint's trunnions and end faces Hertz, eqs. 76-77, a slip
    joint's spline linear); returned with, per link, the indices of its contacts, and
    which contacts are flipped (:class:`ContactRows`).
    """
    rows = ContactRows(model, damping_length_unit_m)
    for link in model.operator.contacts:
        rows.parts.append([])
        link.element_kind.penalty(link, rows)
    return rows.rows, rows.parts, np.array(rows.flipped, bool)


class _Model(Model):
    """The NumPy model (:class:`~.penalty_model.Model`) whose contacts each link's kind
    adds (:func:`_contact_rows`).
    """

    def __init__(self, scene: Scene, damping_length_unit_m: float):
        super().__init__(scene, damping_length_unit_m, _contact_rows)


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
    tolerance on positions (m; velocities get ``atol_m / 0.001 s``): 1e-7 and 1e-8 give the
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
    if refused := refusals(scene, PENALTY_SIMULATION):
        raise SceneError(f"scene {scene.name!r}: {'; '.join(refused)}")
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
    kernels.rhs(t0, y0, model.arrays)
    model.jacobian_compiled(t0, y0)
    if method == COMPILED:
        atol, _ = model.tolerances(1e-8)
        run = kernels.start(t0, y0, t0 + 1e-6, atol, RTOL, model.arrays)
        kernels.advance(run, t0, t0 + 1e-6, atol, RTOL, model.arrays, np.zeros(0),
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
    shaft speeds about their own axes and the deepest penetration of a unilateral
    contact at sampled states (T, n).
    """
    bodies = model.bodies(states.T)
    depth, _, force, arms, couple = model.contacts(bodies)
    rot, omega = bodies[4:]
    first = [next(g for g, s in enumerate(model.segments) if s.shaft == k)
             for k in range(len(model.scene.shafts))]
    speeds = (omega[first] * rot[first, :, 1]).sum(axis=1)
    values = model.link_values(force, arms, couple, rot)
    unilateral = model.c.radial <= kernels.RADIAL  # a bushing's deflections are no depth
    return dict(zip(model.operator.names, values)), speeds, depth[unilateral].max(axis=0)
