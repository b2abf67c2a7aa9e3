"""The equilibrium operator ``A(t) x = b(t)`` of all bodies (DESIGN §1).

Rows: per body (shafts, then cross-pins), three force and three moment equations in
the global frame, moments about the body's reference point (a shaft's centre, a
cross-pin's centre). Row ``i`` reads: sum of contact forces (moments) on the body =
``b_i`` = inertial (d'Alembert) terms - applied loads - weight.

Columns: the contact forces, all in N, each acting on one body and the opposite on
the other (a cross-pin's contacts are reported as forces on the pin):

- ``bearing.<shaft>.<bearing>.<x|y|z>``: a bearing's force on its shaft, global frame;
- ``<joint>.F1.e2``, ``<joint>.F1.e3``: radial force on the driving trunnion at
  ``+hs e1``; ``F2`` the same at ``-hs e1``; ``<joint>.F3`` >= 0 the end-face push
  along ``-e1`` at ``+ht e1``; ``F4`` >= 0 along ``+e1`` at ``-ht e1``;
- ``F5`` (``.e3``, ``.e1``) at ``+hs e2``, ``F6`` at ``-hs e2``, ``F7`` >= 0 along
  ``-e2`` at ``+ht e2``, ``F8`` >= 0 along ``+e2`` at ``-ht e2``: the driven yoke's.

Frame of the joint components: the cross-pin's own ``(e1, e2, e3)``, ``e1`` the
driving trunnion axis, ``e2`` the driven one, ``e3 = e1 x e2``. A radial force acts
through the trunnion axis, so it enters linearly (the paper's contact angle is a
change of variables); in this operator an end-face force acts on the trunnion axis.

``b`` is kept as a sum of named terms, one per effect, so that switching an effect
off removes exactly its term: ``applied`` (drive and load torques, always),
``gravity`` (the shafts' weight, and the cross-pins' when ``crosspin_inertia`` gives
them mass), ``inertia`` (shafts), ``crosspin_inertia`` (cross-pins).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .dynamics import Motion, _pin_inertia_global
from .scene import Scene

AXES = "xyz"


@dataclass(frozen=True)
class Operator:
    """``A`` (T, rows, n) and ``b`` (T, rows) over the motion's instants.

    ``terms`` holds ``b``'s parts by effect; ``b`` is their sum. ``unilateral`` marks
    the end-face components (>= 0); ``pairs`` are the index pairs of the two end faces
    of one trunnion pair, complementary in the paper (eqs. 39, 46).
    """

    t: np.ndarray
    A: np.ndarray
    b: np.ndarray
    terms: dict[str, np.ndarray]
    names: tuple[str, ...]
    rows: tuple[str, ...]
    unilateral: np.ndarray
    pairs: tuple[tuple[int, int], ...]
    scene: Scene

    def index(self, name: str) -> int:
        """Column of a named force component."""
        try:
            return self.names.index(name)
        except ValueError:
            raise KeyError(f"no force component {name!r}") from None


def _columns(motion: Motion):
    """Yield (name, body, point (T,3) or (3,), direction (T,3) or (3,), other body or
    None, unilateral) for every contact force component.
    """
    scene, geo, kin = motion.scene, motion.geometry, motion.kin
    n_shafts = len(scene.shafts)
    eye = np.eye(3)
    for k, shaft in enumerate(scene.shafts):
        for bearing, point in zip(shaft.bearings, geo.bearing_points[k]):
            for i, axis in enumerate(AXES):
                yield f"bearing.{shaft.name}.{bearing.name}.{axis}", k, point, eye[i], None, False
    for j, joint in enumerate(scene.joints):
        pin, centre = n_shafts + j, geo.joint_centres[j]
        e = {"e1": kin.e1[j], "e2": kin.e2[j], "e3": kin.e3[j]}
        sides = (
            (j, "e1", ("F1", "F2", "F3", "F4"), ("e2", "e3")),
            (j + 1, "e2", ("F5", "F6", "F7", "F8"), ("e3", "e1")),
        )
        for yoke, trunnion, (fa, fb, fc, fd), radial in sides:
            axis = e[trunnion]
            for label, sign in ((fa, 1.0), (fb, -1.0)):
                for comp in radial:
                    yield (f"{joint.name}.{label}.{comp}", pin, centre + sign * joint.hs_m * axis,
                           e[comp], yoke, False)
            yield f"{joint.name}.{fc}", pin, centre + joint.ht_m * axis, -axis, yoke, True
            yield f"{joint.name}.{fd}", pin, centre - joint.ht_m * axis, axis, yoke, True


def build_operator(motion: Motion) -> Operator:
    """Assemble ``A`` and ``b`` at every instant of ``motion`` (batched)."""
    scene, geo = motion.scene, motion.geometry
    n_shafts, n_joints = len(scene.shafts), len(scene.joints)
    refs = np.concatenate([geo.centres, geo.joint_centres])  # moment reference per body
    T = len(motion.t)
    cols = list(_columns(motion))
    A = np.zeros((T, 6 * (n_shafts + n_joints), len(cols)))
    for c, (_, body, point, direction, other, _) in enumerate(cols):
        direction = np.broadcast_to(direction, (T, 3))
        point = np.broadcast_to(point, (T, 3))
        for target, sign in ((body, 1.0), (other, -1.0)):
            if target is None:
                continue
            A[:, 6 * target: 6 * target + 3, c] = sign * direction
            A[:, 6 * target + 3: 6 * target + 6, c] = sign * np.cross(point - refs[target],
                                                                       direction)
    names = tuple(c[0] for c in cols)
    unilateral = np.array([c[5] for c in cols])
    pairs = tuple(
        (names.index(f"{joint.name}.{a}"), names.index(f"{joint.name}.{b}"))
        for joint in scene.joints
        for a, b in (("F3", "F4"), ("F7", "F8"))
    )
    terms = _load_terms(motion, A.shape[1])
    rows = tuple(
        f"{body}.{kind}.{axis}"
        for body in [s.name for s in scene.shafts] + [f"{j.name}.pin" for j in scene.joints]
        for kind in ("force", "moment")
        for axis in AXES
    )
    return Operator(
        t=motion.t, A=A, b=sum(terms.values()), terms=terms, names=names, rows=rows,
        unilateral=unilateral, pairs=pairs, scene=scene,
    )


def _load_terms(motion: Motion, n_rows: int) -> dict[str, np.ndarray]:
    """``b``'s terms, one per effect the scene calls for (and ``applied``, always)."""
    scene, geo = motion.scene, motion.geometry
    n_shafts = len(scene.shafts)
    T = len(motion.t)
    moment = lambda body: slice(6 * body + 3, 6 * body + 6)  # noqa: E731
    force = lambda body: slice(6 * body, 6 * body + 3)  # noqa: E731

    applied = np.zeros((T, n_rows))
    applied[:, moment(0)] -= motion.input_torque[:, None] * geo.axes[0]
    applied[:, moment(n_shafts - 1)] += motion.load_torque[:, None] * geo.axes[-1]
    terms = {"applied": applied}

    if scene.has("gravity"):
        g = np.array(scene.gravity_m_s2)
        weight = np.zeros((T, n_rows))
        for k, shaft in enumerate(scene.shafts):
            weight[:, force(k)] -= shaft.mass_kg * g
        if scene.has("crosspin_inertia"):
            for j in range(len(scene.joints)):
                weight[:, force(n_shafts + j)] -= scene.crosspin.mass_kg * g
        terms["gravity"] = weight

    if scene.has("inertia"):
        inertial = np.zeros((T, n_rows))
        for k, shaft in enumerate(scene.shafts):
            # the shaft axis is principal: J omega' + omega x J omega = J_axial alpha a
            inertial[:, moment(k)] += (shaft.axial_inertia_kg_m2 * motion.alpha[k])[:, None] * (
                geo.axes[k]
            )
            inertial[:, force(k)] += shaft.mass_kg * motion.com_acceleration[k]
        terms["inertia"] = inertial

    if scene.has("crosspin_inertia") and scene.joints:
        jp = _pin_inertia_global(scene, motion.kin)
        w, dw = motion.pin_omega, motion.pin_alpha
        gyro = np.einsum("jtab,jtb->jta", jp, dw) + np.cross(w, np.einsum("jtab,jtb->jta", jp, w))
        pins = np.zeros((T, n_rows))
        for j in range(len(scene.joints)):
            pins[:, moment(n_shafts + j)] += gyro[j]
        terms["crosspin_inertia"] = pins
    return terms
