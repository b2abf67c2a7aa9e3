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

from driveline.dynamics import Motion  # noqa: E402


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


def _plot_lines(csv: Path, panels: list[tuple[str, list[tuple[str, str]]]], ylabel: str,
                title: str) -> Path:
    """One panel per entry ``(panel title, [(column, legend label), ...])``."""
    cols = read_csv(csv)
    fig, axes = plt.subplots(len(panels), 1, figsize=(7, 2.8 * len(panels)), squeeze=False)
    for ax, (panel_title, lines) in zip(axes[:, 0], panels):
        for column, label in lines:
            ax.plot(cols["t"], cols[column], label=label, lw=1.2)
        ax.set_title(panel_title, fontsize=10)
        ax.set_xlabel("time t [s]")
        ax.set_ylabel(ylabel)
        ax.grid(alpha=0.3)
        if len(lines) > 1:
            ax.legend(fontsize=8)
    fig.suptitle(title, fontsize=11)
    fig.tight_layout()
    png = csv.with_suffix(".png")
    fig.savefig(png, dpi=120)
    plt.close(fig)
    return png


def fig11(motion: Motion, out: Path) -> Path:
    """Fig. 11: angular velocities of the input and output shafts (rad/s)."""
    csv = write_csv(
        Path(out) / "fig11.csv",
        {"t": motion.t, "omega_input": motion.omega[0], "omega_output": motion.omega[-1]},
    )
    _plot_lines(
        csv,
        [("(a) input shaft", [("omega_input", "input")]),
         ("(b) output shaft", [("omega_output", "output")])],
        "angular velocity [rad/s]",
        f"Fig. 11: input and output angular velocity ({motion.scene.name})",
    )
    return csv


def fig12(motion: Motion, out: Path) -> Path:
    """Fig. 12: angular velocity of the intermediate shaft (rad/s)."""
    csv = write_csv(Path(out) / "fig12.csv",
                    {"t": motion.t, "omega_intermediate": motion.omega[1]})
    _plot_lines(
        csv,
        [("intermediate shaft", [("omega_intermediate", "intermediate")])],
        "angular velocity [rad/s]",
        f"Fig. 12: intermediate shaft angular velocity ({motion.scene.name})",
    )
    return csv
