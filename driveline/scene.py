"""The scene's data model: a drive line as frozen dataclasses, and the limits every
field is held to.

A :class:`Scene` comes from :mod:`.loading` (a built-in name or a TOML file, read,
merged over the scene it ``extends`` and validated) and never from anywhere else: its
variants are made by :meth:`Scene.with_changes`, which validates them again by the same
rules. Every quantity is SI; a field's unit is in its name (``length_m``,
``mass_kg``). The built-in ``paper.toml`` documents each field and each convention once.
"""

from __future__ import annotations

import dataclasses
import math
import re
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

EFFECTS = (
    "gravity",
    "inertia",
    "crosspin_inertia",
    "clearance",
    "compliance",
    "friction",
    "penalty_dynamics",
)
"""Effects a scene may call for (DESIGN §1); only those listed are built."""

LIMITS = {
    "length_m": (1e-6, 1e3),
    "position_m": (0.0, 1e3),
    "mass_kg": (1e-9, 1e9),
    "inertia_kg_m2": (1e-12, 1e12),
    "torque_N_m": (0.0, 1e9),
    "frequency_hz": (0.0, 1e4),
    "speed_rad_s": (0.0, 1e4),
    "speed_rpm": (1e-3, 1e5),
    "angle_rad": (0.0, 1e6),
    "angle_deg": (0.0, 360.0),
    "gravity_m_s2": (0.0, 1e3),
    "time_s": (0.0, 1e6),
    "step_s": (1e-9, 1e6),
    "pressure_Pa": (1e3, 1e13),
    "density_kg_m3": (1e-3, 1e5),
    "stiffness": (1e-3, 1e16),
    "ratio": (0.0, 1e3),
    "force_N": (1e-3, 1e12),
    "number": (0.0, 1e15),
}
"""Accepted magnitudes per kind of field, ``(least, most)``: a positive field must be at
least ``least``, every field at most ``most`` in absolute value (``number``: a field
read without a kind). The ranges hold any
real drive line with room to spare (the hard cases scale masses and torques by 1e6)
and keep every product the model forms finite."""

MAX_ARTICULATION_DEG = 89.0
"""Largest joint angle: the velocity ratio ``1/cos`` reaches 57 (eq. 3); closer to 90
deg the motion is numerically singular."""

MAX_SHAFTS = 8
"""Largest number of shafts: vehicle drive lines have up to four or five; the rigid
set's intervals take two LPs per force component (about 200 LPs at eight shafts) and
the operator's SVD grows with the cube of the bodies."""

MAX_INSTANTS = 20_001
"""Largest time grid: operators are built over the whole grid (a 3-shaft line's takes
8.6 kB per instant)."""

MAX_TURNS = 1_000.0
"""Most revolutions the input may make over the time span (an upper estimate from the
initial speed, the torques and the reduced inertia, :func:`.support.turns_bound`): the
integrator resolves every turn, so this bounds its work."""

MAX_CYCLES = 1_000.0
"""Most periods of a harmonic torque over the time span, for the same reason."""

NAME_PATTERN = re.compile(r"[A-Za-z0-9_-]+")
"""Names of shafts, joints and bearings: they become parts of dotted force names
(``bearing.input.near.x``), so they hold no dot, space or other separator."""


class SceneError(ValueError):
    """A scene that cannot be used: the message names the file and the field."""


def table_keys(record: type) -> tuple[str, ...]:
    """The keys of a scene table that holds a ``record`` (a dataclass): its fields, each
    a key of the same name.
    """
    return tuple(f.name for f in dataclasses.fields(record))


BEARING_TYPES = ("ball", "cylindrical_roller", "tapered_roller", "angular_contact_ball")
"""Rolling-bearing types of a bearing's catalogue data (:class:`BearingRating`): ``ball``
a radial (deep-groove) ball bearing and ``cylindrical_roller`` a radial roller bearing,
both of nominal contact angle 0; ``tapered_roller`` and ``angular_contact_ball`` need
their contact angle."""

ANGULAR_TABLE_DEG = (20.0, 45.0)
"""Contact angles (deg) of a single-row angular-contact ball bearing whose ``X``, ``Y``,
``e`` the package takes from ISO 281:2007 Table 3 (rows 20 to 45 deg, interpolated
between them); outside this range the scene gives ``X``, ``Y`` and ``e`` itself."""


