"""``cardan solve``: every formulation x every backend (or those asked for) at one
instant: status, residuals, optimality, time.
"""

from __future__ import annotations

import argparse
import math

from cardan_forces.driveline.dynamics import simulate
from cardan_forces.driveline.equilibrium import build_operator
from cardan_forces.driveline.loading import load_scene
from cardan_forces.experiments.analysis import build_all, solve_all
from cardan_forces.experiments.environment import number_text
from cardan_forces.formulations import FORMULATIONS
from cardan_forces.formulations.convex import NotApplicable
from cardan_forces.solvers import Residuals, backends_for
from cardan_forces.solvers import get as get_backend
from cardan_forces.solvers.record import ACCEPT, Status

from . import UsageError, check_time, formulation_name, print_json, progress
from .solvers import say_plugin_errors

OPTIMALITY = ("dual", "gap", "distance")
ENGINE = ("engine: MuJoCo is a forward simulation from the scene's start, not a formulation "
          "solved at one instant; run 'cardan engine SCENE' or 'cardan repro --methods "
          "...,engine'")
"""Why ``engine`` is no ``--formulation`` or ``--solver`` here: its forces at ``t``
depend on the motion it integrated up to ``t`` and its constraints' softness, and the
table's measures (sign, complementarity, duality) are a solver's, not an engine's."""


def add_parser(subparsers) -> None:
    """Register ``cardan solve``."""
    so = subparsers.add_parser("solve", help="formulations x solvers at one instant")
    so.add_argument("scene", nargs="?", default="paper", help="built-in name or TOML path")
    so.add_argument("--t", type=float, default=0.5, help="instant in s (default 0.5)")
    so.add_argument("--formulation", action="append",
                    type=_formulation,
                    choices=list(FORMULATIONS), help="one formulation (repeatable); default all")
    so.add_argument("--solver", action="append", type=_not_engine,
                    help="one backend (repeatable); default all")
    so.add_argument("--tol", type=float, default=None,
                    help="one tolerance for every solver (default: each solver's own)")
    so.add_argument("--json", action="store_true", help="print JSON records")
    so.set_defaults(func=run)


def run(args) -> int:
    scene = load_scene(args.scene)
    check_time(scene, args.t)
    for name in args.solver or ():
        get_backend(name)  # unknown or absent backend: a clear error before any work
    op = build_operator(simulate(scene, [args.t]))
    built = build_all(op, 0, args.formulation or FORMULATIONS)
    refused = [p for p in built.values() if isinstance(p, NotApplicable)]
    if args.formulation and refused:
        raise refused[0]  # one the scene does not call for: said before any work
    _check_pairs(built, args.formulation, args.solver)
    records = solve_all(op, 0, args.formulation, args.solver, tol=args.tol,
                        progress=None if args.json else progress, built=built)
    say_plugin_errors("solve")  # a plugin left out says so: its rows are missing
    if args.json:
        print_json([record_json(r) for r in records])
        return 0
    print_table(scene.name, args.t, records)
    grouped: dict[str, list[str]] = {}
    for name, why in left_out(built, args.solver):
        grouped.setdefault(why, []).append(name)
    for why, names in grouped.items():
        print(f"left out: {', '.join(names)}: {why}")
    return 0


def print_table(scene: str, t: float, records) -> None:
    """One line per record: status, residuals, optimality, time and, where the status
    is not ``solved``, why (:func:`reason`).
    """
    print(f"scene {scene}, t = {t:g} s; residuals relative to ||b||; dual = "
          "stationarity with the solver's (or recovered) multipliers; gap = duality or "
          "objective gap; dist = distance to the formulation's clarabel answer at tol 1e-10, "
          f"only where the optimum is unique; '-' = undefined; why = what kept a record "
          f"from 'solved' (a residual, dual or gap above {ACCEPT:g}, or the solver's own "
          "word)")
    print(f"{'formulation':16s} {'solver':22s} {'status':10s} {'equil':>8s} {'sign':>8s} "
          f"{'compl':>8s} {'cone':>8s} {'dual':>8s} {'gap':>8s} {'dist':>8s} {'ms':>8s}  why")
    for r in records:
        res = [r.residuals.get(k, math.nan) for k in Residuals.KEYS]
        res += [r.optimality.get(k, math.nan) for k in OPTIMALITY]
        print(f"{r.formulation:16s} {r.solver:22s} {str(r.status):10s} "
              + " ".join(number_text(v, "8.1e") for v in res)
              + f" {1e3 * (r.setup_s + r.solve_s):8.2f}  {reason(r)}".rstrip())


