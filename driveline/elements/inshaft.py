"""What every element inside a shaft shares (a slip joint, a flexible coupling, ...):
it sits on one shaft at ``offset_m`` from the shaft's centre, read from its kind's own
array of tables (:attr:`InShaftKind.table`), and, if it ``cuts``, splits the shaft
there into two bodies (:mod:`.bodies`), any number of cuts per shaft.

The kind reads its own fields (:meth:`InShaftKind.read_fields`); the fields every such
element has (``name``, ``shaft``, ``offset_m``) and their checks are read here once:
the shaft exists, the element lies strictly inside it and not at a bearing.
"""

from __future__ import annotations

from ..scene import Scene, SceneError, table_keys
from .base import ElementKind


class InShaftKind(ElementKind):
    """An element kind inside a shaft; ``table``: the scene's array of tables its
    elements are read from (``slip_joints``, ...); ``record``: its record (a frozen
    dataclass with ``name``, ``shaft`` (the shaft's name) and ``offset_m``, its kind
    known by its type, :func:`~.registry.kind_of`); ``cuts``: it splits its shaft into
    two bodies at its offset.
    """

    table = ""
    record: type = object
    cuts = True

    def read(self, t, shafts: dict) -> object:
        """One element from its table ``t``; ``shafts``: the scene's shafts by name."""
        t.expect(table_keys(self.record))
        shaft_name = t.string("shaft", name=True)
        if shaft_name not in shafts:
            t.fail("shaft", f"no shaft {shaft_name!r}; shafts: {', '.join(shafts)}")
        shaft = shafts[shaft_name]
        offset = t.number("offset_m", 0.0, kind="position_m")
        if not abs(offset) < shaft.length_m / 2:
            t.fail("offset_m", f"the {self.noun} must lie inside shaft {shaft_name!r} "
                   f"(|offset| < {shaft.length_m / 2} m), got {offset}")
        if self.cuts and any(abs(b.offset_m - offset) < 1e-9 for b in shaft.bearings):
            t.fail("offset_m", f"a {self.noun} cannot sit exactly at a bearing")
        element = self.record(name=t.string("name", name=True), shaft=shaft_name,
                              offset_m=offset, **self.read_fields(t))
        t.done()
        return element

    noun = "element"
    """What one element is called in messages (``slip joint``, ...)."""

    def read_fields(self, t) -> dict:
        """Its own fields from table ``t``, read and checked (by :class:`~..loading`'s
        table reader, which names a misspelled key).
        """
        return {}

    def check(self, element, shaft: int, scene: Scene) -> None:
        """Each body it cuts its shaft into needs a neighbour: a joint at the shaft's
        end or a bearing on it (elements it shares the shaft with do not count: between
        two cuts nothing but the elements would hold it).
        """
        last = len(scene.shafts) - 1
        body = scene.shafts[shaft]
        if not self.cuts:
            return
        from .bodies import cuts_of  # below the registry, which imports this module

        cuts = [e.offset_m for e in cuts_of(scene).get(body.name, []) if e is not element]
        below = max((c for c in cuts if c < element.offset_m), default=None)
        above = min((c for c in cuts if c > element.offset_m), default=None)
        spans = (("upstream", below, element.offset_m, shaft > 0 and below is None),
                 ("downstream", element.offset_m, above, shaft < last and above is None))
        for side, lo, hi, has_joint in spans:
            lo = -body.length_m if lo is None else lo
            hi = body.length_m if hi is None else hi
            if not has_joint and not any(lo < b.offset_m < hi for b in body.bearings):
                raise SceneError(
                    f"scene {scene.source}: {self.noun} {element.name!r} on shaft "
                    f"{body.name!r}: its {side} segment is not held: no neighbour (no joint at "
                    f"its end, no bearing on it), nothing but the {self.noun} would hold it")

    def describe(self, element) -> str:
        """One line of ``scene show``: what it is, where, its own fields with units."""
        return f"{self.noun} {element.name} in shaft {element.shaft} @ {element.offset_m:+g} m"


def sides(segments: list, shaft: int, offset_m: float) -> tuple[int, int]:
    """The two bodies (indices into ``segments``) of shaft ``shaft`` that meet at
    ``offset_m``: the one ending there, the one starting there.
    """
    up = next(g for g, s in enumerate(segments) if s.shaft == shaft and s.hi_m == offset_m)
    return up, up + 1
