"""Contact formulations: problems built from a driveline state (DESIGN §2).

``FORMULATIONS[name](op, i)`` builds the problem of formulation ``name`` at instant
``i`` of the equilibrium operator ``op``; each entry is a
:class:`~cardan_forces.formulations.registry.Formulation` record, the one place that
says what that formulation is (a command's choices of formulations live with the
command).
"""

from .registry import (
    BASELINE,
    FALLBACK,
    FORMULATIONS,
    SELECTION,
    Formulation,
    UnknownFormulation,
    default_backends,
    formulation,
    where,
)

__all__ = ["BASELINE", "FALLBACK", "FORMULATIONS", "SELECTION", "Formulation", "UnknownFormulation",
           "default_backends", "formulation", "where"]
