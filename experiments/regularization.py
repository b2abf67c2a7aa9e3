"""What regularization costs: the physics engines' softened answer beside the rigid one.

MuJoCo and Drake's SAP make a contact problem's answer unique by softening every
constraint. The ``newton`` family offers the same softening (its option ``soften =
R``, :mod:`cardan_forces.solvers.newton_`): the equilibrium ``A f = b`` held by a
penalty, ``min sum psi_c(f_c) + ||A f - b||^2 / (2 R rho)`` (``rho`` the mean
diagonal of the nominal dual Hessian, so ``R`` is a pure number), the answer unique for
any ``R > 0``. This study solves the softened ``positive`` (every contact alike, as
MuJoCo's uniform impedance) and ``compliance`` (each contact by its stiffness) on
``paper`` and ``propshaft`` for ``R`` from 1e-1 down to 1e-10 and ``R = 0`` (rigid),
and measures, per run over the scene's instants:

- its distance from the rigid set: the package's worst residual (equilibrium, end-face
  sign and complementarity) relative to the load ``||b||``;
- its distance from the ``compliance`` member (the exact active-set answer of
  ``numpy-batched``): ``||f - f_c|| / ||f_c||``;
- its time per instant (the batched solve, fastest of :data:`REPEATS`) and Newton steps.

MuJoCo's own answer (``driveline.engine_mujoco``, its default softness) and Drake's
(``driveline.engine_drake``, SAP at a 0.25 ms step) are one point each beside the
curves where the engine is installed: its forces after the engine has settled, its
time the simulation's wall time per instant read; the report sets the two engines'
wall time per simulated second side by side. Writes ``regularization.csv``,
``regularization.md`` (a section for the bench report) and ``regularization.png``.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
from cardan_forces.driveline.dynamics import simulate
from cardan_forces.driveline.equilibrium import build_operator
from cardan_forces.driveline.loading import load_scene
from cardan_forces.formulations import SELECTION, where
from cardan_forces.formulations import batch as fbatch
from cardan_forces.solvers import newton_
from cardan_forces.solvers.judge import finalize_batch
from cardan_forces.solvers.registry import solve_batch

from . import files, images
from .bench_report import write_csv
from .environment import number_text
from .images import save

SCENES = ("paper", "propshaft")
SOFTENED = where(design=True, least_norm_batch=True)
"""The formulations softened: the design answers' selections the newton family
batches (``positive``, ``compliance``)."""
MEMBER = where(compliant=True, least_norm_batch=True)[0]
"""The compliance member of the rigid set the softened answers are measured against."""
LADDER = (1e-1, 1e-2, 1e-3, 1e-4, 1e-6, 1e-8, 1e-10, 0.0)
"""Softenings ``R`` of the study (0: the rigid answer)."""
INSTANTS = 101
"""Evenly spaced instants of each scene's grid."""
REPEATS = 3
COLUMNS = ("scene", "formulation", "R", "instants", "time_us", "iterations",
           "solved_share", "rigid_median", "rigid_worst", "compliance_median",
           "compliance_worst", "wall_s_per_simulated_s")


def operator(name: str, instants: int = INSTANTS):
    """The scene's operator at ``instants`` evenly spaced instants of its grid."""
    scene = load_scene(name)
    times = scene.time.instants()
    picks = np.unique(np.linspace(0, len(times) - 1, instants).round().astype(int))
    return build_operator(simulate(scene, times[picks]))


def measure(op, ladder=LADDER, softened=SOFTENED) -> list[dict]:
    """One row per formulation and softening on the operator's instants (module doc)."""
    member = solve_batch(fbatch.least_norm_batch(op, MEMBER), "numpy-batched").x
    rows = []
    for formulation in softened:
        batch = fbatch.least_norm_batch(op, formulation)
        for R in ladder:
            rows.append(_row(op, formulation, batch, R, member))
    return rows


def _row(op, formulation: str, batch, R: float, member: np.ndarray) -> dict:
    """The softened batch's measures (its fastest of :data:`REPEATS` solves timed)."""
    outcome, best = newton_.solve_batch(batch, soften=R), np.inf  # untimed: loads the kernel
    for _ in range(REPEATS):
        began = time.perf_counter()
        outcome = newton_.solve_batch(batch, soften=R)
        best = min(best, time.perf_counter() - began)
    record = finalize_batch(batch, "newton-batched", outcome)
    return _measures(op.scene.name, formulation, R, record.x, record.residuals.largest(),
                     member, best / len(batch.instants), float(np.mean(outcome.iterations)),
                     float(np.mean(record.status == "solved")))


def _measures(scene, formulation, R, x, primal, member, seconds, iterations, solved):
    away = np.linalg.norm(x - member, axis=1) / np.linalg.norm(member, axis=1)
    return {"scene": scene, "formulation": formulation, "R": R, "instants": len(x),
            "time_us": 1e6 * seconds, "iterations": iterations, "solved_share": solved,
            "rigid_median": float(np.median(primal)), "rigid_worst": float(np.max(primal)),
            "compliance_median": float(np.median(away)),
            "compliance_worst": float(np.max(away))}


