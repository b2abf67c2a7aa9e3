"""qpbenchmark's four settings translated into each solver's own options.

qpbenchmark 2.7 (``SolverSettings`` and ``TestSet.define_solver_settings``) runs every
solver at four settings: ``default`` (the solver's own defaults, only a time limit
where the solver takes one), and ``low_accuracy``, ``mid_accuracy``, ``high_accuracy``
(absolute tolerance ``eps_abs`` = 1e-3, 1e-6, 1e-9 on every parameter the solver has for
it, relative tolerances set to 0, PIQP's and ProxQP's duality-gap check on). Each
solver's translation is one :class:`Profile`, declared by the backend itself beside its
tolerance parameters (``Backend.qpbenchmark``: ``qpsolvers_.PROFILES`` per qpsolvers
solver, :data:`CLARABEL` for the direct Clarabel backend and qpsolvers' alike, as
qpbenchmark declares them), so the package's bench runs a backend exactly as qpbenchmark would;
:func:`options` gives a backend's keyword arguments for a setting. The tolerance
each setting is judged by is in :data:`cardan_forces.solvers.qp_measures.SETTINGS`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from .qp_measures import SETTINGS


@dataclass(frozen=True)
class Profile:
    """How one solver takes qpbenchmark's settings: ``solver``, the qpbenchmark (qpsolvers)
    name whose settings these are; the parameters ``eps_abs`` sets, those the relative
    tolerance (0 outside ``default``) sets, fixed extra options of the non-default
    settings, and the name of its time-limit parameter (``""``: none).
    """

    solver: str
    eps_abs: tuple[str, ...] = ()
    eps_rel: tuple[str, ...] = ()
    extra: dict = field(default_factory=dict)
    time_limit: str = ""

    def options(self, setting: str) -> dict:
        """The solver's keyword arguments at qpbenchmark setting ``setting`` (``KeyError``
        for an unknown one): only the time limit at ``default`` (the solver's defaults).
        """
        chosen = SETTINGS[setting]
        out = {self.time_limit: chosen.time_limit_s} if self.time_limit else {}
        if chosen.eps_abs is None:
            return out
        return (out | dict.fromkeys(self.eps_abs, chosen.eps_abs)
                | dict.fromkeys(self.eps_rel, 0.0) | self.extra)


CLARABEL = Profile("clarabel", ("tol_feas", "tol_gap_abs"), ("tol_gap_rel",))
"""How Clarabel takes qpbenchmark's four settings (qpbenchmark 2.7's for ``clarabel``),
through its own API (``clarabel``) or through qpsolvers (``qpsolvers-clarabel``)."""


def profile(backend: str) -> Profile | None:
    """The profile backend ``backend`` declares (its ``Backend.qpbenchmark``), ``None``
    for one without, or not installed.
    """
    from .registry import SolverNotFound, get

    try:
        return get(backend).qpbenchmark
    except SolverNotFound:
        return None


def options(backend: str, setting: str) -> dict:
    """The keyword arguments backend ``backend`` gets at qpbenchmark setting ``setting``
    (``KeyError`` for a backend without a profile or an unknown setting).
    """
    found = profile(backend)
    if found is None:
        raise KeyError(f"backend {backend!r} declares no qpbenchmark settings")
    return found.options(setting)


def has_profile(backend: str) -> bool:
    """Whether ``backend`` declares how it takes qpbenchmark's settings."""
    return profile(backend) is not None
