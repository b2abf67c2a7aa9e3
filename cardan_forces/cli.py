"""The ``cardan`` command line.

Subcommands: ``scene`` (list, show, dump, check), ``sets`` (rank, null space,
determinacy and intervals of the contact forces at one instant), ``solvers`` (the
backends present), ``solve`` (formulations x solvers at one instant), ``repro`` (the
paper's figures), ``bench`` (throughput and accuracy vs time), ``hard`` (the hard-case
stability suite).
``sweep`` (parameter studies, local processes or Dask; resumable CSV).

Errors in the user's input (scene or arguments) end with one line ``cardan: error:
...`` on stderr and exit code 2, before any work; Ctrl-C ends a run with one line and
exit code 130. With ``--json`` stdout carries strict JSON and nothing else: numbers
that are not finite become ``null`` (the records' ``status`` says why), and whatever a
solver library writes on file descriptor 1 (HiGHS's banner) goes to stderr.
"""

from __future__ import annotations

import argparse
import contextlib
import ctypes
import dataclasses
import io
import json
import math
import os
import sys
import threading
import time
from pathlib import Path

import numpy as np

from cardan_forces.driveline.determinacy import DETERMINATE_TOL, determinacy
from cardan_forces.driveline.dynamics import DynamicsError, simulate
from cardan_forces.driveline.equilibrium import build_operator
from cardan_forces.driveline.loading import builtin_names, builtin_text, load_scene
from cardan_forces.driveline.release import (
    advise,
    named_modes,
    parse_release,
    released_operator,
)
from cardan_forces.driveline.scene import (
    LIMITS,
    MAX_ARTICULATION_DEG,
    MAX_INSTANTS,
    SceneError,
)
from cardan_forces.experiments import bench, hard, report, secondary, sweep
from cardan_forces.experiments.analysis import intervals, solve_all
from cardan_forces.experiments.environment import number_text
from cardan_forces.experiments.paper_method import multistart
from cardan_forces.formulations import FORMULATIONS
from cardan_forces.formulations.convex import NotApplicable
from cardan_forces.solvers import SolverNotFound, available
from cardan_forces.solvers import get as get_backend
from cardan_forces.solvers.registry import known_backends

FIGURES = (11, 12, 13, 14, 15)

HEARTBEAT_S = 30.0
"""A run still going after this many seconds says so on stderr, and again every as many."""

ARGUMENTS = (
    # attribute, flag, least, most, least allowed (else: above least)
    ("t", "--t", 0.0, LIMITS["time_s"][1], True),
    ("tol", "--tol", 0.0, 1.0, False),
    ("multistart", "--multistart", 0, 1000, True),
    ("instants", "--instants", 1, MAX_INSTANTS, True),
    ("stop", "--stop", 0.0, LIMITS["time_s"][1], False),
    ("workers", "--workers", 1, 1024, True),
    ("timeout", "--timeout", 0.0, 1e5, False),
)
"""Ranges of the numeric options, checked before any work (whichever command has them)."""


class UsageError(ValueError):
    """A command-line request that cannot be carried out (exit code 2)."""


class _Parser(argparse.ArgumentParser):
    """An argument parser whose errors are :class:`UsageError` (one line, exit code 2)."""

    def error(self, message: str):
        raise UsageError(f"{message} (see '{self.prog} --help')")


def _progress(message: str) -> None:
    print(message, file=sys.stderr, flush=True)


# ---------------------------------------------------------------------------- scene


def _cmd_scene(args) -> int:
    if args.action == "list":
        for name in builtin_names():
            print(f"{name:20s} {load_scene(name).description}")
    elif args.action == "dump":
        load_scene(args.name)  # a file that is no scene (binary, a folder): a clear error
        print(builtin_text(args.name) if args.name in builtin_names()
              else Path(args.name).read_text(encoding="utf-8-sig"), end="")
    else:
        scene = load_scene(args.name)
        if args.action == "check":
            print(f"{scene.source}: ok ({len(scene.shafts)} shafts, {len(scene.joints)} joints, "
                  f"{len(scene.time.instants())} instants, effects: "
                  f"{', '.join(sorted(scene.effects))})")
        else:
            _show(scene)
    return 0


