"""Faults and odd requests that once ended in a traceback, a silent success or a hung
run: each is constructed here and must end with a clear message, a failed record or a
clean result.
"""

from __future__ import annotations

import numpy as np
from cardan_forces.experiments import engine

import cardan_forces as cf


def test_engine_comparison_passes_over_backends_that_cannot_take_a_friction_cone():
    """On a line with slip-joint friction the signed formulations are conic: the QP
    backends first in line cannot take them and the next backend solves them, and the
    forces found satisfy the equilibrium (A x = b).
    """
    scene = cf.load_scene("paper-penalty")
    op = cf.build_operator(cf.simulate(scene, [scene.time.start_s + 0.1]))
    forces = engine._formulation_forces(op, 0)
    x = forces["positive"]
    assert np.linalg.norm(op.A[0] @ x - op.b[0]) <= 1e-6 * np.linalg.norm(op.b[0])
