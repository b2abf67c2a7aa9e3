"""The checks that every part of a line is held (DESIGN §1).

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

import numpy as np

from ..determinacy import left_null_space
from ..kinematics import rest_geometry
from ..scene import Scene, SceneError
from .bodies import Segment, frames_of, shaft_segments
from .registry import scene_elements


def check_elements(scene: Scene, sliding: bool = True) -> None:
    """Refuse elements their kinds refuse (a slip joint with an unheld segment, ...) and,
    if ``sliding``, lines free to slide (module doc).
    """
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
