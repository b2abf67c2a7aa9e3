"""A backend's declaration: :class:`Backend`, the record an adapter module (or another
package's plugin) fills in to say what it solves, on which installed distributions,
with which settings, and how; the registry (:mod:`.registry`) holds and dispatches
them. Kept apart from the registry so that adapters, which only declare, import
downward.
"""

from __future__ import annotations

import importlib.metadata
from collections.abc import Callable
from dataclasses import dataclass

from . import settings
from .record import Outcome


def _always(problem) -> bool:
    return True


@dataclass(frozen=True, kw_only=True)
class Backend:
    """One named way to solve problems, and what it declares about itself.

    ``solve(problem, tol, initvals, **options) -> Outcome`` receives a problem of one of
    the ``accepts`` classes for which ``supports(problem)`` holds (e.g. no power cone
    for ECOS); ``None`` for a backend that only batches. ``distributions`` are the
    installed distributions it runs on (its version), ``extra`` the pip extra that
    installs it (``None``: core dependency). ``tolerances`` are the solver's own
    parameters a requested tolerance sets (empty: a direct method, ``tol`` ignored),
    clamped below at ``smallest_tol``; ``warm_start`` whether ``initvals`` reach the
    solver; ``batch(batch, tol, **options) -> BatchOutcome`` solves all instants of a
    formulation's batch of one of the ``batch_accepts`` classes at once.
    ``qpbenchmark``: how it takes qpbenchmark's four settings (:class:`.settings.Profile`;
    ``None``: it does not). ``reducible``: a conic backend that also runs on the reduced
    form (equality rows eliminated), registered as ``<name>-reduced`` beside it
    (:func:`.reduced_.variant`); ``reduced_only``: registered only so (a backend made
    for the reduced form); ``unscaled``: the cone kinds on which its reduced variant
    runs without equilibration.
    """

    name: str
    family: str
    distributions: tuple[str, ...]
    extra: str | None = None
    accepts: tuple[type, ...] = ()
    solve: Callable[..., Outcome] | None = None
    supports: Callable[[object], bool] = _always
    tolerances: tuple[str, ...] = ()
    smallest_tol: float = 0.0
    warm_start: bool = False
    batch: Callable | None = None
    batch_accepts: tuple[type, ...] = ()
    qpbenchmark: settings.Profile | None = None
    reducible: bool = False
    reduced_only: bool = False
    unscaled: tuple[str, ...] = ()

    @property
    def version(self) -> str:
        """``"name version"`` of its distributions, joined by ``" + "``."""
        return dist_version(*self.distributions)

    def options(self, tol: float | None) -> dict[str, float]:
        """The solver's own keyword arguments for tolerance ``tol`` (none for ``None``)."""
        return settings.options_for(self.tolerances, tol, self.smallest_tol)


def dist_version(*dists: str) -> str:
    """``"name version"`` of installed distributions, joined by ``" + "``."""
    parts = []
    for dist in dists:
        try:
            parts.append(f"{dist} {importlib.metadata.version(dist)}")
        except importlib.metadata.PackageNotFoundError:
            parts.append(f"{dist} ?")
    return " + ".join(parts)
