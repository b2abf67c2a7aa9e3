"""The paper's figures (Wang & Qi 2017, Figs. 11-15), each a CSV and a PNG drawn from it.

Each ``figNN`` function writes ``figNN.csv`` (first column ``t`` in s, the others named
by quantity and, where several methods are compared, by method) and ``figNN.png``
into a folder, and returns the CSV's path. The PNG is always redrawn from the CSV.

How they are drawn: the rigid-model methods first and on top, and the y axis fitted to
them with a margin, since their differences of tens of newtons are what the figures
compare; the penalty simulation as a light raw line (its impact peaks clipped, the
ranges of raw and average written in the panel where they leave it) under its moving
average over :data:`SMOOTH_S` (column ``..._penalty_avg``). The rigid solution set is
shaded only where it is bounded on both sides; where it is not, the
panel says so (and draws a finite bound as a dashed line).
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from cardan_forces.driveline.dynamics import Motion  # noqa: E402
from cardan_forces.driveline.equilibrium import Operator  # noqa: E402
from scipy.ndimage import uniform_filter1d  # noqa: E402

SMOOTH_S = 0.1
"""Moving-average window (s) for the penalty simulation: the released line rattles in
its clearances, the rigid model does not."""
PENALTY = "penalty"
"""The method name of the penalty-contact simulation in histories and columns."""


def moving_average(values: np.ndarray, t: np.ndarray, window_s: float = SMOOTH_S) -> np.ndarray:
    """Centred moving average over ``window_s`` along the first axis (instants ``t``; an
    odd number of them, so the window is centred).
    """
    size = 2 * int(round(0.5 * window_s / np.median(np.diff(t)))) + 1 if len(t) > 1 else 1
    return uniform_filter1d(np.asarray(values, float), size=size, axis=0, mode="nearest")


def write_csv(path: Path, columns: dict[str, np.ndarray]) -> Path:
    """Write equal-length columns with a header row; full double precision."""
    path.parent.mkdir(parents=True, exist_ok=True)
    data = np.column_stack([np.asarray(v, float) for v in columns.values()])
    np.savetxt(path, data, delimiter=",", header=",".join(columns), comments="", fmt="%.10g")
    return path


def read_csv(path: Path) -> dict[str, np.ndarray]:
    """Read a CSV written by :func:`write_csv` back into named columns."""
    data = np.genfromtxt(path, delimiter=",", names=True)
    return {name: data[name] for name in data.dtype.names}


def _with_average(columns: dict[str, np.ndarray], t: np.ndarray) -> dict[str, np.ndarray]:
    """Add ``<name>_avg`` (moving average) after every ``..._penalty`` column."""
    out = {}
    for name, values in columns.items():
        out[name] = values
        if name.endswith(f"_{PENALTY}"):
            out[f"{name}_avg"] = moving_average(values, t)
    return out


def fig11(motion: Motion, out: Path, penalty_omega: np.ndarray | None = None) -> Path:
    """Fig. 11: angular velocities of the input and output shafts (rad/s); with
    ``penalty_omega`` (shafts, T) the penalty simulation's beside the rigid model's.
    """
    columns = {"t": motion.t, "omega_input": motion.omega[0], "omega_output": motion.omega[-1]}
    if penalty_omega is not None:
        columns |= {"omega_input_penalty": penalty_omega[0],
                    "omega_output_penalty": penalty_omega[-1]}
    csv = write_csv(Path(out) / "fig11.csv", _with_average(columns, motion.t))
    _plot_grid(csv, [(f"({p}) {name} shaft", f"omega_{name}", {"": "rigid model"})
                     for p, name in (("a", "input"), ("b", "output"))],
               "angular velocity [rad/s]",
               f"Fig. 11: input and output angular velocity ({motion.scene.name})", ncols=1)
    return csv


def fig12(motion: Motion, out: Path, penalty_omega: np.ndarray | None = None) -> Path:
    """Fig. 12: angular velocity of the intermediate shaft (rad/s), rigid and penalty."""
    columns = {"t": motion.t, "omega_intermediate": motion.omega[1]}
    if penalty_omega is not None:
        columns["omega_intermediate_penalty"] = penalty_omega[1]
    csv = write_csv(Path(out) / "fig12.csv", _with_average(columns, motion.t))
    _plot_grid(csv, [("intermediate shaft", "omega_intermediate", {"": "rigid model"})],
               "angular velocity [rad/s]",
               f"Fig. 12: intermediate shaft angular velocity ({motion.scene.name})", ncols=1)
    return csv


def joint_magnitudes(op: Operator, forces: np.ndarray, joint: int = 0) -> dict:
    """|F1| ... |F8| of joint ``joint`` (scene index) in N, from forces (T, n) in the
    operator's columns: a radial force as the length of its 2-vector, an end face's push
    as it is (:meth:`Operator.contact_magnitudes`).
    """
    links = op.joint_contacts(joint)
    magnitudes = op.contact_magnitudes(forces, ("trunnion-radial", "end-face"))
    return {label: magnitudes[links[label].name] for label in sorted(links)}


def bearing_loads(op: Operator, forces: np.ndarray, shaft: int = 0) -> dict:
    """The paper's Fig. 14 quantities (N) of shaft ``shaft``: per bearing
    ``<bearing>_radial``, the length of its load normal to the shaft's axis, and
    ``axial``, the sum of its bearings' loads along the axis (the paper merges them);
    in the shaft's own frame (:meth:`Operator.bearing_loads`).
    """
    loads = op.bearing_loads(forces, shaft).values()
    out = {f"{load.label}_radial": load.radial for load in loads}
    out["axial"] = sum(load.axial for load in loads)
    return out


def fig13(op: Operator, histories: dict[str, np.ndarray], out: Path) -> Path:
    """Fig. 13: the eight contact forces F1-F8 of joint 1 (N), one column per method
    (forces in the operator's columns at its instants).
    """
    t, scene_name = op.t, op.scene.name
    columns = {"t": t}
    for method, forces in histories.items():
        for label, values in joint_magnitudes(op, forces).items():
            columns[f"{label}_{method}"] = values
    csv = write_csv(Path(out) / "fig13.csv", _with_average(columns, t))
    titles = {1: "radial", 2: "radial", 3: "axial", 4: "axial", 5: "radial", 6: "radial",
              7: "axial", 8: "axial"}
    rigid = {m: m for m in histories if m != PENALTY}
    panels = [(f"({'abcdefgh'[k - 1]}) {titles[k]} contact force F{k}", f"F{k}", rigid)
              for k in range(1, 9)]
    _plot_grid(csv, panels, "force [N]",
               f"Fig. 13: contact forces of joint 1 on its cross-pin ({scene_name})", ncols=2)
    return csv


def fig14(op: Operator, histories: dict[str, np.ndarray],
          bounds: dict[str, tuple[np.ndarray, np.ndarray]], out: Path,
          number: int = 14) -> Path:
    """Fig. 14 (15 with horizontal gravity): the input shaft's bearing loads per method,
    with the rigid solution set's interval (``bounds``: quantity -> (low, high), NaN where
    not computed, inf where unbounded).
    """
    t, scene_name = op.t, op.scene.name
    columns = {"t": t}
    for method, forces in histories.items():
        for q, values in bearing_loads(op, forces).items():
            columns[f"{q}_{method}"] = values
    for q, (low, high) in bounds.items():
        columns[f"{q}_set_min"], columns[f"{q}_set_max"] = low, high
    csv = write_csv(Path(out) / f"fig{number}.csv", _with_average(columns, t))
    labels = {"far_radial": "(a) left (far) bearing, radial",
              "near_radial": "(b) right (near) bearing, radial",
              "axial": "(c) axial (sum of both bearings)"}
    rigid = {m: m for m in histories if m != PENALTY}
    _plot_grid(csv, [(labels[q], q, rigid) for q in labels], "force [N]",
               f"Fig. {number}: input shaft bearing loads ({scene_name})", ncols=1, sets=True)
    return csv


def _plot_grid(csv: Path, panels, ylabel: str, title: str, ncols: int,
               sets: bool = False) -> Path:
    """Panels from the CSV. A panel is ``(title, quantity, {suffix: label})``: the rigid
    columns ``quantity`` + suffix (``_method``, or none), then the penalty's
    ``quantity_penalty`` (raw, light) and ``quantity_penalty_avg`` where present; with
    ``sets``, the ``quantity_set_min/max`` columns as the rigid solution set.
    """
    cols = read_csv(csv)
    nrows = -(-len(panels) // ncols)
    fig, axes = plt.subplots(nrows, ncols, figsize=(6.5 * ncols, 2.5 * nrows + 0.6),
                             squeeze=False)
    handles: dict[str, object] = {}
    for ax, (panel_title, quantity, rigid) in zip(axes.ravel(), panels):
        t = cols["t"]
        rigid_values = []
        for k, (suffix, label) in enumerate(rigid.items()):
            values = cols[f"{quantity}_{suffix}" if suffix else quantity]
            rigid_values.append(values)
            handles[label], = ax.plot(t, values, lw=1.3, color=f"C{k}", zorder=4,
                                      ls=("-", "--", "-.", ":")[k % 4], label=label)
        raw, avg = cols.get(f"{quantity}_{PENALTY}"), cols.get(f"{quantity}_{PENALTY}_avg")
        low, high = _limits(rigid_values)
        if raw is not None:
            handles["penalty (raw)"], = ax.plot(t, raw, lw=0.5, color="0.45", alpha=0.45,
                                                zorder=1, label="penalty (raw)")
            handles[f"penalty ({SMOOTH_S:g} s average)"], = ax.plot(
                t, avg, lw=2.2, color="C4", zorder=3, label=f"penalty ({SMOOTH_S:g} s average)")
            _note_clipped(ax, {"raw": raw, "average": avg}, low, high)
        if sets:
            handles.update(_draw_set(ax, t, cols[f"{quantity}_set_min"],
                                     cols[f"{quantity}_set_max"], low, high))
        ax.set_ylim(low, high)
        ax.set_title(panel_title, fontsize=9)
        ax.set_xlabel("time t [s]")
        ax.set_ylabel(ylabel)
        ax.grid(alpha=0.3)
    for ax in axes.ravel()[len(panels):]:
        ax.axis("off")
    fig.suptitle(title, fontsize=11)
    fig.legend(list(handles.values()), list(handles), loc="lower center",
               ncol=min(len(handles), 4), fontsize=8, frameon=False)
    fig.tight_layout(rect=(0, 0.07 if len(handles) > 4 else 0.045, 1, 1))
    png = csv.with_suffix(".png")
    fig.savefig(png, dpi=110)
    plt.close(fig)
    return png


def _limits(curves: list[np.ndarray]) -> tuple[float, float]:
    """The y range of ``curves`` with a margin of 15 % of the range (at least 5 % of the
    largest magnitude, so a flat line is not drawn as noise).
    """
    finite = np.concatenate([c[np.isfinite(c)] for c in curves] or [np.zeros(1)])
    finite = finite if finite.size else np.zeros(1)
    lo, hi = float(finite.min()), float(finite.max())
    margin = max(0.15 * (hi - lo), 0.05 * max(abs(lo), abs(hi)), 1e-9)
    return lo - margin, hi + margin


def _note_clipped(ax, curves: dict[str, np.ndarray], low: float, high: float) -> None:
    """Write in the panel how far the penalty curves leave the drawn range."""
    notes = []
    for name, values in curves.items():
        ok = np.isfinite(values)
        if ok.any() and (values[ok].max() > high or values[ok].min() < low):
            lo, hi = values[ok].min(), values[ok].max()
            tiny = 1e-9 * max(abs(lo), abs(hi))  # round-off about zero prints as 0
            notes.append(f"{name} {lo if abs(lo) > tiny else 0.0:.4g} to {hi:.4g}")
    if notes:
        ax.text(0.995, 0.04, "penalty clipped: " + "; ".join(notes), transform=ax.transAxes,
                fontsize=7, ha="right", color="0.3",
                bbox=dict(boxstyle="round,pad=0.2", fc="white", ec="none", alpha=0.8))


def _draw_set(ax, t, set_min, set_max, low, high) -> dict:
    """Shade the rigid solution set where it is bounded on both sides; write where it is
    unbounded, drawing a finite bound as a dashed line. Returns legend handles.
    """
    checked = ~(np.isnan(set_min) | np.isnan(set_max))
    if not checked.any():
        return {}
    lo, hi, tc = set_min[checked], set_max[checked], t[checked]
    bounded = np.isfinite(lo) & np.isfinite(hi)
    handles = {}
    if bounded.any():
        handles["rigid solution set"] = ax.fill_between(
            tc, np.clip(np.where(bounded, lo, np.nan), low, high),
            np.clip(np.where(bounded, hi, np.nan), low, high), color="0.6", alpha=0.3, lw=0,
            zorder=0)
    notes = []
    for bound, finite, word in ((lo, np.isfinite(lo) & ~bounded, "below"),
                                (hi, np.isfinite(hi) & ~bounded, "above")):
        if not finite.any():
            continue
        notes.append(f"{'lower' if word == 'below' else 'upper'} bound "
                     f"{bound[finite].min():.3g} to {bound[finite].max():.3g} N")
        inside = finite & (bound >= low) & (bound <= high)
        if inside.any():
            notes[-1] += " (dashed)"
            handles["finite bound of the rigid set"], = ax.plot(
                tc, np.where(inside, bound, np.nan), ls="--", lw=1.0, color="0.35", zorder=2)
    above, below = np.mean(~np.isfinite(hi)), np.mean(~np.isfinite(lo))
    if above or below:
        side = ("above and below" if above and below else "above" if above else "below")
        text = (f"rigid set unbounded {side} at {100 * max(above, below):.0f} % of "
                f"{checked.sum()} instants" + "".join(f"; {n}" for n in notes))
        ax.text(0.005, 0.96, text, transform=ax.transAxes, fontsize=7.5, va="top",
                color="0.25", bbox=dict(boxstyle="round,pad=0.2", fc="white", ec="0.7",
                                        alpha=0.85))
    return handles
