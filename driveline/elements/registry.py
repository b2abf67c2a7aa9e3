"""The element kinds of the package, and the walk over a scene's elements.

A kind is registered by naming its module in :data:`MODULES` (each module's ``KIND``
is its one instance). Where a kind's elements live in a scene follows from its base:
a bearing kind's on their shafts (``[[shafts.bearings]]``, by their ``kind``), an
in-shaft kind's in the scene's one list :attr:`~..scene.Scene.elements` (read from the
kind's own array of tables), a joint kind's between the shafts (``[[joints]]``, by their
``kind``). :func:`scene_elements` walks them in the operator's column order; nothing
here or in the loader names a kind. What a kind can do beyond the core follows from
the capabilities it mixes in (:mod:`.base`): :data:`~.base.RELEASES` holds the
:class:`~.base.Releasable` ones, :data:`PAIRED` the :class:`~.base.Paired` ones.
"""

from __future__ import annotations

from importlib import import_module

from ..scene import Scene
from .base import LINK_KINDS, RELEASES, ElementKind, Paired, Releasable
from .bearing import BearingKind
from .inshaft import InShaftKind
from .joint import JointKind

MODULES = ("locating", "floating", "slip", "cardan", "angular_contact", "disc_coupling", "cv",
           "gear_mesh", "centring")
"""The kinds' modules (in this package), in the order their pairs are listed."""

KINDS: tuple[ElementKind, ...] = tuple(import_module(f".{m}", __package__).KIND
                                       for m in MODULES)
"""Every element kind."""

BEARING_KINDS: dict[str, BearingKind] = {k.name: k for k in KINDS
                                         if isinstance(k, BearingKind)}
"""Bearing kinds by their ``kind`` in a scene."""

IN_SHAFT_KINDS: tuple[InShaftKind, ...] = tuple(k for k in KINDS
                                                if isinstance(k, InShaftKind))
"""The kinds of elements inside a shaft, in the order their tables are read."""

JOINT_KINDS: dict[str, JointKind] = {k.name: k for k in KINDS if isinstance(k, JointKind)}
"""Joint kinds by their ``kind`` in a scene."""

LINK_KINDS.update({name: k for k in KINDS for name in k.link_kinds})

RELEASES.update({k.release_name: k for k in sorted(
    (k for k in KINDS if isinstance(k, Releasable)), key=lambda k: k.release_rank)})

PAIRED: tuple[Paired, ...] = tuple(k for k in KINDS if isinstance(k, Paired))
"""The kinds whose links hold complementarity pairs, in :data:`MODULES`' order."""

_BY_RECORD = {k.record: k for k in IN_SHAFT_KINDS}


def kind_of(element) -> InShaftKind:
    """The kind of an element of :attr:`~..scene.Scene.elements` (by its record's type)."""
    return _BY_RECORD[type(element)]


def refusals(scene: Scene, engine: str) -> list[str]:
    """Why ``engine`` cannot model elements of ``scene``, one line per element (each
    kind's :meth:`~.base.ElementKind.refusal`); empty where it can.
    """
    return [why for kind, element, _, _ in scene_elements(scene)
            if (why := kind.refusal(element, engine)) is not None]


def scene_elements(scene: Scene):
    """``(kind, element, shaft, index)`` of every element of ``scene`` in column order:
    each shaft's bearings, then the elements inside shafts, then the joints
    (``shaft``: the element's shaft, a joint's upstream one; ``index``: its place in
    its list).
    """
    for k, shaft in enumerate(scene.shafts):
        for b, bearing in enumerate(shaft.bearings):
            yield BEARING_KINDS[bearing.kind], bearing, k, b
    names = [s.name for s in scene.shafts]
    for e, element in enumerate(scene.elements):
        yield kind_of(element), element, names.index(element.shaft), e
    for j, joint in enumerate(scene.joints):
        yield JOINT_KINDS[joint.kind], joint, j, j
