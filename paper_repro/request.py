"""What ``cardan repro`` may be asked to draw, and the refusal of what it cannot.

The figures and methods that the command's options name (``--fig``, ``--methods``,
``--fig15-scene``), the methods drawn unless told, and the check, before any long work,
that each method and figure chosen applies to the scene (one line of
:class:`~cardan_forces.formulations.convex.NotApplicable` that names what does apply).
A module of its own because the run's parts ask the same question: the compliance
comparison leaves out, with the same reason, a method that does not apply.
"""

from __future__ import annotations

import importlib.util

from cardan_forces.driveline import engine_mujoco
from cardan_forces.driveline.engine_mujoco import EngineUnsupported
from cardan_forces.driveline.equilibrium import Operator
from cardan_forces.driveline.scene import Scene
from cardan_forces.formulations import FORMULATIONS
from cardan_forces.formulations.convex import NotApplicable

from .figures import PENALTY
from .methods import METHODS

FIGURES = (11, 12, 13, 14, 15)
FIG15_SCENES = ("paper-fig15", "paper-fig15-axial")
"""Fig. 15's scenes: the paper says "horizontal" gravity but not which; +y (normal to
the articulation plane) and +x (along the input shaft) are both drawn."""
ENGINE = "engine"
"""The method name of MuJoCo's forward simulation
(:mod:`cardan_forces.experiments.engine`)."""
ALL_METHODS = (*METHODS, PENALTY, ENGINE)
"""What ``cardan repro`` can draw: the rigid-model methods, the penalty simulation and
MuJoCo (its own figure and section)."""


def default_methods() -> tuple[str, ...]:
    """What ``cardan repro`` draws unless told: every method, MuJoCo only where it is
    installed (the ``mujoco`` extra, in ``all``).
    """
    present = importlib.util.find_spec("mujoco") is not None
    return tuple(m for m in ALL_METHODS if present or m != ENGINE)


def _refusal(scene: Scene, op: Operator, method: str) -> str:
    """Why ``method`` cannot draw ``scene`` (empty if it can): its problem cannot be
    built (the paper's method on a slip joint), or the penalty simulation of a
    quasi-static scene.
    """
    if method == PENALTY:
        return "" if scene.has("inertia") else "it is dynamic and needs the 'inertia' effect"
    if method == ENGINE:
        try:
            engine_mujoco.check_expressible(scene)
            engine_mujoco.mujoco_version()
        except EngineUnsupported as exc:
            return str(exc)
        return ""
    try:
        FORMULATIONS[method](op, 0)
    except NotApplicable as exc:
        return str(exc)
    return ""


def check_request(scene: Scene, op: Operator, methods, figs) -> None:
    """Refuse, before any long work, what the chosen methods or figures cannot do on
    ``scene`` (:class:`NotApplicable`, one line): a method that does not apply
    (:func:`_refusal`), Fig. 12 without an intermediate shaft, Figs. 13-15 without joint
    1's contacts or the first shaft's bearings.
    """
    why = {m: _refusal(scene, op, m) for m in methods}
    refused = [f"{m!r} ({why[m]})" for m in methods if why[m]]
    if refused:  # the others asked only to name what applies (MuJoCo's is an import)
        why |= {m: _refusal(scene, op, m) for m in ALL_METHODS if m not in why}
        usable = ",".join(m for m in ALL_METHODS if not why[m]) or "none"
        raise NotApplicable(f"cardan repro {scene.name}: {'; '.join(refused)}; choose "
                            f"--methods among those that apply here: {usable}")
    needs = []
    if 12 in figs and len(scene.shafts) < 3:
        needs.append("Fig. 12 draws an intermediate shaft (a line of at least 3 shafts)")
    if 13 in figs and not op.joint_contacts(0):
        needs.append("Fig. 13 draws joint 1's cross-pin contacts")
    if any(f in figs for f in (14, 15)) and not op.bearings(0):
        needs.append("Figs. 14-15 draw the first shaft's bearings")
    if needs:
        raise NotApplicable(f"cardan repro {scene.name}: {'; '.join(needs)}; leave them out "
                            "with --fig")
