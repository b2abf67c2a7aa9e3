"""qpbenchmark's four settings translated into each solver's own options.

qpbenchmark 2.7 (``SolverSettings`` and ``TestSet.define_solver_settings``) runs every
solver at four settings: ``default`` (the solver's own defaults, only a time limit
where the solver takes one), and ``low_accuracy``, ``mid_accuracy``, ``high_accuracy``
(absolute tolerance ``eps_abs`` = 1e-3, 1e-6, 1e-9 on every parameter the solver has for
it, relative tolerances set to 0, PIQP's and ProxQP's duality-gap check on). Each
solver's translation is one :class:`Profile` (:data:`PROFILES`, keyed by the solver's
qpsolvers name; the direct Clarabel backend uses Clarabel's), so the package's bench
runs a backend exactly as qpbenchmark would; :func:`options` gives a backend's keyword
arguments for a setting. The tolerance each setting is judged by is in
:data:`cardan_forces.solvers.qp_measures.SETTINGS`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from .qp_measures import SETTINGS


@dataclass(frozen=True)
class Profile:
    """How one solver takes qpbenchmark's settings: the parameters ``eps_abs`` sets,
    those the relative tolerance (0 outside ``default``) sets, fixed extra options of
    the non-default settings, and the name of its time-limit parameter (``""``: none).
    """

    eps_abs: tuple[str, ...] = ()
    eps_rel: tuple[str, ...] = ()
    extra: dict = field(default_factory=dict)
    time_limit: str = ""


PROFILES: dict[str, Profile] = {
    "clarabel": Profile(("tol_feas", "tol_gap_abs"), ("tol_gap_rel",)),
    "daqp": Profile(("dual_tol", "primal_tol")),
    "ecos": Profile(("feastol",)),
    "highs": Profile(("dual_feasibility_tolerance", "primal_feasibility_tolerance"),
                     time_limit="time_limit"),
    "osqp": Profile(("eps_abs",), ("eps_rel",), time_limit="time_limit"),
    "piqp": Profile(("eps_abs", "eps_duality_gap_abs"), ("eps_duality_gap_rel", "eps_rel"),
                    {"check_duality_gap": True}),
    "proxqp": Profile(("eps_abs", "eps_duality_gap_abs"), ("eps_duality_gap_rel", "eps_rel"),
                      {"check_duality_gap": True}),
    "quadprog": Profile(),
    "scs": Profile(("eps_abs",), ("eps_rel",), time_limit="time_limit_secs"),
}
"""qpbenchmark 2.7's ``set_eps_abs``, ``set_eps_rel``, ``set_param`` and
``set_time_limit`` for the solvers the package has (qpsolvers names)."""

BACKEND_SOLVER = {"clarabel": "clarabel"} | {f"qpsolvers-{name}": name for name in PROFILES}
"""The solver whose profile a backend takes."""


def options(backend: str, setting: str) -> dict:
    """The keyword arguments backend ``backend`` gets at qpbenchmark setting ``setting``
    (``KeyError`` for a backend without a profile or an unknown setting).
    """
    profile, chosen = PROFILES[BACKEND_SOLVER[backend]], SETTINGS[setting]
    out = {profile.time_limit: chosen.time_limit_s} if profile.time_limit else {}
    if chosen.eps_abs is None:
        return out
    return (out | dict.fromkeys(profile.eps_abs, chosen.eps_abs)
            | dict.fromkeys(profile.eps_rel, 0.0) | profile.extra)


def has_profile(backend: str) -> bool:
    """Whether ``backend`` declares how it takes qpbenchmark's settings."""
    return backend in BACKEND_SOLVER
