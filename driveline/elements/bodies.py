"""Shaft bodies of a real drive line: whole shafts, and shaft segments cut by slip
joints (DESIGN §1), with each shaft's frame.

A slip joint cuts its shaft into two coaxial **segments**, ``<shaft>.upstream`` and
``<shaft>.downstream``, each a rigid body of the equilibrium operator with the shaft's
mass and axial inertia split by length, its centre of mass at its own middle. A shaft
without a slip joint is one body named after the shaft. The 1-DOF motion is the same
(the spline makes the segments turn together).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..scene import Scene


@dataclass(frozen=True)
class Segment:
    """A rigid shaft body: shaft ``shaft`` (scene index) from ``lo_m`` to ``hi_m`` along
    its axis (offsets from the shaft's centre, downstream positive).
    """

    name: str
    shaft: int
    lo_m: float
    hi_m: float
    fraction: float  # its share of the shaft's length, mass and axial inertia

    @property
    def middle_m(self) -> float:
        """Its centre of mass: the middle of its span (m from the shaft's centre)."""
        return 0.5 * (self.lo_m + self.hi_m)


def shaft_segments(scene: Scene) -> list[Segment]:
    """Every shaft body in chain order: one per shaft, two where a slip joint cuts it."""
    cut = {s.shaft: s.offset_m for s in scene.slip_joints}
    out = []
    for k, shaft in enumerate(scene.shafts):
        half = shaft.length_m / 2
        if shaft.name in cut:
            at = cut[shaft.name]
            out.append(Segment(f"{shaft.name}.upstream", k, -half, at,
                               (at + half) / shaft.length_m))
            out.append(Segment(f"{shaft.name}.downstream", k, at, half,
                               (half - at) / shaft.length_m))
        else:
            out.append(Segment(shaft.name, k, -half, half, 1.0))
    return out


def segment_of(segments: list[Segment], shaft: int, offset_m: float) -> int:
    """Index (into ``segments``) of the segment of shaft ``shaft`` holding ``offset_m``."""
    for g, seg in enumerate(segments):
        if seg.shaft == shaft and seg.lo_m <= offset_m <= seg.hi_m:
            return g
    raise ValueError(f"offset {offset_m} m lies on no segment of shaft {shaft}")


def frames_of(geo) -> np.ndarray:
    """Per shaft the rows ``r1, r2, axis`` of its frame in rest geometry ``geo``: ``r1 =
    n x axis`` in the articulation plane, ``r2 = n`` its normal (``plane_normal``).
    """
    n = np.broadcast_to(geo.plane_normal, geo.axes.shape)
    return np.stack([np.cross(n, geo.axes), n, geo.axes], axis=1)
