"""MuJoCo's part of ``cardan repro`` (the ``engine`` method).

Its forward simulation over the run's first :data:`ENGINE_S` under the softness settings
its figure draws, set against every component's rigid interval and the formulations
(:mod:`cardan_forces.experiments.engine`), and the report's section and figure on the
input shaft's bearing loads with its cost beside the penalty simulation's. Drawn only
where MuJoCo is installed, apart from the paper's figures.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
from cardan_forces.driveline import engine_mujoco
from cardan_forces.driveline.dynamics import simulate
from cardan_forces.driveline.equilibrium import Operator, build_operator
from cardan_forces.driveline.scene import Scene
from cardan_forces.experiments.engine import (
    FIGURE_SETTINGS,
    SETTINGS,
    agreement_lines,
    compare,
    engine_runs,
    settle_s,
)
from cardan_forces.experiments.engine import (
    spread as softness_spread,
)
from cardan_forces.experiments.environment import number_text

from . import figures
from .rigid_set import bearing_quantities, set_bounds
from .runs import _Runs

ENGINE_S = 0.5
"""MuJoCo's window (s from the start): its settling (0.08 s at the softest setting drawn)
and some 0.1 s of each load's swing, short enough for every setting to stay a small
part of the run."""
ENGINE_INSTANTS = 3
"""Instants of MuJoCo's window, after its settling, set against every component's
interval and the formulations (:func:`cardan_forces.experiments.engine.compare`; some
70 LPs each)."""
ENGINE_BOUND_INSTANTS = 11
"""Instants of MuJoCo's window at which its figure's rigid band is computed."""
ENGINE_RTOL = 1e-4
"""A load of MuJoCo's is inside the rigid band within this share of the largest load:
its soft constraints leave ``A x = b`` at ~1e-5 (module doc of the engine's tests)."""


def _engine_work(scene: Scene, times: np.ndarray, progress) -> dict:
    """MuJoCo on the run's first :data:`ENGINE_S` under the softness settings its figure
    draws: the study (every component against its interval and the formulations at
    :data:`ENGINE_INSTANTS` instants), the figure's rigid band, and the wall time of it.
    """
    settings = [s for s in SETTINGS if s.label in FIGURE_SETTINGS]
    window = times[times <= times[0] + ENGINE_S + 1e-12]
    progress(f"repro: MuJoCo on the first {window[-1] - window[0]:g} s, {len(settings)} "
             "softness settings ...")
    start = time.perf_counter()
    op = build_operator(simulate(scene, window))
    runs = engine_runs(op, settings)
    settled = np.flatnonzero(op.t >= op.t[0] + settle_s(runs))
    picks = np.linspace(0, len(settled) - 1, min(ENGINE_INSTANTS, len(settled)))
    result = compare(op, runs, settled[picks.round().astype(int)])
    bounds = set_bounds(op, bearing_quantities(op), ENGINE_BOUND_INSTANTS)
    return {"result": result, "bounds": bounds, "wall_s": time.perf_counter() - start,
            "version": engine_mujoco.mujoco_version()}


def _engine_section(work: dict, runs: _Runs, out: Path, formats):
    """The report's MuJoCo section and its figure: what the engine says about the input
    shaft's bearing loads, where that lies in the rigid set, how far softness settings
    move it, and what it cost beside the penalty simulation.
    """
    result, bounds = work["result"], work["bounds"]
    op, runs_e = result.op, result.runs
    settle = settle_s(runs_e)
    csv, caption = figures.engine_figure(op, {k: r.forces for k, r in runs_e.items()}, bounds,
                                         out, formats, settle)
    lines = [
        f"MuJoCo {work['version']}, forward simulation of `{op.scene.name}` from its start "
        f"over {op.t[-1] - op.t[0]:g} s ({len(op.t)} instants), every bearing a soft "
        "`connect` equality, under the softness settings drawn (`solref`/`solimp`; the "
        "relative softness of the input and output shafts' bearings). A MuJoCo user reads "
        "the `default` curve. Statistics after the engine's settling "
        f"({settle:g} s; {len(result.sampled)} instants for the table); a load is inside "
        f"the rigid band within {ENGINE_RTOL:g} of the largest load. `cardan engine` "
        "runs the full study (more settings, more instants).", "", *caption,
        *_engine_load_lines(op, result, bounds, settle), "",
        "Every component against its rigid interval and the formulations:", "",
        *agreement_lines(result)[2:], "",
        *_engine_cost_lines(work, runs)]
    return ("MuJoCo beside the rigid set: input shaft bearing loads", csv, lines)


def _engine_load_lines(op: Operator, result, bounds, settle: float) -> list[str]:
    """Per bearing load of the figure: what MuJoCo reads, inside the band or not, and
    how far the settings move it against the band's width.
    """
    ok = op.t >= op.t[0] + settle
    loads = {k: figures.bearing_loads(op, r.forces) for k, r in result.runs.items()}
    first = next(iter(loads))
    lines = []
    for q, (lo, hi) in bounds.items():
        values = np.array([loads[k][q] for k in loads])
        slack = ENGINE_RTOL * max(np.nanmax(np.abs(values)), 1.0)
        checked = ok & ~np.isnan(lo)
        inside = np.all((values[:, checked] >= lo[checked] - slack)
                        & (values[:, checked] <= hi[checked] + slack), axis=0)
        width = float(np.median(hi[checked] - lo[checked])) if checked.any() else np.nan
        moved = float(np.max(np.ptp(values[:, ok], axis=0))) if ok.any() else np.nan
        share = (f" ({100 * moved / width:.0f} % of the band's median width "
                 f"{width:.1f} N)" if np.isfinite(width) and width > slack else
                 " (the band is unbounded)" if not np.isfinite(width) else
                 " (the band is one value: the load is determinate)")
        lines.append(
            f"- {q}: MuJoCo (`{first}`) reads {np.nanmin(loads[first][q][ok]):.1f} to "
            f"{np.nanmax(loads[first][q][ok]):.1f} N; every setting inside the rigid band at "
            f"{inside.sum()} of {checked.sum()} instants checked; the settings move it by "
            f"up to {moved:.1f} N{share}")
    moves = softness_spread(result)
    det = result.determinate
    lines.append(f"- all components: the settings move the determinate ones by up to "
                 f"{number_text(np.nanmax(moves[det], initial=0.0), '.3g')}, the "
                 f"indeterminate ones by up to "
                 f"{number_text(np.nanmax(moves[~det], initial=0.0), '.3g')} (N, N m): "
                 "the engine's softness, not the machine, picks the member of the set")
    return lines


def _engine_cost_lines(work: dict, runs: _Runs) -> list[str]:
    """MuJoCo's cost per simulated second beside the penalty simulation's (same run)."""
    runs_e = work["result"].runs
    span = max(work["result"].op.t[-1] - work["result"].op.t[0], 1e-12)
    per = ", ".join(f"`{k}` {r.wall_s / span:.2f}" for k, r in runs_e.items())
    pen = runs.penalty_costs()
    beside = ("; the penalty simulation " + ", ".join(f"`{n}` {c}" for n, c in pen.items())
              + " s per simulated second (in worker processes, at the same time)"
              if pen else "; no penalty simulation in this run")
    return [f"- cost (this run): MuJoCo {per} s of wall time per simulated second "
            f"({next(iter(runs_e.values())).steps / span:.0f} RK4 steps per second){beside}; "
            f"MuJoCo's whole part of this report, the rigid comparisons included, "
            f"{work['wall_s']:.1f} s"]
