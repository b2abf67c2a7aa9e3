"""The centring device of a double-Cardan joint: a ball on the driving shaft's stub in
a bore of the driven shaft's yoke, which keeps the centre yoke (a short shaft between
two Cardan joints) on the bisector of the outer shafts, so that the pair runs at
constant velocity at any angle. It links two shafts that are not adjacent: the ones
either side of the centre yoke it sits in.

Rigid model: the ball sits where the outer shafts' axes meet (the scene's
``offset_m`` must be 0: it sits at the centre yoke's middle in the scene's layout of a
double-Cardan pair, equal angles either side); its link acts on the driven shaft's
first body and the opposite on the driving shaft's last, ``<device>.r1``,
``<device>.r2`` (N), normal to the driven shaft's axis (the bore lets the ball slide
along it as the angle changes). It adds a loop around the centre yoke: the joint's
secondary couples are shared between the crosses and the ball, a redundancy the rigid
set exposes; its release ``unball:<centre yoke>`` takes the ball out. Contact law (an
assumption): as stiff as a bearing, without gap.

Penalty model (:meth:`Centring.penalty`): the ball's centre, a point of the driving
shaft, held on the bore's axis, a line of the driven shaft, by a linear spring-damper
both ways normal to the line (a ``LINE`` row: ``-(k r + c r')``, ``r`` the centre's
offset from the axis, ``c`` the scene's damping fraction of ``k``), free along it: the
rigid link's two columns and its one freedom, at any spin of either shaft, the bore's
axis being the one line of the driven shaft that its spin leaves in place. ``k`` is the
rigid law's, the bearing stiffness. MuJoCo closes it outside its kinematic tree
(:meth:`Centring.mjcf_loop`): a carrier hung on the driven shaft's first body by a slide
along the bore's axis, held at the ball's centre by a ``connect`` to the driving
shaft's last body; the connect's force, normal to the bore, is the link's. Drake is not
handed the carrier: it refuses the device, in one line.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..scene import Scene, SceneError
from .base import (
    MUJOCO,
    PENALTY_SIMULATION,
    Column,
    EngineLoop,
    EngineStep,
    Law,
    Layout,
    Link,
    Releasable,
    Release,
)
from .inshaft import InShaftKind


@dataclass(frozen=True)
class CentringDevice:
    """The centring ball of the double-Cardan joint whose centre yoke is shaft
    ``shaft`` (``offset_m`` 0: module doc).
    """

    name: str
    shaft: str
    offset_m: float


def meeting_point(start, a_in, end, a_out) -> np.ndarray:
    """The point nearest both lines ``start + s a_in`` and ``end + u a_out`` (m): where
    the outer shafts' axes meet.
    """
    m = np.column_stack([a_in, -a_out])
    s, u = np.linalg.lstsq(m, end - start, rcond=None)[0]
    return 0.5 * (start + s * a_in + end + u * a_out)


class Centring(InShaftKind, Releasable, EngineLoop):
    """The centring device kind (module doc)."""

    name, table, record, noun = "centring", "centring_devices", CentringDevice, \
        "centring device"
    cuts = False
    link_kinds = ("centring-ball",)

    def check(self, element: CentringDevice, shaft: int, scene: Scene) -> None:
        """In a shaft between two others, at its middle."""
        if not 0 < shaft < len(scene.shafts) - 1 or element.offset_m != 0.0:
            raise SceneError(f"scene {scene.source}: centring device {element.name!r}: it "
                             "sits in the middle (offset_m 0) of a centre yoke, a shaft "
                             "between two others")

    def describe(self, device: CentringDevice) -> str:
        return (f"centring device {device.name} of the double-Cardan joint around shaft "
                f"{device.shaft}")

    def holds(self, element, shaft, segments, frames):
        up = max(g for g, s in enumerate(segments) if s.shaft == shaft - 1)
        down = min(g for g, s in enumerate(segments) if s.shaft == shaft + 1)
        axis = frames[shaft + 1][2]
        return [(down, np.eye(3) - np.outer(axis, axis), up)]

    def add_links(self, element: CentringDevice, shaft: int, index: int,
                  layout: Layout) -> None:
        geo = layout.geo
        up = max(g for g, s in enumerate(layout.segments) if s.shaft == shaft - 1)
        down = min(g for g, s in enumerate(layout.segments) if s.shaft == shaft + 1)
        point = meeting_point(geo.joint_centres[shaft - 1], geo.axes[shaft - 1],
                              geo.joint_centres[shaft], geo.axes[shaft + 1])
        r1, r2, _ = layout.frames[shaft + 1]
        name = element.name
        layout.add([Column(f"{name}.r1", down, up, point, r1),
                    Column(f"{name}.r2", down, up, point, r2)],
                   name=name, kind=self.link_kinds[0], body=down, other=up, element=name,
                   frame="shaft", components=("r1", "r2"), shaft=shaft + 1,
                   units=("N", "N"))

    def laws(self, link: Link, scene) -> list[Law]:
        return [Law(link.columns, scene.contact.bearing_stiffness_N_m, 0.0)]

    release_name, release_form, release_rank = "unball", "unball:<centre yoke>", 2

    def releases(self, scene):
        """Taking the ball out: the crosses alone centre the yoke (the pair then runs at
        constant velocity only at equal angles).
        """
        return [Release(self.release_name, d.shaft) for d in scene.elements
                if isinstance(d, CentringDevice)]

    def parse_release(self, target, scene):
        found = any(isinstance(d, CentringDevice) and d.shaft == target
                    for d in scene.elements)
        return Release(self.release_name, target) if found else None

    def release_label(self, release):
        return f"unball:{release.shaft}"

    def release_words(self, release):
        return f"take out the centring ball around {release.shaft}"

    def apply_release(self, release, shafts, elements):
        elements[:] = [e for e in elements if not (isinstance(e, CentringDevice)
                                                   and e.shaft == release.shaft)]

    def penalty(self, link: Link, rows) -> None:
        """The ball's centre, on the driving shaft, held on the bore's axis, on the
        driven shaft, both ways and free along it (a ``LINE`` row), as stiff as a
        bearing (module doc).
        """
        rows.line(link, rows.op.points[0, link.columns[0]],
                  rows.op.shaft_frames[link.shaft][2],
                  rows.law(rows.scene.contact.bearing_stiffness_N_m))

    def mjcf_loop(self, link: Link, start) -> tuple[int, EngineStep]:
        """The carrier on the driven shaft's first body, sliding along its axis from the
        ball's centre (module doc).
        """
        geo, k = start.geo, link.shaft
        point = meeting_point(geo.joint_centres[k - 2], geo.axes[k - 2],
                              geo.joint_centres[k - 1], geo.axes[k])
        return link.body, EngineStep("slide", geo.axes[k], point)

    def refusal(self, device: CentringDevice, engine: str) -> str | None:
        if engine in (PENALTY_SIMULATION, MUJOCO):
            return None
        return (f"centring device {device.name!r}: {engine} is not handed its carrier "
                "between shafts that are not adjacent")

    def words(self, link: Link) -> str:
        return "centring ball"


KIND = Centring()
