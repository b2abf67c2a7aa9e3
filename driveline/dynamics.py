"""The reduced 1-DOF equation of motion and every body's motion over a time grid.

With the input angle ``q`` as the one coordinate, each body's angular velocity is
``w_b(q) q'`` (shafts: ``w = (dphi_k/dq) a_k``; cross-pins: the kinematics' rate).
The kinetic energy ``T = 1/2 I(q) q'^2`` with ``I = sum_b w_b · J_b w_b`` gives
Lagrange's equation

    I(q) q'' + 1/2 I'(q) q'^2 = M(t) - T_load(t) dphi_out/dq,    1/2 I' = sum_b w_b · J_b w_b'

(centres of mass lie on fixed axes or at fixed joint centres, so gravity does no
work). The same ``w_b`` and inertias build the d'Alembert loads of the equilibrium
operator, so ``A x = b`` is consistent to round-off at every instant.

Without the ``inertia`` effect the analysis is quasi-static: the input turns at the
scene's initial speed, no d'Alembert term exists, and the load torque is the one
that balances the input torque (power balance), reported in ``Motion.load_torque``.

Its compiled kernels use NumPy's error model (:mod:`.compiled`): a bad number gives a
NaN for the callers' finiteness checks, never an exception from compiled code.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from cardan_forces.util.compiled import HAVE_NUMBA, njit

from .harmonic import harmonic, harmonic_law
from .kinematics import Geometry, Kinematics, kinematics, reduced_terms, rest_geometry
from .scene import Scene


class DynamicsError(RuntimeError):
    """The equation of motion could not be integrated."""


@dataclass(frozen=True)
class Motion:
    """Every body's motion at the instants ``t`` (s); angles in rad, SI throughout.

    Shafts: ``omega[k]``, ``alpha[k]`` about their own axes. Cross-pins:
    ``pin_omega[j]``, ``pin_alpha[j]`` as global vectors. Centres of mass of shafts
    and cross-pins do not move in the rigid model: ``com_acceleration`` is zero and
    kept so that callers need not know that.
    """

    scene: Scene
    geometry: Geometry
    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    kin: Kinematics
    omega: np.ndarray
    alpha: np.ndarray
    pin_omega: np.ndarray
    pin_alpha: np.ndarray
    com_acceleration: np.ndarray
    input_torque: np.ndarray
    load_torque: np.ndarray


def _pin_inertia_global(scene: Scene, kin: Kinematics) -> np.ndarray:
    """Cross-pin inertia tensors in the global frame, shape (joints, T, 3, 3); zero for
    a joint without a pin.
    """
    frames = np.stack([kin.e1, kin.e2, kin.e3], axis=-1)  # columns e1, e2, e3
    diag = np.diag(scene.crosspin.inertia_kg_m2)
    tensors = frames @ diag @ np.swapaxes(frames, -1, -2)
    return tensors * np.array(kin.pinned, bool)[:, None, None, None]


def reduced_inertia(scene: Scene, kin: Kinematics) -> tuple[np.ndarray, np.ndarray]:
    """``I(q)`` (kg m²) and ``1/2 I'(q)`` at the kinematics' instants."""
    jax = np.array([s.axial_inertia_kg_m2 for s in scene.shafts])[:, None]
    inertia = np.sum(jax * kin.ratio**2, axis=0)
    half_slope = np.sum(jax * kin.ratio * kin.ratio_dq, axis=0)
    if scene.has("crosspin_inertia") and len(scene.joints):
        jp = _pin_inertia_global(scene, kin)
        jw = np.einsum("jtab,jtb->jta", jp, kin.pin_rate)
        inertia = inertia + np.einsum("jta,jta->t", kin.pin_rate, jw)
        half_slope = half_slope + np.einsum("jta,jta->t", kin.pin_rate_dq, jw)
    return inertia, half_slope


def _acceleration(scene: Scene, kin: Kinematics, t, qd) -> np.ndarray:
    inertia, half_slope = reduced_inertia(scene, kin)
    drive = scene.input_torque(t) - scene.load_torque(t) * kin.ratio[-1]
    return (drive - half_slope * qd**2) / inertia


@njit(cache=True)
def _compiled_rhs(t, y, drive, load, geometry_arrays):
    """``(q', q'')`` from the reduced equation at one state, compiled."""
    inertia, half_slope, ratio = reduced_terms(y[0], *geometry_arrays)
    torque = harmonic(drive, t) - harmonic(load, t) * ratio
    return np.array([y[1], (torque - half_slope * y[1] ** 2) / inertia])


def _right_hand_side(scene: Scene, geometry: Geometry):
    """``(t, [q, q']) -> [q', q'']`` for the integrator: the compiled one-instant
    kinematics (:func:`~cardan_forces.driveline.kinematics.reduced_terms`) where numba is
    installed and it reproduces the array path (:func:`_acceleration`) to 1e-12 at a few
    angles, so that a chain the compiled copy does not know falls back to the array path
    instead of giving other answers; else the array path (array calls per instant).
    """
    def array(time, y):
        kin = kinematics(geometry, y[0])
        return [y[1], _acceleration(scene, kin, time, y[1:2])[0]]

    if not HAVE_NUMBA:
        return array
    jax = np.array([s.axial_inertia_kg_m2 for s in scene.shafts], float)
    pins = (np.array(scene.crosspin.inertia_kg_m2, float) if scene.has("crosspin_inertia")
            else np.zeros(3))
    arrays = (geometry.axes, geometry.yoke_in, geometry.yoke_out, jax, pins,
              geometry.homokinetic)
    drive, load = harmonic_law(scene.input_torque), harmonic_law(scene.load_torque)
    compiled = lambda time, y: _compiled_rhs(time, y, drive, load, arrays)  # noqa: E731
    probe = np.array([0.3, 1.1, 2.0, 4.4]) + scene.initial_angle_rad
    expected = _acceleration(scene, kinematics(geometry, probe), 0.4, np.full(4, 1.3))
    got = np.array([compiled(0.4, np.array([q, 1.3]))[1] for q in probe])
    return compiled if np.allclose(got, expected, rtol=1e-12, atol=0.0) else array


def simulate(scene: Scene, times=None, rtol: float = 1e-11, atol: float = 1e-12) -> Motion:
    """Motion at ``times`` (default: the scene's grid), integrated from the scene's
    start with an explicit 8th-order method at tight tolerance.
    """
    geometry = rest_geometry(scene)
    t = scene.time.instants() if times is None else np.atleast_1d(np.asarray(times, float))
    if np.any(t < scene.time.start_s):
        raise DynamicsError(f"instants before the scene's start {scene.time.start_s} s")
    q0, w0 = scene.initial_angle_rad, scene.initial_speed_rad_s
    if scene.has("inertia"):
        from scipy.integrate import solve_ivp  # slow to import; quasi-static lines skip it

        order = np.argsort(t)

        rhs = _right_hand_side(scene, geometry)
        t_end = max(float(t.max()), scene.time.start_s)
        sol = solve_ivp(
            rhs, (scene.time.start_s, t_end), [q0, w0], method="DOP853", t_eval=t[order],
            rtol=rtol, atol=atol,
        ) if t_end > scene.time.start_s else None
        if sol is not None and not sol.success:
            raise DynamicsError(f"integration failed: {sol.message}")
        q, qd = np.empty_like(t), np.empty_like(t)
        if sol is None:
            q[:], qd[:] = q0, w0
        else:
            q[order], qd[order] = sol.y[0], sol.y[1]
        kin = kinematics(geometry, q)
        qdd = _acceleration(scene, kin, t, qd)
        load = scene.load_torque(t) * np.ones_like(t)
    else:
        q = q0 + w0 * (t - scene.time.start_s)
        qd, qdd = np.full_like(t, w0), np.zeros_like(t)
        kin = kinematics(geometry, q)
        load = scene.input_torque(t) / kin.ratio[-1]
    omega = kin.ratio * qd
    alpha = kin.ratio * qdd + kin.ratio_dq * qd**2
    pin_omega = kin.pin_rate * qd[:, None]
    pin_alpha = kin.pin_rate * qdd[:, None] + kin.pin_rate_dq * (qd**2)[:, None]
    n_bodies = len(scene.shafts) + sum(kin.pinned)
    return Motion(
        scene=scene,
        geometry=geometry,
        t=t,
        q=q,
        qd=qd,
        qdd=qdd,
        kin=kin,
        omega=omega,
        alpha=alpha,
        pin_omega=pin_omega,
        pin_alpha=pin_alpha,
        com_acceleration=np.zeros((n_bodies, len(t), 3)),
        input_torque=scene.input_torque(t) * np.ones_like(t),
        load_torque=load,
    )
