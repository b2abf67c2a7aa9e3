"""``cardan compile``: compile every numba kernel of the package ahead of a first run.

numba compiles the package's kernels for the CPU it runs on, on their first call, and
caches them on disk (beside the modules, or in ``NUMBA_CACHE_DIR``). A first ``cardan
repro`` would otherwise spend minutes compiling inside its first penalty simulation, a
first ``solve --solver newton`` most of a minute inside its first solve; this command
does that work up front, with the calls those runs make, and says where the caches are.

:data:`FAMILIES` is the one list of what there is to compile: each family names the
modules whose kernels its warm-up call compiles. A module that defines numba kernels
joins a family there (a test walks the package's modules and fails on one that is in
none). Without the ``numba`` extra there is nothing to compile.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from cardan_forces.commands import progress
from cardan_forces.driveline.loading import load_scene
from cardan_forces.formulations import SELECTION
from cardan_forces.util.compiled import HAVE_NUMBA


@dataclass(frozen=True)
class Family:
    """Kernels compiled by one warm-up call: ``what`` they are (for the progress line),
    the ``modules`` that define them (``cardan_forces.`` left out) and ``warm``, the call
    that compiles them (or loads them from the cache).
    """

    what: str
    modules: tuple[str, ...]
    warm: Callable[[], None]


def _penalty() -> None:
    """One instant of ``paper-penalty``'s simulation (its first call compiles the BDF,
    the right-hand side and the Jacobian).
    """
    from cardan_forces.driveline import penalty

    scene = load_scene("paper-penalty")
    penalty.simulate_penalty(scene, [scene.time.start_s])


def _operator():
    """``paper``'s operator at its first two instants (the rigid simulation's kernels
    compile on the way).
    """
    from cardan_forces.driveline.dynamics import simulate
    from cardan_forces.driveline.equilibrium import build_operator

    scene = load_scene("paper")
    return build_operator(simulate(scene, scene.time.instants()[:2]))


def _batched() -> None:
    """Two instants of ``paper`` as one batch of the batched least norm, as the bench
    solves them.
    """
    from cardan_forces.formulations.batch import least_norm_batch
    from cardan_forces.solvers.registry import solve_batch

    solve_batch(least_norm_batch(_operator(), SELECTION, [0, 1]), "numpy-batched")


def _newton() -> None:
    """One instant of ``paper``'s selection by ``newton`` (every path of the family,
    per instant or batched, chained or not, calls the one compiled entry with the same
    types).
    """
    from cardan_forces.formulations import batch
    from cardan_forces.solvers import solve

    solve(batch.build_problems(_operator(), SELECTION, [0])[0], "newton")


def _reduced_ipm() -> None:
    """Two instants of ``paper``'s first physical cone program as one batch of the
    reduced-space interior point, as the bench solves them (every cone program calls
    the one compiled entry with the same types).
    """
    from cardan_forces.formulations import batch, where
    from cardan_forces.formulations.problems import Conic
    from cardan_forces.solvers.registry import solve_batch

    conic = where(problem=(Conic,), physical=True)[0]
    problems = batch.build_problems(_operator(), conic, [0, 1])
    solve_batch(batch.conic_batch(problems, [0, 1]), "reduced-ipm")


FAMILIES = (
    Family("the penalty simulation's kernels (a few minutes on a small machine)",
           ("driveline.harmonic", "driveline.penalty_bdf", "driveline.penalty_contact",
            "driveline.penalty_jacobian", "driveline.penalty_linear"), _penalty),
    Family("the rigid simulation's kernels", ("driveline.harmonic", "driveline.dynamics",
                                              "driveline.kinematics"), _operator),
    Family("the batched least-norm kernels", ("solvers._batched_kernels",), _batched),
    Family("the newton family's kernels (about a minute)",
           ("solvers._newton_kernels", "solvers._newton_linalg"), _newton),
    Family("the reduced interior point's kernels", ("solvers._reduced_ipm_kernels",),
           _reduced_ipm),
)
"""Every compiled kernel family of the package, in the order ``cardan compile`` runs
them."""


def add_parser(subparsers) -> None:
    """Register ``cardan compile``."""
    c = subparsers.add_parser(
        "compile", help="compile the numba kernels now (else the first run does, for minutes)")
    c.set_defaults(func=run)


def run(args) -> int:
    if not HAVE_NUMBA:
        progress("numba is not installed: nothing to compile (the NumPy paths run)")
        return 0
    for family in FAMILIES:
        progress(f"compiling {family.what}")
        family.warm()
    progress(f"done: every kernel family ({len(FAMILIES)}) is cached, in "
             f"{', '.join(cache_folders())}")
    return 0


def cache_folders() -> list[str]:
    """The folders numba caches the families' kernels in (one per source folder, or
    ``NUMBA_CACHE_DIR``).
    """
    found = []
    for name in dict.fromkeys(m for family in FAMILIES for m in family.modules):
        module = importlib.import_module(f"cardan_forces.{name}")
        for value in vars(module).values():
            index = getattr(getattr(getattr(value, "_cache", None), "_cache_file", None),
                            "_index_path", None)
            if index and str(Path(index).parent) not in found:
                found.append(str(Path(index).parent))
    return found or ["numba's cache folder"]
