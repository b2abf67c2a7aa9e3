"""The angular-contact bearing (a tapered roller or angular-contact ball bearing):
radial force both ways, axial force in one direction only.

Its rolling elements touch the raceways along lines at the contact angle ``alpha`` to
the radial plane, so the outer ring can push the inner ring (and the shaft) axially
one way and never pull it: a unilateral contact like an end face. A pair facing
opposite ways locates its shaft: in an **O** (back-to-back) arrangement each bearing
pushes its shaft outward (the upstream one upstream), in an **X** (face-to-face)
arrangement inward. How the pair shares an axial load is a pair mode (both pushing
equally: a preload) that complementarity resolves, as it resolves a trunnion pair's
end faces: without preload only one of the two carries it.

Scene fields (``[[shafts.bearings]]`` with ``kind = "angular-contact"``):

- ``contact_angle_deg``: ``alpha``, within :data:`~..scene.CONTACT_ANGLE_DEG` (the
  contact angles of real angular-contact and tapered roller bearings); if the bearing
  also has a ``rating``, its type must be one with a contact angle (``tapered_roller``,
  ``angular_contact_ball``) and its contact angle this one;
- ``pushes``: ``"upstream"`` or ``"downstream"``, the direction along its shaft's axis
  in which it pushes the shaft;
- ``offset_m``: its effective load centre (where its pressure cone meets the axis,
  off the bearing's middle by the catalogue's ``a``), as for every bearing where the
  force acts.

On one shaft at most one pushes each way, and two that face each other share their
contact angle (a matched pair; the compliance energy merges a pair into one signed
axial force of one law).

Columns, in the shaft's frame: ``bearing.<shaft>.<bearing>.<r1|r2>`` (radial, both
ways, as a floating bearing's) and ``bearing.<shaft>.<bearing>.axial`` >= 0, the push
along ``pushes``. The structural checks are linear: they take it as stopping its
shaft's translations both ways along the axis (one facing the other way completes it).

Contact laws, an assumption: the scene's ``bearing_stiffness_N_m`` is its radial
stiffness ``k_r``; a rolling element's normal approach is ``cos alpha`` of a radial and
``sin alpha`` of an axial displacement, so with the same elements loaded the axial
stiffness is ``k_a = k_r tan^2 alpha`` (Harris & Kotzalas, *Rolling Bearing Analysis*,
5th ed., on bearing deflections, give the full load-zone sums; this keeps their ratio
only). Both laws linear with the scene's bearing clearance; the penalty model has the
radial contact and one axial face along ``pushes``. MuJoCo holds the bearing point as
a locating bearing's; the pair's split is resolved on reading, by complementarity.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..scene import CONTACT_ANGLE_DEG, Bearing, Scene, SceneError
from .base import Law, Link, Paired, PairMode
from .bearing import BearingKind

SIDES = {"upstream": -1.0, "downstream": 1.0}
"""The directions it may push its shaft: the sign along the shaft's axis."""

ANGLED_TYPES = ("tapered_roller", "angular_contact_ball")
"""Catalogue types (a bearing's ``rating``) of bearings with a contact angle."""


@dataclass(frozen=True)
class AngularContactBearing(Bearing):
    """An angular-contact bearing (module doc): ``contact_angle_deg`` (deg) and the way
    it ``pushes`` its shaft (``upstream`` or ``downstream``).
    """

    contact_angle_deg: float = 0.0
    pushes: str = "downstream"


class AngularContact(BearingKind, Paired):
    """The angular-contact bearing kind (module doc)."""

    name = "angular-contact"
    record = AngularContactBearing

    def read(self, table, name, offset_m, rating) -> Bearing:
        alpha = table.number("contact_angle_deg", positive=True, kind="angle_deg",
                             within=CONTACT_ANGLE_DEG, why="the contact angles of real "
                             "angular-contact and tapered roller bearings")
        if rating is not None and rating.type not in ANGLED_TYPES:
            table.fail("rating.type", f"an angular-contact bearing is rated as one of "
                       f"{', '.join(ANGLED_TYPES)}, got {rating.type!r}")
        if rating is not None and rating.contact_angle_deg != alpha:
            table.fail("contact_angle_deg", f"{alpha:g} deg differs from its rating's "
                       f"{rating.contact_angle_deg:g} deg")
        return AngularContactBearing(
            name=name, offset_m=offset_m, kind=self.name, rating=rating,
            contact_angle_deg=alpha, pushes=table.string("pushes", choices=tuple(SIDES)))

    def made_from(self, bearing: Bearing) -> Bearing:
        """Refused: an angular-contact bearing needs a contact angle and a side that no
        other kind's bearing has, so no release makes one.
        """
        raise NotImplementedError("no release makes a bearing angular-contact")

    def check(self, element, shaft, scene: Scene) -> None:
        """At most one pushing each way on a shaft; facing ones of one contact angle."""
        body = scene.shafts[shaft]
        mine = [b for b in body.bearings if b.kind == self.name]
        if element is not mine[0]:
            return
        for side in SIDES:
            if sum(b.pushes == side for b in mine) > 1:
                raise SceneError(f"scene {scene.source}: shaft {body.name!r}: more than one "
                                 f"angular-contact bearing pushes {side}; at most one each way")
        if len({b.contact_angle_deg for b in mine}) > 1:
            raise SceneError(f"scene {scene.source}: shaft {body.name!r}: its angular-contact "
                             "bearings face each other with different contact angles; a "
                             "matched pair shares one")

    def directions(self, element, frame):
        return "shaft", ("r1", "r2", "axial"), np.vstack(
            [frame[:2], SIDES[element.pushes] * frame[2]])

    def unilateral(self, element, components):
        return (False, False, True)

    def pairs(self, links: list[Link]) -> list[tuple[int, int]]:
        """Per shaft body, its bearing pushing upstream and the one pushing downstream."""
        by_body: dict[int, list[Link]] = {}
        for link in links:
            by_body.setdefault(link.body, []).append(link)
        return [(facing[0].column("axial"), facing[1].column("axial"))
                for facing in by_body.values() if len(facing) == 2]

    def pair_mode(self, link: Link, other: Link) -> PairMode:
        return PairMode("bearing pair", f"both bearings {link.element} and {other.element} "
                        "pushing their shaft axially equally (a preload)", "none needed: "
                        "complementarity (without preload one carries the axial load)")

    def laws(self, link: Link, scene: Scene) -> list[Law]:
        ct, radial = scene.contact, link.columns[:2]
        return [Law(radial, ct.bearing_stiffness_N_m, ct.bearing_clearance_m),
                Law(link.columns[2:], self._axial_stiffness(link, scene),
                    ct.bearing_clearance_m)]

    def axial_faces(self, link: Link, scene: Scene) -> list[tuple[float, float]]:
        """One face, resisting the shaft's motion against ``pushes``."""
        bearing = self._bearing(link, scene)
        return [(-SIDES[bearing.pushes], self._axial_stiffness(link, scene))]

    def _bearing(self, link: Link, scene: Scene) -> AngularContactBearing:
        return next(b for b in scene.shafts[link.shaft].bearings if b.name == link.label)

    def _axial_stiffness(self, link: Link, scene: Scene) -> float:
        """``k_r tan^2 alpha`` (N/m, module doc)."""
        alpha = math.radians(self._bearing(link, scene).contact_angle_deg)
        return scene.contact.bearing_stiffness_N_m * math.tan(alpha) ** 2


KIND = AngularContact()
