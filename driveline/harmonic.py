"""The harmonic torque law as compiled kernels take it (the rigid and the penalty
simulations' drive and load torques, :class:`~cardan_forces.driveline.scene.TorqueLaw`).
"""

from __future__ import annotations

import numpy as np

from cardan_forces.util.compiled import njit


@njit(cache=True)
def harmonic(law, t):
    """``mean + amplitude cos(2 pi f t + phase)`` (N m) with ``law`` = those four
    (:class:`~cardan_forces.driveline.scene.TorqueLaw`'s fields) at time ``t`` (s).
    """
    return law[0] + law[1] * np.cos(2.0 * np.pi * law[2] * t + law[3])


def harmonic_law(torque) -> np.ndarray:
    """A :class:`~cardan_forces.driveline.scene.TorqueLaw` as :func:`harmonic` takes it."""
    return np.array([torque.mean_N_m, torque.amplitude_N_m, torque.frequency_hz,
                     torque.phase_rad], float)
