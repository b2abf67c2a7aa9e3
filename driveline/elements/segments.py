"""Shaft bodies of a real drive line: shaft segments cut by slip joints, and the checks
that every part of the line is held (DESIGN §1).

A slip joint cuts its shaft into two coaxial **segments**, ``<shaft>.upstream`` and
``<shaft>.downstream``, each a rigid body of the equilibrium operator with the shaft's
mass and axial inertia split by length, its centre of mass at its own middle. A shaft
without a slip joint is one body named after the shaft. The 1-DOF motion is the same
(the spline makes the segments turn together).

Bad layouts raise :class:`~cardan_forces.driveline.scene.SceneError`:

- an element its kind refuses (:meth:`~.base.ElementKind.check`), e.g. a slip joint
  whose segment has no neighbour: neither a Cardan joint at its end nor a bearing on
  it, so nothing but the spline holds it;
- a line that can slide as a whole (or a part of it between slip joints): its
  bearings are all floating along a common direction, no locating bearing holds it.
  Checked by the translations the elements allow (a small null space), each kind
  saying what it stops: a floating bearing on a shaft with axis ``a`` stops
  translations normal to ``a``, a locating one all, a Cardan joint makes its two
  shafts translate together, a frictionless spline lets its segments slide relative
  to each other along ``a``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..determinacy import left_null_space
from ..kinematics import rest_geometry
from ..scene import Scene, SceneError


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


def check_elements(scene: Scene, sliding: bool = True) -> None:
    """Refuse elements their kinds refuse (a slip joint with an unheld segment, ...) and,
    if ``sliding``, lines free to slide (module doc).
    """
    from .registry import scene_elements

    for kind, element, shaft, _ in scene_elements(scene):
        kind.check(element, shaft, scene)
    free = sliding_bodies(scene) if sliding else []
    if free:
        raise SceneError(
            f"scene {scene.source}: no axial support: {', '.join(free)} can slide along "
            "their axis (a floating bearing carries no axial force; make one bearing "
            "of that part of the line locating)")


def sliding_bodies(scene: Scene, segments: list[Segment] | None = None) -> list[str]:
    """Names of the shaft bodies that some rigid translation allowed by the elements
    (each kind's :meth:`~.base.ElementKind.holds`) moves (empty when the line is held).
    """
    from .registry import scene_elements

    segments = shaft_segments(scene) if segments is None else segments
    frames = frames_of(rest_geometry(scene))
    n = 3 * len(segments)
    rows = []
    for kind, element, shaft, _ in scene_elements(scene):
        for g, matrix, h in kind.holds(element, shaft, segments, frames):
            row = np.zeros((3, n))
            row[:, 3 * g: 3 * g + 3] = matrix
            if h is not None:
                row[:, 3 * h: 3 * h + 3] = -matrix
            rows.append(row)
    matrix = np.vstack(rows) if rows else np.zeros((1, n))
    null = left_null_space(matrix.T)  # the translations allowed, n x free
    if not null.shape[1]:
        return []
    moved = np.linalg.norm(null.reshape(len(segments), 3, -1), axis=(1, 2)) > 1e-9
    return [seg.name for seg, m in zip(segments, moved) if m]
