"""The Cardan (universal, Hooke) joint: a cross-pin body between the end of one shaft
and the start of the next, held in each yoke by two trunnions in their bores and two
end faces.

Links (forces on the pin, the opposite on the yoke's shaft body), in the pin's own
frame ``(e1, e2, e3)``, ``e1`` the driving trunnion axis, ``e2`` the driven one,
``e3 = e1 x e2``:

- ``<joint>.F1.e2``, ``<joint>.F1.e3``: radial force on the driving trunnion at
  ``+hs e1``; ``F2`` the same at ``-hs e1``; ``<joint>.F3`` >= 0 the end-face push
  along ``-e1`` at ``+ht e1``; ``F4`` >= 0 along ``+e1`` at ``-ht e1``;
- ``F5`` (``.e3``, ``.e1``) at ``+hs e2``, ``F6`` at ``-hs e2``, ``F7`` >= 0 along
  ``-e2`` at ``+ht e2``, ``F8`` >= 0 along ``+e2`` at ``-ht e2``: the driven yoke's.

A radial force acts through the trunnion axis, so it enters linearly (the paper's
contact angle is a change of variables); an end-face force acts on the trunnion axis.
The two end faces of one trunnion pair are opposite columns: only one touches (the
paper's eqs. 39, 46), a pair complementarity resolves.

Contact laws: Hertz, ``K`` of the paper's eqs. 76-77
(:func:`~..contact.hertz_stiffness`, one per joint), the scene's exponent; gaps the
radial clearance ``rb - rs`` in a bore and the axial one ``hb - ht`` at an end face.
The penalty model (eqs. 75-78): the trunnion point at ``+-hs`` in its bore (the yoke's
axis through the joint centre), and the trunnion end beyond the housing bottom at
``hb``.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..contact import hertz_stiffness
from ..scene import CROSSPIN_ASPECT, MAX_ARTICULATION_DEG, Joint, Range, Scene, table_keys
from .base import Body, Column, EngineJoint, FormulationExtras, Law, Layout, Link, Paired, PairMode
from .joint import JointKind, JointStep, rotate_perp

RADIAL, FACE = "trunnion-radial", "end-face"

CROSSPIN_KEYS = ("hs_m", "rs_m", "rb_m", "ht_m", "hb_m", "rt_m")
"""A cross-pin's dimensions (m), the paper's Table 2 and Fig. 5."""

MASSLESS_PIN_KG = 1e-6
"""Mass MuJoCo's model gives a cross-pin the scene leaves massless (no
``crosspin_inertia``): the engine needs a positive one; its weight, 1e-5 N, is far below
the loads compared."""


def normal_components(trunnion: str) -> tuple[str, str]:
    """The pin-frame directions normal to a trunnion axis, in the operator's order."""
    return ("e2", "e3") if trunnion == "e1" else ("e3", "e1")


def _yokes(segments: list, joint: int) -> tuple[int, int]:
    """The shaft bodies either side of joint ``joint``: the upstream shaft's last
    segment, the downstream shaft's first.
    """
    return (max(g for g, s in enumerate(segments) if s.shaft == joint),
            min(g for g, s in enumerate(segments) if s.shaft == joint + 1))


def _check_proportions(t, joint: Joint) -> None:
    """Refuse a cross-pin dimension below 1/:data:`~..scene.CROSSPIN_ASPECT` of the
    joint's largest, naming it, its value and the range.
    """
    largest = max(CROSSPIN_KEYS, key=lambda key: getattr(joint, key))
    most = getattr(joint, largest)
    allowed = Range(most / CROSSPIN_ASPECT, most, "m")
    for key in CROSSPIN_KEYS:
        if (refusal := allowed.refusal(getattr(joint, key))) is not None:
            t.fail(key, f"{refusal} (1/{CROSSPIN_ASPECT:g} of its largest dimension, "
                   f"{largest} = {most:g} m, to it: a cross-pin's dimensions are of one "
                   "scale)")


