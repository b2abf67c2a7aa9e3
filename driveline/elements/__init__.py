"""Element kinds of a drive line as objects (:mod:`.base`: the protocol; one module
per kind; :mod:`.registry`: the list), the shaft bodies they act on (:mod:`.bodies`)
and the checks that the line is held (:mod:`.checks`).
"""

from .base import Segment, segment_of
from .bodies import shaft_segments
from .checks import check_elements, sliding_bodies

__all__ = ["Segment", "check_elements", "segment_of", "shaft_segments", "sliding_bodies"]
