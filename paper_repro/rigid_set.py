"""The rigid solution set's intervals drawn in Figs. 13-15 and in MuJoCo's figure.

The figures' quantities as rows over the contact forces (joint 1's contacts; the first
shaft's bearing loads) and the interval of each over the rigid set at evenly spread
instants (the study layer's :func:`~cardan_forces.experiments.study.value_ranges`). Both
the figures' jobs (:mod:`cardan_forces.paper_repro.runs`, in worker processes) and
MuJoCo's section (in the main process) compute them, so they sit below both.
"""

from __future__ import annotations

import numpy as np
from cardan_forces.driveline.equilibrium import Operator
from cardan_forces.experiments.study import value_ranges

BOUND_INSTANTS = 41
"""Instants (evenly spread) at which Figs. 13-15's solution-set intervals are computed."""


def joint_quantities(op: Operator, joint: int = 0) -> dict[str, np.ndarray]:
    """Fig. 13's quantities as rows over the forces: per contact ``F1`` ... ``F8`` of
    joint ``joint``, the unit rows of its columns (two for a radial force, whose
    magnitude is their length; one for an end face's push).
    """
    eye = np.eye(len(op.names))
    return {label: eye[list(link.columns)] for label, link in op.joint_contacts(joint).items()}


def bearing_quantities(op: Operator, shaft: int = 0) -> dict[str, np.ndarray]:
    """Figs. 14-15's quantities as rows over the forces, in the shaft's frame: per
    bearing ``<label>_radial`` its two rows normal to the axis; ``axial`` the one row of
    the sum of its bearings' axial loads.
    """
    rows = {c.label: op.bearing_matrix(c) for c in op.bearings(shaft)}
    out = {f"{label}_radial": m[:2] for label, m in rows.items()}
    out["axial"] = sum(m[2] for m in rows.values())[None, :]
    return out


def set_bounds(op: Operator, quantities: dict[str, np.ndarray], instants: int = BOUND_INSTANTS
               ) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """The interval of each quantity over the rigid set at ``instants`` instants
    (NaN elsewhere, and where an LP failed; +-inf where unbounded). A quantity of one row
    ``c``: the exact range of ``c x`` (:func:`value_ranges`, one warm ranging for every
    quantity at an instant). Of two rows: the range of the length of ``(c1 x, c2 x)``
    allowed by the two components' intervals (their box hull: it contains the exact
    range).
    """
    T = len(op.t)
    picks = np.unique(np.linspace(0, T - 1, min(instants, T)).round().astype(int))
    out = {q: (np.full(T, np.nan), np.full(T, np.nan)) for q in quantities}

    def span(r):  # None: unbounded on that side; a failed LP is not computed (NaN)
        if r["status"] != "solved":
            return np.nan, np.nan
        return (-np.inf if r["min"] is None else r["min"],
                np.inf if r["max"] is None else r["max"])

    starts = np.cumsum([0] + [len(rows) for rows in quantities.values()])
    every = np.vstack(list(quantities.values()))
    for i in picks:
        found = value_ranges(op, i, every)
        for (q, rows), start in zip(quantities.items(), starts):
            ranges = [span(r) for r in found[start:start + len(rows)]]
            if len(ranges) == 1:
                out[q][0][i], out[q][1][i] = ranges[0]
                continue
            closest = [0.0 if lo <= 0.0 <= hi else min(abs(lo), abs(hi)) for lo, hi in ranges]
            out[q][0][i] = np.hypot(*closest)
            out[q][1][i] = np.hypot(*[max(abs(lo), abs(hi)) for lo, hi in ranges])
    return out
