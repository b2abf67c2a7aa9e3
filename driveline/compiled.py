"""numba's ``njit`` where numba is installed, else a decorator that leaves functions as
they are (callers then use their NumPy paths; see :data:`HAVE_NUMBA`).
"""

from __future__ import annotations

import numpy as np

try:
    from numba import njit

    HAVE_NUMBA = True
except ImportError:
    HAVE_NUMBA = False

    def njit(*args, **kwargs):
        """Leave a function as it is where numba is not installed."""
        return args[0] if args and callable(args[0]) else (lambda f: f)

__all__ = ["HAVE_NUMBA", "harmonic", "harmonic_law", "njit"]


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
