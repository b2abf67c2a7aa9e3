"""What the engine studies share: which engine a run is, and the first shaft's loads
their figures draw (as Figs. 14-15 and ``cardan repro``'s engine figure draw them).
"""

from __future__ import annotations

import numpy as np
from cardan_forces.driveline.engine_drake import Stepping
from cardan_forces.driveline.engine_mujoco import EngineRun

ENGINES = {"mujoco": "MuJoCo", "drake": "Drake"}
"""The engines ``--engine`` names, with the name the outputs give each."""


def engine_of(run: EngineRun) -> str:
    """The engine's name of a run (:data:`ENGINES`), from its setting's type."""
    return ENGINES["drake" if isinstance(run.softness, Stepping) else "mujoco"]


def load_rows(op) -> dict[str, np.ndarray]:
    """The first shaft's loads the figure draws, as Figs. 14-15 and ``cardan repro``'s
    MuJoCo figure draw them, by panel title: per bearing the magnitude of its radial
    load (the length of its two components normal to the axis: two rows over the
    forces) and the shaft's axial load (sum over its bearings, signed: one row).
    """
    bearings = op.bearings(0)
    matrices = [op.bearing_matrix(link) for link in bearings]  # rows (r1, r2, axis)
    rows = {f"({'abcdefgh'[k]}) bearing '{link.label}': magnitude of its radial load": m[:2]
            for k, (link, m) in enumerate(zip(bearings, matrices))}
    rows[f"({'abcdefgh'[len(rows)]}) axial load of shaft '{op.scene.shafts[0].name}' (sum "
         "over its bearings, signed)"] = sum(m[2] for m in matrices)[None, :]
    return rows


def load_of(forces: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """The load ``rows`` (k, n) makes of ``forces`` (T, n): its length for two rows, its
    signed value for one.
    """
    values = np.asarray(forces) @ rows.T
    return values[:, 0] if len(rows) == 1 else np.linalg.norm(values, axis=1)
