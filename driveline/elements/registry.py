"""The element kinds of the package, and the walk over a scene's elements.

A kind is registered by naming its module in :data:`MODULES` (each module's ``KIND``
is its one instance). A scene holds its elements in three places: bearings on their
shafts (any registered bearing kind, by their ``kind``), slip joints, and the joints
between shafts (Cardan joints); :func:`scene_elements` walks them in the operator's
column order.
"""

from __future__ import annotations

from importlib import import_module

from ..scene import Scene
from .base import LINK_KINDS, RELEASES, ElementKind
from .bearing import BearingKind
from .cardan import KIND as JOINT
from .slip import KIND as SLIP

MODULES = ("locating", "floating", "slip", "cardan", "angular_contact")
"""The kinds' modules (in this package), in the order their pairs are listed."""

KINDS: tuple[ElementKind, ...] = tuple(import_module(f".{m}", __package__).KIND
                                       for m in MODULES)
"""Every element kind."""

BEARING_KINDS: dict[str, BearingKind] = {k.name: k for k in KINDS
                                         if isinstance(k, BearingKind)}
"""Bearing kinds by their ``kind`` in a scene."""

LINK_KINDS.update({name: k for k in KINDS for name in k.link_kinds})



RELEASES.update({k.release_name: k for k in sorted(KINDS, key=lambda k: k.release_rank)
                 if k.release_name})


def scene_elements(scene: Scene):
    """``(kind, element, shaft, index)`` of every element of ``scene`` in column order:
    each shaft's bearings, then the slip joints, then the joints (``shaft``: the
    element's shaft, a joint's upstream one; ``index``: its place in its list).
    """
    for k, shaft in enumerate(scene.shafts):
        for b, bearing in enumerate(shaft.bearings):
            yield BEARING_KINDS[bearing.kind], bearing, k, b
    names = [s.name for s in scene.shafts]
    for s, slip in enumerate(scene.slip_joints):
        yield SLIP, slip, names.index(slip.shaft), s
    for j, joint in enumerate(scene.joints):
        yield JOINT, joint, j, j
