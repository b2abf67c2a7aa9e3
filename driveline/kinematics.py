"""Rest geometry and 1-DOF kinematics of a chain of shafts and joints.

The chain is walked joint by joint, each joint's kind giving the driven shaft's angle
and its derivatives from the driving shaft's (:meth:`~.elements.joint.JointKind.kinematics`:
a Cardan joint solves its cross-pin's condition ``e1 · e2 = 0``, a constant-velocity
joint passes the angle on).

Everything is batched over instants: angles have shape ``(n_shafts, T)`` and
vectors ``(n_joints, T, 3)``.

Its compiled kernels use NumPy's error model (:mod:`.compiled`): a bad number gives a
NaN for the callers' finiteness checks, never an exception from compiled code.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from cardan_forces.util.compiled import njit

from .elements.joint import rotate_perp
from .elements.registry import JOINT_KINDS
from .scene import Scene


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


@dataclass(frozen=True)
class Geometry:
    """The chain at rest (all shaft angles zero), in the global frame (m).

    ``axes[k]`` points downstream along shaft ``k``; ``starts[k]`` and
    ``centres[k]`` are its upstream end and centre; joint ``j`` sits at
    ``joint_centres[j]``, the end of shaft ``j`` and start of shaft ``j + 1``.
    ``yoke_in[j]`` / ``yoke_out[j]`` are the driving / driven trunnion axes of joint
    ``j`` at rest (for a joint without trunnions, the references its shafts' angles are
    measured from). ``bearing_points[k]`` are the bearing positions on shaft ``k``;
    ``joint_kinds[j]`` the kind of joint ``j`` (:mod:`.elements`), which owns its
    kinematics.
    """

    axes: np.ndarray
    starts: np.ndarray
    centres: np.ndarray
    joint_centres: np.ndarray
    yoke_in: np.ndarray
    yoke_out: np.ndarray
    bearing_points: tuple[np.ndarray, ...]
    plane_normal: np.ndarray
    joint_kinds: tuple = ()

    @property
    def pinned(self) -> np.ndarray:
        """Per joint: it adds a body at its centre (a Cardan joint's cross-pin)."""
        return np.array([k.pinned for k in self.joint_kinds], bool)

    @property
    def homokinetic(self) -> np.ndarray:
        """Per joint: its shafts turn at one speed at any angle (a constant-velocity
        joint), the flag the compiled :func:`reduced_terms` reads.
        """
        return np.array([k.homokinetic for k in self.joint_kinds], bool)


def rest_geometry(scene: Scene) -> Geometry:
    """Lay out the chain: shafts end to end, each joint turning the next shaft in the
    articulation plane by its signed articulation angle.
    """
    a = np.array(scene.frame.input_axis)
    towards = np.array(scene.frame.articulation_towards)
    u = _unit(towards - towards.dot(a) * a)
    normal = np.cross(a, u)
    start = np.array(scene.frame.input_start_m)
    axes, starts, ins, outs = [], [], [], []
    for k, shaft in enumerate(scene.shafts):
        axes.append(a)
        starts.append(start)
        start = start + shaft.length_m * a
        if k < len(scene.joints):
            joint = scene.joints[k]
            # yoke phase reference: the articulation plane for the first joint, the
            # previous joint's driven yoke on the same shaft for later ones
            reference = outs[-1] if outs else u
            y_in = rotate_perp(reference, a, JOINT_KINDS[joint.kind].phase_rad(joint))
            gamma = math.radians(joint.articulation_deg) * scene.articulation_signs()[k]
            a, u = (
                math.cos(gamma) * a + math.sin(gamma) * u,
                -math.sin(gamma) * a + math.cos(gamma) * u,
            )
            ins.append(y_in)
            outs.append(_unit(np.cross(a, y_in)))
    axes, starts = np.array(axes), np.array(starts)
    lengths = np.array([s.length_m for s in scene.shafts])
    centres = starts + 0.5 * lengths[:, None] * axes
    bearing_points = tuple(
        np.array([centres[k] + b.offset_m * axes[k] for b in s.bearings]).reshape(-1, 3)
        for k, s in enumerate(scene.shafts)
    )
    return Geometry(
        axes=axes,
        starts=starts,
        centres=centres,
        joint_centres=starts[1:],
        yoke_in=np.array(ins).reshape(-1, 3),
        yoke_out=np.array(outs).reshape(-1, 3),
        bearing_points=bearing_points,
        plane_normal=normal,
        joint_kinds=tuple(JOINT_KINDS[j.kind] for j in scene.joints),
    )


@dataclass(frozen=True)
class Kinematics:
    """Configuration of the chain as a function of the input angle ``q`` (rad).

    ``phi[k]`` is shaft ``k``'s angle about its axis, ``ratio[k] = dphi_k/dq`` and
    ``ratio_dq[k] = d²phi_k/dq²``. Per joint: the cross-pin frame ``e1`` (driving
    trunnion), ``e2`` (driven trunnion), ``e3 = e1 x e2``, and the cross-pin's angular
    velocity per unit input speed ``pin_rate`` and its ``q``-derivative
    ``pin_rate_dq`` (so ``omega = pin_rate q'``, ``alpha = pin_rate q'' +
    pin_rate_dq q'²``); ``pinned[j]``: joint ``j`` has that body (a tuple, not indexed
    by instant; a joint without one gives its frame and rate all the same,
    :class:`~.elements.joint.JointStep`).
    """

    q: np.ndarray
    phi: np.ndarray
    ratio: np.ndarray
    ratio_dq: np.ndarray
    e1: np.ndarray
    e2: np.ndarray
    e3: np.ndarray
    pin_rate: np.ndarray
    pin_rate_dq: np.ndarray
    pinned: tuple[bool, ...]


def kinematics(geometry: Geometry, q) -> Kinematics:
    """Shaft angles, velocity ratios and cross-pin frames at input angles ``q``."""
    q = np.atleast_1d(np.asarray(q, float))
    axes = geometry.axes
    phi, ratio, ratio_dq = [q], [np.ones_like(q)], [np.zeros_like(q)]
    e1s, e2s, rates, rates_dq = [], [], [], []
    for j, kind in enumerate(geometry.joint_kinds):
        step = kind.kinematics(axes[j], axes[j + 1], geometry.yoke_in[j],
                               geometry.yoke_out[j], phi[j], ratio[j], ratio_dq[j])
        phi.append(step.angle)
        ratio.append(step.ratio)
        ratio_dq.append(step.ratio_dq)
        e1s.append(step.e1)
        e2s.append(step.e2)
        rates.append(step.rate)
        rates_dq.append(step.rate_dq)
    e1a = np.array(e1s).reshape(-1, len(q), 3)
    e2a = np.array(e2s).reshape(-1, len(q), 3)
    return Kinematics(
        q=q,
        phi=np.array(phi),
        ratio=np.array(ratio),
        ratio_dq=np.array(ratio_dq),
        e1=e1a,
        e2=e2a,
        e3=np.cross(e1a, e2a),
        pin_rate=np.array(rates).reshape(-1, len(q), 3),
        pin_rate_dq=np.array(rates_dq).reshape(-1, len(q), 3),
        pinned=tuple(bool(p) for p in geometry.pinned),
    )


# ----------------------------------------------------------------- one instant, compiled


@njit(cache=True)
def _cross3(a, b):
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
                     a[0] * b[1] - a[1] * b[0]])


