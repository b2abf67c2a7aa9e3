"""Contact laws shared by the compliance formulation and the penalty simulation."""

from __future__ import annotations

import numpy as np

from .scene import Joint, Scene


def hertz_stiffness(scene: Scene, joint: Joint) -> float:
    """Paper eqs. 76-77: ``K = 4 / (3 (s1 + s2)) sqrt(R1 R2 / (R2 - R1))`` (N/m^1.5) for
    the trunnion (R1 = rs) in its bore (R2 = rb), ``s_k = (1 - nu^2) / E``; the end faces
    of the same joint use the same K (the paper gives one per joint).
    """
    sigma = (1.0 - scene.material.poisson_ratio**2) / scene.material.youngs_modulus_Pa
    r1, r2 = joint.rs_m, joint.rb_m
    return 4.0 / (3.0 * 2.0 * sigma) * np.sqrt(r1 * r2 / max(r2 - r1, 1e-12))
