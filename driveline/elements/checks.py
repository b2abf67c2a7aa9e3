"""The checks that every part of a line is held (DESIGN §1).

Bad layouts raise :class:`~cardan_forces.driveline.scene.SceneError`:

- an element its kind refuses (:meth:`~.base.ElementKind.check`), e.g. a slip joint
  whose segment is not held: neither a joint at its end nor a bearing on
  it, so nothing but the spline holds it;
- a line that can slide as a whole (or a part of it between slip joints): its
  bearings are all floating along a common direction, no locating bearing holds it.
  Checked by the translations the elements allow (a small null space), each kind
  saying what it stops: a floating bearing on a shaft with axis ``a`` stops
  translations normal to ``a``, a locating one all, a Cardan joint makes its two
  shafts translate together, a frictionless spline lets its segments slide relative
  to each other along ``a``;
- bearings far stiffer or far softer than the joints (beyond
  :data:`~cardan_forces.driveline.scene.MAX_STIFFNESS_RATIO` either way).
"""

from __future__ import annotations

import math

import numpy as np

from ..determinacy import left_null_space
from ..kinematics import rest_geometry
from ..scene import MAX_STIFFNESS_RATIO, Range, Scene, SceneError
from .bodies import Segment, cuts_of, frames_of, shaft_segments
from .registry import JOINT_KINDS, kind_of, scene_elements


def check_elements(scene: Scene, sliding: bool = True) -> None:
    """Refuse bearings out of proportion to the joints' stiffness, elements their kinds
    refuse (a slip joint with an unheld segment, ...) and, if ``sliding``, lines free to
    slide (module doc).
    """
    check_stiffness(scene)
    check_segments(scene)
    for kind, element, shaft, _ in scene_elements(scene):
        kind.check(element, shaft, scene)
    free = sliding_bodies(scene) if sliding else []
    if free:
        raise SceneError(
            f"scene {scene.source}: no axial support: {', '.join(free)} can slide along "
            "their axis (a floating bearing carries no axial force; make one bearing "
            "of that part of the line locating)")


def check_segments(scene: Scene) -> None:
    """Each shaft body that elements cut a shaft into needs a neighbour: a joint at the
    shaft's end or a bearing on it (the cutting elements do not count: between two cuts
    nothing but the elements would hold it). The refusal names the element on the
    body's upstream side (the first cut's, for the shaft's first body).
    """
    last = len(scene.shafts) - 1
    cuts = cuts_of(scene)
    for k, shaft in enumerate(scene.shafts):
        mine = cuts.get(shaft.name, [])
        bounds = [-math.inf, *(e.offset_m for e in mine), math.inf]
        for s, (lo, hi) in enumerate(zip(bounds[:-1], bounds[1:])):
            if not mine or (s == 0 and k > 0) or (s == len(mine) and k < last):
                continue
            if any(lo < b.offset_m < hi for b in shaft.bearings):
                continue
            element, side = (mine[0], "upstream") if s == 0 else (mine[s - 1], "downstream")
            noun = kind_of(element).noun
            raise SceneError(
                f"scene {scene.source}: {noun} {element.name!r} on shaft {shaft.name!r}: its "
                f"{side} segment is not held: no neighbour (no joint at its end, no bearing "
                f"on it), nothing but the {noun} would hold it")


def check_stiffness(scene: Scene) -> None:
    """Refuse a bearing stiffness beyond :data:`~..scene.MAX_STIFFNESS_RATIO` times the
    joints' (:meth:`~.joint.JointKind.secant_stiffness`: a Cardan joint's Hertz
    stiffness's secant at ``damping_full_depth_m``) either way.
    """
    secants = [k for j in scene.joints
               if (k := JOINT_KINDS[j.kind].secant_stiffness(j, scene)) is not None]
    if not secants:
        return
    allowed = Range(max(secants) / MAX_STIFFNESS_RATIO, min(secants) * MAX_STIFFNESS_RATIO,
                    "N/m")
    if (refusal := allowed.refusal(scene.contact.bearing_stiffness_N_m)) is not None:
        raise SceneError(
            f"scene {scene.source}: field 'contact.bearing_stiffness_N_m': {refusal} "
            f"({1 / MAX_STIFFNESS_RATIO:g} to {MAX_STIFFNESS_RATIO:g} times the joints' "
            f"stiffness, {min(secants):.3g} to {max(secants):.3g} N/m: the secant of their "
            "Hertz stiffness at contact.damping_full_depth_m)")


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
