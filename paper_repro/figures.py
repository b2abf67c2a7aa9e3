"""The paper's figures (Wang & Qi 2017, Figs. 11-15), each a CSV and a PNG drawn from it.

Each ``figNN`` function writes ``figNN.csv`` (first column ``t`` in s, the others named
by quantity and, where several methods are compared, by method) and ``figNN.png``
into a folder, and returns the CSV's path. The PNG is always redrawn from the CSV.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from cardan_forces.driveline.dynamics import Motion  # noqa: E402


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


def fig11(motion: Motion, out: Path, penalty_omega: np.ndarray | None = None) -> Path:
    """Fig. 11: angular velocities of the input and output shafts (rad/s); with
    ``penalty_omega`` (shafts, T) the penalty simulation's beside the rigid model's.
    """
    columns = {"t": motion.t, "omega_input": motion.omega[0], "omega_output": motion.omega[-1]}
    if penalty_omega is not None:
        columns |= {"omega_input_penalty": penalty_omega[0],
                    "omega_output_penalty": penalty_omega[-1]}
    csv = write_csv(Path(out) / "fig11.csv", columns)
    _plot_grid(
        csv,
        [(f"({p}) {name} shaft", [(c, label) for c, label in
                                  ((f"omega_{name}", "rigid model"),
                                   (f"omega_{name}_penalty", "penalty")) if c in columns])
         for p, name in (("a", "input"), ("b", "output"))],
        "angular velocity [rad/s]",
        f"Fig. 11: input and output angular velocity ({motion.scene.name})",
        ncols=1,
    )
    return csv


def fig12(motion: Motion, out: Path, penalty_omega: np.ndarray | None = None) -> Path:
    """Fig. 12: angular velocity of the intermediate shaft (rad/s), rigid and penalty."""
    columns = {"t": motion.t, "omega_intermediate": motion.omega[1]}
    if penalty_omega is not None:
        columns["omega_intermediate_penalty"] = penalty_omega[1]
    csv = write_csv(Path(out) / "fig12.csv", columns)
    _plot_grid(
        csv,
        [("intermediate shaft", [(c, label) for c, label in
                                 (("omega_intermediate", "rigid model"),
                                  ("omega_intermediate_penalty", "penalty")) if c in columns])],
        "angular velocity [rad/s]",
        f"Fig. 12: intermediate shaft angular velocity ({motion.scene.name})",
        ncols=1,
    )
    return csv


def joint_magnitudes(names: tuple[str, ...], forces: np.ndarray, joint: str = "uj1") -> dict:
    """|F1| ... |F8| of one joint (N) from named Cartesian forces (T, n): radial forces
    as the length of their 2-vector, end faces as they are.
    """
    idx = {n: i for i, n in enumerate(names)}
    out = {}
    for k in range(1, 9):
        label = f"F{k}"
        parts = [idx[n] for n in names if n.startswith(f"{joint}.{label}.")]
        parts = parts or [idx[f"{joint}.{label}"]]
        out[label] = np.linalg.norm(forces[:, parts], axis=1)
    return out


def bearing_loads(names: tuple[str, ...], forces: np.ndarray, shaft: str = "input") -> dict:
    """The paper's Fig. 14 quantities (N): far (left) and near (right) bearing radial
    loads (length of the components normal to the shaft, x being its axis in the paper
    frame) and the axial load (sum of the two bearings' x, which the paper merges).
    """
    idx = {n: i for i, n in enumerate(names)}
    col = lambda b, a: forces[:, idx[f"bearing.{shaft}.{b}.{a}"]]  # noqa: E731
    return {
        "far_radial": np.hypot(col("far", "y"), col("far", "z")),
        "near_radial": np.hypot(col("near", "y"), col("near", "z")),
        "axial": col("far", "x") + col("near", "x"),
    }


def fig13(t: np.ndarray, names: tuple[str, ...], histories: dict[str, np.ndarray], out: Path,
          scene_name: str) -> Path:
    """Fig. 13: the eight contact forces F1-F8 of joint 1 (N), one column per method."""
    columns = {"t": t}
    for method, forces in histories.items():
        for label, values in joint_magnitudes(names, forces).items():
            columns[f"{label}_{method}"] = values
    csv = write_csv(Path(out) / "fig13.csv", columns)
    titles = {1: "radial", 2: "radial", 3: "axial", 4: "axial", 5: "radial", 6: "radial",
              7: "axial", 8: "axial"}
    panels = [(f"({'abcdefgh'[k - 1]}) {titles[k]} contact force F{k}",
               [(f"F{k}_{m}", m) for m in histories]) for k in range(1, 9)]
    _plot_grid(csv, panels, "force [N]",
               f"Fig. 13: contact forces of joint 1 on its cross-pin ({scene_name})", ncols=2)
    return csv


def fig14(t: np.ndarray, names: tuple[str, ...], histories: dict[str, np.ndarray],
          bounds: dict[str, tuple[np.ndarray, np.ndarray]], out: Path, scene_name: str,
          number: int = 14) -> Path:
    """Fig. 14 (15 with horizontal gravity): the input shaft's bearing loads per method,
    with the rigid solution set's interval (``bounds``: quantity -> (low, high), NaN where
    not computed, inf where unbounded) shaded.
    """
    columns = {"t": t}
    for method, forces in histories.items():
        for q, values in bearing_loads(names, forces).items():
            columns[f"{q}_{method}"] = values
    for q, (low, high) in bounds.items():
        columns[f"{q}_set_min"], columns[f"{q}_set_max"] = low, high
    csv = write_csv(Path(out) / f"fig{number}.csv", columns)
    labels = {"far_radial": "(a) left (far) bearing, radial",
              "near_radial": "(b) right (near) bearing, radial",
              "axial": "(c) axial (sum of both bearings)"}
    panels = [(labels[q], [(f"{q}_{m}", m) for m in histories]) for q in labels]
    _plot_grid(csv, panels, "force [N]",
               f"Fig. {number}: input shaft bearing loads ({scene_name})", ncols=1,
               shade={labels[q]: q for q in labels})
    return csv


def _plot_grid(csv: Path, panels, ylabel: str, title: str, ncols: int,
               shade: dict[str, str] | None = None) -> Path:
    """Panels of lines from the CSV; ``shade`` maps a panel title to the quantity whose
    ``_set_min``/``_set_max`` columns are drawn as the solution set (clipped to the
    drawn lines' range, hatched where unbounded).
    """
    cols = read_csv(csv)
    nrows = -(-len(panels) // ncols)
    fig, axes = plt.subplots(nrows, ncols, figsize=(6.5 * ncols, 2.6 * nrows), squeeze=False)
    for ax, (panel_title, lines) in zip(axes.ravel(), panels):
        for column, label in lines:
            ax.plot(cols["t"], cols[column], label=label, lw=1.0)
        if shade and panel_title in shade:
            q = shade[panel_title]
            low, high = cols[f"{q}_set_min"], cols[f"{q}_set_max"]
            ok = np.isfinite(low) | np.isfinite(high) | np.isinf(low) | np.isinf(high)
            ok &= ~(np.isnan(low) | np.isnan(high))
            y0, y1 = ax.get_ylim()
            ax.fill_between(cols["t"][ok], np.clip(low[ok], y0, y1), np.clip(high[ok], y0, y1),
                            color="grey", alpha=0.25, lw=0, label="rigid solution set")
            if np.any(np.isinf(high[ok])):
                ax.text(0.01, 0.92, "set unbounded above", transform=ax.transAxes, fontsize=7)
            ax.set_ylim(y0, y1)
        ax.set_title(panel_title, fontsize=9)
        ax.set_xlabel("time t [s]")
        ax.set_ylabel(ylabel)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=6, ncol=3)
    for ax in axes.ravel()[len(panels):]:
        ax.axis("off")
    fig.suptitle(title, fontsize=11)
    fig.tight_layout()
    png = csv.with_suffix(".png")
    fig.savefig(png, dpi=110)
    plt.close(fig)
    return png
