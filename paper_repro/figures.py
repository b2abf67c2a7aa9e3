"""The paper's figures (Wang & Qi 2017, Figs. 11-15), each a CSV and images drawn from it.

Each ``figNN`` function writes ``<stem>.csv`` (first column ``t`` in s, the others named
by quantity and, where several methods are compared, by method) and one image per format
asked for (``png``, ``svg``, ``pdf``) into a folder, and returns the CSV's path. The
images are always redrawn from the CSV.

How they are drawn (:func:`_draw_panel`):

- the rigid-model methods on top, each its own colour and dash; the paper's method is
  labelled as computed here, and ``min_max`` with why it is no physical selection;
- the penalty simulation as a light raw line under a bold smoothed line: forces as their
  moving average over :data:`SMOOTH_S` (column ``..._penalty_avg``), speeds by a cubic
  Savitzky-Golay filter over :data:`SPEED_SMOOTH_S` (``..._penalty_smooth``), which keeps
  the intermediate shaft's twice-per-revolution fluctuation (period ~0.2 s) that a
  moving average over the same window flattens;
- the y axis holds every bold curve (the rigid methods and the smoothed penalty) with a
  margin; only the raw penalty line may leave it, and the panel then says so with its
  range;
- behind them the rigid solution set (``..._set_min``, ``..._set_max``): shaded where
  both bounds are finite; where a side is open, the finite bound as a dashed line and a
  hatched shade from it to the axis edge (the whole panel when both sides are open); the
  panel says which sides are open and where a bound out of view lies.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from cardan_forces.driveline.dynamics import Motion  # noqa: E402
from cardan_forces.driveline.equilibrium import Operator  # noqa: E402
from cardan_forces.experiments.images import save  # noqa: E402
from scipy.ndimage import uniform_filter1d  # noqa: E402
from scipy.signal import savgol_filter  # noqa: E402

SMOOTH_S = 0.1
"""Moving-average window (s) for the penalty simulation's forces: the released line
rattles in its clearances, the rigid model does not."""
SPEED_SMOOTH_S = 0.1
"""Savitzky-Golay window (s, cubic) for the penalty simulation's speeds: on ``paper`` it
keeps the intermediate shaft's peaks (14.94 vs the rigid 14.98 rad/s after 4 s, where a
0.1 s moving average gives 14.33) while taking out the rattle."""
PENALTY = "penalty"
"""The method name of the penalty-contact simulation in histories and columns."""
METHOD_LABELS = {
    "paper": "the paper's method (as computed here; end faces at the rim, eqs. 33-36)",
    "min_max": "min_max (comparison only: both end faces of a pair may push)",
}
"""Legend labels of methods whose bare name would mislead: ``paper`` is this package's
run of the paper's method, not data from the paper, and it puts the end-face forces at
the rim (with their moments), so its forces may leave the set drawn (of forces on the
axis); ``min_max`` bounds the largest force but does not impose the end faces'
complementarity (eqs. 39, 46), so its curve is no physical selection."""
SET_COLOUR = "0.55"


def method_label(method: str) -> str:
    """The legend label of ``method`` (its name unless :data:`METHOD_LABELS` says more)."""
    return METHOD_LABELS.get(method, method)


def _window(t: np.ndarray, window_s: float) -> int:
    """An odd number of instants spanning about ``window_s`` (so the window is centred)."""
    return 2 * int(round(0.5 * window_s / np.median(np.diff(t)))) + 1 if len(t) > 1 else 1


def moving_average(values: np.ndarray, t: np.ndarray, window_s: float = SMOOTH_S) -> np.ndarray:
    """Centred moving average over ``window_s`` along the first axis (instants ``t``)."""
    return uniform_filter1d(np.asarray(values, float), size=_window(t, window_s), axis=0,
                            mode="nearest")


def smooth_speed(values: np.ndarray, t: np.ndarray, window_s: float = SPEED_SMOOTH_S
                 ) -> np.ndarray:
    """Cubic Savitzky-Golay smoothing over ``window_s`` along the first axis: it fits a
    cubic in each window, so a fluctuation slower than the window passes (a moving
    average over the same window takes a third off a 0.2 s period).
    """
    size = _window(t, window_s)
    values = np.asarray(values, float)
    if size <= 3 or len(values) < size:
        return values.copy()
    return savgol_filter(values, size, 3, axis=0, mode="interp")


def write_csv(path: Path, columns: dict[str, np.ndarray]) -> Path:
    """Write equal-length columns with a header row; full double precision."""
    path.parent.mkdir(parents=True, exist_ok=True)
    data = np.column_stack([np.asarray(v, float) for v in columns.values()])
    np.savetxt(path, data, delimiter=",", header=",".join(columns), comments="", fmt="%.10g")
    return path


def read_csv(path: Path) -> dict[str, np.ndarray]:
    """Read a CSV written by :func:`write_csv` back into named columns."""
    data = np.genfromtxt(path, delimiter=",", names=True, deletechars="")
    return {name: data[name] for name in data.dtype.names}


def _with_smoothed(columns: dict[str, np.ndarray], t: np.ndarray, speeds: bool = False
                   ) -> dict[str, np.ndarray]:
    """Add the smoothed curve after every ``..._penalty`` column: ``<name>_avg`` (forces,
    :func:`moving_average`) or ``<name>_smooth`` (speeds, :func:`smooth_speed`).
    """
    out = {}
    for name, values in columns.items():
        out[name] = values
        if name.endswith(f"_{PENALTY}"):
            out[f"{name}{_SMOOTHED[speeds]}"] = (smooth_speed if speeds else moving_average)(
                values, t)
    return out


_SMOOTHED = {False: "_avg", True: "_smooth"}
_SMOOTH_LABEL = {False: f"penalty ({SMOOTH_S:g} s moving average)",
                 True: f"penalty (cubic Savitzky-Golay over {SPEED_SMOOTH_S:g} s)"}


@dataclass(frozen=True)
class Panel:
    """One panel: the columns of ``quantity``. ``methods``: the rigid-model curves, the
    columns ``quantity_<method>`` (``""``: the column ``quantity`` itself, the rigid
    model's); the penalty's ``quantity_penalty`` (raw) and its smoothed column where
    present; with ``sets``, ``quantity_set_min/max`` as the rigid solution set.
    """

    title: str
    quantity: str
    ylabel: str
    methods: tuple[str, ...] = ()
    sets: bool = False
    zero_line: bool = False
    labels: tuple[tuple[str, str], ...] = ()
    """Legend labels of ``methods`` as ``(method, label)`` pairs, where not
    :func:`method_label`'s."""


def fig11(motion: Motion, out: Path, penalty_omega: np.ndarray | None = None,
          formats=("png",)) -> Path:
    """Fig. 11: angular velocities of the input and output shafts (rad/s); with
    ``penalty_omega`` (shafts, T) the penalty simulation's beside the rigid model's, and
    a panel per shaft of the difference penalty - rigid, where the agreement is read.
    """
    columns = {"t": motion.t, "omega_input": motion.omega[0], "omega_output": motion.omega[-1]}
    panels = [Panel(f"({p}) {name} shaft", f"omega_{name}", "angular velocity [rad/s]", ("",))
              for p, name in (("a", "input"), ("b", "output"))]
    if penalty_omega is not None:
        columns |= {"omega_input_penalty": penalty_omega[0],
                    "omega_output_penalty": penalty_omega[-1],
                    "domega_input_penalty": penalty_omega[0] - motion.omega[0],
                    "domega_output_penalty": penalty_omega[-1] - motion.omega[-1]}
        panels += [Panel(f"({p}) {name} shaft: penalty - rigid", f"domega_{name}",
                         "difference [rad/s]", zero_line=True)
                   for p, name in (("c", "input"), ("d", "output"))]
    csv = write_csv(Path(out) / "fig11.csv", _with_smoothed(columns, motion.t, speeds=True))
    _plot_grid(csv, panels, f"Fig. 11: input and output angular velocity ({motion.scene.name})",
               ncols=2, formats=formats)
    return csv


def fig12(motion: Motion, out: Path, penalty_omega: np.ndarray | None = None,
          formats=("png",)) -> Path:
    """Fig. 12: angular velocity of the intermediate shaft (rad/s), rigid and penalty,
    and with the penalty a panel of the difference penalty - rigid.
    """
    columns = {"t": motion.t, "omega_intermediate": motion.omega[1]}
    name = motion.scene.shafts[1].name
    panels = [Panel(f"(a) {name} shaft (the first after joint 1)", "omega_intermediate",
                    "angular velocity [rad/s]", ("",))]
    if penalty_omega is not None:
        columns["omega_intermediate_penalty"] = penalty_omega[1]
        columns["domega_intermediate_penalty"] = penalty_omega[1] - motion.omega[1]
        panels.append(Panel(f"(b) {name} shaft: penalty - rigid", "domega_intermediate",
                            "difference [rad/s]", zero_line=True))
    csv = write_csv(Path(out) / "fig12.csv", _with_smoothed(columns, motion.t, speeds=True))
    _plot_grid(csv, panels,
               f"Fig. 12: intermediate shaft angular velocity ({motion.scene.name})", ncols=1,
               formats=formats)
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


def _set_columns(columns: dict, bounds: dict[str, tuple[np.ndarray, np.ndarray]]) -> dict:
    for q, (low, high) in bounds.items():
        columns[f"{q}_set_min"], columns[f"{q}_set_max"] = low, high
    return columns


def fig13(op: Operator, histories: dict[str, np.ndarray],
          bounds: dict[str, tuple[np.ndarray, np.ndarray]], out: Path, formats=("png",)) -> Path:
    """Fig. 13: the eight contact forces F1-F8 of joint 1 (N), one column per method
    (forces in the operator's columns at its instants), with the rigid solution set's
    interval of each (``bounds``: label -> (low, high), NaN where not computed, inf where
    unbounded).
    """
    t, scene_name = op.t, op.scene.name
    columns = {"t": t}
    for method, forces in histories.items():
        for label, values in joint_magnitudes(op, forces).items():
            columns[f"{label}_{method}"] = values
    csv = write_csv(Path(out) / "fig13.csv", _with_smoothed(_set_columns(columns, bounds), t))
    links = op.joint_contacts(0)
    rigid = tuple(m for m in histories if m != PENALTY)
    panels = [Panel(f"({'abcdefgh'[k]}) {label}, {_kind_word(links[label].kind)}", label,
                    "force [N]", rigid, sets=label in bounds)
              for k, label in enumerate(sorted(links))]
    _plot_grid(csv, panels,
               f"Fig. 13: contact forces of joint 1 on its cross-pin ({scene_name})", ncols=2,
               formats=formats)
    return csv


def _kind_word(kind: str) -> str:
    return {"trunnion-radial": "radial", "end-face": "axial (end face)"}.get(kind, kind)


def fig14(op: Operator, histories: dict[str, np.ndarray],
          bounds: dict[str, tuple[np.ndarray, np.ndarray]], out: Path,
          number: int = 14, stem: str | None = None, subtitle: str = "",
          formats=("png",)) -> Path:
    """Fig. 14 (15 with horizontal gravity): the input shaft's bearing loads per method,
    with the rigid solution set's interval (``bounds``: quantity -> (low, high), NaN where
    not computed, inf where unbounded). ``stem``: the files' name (default ``figNN``).
    """
    t, scene_name = op.t, op.scene.name
    columns = {"t": t}
    for method, forces in histories.items():
        for q, values in bearing_loads(op, forces).items():
            columns[f"{q}_{method}"] = values
    csv = write_csv(Path(out) / f"{stem or f'fig{number}'}.csv",
                    _with_smoothed(_set_columns(columns, bounds), t))
    rigid = tuple(m for m in histories if m != PENALTY)
    _plot_grid(csv, [Panel(title, q, "force [N]", rigid, sets=q in bounds)
                     for q, title in _bearing_titles(op).items()],
               f"Fig. {number}: input shaft bearing loads ({scene_name}{subtitle})", ncols=1,
               formats=formats)
    return csv


def _bearing_titles(op: Operator) -> dict[str, str]:
    """Panel titles of the first shaft's bearing loads (:func:`bearing_loads`' keys)."""
    labels = [c.label for c in op.bearings(0)]
    titles = {f"{b}_radial": f"({'abcdefgh'[k]}) bearing '{b}', radial"
              for k, b in enumerate(labels)}
    titles["axial"] = f"({'abcdefgh'[len(labels)]}) axial (sum of its bearings)"
    return titles


def engine_figure(op: Operator, runs: dict[str, np.ndarray],
                  bounds: dict[str, tuple[np.ndarray, np.ndarray]], out: Path,
                  formats=("png",)) -> Path:
    """``engine``: MuJoCo's input shaft bearing loads (N, as Fig. 14's quantities) over
    time, one curve per softness setting (``runs``: setting label -> forces (T, n) in
    the operator's columns), over the rigid solution set's interval (``bounds`` as in
    :func:`fig14`). Columns ``<quantity>_engine<k>`` in the order of ``runs``.
    """
    columns = {"t": op.t}
    keys = {label: f"engine{k}" for k, label in enumerate(runs)}
    for label, forces in runs.items():
        for q, values in bearing_loads(op, forces).items():
            columns[f"{q}_{keys[label]}"] = values
    csv = write_csv(Path(out) / "engine.csv", _set_columns(columns, bounds))
    labels = tuple((key, f"MuJoCo, {label}") for label, key in keys.items())
    _plot_grid(csv, [Panel(title, q, "force [N]", tuple(keys.values()), sets=q in bounds,
                           labels=labels) for q, title in _bearing_titles(op).items()],
               f"MuJoCo's input shaft bearing loads over the rigid set ({op.scene.name})",
               ncols=1, formats=formats)
    return csv


def _plot_grid(csv: Path, panels: list[Panel], title: str, ncols: int,
               formats=("png",)) -> list[Path]:
    """Draw ``panels`` from the CSV in a grid with one shared legend below; write one
    image per format beside the CSV and return their paths.
    """
    cols = read_csv(csv)
    nrows = -(-len(panels) // ncols)
    width = 8.0 if ncols == 1 else 6.5 * ncols
    fig, axes = plt.subplots(nrows, ncols, figsize=(width, 2.6 * nrows + 0.9), squeeze=False)
    handles: dict[str, object] = {}
    for ax, panel in zip(axes.ravel(), panels):
        handles.update(_draw_panel(ax, cols, panel))
    for ax in axes.ravel()[len(panels):]:
        ax.axis("off")
    fig.suptitle(title, fontsize=11)
    ncol = 2 if ncols == 1 else 3
    fig.legend(list(handles.values()), list(handles), loc="lower center", ncol=ncol,
               fontsize=7.5, frameon=False)
    rows = -(-len(handles) // ncol)
    fig.tight_layout(rect=(0, (0.12 + 0.2 * rows) / fig.get_figheight(), 1, 1))
    paths = save(fig, csv.with_suffix(""), formats, dpi=110)
    plt.close(fig)
    return paths


def _draw_panel(ax, cols: dict[str, np.ndarray], panel: Panel) -> dict:
    """One panel (:class:`Panel`) on ``ax``; returns its legend handles by label. The y
    range holds every bold curve: the rigid methods and the smoothed penalty.
    """
    t, q, handles = cols["t"], panel.quantity, {}
    bold = []
    for k, method in enumerate(panel.methods):
        values = cols[f"{q}_{method}" if method else q]
        bold.append(values)
        label = dict(panel.labels).get(method) or (method_label(method) if method
                                                    else "rigid model")
        handles[label], = ax.plot(t, values, lw=1.3, color=f"C{k}", zorder=4,
                                  ls=("-", "--", "-.", ":")[k % 4], label=label)
    raw = cols.get(f"{q}_{PENALTY}")
    smooth_key = next((f"{q}_{PENALTY}{s}" for s in _SMOOTHED.values()
                       if f"{q}_{PENALTY}{s}" in cols), None)
    if smooth_key is not None:
        bold.append(cols[smooth_key])
    low, high = _limits(bold or [raw])
    notes = []
    if raw is not None:
        handles["penalty (raw)"], = ax.plot(t, raw, lw=0.5, color="0.45", alpha=0.45,
                                            zorder=1, label="penalty (raw)")
        notes.append(_clip_note(raw, low, high))
    if smooth_key is not None:
        label = _SMOOTH_LABEL[smooth_key.endswith("_smooth")]
        handles[label], = ax.plot(t, cols[smooth_key], lw=2.2, color="C4", zorder=3,
                                  label=label)
    if panel.sets:
        drawn, note = _draw_set(ax, t, cols[f"{q}_set_min"], cols[f"{q}_set_max"], low, high)
        handles.update(drawn)
        notes.insert(0, note)
    ax.set_title("\n".join(n for n in notes if n), fontsize=6.5, loc="right", color="0.25")
    if panel.zero_line:
        ax.axhline(0.0, color="0.2", lw=0.6, zorder=2)
    ax.set_ylim(low, high)
    ax.set_title(panel.title, fontsize=9, loc="left")
    ax.set_xlabel("time t [s]")
    ax.set_ylabel(panel.ylabel)
    ax.grid(alpha=0.3)
    return handles


def _limits(curves: list[np.ndarray]) -> tuple[float, float]:
    """The y range of ``curves`` with a margin of 15 % of the range (at least 5 % of the
    largest magnitude, so a flat line is not drawn as noise).
    """
    finite = np.concatenate([c[np.isfinite(c)] for c in curves if c is not None]
                            or [np.zeros(1)])
    finite = finite if finite.size else np.zeros(1)
    lo, hi = float(finite.min()), float(finite.max())
    margin = max(0.15 * (hi - lo), 0.05 * max(abs(lo), abs(hi)), 1e-9)
    return lo - margin, hi + margin


def _clip_note(raw: np.ndarray, low: float, high: float) -> str:
    """What the panel says when the raw penalty line leaves the drawn range: its range."""
    ok = np.isfinite(raw)
    if not ok.any() or low <= raw[ok].min() and raw[ok].max() <= high:
        return ""
    lo, hi = raw[ok].min(), raw[ok].max()
    tiny = 1e-9 * max(abs(lo), abs(hi))  # round-off about zero prints as 0
    return (f"raw penalty clipped (impacts): it spans {lo if abs(lo) > tiny else 0.0:.4g} "
            f"to {hi:.4g}")


SET_LABEL = "rigid solution set (both bounds finite)"
OPEN_LABEL = "rigid solution set, open side (hatched to the axis edge)"
BOUND_LABEL = "finite bound of an open rigid set"


def _draw_set(ax, t, set_min, set_max, low, high) -> tuple[dict, str]:
    """Draw the rigid solution set behind the curves: shaded (with its edges, so a set of
    one value still shows) where both bounds are finite; hatched from the finite bound
    (or the axis edge) to the axis edge where a side is open, the finite bound dashed.
    Returns the legend handles and the panel's note: which sides are open and where a
    bound out of view lies.
    """
    checked = ~(np.isnan(set_min) | np.isnan(set_max))
    if not checked.any():
        return {}, ""
    lo, hi, tc = set_min[checked], set_max[checked], t[checked]
    both = np.isfinite(lo) & np.isfinite(hi)
    handles = {}
    if both.any():
        lo_b, hi_b = np.where(both, lo, np.nan), np.where(both, hi, np.nan)
        handles[SET_LABEL] = ax.fill_between(tc, lo_b, hi_b, color=SET_COLOUR, alpha=0.35,
                                             lw=0, zorder=0)
        ax.plot(tc, lo_b, tc, hi_b, color=SET_COLOUR, lw=0.8, zorder=0.5)
    if (~both).any():
        edge_lo = np.where(~both, np.where(np.isfinite(lo), lo, low), np.nan)
        edge_hi = np.where(~both, np.where(np.isfinite(hi), hi, high), np.nan)
        handles[OPEN_LABEL] = ax.fill_between(tc, edge_lo, edge_hi, facecolor="none",
                                              hatch="///", edgecolor="0.8", lw=0, zorder=0)
    notes = []
    for bound, word in ((lo, "lower"), (hi, "upper")):
        finite = np.isfinite(bound) & ~both
        if not finite.any():
            continue
        handles[BOUND_LABEL], = ax.plot(tc, np.where(finite, bound, np.nan), ls="--", lw=1.2,
                                        color="0.25", zorder=2)
        inside = finite & (bound >= low) & (bound <= high)
        where = ("dashed" if inside.all() else "out of view" if not inside.any()
                 else "dashed where in view")
        notes.append(f"{word} bound {bound[finite].min():.3g} to {bound[finite].max():.3g} "
                     f"N, {where}")
    above, below = np.mean(~np.isfinite(hi)), np.mean(~np.isfinite(lo))
    single = both & (hi - lo <= 1e-6 * (high - low))
    if single.any():  # a determinate quantity: the band is a line under the curves
        notes.insert(0, f"one value (determinate) at {single.sum()} of {checked.sum()} "
                        "instants")
    if not (above or below):
        return handles, "rigid set: " + "; ".join(notes) if notes else ""
    side = "above and below" if above and below else "above" if above else "below"
    return handles, (f"rigid set open {side} ({100 * max(above, below):.0f} % of "
                     f"{checked.sum()} instants)" + "".join(f"; {n}" for n in notes))
