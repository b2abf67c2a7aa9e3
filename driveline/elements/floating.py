"""The floating bearing: carries a force normal to its shaft's axis only (two
components in the shaft's frame, ``bearing.<shaft>.<bearing>.<r1|r2>``: ``r1`` in the
articulation plane, ``r2`` its normal); the shaft slides through it axially.

In MuJoCo it is a ``connect`` to a carrier body that slides along the shaft's axis on
the ground (its weight compensated, as heavy as the shaft), so that it carries no axial
force but the carrier's inertia.
"""

from __future__ import annotations

import numpy as np

from .base import mjcf_numbers
from .bearing import BearingKind, _connect


class Floating(BearingKind):
    """The floating bearing kind (module doc)."""

    name = "floating"
    slides = True

    def directions(self, element, frame):
        return "shaft", ("r1", "r2"), frame[:2]

    def mjcf(self, link, body, anchor, point, axis, mass, soft):
        carrier = f"carrier.{link.name}"
        inertia = mjcf_numbers(np.full(3, mass * 1e-2))
        return (f'<body name="{carrier}" pos="{mjcf_numbers(point)}" gravcomp="1">'
                f'<joint type="slide" axis="{mjcf_numbers(axis)}"/><inertial pos="0 0 0" '
                f'mass="{mass:.17g}" diaginertia="{inertia}"/></body>',
                _connect(link.name, body, carrier, anchor, soft))



KIND = Floating()
