"""numba's ``njit`` where numba is installed, else a decorator that leaves functions as
they are (callers then use their NumPy paths; see :data:`HAVE_NUMBA`).

The package's kernels compile with NumPy's error model: a division by zero gives an
infinity or a NaN, as the NumPy reference does, instead of raising
``ZeroDivisionError`` from inside compiled code. Whether a divisor is exactly zero can
depend on the CPU numba compiles for (fused multiply-adds change the last bits), so a
raise there would fail on one machine and not on another; the kernels' callers check
their results for finite numbers and end with a failed status instead.
"""

from __future__ import annotations

import numpy as np

try:
    import numba

    HAVE_NUMBA = True

    def njit(*args, **kwargs):
        """``numba.njit`` with NumPy's error model unless the caller sets one."""
        kwargs.setdefault("error_model", "numpy")
        return numba.njit(*args, **kwargs)
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