def _show(scene) -> None:
    print(f"scene {scene.name}: {scene.description}")
    print(f"  source       {scene.source}")
    print(f"  effects      {', '.join(sorted(scene.effects))}")
    print(f"  arrangement  {scene.arrangement}, gravity {scene.gravity_m_s2} m/s^2")
    for s in scene.shafts:
        bearings = ", ".join(f"{b.name} @ {b.offset_m:+g} m ({b.kind})"
                             for b in s.bearings) or "none"
        print(f"  shaft {s.name:13s} L={s.length_m} m  m={s.mass_kg} kg  "
              f"J={s.inertia_kg_m2} kg m^2  bearings: {bearings}")
    for j in scene.joints:
        print(f"  joint {j.name:13s} articulation {j.articulation_deg} deg, yoke phase "
              f"{j.yoke_phase_deg} deg, clearance radial {j.radial_clearance_m:.3g} m, "
              f"axial {j.axial_clearance_m:.3g} m")
    for slip in scene.slip_joints:
        print(f"  slip joint {slip.name:8s} in shaft {slip.shaft} @ {slip.offset_m:+g} m, pitch "
              f"radius {slip.pitch_radius_m} m, friction {slip.friction_coefficient}")
    tq = scene.input_torque
    print(f"  input torque {tq.mean_N_m:+g} {tq.amplitude_N_m:+g} cos(2 pi {tq.frequency_hz:g} t"
          f" + {tq.phase_rad:g}) N m")
    g = scene.time
    print(f"  time         {g.start_s} .. {g.stop_s} s every {g.step_s} s "
          f"({len(g.instants())} instants)")


# ---------------------------------------------------------------------------- sets


def _check_time(scene, t: float) -> None:
    if not scene.time.start_s <= t <= scene.time.stop_s:
        raise UsageError(
            f"--t {t}: outside the scene's time span [{scene.time.start_s}, "
            f"{scene.time.stop_s}] s"
        )


def _cmd_sets(args) -> int:
    scene = load_scene(args.scene)
    _check_time(scene, args.t)
    motion = simulate(scene, [args.t])
    if args.release:
        return _cmd_release(args, motion)
    op = _released(motion, args.apply)
    result = determinacy(op, 0)
    ranges = intervals(op, 0)
    modes = named_modes(op_motion(motion, op), 0, op)
    starts = multistart(op, 0, n=args.multistart, rim=False)[:, : len(op.names)] \
        if args.multistart else None
    if args.json:
        report = result.to_json()
        for j, (name, entry) in enumerate(report["components"].items()):
            entry.update(min=ranges[name]["min"], max=ranges[name]["max"])
            if starts is not None:
                entry["paper_multistart"] = [float(v) for v in starts[:, j]]
        report["modes"] = [m.to_json() for m in modes]
        print(json.dumps(report, indent=2))
        return 0
    _print_sets(op.scene.name, result, ranges, starts, args.multistart)
    _print_modes(modes)
    return 0


def _print_sets(name, result, ranges, starts=None, n_starts=0) -> None:
    print(f"scene {name}, t = {result.t:g} s: rank {result.rank}, nullity "
          f"{result.nullity}, least-norm residual {result.residual:.1e}")
    print(f"determinate: null-space row norm < {DETERMINATE_TOL:g}; least-norm values in N, "
          "N m for a slip joint's bending and torque (one member of the solution set where "
          "not determinate); interval over all solutions with end faces >= 0 (-inf/+inf: "
          "unbounded)")
    width = max(24, *(len(n) for n in result.names))
    print(f"{'component':{width}s} {'determinate':>11s} {'least-norm N':>14s} {'min N':>12s} "
          f"{'max N':>12s}")
    if starts is not None:
        print(f"paper method (fsolve, end faces on the axis) from {n_starts} random "
              f"starts: {len(starts)} converged; their spread per component at the right")
    for j, (name, det, value) in enumerate(zip(result.names, result.determinate,
                                               result.min_norm)):
        lo, hi = ranges[name]["min"], ranges[name]["max"]
        lo = "-inf" if lo is None else f"{lo:.4f}"
        hi = "+inf" if hi is None else f"{hi:.4f}"
        spread = "" if starts is None or not len(starts) else \
            f"  paper: [{starts[:, j].min():.3f}, {starts[:, j].max():.3f}]"
        print(f"{name:{width}s} {'yes' if det else 'no':>11s} {value:14.4f} {lo:>12s} {hi:>12s}"
              f"{spread}")


# ---------------------------------------------------------------------------- modes, releases


def op_motion(motion, op):
    """The motion with the operator's (possibly released) scene."""
    return dataclasses.replace(motion, scene=op.scene)