class Cardan(JointKind, Paired, EngineJoint, FormulationExtras):
    """The Cardan joint kind (module doc)."""

    name, record = "cardan", Joint
    link_kinds = (RADIAL, FACE)
    paper = True

    def read(self, t) -> Joint:
        """A ``[[joints]]`` table (:class:`~..scene.Joint`: angles in deg, the cross-pin
        geometry of the paper's Table 2 and Fig. 5 in m), checked: the articulation
        within :data:`~..scene.MAX_ARTICULATION_DEG`, no dimension a zero length next to
        the others (:data:`~..scene.CROSSPIN_ASPECT`), bore and housing bottom outside
        the trunnion.
        """
        t.expect(table_keys(Joint))
        name = t.string("name", name=True)
        gamma = t.number("articulation_deg", kind="angle_deg", within=Range(
            -MAX_ARTICULATION_DEG, MAX_ARTICULATION_DEG, "deg"), why="below 90 deg: the "
            "velocity ratio 1/cos grows without bound")
        joint = Joint(name=name, kind=self.name, articulation_deg=gamma,
                      yoke_phase_deg=t.number("yoke_phase_deg", 0.0, kind="angle_deg"),
                      **{key: t.number(key, positive=True, kind="length_m")
                         for key in CROSSPIN_KEYS})
        _check_proportions(t, joint)
        if joint.rb_m < joint.rs_m:
            t.fail("rb_m", f"housing bore {joint.rb_m} m is smaller than the trunnion "
                   f"{joint.rs_m} m")
        if joint.hb_m < joint.ht_m:
            t.fail("hb_m", f"housing bottom {joint.hb_m} m is inside the trunnion end "
                   f"{joint.ht_m} m")
        t.done()
        return joint

    pinned = True

    def phase_rad(self, joint: Joint) -> float:
        return np.radians(joint.yoke_phase_deg)

    def secant_stiffness(self, joint: Joint, scene: Scene) -> float:
        """Its Hertz stiffness's secant at ``damping_full_depth_m`` (N/m)."""
        ct = scene.contact
        return hertz_stiffness(scene, joint) * ct.damping_full_depth_m ** (ct.exponent - 1.0)

    def with_clearance(self, joint: Joint, gap_m: float) -> Joint:
        """Radial and axial clearance ``gap_m``: the bore ``rs + gap``, the housing
        bottom ``ht + gap``.
        """
        return dataclasses.replace(joint, rb_m=joint.rs_m + gap_m, hb_m=joint.ht_m + gap_m)

    def kinematics(self, a_in, a_out, yoke_in, yoke_out, phi, ratio, ratio_dq):
        """From 3-D frames, not from the closed forms: the cross-pin's driving trunnion
        ``e1`` turns with the driving yoke, its driven trunnion ``e2`` with the driven
        one, and the only condition is ``e1 · e2 = 0`` (both trunnions in one rigid
        cross). The driven angle solves it; its derivatives come from implicit
        differentiation. The paper's eqs. (1)-(4) are tests of this construction, not its
        implementation. The pin turns with the driving yoke and about ``e1`` relative to
        it: ``omega = omega_in a_in + omega_out (a_out · e1) e1``.
        """
        e1 = rotate_perp(yoke_in, a_in, phi)
        w_out = np.cross(a_out, yoke_out)
        raw = np.arctan2(-(e1 @ yoke_out), e1 @ w_out)
        # e2 and -e2 are the same trunnion: the solution is defined modulo pi; take the
        # branch nearest to the driving shaft's angle, which keeps it continuous.
        psi = phi + np.mod(raw - phi + 0.5 * np.pi, np.pi) - 0.5 * np.pi
        e2 = rotate_perp(yoke_out, a_out, psi)
        de1, de2 = np.cross(a_in, e1), np.cross(a_out, e2)
        g_phi = np.einsum("ti,ti->t", de1, e2)
        g_psi = np.einsum("ti,ti->t", e1, de2)
        g_phiphi = np.einsum("ti,ti->t", np.cross(a_in, de1), e2)
        g_psipsi = np.einsum("ti,ti->t", e1, np.cross(a_out, de2))
        g_phipsi = np.einsum("ti,ti->t", de1, de2)
        rho = -g_phi / g_psi
        rho_dphi = -(g_phiphi + 2.0 * g_phipsi * rho + g_psipsi * rho**2) / g_psi
        j_out = rho * ratio
        h_out = rho_dphi * ratio**2 + rho * ratio_dq
        c = e1 @ a_out
        de1_dq = ratio[:, None] * de1
        rate = ratio[:, None] * a_in + (j_out * c)[:, None] * e1
        rate_dq = (ratio_dq[:, None] * a_in
                   + (h_out * c + j_out * (de1_dq @ a_out))[:, None] * e1
                   + (j_out * c)[:, None] * de1_dq)
        return JointStep(psi, j_out, h_out, e1, e2, rate, rate_dq)

    def describe(self, joint: Joint) -> str:
        return (f"joint {joint.name:13s} articulation {joint.articulation_deg} deg, yoke "
                f"phase {joint.yoke_phase_deg} deg, clearance radial "
                f"{joint.radial_clearance_m:.3g} m, axial {joint.axial_clearance_m:.3g} m")

    def holds(self, element: Joint, shaft, segments, frames):
        a, b = _yokes(segments, shaft)
        return [(a, np.eye(3), b)]

    def add_links(self, element: Joint, shaft: int, index: int, layout: Layout) -> None:
        j, geo, kin = index, layout.geo, layout.kin
        pin = layout.add_body(Body(f"{element.name}.pin", "pin", joint=j))
        centre = geo.joint_centres[j]
        e = {"e1": kin.e1[j], "e2": kin.e2[j], "e3": kin.e3[j]}
        up, down = _yokes(layout.segments, j)
        sides = ((up, "e1", ("F1", "F2", "F3", "F4")), (down, "e2", ("F5", "F6", "F7", "F8")))
        for yoke, trunnion, (fa, fb, fc, fd) in sides:
            axis, radial = e[trunnion], normal_components(trunnion)
            common = dict(body=pin, other=yoke, element=element.name, frame="pin", joint=j,
                          trunnion=trunnion)
            for label, sign in ((fa, 1.0), (fb, -1.0)):
                name = f"{element.name}.{label}"
                point = centre + sign * element.hs_m * axis
                layout.add([Column(f"{name}.{c}", pin, yoke, point, e[c]) for c in radial],
                           name=name, kind=RADIAL, components=radial, side=sign,
                           label=label, units=("N", "N"), **common)
            for label, sign in ((fc, 1.0), (fd, -1.0)):
                name = f"{element.name}.{label}"
                layout.add([Column(name, pin, yoke, centre + sign * element.ht_m * axis,
                                   -sign * axis, True)],
                           name=name, kind=FACE,
                           components=(f"{'-' if sign > 0 else '+'}{trunnion}",),
                           side=sign, label=label, units=("N",), **common)

    def pairs(self, links: list[Link]) -> list[tuple[int, int]]:
        """Per joint and trunnion axis (``e1`` then ``e2``), its two end faces."""
        faces = {(c.joint, c.trunnion, c.side): c.columns[0] for c in links if c.kind == FACE}
        joints = sorted({c.joint for c in links})
        return [(faces[(j, tr, 1.0)], faces[(j, tr, -1.0)]) for j in joints for tr in ("e1", "e2")]

    def pair_mode(self, link: Link, other: Link) -> PairMode:
        return PairMode("end-face pair", f"both end faces {link.name} and {other.name} "
                        "pushing equally", "none needed: complementarity (only one face "
                        "touches)")

    def laws(self, link: Link, scene: Scene) -> list[Law]:
        joint = scene.joints[link.joint]
        gap = joint.axial_clearance_m if link.kind == FACE else joint.radial_clearance_m
        return [Law(link.columns, hertz_stiffness(scene, joint), gap, hertz=True)]

    def penalty(self, link: Link, rows) -> None:
        op, joint = rows.op, rows.scene.joints[link.joint]
        hertz = rows.hertz(joint)
        point, centre = op.points[0, link.columns[0]], rows.centre(link.body)
        if link.kind == RADIAL:
            axis = op.pin_frames[link.joint, 0, "e1 e2".split().index(link.trunnion)]
            rows.add(link, point, axis, centre, axis, joint.radial_clearance_m, True, hertz)
        else:
            axis = -op.directions[0, link.columns[0]]
            rows.add(link, point, axis, centre, axis, joint.hb_m, False, hertz)

    def words(self, link: Link) -> str:
        return "trunnion, radial" if link.kind == RADIAL else "end face"

    # ------------------------------------------------------------ MuJoCo

    def mjcf_joint(self, link, child, start):
        """MuJoCo: the cross-pin hangs on its driving yoke by a hinge about ``e1``, the
        driven shaft on the pin by a hinge about ``e2``, both through the joint centre.
        """
        axis = (start.kin.e1 if link.trunnion == "e1" else start.kin.e2)[link.joint, 0]
        return "hinge", axis, start.geo.joint_centres[link.joint]

    def mjcf_speed(self, link, child, axis, start):
        """The hinge's kinematic rate (eq. 3's ratio, the pin's rate) at the start."""
        kin, axes, qd0, j = start.kin, start.geo.axes, start.speed, link.joint
        if child == link.body:  # the pin on its driving shaft
            return qd0 * (kin.pin_rate[j, 0] - kin.ratio[j, 0] * axes[j]) @ axis
        return qd0 * (kin.ratio[j + 1, 0] * axes[j + 1] - kin.pin_rate[j, 0]) @ axis

    def mjcf_body(self, body, start):
        """The cross-pin at the start: the scene's ``[crosspin]`` mass and inertia with
        ``crosspin_inertia``, else nearly massless (:data:`MASSLESS_PIN_KG`).
        """
        scene, geo, kin = start.scene, start.geo, start.kin
        j = start.bodies[body].joint
        now = np.stack([kin.e1[j, 0], kin.e2[j, 0], kin.e3[j, 0]], axis=1)
        rest = np.stack([geo.yoke_in[j], geo.yoke_out[j],
                         np.cross(geo.yoke_in[j], geo.yoke_out[j])], axis=1)
        massive = scene.has("crosspin_inertia")
        moments = np.array(scene.crosspin.inertia_kg_m2) if massive else np.full(3, 1e-12)
        return (geo.joint_centres[j], now @ rest.T,
                scene.crosspin.mass_kg if massive else MASSLESS_PIN_KG,
                now @ np.diag(moments) @ now.T)

    # ------------------------------------------------------------ convex extensions

    def rim_moments(self, op, i: int, link: Link) -> list:
        """An end face's moment normal to its trunnion axis inside its centre-of-pressure
        cone ``||m|| <= rt f`` (the paper's rim contact, eqs. 33-36, 42-43, made convex):
        ``[(members, cone)]``, members ``(name, column of A, weight)``, the cone's
        ``apex`` and ``scale``; none for a radial contact.
        """
        if link.kind != FACE:
            return []
        rt, frames = op.scene.joints[link.joint].rt_m, op.pin_frames[link.joint, i]
        members = []
        for comp in normal_components(link.trunnion):
            direction = frames["e1 e2 e3".split().index(comp)]
            col = np.zeros(op.A.shape[1])
            col[op.body_rows(link.body)] = direction
            col[op.body_rows(link.other)] = -direction
            members.append((f"{link.name}.m_{comp}", col, 1.0 / rt ** 2))
        return [(members, dict(apex=link.columns[0], scale=rt))]

    def friction_forces(self, op, i: int, link: Link, frameless: np.ndarray, mu: float
                        ) -> list:
        """Coulomb friction at an end face and on its trunnion's radial contact (the
        ``friction`` formulation's terms, as :meth:`rim_moments` gives its moments).

        - the face: a tangential force ``t`` in the face plane at the face centre,
          ``||t|| <= mu f``;
        - the radial contact on the same trunnion side: a force along the trunnion axis
          ``a``, ``|a| <= mu n0 . r`` with ``n0`` the direction of the frictionless
          least-norm radial force ``frameless``: Coulomb's cone about that normal, an
          inner approximation of ``|a| <= mu ||r||`` (which is not convex).
        """
        if link.kind != FACE:
            return []
        joint, j = op.scene.joints[link.joint], link.columns[0]
        frames = op.pin_frames[link.joint, i]
        axis_dir = frames["e1 e2".split().index(link.trunnion)]
        radial = next(c for c in op.contacts if c.kind == RADIAL and (c.joint, c.trunnion,
                      c.side) == (link.joint, link.trunnion, link.side))
        members = []
        for comp, column in zip(normal_components(link.trunnion), radial.columns):
            # the radial column of the same trunnion, moved from hs to ht along the axis
            col = op.A[i][:, column].copy()
            comp_dir = frames["e1 e2 e3".split().index(comp)]
            arm = link.side * (joint.ht_m - joint.hs_m) * np.cross(axis_dir, comp_dir)
            col[op.body_rows(link.body)] += arm
            col[op.body_rows(link.other)] -= arm
            members.append((f"{link.name}.t_{comp}", col, 1.0))
        # axial friction of the radial contact: a force along the axis through the axis,
        # the same line as the end face's (opposite) push
        cols = list(radial.columns)
        normal = frameless[cols]
        norm = np.linalg.norm(normal)
        w = mu * (normal / norm if norm > 0 else np.zeros(2))
        along = -link.side * op.A[i][:, j]
        return [(members, dict(apex=j, scale=mu)),
                ([(f"{radial.name}.t_{link.trunnion}", along, 1.0)],
                 dict(apex=cols[0], scale=w[0], apex_terms=((cols[1], w[1]),)))]


KIND = Cardan()
