"""The flexible disc coupling: a compliant link inside a shaft (a rubber disc, a
"giubo", or a steel disc pack between two flanges) that cuts the shaft into two
segments and carries every load between them through its own stiffness.

Its link acts on the downstream segment at the coupling and the opposite on the
upstream one, in the shaft's frame: ``<coupling>.shear.<r1|r2>`` and
``<coupling>.axial`` (N), ``<coupling>.bending.<r1|r2>`` and ``<coupling>.torque``
(N m). In the rigid model it is a weld (six bilateral components, so it removes no
redundancy and adds none); in the compliance formulations each component has the
coupling's own stiffness, without gap (``radial_stiffness_N_m`` for the shear,
``axial_stiffness_N_m``, ``angular_stiffness_N_m_rad`` for the bending,
``torsional_stiffness_N_m_rad``), linear. Makers give these four (e.g. a flexible disc
coupling's data sheet lists torsional, axial, angular and radial stiffness); the
ranges accepted (:data:`STIFFNESS`) span rubber discs to steel disc packs.

The penalty simulation models it as a bushing (:meth:`~..penalty.ContactRows.bushing`:
a linear six-way spring-damper at the coupling, in the shaft's frame, with these
stiffnesses and the scene's damping fraction of each); its reported forces are the
link's six columns. MuJoCo (:meth:`Disc.mjcf_steps`) models the same bushing as six
sprung joints in a row at the coupling, slides along ``r1, r2, axis`` then hinges about
them (small deflections: the order does not matter to first order), each with its
stiffness and damping. Drake is not handed joint springs: it refuses the coupling, in
one line.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..scene import Range
from .base import MUJOCO, PENALTY_SIMULATION, Column, EngineJoint, EngineStep, Law, Layout, Link
from .inshaft import InShaftKind, sides

STIFFNESS = {
    "radial_stiffness_N_m": Range(1e4, 1e11, "N/m"),
    "axial_stiffness_N_m": Range(1e3, 1e11, "N/m"),
    "angular_stiffness_N_m_rad": Range(1.0, 1e9, "N m/rad"),
    "torsional_stiffness_N_m_rad": Range(1e2, 1e10, "N m/rad"),
}
"""Accepted stiffness of each component: a rubber disc (about 1e5 N/m axially, 1e3 N
m/rad in bending, 1e4 N m/rad in torsion) to a steel disc pack, with a decade of room
either way; below them a coupling holds nothing, above them it is a weld (the rigid
model's reading)."""


@dataclass(frozen=True)
class DiscCoupling:
    """A flexible disc coupling inside shaft ``shaft``, ``offset_m`` from its centre
    (downstream positive), with its four stiffnesses (module doc).
    """

    name: str
    shaft: str
    offset_m: float
    radial_stiffness_N_m: float
    axial_stiffness_N_m: float
    angular_stiffness_N_m_rad: float
    torsional_stiffness_N_m_rad: float


COMPONENTS = ("shear.r1", "shear.r2", "axial", "bending.r1", "bending.r2", "torque")
"""Its components in column order, named in the shaft's frame."""


class Disc(InShaftKind, EngineJoint):
    """The flexible disc coupling kind (module doc)."""

    name, table, record, noun = "disc", "disc_couplings", DiscCoupling, "disc coupling"
    link_kinds = ("disc-coupling",)

    def read_fields(self, t) -> dict:
        return {key: t.number(key, positive=True, kind="stiffness", within=within,
                              why="rubber discs to steel disc packs")
                for key, within in STIFFNESS.items()}

    def describe(self, disc: DiscCoupling) -> str:
        return (f"disc coupling {disc.name} in shaft {disc.shaft} @ {disc.offset_m:+g} m, "
                f"stiffness radial {disc.radial_stiffness_N_m:g} N/m, axial "
                f"{disc.axial_stiffness_N_m:g} N/m, angular "
                f"{disc.angular_stiffness_N_m_rad:g} N m/rad, torsional "
                f"{disc.torsional_stiffness_N_m_rad:g} N m/rad")

    def holds(self, element: DiscCoupling, shaft, segments, frames):
        up, down = sides(segments, shaft, element.offset_m)
        return [(up, np.eye(3), down)]

    def add_links(self, element: DiscCoupling, shaft: int, index: int,
                  layout: Layout) -> None:
        up, down = sides(layout.segments, shaft, element.offset_m)
        geo = layout.geo
        point = geo.centres[shaft] + element.offset_m * geo.axes[shaft]
        r1, r2, axis = layout.frames[shaft]
        directions = (r1, r2, axis, r1, r2, axis)
        moments = (False, False, False, True, True, True)
        columns = [Column(f"{element.name}.{c}", down, up, None if m else point, d)
                   for c, d, m in zip(COMPONENTS, directions, moments)]
        layout.add(columns, name=element.name, kind=self.link_kinds[0], body=down,
                   other=up, element=element.name, frame="shaft", components=COMPONENTS,
                   shaft=shaft, units=("N",) * 3 + ("N m",) * 3)

    def laws(self, link: Link, scene) -> list[Law]:
        disc = next(e for e in scene.elements if e.name == link.element)
        c = link.columns
        return [Law(c[0:2], disc.radial_stiffness_N_m, 0.0),
                Law(c[2:3], disc.axial_stiffness_N_m, 0.0),
                Law(c[3:5], disc.angular_stiffness_N_m_rad, 0.0),
                Law(c[5:6], disc.torsional_stiffness_N_m_rad, 0.0)]

    def penalty(self, link: Link, rows) -> None:
        """One bushing at the coupling, in the shaft's frame (r1, r2, axis)."""
        disc = next(e for e in rows.scene.elements if e.name == link.element)
        radial, angular = disc.radial_stiffness_N_m, disc.angular_stiffness_N_m_rad
        rows.bushing(link, rows.op.points[0, link.columns[0]], rows.op.shaft_frames[link.shaft],
                     (radial, radial, disc.axial_stiffness_N_m),
                     (angular, angular, disc.torsional_stiffness_N_m_rad))

    def mjcf_steps(self, link: Link, child: int, start) -> list[EngineStep]:
        """The bushing as six sprung joints at the coupling (module doc): slides along
        the shaft's ``r1, r2, axis``, then hinges about them, each with its stiffness and
        the scene's damping fraction of it; all start still (one shaft, one speed).
        """
        disc = next(e for e in start.scene.elements if e.name == link.element)
        k, geo = link.shaft, start.geo
        point = geo.centres[k] + disc.offset_m * geo.axes[k]
        radial, angular = disc.radial_stiffness_N_m, disc.angular_stiffness_N_m_rad
        stiff = (radial, radial, disc.axial_stiffness_N_m,
                 angular, angular, disc.torsional_stiffness_N_m_rad)
        fraction = start.scene.contact.damping_fraction_of_stiffness
        axes = np.concatenate([start.frames[k]] * 2)
        return [EngineStep("slide" if i < 3 else "hinge", axes[i], point, 0.0, s,
                           fraction * s) for i, s in enumerate(stiff)]

    def refusal(self, disc: DiscCoupling, engine: str) -> str | None:
        if engine in (PENALTY_SIMULATION, MUJOCO):
            return None
        return (f"disc coupling {disc.name!r}: {engine} is not handed its six sprung "
                "joints (MJCF joint springs)")

    def words(self, link: Link) -> str:
        return "disc coupling"


KIND = Disc()
