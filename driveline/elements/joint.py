"""What every joint kind shares: a joint sits at the end of one shaft and the start
of the next (``[[joints]]``, its ``kind`` naming the kind, the Cardan joint by
default), and joins their bodies, directly or through bodies of its own.
"""

from __future__ import annotations

from .base import ElementKind


class JointKind(ElementKind):
    """A joint kind; ``name`` is its ``kind`` in a scene's ``[[joints]]`` table."""

    name = ""

    def read(self, t):
        """The joint from its scene table (its fields read and checked here)."""
        raise NotImplementedError

    def describe(self, joint) -> str:
        """One line of ``scene show``: what it is and its own fields with units."""
        return f"joint {joint.name} ({self.name})"