@dataclass(frozen=True)
class Range:
    """The physical range of a field, narrower than its kind's :data:`LIMITS`: ``least``
    to ``most`` (inclusive) in ``unit``.
    """

    least: float
    most: float
    unit: str

    def refusal(self, value: float) -> str | None:
        """Why ``value`` is refused, in one line naming it, its unit and the range; None
        inside the range.
        """
        if self.least <= value <= self.most:
            return None
        return f"{value:g} {self.unit} is outside {self}"

    def __str__(self) -> str:
        """``LEAST to MOST UNIT``, as refusals and the scene reference write it."""
        return f"{self.least:g} to {self.most:g} {self.unit}"


CONTACT_ANGLE_DEG = Range(5.0, 60.0, "deg")
"""Nominal contact angle of a bearing that has one, as an element (an angular-contact
bearing) and in a rating (``tapered_roller``, ``angular_contact_ball``). Catalogue
angular-contact ball bearings have 15 to 40 deg (15, 25, 30, 40 in the makers' series)
and the angular-contact thrust ball bearings of ball-screw supports 60 deg; tapered
roller bearings 10 to 30 deg. The least, 5 deg, is the smallest angular-contact row of
ISO 281:2007 Table 3 (ISO/TR 1281-1, 7.2.1); below it the axial stiffness the model
gives, ``k_r tan^2 alpha``, falls under 1/130 of the radial one and the axial contact
problem degenerates. Above 60 deg a bearing carries next to no radial load (a thrust
bearing)."""

MEAN_DIAMETER_M = Range(0.002, 2.5, "m")
"""Mean diameter ``(d + D) / 2`` of a rated bearing (ISO 281:2007's modified rating life
takes it for the pitch diameter ``D_pw`` in the reference viscosity ``nu1``): from 2 mm, a
miniature bearing of 1 mm bore and 3 mm outside diameter, to 2.5 m, above the largest
catalogue rolling bearings (about 1.8 m bore, 2.2 m outside diameter)."""

VISCOSITY_MM2_S = Range(1.0, 1e4, "mm^2/s")
"""Kinematic viscosity of a bearing's lubricant at its operating temperature (mm^2/s):
ISO 3448's grades span VG 2 to VG 3200 (2 to 3200 mm^2/s at 40 deg C); a thin grade hot
falls towards 1, a heavy grade cold rises towards 10^4, beyond which an oil no longer
flows into a bearing. ``nu`` enters the life only through ``kappa = nu / nu1``, taken as
at most 4."""

CROSSPIN_ASPECT = 100.0
"""Most ratio of a cross-pin's largest dimension (``hs_m``, ``rs_m``, ``rb_m``, ``ht_m``,
``hb_m``, ``rt_m``) to any other: the paper's Table 2 spans a factor 6, the truck cross
of the built-in ``propshaft`` 5.4; a dimension a hundredth of the joint's largest is a zero
length (a trunnion contact at the cross centre, a trunnion of no radius)."""

SPLINE_PITCH_RADIUS_M = Range(5e-4, 1.0, "m")
"""Pitch radius of a slip joint's spline: ISO 4156's involute splines have modules
0.25 to 10 mm and a pitch diameter of module times number of teeth, about 1.5 mm for a
few teeth of the smallest module, about 1 m for a hundred of the largest. The spline's
friction bound ``mu T / r`` grows without limit as ``r`` goes to 0."""

MAX_STIFFNESS_RATIO = 1e7
"""Most ratio, either way, of the bearings' stiffness ``bearing_stiffness_N_m`` to the
joints' (their Hertz stiffness's secant at ``damping_full_depth_m``, the linear one the
compliance formulation takes): the hard cases study 1e6 and 1e-6 and every formulation
passes them; a decade beyond, a bearing so soft next to its joints holds nothing, one
so stiff makes the joints' compliance vanish."""


# ---------------------------------------------------------------------------- data


