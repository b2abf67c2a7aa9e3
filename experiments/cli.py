"""The ``cardan`` command line.

Subcommands: ``scene`` (list, show, dump, check), ``sets`` (rank, null space and
determinacy of the contact forces at one instant), ``repro`` (the paper's figures).
Errors in the user's input end with one message on stderr and exit code 2.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

from driveline.determinacy import DETERMINATE_TOL, determinacy
from driveline.dynamics import DynamicsError, simulate
from driveline.equilibrium import build_operator
from driveline.scene import SceneError, builtin_names, builtin_text, load_scene

FIGURES = (11, 12)


class UsageError(ValueError):
    """A command-line request that cannot be carried out (exit code 2)."""


def _progress(message: str) -> None:
    print(message, file=sys.stderr, flush=True)


# ---------------------------------------------------------------------------- scene


def _cmd_scene(args) -> int:
    if args.action == "list":
        for name in builtin_names():
            print(f"{name:20s} {load_scene(name).description}")
    elif args.action == "dump":
        print(builtin_text(args.name) if args.name in builtin_names()
              else Path(args.name).read_text(), end="")
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
        bearings = ", ".join(f"{b.name} @ {b.offset_m:+g} m" for b in s.bearings) or "none"
        print(f"  shaft {s.name:13s} L={s.length_m} m  m={s.mass_kg} kg  "
              f"J={s.inertia_kg_m2} kg m^2  bearings: {bearings}")
    for j in scene.joints:
        print(f"  joint {j.name:13s} articulation {j.articulation_deg} deg, yoke phase "
              f"{j.yoke_phase_deg} deg, clearance radial {j.radial_clearance_m:.3g} m, "
              f"axial {j.axial_clearance_m:.3g} m")
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
    result = determinacy(build_operator(simulate(scene, [args.t])), 0)
    if args.json:
        print(json.dumps(result.to_json(), indent=2))
        return 0
    print(f"scene {scene.name}, t = {result.t:g} s: rank {result.rank}, nullity "
          f"{result.nullity}, least-norm residual {result.residual:.1e}")
    print(f"determinate: null-space row norm < {DETERMINATE_TOL:g}; least-norm values in N "
          "(one member of the solution set where not determinate)")
    print(f"{'component':24s} {'determinate':>11s} {'least-norm N':>14s} {'null row':>9s}")
    for name, det, value, row in zip(result.names, result.determinate, result.min_norm,
                                     result.null_row_norms):
        print(f"{name:24s} {'yes' if det else 'no':>11s} {value:14.4f} {row:9.2e}")
    return 0


# ---------------------------------------------------------------------------- repro


def _cmd_repro(args) -> int:
    from paper_repro import figures

    figs = sorted(set(args.fig or FIGURES))
    out = Path(args.out)
    scene = load_scene(args.scene)
    times = scene.time.instants()
    if args.quick:
        times = times[times <= scene.time.start_s + 0.5]
    started = time.perf_counter()
    _progress(f"repro: simulating {scene.name} over {len(times)} instants ...")
    motion = simulate(scene, times)
    _progress(f"repro: motion done in {time.perf_counter() - started:.1f} s")
    for number in figs:
        csv = getattr(figures, f"fig{number}")(motion, out)
        _progress(f"repro: fig {number} -> {csv} and {csv.with_suffix('.png').name}")
    return 0


# ---------------------------------------------------------------------------- main


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
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
    st.set_defaults(func=_cmd_sets)

    rp = sub.add_parser("repro", help="reproduce the paper's figures (CSV + PNG)")
    rp.add_argument("scene", nargs="?", default="paper", help="built-in name or TOML path")
    rp.add_argument("--fig", type=int, action="append", choices=FIGURES,
                    help="one figure (repeatable); default all")
    rp.add_argument("--out", default="results", help="output folder (default results/)")
    rp.add_argument("--quick", action="store_true", help="first 0.5 s only (tests, CI)")
    rp.set_defaults(func=_cmd_repro)
    return p


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``cardan`` console script."""
    args = _parser().parse_args(argv)
    np.set_printoptions(precision=4, suppress=True)
    try:
        return args.func(args)
    except (SceneError, UsageError, DynamicsError, OSError) as err:
        print(f"cardan: error: {err}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
