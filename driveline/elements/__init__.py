"""Element kinds of a drive line as objects (:mod:`.base`: the protocol; one module
per kind; :mod:`.registry`: the list), the shaft bodies they act on (:mod:`.bodies`)
and the checks that the line is held (:mod:`.checks`, which reads the rest geometry
and so is imported by name, not here: the kinematics are below it and use the kinds).
"""

from .base import Segment, segment_of
from .bodies import shaft_segments

__all__ = ["Segment", "segment_of", "shaft_segments"]