@dataclass(frozen=True)
class BearingRating:
    """A bearing's catalogue data for ISO 281's basic rating life (all optional in a
    scene: a bearing without it has no rated life).

    ``type`` one of :data:`BEARING_TYPES`; ``contact_angle_deg`` its nominal contact
    angle alpha (deg, 0 for the radial types); ``C_N`` the basic dynamic and ``C0_N``
    the basic static load rating (N). ``X``, ``Y``, ``e`` (dimensionless) are the
    radial and axial factors of the equivalent dynamic load ``P = X Fr + Y Fa`` where
    ``Fa / Fr > e`` (``P = Fr`` below it); ``None`` takes them from ISO 281's tables by
    type and angle.

    ISO 281:2007's modified rating life needs four more, all four or none: the fatigue
    load limit ``C_u_N`` (N, below ``C0_N``: catalogues list a few per cent of it), the
    mean diameter ``mean_diameter_m`` ((d + D) / 2, m, within :data:`MEAN_DIAMETER_M`),
    the lubricant's kinematic viscosity at operating temperature ``viscosity_mm2_s``
    (mm^2/s, within :data:`VISCOSITY_MM2_S`) and the contamination factor
    ``contamination`` (``e_C``, above 0 and at most 1, ISO 281:2007 Table 13).
    """

    type: str
    C_N: float
    C0_N: float
    contact_angle_deg: float = 0.0
    X: float | None = None
    Y: float | None = None
    e: float | None = None
    C_u_N: float | None = None
    mean_diameter_m: float | None = None
    viscosity_mm2_s: float | None = None
    contamination: float | None = None

    @property
    def roller(self) -> bool:
        """Roller bearings take the life exponent 10/3, ball bearings 3 (ISO 281)."""
        return self.type.endswith("roller")


@dataclass(frozen=True)
class Tolerances:
    """Manufacturing and assembly tolerances, each the half-width of a uniform spread
    about the nominal value (the worst-case reading of a drawing's +- tolerance).

    ``bearing_seat_m``: each radial component of every bearing seat's position (m);
    ``articulation_deg``: every joint's articulation angle (deg);
    ``bearing_clearance_m``: every bearing's clearance about the scene's
    ``contact.bearing_clearance_m`` (m; a clearance sampled below zero is zero).
    """

    bearing_seat_m: float = 0.0
    articulation_deg: float = 0.0
    bearing_clearance_m: float = 0.0


@dataclass(frozen=True)
class Bearing:
    """A rolling bearing: carries a force, no moment.

    ``offset_m`` is its position along the shaft axis from the shaft's centre, positive
    downstream (towards the output). ``kind``: one of the bearing kinds of
    :mod:`.elements` (each says what it carries; ``locating`` a force in any
    direction, ``floating`` only normal to the shaft axis, the shaft slides through it).
    A kind with fields of its own subclasses this record. ``rating``: its catalogue
    data (:class:`BearingRating`), if the scene gives it.
    """

    name: str
    offset_m: float
    kind: str = "locating"
    rating: BearingRating | None = None


@dataclass(frozen=True)
class Shaft:
    """A rigid shaft between two points of the chain, centre of mass at its centre.

    ``inertia_kg_m2`` are the principal moments about the centre of mass in the
    paper's order (J1, J2, J3), J2 about the shaft axis.
    """

    name: str
    length_m: float
    mass_kg: float
    inertia_kg_m2: tuple[float, float, float]
    bearings: tuple[Bearing, ...]

    @property
    def axial_inertia_kg_m2(self) -> float:
        return self.inertia_kg_m2[1]


@dataclass(frozen=True)
class Joint:
    """A Cardan joint at the end of one shaft and the start of the next (``kind``: its
    joint kind, :mod:`.elements`).

    ``articulation_deg`` is the angle between the two shafts; its sense follows the
    scene's arrangement. ``yoke_phase_deg`` turns this joint's driving yoke about the
    driving shaft: for the first joint from the articulation plane, for later joints
    from the previous joint's driven yoke on the same shaft. Cross-pin geometry as in
    the paper's Table 2 and Fig. 5.
    """

    name: str
    articulation_deg: float
    yoke_phase_deg: float
    hs_m: float
    rs_m: float
    rb_m: float
    ht_m: float
    hb_m: float
    rt_m: float
    kind: str = "cardan"

    @property
    def radial_clearance_m(self) -> float:
        """Paper: eps_r = rb - rs."""
        return self.rb_m - self.rs_m

    @property
    def axial_clearance_m(self) -> float:
        """Paper: eps_a = hb - ht."""
        return self.hb_m - self.ht_m


@dataclass(frozen=True)
class Crosspin:
    """Cross-pin mass and principal moments about its centre along (e1, e2, e3)."""

    mass_kg: float
    inertia_kg_m2: tuple[float, float, float]


@dataclass(frozen=True)
class DutyBin:
    """One bin of a load spectrum (duty cycle): the line's input torque ``torque_N_m``
    (N m) at the input speed ``speed_rpm`` (r/min) for the share ``share`` of the
    operating time (the shares of a spectrum sum to 1).
    """

    torque_N_m: float
    speed_rpm: float
    share: float


