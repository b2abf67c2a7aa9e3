"""The paper's figures (Wang & Qi 2017, Figs. 11-15), each a CSV and images drawn from it.

Each ``figNN`` function writes ``<stem>.csv`` (first column ``t`` in s, the others named
by quantity and, where several methods are compared, by method) and one image per format
asked for (``png``, ``svg``, ``pdf``) into a folder, and returns the CSV's path with the
figure's caption (:class:`~.figures_draw.Drawn`). The images are always redrawn from the
CSV (:mod:`cardan_forces.paper_repro.figures_draw` says how).

The penalty simulation's curves are drawn from the end of its start-up on (``settled_s``
from the run's start: the joints' play taken up from rest, the instants its statistics
leave out too, :data:`~.verdicts.SETTLED_S`) and summarised by a zero-phase filter of
the instants from there on: forces by a Butterworth low-pass (:func:`low_pass`, column
``..._penalty_lowpass``), which makes a bump of an impact where it happened rather than
a plateau a window wide; speeds by a cubic Savitzky-Golay filter (``..._penalty_smooth``),
which keeps the intermediate shaft's twice-per-revolution fluctuation. Where a filter
has too few instants (a run shorter than one period of the cut-off after the start-up,
or within half a Savitzky-Golay window of either end) the filtered value is left out
(NaN in the CSV, not drawn). The verdicts' statistics keep their own smoothing
(:func:`moving_average`, the means over blocks of :data:`SMOOTH_S` that their sign test
counts).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from cardan_forces.driveline.dynamics import Motion
from cardan_forces.driveline.equilibrium import Operator
from cardan_forces.experiments import files
from cardan_forces.formulations import FORMULATIONS
from scipy.ndimage import uniform_filter1d
from scipy.signal import butter, savgol_filter, sosfiltfilt

from .figures_draw import OPEN, PENALTY, RAW_LABEL, SMOOTHED, Drawn, Panel, plot_grid
from .figures_draw import read_csv as read_csv  # the figures' CSV reader, with write_csv

SMOOTH_S = 0.1
"""Moving-average window (s) of the verdicts' statistics on the penalty simulation's
forces (:func:`moving_average`): the released line rattles in its clearances, the rigid
model does not."""
SPEED_SMOOTH_S = 0.1
"""Savitzky-Golay window (s, cubic) for the penalty simulation's speeds: on ``paper`` it
keeps the intermediate shaft's peaks (14.94 vs the rigid 14.98 rad/s after 4 s, where a
0.1 s moving average gives 14.33) while taking out the rattle."""
LOWPASS_HZ = 10.0
"""Cut-off of the figures' low-pass filter of the penalty simulation's forces: twice the
frequency of the fastest periodic load on ``paper`` (the intermediate shaft's
twice-per-revolution fluctuation, 4.8 Hz at the input's 15 rad/s), which it passes at
95 % of its amplitude; the rigid curves have less than 1 % of their power above it."""
LOWPASS_ORDER = 2
"""Order of the Butterworth low-pass, run forward and back (zero phase; gain 1/2 at the
cut-off). A higher order rings more after an impact: -23 N under a magnitude at 4th
order on ``paper``'s |F1|, -9 N at 2nd."""


def smooth_labels(start_s: float) -> dict[str, str]:
    """Legend labels of the penalty's curves (raw and filtered, by column suffix) drawn
    from ``start_s`` on.
    """
    since = f"from {start_s:g} s"
    return {RAW_LABEL: f"penalty (raw), {since}",
            SMOOTHED[False]: f"penalty, zero-phase Butterworth low-pass {LOWPASS_HZ:g} Hz "
                             f"(order {LOWPASS_ORDER}), {since}",
            SMOOTHED[True]: f"penalty, cubic Savitzky-Golay over a centred "
                            f"{SPEED_SMOOTH_S:g} s, {since} (none within "
                            f"{SPEED_SMOOTH_S / 2:g} s of either end)"}


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
    end (where the window does not fit). The verdicts' smoothing, not the figures'.
    """
    size = _window(t, window_s)
    values = np.asarray(values, float)
    return _centred(uniform_filter1d(values, size=size, axis=0, mode="nearest"), size,
                    len(values))


def low_pass(values: np.ndarray, t: np.ndarray, start_s: float = -np.inf,
             cutoff_hz: float = LOWPASS_HZ) -> np.ndarray:
    """Zero-phase Butterworth low-pass (:data:`LOWPASS_ORDER`, ``sosfiltfilt``) of
    ``values`` over the instants ``t`` (evenly spaced) from ``start_s`` on; NaN before
    it, so that a start-up does not leak into what follows. Each stretch of finite
    values is filtered on its own, one shorter than a period of the cut-off left out
    (NaN): too short to tell what to keep.
    """
    values = np.asarray(values, float)
    out = np.full_like(values, np.nan)
    if len(t) < 2:
        return out
    rate = 1.0 / float(np.median(np.diff(t)))
    if cutoff_hz >= rate / 2:  # nothing above the cut-off to take out
        return np.where(t >= start_s - 1e-12, values, np.nan)
    sos = butter(LOWPASS_ORDER, cutoff_hz, fs=rate, output="sos")
    keep = np.isfinite(values) & (t >= start_s - 1e-12)
    for first, stop in _stretches(keep):
        if (stop - first) / rate >= 1.0 / cutoff_hz:
            out[first:stop] = sosfiltfilt(sos, values[first:stop],
                                          padlen=min(3 * (2 * len(sos) + 1), stop - first - 1))
    return out


def _stretches(mask: np.ndarray) -> list[tuple[int, int]]:
    """``(first, stop)`` of each run of True in ``mask``."""
    edges = np.flatnonzero(np.diff(np.concatenate([[0], mask.astype(int), [0]])))
    return list(zip(edges[::2], edges[1::2]))


def smooth_speed(values: np.ndarray, t: np.ndarray, window_s: float = SPEED_SMOOTH_S,
                 start_s: float = -np.inf) -> np.ndarray:
    """Cubic Savitzky-Golay smoothing over a centred window of ``window_s`` along the
    first axis, of the instants from ``start_s`` on (NaN before): it fits a cubic in
    each window, so a fluctuation slower than the window passes (a moving average over
    the same window takes a third off a 0.2 s period). NaN within half a window of
    either end, as :func:`moving_average`.
    """
    size = _window(t, window_s)
    values = np.asarray(values, float)
    out = np.full_like(values, np.nan)
    first = int(np.searchsorted(t, start_s - 1e-12))
    if size <= 3:  # a cubic through three points or fewer is the data itself
        out[first:] = values[first:]
    elif len(values) - first >= size:
        out[first:] = _centred(savgol_filter(values[first:], size, 3, axis=0, mode="interp"),
                               size, len(values) - first)
    return out


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


def _with_smoothed(columns: dict[str, np.ndarray], t: np.ndarray, settled_s: float,
                   speeds: bool = False) -> dict[str, np.ndarray]:
    """Add the filtered curve after every ``..._penalty`` column, of its instants after
    the start-up (``settled_s`` from the first): ``<name>_lowpass`` (forces,
    :func:`low_pass`) or ``<name>_smooth`` (speeds, :func:`smooth_speed`).
    """
    out, start = {}, t[0] + settled_s if len(t) else 0.0
    for name, values in columns.items():
        out[name] = values
        if name.endswith(f"_{PENALTY}"):
            out[f"{name}{SMOOTHED[speeds]}"] = (
                smooth_speed(values, t, start_s=start) if speeds else
                low_pass(values, t, start_s=start))
    return out


def _plot_grid(csv: Path, panels: list[Panel], title: str, ncols: int, formats=("png",),
               settled_s: float = 0.0, caption: tuple[str, ...] = (),
               starts: dict | None = None) -> Drawn:
    """:func:`figures_draw.plot_grid` with this module's legend labels (methods, the
    penalty's curves), the penalty drawn from the end of its start-up (``settled_s``
    from the first instant; ``starts``: the time from which other simulated methods are
    drawn); ``caption``: the figure's own lines, before its panels'.
    """
    names = read_csv(csv)
    start = float(names["t"][0]) + settled_s
    labels = {m: method_label(m) for m in FORMULATIONS} | smooth_labels(start)
    drawn = plot_grid(csv, panels, title, ncols, formats, labels,
                      {PENALTY: start} | (starts or {}))
    filters = {s for p in panels for s in SMOOTHED.values()
               if f"{p.quantity}_{PENALTY}{s}" in names}
    return Drawn(csv, [*caption, *(_penalty_caption(start, s) for s in filters),
                       *drawn.caption])


def _penalty_caption(start: float, suffix: str) -> str:
    """The caption's line on the penalty's curves: from when, and filtered how."""
    how = (f"a zero-phase Butterworth low-pass of its forces (order {LOWPASS_ORDER}, cut-off "
           f"{LOWPASS_HZ:g} Hz, run forward and back)" if suffix == SMOOTHED[False] else
           f"a cubic Savitzky-Golay filter of its speeds over a centred {SPEED_SMOOTH_S:g} s")
    return (f"- the penalty simulation is drawn from {start:g} s on: before, it takes up "
            "the joints' play from rest, a start-up the rigid model has not and the "
            f"statistics leave out too. Its bold curve is {how}, of the instants from "
            f"{start:g} s on")


def fig11(motion: Motion, out: Path, penalty_omega: np.ndarray | None = None,
          formats=("png",), *, settled_s: float) -> Drawn:
    """Fig. 11: angular velocities of the input and output shafts (rad/s); with
    ``penalty_omega`` (shafts, T) the penalty simulation's beside the rigid model's, and
    a panel per shaft of the difference penalty - rigid, where the agreement is read;
    the penalty's drawn from ``settled_s`` after the start on (its start-up left out).
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
    csv = write_csv(Path(out) / "fig11.csv",
                    _with_smoothed(columns, motion.t, settled_s, speeds=True))
    return _plot_grid(csv, panels,
                      f"Fig. 11: input and output angular velocity ({motion.scene.name})",
                      ncols=2, formats=formats, settled_s=settled_s)


