"""What every element inside a shaft shares (a slip joint, a flexible coupling, ...):
it sits on one shaft at ``offset_m`` from the shaft's centre, read from its kind's own
array of tables (:attr:`InShaftKind.table`), and, if it ``cuts``, splits the shaft
there into two bodies (:mod:`.bodies`), any number of cuts per shaft.

The kind reads its own fields (:meth:`InShaftKind.read_fields`); the fields every such
element has (``name``, ``shaft``, ``offset_m``) and their checks are read here once:
the shaft exists, the element lies strictly inside it and, if it cuts, not at a
bearing. That every segment the cuts make is held is checked over the segments
(:func:`~.checks.check_segments`).
"""

from __future__ import annotations

from ..scene import table_keys
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

    def describe(self, element) -> str:
        """One line of ``scene show``: what it is, where, its own fields with units."""
        return f"{self.noun} {element.name} in shaft {element.shaft} @ {element.offset_m:+g} m"


def sides(segments: list, shaft: int, offset_m: float) -> tuple[int, int]:
    """The two bodies (indices into ``segments``) of shaft ``shaft`` that meet at
    ``offset_m``: the one ending there, the one starting there.
    """
    up = next(g for g, s in enumerate(segments) if s.shaft == shaft and s.hi_m == offset_m)
    return up, up + 1
