"""What every joint kind shares: a joint sits at the end of one shaft and the start
of the next (``[[joints]]``, its ``kind`` naming the kind, the Cardan joint by
default), and joins their bodies, directly or through a body of its own.

A joint kind owns its kinematics (:meth:`JointKind.kinematics`, the NumPy reference
that :mod:`..kinematics` chains joint by joint): from the driving shaft's angle and
its derivatives with respect to the input angle ``q``, the driven shaft's, and the
frame and angular velocity of the body it adds, if any (``pinned``). The compiled
one-instant form (:func:`~..kinematics.reduced_terms`) knows a joint by its flags
(``homokinetic``) and is held to this reference by a test and, at run time, by a probe
(:func:`~..dynamics._right_hand_side`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .base import ElementKind


def rotate_perp(v: np.ndarray, axis: np.ndarray, angle) -> np.ndarray:
    """Rotate ``v`` (perpendicular to the unit ``axis``) by ``angle`` (rad), batched."""
    angle = np.asarray(angle, float)[..., None]
    return v * np.cos(angle) + np.cross(axis, v) * np.sin(angle)


@dataclass(frozen=True)
class JointStep:
    """One joint's kinematics at the instants of ``q`` (arrays over instants): the
    driven shaft's ``angle`` (rad), ``ratio`` ``d angle/dq`` and ``ratio_dq``
    ``d² angle/dq²``; the joint's frame ``e1``, ``e2`` (T, 3), and the angular velocity
    of its body per unit input speed ``rate`` and its ``q``-derivative ``rate_dq``
    (T, 3), so that ``omega = rate q'`` and ``alpha = rate q'' + rate_dq q'²``.
    """

    angle: np.ndarray
    ratio: np.ndarray
    ratio_dq: np.ndarray
    e1: np.ndarray
    e2: np.ndarray
    rate: np.ndarray
    rate_dq: np.ndarray


class JointKind(ElementKind):
    """A joint kind; ``name`` is its ``kind`` in a scene's ``[[joints]]`` table, ``record``
    the record of its joints; ``pinned``: it adds a body at its centre; ``homokinetic``:
    its shafts turn at one speed at any angle.
    """

    record: type = object
    pinned = False
    homokinetic = False

    def read(self, t):
        """The joint from its scene table (its fields read and checked here)."""
        raise NotImplementedError

    def describe(self, joint) -> str:
        """One line of ``scene show``: what it is and its own fields with units."""
        return f"joint {joint.name} ({self.name})"

    def phase_rad(self, joint) -> float:
        """Its driving reference's turn about the driving shaft from the one before it
        (rad): a Cardan joint's yoke phase; none for a joint without yokes.
        """
        return 0.0

    def secant_stiffness(self, joint, scene) -> float | None:
        """Its contacts' stiffness that the bearings' is held against
        (:func:`~.checks.check_stiffness`, N/m), None without such contacts.
        """
        return None

    def with_clearance(self, joint, gap_m: float):
        """The joint with every clearance of its contacts ``gap_m`` (m); unchanged for a
        joint without clearances.
        """
        return joint

    def kinematics(self, a_in, a_out, yoke_in, yoke_out, phi, ratio, ratio_dq
                   ) -> JointStep:
        """The driven shaft's angle and the joint's body from the driving shaft's
        ``phi``, ``ratio`` and ``ratio_dq`` (arrays over instants), on axes ``a_in``,
        ``a_out`` with rest references ``yoke_in``, ``yoke_out`` (:class:`JointStep`).
        """
        raise NotImplementedError
