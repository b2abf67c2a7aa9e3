"""A scene's load spectrum (duty cycle): bins of the line's input torque and speed, each
with its share of the operating time (:class:`~.scene.DutyBin`), read from the scene's
``[[duty_cycle]]`` tables; a spectrum built from the engine and the gearbox
(:func:`from_engine`); the spectrum's mean speed and each bin's share of the
revolutions; and Palmgren-Miner's sum of lives over the bins (:func:`miner_life`).
"""

from __future__ import annotations

import math

import numpy as np

from .scene import DutyBin, table_keys

SHARE_SUM_TOL = 1e-6
"""How far the shares of a spectrum may sum from 1 (rounding of printed shares)."""


def read_duty_cycle(top) -> tuple[DutyBin, ...]:
    """The scene's ``[[duty_cycle]]`` bins (none: an empty tuple), each torque and speed
    positive, each share in (0, 1], the shares summing to 1.
    """
    bins = []
    for t in top.tables("duty_cycle", []):
        t.expect(table_keys(DutyBin))
        bins.append(DutyBin(
            torque_N_m=t.number("torque_N_m", positive=True, kind="torque_N_m"),
            speed_rpm=t.number("speed_rpm", positive=True, kind="speed_rpm"),
            share=t.number("share", positive=True, kind="ratio")))
        t.done()
    total = sum(b.share for b in bins)
    if bins and abs(total - 1.0) > SHARE_SUM_TOL:
        top.fail("duty_cycle", f"the bins' shares of time sum to {total:g}; they must sum "
                 "to 1")
    return tuple(bins)


def from_engine(engine_torque_N_m, engine_speed_rpm, gear_ratios, time_shares,
                efficiency: float = 1.0) -> tuple[DutyBin, ...]:
    """The load spectrum at the line's input (the gearbox output) from the engine's,
    one bin per gear ``g`` with ratio ``i_g`` (engine speed over output speed) and its
    share of the operating time.

    Each bin carries ``T = T_engine i_g eta`` (N m) at ``n = n_engine / i_g`` (r/min).

    ``engine_torque_N_m`` and ``engine_speed_rpm`` are one value for every gear or one
    per gear; ``efficiency`` ``eta`` in (0, 1] is the gearbox's. This is how drive-line
    handbooks derive the loads of the parts behind the gearbox from the engine: the
    propshaft's design torque is the engine's greatest torque through first gear, and
    its life is the fatigue damage summed over the gears, each at its share of the
    time (Seherr-Thoss, Schmelz, Aucktor, "Universal Joints and Driveshafts", 2nd ed.,
    Springer 2006, Sect. 4.7 with eqs. 1.20 and 1.22; Naunheimer, Bertsche, Ryborz,
    Novak, "Automotive Transmissions", 2nd ed., Springer 2011, on load spectra and the
    design torque of drive-line parts). ValueError for a spectrum that is none: the
    lengths differ, a ratio, torque, speed or share is not positive, the shares do not
    sum to 1 (to :data:`SHARE_SUM_TOL`), ``eta`` is outside (0, 1].
    """
    ratios = np.asarray(gear_ratios, float)
    shares = np.asarray(time_shares, float)
    if ratios.ndim != 1 or shares.shape != ratios.shape or not len(ratios):
        raise ValueError(f"give one time share per gear: {ratios.size} gear ratios, "
                         f"{shares.size} shares")
    torque, speed = (np.broadcast_to(np.asarray(v, float), ratios.shape)
                     for v in (engine_torque_N_m, engine_speed_rpm))
    for name, values in (("gear ratio", ratios), ("engine torque", torque),
                         ("engine speed", speed), ("time share", shares)):
        if not np.all(np.isfinite(values) & (values > 0)):
            raise ValueError(f"every {name} must be positive and finite, got {values}")
    if abs(shares.sum() - 1.0) > SHARE_SUM_TOL:
        raise ValueError(f"the time shares sum to {shares.sum():g}; they must sum to 1")
    if not 0.0 < efficiency <= 1.0:
        raise ValueError(f"the efficiency must lie in (0, 1], got {efficiency:g}")
    return tuple(DutyBin(torque_N_m=float(t * i * efficiency), speed_rpm=float(n / i),
                         share=float(s)) for t, n, i, s in zip(torque, speed, ratios, shares))


def _speeds(bins, speeds_rpm) -> np.ndarray:
    """The bins' speeds (r/min), or ``speeds_rpm``, those of a shaft the bins turn."""
    return np.array([b.speed_rpm for b in bins] if speeds_rpm is None else speeds_rpm,
                    float)


def mean_speed_rpm(bins, speeds_rpm=None) -> float:
    """The time-weighted mean speed ``n_m = sum t_i n_i`` (r/min) of a spectrum, its
    shares of time ``t_i`` summing to 1; with ``speeds_rpm``, of a shaft turning at
    those speeds in the bins (the line's input by default).
    """
    return float(np.dot([b.share for b in bins], _speeds(bins, speeds_rpm)))


def revolution_shares(bins, speeds_rpm=None) -> np.ndarray:
    """Each bin's share of the revolutions, ``u_i = t_i n_i / sum_j t_j n_j``: ISO 281
    counts a life in revolutions, so the bins' damage adds by these shares, not by the
    shares of time (``speeds_rpm`` as in :func:`mean_speed_rpm`).
    """
    revs = np.array([b.share for b in bins]) * _speeds(bins, speeds_rpm)
    return revs / revs.sum()


def miner_life(lives, shares) -> float:
    """Palmgren-Miner's linear damage sum: the life ``L = 1 / sum_i (u_i / L_i)`` of a
    spectrum whose bin ``i``, alone, gives life ``L_i`` and takes the share ``u_i`` of
    the revolutions (the unit of ``L_i`` is ``L``'s). A bin of infinite life does no
    damage; one of life 0 makes ``L`` 0; NaN where a bin that turns has no value, and
    ``inf`` where no bin does damage.
    """
    lives, shares = np.asarray(lives, float), np.asarray(shares, float)
    turning = shares > 0
    if np.isnan(lives[turning]).any():
        return math.nan
    if (lives[turning] == 0).any():
        return 0.0
    damage = float(np.sum(shares[turning] / lives[turning]))
    return math.inf if damage == 0 else 1.0 / damage
