"""What every rolling bearing kind shares: a bearing is a contact of one shaft body
with the ground at its bearing point, carrying a force and no moment.

A kind says which components it has (:meth:`BearingKind.directions`: the
translations it stops follow from them) and how it reads its fields of a scene's
``[[shafts.bearings]]`` table (:meth:`BearingKind.read`: ``name``, ``offset_m`` and
``rating`` are read for every kind by :mod:`..loading`). Its contact laws, for the
compliance energy and the penalty model, are linear with the scene's
``contact.bearing_stiffness_N_m`` and ``bearing_clearance_m`` (an assumption the
scenes state: a rolling bearing is far stiffer than the loads' range of interest
needs).
"""

from __future__ import annotations

import numpy as np

from ..scene import Bearing, Scene, table_keys
from .base import Column, ElementKind, Law, Layout, Link, mjcf_numbers, segment_of


class BearingKind(ElementKind):
    """A bearing kind; ``name`` is its ``kind`` in a scene (``locating``, ...), ``record``
    the record of its bearings (:class:`~..scene.Bearing` or a subclass with its own
    fields).
    """

    record: type[Bearing] = Bearing

    @property
    def link_kinds(self) -> tuple[str, ...]:
        return (f"bearing-{self.name}",)

    @property
    def keys(self) -> tuple[str, ...]:
        """The keys its scene table may hold: its record's fields."""
        return table_keys(self.record)

    def read(self, table, name: str, offset_m: float, rating) -> Bearing:
        """The bearing from its scene table (its own fields read and checked here)."""
        return Bearing(name=name, offset_m=offset_m, kind=self.name, rating=rating)

    def made_from(self, bearing: Bearing) -> Bearing:
        """A bearing of this kind in place of ``bearing`` (a release's change of kind): its
        name, seat and rating kept, the fields of its former kind that this one does not
        take dropped (an angular-contact bearing made floating loses its contact angle).
        """
        return Bearing(name=bearing.name, offset_m=bearing.offset_m, kind=self.name,
                       rating=bearing.rating)

    def directions(self, element: Bearing, frame: np.ndarray
                   ) -> tuple[str, tuple[str, ...], np.ndarray]:
        """Its components: the frame they are named in (``global`` or ``shaft``), their
        names and their global directions (rows), on a shaft whose frame rows are
        ``frame`` (``r1, r2, axis``).
        """
        raise NotImplementedError

    def holds(self, element, shaft, segments, frames):
        """The translations its components' directions span (``D' D``): what it
        constrains is said once, by :meth:`directions`.
        """
        _, _, directions = self.directions(element, frames[shaft])
        return [(segment_of(segments, shaft, element.offset_m), directions.T @ directions,
                 None)]

    def add_links(self, element: Bearing, shaft: int, index: int, layout: Layout) -> None:
        g = layout.segment(shaft, element.offset_m)
        point = layout.geo.bearing_points[shaft][index]
        shaft_name = layout.scene.shafts[shaft].name
        name = f"bearing.{shaft_name}.{element.name}"
        frame, comps, dirs = self.directions(element, layout.frames[shaft])
        unilateral = self.unilateral(element, comps)
        layout.add([Column(f"{name}.{c}", g, None, point, d, u)
                    for c, d, u in zip(comps, dirs, unilateral)],
                   name=name, kind=self.link_kinds[0], body=g, other=None,
                   element=f"{shaft_name}.{element.name}", label=element.name, frame=frame,
                   components=comps, shaft=shaft, units=("N",) * len(comps))

    def unilateral(self, element: Bearing, components: tuple[str, ...]) -> tuple[bool, ...]:
        """Which of its components only push (>= 0); none for a plain bearing."""
        return (False,) * len(components)

    def laws(self, link: Link, scene: Scene) -> list[Law]:
        ct = scene.contact
        return [Law(link.columns, ct.bearing_stiffness_N_m, ct.bearing_clearance_m)]

    def axial_faces(self, link: Link, scene: Scene) -> list[tuple[float, float]]:
        """Its axial penalty contacts: ``(sign, stiffness)`` per face (N/m), the face's
        axis ``sign`` times the shaft's: it pushes the shaft along ``-sign`` times the
        axis, against the shaft's motion along ``sign`` times it.
        """
        return []

    def penalty(self, link: Link, rows) -> None:
        """Radially a contact with the bearing clearance; axially the faces of
        :meth:`axial_faces`, with the same clearance; linear.
        """
        ct = rows.scene.contact
        point = rows.op.points[0, link.columns[0]]
        axis, gap = rows.op.shaft_frames[link.shaft, 2], ct.bearing_clearance_m
        rows.add(link, point, axis, point, axis, gap, True, rows.law(ct.bearing_stiffness_N_m))
        for sign, stiffness in self.axial_faces(link, rows.scene):
            rows.add(link, point, sign * axis, point, sign * axis, gap, False,
                     rows.law(stiffness))

    def words(self, link: Link) -> str:
        return f"{self.name} bearing"

    def mjcf(self, link: Link, body: str, anchor: np.ndarray, point: np.ndarray,
             axis: np.ndarray, mass: float, soft: str) -> tuple[str, str]:
        """Its MJCF: ``(bodies, equality)``, bodies it adds to the world and its equality
        constraint named as the link, on the engine body ``body`` at ``anchor`` (its
        frame; ``point`` global, on a shaft of ``axis`` and ``mass``), softness
        attributes ``soft``. A ``connect`` to the world: it holds the point every way
        (the pairs a kind makes are resolved on reading, by complementarity).
        """
        return "", _connect(link.name, body, "world", anchor, soft)


def _connect(name: str, body: str, other: str, anchor: np.ndarray, soft: str) -> str:
    return (f'<connect name="{name}" body1="{body}" body2="{other}" '
            f'anchor="{mjcf_numbers(anchor)}" {soft}/>')
