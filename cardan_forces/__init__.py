"""cardan-forces: reaction forces in drive shafts with Cardan joints.

The package's layers install as subpackages of this one, data flowing one way:
:mod:`cardan_forces.driveline` (scene, motion, equilibrium operator, determinacy) ->
:mod:`cardan_forces.formulations` (contact problems) -> :mod:`cardan_forces.solvers`
(backends, records) -> :mod:`cardan_forces.experiments` and
:mod:`cardan_forces.paper_repro`; the ``cardan`` command line
(:mod:`cardan_forces.cli`) sits above them all.

The small public API, in the order a study uses it::

    import cardan_forces as cf
    scene = cf.load_scene("paper")          # a built-in name or a TOML path
    motion = cf.simulate(scene)             # the 1-DOF motion on the scene's time grid
    op = cf.build_operator(motion)          # A(t) x = b(t) over named contact forces
    det = cf.determinacy(op, 100)           # rank, null space, determinate components
    modes = cf.named_modes(motion, 100)     # each null-space direction in words
    advice = cf.advise(motion, 100)         # the smallest releases that make it unique
    problem = cf.build_formulation("positive", op, 100)
    record = cf.solve(problem, "clarabel")  # status and residuals computed here
"""

from __future__ import annotations

from .driveline.determinacy import Determinacy, determinacy
from .driveline.dynamics import Motion, simulate
from .driveline.equilibrium import Operator, build_operator
from .driveline.loading import load_scene
from .driveline.release import advise, named_modes
from .driveline.scene import Scene, SceneError
from .formulations import FORMULATIONS
from .solvers import Record, SolverNotFound, available, solve


def build_formulation(name: str, op: Operator, i: int):
    """The problem of formulation ``name`` (a key of :data:`FORMULATIONS`) at instant ``i``.

    Raises ``KeyError`` with the known names for an unknown formulation.
    """
    try:
        build = FORMULATIONS[name]
    except KeyError:
        raise KeyError(f"unknown formulation {name!r}; known: {', '.join(FORMULATIONS)}") from None
    return build(op, i)


__all__ = [
    "FORMULATIONS",
    "Determinacy",
    "Motion",
    "Operator",
    "Record",
    "Scene",
    "SceneError",
    "SolverNotFound",
    "advise",
    "available",
    "build_formulation",
    "build_operator",
    "determinacy",
    "load_scene",
    "named_modes",
    "simulate",
    "solve",
]
