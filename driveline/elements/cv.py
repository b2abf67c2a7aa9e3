"""The fixed ball-type constant-velocity (CV, Rzeppa) joint: the driven shaft turns at
the driving shaft's speed at any angle (homokinetic), its balls held by the cage in the
plane that bisects the shafts' angle.

Rigid model: a spherical joint at the joint centre that also holds the two shafts'
spin together. Its link acts on the driven shaft's first body and the opposite on the
driving shaft's last: ``<joint>.force.<r1|r2|axial>`` (N) in the driving shaft's frame
at the centre, and ``<joint>.moment`` (N m) about the bisector ``b = (a_in + a_out) /
|a_in + a_out|``, the one rotation the joint stops (its shafts may turn relative to each
other about any axis normal to ``b``: the articulation). A moment ``M`` about ``b`` has
the component ``M cos(beta/2)`` along either shaft, the torque ``T`` it transmits, and
``M sin(beta/2) = T tan(beta/2)`` normal to it: the joint's internal bending moment
(secondary couple) on each shaft, constant over a turn, where a Cardan joint's swings
between ``0`` and ``T tan(beta)`` (Seherr-Thoss, Schmelz, Aucktor, *Universal Joints and
Driveshafts*, 2nd ed., Springer 2006, on the additional moments of homokinetic joints).
The cage and balls are massless (no body).

Kinematics: the driven angle equals the driving one (its rest reference carried over
the articulation as a Cardan joint's driven yoke), so the ratio is 1 and its derivative
0 whatever the angle. Contact laws (an assumption: the scenes give no joint stiffness):
as stiff as a bearing, ``k`` for the forces and ``k (1 m)^2`` for the moment. The
penalty simulation and the physics engines have no homokinetic constraint: they refuse
a scene that holds one, in one line.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..scene import Range, table_keys
from .base import Column, Law, Layout, Link
from .joint import JointKind, JointStep, rotate_perp

LENGTH_M = 1.0
"""Length that turns the bearing stiffness (N/m) into the joint's stiffness about its
bisector (N m/rad), as a slip joint's bending and torsion."""

MAX_CV_ARTICULATION_DEG = 50.0
"""Largest angle of a fixed ball CV joint: makers' fixed joints reach 45 to 50 deg (the
wheel side of a steered front axle); the plunging ones about 25 deg."""


@dataclass(frozen=True)
class CVJoint:
    """A fixed ball CV joint at the end of one shaft and the start of the next: its
    articulation angle (deg, the sense following the scene's arrangement).
    """

    name: str
    articulation_deg: float
    kind: str = "cv"


def bisector(a_in: np.ndarray, a_out: np.ndarray) -> np.ndarray:
    """The unit bisector of two shaft axes: the axis of the joint's constraint moment."""
    b = a_in + a_out
    return b / np.linalg.norm(b)


class CV(JointKind):
    """The constant-velocity joint kind (module doc)."""

    name, record = "cv", CVJoint
    homokinetic = True
    link_kinds = ("cv-joint",)

    def read(self, t) -> CVJoint:
        t.expect(table_keys(CVJoint))
        joint = CVJoint(name=t.string("name", name=True), kind=self.name,
                        articulation_deg=t.number(
                            "articulation_deg", kind="angle_deg",
                            within=Range(-MAX_CV_ARTICULATION_DEG, MAX_CV_ARTICULATION_DEG,
                                         "deg"),
                            why="the largest angle of makers' fixed CV joints"))
        t.done()
        return joint

    def describe(self, joint: CVJoint) -> str:
        return (f"joint {joint.name:13s} constant velocity, articulation "
                f"{joint.articulation_deg} deg")

    def kinematics(self, a_in, a_out, yoke_in, yoke_out, phi, ratio, ratio_dq):
        """The driven shaft at the driving shaft's angle, speed and acceleration; the
        frame is the references turned with their shafts, the rate the cage's (half the
        sum of the shafts' angular velocities, about the bisector), for the record: the
        joint adds no body.
        """
        e1, e2 = rotate_perp(yoke_in, a_in, phi), rotate_perp(yoke_out, a_out, phi)
        mean = 0.5 * (a_in + a_out)
        return JointStep(phi, ratio, ratio_dq, e1, e2, ratio[:, None] * mean,
                         ratio_dq[:, None] * mean)

    def holds(self, element, shaft, segments, frames):
        up = max(g for g, s in enumerate(segments) if s.shaft == shaft)
        return [(up, np.eye(3), up + 1)]

    def add_links(self, element: CVJoint, shaft: int, index: int, layout: Layout) -> None:
        geo = layout.geo
        up = max(g for g, s in enumerate(layout.segments) if s.shaft == shaft)
        down, centre = up + 1, geo.joint_centres[index]
        r1, r2, axis = layout.frames[shaft]
        b = bisector(geo.axes[shaft], geo.axes[shaft + 1])
        name = element.name
        columns = [Column(f"{name}.force.r1", down, up, centre, r1),
                   Column(f"{name}.force.r2", down, up, centre, r2),
                   Column(f"{name}.force.axial", down, up, centre, axis),
                   Column(f"{name}.moment", down, up, None, b)]
        layout.add(columns, name=name, kind=self.link_kinds[0], body=down, other=up,
                   element=name, frame="joint", components=("force.r1", "force.r2",
                                                            "force.axial", "moment"),
                   shaft=shaft, joint=index, units=("N", "N", "N", "N m"))

    def laws(self, link: Link, scene) -> list[Law]:
        k, c = scene.contact.bearing_stiffness_N_m, link.columns
        return [Law(c[:3], k, 0.0), Law(c[3:], k * LENGTH_M ** 2, 0.0)]

    def refusal(self, joint: CVJoint, engine: str) -> str | None:
        return (f"constant-velocity joint {joint.name!r}: {engine} has no homokinetic "
                "constraint to model it with")

    def words(self, link: Link) -> str:
        return "constant-velocity joint"


KIND = CV()