ENGINE_MARKERS = {"MuJoCo": "*", "Drake": "P"}
"""The engines' points in the figure, by the start of their row's formulation."""


def mujoco_row(op) -> dict | None:
    """MuJoCo's answer at its default softness as a row (``None`` where MuJoCo is not
    installed or cannot express the scene): the instants after it settled.
    """
    try:
        from cardan_forces.driveline import engine_mujoco

        found = engine_mujoco.run(op, engine_mujoco.Softness(label="default"))
    except Exception:  # an optional engine: absent or unable, the study goes on
        return None
    return _engine_row(op, "MuJoCo (default softness)", found)


def drake_row(op) -> dict | None:
    """Drake's answer at its reference step as a row (``None`` where Drake is not
    installed or cannot express the scene): the instants after it settled.
    """
    try:
        from cardan_forces.driveline import engine_drake

        from .engine import DRAKE_SETTINGS
        found = engine_drake.run(op, DRAKE_SETTINGS[0])
    except Exception:  # an optional engine: absent or unable, the study goes on
        return None
    return _engine_row(op, "Drake (SAP, step 0.25 ms)", found)


def _engine_row(op, label: str, found) -> dict | None:
    """An engine run's row (:func:`mujoco_row`), with its wall time per simulated second."""
    from .engine import settle_s

    keep = op.t >= settle_s({"default": found})
    if not keep.any() or tuple(found.names) != tuple(op.names):
        return None
    residuals = fbatch.least_norm_batch(op, SELECTION).checks.residuals(found.forces)
    primal = np.max(list(residuals.values()), axis=0)[keep]
    member = solve_batch(fbatch.least_norm_batch(op, MEMBER), "numpy-batched").x[keep]
    span = float(op.t[-1] - op.t[0])
    return {**_measures(op.scene.name, label, float("nan"), found.forces[keep], primal,
                        member, found.wall_s / len(op.t), float("nan"), float("nan")),
            "wall_s_per_simulated_s": found.wall_s / span if span > 0 else float("nan")}


def write(rows: list[dict], folder: Path, formats=("png",)) -> list[Path]:
    """The CSV, the markdown section and the figure of ``rows`` into ``folder``."""
    folder.mkdir(parents=True, exist_ok=True)
    write_csv(folder / "regularization.csv", rows, COLUMNS)  # undefined: an empty cell
    files.write_text(folder / "regularization.md", "\n".join(markdown(rows)) + "\n")
    return [folder / "regularization.csv", folder / "regularization.md",
            *draw(rows, folder / "regularization", formats)]


def markdown(rows: list[dict]) -> list[str]:
    """The section for the bench report: what was measured and the table."""
    lines = ["## What regularization costs: the engines' softened answer", "",
             "The `newton` family's `soften = R`: the equilibrium held by a penalty, as "
             "MuJoCo and SAP soften their constraints (`solvers/newton_.py`). Rigid set: "
             "the package's worst residual over `||b||`; compliance member: "
             "`||f - f_c|| / ||f_c||` against `numpy-batched`'s exact answer. Time: "
             "the batched solve per instant (fastest of "
             f"{REPEATS}); an engine's: its simulation's wall time per instant read.", "",
             "| scene | formulation | R | time (us) | Newton steps | solved | rigid set "
             "(median / worst) | compliance member (median / worst) |",
             "|---|---|---|---|---|---|---|---|"]
    lines += [_table_row(r) for r in rows]
    for name in ENGINE_MARKERS:
        engine = {r["scene"] for r in rows if r["formulation"].startswith(name)}
        without = sorted({r["scene"] for r in rows} - engine)
        if without:
            lines += ["", f"No {name} point for {', '.join(without)}: {name} is not installed "
                      "or cannot express the scene (a quasi-static one: the engine integrates "
                      "dynamics)."]
    return lines + _engine_cost_lines(rows)


def _engine_cost_lines(rows: list[dict]) -> list[str]:
    """The engines side by side: wall time per simulated second and distance from the
    rigid set, per scene (nothing where no engine ran).
    """
    engines = [r for r in rows if r["formulation"].startswith(tuple(ENGINE_MARKERS))]
    if not engines:
        return []
    lines = ["", "### The engines side by side (one run each)", "",
             "| engine | scene | wall s per simulated s | rigid set (median / worst) |",
             "|---|---|---|---|"]
    for r in engines:
        lines.append(f"| {r['formulation']} | {r['scene']} | "
                     f"{number_text(r['wall_s_per_simulated_s'], '.3g')} | "
                     f"{number_text(r['rigid_median'], '.1e')} / "
                     f"{number_text(r['rigid_worst'], '.1e')} |")
    return lines


def _table_row(r: dict) -> str:
    """One row of the section's table; an undefined number (MuJoCo's softening and
    steps, a measure of no answer) shows as ``-``.
    """
    cells = [r["scene"], r["formulation"], number_text(r["R"], "g"),
             number_text(r["time_us"], ".1f"), number_text(r["iterations"], "g"),
             number_text(r["solved_share"], ".1%"),
             *(f"{number_text(r[median], '.1e')} / {number_text(r[worst], '.1e')}"
               for median, worst in (COLUMNS[-5:-3], COLUMNS[-3:-1]))]
    return f"| {' | '.join(cells)} |"


