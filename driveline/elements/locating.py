"""The locating bearing: carries a force in any direction (three components in the
global frame, ``bearing.<shaft>.<bearing>.<x|y|z>``), so it holds its shaft axially
both ways. Two on one shaft body split an axial load in a way the rigid model leaves
open (an axial split, released by making one floating: its release
``float:<shaft>.<bearing>``).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .base import Releasable, Release
from .bearing import BearingKind
from .floating import KIND as FLOATING


class Locating(BearingKind, Releasable):
    """The locating bearing kind (module doc)."""

    name = "locating"
    locates = True
    paper = True

    def directions(self, element, frame):
        return "global", ("x", "y", "z"), np.eye(3)

    release_name, release_form, release_rank = "floating", "float:<shaft>.<bearing>", 1

    def releases(self, scene):
        return [Release(self.release_name, s.name, b.name) for s in scene.shafts
                for b in s.bearings if b.kind == self.name]

    def parse_release(self, target, scene):
        shaft, _, bearing = target.partition(".")
        found = {s.name: s for s in scene.shafts}.get(shaft)
        if found is not None and bearing in {b.name for b in found.bearings}:
            return Release(self.release_name, shaft, bearing)
        return None

    def release_label(self, release):
        return f"float:{release.shaft}.{release.bearing}"

    def release_words(self, release):
        return f"make bearing {release.shaft}.{release.bearing} floating"

    def apply_release(self, release, shafts, elements):
        k = [s.name for s in shafts].index(release.shaft)
        bearings = tuple(FLOATING.made_from(b) if b.name == release.bearing else b
                         for b in shafts[k].bearings)
        shafts[k] = dataclasses.replace(shafts[k], bearings=bearings)

    def axial_faces(self, link, scene):
        k = scene.contact.bearing_stiffness_N_m
        return [(1.0, k), (-1.0, k)]


KIND = Locating()