def _released(motion, labels):
    """The operator of ``motion``'s scene with the ``--apply`` releases (SceneError if
    they leave a mechanism).
    """
    if not labels:
        return build_operator(motion)
    releases = [parse_release(text, motion.scene) for text in labels]
    return released_operator(motion, releases)


def _print_modes(modes) -> None:
    print(f"modes (null-space directions): {len(modes)}")
    for k, m in enumerate(modes, 1):
        print(f"  {k}. {m.kind}: {m.description}")
        shown = ", ".join(m.components[:6]) + (" ..." if len(m.components) > 6 else "")
        print(f"     moves {shown}; release: {m.release}")


def _cmd_release(args, motion) -> int:
    """``cardan sets --release``: the advisor's release set and the released table."""
    advice = advise(motion, 0)
    ranges = intervals(advice.operator, 0)
    if args.json:
        report = advice.to_json()
        report["modes"] = [m.to_json() for m in advice.modes]
        released = advice.released.to_json()
        for name, entry in released["components"].items():
            entry.update(min=ranges[name]["min"], max=ranges[name]["max"])
        released["modes"] = [m.to_json() for m in advice.released_modes]
        report["released"] = released
        print(json.dumps(report, indent=2))
        return 0
    _print_modes(advice.modes)
    words = "; ".join(r.words for r in advice.releases) or "none: only end-face pair modes"
    print(f"release advisor: {len(advice.releases)} release(s): {words}")
    print(f"  ({len(advice.alternatives)} other set(s) of the same size also work; "
          f"{advice.tried} set(s) built and checked by determinacy)")
    if advice.releases:
        print(f"  as --apply: {' '.join('--apply ' + r.label for r in advice.releases)}")
    print()
    _print_sets(advice.scene.name, advice.released, ranges)
    _print_modes(advice.released_modes)
    return 0


# ---------------------------------------------------------------------------- solvers


def _cmd_solvers(args) -> int:
    backends = available()
    if args.json:
        print(json.dumps([{"name": b.name, "family": b.family, "version": b.version,
                           "classes": [c.__name__ for c in b.accepts], "extra": b.extra}
                          for b in backends.values()], indent=2))
        return 0
    for b in backends.values():
        print(f"{b.name:22s} {'/'.join(c.__name__ for c in b.accepts):18s} {b.version}")
    missing = sorted(set(known_backends()) - set(backends))
    for name in missing:
        extra = known_backends()[name]
        target = "cardan-forces" if extra is None else f"cardan-forces[{extra}]"
        print(f"{name:22s} absent: pip install \"{target}\"")
    return 0


def _cmd_solve(args) -> int:
    scene = load_scene(args.scene)
    _check_time(scene, args.t)
    for name in args.solver or ():
        get_backend(name)  # unknown or absent backend: a clear error before any work
    op = build_operator(simulate(scene, [args.t]))
    records = solve_all(op, 0, args.formulation, args.solver, tol=args.tol,
                        progress=None if args.json else _progress)
    if args.json:
        print(json.dumps([r.to_json() for r in records], indent=2))
        return 0
    print(f"scene {scene.name}, t = {args.t:g} s; residuals relative to ||b||; dual = "
          "stationarity with the solver's (or recovered) multipliers; gap = duality or "
          "objective gap; dist = distance to the formulation's clarabel answer at tol 1e-10, "
          "only where the optimum is unique; '-' = undefined")
    print(f"{'formulation':16s} {'solver':22s} {'status':10s} {'equil':>8s} {'sign':>8s} "
          f"{'compl':>8s} {'cone':>8s} {'dual':>8s} {'gap':>8s} {'dist':>8s} {'ms':>8s}")
    for r in records:
        res = [r.residuals.get(k, math.nan) for k in ("equilibrium", "sign", "complementarity",
                                                     "cone")]
        res += [r.optimality.get(k, math.nan) for k in ("dual", "gap", "distance")]
        print(f"{r.formulation:16s} {r.solver:22s} {r.status:10s} "
              + " ".join(number_text(v, "8.1e") for v in res)
              + f" {1e3 * (r.setup_s + r.solve_s):8.2f}")
    return 0


# ---------------------------------------------------------------------------- repro


