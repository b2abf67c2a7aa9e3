"""The gear mesh: the line's load taken off its last shaft by a gear instead of a pure
torque, or its input torque brought onto its first shaft by one (a transmission's
output shaft driven through a helical gear pair). The mating gear is held by its own
bearings (outside the line), so the mesh is an applied load, not a contact: a force at
the mesh point on the pitch circle whose moment about the shaft axis is the scene's
load torque (against the rotation) or input torque (with it), with the radial and
axial components the tooth geometry adds. Those load the shaft's bearings; they do no
work on the 1-DOF motion (the axes are fixed), which stays the scene's.

``type = "helical"`` (the default; spur for ``helix_angle_deg = 0``): the nominal loads
from the torque ``T`` (ISO 6336-1:2019, 5.2, with the pitch diameter ``d = 2 r``):

    Ft = T / r,   Fr = Ft tan(alpha_n) / cos(beta),   Fa = Ft tan(|beta|)

``alpha_n`` the normal pressure angle, ``beta`` the helix angle at the pitch circle.
The mesh point sits ``mesh_angle_deg`` about the shaft axis from the shaft frame's
``r1`` (in the articulation plane), ``offset_m`` along it; the tangential force opposes
the rotation, the radial one points to the axis, and the axial one acts along the axis,
downstream for a positive ``helix_angle_deg``, upstream for a negative one (the sign
stands for the hand of the helix and the sense of the load).

:meth:`Mesh.load` takes the torque the mesh takes off the shaft: the load torque on the
last shaft, minus the input torque on the first. A negative torque (a driving mesh)
reverses ``Ft`` and, through it, ``Fa`` (the tooth's normal force reverses along the
same helix); ``Fr`` still separates the gears (``|Ft|`` in it).

``type = "bevel"`` (spiral bevel; straight bevel for ``spiral_angle_deg = 0``) and
``type = "hypoid"``: the shaft is the pinion, at the end of the line with its pitch
cone's apex downstream (toward the ring gear's axis). ``pitch_radius_m`` is then the
mean pitch radius ``r_m = d_m1 / 2`` (the mean point, at mid face width, ISO
23509:2016 ``d_m1``) and ``offset_m`` the mean point's place along the axis. With the
pitch cone angle ``delta`` (ISO 23509 ``delta_1``), the pinion's mean spiral angle
``psi`` (``beta_m1``) and the normal pressure angle ``alpha_n`` of the loaded flank,
the loads at the mean point (ISO 10300-1:2014, 6.1: ``F_mt1 = 2000 T1 / d_m1`` with
``T1`` in N m and ``d_m1`` in mm; the components as in Machinery's Handbook, "Bevel
gearing", thrust and separating forces, and Carvill, *Mechanical Engineer's Data
Handbook*, 1993, 2.10.5):

    Ft = T / r_m
    Fa = |Ft| / cos(psi) (tan(alpha_n) sin(delta) + s sin(psi) cos(delta))
    Fr = |Ft| / cos(psi) (tan(alpha_n) cos(delta) - s sin(psi) sin(delta))

``Fa`` positive away from the cone apex (upstream here), ``Fr`` positive toward the
pinion axis (separating). ``s = +1`` (the upper signs of the handbooks' ``±``/``∓``)
where the pinion drives turning clockwise seen from its back toward the apex with a
left-hand spiral (or counter-clockwise with a right-hand one): it is pushed out of
mesh; ``s = -1`` where it is drawn into mesh. The line's shafts turn positive about
their axes, downstream, so the pinion turns clockwise seen from its back, and the load
torque opposes the rotation: at ``T > 0`` a ``hand = "left"`` pinion has ``s = +1``, a
``"right"`` one ``s = -1`` (a right-hand pinion driving clockwise moves toward the cone
centre: Crosher, "Tooth Tips", Gear Solutions). At ``T < 0`` the other flank carries
the load: ``s`` changes sign, the pressure terms keep their separating sense.

A hypoid pinion's ``psi`` exceeds its ring gear's (``gear_spiral_angle_deg``,
``beta_m2``) by the offset angle in the pitch plane; the normal force is common, so the
gear's tangential force is ``Ft2 = Ft1 cos(beta_m2) / cos(beta_m1)``
(:func:`gear_tangential_force`). One normal pressure angle stands for the hypoid's
drive and coast flanks (ISO 23509 gives them apart); the limit pressure angle is not
modelled.

A line has at most one mesh at each end: on its last shaft, of any type, and on its
first, a helical one. The penalty simulation applies the mesh force instead of the
torque, at the mesh point fixed in space on the body that holds the gear
(:meth:`~..penalty_model.Model._line_loads`), and MuJoCo's model likewise at each step
(:func:`~..engine_mujoco.run`). Drake is given the line's torques as torques: it refuses
a scene with a mesh, in one line.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..scene import Range, Scene, SceneError
from .base import MUJOCO, PENALTY_SIMULATION, Loads
from .inshaft import InShaftKind

PRESSURE_ANGLE_DEG = Range(10.0, 35.0, "deg")
"""Normal pressure angles of involute gears: 20 deg is ISO 53's standard profile; 14.5
to 30 deg are in use."""

HELIX_ANGLE_DEG = Range(-45.0, 45.0, "deg")
"""Helix angles of helical gears: up to about 45 deg (double-helical); single-helical
gears run 15 to 30 deg."""

PITCH_RADIUS_M = Range(5e-3, 2.0, "m")
"""Pitch radii of the gears such a line drives: a few millimetres to a 4 m wheel (a
bevel or hypoid pinion's mean pitch radius)."""

PITCH_CONE_ANGLE_DEG = Range(1.0, 89.0, "deg")
"""Pitch cone angles of bevel and hypoid pinions, strictly between the cylinder (0 deg)
and the crown gear (90 deg): a 90 deg drive's pinion has ``atan(z1 / z2)``, about 8 deg
at 7:1 to 45 deg for a mitre pair."""

SPIRAL_ANGLE_DEG = Range(0.0, 60.0, "deg")
"""Mean spiral angles of bevel and hypoid gears (the hand apart): 0 deg straight (or
Zerol), 35 deg the usual spiral bevel, 45 to 50 deg a hypoid pinion's, 60 deg about the
most cut."""

GEAR_TYPES = ("helical", "bevel", "hypoid")
"""What a gear mesh's ``type`` names: a cylindrical (spur or helical) gear, a bevel
pinion (straight or spiral) or a hypoid pinion."""

HANDS = ("left", "right")
"""The hand of a bevel or hypoid pinion's spiral: a right-hand tooth's outer half turns
clockwise from the axial plane through its mean point, seen from the cone's apex (a
right-hand helix in the limit of a cylinder)."""

_ONLY = {"helix_angle_deg": ("helical",), "pitch_cone_angle_deg": ("bevel", "hypoid"),
         "spiral_angle_deg": ("bevel", "hypoid"), "hand": ("bevel", "hypoid"),
         "gear_spiral_angle_deg": ("hypoid",)}
"""The fields that apply to some types of gear only, with those types."""


@dataclass(frozen=True)
class GearMesh:
    """A gear on shaft ``shaft`` at ``offset_m`` from its centre meshing with a gear
    outside the line (module doc): its ``type`` (:data:`GEAR_TYPES`), pitch radius (m;
    the mean one of a bevel or hypoid pinion), normal pressure angle (deg), where on
    the circle the mesh sits (deg about the axis from ``r1``); a helical gear's helix
    angle (deg, signed); a bevel or hypoid pinion's pitch cone angle, mean spiral angle
    (deg) and hand (:data:`HANDS`); a hypoid ring gear's mean spiral angle (deg). The
    fields of the other types are None.
    """

    name: str
    shaft: str
    offset_m: float
    pitch_radius_m: float
    pressure_angle_deg: float = 20.0
    helix_angle_deg: float | None = 0.0
    mesh_angle_deg: float = 0.0
    type: str = "helical"
    pitch_cone_angle_deg: float | None = None
    spiral_angle_deg: float | None = None
    hand: str | None = None
    gear_spiral_angle_deg: float | None = None


def spiral_sign(torque_N_m, gear: GearMesh) -> np.ndarray:
    """``s`` of the module doc, +1 where the pinion is pushed out of mesh (a left-hand
    spiral driving, ``T >= 0``), -1 where it is drawn in; arrays like the torque.
    """
    hand = 1.0 if gear.hand == "left" else -1.0
    return np.where(np.asarray(torque_N_m, float) < 0, -hand, hand)


def nominal_forces(torque_N_m, gear: GearMesh) -> tuple:
    """``(Ft, Fr, Fa)`` (N) at the load torque ``torque_N_m`` (N m; arrays over instants
    where the torque is one): ISO 6336-1's nominal loads of a helical gear, or a bevel
    or hypoid pinion's loads at the mean point (module doc: ``Ft`` signed as the
    torque, ``Fr`` positive toward the axis, ``Fa`` positive away from the cone apex).
    """
    ft = np.asarray(torque_N_m, float) / gear.pitch_radius_m
    alpha = math.radians(gear.pressure_angle_deg)
    if gear.type == "helical":
        beta = math.radians(gear.helix_angle_deg)
        return ft, np.abs(ft) * math.tan(alpha) / math.cos(beta), ft * math.tan(abs(beta))
    delta, psi = math.radians(gear.pitch_cone_angle_deg), math.radians(gear.spiral_angle_deg)
    s, normal = spiral_sign(torque_N_m, gear), np.abs(ft) / math.cos(psi)
    fa = normal * (math.tan(alpha) * math.sin(delta) + s * math.sin(psi) * math.cos(delta))
    fr = normal * (math.tan(alpha) * math.cos(delta) - s * math.sin(psi) * math.sin(delta))
    return ft, fr, fa


def gear_tangential_force(pinion_tangential_N, gear: GearMesh):
    """The ring gear's tangential force (N) at its mean point from the pinion's
    ``pinion_tangential_N``: ``Ft2 = Ft1 cos(beta_m2) / cos(beta_m1)``, the one normal
    force's share along each member's pitch-plane tangent (module doc); equal to
    ``Ft1`` for a bevel pair (one spiral angle), refused for a helical gear.
    """
    if gear.type == "helical":
        raise ValueError(f"gear mesh {gear.name!r}: a helical gear has no ring gear")
    psi1 = math.radians(gear.spiral_angle_deg)
    psi2 = math.radians(gear.gear_spiral_angle_deg if gear.type == "hypoid"
                        else gear.spiral_angle_deg)
    return np.asarray(pinion_tangential_N, float) * math.cos(psi2) / math.cos(psi1)


def _meshes(scene: Scene) -> list[tuple[GearMesh, int]]:
    """The scene's gear meshes with their shafts' indices."""
    shafts = [s.name for s in scene.shafts]
    return [(e, shafts.index(e.shaft)) for e in scene.elements if isinstance(e, GearMesh)]


class Mesh(InShaftKind, Loads):
    """The gear mesh kind (module doc)."""

    name, table, record, noun = "gear", "gear_meshes", GearMesh, "gear mesh"
    cuts = False

    def read_fields(self, t) -> dict:
        """Its type, then the fields of that type (module doc); a field of another type
        is refused by name.
        """
        kind = t.string("type", "helical", choices=GEAR_TYPES)
        for key, types in _ONLY.items():
            if key in t.raw and kind not in types:
                t.fail(key, f"applies to {' and '.join(types)} gears, not to a {kind} one")
        fields = dict(
            type=kind,
            pitch_radius_m=t.number("pitch_radius_m", positive=True, kind="length_m",
                                    within=PITCH_RADIUS_M, why="gears of drive lines"),
            pressure_angle_deg=t.number("pressure_angle_deg", 20.0, kind="angle_deg",
                                        within=PRESSURE_ANGLE_DEG,
                                        why="involute gears' pressure angles"),
            mesh_angle_deg=t.number("mesh_angle_deg", 0.0, kind="angle_deg"))
        if kind == "helical":
            fields["helix_angle_deg"] = t.number("helix_angle_deg", 0.0, kind="angle_deg",
                                                 within=HELIX_ANGLE_DEG,
                                                 why="helical gears' helix angles")
            return fields
        fields.update(
            helix_angle_deg=None,
            pitch_cone_angle_deg=t.number("pitch_cone_angle_deg", kind="angle_deg",
                                          within=PITCH_CONE_ANGLE_DEG,
                                          why="bevel pinions' pitch cones"),
            spiral_angle_deg=t.number("spiral_angle_deg", 0.0 if kind == "bevel" else ...,
                                      kind="angle_deg", within=SPIRAL_ANGLE_DEG,
                                      why=f"{kind} gears' mean spiral angles"))
        if fields["spiral_angle_deg"] > 0 or "hand" in t.raw:
            fields["hand"] = t.string("hand", choices=HANDS)
        if kind == "hypoid":
            fields["gear_spiral_angle_deg"] = t.number(
                "gear_spiral_angle_deg", kind="angle_deg", within=SPIRAL_ANGLE_DEG,
                why="hypoid ring gears' mean spiral angles")
        return fields

    def check(self, element: GearMesh, shaft: int, scene: Scene) -> None:
        """On the last shaft (it takes the line's load) or, a helical gear, on the first
        (it drives the line); one at each end at most.
        """
        last = len(scene.shafts) - 1
        where = f"scene {scene.source}: gear mesh {element.name!r}: "
        if shaft not in (0, last):
            raise SceneError(where + "a gear mesh sits on the first shaft (it drives the "
                             "line) or on the last (it takes the line's load torque)")
        if shaft == 0 and element.type != "helical":
            raise SceneError(where + f"a {element.type} pinion ends the line (its cone's "
                             "apex lies downstream); only a helical gear drives it")
        same_end = [e for e, k in _meshes(scene) if k == shaft]
        if len(same_end) > 1:
            raise SceneError(where + "at most one gear mesh at each end of the line")

    def describe(self, gear: GearMesh) -> str:
        where = (f"on shaft {gear.shaft} @ {gear.offset_m:+g} m, pressure angle "
                 f"{gear.pressure_angle_deg} deg, at {gear.mesh_angle_deg} deg")
        if gear.type == "helical":
            return (f"gear mesh {gear.name}: helical gear {where}, pitch radius "
                    f"{gear.pitch_radius_m} m, helix {gear.helix_angle_deg} deg")
        spiral = (f"{gear.hand}-hand spiral {gear.spiral_angle_deg} deg"
                  if gear.spiral_angle_deg > 0 else "straight teeth")
        ring = (f", ring gear spiral {gear.gear_spiral_angle_deg} deg"
                if gear.type == "hypoid" else "")
        return (f"gear mesh {gear.name}: {gear.type} pinion {where}, mean pitch radius "
                f"{gear.pitch_radius_m} m, pitch cone {gear.pitch_cone_angle_deg} deg "
                f"(apex downstream), {spiral}{ring}")

    def load(self, gear: GearMesh, torque_N_m: np.ndarray, frame: np.ndarray,
             centre: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The mesh force on the shaft: ``(point, force)``, the point (3,) fixed in space
        on the pitch circle (a bevel or hypoid pinion's mean point), the force (T, 3)
        taking the torque ``torque_N_m`` (T,) off a shaft of frame rows ``r1, r2, axis`` and
        centre ``centre`` (m, global). A bevel or hypoid pinion's cone apex lies
        downstream, so its ``Fa`` (away from the apex) acts upstream.
        """
        r1, r2, axis = frame
        angle = math.radians(gear.mesh_angle_deg)
        out = math.cos(angle) * r1 + math.sin(angle) * r2  # from the axis to the mesh
        point = centre + gear.offset_m * axis + gear.pitch_radius_m * out
        ft, fr, fa = nominal_forces(torque_N_m, gear)
        along = (-axis if gear.type != "helical"
                 else math.copysign(1.0, gear.helix_angle_deg) * axis)
        force = (-ft[:, None] * np.cross(axis, out) - fr[:, None] * out
                 + fa[:, None] * along)
        return point, force

    def holds(self, gear: GearMesh, shaft, segments, frames) -> list:
        """None: the mesh is a load (:meth:`load`), not a contact; it stops nothing."""
        return []

    def add_links(self, gear: GearMesh, shaft: int, index: int, layout) -> None:
        """None: the mesh is a load (:meth:`load`), not a contact."""

    def refusal(self, gear: GearMesh, engine: str) -> str | None:
        if engine in (PENALTY_SIMULATION, MUJOCO):
            return None
        return (f"gear mesh {gear.name!r}: {engine} applies the line's torques as "
                "torques, not as mesh forces")


KIND = Mesh()