@njit(cache=True)
def reduced_terms(q, axes, yoke_in, yoke_out, axial_inertia, pin_inertia, homokinetic):
    """At one input angle ``q`` (rad): ``I(q)`` (kg m²), ``1/2 I'(q)`` and the last
    shaft's ratio ``dphi_out/dq``; the joint kinds' kinematics
    (:meth:`~.elements.joint.JointKind.kinematics`) for one instant, compiled, for the
    equation of motion's right-hand side: a ``homokinetic`` joint passes the angle on,
    any other is a Cardan joint. ``pin_inertia``: the cross-pins' principal inertias
    about (e1, e2, e3), or zeros without the ``crosspin_inertia`` effect.
    """
    phi, j_in, h_in = q, 1.0, 0.0
    inertia = axial_inertia[0]
    half_slope = 0.0
    for j in range(yoke_in.shape[0]):
        if homokinetic[j]:
            inertia += axial_inertia[j + 1] * j_in**2
            half_slope += axial_inertia[j + 1] * j_in * h_in
            continue
        a_in, a_out, y_out = axes[j], axes[j + 1], yoke_out[j]
        e1 = yoke_in[j] * np.cos(phi) + _cross3(a_in, yoke_in[j]) * np.sin(phi)
        w_out = _cross3(a_out, y_out)
        raw = np.arctan2(-np.dot(e1, y_out), np.dot(e1, w_out))
        psi = phi + np.mod(raw - phi + 0.5 * np.pi, np.pi) - 0.5 * np.pi
        e2 = y_out * np.cos(psi) + w_out * np.sin(psi)
        de1, de2 = _cross3(a_in, e1), _cross3(a_out, e2)
        g_phi, g_psi = np.dot(de1, e2), np.dot(e1, de2)
        rho = -g_phi / g_psi
        rho_dphi = -(np.dot(_cross3(a_in, de1), e2) + 2.0 * np.dot(de1, de2) * rho
                     + np.dot(e1, _cross3(a_out, de2)) * rho**2) / g_psi
        j_out = rho * j_in
        h_out = rho_dphi * j_in**2 + rho * h_in
        inertia += axial_inertia[j + 1] * j_out**2
        half_slope += axial_inertia[j + 1] * j_out * h_out
        if pin_inertia[0] > 0.0:
            c = np.dot(e1, a_out)
            de1_dq = j_in * de1
            rate = j_in * a_in + (j_out * c) * e1
            rate_dq = (h_in * a_in + (h_out * c + j_out * np.dot(de1_dq, a_out)) * e1
                       + (j_out * c) * de1_dq)
            e3 = _cross3(e1, e2)
            jw = (pin_inertia[0] * np.dot(e1, rate) * e1 + pin_inertia[1] * np.dot(e2, rate) * e2
                  + pin_inertia[2] * np.dot(e3, rate) * e3)
            inertia += np.dot(rate, jw)
            half_slope += np.dot(rate_dq, jw)
        phi, j_in, h_in = psi, j_out, h_out
    return inertia, half_slope, j_in
