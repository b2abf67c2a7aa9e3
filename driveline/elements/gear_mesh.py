"""The gear mesh: the line's load taken off its last shaft by a gear instead of a pure
torque. The mating gear is held by its own bearings (outside the line), so the mesh is
an applied load, not a contact: a force at the mesh point on the pitch circle whose
moment about the shaft axis is the scene's load torque, with the radial and axial
components the tooth geometry adds. Those load the shaft's bearings; they do no work
on the 1-DOF motion (the axes are fixed), which stays the scene's.

Nominal loads of a helical (spur for ``helix_angle_deg = 0``) gear from the torque
``T`` (ISO 6336-1:2019, 5.2, with the pitch diameter ``d = 2 r``):

    Ft = T / r,   Fr = Ft tan(alpha_n) / cos(beta),   Fa = Ft tan(|beta|)

``alpha_n`` the normal pressure angle, ``beta`` the helix angle at the pitch circle.
The mesh point sits ``mesh_angle_deg`` about the shaft axis from the shaft frame's
``r1`` (in the articulation plane), ``offset_m`` along it; the tangential force opposes
the rotation, the radial one points to the axis, and the axial one acts along the axis,
downstream for a positive ``helix_angle_deg``, upstream for a negative one (the sign
stands for the hand of the helix and the sense of the load). Bevel and hypoid meshes
(ISO 10300) and duty cycles are the next step.

A line has at most one, on its last shaft. The penalty simulation and the physics
engines apply the load as a torque: they refuse a scene with a mesh, in one line.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..scene import Range, Scene, SceneError
from .inshaft import InShaftKind

PRESSURE_ANGLE_DEG = Range(10.0, 35.0, "deg")
"""Normal pressure angles of involute gears: 20 deg is ISO 53's standard profile; 14.5
to 30 deg are in use."""

HELIX_ANGLE_DEG = Range(-45.0, 45.0, "deg")
"""Helix angles of helical gears: up to about 45 deg (double-helical); single-helical
gears run 15 to 30 deg."""

PITCH_RADIUS_M = Range(5e-3, 2.0, "m")
"""Pitch radii of the gears such a line drives: a few millimetres to a 4 m wheel."""


@dataclass(frozen=True)
class GearMesh:
    """A gear on shaft ``shaft`` at ``offset_m`` from its centre meshing with a gear
    outside the line (module doc): pitch radius (m), normal pressure and helix angles
    (deg) and where on the circle the mesh sits (deg about the axis from ``r1``).
    """

    name: str
    shaft: str
    offset_m: float
    pitch_radius_m: float
    pressure_angle_deg: float = 20.0
    helix_angle_deg: float = 0.0
    mesh_angle_deg: float = 0.0


def nominal_forces(torque_N_m, gear: GearMesh) -> tuple:
    """``(Ft, Fr, Fa)`` (N) of ISO 6336-1's nominal loads at torque ``torque_N_m``
    (module doc); arrays over instants where the torque is one.
    """
    ft = np.asarray(torque_N_m, float) / gear.pitch_radius_m
    beta, alpha = math.radians(gear.helix_angle_deg), math.radians(gear.pressure_angle_deg)
    return ft, ft * math.tan(alpha) / math.cos(beta), ft * math.tan(abs(beta))


class Mesh(InShaftKind):
    """The gear mesh kind (module doc)."""

    name, table, record, noun = "gear", "gear_meshes", GearMesh, "gear mesh"
    cuts = False
    takes_load = True

    def read_fields(self, t) -> dict:
        return dict(
            pitch_radius_m=t.number("pitch_radius_m", positive=True, kind="length_m",
                                    within=PITCH_RADIUS_M, why="gears of drive lines"),
            pressure_angle_deg=t.number("pressure_angle_deg", 20.0, kind="angle_deg",
                                        within=PRESSURE_ANGLE_DEG,
                                        why="involute gears' pressure angles"),
            helix_angle_deg=t.number("helix_angle_deg", 0.0, kind="angle_deg",
                                     within=HELIX_ANGLE_DEG,
                                     why="helical gears' helix angles"),
            mesh_angle_deg=t.number("mesh_angle_deg", 0.0, kind="angle_deg"))

    def check(self, element: GearMesh, shaft: int, scene: Scene) -> None:
        """On the last shaft, alone: it takes the line's load."""
        meshes = [e for e in scene.elements if isinstance(e, GearMesh)]
        if shaft != len(scene.shafts) - 1 or len(meshes) > 1:
            raise SceneError(f"scene {scene.source}: gear mesh {element.name!r}: a line "
                             "has at most one gear mesh, on its last shaft (it takes the "
                             "line's load torque)")

    def describe(self, gear: GearMesh) -> str:
        return (f"gear mesh {gear.name} on shaft {gear.shaft} @ {gear.offset_m:+g} m, pitch "
                f"radius {gear.pitch_radius_m} m, pressure angle {gear.pressure_angle_deg} "
                f"deg, helix {gear.helix_angle_deg} deg, at {gear.mesh_angle_deg} deg")

    def load(self, gear: GearMesh, torque_N_m: np.ndarray, frame: np.ndarray,
             centre: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The mesh force on the shaft: ``(point, force)``, the point (3,) fixed in space
        on the pitch circle, the force (T, 3) at the load torque ``torque_N_m`` (T,) on a
        shaft of frame rows ``r1, r2, axis`` and centre ``centre`` (m, global).
        """
        r1, r2, axis = frame
        angle = math.radians(gear.mesh_angle_deg)
        out = math.cos(angle) * r1 + math.sin(angle) * r2  # from the axis to the mesh
        point = centre + gear.offset_m * axis + gear.pitch_radius_m * out
        ft, fr, fa = nominal_forces(torque_N_m, gear)
        along = math.copysign(1.0, gear.helix_angle_deg) * axis
        force = (-ft[:, None] * np.cross(axis, out) - fr[:, None] * out
                 + fa[:, None] * along)
        return point, force

    def add_links(self, gear: GearMesh, shaft: int, index: int, layout) -> None:
        """None: the mesh is a load (:meth:`load`), not a contact."""

    def refusal(self, gear: GearMesh, engine: str) -> str | None:
        return (f"gear mesh {gear.name!r}: {engine} applies the line's load as a torque, "
                "not as mesh forces")


KIND = Mesh()
