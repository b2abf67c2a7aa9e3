"""Shaft bodies of a real drive line: whole shafts, and shaft segments cut by the
elements inside them (DESIGN §1), with each shaft's frame.

An element whose kind ``cuts`` (a slip joint, a flexible coupling) splits its shaft at
its offset into coaxial **segments**, each a rigid body of the equilibrium operator with
the shaft's mass and axial inertia split by length, its centre of mass at its own
middle. One cut makes ``<shaft>.upstream`` and ``<shaft>.downstream``; more cuts make
the segments between them ``<shaft>.after-<element>``. A shaft without a cut is one
body named after the shaft. The 1-DOF motion is the same (the elements make the
segments turn together).
"""

from __future__ import annotations

import numpy as np

from ..scene import Scene
from .base import Segment
from .registry import kind_of


def cuts_of(scene: Scene) -> dict[str, list]:
    """Per shaft name, the elements that cut it, upstream first."""
    cuts: dict[str, list] = {}
    for element in scene.elements:
        if kind_of(element).cuts:
            cuts.setdefault(element.shaft, []).append(element)
    return {shaft: sorted(els, key=lambda e: e.offset_m) for shaft, els in cuts.items()}


def shaft_segments(scene: Scene) -> list[Segment]:
    """Every shaft body in chain order: one per shaft, one more per cut in it."""
    cuts = cuts_of(scene)
    out = []
    for k, shaft in enumerate(scene.shafts):
        half = shaft.length_m / 2
        mine = cuts.get(shaft.name, [])
        bounds = [-half, *(e.offset_m for e in mine), half]
        names = ["upstream", *(f"after-{e.name}" for e in mine[:-1]), "downstream"]
        if not mine:
            names = [None]
        for (lo, hi), name in zip(zip(bounds[:-1], bounds[1:]), names):
            out.append(Segment(shaft.name if name is None else f"{shaft.name}.{name}", k,
                               lo, hi, (hi - lo) / shaft.length_m))
    return out


def frames_of(geo) -> np.ndarray:
    """Per shaft the rows ``r1, r2, axis`` of its frame in rest geometry ``geo``: ``r1 =
    n x axis`` in the articulation plane, ``r2 = n`` its normal (``plane_normal``).
    """
    n = np.broadcast_to(geo.plane_normal, geo.axes.shape)
    return np.stack([np.cross(n, geo.axes), n, geo.axes], axis=1)