PANELS = (("rigid_median", "(a) distance from the rigid set"),
          ("compliance_median", "(b) distance from the compliance member"))
"""The figure's panels: the measure drawn and the panel's title."""
RIGID_LABEL = "R = 0: the rigid answer"
ZERO_LABEL = "distance 0 (the arrow: below the log axis)"
"""Legend labels of the rigid answers' marks and of a distance of exactly 0."""


def _down_arrow():
    """A marker whose tip is the point it marks, pointing down: on a panel's lower edge,
    a distance of 0, which a log axis cannot show.
    """
    from matplotlib.path import Path as Shape

    return Shape([(0.0, 0.0), (1.0, 1.6), (-1.0, 1.6), (0.0, 0.0)],
                 [Shape.MOVETO, Shape.LINETO, Shape.LINETO, Shape.CLOSEPOLY])


def draw(rows: list[dict], stem: Path, formats=("png",)) -> list[Path]:
    """Two panels against the time per instant, a column each: distance from the rigid
    set and from the compliance member, one curve per scene and formulation (its points
    the softenings, the rigid answer ``R = 0`` marked), MuJoCo a star and Drake a plus;
    a distance of exactly 0 as an arrow on the panel's lower edge. In the print style
    (:mod:`~cardan_forces.experiments.images`), one legend under the panels.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    with images.styled():
        fig, axes = plt.subplots(1, 2, figsize=(images.PAGE_IN[0], 3.9))
        handles = {}
        for ax, (key, title) in zip(axes, PANELS):
            handles.update(_panel(ax, rows, key, title))
        fig.suptitle(images.typeset("Softened (R from 1e-1 to 0) against rigid: accuracy "
                                    "and time"))
        fig.legend(handles.values(), handles.keys(), loc="lower center", ncol=3)
        fig.canvas.draw()
        below = fig.legends[0].get_window_extent().height / fig.dpi + 0.05
        fig.tight_layout(rect=(0, below / fig.get_figheight(), 1, 1), pad=0.3, w_pad=2.0)
        paths = save(fig, stem, formats)
    plt.close(fig)
    return paths


def _panel(ax, rows: list[dict], key: str, title: str) -> dict:
    """One panel of :func:`draw`: ``key`` of each curve against its time; its legend
    handles by label.
    """
    handles, rigid, zeros = {}, [], []
    values = np.array([r[key] for r in rows], float)
    shown = values[np.isfinite(values) & (values > 0)]
    low, high = (10.0 ** v for v in images.limits([np.log10(shown)]))
    for (scene, formulation), group in _curves(rows).items():
        label = f"{scene}: {formulation}"
        marker = next((m for name, m in ENGINE_MARKERS.items()
                       if formulation.startswith(name)), None)
        star = marker is not None
        x = np.array([r["time_us"] for r in group], float)
        y = np.array([r[key] for r in group], float)
        handles[label], = ax.plot(x, np.where(y > 0, y, np.nan), marker=marker or "o",
                                  ms=8 if star else 3.5, ls="none" if star else "-",
                                  zorder=3 if star else 2, label=label)
        rigid += [(xi, yi) for r, xi, yi in zip(group, x, y) if r["R"] == 0.0 and yi > 0]
        zeros += [xi for xi, yi in zip(x, y) if yi == 0.0]
    if rigid:
        handles[RIGID_LABEL], = ax.plot(*zip(*rigid), ls="none", marker="s", ms=7, mfc="none",
                                        mec="k", mew=0.8, zorder=4, label=RIGID_LABEL)
    if zeros:
        handles[ZERO_LABEL], = ax.plot(zeros, [low] * len(zeros), ls="none", ms=10,
                                       marker=_down_arrow(), color="0.3", clip_on=False,
                                       zorder=4, label=ZERO_LABEL)
    ax.set(xscale="log", yscale="log", ylim=(low, high))
    ax.set_title(title, loc="left")
    ax.set_xlabel("time per instant [\u00b5s]")
    ax.set_ylabel("median relative distance [-]")
    ax.grid(True, which="major")
    return handles


def _curves(rows: list[dict]) -> dict:
    out: dict = {}
    for r in rows:
        out.setdefault((r["scene"], r["formulation"]), []).append(r)
    return out


def study(folder: Path, scenes=SCENES, instants: int = INSTANTS, formats=("png",),
          with_engines: bool = True) -> list[Path]:
    """The study on ``scenes``, written into ``folder``; the paths written."""
    rows = []
    for name in scenes:
        op = operator(name, instants)
        rows += measure(op)
        found = [mujoco_row(op), drake_row(op)] if with_engines else []
        rows += [r for r in found if r is not None]
    return write(rows, Path(folder), formats)


def main(argv=None) -> int:
    """``python -m cardan_forces.experiments.regularization [--out DIR]``."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=files.folder, default="results/bench", help="output folder")
    parser.add_argument("--instants", type=int, default=INSTANTS)
    args = parser.parse_args(argv)
    for path in study(Path(args.out), instants=args.instants):
        print(path)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