@dataclass(frozen=True)
class TorqueLaw:
    """``M(t) = mean + amplitude * cos(2 pi f t + phase)`` in N·m (constant: amplitude 0)."""

    mean_N_m: float
    amplitude_N_m: float = 0.0
    frequency_hz: float = 0.0
    phase_rad: float = 0.0

    def __call__(self, t):
        """Torque at time(s) ``t`` (s), vectorized."""
        t = np.asarray(t, float)
        w = 2.0 * math.pi * self.frequency_hz
        return self.mean_N_m + self.amplitude_N_m * np.cos(w * t + self.phase_rad)


@dataclass(frozen=True)
class Frame:
    """Where the chain sits in the global frame (unit vectors are normalized)."""

    input_start_m: tuple[float, float, float]
    input_axis: tuple[float, float, float]
    articulation_towards: tuple[float, float, float]


@dataclass(frozen=True)
class TimeGrid:
    """Uniform instants from ``start_s`` to ``stop_s`` (inclusive) every ``step_s``."""

    start_s: float
    stop_s: float
    step_s: float

    def instants(self) -> np.ndarray:
        n = int(round((self.stop_s - self.start_s) / self.step_s))
        return self.start_s + self.step_s * np.arange(n + 1)


@dataclass(frozen=True)
class Material:
    """Elastic constants for Hertz stiffness (paper eqs. 76-77) and density."""

    youngs_modulus_Pa: float
    poisson_ratio: float
    density_kg_m3: float


@dataclass(frozen=True)
class Contact:
    """Penalty-contact parameters (paper eqs. 75-78) and the bearings' own."""

    exponent: float
    damping_full_depth_m: float
    damping_fraction_of_stiffness: float
    bearing_clearance_m: float
    bearing_stiffness_N_m: float
    friction_coefficient: float


@dataclass(frozen=True)
class Scene:
    """A validated drive line: a chain of shafts joined by joints, bearings on the
    shafts, and ``elements`` inside the shafts (slip joints, ...: each a record of its
    kind, :mod:`.elements`), in the order the loader read them.
    """

    name: str
    description: str
    effects: frozenset[str]
    arrangement: str
    gravity_m_s2: tuple[float, float, float]
    frame: Frame
    shafts: tuple[Shaft, ...]
    joints: tuple[Joint, ...]
    crosspin: Crosspin
    input_torque: TorqueLaw
    load_torque: TorqueLaw
    initial_angle_rad: float
    initial_speed_rad_s: float
    time: TimeGrid
    material: Material
    contact: Contact
    source: str = "<memory>"
    elements: tuple = ()
    tolerances: Tolerances | None = None
    duty_cycle: tuple[DutyBin, ...] = ()

    def has(self, effect: str) -> bool:
        """Whether the scene calls for ``effect`` (one of :data:`EFFECTS`)."""
        if effect not in EFFECTS:
            raise KeyError(f"unknown effect {effect!r}; known: {', '.join(EFFECTS)}")
        return effect in self.effects

    def articulation_signs(self) -> tuple[int, ...]:
        """Sense of each joint's articulation: Z alternates it, W keeps it."""
        signs = [1]
        for _ in self.joints[1:]:
            signs.append(-signs[-1] if self.arrangement == "Z" else signs[-1])
        return tuple(signs)


    def with_changes(self, **changes) -> Scene:
        """The scene with ``changes`` (fields and values, as :func:`dataclasses.replace`
        takes them), validated again by every rule a scene file meets (SceneError
        otherwise): the one way to make a variant of a scene.
        """
        return _VALIDATE[0](dataclasses.replace(self, **changes))

    def in_motion(self) -> Scene:
        """The scene as the dynamic models take it (a physics engine, the penalty
        simulation's measurements): the scene itself where it calls for ``inertia``;
        a quasi-static one with the ``inertia`` effect added (its shafts' masses and
        inertias, the same torques and speed), its description saying so.
        """
        if self.has("inertia"):
            return self
        return self.with_changes(
            effects=self.effects | {"inertia"},
            description=self.description + IN_MOTION)


IN_MOTION = "; with inertia (the scene is quasi-static)"
"""What :meth:`Scene.in_motion` adds to a quasi-static scene's description (reports
read it to say so)."""

_VALIDATE: list[Callable[[Scene], Scene]] = []
"""The validator of :meth:`Scene.with_changes`: :func:`.loading.revalidate`, registered
by :mod:`.loading` (which imports this module; the rules need the layers above the data
model, so they are handed down rather than imported up)."""


def use_validator(validate: Callable[[Scene], Scene]) -> None:
    """Make ``validate`` the validator of :meth:`Scene.with_changes`."""
    _VALIDATE[:] = [validate]
