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

The API checks its arguments as the command line checks its options, before any work
(:mod:`cardan_forces._checks`): an instant outside the motion, a float or str where an
index belongs, a scene's name where a motion belongs, an unknown formulation, a NaN
time are one of the package's own exceptions, :class:`ArgumentError` (a ``ValueError``;
:class:`ArgumentTypeError` also a ``TypeError``, :class:`UnknownChoice` also a
``KeyError``), whose message names the argument and what it allows.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence

from threadpoolctl import threadpool_limits

from . import _checks
from ._checks import ArgumentError, ArgumentTypeError, UnknownChoice
from .driveline import determinacy as _determinacy
from .driveline import dynamics as _dynamics
from .driveline import equilibrium as _equilibrium
from .driveline import release as _release
from .driveline.determinacy import Determinacy
from .driveline.dynamics import Motion
from .driveline.equilibrium import Operator
from .driveline.loading import load_scene
from .driveline.modes import Mode
from .driveline.release import Release, parse_release, released_operator
from .driveline.scene import Scene, SceneError
from .experiments import study as _study
from .experiments.study import History, IntervalHistory
from .formulations import FORMULATIONS
from .solvers import (
    Backend,
    InvalidBackend,
    Outcome,
    Record,
    SolverNotFound,
    available,
    register,
    solve,
)


def simulate(scene: Scene, times=None, rtol: float = 1e-11, atol: float = 1e-12) -> Motion:
    """The 1-DOF motion of ``scene`` at ``times`` (s; default: the scene's grid)
    (:func:`cardan_forces.driveline.dynamics.simulate`). :class:`ArgumentError` for a
    time that is not finite or before the scene's start, or a tolerance that is not > 0.
    """
    _checks.of_type(scene, Scene, "scene")
    t = _checks.times(scene, times)
    return _dynamics.simulate(scene, t, _checks.positive(rtol, "rtol"),
                              _checks.positive(atol, "atol"))


def build_operator(motion: Motion) -> Operator:
    """``A(t) x = b(t)`` over the named contact forces at every instant of ``motion``
    (:func:`cardan_forces.driveline.equilibrium.build_operator`).
    """
    return _equilibrium.build_operator(_checks.of_type(motion, Motion, "motion"))


def determinacy(op: Operator, i: int) -> Determinacy:
    """Rank, null space, determinate components and least-norm forces at instant ``i``
    (an index of ``op.t``) (:func:`cardan_forces.driveline.determinacy.determinacy`).
    """
    _checks.of_type(op, Operator, "op")
    return _determinacy.determinacy(op, _checks.instant(op, i))


def advise(motion: Motion, i: int) -> _release.Advice:
    """The smallest set of releases that leaves only end-face pair modes at instant
    ``i`` (:func:`cardan_forces.driveline.release.advise`), run as ``cardan sets
    --release`` runs it: one BLAS thread (its matrices are small; more threads contend).
    """
    _checks.of_type(motion, Motion, "motion")
    i = _checks.instant(motion, i)
    with threadpool_limits(limits=1):
        return _release.advise(motion, i)


def named_modes(motion: Motion, i: int, op: Operator | None = None) -> list[Mode]:
    """Each null-space direction at instant ``i`` in words, with the releases that
    remove a closed loop (:func:`cardan_forces.driveline.release.named_modes`), on one
    BLAS thread as the command line runs it.
    """
    _checks.of_type(motion, Motion, "motion")
    i = _checks.instant(motion, i)
    if op is not None:
        _checks.of_type(op, Operator, "op")
    with threadpool_limits(limits=1):
        return _release.named_modes(motion, i, op)


def build_formulation(name: str, op: Operator, i: int):
    """The problem of formulation ``name`` (a key of :data:`FORMULATIONS`) at instant ``i``.

    :class:`UnknownChoice` (a ``KeyError``) with the known names for an unknown
    formulation, :class:`ArgumentError` for an instant outside ``op``.
    """
    _checks.choice(name, FORMULATIONS, "formulation")
    _checks.of_type(op, Operator, "op")
    return FORMULATIONS[name](op, _checks.instant(op, i))


def intervals(op: Operator, i: int, solver: str = _study.INTERVAL_SOLVER) -> dict[str, dict]:
    """``{name: {"min", "max", "status"}}`` of every named force at instant ``i``: the
    interval the rigid set allows it (:func:`cardan_forces.experiments.study.intervals`).
    """
    _checks.of_type(op, Operator, "op")
    return _study.intervals(op, _checks.instant(op, i), _checks.name_or_none(solver, "solver"))


def interval_history(op: Operator, instants: Sequence[int] | None = None,
                     progress: Callable[[str], None] | None = None) -> IntervalHistory:
    """:func:`intervals` at ``instants`` of ``op`` (default all), warm-started from one
    instant to the next (:func:`cardan_forces.experiments.study.interval_history`).
    """
    _checks.of_type(op, Operator, "op")
    return _study.interval_history(op, _checks.instants(op, instants),
                                   _checks.callable_or_none(progress, "progress"))


def solve_over_time(op: Operator, formulation: str, solver: str | None = None, *,
                    instants: Sequence[int] | None = None, tol: float | None = None,
                    budget_s: float = math.inf, **options) -> History:
    """``formulation`` solved with ``solver`` (default: the formulation's default
    backend) at ``instants`` of ``op`` (default all), in order; ``tol`` one tolerance
    for the solver, ``budget_s`` seconds after which it stops; ``options`` as
    :func:`cardan_forces.experiments.study.solve_over_time` takes them (``warm``,
    ``restart``, ``progress``, ...). Solver failures are failed records; a wrong
    argument is an :class:`ArgumentError`, an unknown backend :class:`SolverNotFound`.
    """
    _checks.of_type(op, Operator, "op")
    _checks.choice(formulation, FORMULATIONS, "formulation")
    return _study.solve_over_time(op, formulation, _checks.name_or_none(solver, "solver"),
                                  instants=_checks.instants(op, instants),
                                  tol=_checks.positive(tol, "tol", allow_none=True),
                                  budget_s=_checks.positive(budget_s, "budget_s", inf=True),
                                  **options)


def apply_releases(motion: Motion, releases) -> Motion:
    """``motion`` on its scene with ``releases`` applied, as ``cardan sets --apply``
    does: each a :class:`Release` or its command-line label (``"float:input.far"``: that
    bearing floating, ``"slip:intermediate"``: a slip joint in that shaft). The motion
    itself is unchanged (a release changes no kinematics); :func:`build_operator`,
    :func:`named_modes` and :func:`advise` then answer for the released line.
    ``SceneError`` for a release the scene does not have or one that leaves a mechanism.
    """
    _checks.of_type(motion, Motion, "motion")
    chosen = [r if isinstance(r, Release) else parse_release(r, motion.scene)
              for r in _checks.releases(releases)]
    return dataclasses.replace(motion, scene=released_operator(motion, chosen).scene)


__all__ = [
    "FORMULATIONS",
    "ArgumentError",
    "ArgumentTypeError",
    "Backend",
    "Determinacy",
    "History",
    "IntervalHistory",
    "InvalidBackend",
    "Motion",
    "Operator",
    "Outcome",
    "Record",
    "Release",
    "Scene",
    "SceneError",
    "SolverNotFound",
    "UnknownChoice",
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
