"""``cardan report``: one scene's bearing and joint loads over time, with the rigid
solution set (DESIGN §4; any scene, its own names).

At ``--instants`` instants spread over the scene's window: every contact force
component of the operator, the member ``positive`` picks (least force, end faces
pushing only), the interval ``[min, max]`` over every rigid solution with end faces
>= 0 (two LPs per component that is not determinate, the band; a determinate one's
interval is its value), and whether the component is determinate.
Written as ``report.csv`` (long format), ``report.png`` (one panel per contact: a
bearing, a slip joint, a trunnion, an end face) and ``report.md`` (the determinacy
table and the named modes).
"""

from __future__ import annotations

import csv
import math
import sys
from pathlib import Path

import numpy as np
from cardan_forces.driveline.determinacy import determinacy
from cardan_forces.driveline.dynamics import simulate
from cardan_forces.driveline.equilibrium import Operator, build_operator
from cardan_forces.driveline.loading import load_scene
from cardan_forces.driveline.release import named_modes
from cardan_forces.experiments.environment import number_text
from cardan_forces.experiments.study import interval_history, solve_over_time

INSTANTS = 41
"""Instants of the report by default (each costs two LPs per component)."""

SELECTION = "positive"
"""The formulation drawn as lines, by the study layer's default backend."""


def histories(op: Operator, progress=None) -> dict[str, np.ndarray]:
    """``value``, ``min``, ``max`` (T, n; NaN where unbounded or not solved) and
    ``determinate`` (T, n) over the operator's instants (a determinate component's
    interval is its one value).
    """
    chosen = solve_over_time(op, SELECTION)
    say = None if progress is None else (lambda m: progress(f"report: {m}"))
    sets = interval_history(op, progress=say)
    return {"value": chosen.forces, "min": sets.min, "max": sets.max,
            "determinate": sets.determinate}


def write_csv(op: Operator, h: dict[str, np.ndarray], path: Path) -> None:
    """Long format, one row per component x instant; an empty cell where the answer
    is missing (not solved) or an end of the interval is unbounded.
    """
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["t_s", "component", "contact", "kind", f"{SELECTION}_N", "min_N", "max_N",
                    "determinate"])
        for c in op.contacts:
            for j in c.columns:
                for i, t in enumerate(op.t):
                    w.writerow([f"{t:.6g}", op.names[j], c.name, c.kind,
                                *(number_text(h[k][i, j], ".9g", "")
                                  for k in ("value", "min", "max")),
                                bool(h["determinate"][i, j])])


def write_png(op: Operator, h: dict[str, np.ndarray], path: Path) -> None:
    """One panel per contact: the solution set shaded where both its ends are finite, a
    finite end dashed where the other is not; an unbounded side is said in the title
    rather than shaded to the panel's edge.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    contacts = op.contacts
    cols = 4
    rows = math.ceil(len(contacts) / cols)
    fig, axes = plt.subplots(rows, cols, figsize=(4.2 * cols, 2.6 * rows), squeeze=False)
    for ax, c in zip(axes.ravel(), contacts):
        lines = [ax.plot(op.t, h["value"][:, j], lw=1.2,
                         label=op.names[j][len(c.name) + 1:] or "force")[0] for j in c.columns]
        bottom, top = ax.get_ylim()
        sides = set()
        for line, j in zip(lines, c.columns):
            lo, hi = h["min"][:, j], h["max"][:, j]
            finite_lo, finite_hi = np.isfinite(lo), np.isfinite(hi)
            sides |= {"below"} if not finite_lo.all() else set()
            sides |= {"above"} if not finite_hi.all() else set()
            both = finite_lo & finite_hi
            ax.fill_between(op.t, np.where(both, lo, np.nan), np.where(both, hi, np.nan),
                            color=line.get_color(), alpha=0.15, lw=0)
            for bound, finite in ((lo, finite_lo), (hi, finite_hi)):
                ax.plot(op.t, np.where(finite & ~both, bound, np.nan), ls="--", lw=0.8,
                        color=line.get_color())
        ax.set_ylim(bottom, top)
        words = " and ".join(sorted(sides, reverse=True))
        ax.set_title(f"{c.name} ({c.kind})" + (f", set unbounded {words}" if sides else ""),
                     fontsize=8)
        ax.tick_params(labelsize=7)
        ax.legend(fontsize=6)
    for ax in axes.ravel()[len(contacts):]:
        ax.set_visible(False)
    fig.suptitle(f"{op.scene.name}: {SELECTION} (lines) and the rigid solution set (bands), "
                 "N / N m against t (s)", fontsize=10)
    fig.tight_layout(rect=(0, 0, 1, 0.97))
    fig.savefig(path, dpi=100)
    plt.close(fig)


def write_md(op: Operator, h: dict[str, np.ndarray], modes, path: Path) -> None:
    det = determinacy(op, 0)
    lines = [f"# Loads of scene {op.scene.name}", "", op.scene.description, "",
             f"{len(op.t)} instants from {op.t[0]:g} to {op.t[-1]:g} s; rank {det.rank}, "
             f"nullity {det.nullity} at the first; `{SELECTION}` answer and the interval "
             "over all rigid solutions with end faces >= 0.", "",
             "| component | determinate (all instants) | largest interval width (N) |",
             "|---|---|---|"]
    width = np.nanmax(np.where(np.isfinite(h["max"] - h["min"]), h["max"] - h["min"], np.inf),
                      axis=0)
    for j, name in enumerate(op.names):
        lines.append(f"| {name} | {'yes' if h['determinate'][:, j].all() else 'no'} | "
                     f"{number_text(width[j], '.3g', 'unbounded')} |")
    lines += ["", "## Modes (null-space directions)", ""]
    lines += [f"- **{m.kind}**: {m.description}; release: {m.release}" for m in modes]
    path.write_text("\n".join(lines) + "\n")


def run_report(scene_spec: str, out: Path, instants: int = INSTANTS,
               progress=None) -> list[Path]:
    """Write ``report.csv``, ``report.png`` and ``report.md`` for one scene into ``out``."""
    scene = load_scene(scene_spec)
    t = np.linspace(scene.time.start_s, scene.time.stop_s, instants)
    motion = simulate(scene, t)
    op = build_operator(motion)
    h = histories(op, progress)
    out.mkdir(parents=True, exist_ok=True)
    paths = [out / "report.csv", out / "report.png", out / "report.md"]
    write_csv(op, h, paths[0])
    write_png(op, h, paths[1])
    write_md(op, h, named_modes(motion, 0, op), paths[2])
    return paths


def add_parser(subparsers) -> None:
    """Register ``cardan report``."""
    p = subparsers.add_parser("report", help="one scene's bearing and joint loads over time "
                              "with the rigid solution set (CSV, PNG, Markdown)")
    p.add_argument("scene", nargs="?", default="paper", help="built-in name or TOML path")
    p.add_argument("--out", default="results/report", help="output folder")
    p.add_argument("--instants", type=_count, default=INSTANTS,
                   help=f"instants over the scene's window (default {INSTANTS})")
    p.set_defaults(func=run)


def _count(text: str) -> int:
    import argparse

    try:
        value = int(text)
    except ValueError:
        value = 0
    if value < 2:
        raise argparse.ArgumentTypeError(f"expected a whole number >= 2, got {text!r}")
    return value


def run(args) -> int:
    """Write the report; the paths written on stdout, progress on stderr."""
    for path in run_report(args.scene, Path(args.out), args.instants,
                           progress=lambda m: print(m, file=sys.stderr, flush=True)):
        print(path)
    return 0
