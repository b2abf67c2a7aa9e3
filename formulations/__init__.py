"""Contact formulations: problems built from a driveline state (DESIGN §2).

``FORMULATIONS[name](op, i)`` builds the problem of formulation ``name`` at instant
``i`` of the equilibrium operator ``op``.
"""

from .convex import FORMULATIONS as _CONVEX
from .paper import build_paper

FORMULATIONS = {"paper": build_paper, **_CONVEX}

__all__ = ["FORMULATIONS"]
