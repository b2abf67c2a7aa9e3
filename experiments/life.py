"""``cardan life``: every rated bearing's ISO 281 basic rating life, for each selection
the package can compute and over the whole rigid solution set (the command: its
options, each checked as it is parsed, and its run).

The answer is :func:`~cardan_forces.experiments.life_study.study`'s (the duty cycle's
spectrum and bins by :mod:`~cardan_forces.experiments.life_duty`, the simulated
selections by :mod:`~cardan_forces.experiments.life_runs`); written into ``--out`` by
:mod:`~cardan_forces.experiments.life_report`: ``life.csv`` (every ``P`` over time, by
bin, the reason beside an empty cell), ``life.md`` and the figure ``life.<format>``
(each bearing's life interval with each selection's mark); ``--json`` prints the whole
answer as strict JSON instead.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

from cardan_forces.driveline import bearing_life as iso
from cardan_forces.driveline.scene import LIMITS
from cardan_forces.experiments import files
from cardan_forces.experiments import progress as bars
from cardan_forces.experiments.arguments import whole_number
from cardan_forces.experiments.environment import json_text
from cardan_forces.experiments.images import format_list
from cardan_forces.experiments.life_report import write_outputs
from cardan_forces.experiments.life_study import INSTANTS, RELIABILITY, study

MAX_INSTANTS = 2001
"""Most instants a run takes (checked before any work)."""


def add_parser(subparsers) -> None:
    """Register ``cardan life``."""
    p = subparsers.add_parser("life", help="ISO 281 bearing life of each selection and over "
                              "the rigid solution set, over a duty cycle (CSV, Markdown, "
                              "figure; --json)")
    p.add_argument("scene", help="built-in name or TOML path")
    p.add_argument("--instants", type=whole_number(2, MAX_INSTANTS), default=INSTANTS,
                   help=f"instants over the scene's window, or over one input revolution "
                        f"of each duty-cycle bin (default {INSTANTS})")
    spectrum = p.add_mutually_exclusive_group()
    spectrum.add_argument("--duty-cycle", dest="duty_file", metavar="FILE",
                          help="a TOML file of [[duty_cycle]] bins (torque_N_m, speed_rpm, "
                               "share), rated instead of the scene's")
    spectrum.add_argument("--speed-rpm", type=_speed, metavar="N",
                          help="one bin: the scene's mean input torque at N r/min")
    p.add_argument("--reliability", type=_reliability, default=RELIABILITY,
                   metavar="PERCENT", help="reliability of the modified life L_nm, ISO "
                   f"281:2007's a1 (default {RELIABILITY:g}: a1 = 1)")
    p.add_argument("--out", type=files.folder, default="results/life",
                   help="output folder (default %(default)s)")
    p.add_argument("--format", type=format_list, default=("png",),
                   help="comma-separated image formats (default png; any of png,svg,pdf)")
    p.add_argument("--penalty", action="store_true",
                   help="also rate the penalty-contact simulation's average (a simulation "
                        "of the released line over the window; dynamic scenes, no duty "
                        "cycle)")
    p.add_argument("--no-engine", dest="engine", action="store_false",
                   help="leave out MuJoCo's forces (run by default where installed, the "
                        "scene is expressible and no duty cycle is rated)")
    p.add_argument("--json", action="store_true",
                   help="print the whole answer as strict JSON on stdout (no files)")
    p.set_defaults(func=run)


def _number(text: str) -> float:
    """``text`` as a finite number (argparse's error otherwise)."""
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"expected a finite number, got {text!r}")
    return value


def _speed(text: str) -> float:
    """An argparse type: a speed (r/min) within a duty-cycle bin's limits."""
    value = _number(text)
    least, most = LIMITS["speed_rpm"]
    if not least <= value <= most:
        raise argparse.ArgumentTypeError(f"expected a speed from {least:g} to {most:g} "
                                         f"r/min, got {text!r}")
    return value


def _reliability(text: str) -> float:
    """An argparse type: a reliability (%) ISO 281:2007 gives ``a1`` for."""
    value = _number(text)
    refused = iso.RELIABILITY_PERCENT.refusal(value)
    if refused:
        raise argparse.ArgumentTypeError(f"{refused}, the reliabilities ISO 281:2007 "
                                         "Table 12 gives a1 for")
    return value


def run(args) -> int:
    """The answer as JSON on stdout, or the files written (named on stderr)."""
    answer = study(args.scene, args.instants, progress=bars.line, penalty=args.penalty,
                   engine=args.engine, duty_file=args.duty_file, speed_rpm=args.speed_rpm,
                   reliability=args.reliability)
    if not answer["bearings"]:
        bars.line(f"life: scene {answer['scene']} rates no bearing (no catalogue data)")
    if args.json:
        print(json_text(answer))
        return 0
    files.say_written("life", write_outputs(answer, Path(args.out), args.format))
    return 0