def _check_paper_layout(spec: str) -> None:
    """``cardan repro`` draws the paper's quantities by name: refuse a scene without the
    paper's layout (three shafts, the first ``input`` with bearings ``far`` and ``near``,
    the first joint ``uj1``) before any work.
    """
    scene = load_scene(spec)
    missing = []
    if len(scene.shafts) != 3:
        missing.append(f"three shafts (it has {len(scene.shafts)})")
    first = scene.shafts[0]
    if first.name != "input":
        missing.append(f"a first shaft named 'input' (it is {first.name!r})")
    absent = sorted({"far", "near"} - {b.name for b in first.bearings})
    if absent:
        missing.append(f"bearings {' and '.join(map(repr, absent))} on the first shaft")
    if scene.joints[0].name != "uj1":
        missing.append(f"a first joint named 'uj1' (it is {scene.joints[0].name!r})")
    if missing:
        raise UsageError(f"scene {scene.source}: cardan repro needs the paper's layout; "
                         f"missing: {'; '.join(missing)}")


def _cmd_repro(args) -> int:
    from cardan_forces.paper_repro.repro import FIGURES, run_repro

    _check_paper_layout(args.scene)
    if 15 in (args.fig or FIGURES):
        _check_paper_layout(args.fig15_scene)
    run_repro(args.scene, sorted(set(args.fig or FIGURES)), args.out, args.quick,
              args.fig15_scene, progress=_progress, penalty=args.penalty)
    return 0


# ---------------------------------------------------------------------------- main


def _parser() -> argparse.ArgumentParser:
    p = _Parser(
        prog="cardan",
        description="Reaction forces in drive shafts with two Cardan joints.",
    )
    sub = p.add_subparsers(dest="command", required=True)

    sc = sub.add_parser("scene", help="list, show, dump or check scenes")
    sc_sub = sc.add_subparsers(dest="action", required=True)
    sc_sub.add_parser("list", help="built-in scenes")
    for action, text in (("show", "a scene's contents"), ("dump", "a scene's TOML text"),
                         ("check", "validate a scene file")):
        a = sc_sub.add_parser(action, help=text)
        a.add_argument("name", help="built-in name or TOML path")
    sc.set_defaults(func=_cmd_scene)

    st = sub.add_parser("sets", help="rank, null space and determinacy at one instant")
    st.add_argument("scene", nargs="?", default="paper", help="built-in name or TOML path")
    st.add_argument("--t", type=float, default=0.5, help="instant in s (default 0.5)")
    st.add_argument("--json", action="store_true", help="print JSON")
    st.add_argument("--multistart", type=int, default=0, metavar="N",
                    help="also run the paper's method from N seeded random starts")
    st.add_argument("--release", action="store_true",
                    help="propose the smallest set of releases (floating bearings, slip "
                         "joints) that leaves only end-face pair modes; show the released "
                         "line's table")
    st.add_argument("--apply", action="append", metavar="RELEASE",
                    help="apply a release first: float:<shaft>.<bearing> or slip:<shaft> "
                         "(repeatable)")
    st.set_defaults(func=_cmd_sets)

    sv = sub.add_parser("solvers", help="solver backends present, with their problem classes")
    sv.add_argument("--json", action="store_true", help="print JSON")
    sv.set_defaults(func=_cmd_solvers)

    so = sub.add_parser("solve", help="formulations x solvers at one instant")
    so.add_argument("scene", nargs="?", default="paper", help="built-in name or TOML path")
    so.add_argument("--t", type=float, default=0.5, help="instant in s (default 0.5)")
    so.add_argument("--formulation", action="append", choices=list(FORMULATIONS),
                    help="one formulation (repeatable); default all")
    so.add_argument("--solver", action="append", help="one backend (repeatable); default all")
    so.add_argument("--tol", type=float, default=None,
                    help="one tolerance for every solver (default: each solver's own)")
    so.add_argument("--json", action="store_true", help="print JSON records")
    so.set_defaults(func=_cmd_solve)

    rp = sub.add_parser("repro", help="reproduce the paper's figures (CSV + PNG)")
    rp.add_argument("scene", nargs="?", default="paper", help="built-in name or TOML path")
    rp.add_argument("--fig", type=int, action="append", choices=FIGURES,
                    help="one figure (repeatable); default all")
    rp.add_argument("--out", default="results", help="output folder (default results/)")
    rp.add_argument("--quick", action="store_true", help="first 0.15 s only (tests, CI)")
    rp.add_argument("--no-penalty", dest="penalty", action="store_false",
                    help="leave out the penalty-contact simulation (the slow part)")
    rp.add_argument("--fig15-scene", default="paper-fig15",
                    help="scene of Fig. 15 (default paper-fig15: gravity +y; "
                         "paper-fig15-axial: gravity +x)")
    rp.set_defaults(func=_cmd_repro)

    bench.add_parser(sub)
    hard.add_parser(sub)
    sweep.add_parser(sub)
    report.add_parser(sub)
    secondary.add_parser(sub)
    return p