def reason(record, width: int = 60) -> str:
    """Why a record is not ``solved``, in one short line ("" when it is): its first
    checked residual, else its dual residual or gap, above :data:`ACCEPT` (the
    package's rule that makes an answer ``inaccurate``), else the solver's own status
    and message.
    """
    if record.status is Status.SOLVED:
        return ""
    measured = {**{k: record.residuals.get(k, math.nan) for k in Residuals.KEYS},
                **{k: record.optimality.get(k, math.nan) for k in ("dual", "gap")}}
    failed = [k for k, value in measured.items() if value > ACCEPT]
    if record.status.has_answer and failed:
        return f"{failed[0]} {measured[failed[0]]:.1e} > {ACCEPT:g}"
    said = record.solver_status if record.solver_status is not None else record.status
    words = " ".join(str(record.message).split())
    text = f"solver: {said}" + (f": {words}" if words else "")
    return text if len(text) <= width else text[: width - 3] + "..."


def left_out(built: dict, solvers) -> list[tuple[str, str]]:
    """The formulations a run left out, each with why: one the scene does not call for
    (its builder's :class:`NotApplicable` message) or one no solver asked for takes
    (``built``: :func:`~.analysis.build_all` of the formulations asked for).
    """
    out = []
    for name, problem in built.items():
        if isinstance(problem, NotApplicable):
            out.append((name, " ".join(str(problem).split())))
            continue
        if solvers and not set(solvers) & set(backends_for(problem)):
            out.append((name, f"no solver asked for ({', '.join(solvers)}) takes it"))
    return out


def _not_engine(text: str) -> str:
    """An argument type that refuses ``engine`` in words (:data:`ENGINE`)."""
    if text == "engine":
        raise argparse.ArgumentTypeError(ENGINE)
    return text


def _formulation(text: str) -> str:
    """An argument type: a formulation's name (:func:`formulation_name`), ``engine``
    refused in words (:func:`_not_engine`).
    """
    return formulation_name(_not_engine(text))


def _check_pairs(built: dict, formulations, solvers) -> None:
    """Every solver asked for takes every formulation asked for (else a
    :class:`UsageError` naming the solvers that can); with no formulation named, the
    solvers must take at least one of the scene's (``built``: the problems,
    :func:`~.analysis.build_all`; a formulation asked for and refused is already an
    error).
    """
    if not solvers:
        return
    usable = {name: backends_for(problem) for name, problem in built.items()
              if not isinstance(problem, NotApplicable)}
    if formulations:
        bad = [f"{f} with {', '.join(s for s in solvers if s not in usable[f])} (solvers "
               f"that take it: {', '.join(usable[f]) or 'none installed'})"
               for f in formulations if set(solvers) - set(usable[f])]
        if bad:
            raise UsageError(f"a solver cannot take the formulation: {'; '.join(bad)}")
    elif not any(s in u for s in solvers for u in usable.values()):
        raise UsageError(f"{', '.join(solvers)} takes none of this scene's formulations; "
                         + "; ".join(f"{f}: {', '.join(u)}" for f, u in usable.items()))


def record_json(record) -> dict:
    """A record as the README's ``solve --json`` object: its own fields, with its
    numbers as numbers (the encoder writes the non-finite ones as null).
    """
    return {**record.to_json(),
            "residuals": dict(record.residuals), "forces": record.forces(),
            "setup_s": record.setup_s, "solve_s": record.solve_s,
            "optimality": dict(record.optimality)}

