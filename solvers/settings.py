"""Solver settings, in one place: a tolerance in each solver's own parameter names, and
qpbenchmark's four settings in the same names.

Two ways a solve asks for accuracy, both translated here and nowhere else (adapters read
their names from this module, ``Backend.tolerances`` and ``Backend.qpbenchmark``):

- a tolerance ``tol`` (``solve(..., tol=...)``, the bench's ladder): :data:`TOLERANCES`
  names, per solver, the parameters it sets; :func:`options_for` sets each to ``tol``,
  raised to the least value the solver accepts (:data:`SMALLEST`). ``tol=None`` means
  the solver's defaults: nothing is set. Direct methods (SVD, quadprog, Lemke) have no
  such parameter; ``tol`` is ignored for them.
- qpbenchmark 2.7's settings (``SolverSettings`` and ``TestSet.define_solver_settings``,
  :data:`SETTINGS`): ``default`` (the solver's own defaults, only a time limit where the
  solver takes one), and ``low_accuracy``, ``mid_accuracy``, ``high_accuracy`` (absolute
  tolerance ``eps_abs`` = 1e-3, 1e-6, 1e-9 on every parameter the solver has for it,
  relative tolerances set to 0, PIQP's and ProxQP's duality-gap check on). Each solver's
  translation is one :class:`Profile` (:data:`PROFILES`, as qpbenchmark declares them),
  so the package's bench runs a backend exactly as qpbenchmark would;
  :func:`~.registry.qpbenchmark_options` gives a backend's keyword arguments for a
  setting.

Besides these, an adapter changes no numerical default: it quiets the solver's output and
gives the solvers of :data:`TIME_LIMITED` the wall-time guard :data:`TIME_LIMIT_S`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

_CLARABEL = ("tol_gap_abs", "tol_gap_rel", "tol_feas")
_QOCO = ("abstol", "reltol")

TOLERANCES: dict[str, tuple[str, ...]] = {
    "clarabel": _CLARABEL,
    "moreau": _CLARABEL,
    "qoco": _QOCO,
    "qocogen": _QOCO,
    "daqp": ("primal_tol",),
    "ecos": ("abstol", "reltol", "feastol"),
    "highs": ("primal_feasibility_tolerance", "dual_feasibility_tolerance"),
    "osqp": ("eps_abs", "eps_rel"),
    "piqp": ("eps_abs", "eps_rel"),
    "proxqp": ("eps_abs",),
    "quadprog": (),
    "scs": ("eps_abs", "eps_rel"),
    "lsq_linear": ("tol",),
    "fsolve": ("xtol",),
    "root-lm": ("xtol", "ftol"),
    "lemke": (),
    "pgs": ("tol",),
    "fb-newton": ("tol",),
    "newton": ("tol",),
    "reduced-ipm": ("tol",),
}
"""Each solver's own parameters a requested tolerance sets, by the solver's name (the
same names whichever package passes them on: Clarabel's through cvxpy, qpsolvers or its
own API; HiGHS's through qpsolvers or ``scipy.optimize.linprog``). moreau is Clarabel's
algorithm and takes its names; ``()``: a direct method."""

SMALLEST: dict[str, float] = {"highs": 1e-10, "newton": 1e-15}
"""The least tolerance a solver is given, a smaller requested one raised to it (HiGHS
rejects smaller ones; the Newton family's relative stopping rule is kept at 1e-15 or
above); 0 for the others."""

TIME_LIMIT_S = 20.0
"""Wall-time limit of one solve for solvers whose own iteration limit does not bound the
time (HiGHS's QP ran for minutes on one near-90-degree instant): the adapter passes it
as the solver's own time limit, so a stalled solve ends as a failed record, never a
hang. Options given to a solve override it."""

TIME_LIMITED = ("highs",)
"""Solvers given :data:`TIME_LIMIT_S` (through their profile's time-limit parameter)."""

TIKHONOV_DEFAULT = 1e-10
"""Relative Tikhonov weight of ``scipy-lsq_linear`` when no ``tol`` is given."""

REFERENCE_TOL = 1e-10
"""The tolerance a reference answer by Clarabel is asked for (``cardan solve``'s
reference, the bench's conic references): two decades below the bench's finest judged
level (1e-8), so the reference's own error does not count against the answer judged."""


def options_for(parameters: tuple[str, ...], tol: float | None,
                smallest: float = 0.0) -> dict[str, float]:
    """``{parameter: tol}`` for each of ``parameters`` (empty when ``tol`` is None);
    ``smallest``: the least value the solver accepts (HiGHS rejects smaller ones).
    """
    if tol is None:
        return {}
    return dict.fromkeys(parameters, max(float(tol), smallest))


def solver_options(solver: str, tol: float | None) -> dict[str, float]:
    """:func:`options_for` solver ``solver``'s :data:`TOLERANCES` (none for a solver
    without an entry), raised to its :data:`SMALLEST`.
    """
    return options_for(TOLERANCES.get(solver, ()), tol, SMALLEST.get(solver, 0.0))


def time_limit(solver: str) -> dict[str, float]:
    """``{its time-limit parameter: TIME_LIMIT_S}`` for a solver of :data:`TIME_LIMITED`,
    else empty.
    """
    return {PROFILES[solver].time_limit: TIME_LIMIT_S} if solver in TIME_LIMITED else {}


def tikhonov_weight(tol: float | None) -> float:
    """Relative weight ``mu / sigma_max^2`` of the penalty in ``scipy-lsq_linear``.

    The penalty biases the answer by about ``mu`` relative to the squared singular values
    of the (scaled) equilibrium matrix, so the weight follows the requested tolerance.
    """
    return TIKHONOV_DEFAULT if tol is None else float(tol)


@dataclass(frozen=True)
class Setting:
    """One of qpbenchmark's solver settings: the absolute tolerance it asks of the
    solver (``None``: the solver's defaults), the tolerance it judges primal, dual and
    gap by (strictly below: qpbenchmark's success rule), and the time limit (s) given
    to solvers that take one and counted for a run the solver reports as not found.
    """

    name: str
    eps_abs: float | None
    tolerance: float
    time_limit_s: float


QPBENCHMARK_TIME_LIMIT_S = 10.0
"""qpbenchmark's time limit per solve (``TestSet.define_tolerances(runtime=10.0)``)."""

SETTINGS = {s.name: s for s in (
    Setting("default", None, 1.0, QPBENCHMARK_TIME_LIMIT_S),
    Setting("low_accuracy", 1e-3, 1e-3, QPBENCHMARK_TIME_LIMIT_S),
    Setting("mid_accuracy", 1e-6, 1e-6, QPBENCHMARK_TIME_LIMIT_S),
    Setting("high_accuracy", 1e-9, 1e-9, QPBENCHMARK_TIME_LIMIT_S),
)}
"""qpbenchmark 2.7's four settings (``TestSet.define_solver_settings`` and
``define_tolerances``); ``default`` judges at 1, its other settings at their ``eps_abs``."""


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


PROFILES: dict[str, Profile] = {p.solver: p for p in (
    Profile("clarabel", ("tol_feas", "tol_gap_abs"), ("tol_gap_rel",)),
    Profile("daqp", ("dual_tol", "primal_tol")),
    Profile("ecos", ("feastol",)),
    Profile("highs", ("dual_feasibility_tolerance", "primal_feasibility_tolerance"),
            time_limit="time_limit"),
    Profile("osqp", ("eps_abs",), ("eps_rel",), time_limit="time_limit"),
    Profile("piqp", ("eps_abs", "eps_duality_gap_abs"), ("eps_duality_gap_rel", "eps_rel"),
            {"check_duality_gap": True}),
    Profile("proxqp", ("eps_abs", "eps_duality_gap_abs"), ("eps_duality_gap_rel", "eps_rel"),
            {"check_duality_gap": True}),
    Profile("quadprog"),
    Profile("scs", ("eps_abs",), ("eps_rel",), time_limit="time_limit_secs"),
)}
"""How each solver takes qpbenchmark's four settings, by its qpbenchmark name:
qpbenchmark 2.7's ``set_eps_abs``, ``set_eps_rel``, ``set_param`` and ``set_time_limit``
for it. The qpsolvers backends declare their solver's; ``clarabel`` declares Clarabel's,
as qpbenchmark runs it through qpsolvers."""
