"""``cardan compile``: compile the numba kernels ahead of a first run.

numba compiles the package's kernels for the CPU it runs on, on their first call, and
caches them on disk (beside the modules, or in ``NUMBA_CACHE_DIR``). The first
``cardan repro`` would otherwise spend minutes compiling inside its first penalty
simulation; this command does that work up front, with the same calls, and says where
the cache is. Without the ``numba`` extra there is nothing to compile.
"""

from __future__ import annotations

from cardan_forces.commands import progress
from cardan_forces.driveline import penalty
from cardan_forces.driveline.compiled import HAVE_NUMBA
from cardan_forces.driveline.loading import load_scene
from cardan_forces.formulations import SELECTION


def add_parser(subparsers) -> None:
    """Register ``cardan compile``."""
    c = subparsers.add_parser(
        "compile", help="compile the numba kernels now (else the first run does, for minutes)")
    c.set_defaults(func=run)


def run(args) -> int:
    if not HAVE_NUMBA:
        progress("numba is not installed: nothing to compile (the NumPy paths run)")
        return 0
    scene = load_scene("paper-penalty")
    progress("compiling the penalty simulation's kernels (a few minutes on a small machine)")
    penalty.simulate_penalty(scene, [scene.time.start_s])
    progress("compiling the batched least-norm kernels")
    _batched()
    progress(f"done: the kernels are cached in {penalty.cache_folder()}")
    return 0


def _batched() -> None:
    """Solve two instants of ``paper`` as one batch with the batched backend (its first
    call compiles its kernels), as the bench does.
    """
    import cardan_forces as cf
    from cardan_forces.formulations.batch import least_norm_batch
    from cardan_forces.solvers.registry import solve_batch

    op = cf.build_operator(cf.simulate(load_scene("paper")))
    solve_batch(least_norm_batch(op, SELECTION, [0, 1]), "numpy-batched")
