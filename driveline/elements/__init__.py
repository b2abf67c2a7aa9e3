"""Element kinds of a drive line as objects (:mod:`.base`: the protocol; one module
per kind; :mod:`.registry`: the list), and the shaft bodies they act on
(:mod:`.segments`).
"""

from .segments import Segment, check_elements, segment_of, shaft_segments, sliding_bodies

__all__ = ["Segment", "check_elements", "segment_of", "shaft_segments", "sliding_bodies"]
