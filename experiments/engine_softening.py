"""What the engines' softening selects: where their settings put the indeterminate loads
inside the rigid set, the prediction (:mod:`~cardan_forces.experiments.engine_member`)
drawn as a curve and the simulations (:mod:`~cardan_forces.experiments.engine`) as
points, at the study's last settled sampled instant.

- **MuJoCo**: against the ratio ``s`` of the last shaft's bearings' ``solref`` time
  constant to the first shaft's. By eq. (2) of the prediction only that ratio moves the
  member (``c_k ~ s_k^2 A_hat_k``): every other setting (time constant, damping
  ratio, impedance, width, step) scales all bearings alike and lands at ``s = 1``.
- **Drake**: against its discrete step. By eq. (3) the step scales every bearing's
  compliance alike, so the predicted member is one value, a horizontal line; SAP offers
  no other softness for ball constraints.

The loads are the first shaft's, as ``cardan engine``'s figure draws them over time
(:func:`~cardan_forces.experiments.engine_loads.load_rows`): its bearings' radial
magnitudes and its signed axial load. Writes ``engine_softening.csv`` (every number the
figure draws) and the figure ``engine_softening.<format>``.
"""

from __future__ import annotations

import csv
import textwrap
from pathlib import Path

import numpy as np
from cardan_forces.driveline.engine_mujoco import Softness

from . import engine_member, files
from .engine_loads import ENGINES, engine_of, load_of, load_rows
from .images import PAGE_IN, chars_across, legend_below, limits, save, styled

RATIOS = np.geomspace(1 / 8, 8, 49)
"""The ratios ``s`` of the MuJoCo prediction's curve."""


def _instant(result) -> int:
    """The study's last settled sampled instant (its last sampled one if none is)."""
    settled = result.sampled[result.settled]
    return int(settled[-1] if len(settled) else result.sampled[-1])


def _ratio(op, softness) -> float:
    """A MuJoCo setting's time-constant scale of the last shaft's bearings over the
    first's.
    """
    scale = dict(softness.scaled)
    first, last = op.scene.shafts[0].name, op.scene.shafts[-1].name
    return scale.get(last, 1.0) / scale.get(first, 1.0)


def rows(result) -> list[dict]:
    """The figure's numbers: per engine, load and abscissa, ``predicted`` (the curve)
    and ``simulated`` (one per run, its setting named) values (N).
    """
    op, i = result.op, _instant(result)
    loads = load_rows(op)
    out = []

    def add(engine_name, source, setting, x, forces):
        for name, rows in loads.items():
            out.append({"engine": engine_name, "source": source, "setting": setting, "x": x,
                        "load": name, "value_N": float(load_of(forces[None], rows)[0]),
                        "t": float(op.t[i])})

    runs = {label: r for label, r in result.runs.items()}
    mujoco = {k: r for k, r in runs.items() if engine_of(r) == ENGINES["mujoco"]}
    drake = {k: r for k, r in runs.items() if engine_of(r) == ENGINES["drake"]}
    if mujoco:
        base = engine_member.compliances_mujoco(op, Softness(label="default"))
        last = {link.name for link in op.bearings() if link.shaft == len(op.scene.shafts) - 1}
        for s in RATIOS:
            c = {n: v * (s * s if n in last else 1.0) for n, v in base.items()}
            add("MuJoCo", "predicted", "", float(s), engine_member.predicted(op, i, c))
        for label, r in mujoco.items():
            add("MuJoCo", "simulated", label, _ratio(op, r.softness), r.forces[i])
    if drake:
        member = result.predicted[next(iter(drake))][i]
        steps = [1e3 * r.softness.time_step_s for r in drake.values()]
        for x in (min(steps) / 1.5, max(steps) * 1.5):
            add("Drake", "predicted", "", x, member)
        for label, r in drake.items():
            add("Drake", "simulated", label, 1e3 * r.softness.time_step_s, r.forces[i])
    return out


def write_csv(found: list[dict], path: Path) -> Path:
    """``engine_softening.csv``: the rows of :func:`rows`."""
    with files.replacing(path, newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=list(found[0]))
        writer.writeheader()
        writer.writerows({**r, "x": f"{r['x']:.6g}", "value_N": f"{r['value_N']:.9g}"}
                         for r in found)
    return path


TICKS = {"MuJoCo": [0.125, 0.25, 0.5, 1.0, 2.0, 4.0, 8.0]}
"""The ratio axis' ticks (Drake's: its steps)."""
X_LABELS = {"MuJoCo": "time-constant ratio, last shaft's bearings to first's [-]",
            "Drake": "discrete step [ms]"}


def draw(result, found: list[dict], stem: Path, formats=("png",)) -> list[Path]:
    """The figure (module doc): a row per load, a column per engine that ran; the
    prediction a line, the simulations open markers; legends below.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import NullFormatter

    engines = [e for e in ("MuJoCo", "Drake") if any(r["engine"] == e for r in found)]
    loads = list(dict.fromkeys(r["load"] for r in found))
    with styled():
        fig, axes = plt.subplots(len(loads), len(engines), squeeze=False,
                                 figsize=(PAGE_IN[0], 2.0 * len(loads) + 1.4))
        handles = {}
        for col, name in enumerate(engines):
            for row, load in enumerate(loads):
                ax = axes[row, col]
                mine = [r for r in found if r["engine"] == name and r["load"] == load]
                curve = sorted((r["x"], r["value_N"]) for r in mine if r["source"] == "predicted")
                points = [(r["x"], r["value_N"]) for r in mine if r["source"] == "simulated"]
                said = (f"{name}: predicted member (least complementary energy)",
                        f"{name}: simulated, one point per setting")
                handles[said[0]], = ax.plot(*zip(*curve), "-", color="C0", zorder=2,
                                            label=said[0])
                handles[said[1]], = ax.plot(*zip(*points), "o", mfc="none", color="C3", ms=5,
                                            zorder=3, label=said[1])
                low, high = limits([np.array([v for _, v in curve + points])])
                ax.set_ylim(low, high)
                ax.set_xscale("log")
                ticks = TICKS[name] if name in TICKS else sorted({x for x, _ in points})
                ax.set_xticks(ticks, [f"{x:g}" for x in ticks])
                ax.xaxis.set_minor_formatter(NullFormatter())
                ax.set_title(textwrap.fill(f"{name}: {load}",
                                           chars_across(PAGE_IN[0] / 2 - 0.4, 8.0)), loc="left")
                ax.set_xlabel(X_LABELS[name])
                ax.set_ylabel("force [N]")
                ax.grid(True)
        fig.suptitle(f"What the engines' softening selects ({result.op.scene.name}, "
                     f"t = {found[0]['t']:.3g} s)")
        legend_below(fig, handles)
        paths = save(fig, stem, formats)
    plt.close(fig)
    return paths


def write(result, out: Path, formats=("png",)) -> list[Path]:
    """``engine_softening.csv`` and the figure in each of ``formats``."""
    found = rows(result)
    return [write_csv(found, out / "engine_softening.csv"),
            *draw(result, found, out / "engine_softening", formats)]