def fig12(motion: Motion, out: Path, penalty_omega: np.ndarray | None = None,
          formats=("png",), *, settled_s: float) -> Drawn:
    """Fig. 12: angular velocity of the intermediate shaft (rad/s), rigid and penalty,
    and with the penalty a panel of the difference penalty - rigid; the penalty's drawn
    from ``settled_s`` after the start on.
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
    csv = write_csv(Path(out) / "fig12.csv",
                    _with_smoothed(columns, motion.t, settled_s, speeds=True))
    return _plot_grid(csv, panels,
                      f"Fig. 12: intermediate shaft angular velocity ({motion.scene.name})",
                      ncols=1, formats=formats, settled_s=settled_s)


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
          bounds: dict[str, tuple[np.ndarray, np.ndarray]], out: Path, formats=("png",),
          *, settled_s: float) -> Drawn:
    """Fig. 13: the eight contact forces F1-F8 of joint 1 (N), one column per method
    (forces in the operator's columns at its instants), with the rigid solution set's
    interval of each (``bounds``: label -> (low, high), NaN where not computed, inf where
    unbounded); the penalty's drawn from ``settled_s`` after the start on.
    """
    t, scene_name = op.t, op.scene.name
    columns = {"t": t}
    for method, forces in histories.items():
        for label, values in joint_magnitudes(op, forces).items():
            columns[f"{label}_{method}"] = values
    csv = write_csv(Path(out) / "fig13.csv",
                    _with_smoothed(_set_columns(columns, bounds), t, settled_s))
    links = op.joint_contacts(0)
    rigid = tuple(m for m in histories if m != PENALTY)
    panels = [Panel(f"({'abcdefgh'[k]}) {_force_title(label, links[label])}", label,
                    "force [N]", rigid, sets=label in bounds)
              for k, label in enumerate(sorted(links))]
    return _plot_grid(csv, panels,
                      f"Fig. 13: contact forces of joint 1 on its cross-pin ({scene_name})",
                      ncols=2, formats=formats, settled_s=settled_s)


def _force_title(label: str, link) -> str:
    """A Fig. 13 panel's quantity: the magnitude of a contact's force of several
    components, the push of a one-component contact; what the contact is in its kind's
    words.
    """
    words = link.element_kind.words(link)
    if len(link.columns) > 1:
        return f"|{label}|, magnitude ({words})"
    return f"{label}, push ({words})"


def fig14(op: Operator, histories: dict[str, np.ndarray],
          bounds: dict[str, tuple[np.ndarray, np.ndarray]], out: Path,
          number: int = 14, stem: str | None = None, subtitle: str = "",
          formats=("png",), *, settled_s: float) -> Drawn:
    """Fig. 14 (15 with horizontal gravity): the input shaft's bearing loads per method,
    with the rigid solution set's interval (``bounds``: quantity -> (low, high), NaN where
    not computed, inf where unbounded; written as :func:`open_sides` says); the
    penalty's drawn from ``settled_s`` after the start on. ``stem``: the files' name
    (default ``figNN``).
    """
    t, scene_name = op.t, op.scene.name
    columns = {"t": t}
    for method, forces in histories.items():
        for q, values in bearing_loads(op, forces).items():
            columns[f"{q}_{method}"] = values
    csv = write_csv(Path(out) / f"{stem or f'fig{number}'}.csv",
                    _with_smoothed(_set_columns(columns, bounds), t, settled_s))
    rigid = tuple(m for m in histories if m != PENALTY)
    return _plot_grid(csv, [Panel(title, q, "force [N]", rigid, sets=q in bounds)
                            for q, title in _bearing_titles(op).items()],
                      f"Fig. {number}: input shaft bearing loads ({scene_name}{subtitle})",
                      ncols=1, formats=formats, settled_s=settled_s)


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
                  formats=("png",), settle_s: float = 0.0) -> Drawn:
    """``engine``: MuJoCo's input shaft bearing loads (N, as Fig. 14's quantities) over
    time, one curve per softness setting (``runs``: setting label -> forces (T, n) in
    the operator's columns), over the rigid solution set's interval (``bounds`` as in
    :func:`fig14`). Columns ``<quantity>_engine<k>`` in the order of ``runs``, every
    instant; the curves drawn from ``settle_s`` after the start on (the engine's
    settling, which its statistics leave out).
    """
    columns = {"t": op.t}
    keys = {label: f"engine{k}" for k, label in enumerate(runs)}
    for label, forces in runs.items():
        for q, values in bearing_loads(op, forces).items():
            columns[f"{q}_{keys[label]}"] = values
    csv = write_csv(Path(out) / "engine.csv", _set_columns(columns, bounds))
    start = float(op.t[0]) + settle_s
    labels = tuple((key, f"MuJoCo, {label}, from {start:g} s") for label, key in keys.items())
    return _plot_grid(
        csv, [Panel(title, q, "force [N]", tuple(keys.values()), sets=q in bounds,
                    labels=labels) for q, title in _bearing_titles(op).items()],
        f"MuJoCo's input shaft bearing loads over the rigid set ({op.scene.name}; "
        f"{len(runs)} softness settings)", ncols=1, formats=formats,
        caption=(f"- MuJoCo's curves are drawn from {start:g} s on: before, the line sags "
                 "into its soft constraints from unloaded, the engine's settling that the "
                 "statistics leave out too",),
        starts=dict.fromkeys(keys.values(), start))
