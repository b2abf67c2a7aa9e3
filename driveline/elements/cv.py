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
as stiff as a bearing, ``k`` for the forces and ``k (1 m)^2`` for the moment.

MuJoCo (:meth:`CV.mjcf_steps`): the driven shaft hangs on the driving one by three
hinges through the centre, about ``a_in``, about the normal ``n`` of the shafts' plane
and about ``a_out`` (angles ``psi``, ``beta'``, ``chi`` from the start), with the
coupling ``chi = -psi`` (a joint equality). The relative rotation ``Rz(psi) Rn(beta')
Rz(-psi)`` then turns about an axis normal to ``a_in`` only: the driven shaft is turned
by the driving one's angle about its own axis, homokinetic at any angle, and its first
order freedoms ``n`` and ``a_in - a_out`` span the plane normal to the bisector, the two
rotations the rigid joint allows. In steady running the two engine bodies between the
hinges do not spin (``psi`` runs at minus the shaft speed). Drake is not handed the
coupling: it refuses the joint, in one line.

Penalty model (:meth:`CV.penalty`): a bushing at the joint centre, stiff in the three
translations (the centre is common to both shafts), stiff in the one relative rotation
the rigid joint stops and free in the two it allows. Homokinetic means the driven shaft
is the mirror image of the driving one in the bisecting plane (Seherr-Thoss, Schmelz,
Aucktor, op. cit., on the homokinetic condition: the balls, held by the cage, stay in
the plane that bisects the shafts' angle): with ``M = I - 2 b b^T`` that mirror, the
shafts' rotations since the start satisfy ``R_out = M R_in M`` (a mirror turns a
rotation about ``a_in`` into one about ``-M a_in = a_out`` by the same angle). So a
torsion spring ``theta = (M x1 . y2 - M x2 . y1) / 2``, ``x1, x2`` normal to ``a_in``
and fixed in the driving shaft, their mirrors ``M x1, M x2`` fixed in the driven one
(a ``TWIST`` row), stays at ``theta = 0`` while the two turn homokinetically at any
angle; its rate is ``g . (w_out - w_in)`` with ``g = cos(beta/2) b`` (normal to
``b``, bending, it does not feel to first order), so its stiffness ``k (1 m)^2 /
cos^2(beta/2)`` gives the rigid law's ``k (1 m)^2`` about the bisector. The shafts'
frames are turned by ``Q`` (the rotation by ``beta`` about ``a_in x a_out``) relative
to each other while they turn, ``R_out = Q R_in Q^T``, so no spring fixed in both can
stay aligned: three springs with their driven side turned by ``Q`` (force ``-k/2 Q
p`` on the driven shaft, ``p`` the driven centre's offset from the driving one), and
three the other way round (``-k/2 Q^T p``) make the symmetric, hence conservative,
stiffness ``k (Q + Q^T) / 2``: ``k`` normal to the shafts' plane, ``k cos(beta)``
within it (at least 0.64 ``k`` up to 50 deg), the joint's law's ``k`` as the scenes'
bearing stiffness. Damping: the scene's fraction of each stiffness, as a bushing's.
The relations hold for the articulation at the start; the penalty model's axes move by
microradians about it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..scene import Range, table_keys
from .base import MUJOCO, PENALTY_SIMULATION, Column, EngineJoint, EngineStep, Law, Layout, Link
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


def reflection(normal: np.ndarray) -> np.ndarray:
    """(3, 3): the mirror in the plane of unit normal ``normal``, ``I - 2 n n^T``; in the
    bisecting plane (``normal`` the bisector) it takes the driving shaft onto the driven
    one (module doc).
    """
    return np.eye(3) - 2.0 * np.outer(normal, normal)


def bend(a_in: np.ndarray, a_out: np.ndarray) -> np.ndarray:
    """(3, 3): the rotation ``Q`` by the articulation angle about ``a_in x a_out`` that
    takes ``a_in`` to ``a_out`` (the identity for aligned shafts), Rodrigues' formula.
    """
    axis, cos = np.cross(a_in, a_out), float(np.dot(a_in, a_out))
    cross = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]],
                      [-axis[1], axis[0], 0.0]])
    return np.eye(3) + cross + cross @ cross / (1.0 + cos)


class CV(JointKind, EngineJoint):
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

    def penalty(self, link: Link, rows) -> None:
        """A bushing homokinetic in twist and free in bending (module doc): at the
        joint centre, between the driven shaft's body and the driving shaft's, three
        springs that share the centre, each half flipped, and one twist spring about the
        bisector.
        """
        op, k = rows.op, rows.scene.contact.bearing_stiffness_N_m
        centre = op.points[0, link.columns[0]]
        a_in, a_out = op.shaft_frames[link.shaft][2], op.shaft_frames[link.shaft + 1][2]
        turn, mirror = bend(a_in, a_out), reflection(bisector(a_in, a_out))
        half = rows.law(0.5 * k)
        for z in np.eye(3):
            rows.spring(link, centre, turn @ z, z, half)
            rows.spring(link, centre, turn @ z, z, half, flip=True)
        r1, r2, _ = op.shaft_frames[link.shaft]
        cos_half = float(np.dot(a_in, bisector(a_in, a_out)))
        rows.twist(link, (mirror @ r1, mirror @ r2), (r1, r2),
                   rows.law(k * LENGTH_M ** 2 / cos_half ** 2))

    def mjcf_steps(self, link: Link, child: int, start) -> list[EngineStep]:
        """The driven shaft (the engine's tree runs downstream) on the driving one by
        three hinges through the centre (module doc), their speeds those of non-spinning
        engine bodies between them.
        """
        j, geo = link.joint, start.geo
        a_in, a_out, centre = geo.axes[j], geo.axes[j + 1], geo.joint_centres[j]
        normal = np.cross(a_in, a_out)
        if np.linalg.norm(normal) < 1e-12:  # straight: any normal of the axis
            normal = np.cross(a_in, np.eye(3)[np.argmin(np.abs(a_in))])
        speed = start.speed * start.kin.ratio[j, 0]
        return [EngineStep("hinge", a_in, centre, -speed),
                EngineStep("hinge", normal / np.linalg.norm(normal), centre),
                EngineStep("hinge", a_out, centre, speed)]

    def mjcf_couplings(self, link: Link, joints: list[str], soft: str) -> str:
        """The homokinetic coupling ``chi = -psi`` of the first and last hinges."""
        return (f'<joint name="{link.name}.homokinetic" joint1="{joints[-1]}" '
                f'joint2="{joints[0]}" polycoef="0 -1 0 0 0" {soft}/>')

    def refusal(self, joint: CVJoint, engine: str) -> str | None:
        if engine in (PENALTY_SIMULATION, MUJOCO):
            return None
        return (f"constant-velocity joint {joint.name!r}: {engine} is not handed its "
                "hinges' homokinetic coupling (an MJCF joint equality)")

    def words(self, link: Link) -> str:
        return "constant-velocity joint"


KIND = CV()
