"""The slip (spline) joint: a shaft cut into two coaxial segments that turn together
and may slide axially (:mod:`.bodies` makes the two bodies).

Its link acts on the downstream segment at the joint and the opposite on the upstream
one, in the shaft's frame: ``<slip>.shear.<r1|r2>`` (N), ``<slip>.bending.<r1|r2>``,
``<slip>.torque`` (N m, about the axis, downstream positive); no axial force when
frictionless. With friction coefficient ``mu > 0`` also ``<slip>.axial`` (N, along
the axis), bounded by ``|axial| <= mu |torque| / pitch_radius`` (:class:`SlipFriction`).

Contact laws (assumptions: the spline's own compliance is not modelled): as stiff as a
bearing, ``k`` for the shear and axial force and ``k * (1 m)^2`` for bending and torque
(:data:`SLIP_LENGTH_M`), without gap; the components are determinate in the built-in
scenes, so the choice changes no answer there, and a stiffer spline would only worsen
the conditioning. The penalty model (frictionless only):
two radial contacts without clearance one pitch radius either side of the joint along
the axis (shear and bending) and two teeth at the pitch radius, each a face both ways
along the tangent (torque); no axial contact, the spline slides.

Its release ``slip:<shaft>`` puts a frictionless slip joint in a shaft that has none,
at its centre (or, if a bearing sits there, midway between the centre and the nearest
bearing downstream), pitch radius :data:`SLIP_PITCH_RADIUS_M` (it enters only with
friction or the compliance formulation's spline stiffness).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..scene import SPLINE_PITCH_RADIUS_M, Scene
from .base import Column, EngineJoint, FormulationExtras, Law, Layout, Link, Releasable, Release
from .inshaft import InShaftKind, sides

SLIP_LENGTH_M = 1.0
"""Length that turns the bearing stiffness (N/m) into a slip joint's bending and torsion
stiffness (N m/rad), as ``min_norm_scaled`` measures moments over 1 m."""

SLIP_PITCH_RADIUS_M = 0.02
"""Pitch radius of a spline a release adds (m; an assumption, see the module doc)."""

SPLINE_STIFFNESS_FACTOR = 1.0
"""A slip joint's spline is as stiff as a bearing (``bearing_stiffness_N_m``) per
penalty contact: the scenes give no spline stiffness, and any stiffness far above the
shafts' loads over the play leaves the rigid model's loads."""


@dataclass(frozen=True)
class SlipJoint:
    """A slip (spline) joint inside one shaft, ``offset_m`` from its centre (downstream
    positive): the shaft is two coaxial segments that turn together and may slide
    axially. The spline carries torque, shear and bending; axially only friction, at
    most ``friction_coefficient`` times its normal load ``T / pitch_radius_m``; none
    when frictionless.
    """

    name: str
    shaft: str
    offset_m: float
    pitch_radius_m: float
    friction_coefficient: float = 0.0


@dataclass(frozen=True)
class SlipFriction:
    """The axial force of a slip joint with friction: ``|x[axial]| <= ratio |x[torque]|``,
    ``ratio = mu / r`` (1/m).

    A spline of pitch radius ``r`` transmitting a torque ``T`` presses its teeth with a
    total tangential (normal-to-flank, for straight-sided teeth and no pressure angle)
    load ``N = T / r``; Coulomb friction on the flanks resists sliding by at most
    ``mu N = mu T / r``: the handbooks' spline displacement (slip) force (e.g. SAE
    Universal Joint and Driveshaft Design Manual, AE-7, section on slip spline
    friction; Seherr-Thoss et al., *Universal Joints and Driveshafts*, 2nd ed.,
    Springer 2006, on axial displacement forces of splined propshafts). Involute
    flanks at pressure angle ``alpha`` would give ``T / (r cos alpha)``; the model
    takes ``alpha = 0`` (an assumption, the lower bound).
    """

    slip: str
    axial: int
    torque: int
    ratio_per_m: float


class Slip(InShaftKind, Releasable, EngineJoint, FormulationExtras):
    """The slip joint kind (module doc)."""

    name, table, record, noun = "slip", "slip_joints", SlipJoint, "slip joint"
    link_kinds = ("slip",)
    slides = True

    def read_fields(self, t) -> dict:
        """Its pitch radius (within :data:`~..scene.SPLINE_PITCH_RADIUS_M`) and its
        flanks' friction coefficient.
        """
        return dict(
            pitch_radius_m=t.number("pitch_radius_m", positive=True, kind="length_m",
                                    within=SPLINE_PITCH_RADIUS_M,
                                    why="the pitch radii of ISO 4156's involute splines"),
            friction_coefficient=t.number("friction_coefficient", 0.0, nonnegative=True,
                                          kind="ratio"))

    def describe(self, slip: SlipJoint) -> str:
        return (f"slip joint {slip.name:8s} in shaft {slip.shaft} @ {slip.offset_m:+g} m, "
                f"pitch radius {slip.pitch_radius_m} m, friction {slip.friction_coefficient}")

    def refusal(self, slip: SlipJoint, engine: str) -> str | None:
        """Its spline friction ``mu |T| / r`` has no counterpart in a penalty contact or
        an engine joint's constant ``frictionloss``.
        """
        if slip.friction_coefficient <= 0:
            return None
        return (f"slip joint {slip.name!r} has friction (coefficient "
                f"{slip.friction_coefficient:g}): {engine} models a spline as frictionless; "
                "set its friction_coefficient to 0")

    def holds(self, element: SlipJoint, shaft, segments, frames):
        up, down = sides(segments, shaft, element.offset_m)
        axis = frames[shaft][2]
        stops = np.eye(3) if element.friction_coefficient > 0 else \
            np.eye(3) - np.outer(axis, axis)
        return [(up, stops, down)]

    def add_links(self, element: SlipJoint, shaft: int, index: int, layout: Layout) -> None:
        up, down = sides(layout.segments, shaft, element.offset_m)
        geo = layout.geo
        point = geo.centres[shaft] + element.offset_m * geo.axes[shaft]
        r1, r2, axis = layout.frames[shaft]
        name = element.name
        columns = [Column(f"{name}.shear.r1", down, up, point, r1),
                   Column(f"{name}.shear.r2", down, up, point, r2),
                   Column(f"{name}.bending.r1", down, up, None, r1),
                   Column(f"{name}.bending.r2", down, up, None, r2),
                   Column(f"{name}.torque", down, up, None, axis)]
        comps = ["shear.r1", "shear.r2", "bending.r1", "bending.r2", "torque"]
        if element.friction_coefficient > 0:
            columns.append(Column(f"{name}.axial", down, up, point, axis))
            comps.append("axial")
        units = tuple("N m" if c.point is None else "N" for c in columns)
        layout.add(columns, name=name, kind="slip", body=down, other=up, element=name,
                   frame="shaft", components=tuple(comps), shaft=shaft, units=units)

    def mjcf_joint(self, link, child, start):
        """MuJoCo: the downstream segment slides along the axis (frictionless)."""
        return "slide", start.geo.axes[link.shaft], start.refs[child]

    def friction(self, link: Link, scene: Scene) -> SlipFriction | None:
        """Its friction bound, if it has friction."""
        slip = next(s for s in scene.elements if s.name == link.element)
        if slip.friction_coefficient <= 0:
            return None
        return SlipFriction(slip=link.name, axial=link.column("axial"),
                            torque=link.column("torque"),
                            ratio_per_m=slip.friction_coefficient / slip.pitch_radius_m)

    def laws(self, link: Link, scene: Scene) -> list[Law]:
        k, c = scene.contact.bearing_stiffness_N_m, link.columns
        return [Law(c[:2], k, 0.0), Law(c[2:4], k * SLIP_LENGTH_M ** 2, 0.0),
                Law(c[4:5], k * SLIP_LENGTH_M ** 2, 0.0), *(Law((j,), k, 0.0) for j in c[5:])]

    def penalty(self, link: Link, rows) -> None:
        op = rows.op
        point = op.points[0, link.columns[0]]
        r1, _, axis = op.shaft_frames[link.shaft]
        reach = next(s for s in rows.scene.elements
                     if s.name == link.element).pitch_radius_m
        spline = rows.law(SPLINE_STIFFNESS_FACTOR * rows.scene.contact.bearing_stiffness_N_m)
        for sign in (1.0, -1.0):
            ring = point + sign * reach * axis
            rows.add(link, ring, axis, ring, axis, 0.0, True, spline)
            tooth, tangent = point + sign * reach * r1, sign * np.cross(axis, r1)
            for face in (1.0, -1.0):
                rows.add(link, tooth, face * tangent, tooth, face * tangent, 0.0, False, spline)

    def words(self, link: Link) -> str:
        return "slip joint"

    release_name, release_form, release_rank, adds_joint = "slip", "slip:<shaft>", 0, True

    def releases(self, scene):
        slipped = {s.shaft for s in scene.elements if isinstance(s, SlipJoint)}
        return [Release(self.release_name, s.name) for s in scene.shafts
                if s.name not in slipped]

    def parse_release(self, target, scene):
        if target in {s.name for s in scene.shafts}:
            return Release(self.release_name, target)
        return None

    def release_label(self, release):
        return f"slip:{release.shaft}"

    def release_words(self, release):
        return f"add a slip joint in shaft {release.shaft}"

    def apply_release(self, release, shafts, elements):
        if any(isinstance(s, SlipJoint) and s.shaft == release.shaft for s in elements):
            return
        shaft = next(s for s in shafts if s.name == release.shaft)
        elements.append(SlipJoint(name=f"slip_{release.shaft}", shaft=release.shaft,
                               offset_m=_slip_offset(shaft),
                               pitch_radius_m=SLIP_PITCH_RADIUS_M))


def _slip_offset(shaft) -> float:
    """Where a release puts a spline in ``shaft`` (module doc), m from its centre."""
    taken = sorted(b.offset_m for b in shaft.bearings)
    if all(abs(o) > 1e-9 for o in taken):
        return 0.0
    above = [o for o in taken if o > 1e-9] + [shaft.length_m / 2]
    return 0.5 * above[0]


KIND = Slip()
