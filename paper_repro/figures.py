"""The paper's figures (Wang & Qi 2017, Figs. 11-15), each a CSV and images drawn from it.

Each ``figNN`` function writes ``<stem>.csv`` (first column ``t`` in s, the others named
by quantity and, where several methods are compared, by method) and one image per format
asked for (``png``, ``svg``, ``pdf``) into a folder, and returns the CSV's path. The
images are always redrawn from the CSV (:mod:`cardan_forces.paper_repro.figures_draw`
says how).

The penalty simulation's curves are smoothed by a centred window of :data:`SMOOTH_S`:
forces by their moving average (column ``..._penalty_avg``), speeds by a cubic
Savitzky-Golay filter (``..._penalty_smooth``), which keeps the intermediate shaft's
twice-per-revolution fluctuation (period ~0.2 s) that a moving average over the same
window flattens. Where the centred window does not fit (within half a window of either
end of the run) the smoothed value is left out (NaN in the CSV, not drawn), never
filled with an average of a part window; the legend says so.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from cardan_forces.driveline.dynamics import Motion
from cardan_forces.driveline.equilibrium import Operator
from cardan_forces.experiments import files
from cardan_forces.formulations import FORMULATIONS
from scipy.ndimage import uniform_filter1d
from scipy.signal import savgol_filter

from .figures_draw import OPEN, PENALTY, SMOOTHED, Panel, plot_grid
from .figures_draw import read_csv as read_csv  # the figures' CSV reader, with write_csv

SMOOTH_S = 0.1
"""Moving-average window (s) for the penalty simulation's forces: the released line
rattles in its clearances, the rigid model does not."""
SPEED_SMOOTH_S = 0.1
"""Savitzky-Golay window (s, cubic) for the penalty simulation's speeds: on ``paper`` it
keeps the intermediate shaft's peaks (14.94 vs the rigid 14.98 rad/s after 4 s, where a
0.1 s moving average gives 14.33) while taking out the rattle."""
SMOOTH_LABELS = {
    SMOOTHED[False]: f"penalty, centred {SMOOTH_S:g} s moving average (none within "
                     f"{SMOOTH_S / 2:g} s of either end)",
    SMOOTHED[True]: f"penalty, cubic Savitzky-Golay over a centred {SPEED_SMOOTH_S:g} s "
                    f"(none within {SPEED_SMOOTH_S / 2:g} s of either end)"}
"""Legend labels of the smoothed penalty curves, by column suffix."""


def method_label(method: str) -> str:
    """The legend label of ``method``: its formulation record's (what it selects; e.g.
    ``paper`` is this package's run of the paper's method, not data from the paper, and
    ``min_max`` no physical selection), else its name.
    """
    return FORMULATIONS[method].label if method in FORMULATIONS else method


def _window(t: np.ndarray, window_s: float) -> int:
    """An odd number of instants spanning about ``window_s`` (so the window is centred)."""
    return 2 * int(round(0.5 * window_s / np.median(np.diff(t)))) + 1 if len(t) > 1 else 1


def _centred(smoothed: np.ndarray, size: int, n: int) -> np.ndarray:
    """``smoothed`` with NaN where a centred window of ``size`` of ``n`` instants does not
    fit (the first and last ``size // 2``, all of them when ``n < size``).
    """
    half = size // 2
    if n < size:
        smoothed[:] = np.nan
    elif half:
        smoothed[:half] = smoothed[n - half:] = np.nan
    return smoothed


def moving_average(values: np.ndarray, t: np.ndarray, window_s: float = SMOOTH_S) -> np.ndarray:
    """Centred moving average over ``window_s`` along the first axis (instants ``t``):
    each value the mean of a full window around it, NaN within half a window of either
    end (where the window does not fit).
    """
    size = _window(t, window_s)
    values = np.asarray(values, float)
    return _centred(uniform_filter1d(values, size=size, axis=0, mode="nearest"), size,
                    len(values))


def smooth_speed(values: np.ndarray, t: np.ndarray, window_s: float = SPEED_SMOOTH_S
                 ) -> np.ndarray:
    """Cubic Savitzky-Golay smoothing over a centred window of ``window_s`` along the
    first axis: it fits a cubic in each window, so a fluctuation slower than the window
    passes (a moving average over the same window takes a third off a 0.2 s period).
    NaN within half a window of either end, as :func:`moving_average`.
    """
    size = _window(t, window_s)
    values = np.asarray(values, float)
    if size <= 3:  # a cubic through three points or fewer is the data itself
        return values.copy()
    if len(values) < size:
        return np.full_like(values, np.nan)
    return _centred(savgol_filter(values, size, 3, axis=0, mode="interp"), size, len(values))


def write_csv(path: Path, columns: dict[str, np.ndarray]) -> Path:
    """Write equal-length columns with a header row; full double precision, written
    whole (:func:`~cardan_forces.experiments.files.replacing`). A number not known
    (NaN: not solved, not computed) is an empty cell, and so is the open side of a rigid
    set, which its ``*_set_open`` column names (:func:`open_sides`): no cell holds an
    infinity. :func:`~.figures_draw.read_csv` gives the columns back as they were.
    """
    path.parent.mkdir(parents=True, exist_ok=True)
    columns = open_sides(columns)
    data = np.column_stack([np.asarray(v, float) for v in columns.values()])
    with files.replacing(path, newline="") as f:
        f.write(",".join(columns) + "\n")
        f.writelines(",".join("" if np.isnan(v) else f"{v:.10g}" for v in row) + "\n"
                     for row in data)
    return path


def open_sides(columns: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """``columns`` with each rigid set's ``q_set_min``/``q_set_max`` finite or NaN and,
    after them, ``q_set_open`` (:data:`~.figures_draw.OPEN`: 0 closed, 1 open above, -1
    open below, 2 open on both sides; NaN where the set is not known).
    """
    out = {}
    for name, values in columns.items():
        if name.endswith("_set_min"):
            low = np.asarray(values, float)
            out[name] = np.where(np.isneginf(low), np.nan, low)
            continue
        if not name.endswith("_set_max"):
            out[name] = values
            continue
        q, high = name.removesuffix("_set_max"), np.asarray(values, float)
        low = np.asarray(columns[f"{q}_set_min"], float)
        above, below = np.isposinf(high), np.isneginf(low)
        out[name] = np.where(above, np.nan, high)
        code = above * OPEN["above"] + below * OPEN["below"] + (above & below) * 2.0
        out[f"{q}_set_open"] = np.where(np.isnan(low) | np.isnan(high), np.nan, code)
    return out


def _with_smoothed(columns: dict[str, np.ndarray], t: np.ndarray, speeds: bool = False
                   ) -> dict[str, np.ndarray]:
    """Add the smoothed curve after every ``..._penalty`` column: ``<name>_avg`` (forces,
    :func:`moving_average`) or ``<name>_smooth`` (speeds, :func:`smooth_speed`).
    """
    out = {}
    for name, values in columns.items():
        out[name] = values
        if name.endswith(f"_{PENALTY}"):
            out[f"{name}{SMOOTHED[speeds]}"] = (smooth_speed if speeds else moving_average)(
                values, t)
    return out


def _plot_grid(csv: Path, panels: list[Panel], title: str, ncols: int,
               formats=("png",)) -> list[Path]:
    """:func:`figures_draw.plot_grid` with this module's legend labels (methods, smoothing)."""
    labels = {m: method_label(m) for m in FORMULATIONS} | SMOOTH_LABELS
    return plot_grid(csv, panels, title, ncols, formats, labels)


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
    operator's columns: the length of each of its contacts' forces (a radial force's
    2-vector, an end face's push).
    """
    forces = np.asarray(forces)
    return {label: np.linalg.norm(forces[..., list(link.columns)], axis=-1)
            for label, link in sorted(op.joint_contacts(joint).items())}


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
    panels = [Panel(f"({'abcdefgh'[k]}) {_force_title(label, links[label])}", label,
                    "force [N]", rigid, sets=label in bounds)
              for k, label in enumerate(sorted(links))]
    _plot_grid(csv, panels,
               f"Fig. 13: contact forces of joint 1 on its cross-pin ({scene_name})", ncols=2,
               formats=formats)
    return csv


def _force_title(label: str, link) -> str:
    """A Fig. 13 panel's quantity: the magnitude of a contact's force of several
    components, the push of a one-component contact; what the contact is in its kind's
    words.
    """
    words = link.element_kind.words(link)
    if len(link.columns) > 1:
        return f"|{label}|, magnitude of its force ({words})"
    return f"{label}, push ({words})"


def fig14(op: Operator, histories: dict[str, np.ndarray],
          bounds: dict[str, tuple[np.ndarray, np.ndarray]], out: Path,
          number: int = 14, stem: str | None = None, subtitle: str = "",
          formats=("png",)) -> Path:
    """Fig. 14 (15 with horizontal gravity): the input shaft's bearing loads per method,
    with the rigid solution set's interval (``bounds``: quantity -> (low, high), NaN where
    not computed, inf where unbounded; written as :func:`open_sides` says). ``stem``:
    the files' name (default ``figNN``).
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
    titles = {f"{b}_radial": f"({'abcdefgh'[k]}) bearing '{b}': magnitude of its radial load"
              for k, b in enumerate(labels)}
    titles["axial"] = (f"({'abcdefgh'[len(labels)]}) axial load of the shaft (sum over its "
                       "bearings, signed)")
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
