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
    sets = cf.intervals(op, 100)            # {name: {"min", "max", "status"}}
    history = cf.solve_over_time(op, "positive")   # forces (T, n) and a record per instant
    released = cf.apply_releases(motion, ["slip:intermediate"])  # the motion, released line

What the command line gives, the API gives: ``cardan sets`` is :func:`determinacy`,
:func:`intervals` and :func:`named_modes` (``--apply``: :func:`apply_releases`,
``--release``: :func:`advise`); ``cardan report`` is :func:`solve_over_time` and
:func:`interval_history`; :func:`register` adds a solver backend of one's own.
"""

from __future__ import annotations

import dataclasses

from threadpoolctl import threadpool_limits

from .driveline import release as _release
from .driveline.determinacy import Determinacy, determinacy
from .driveline.dynamics import Motion, simulate
from .driveline.equilibrium import Operator, build_operator
from .driveline.loading import load_scene
from .driveline.modes import Mode
from .driveline.release import Release, parse_release, released_operator
from .driveline.scene import Scene, SceneError
from .experiments.study import (
    History,
    IntervalHistory,
    interval_history,
    intervals,
    solve_over_time,
)
from .formulations import FORMULATIONS
from .solvers import Backend, Outcome, Record, SolverNotFound, available, register, solve


def advise(motion: Motion, i: int) -> _release.Advice:
    """The smallest set of releases that leaves only end-face pair modes at instant
    ``i`` (:func:`cardan_forces.driveline.release.advise`), run as ``cardan sets
    --release`` runs it: one BLAS thread (its matrices are small; more threads contend).
    """
    with threadpool_limits(limits=1):
        return _release.advise(motion, i)


def named_modes(motion: Motion, i: int, op: Operator | None = None) -> list[Mode]:
    """Each null-space direction at instant ``i`` in words, with the releases that
    remove a closed loop (:func:`cardan_forces.driveline.release.named_modes`), on one
    BLAS thread as the command line runs it.
    """
    with threadpool_limits(limits=1):
        return _release.named_modes(motion, i, op)


def build_formulation(name: str, op: Operator, i: int):
    """The problem of formulation ``name`` (a key of :data:`FORMULATIONS`) at instant ``i``.

    Raises ``KeyError`` with the known names for an unknown formulation.
    """
    try:
        build = FORMULATIONS[name]
    except KeyError:
        raise KeyError(f"unknown formulation {name!r}; known: {', '.join(FORMULATIONS)}") from None
    return build(op, i)


def apply_releases(motion: Motion, releases) -> Motion:
    """``motion`` on its scene with ``releases`` applied, as ``cardan sets --apply``
    does: each a :class:`Release` or its command-line label (``"float:input.far"``: that
    bearing floating, ``"slip:intermediate"``: a slip joint in that shaft). The motion
    itself is unchanged (a release changes no kinematics); :func:`build_operator`,
    :func:`named_modes` and :func:`advise` then answer for the released line.
    ``SceneError`` for a release the scene does not have or one that leaves a mechanism.
    """
    chosen = [r if isinstance(r, Release) else parse_release(r, motion.scene)
              for r in releases]
    return dataclasses.replace(motion, scene=released_operator(motion, chosen).scene)


__all__ = [
    "FORMULATIONS",
    "Backend",
    "Determinacy",
    "History",
    "IntervalHistory",
    "Motion",
    "Operator",
    "Outcome",
    "Record",
    "Release",
    "Scene",
    "SceneError",
    "SolverNotFound",
    "advise",
    "apply_releases",
    "available",
    "build_formulation",
    "build_operator",
    "determinacy",
    "interval_history",
    "intervals",
    "load_scene",
    "named_modes",
    "register",
    "simulate",
    "solve",
    "solve_over_time",
]