def _check_args(args) -> None:
    """Every numeric option within its range (:data:`ARGUMENTS`), and a sweep's
    articulations and amplitudes within the scene limits, before any work.
    """
    for attribute, flag, least, most, inclusive in ARGUMENTS:
        value = getattr(args, attribute, None)
        if value is None:
            continue
        low = value >= least if inclusive else value > least
        if not (math.isfinite(value) and low and value <= most):
            bound = f"[{least:g}, {most:g}]" if inclusive else f"({least:g}, {most:g}]"
            raise UsageError(f"{flag} {value}: must be a finite number in {bound}")
    if args.command == "sweep":
        for value in sweep.grid((args.angle or []) + (args.angles or [])):
            if abs(value) > MAX_ARTICULATION_DEG:
                raise UsageError(f"--angle {value:g}: |articulation| must be at most "
                                 f"{MAX_ARTICULATION_DEG:g} deg")
        for value in sweep.grid(args.amplitude):
            if abs(value) > LIMITS["torque_N_m"][1]:
                raise UsageError(f"--amplitude {value:g}: must be at most "
                                 f"{LIMITS['torque_N_m'][1]:g} N m in magnitude")


@contextlib.contextmanager
def _library_output_to_stderr():
    """While a command runs, file descriptor 1 points at stderr, so that what solver
    libraries write there (HiGHS prints a banner on stdout) never mixes with the
    package's output, which the caller buffers and prints afterwards.
    """
    try:
        sys.stdout.flush()
        saved = os.dup(1)
    except (OSError, ValueError, AttributeError):  # no file descriptor 1 to protect
        yield
        return
    os.dup2(2, 1)
    try:
        yield
    finally:
        try:  # C stdio buffers written by a library go out while fd 1 is still stderr
            ctypes.CDLL(None).fflush(None)
        except (OSError, AttributeError):
            pass
        os.dup2(saved, 1)
        os.close(saved)


@contextlib.contextmanager
def _heartbeat(command: str):
    """Say on stderr every :data:`HEARTBEAT_S` s that a long run is still going."""
    done, started = threading.Event(), time.monotonic()

    def beat():
        while not done.wait(HEARTBEAT_S):
            _progress(f"cardan {command}: still running after "
                      f"{time.monotonic() - started:.0f} s (Ctrl-C stops it)")

    thread = threading.Thread(target=beat, daemon=True)
    thread.start()
    try:
        yield
    finally:
        done.set()


UNDEFINED = ("nan", "inf", "-inf")
"""How records spell a non-finite number in JSON (``Record.to_json``); printed as null."""


def _finite(value):
    """``value`` with every non-finite number (a float, or a record's ``"nan"``,
    ``"inf"``, ``"-inf"``) replaced by ``None`` (JSON ``null``).
    """
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, str) and value in UNDEFINED:
        return None
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_finite(v) for v in value]
    return value


def strict_json(text: str) -> str:
    """A command's JSON output as strict JSON: numbers that are not finite become
    ``null`` (each record's ``status`` says why).
    """
    return json.dumps(_finite(json.loads(text)), indent=2, allow_nan=False) + "\n"


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``cardan`` console script: 0 done, 1 work that failed (hard
    cases, lost sweep points), 2 bad input, 130 interrupted.
    """
    buffer = io.StringIO()
    json_out = False
    try:
        args = _parser().parse_args(argv)
        json_out = getattr(args, "json", False)
        np.set_printoptions(precision=4, suppress=True)
        _check_args(args)
        with _heartbeat(args.command), _library_output_to_stderr(), \
                contextlib.redirect_stdout(buffer):
            code = args.func(args)
        text = buffer.getvalue()
        sys.stdout.write(strict_json(text) if json_out and text.strip() else text)
        return code
    except KeyboardInterrupt:
        print("cardan: interrupted", file=sys.stderr)
        return 130
    except (SceneError, UsageError, DynamicsError, SolverNotFound, NotApplicable,
            sweep.SweepError, OSError) as err:
        if not json_out:
            sys.stdout.write(buffer.getvalue())
        message = " ".join(str(err).split())
        print(f"cardan: error: {message}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
