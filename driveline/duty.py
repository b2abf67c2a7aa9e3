"""A scene's load spectrum (duty cycle): bins of the line's input torque and speed, each
with its share of the operating time (:class:`~.scene.DutyBin`), read from the scene's
``[[duty_cycle]]`` tables.
"""

from __future__ import annotations

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
