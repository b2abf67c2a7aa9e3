"""``cardan sets``: rank, null space, determinacy and the interval of every contact
force at one instant; with ``--apply`` on a released line, with ``--release`` the
advisor's smallest release set (started from the ``--apply``-released line).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from cardan_forces.driveline.determinacy import DETERMINATE_TOL, determinacy
from cardan_forces.driveline.dynamics import simulate
from cardan_forces.driveline.equilibrium import build_operator
from cardan_forces.driveline.loading import load_scene
from cardan_forces.driveline.release import (
    advise,
    named_modes,
    parse_release,
    released_operator,
)
from cardan_forces.experiments.environment import number_text
from cardan_forces.experiments.paper_method import multistart
from cardan_forces.experiments.study import default_backend, intervals
from cardan_forces.formulations import FORMULATIONS, SELECTION
from cardan_forces.formulations.paper import end_faces_words
from cardan_forces.solvers import solve

from . import check_time, print_json


def add_parser(subparsers) -> None:
    """Register ``cardan sets``."""
    st = subparsers.add_parser("sets", help="rank, null space and determinacy at one instant")
    st.add_argument("scene", nargs="?", default="paper", help="built-in name or TOML path")
    st.add_argument("--t", type=float, default=0.5, help="instant in s (default 0.5)")
    st.add_argument("--json", action="store_true", help="print JSON")
    st.add_argument("--multistart", type=int, default=0, metavar="N",
                    help="also run the paper's method from N seeded random starts")
    st.add_argument("--release", action="store_true",
                    help="propose the smallest set of releases (floating bearings, slip "
                         "joints) that leaves only end-face pair modes, starting from the "
                         "line as --apply leaves it; show the released line's table")
    st.add_argument("--apply", action="append", metavar="RELEASE",
                    help="apply a release first: float:<shaft>.<bearing> or slip:<shaft> "
                         "(repeatable)")
    st.set_defaults(func=run)


def run(args) -> int:
    scene = load_scene(args.scene)
    check_time(scene, args.t)
    applied = [parse_release(text, scene) for text in args.apply or ()]  # before any work
    motion = simulate(scene, [args.t])
    if applied:  # SceneError when the releases leave a mechanism
        op = released_operator(motion, applied)
        motion = dataclasses.replace(motion, scene=op.scene)
    else:
        op = build_operator(motion)
    if args.release:
        return _advise(args, motion, applied)
    result = determinacy(op, 0)
    ranges = intervals(op, 0)
    modes = named_modes(motion, 0, op)
    starts = multistart(op, 0, n=args.multistart, rim=MULTISTART_RIM)[:, : len(op.names)] \
        if args.multistart else None
    member = signed_member(op)
    if args.json:
        report = _with_intervals(result.to_json(), ranges, member)
        if starts is not None:
            for j, entry in enumerate(report["components"].values()):
                entry["paper_multistart"] = starts[:, j]
        report["modes"] = [m.to_json() for m in modes]
        print_json(report)
        return 0
    print_table(op.scene.name, result, ranges, member, starts, args.multistart)
    print_modes(modes)
    return 0


MULTISTART_RIM = False
"""``--multistart`` solves the paper's equations with the end faces on the axis, as the
operator puts them: its answers then solve ``A x = b`` and are members of the rigid set
whose intervals the table shows (with the rim moments they would solve other equations)."""

EMPTY = ("empty: no forces satisfy the equilibrium with end faces >= 0 and the slip "
         "joints' friction bounds at this instant")
"""What the table says of a rigid set the LPs find infeasible."""

SIGNED = SELECTION
"""The formulation whose answer ``sets`` shows as a member of the rigid set: the least
norm with end faces >= 0, so it lies inside every interval the table prints."""


def signed_member(op) -> tuple[np.ndarray, str]:
    """The :data:`SIGNED` answer at the operator's first instant (N, N m; NaN where its
    default backend, ``study.default_backend``, did not solve it) and that backend.
    """
    problem = FORMULATIONS[SIGNED](op, 0)
    backend = default_backend(SIGNED, problem)
    record = solve(problem, backend)
    return (record.x if record.solved else np.full(len(op.names), np.nan)), backend


def rigid_set(ranges: dict) -> str:
    """The rigid set's state from its intervals: ``solved`` when some interval was
    found, else the one status they share (``infeasible``: no forces satisfy the
    equilibrium with end faces >= 0 and the slip joints' friction bounds).
    """
    statuses = {found["status"] for found in ranges.values()}
    return "solved" if "solved" in statuses or not statuses else statuses.pop()


def _with_intervals(report: dict, ranges: dict, member) -> dict:
    """A determinacy report's components with their ``min``/``max`` (None: unbounded
    when ``interval_status`` is ``solved``, else not known) and their value in the
    signed member (``positive``, :func:`signed_member`); ``rigid_set`` as
    :func:`rigid_set` says. A component is called determinate only with its one value
    as ``min = max``: where the set is empty or its interval was not found, the null
    space alone does not give it a value (``determinate`` false, the reason in
    ``interval_status``).
    """
    values, _ = member
    report["rigid_set"] = rigid_set(ranges)
    for j, (name, entry) in enumerate(report["components"].items()):
        found = ranges[name]
        entry.update(min=found["min"], max=found["max"], positive=float(values[j]),
                     interval_status=found["status"])
        entry["determinate"] = bool(entry["determinate"]) and found["status"] == "solved"
    return report


def print_table(name, result, ranges, member, starts=None, n_starts=0) -> None:
    """One line per component: determinate, its value in the signed member (the
    ``positive`` answer, inside every interval), interval (and the spread of the paper
    method's multistart answers).
    """
    values, backend = member
    print(f"scene {name}, t = {result.t:g} s: rank {result.rank}, nullity "
          f"{result.nullity}, least-norm residual {result.residual:.1e}")
    state = rigid_set(ranges)
    if state != "solved":
        words = EMPTY if state == "infeasible" else \
            f"{state} (the LP solver could not decide whether forces exist)"
        print(f"rigid set: {words}: no component has a value or an interval")
    print(f"determinate: null-space row norm < {DETERMINATE_TOL:g}; '{SIGNED}': the least-"
          f"norm solution with end faces >= 0 ({backend}), one member of the rigid set, in N "
          "(N m for moments: an element's bending and torque); interval over all solutions "
          "with end faces >= 0 (-inf/+inf: unbounded)")
    width = max(24, *(len(n) for n in result.names))
    print(f"{'component':{width}s} {'determinate':>11s} {SIGNED + ' N':>14s} {'min N':>12s} "
          f"{'max N':>12s}")
    if starts is not None:
        print(f"paper method (fsolve, {end_faces_words(MULTISTART_RIM)}) from {n_starts} "
              f"random starts: {len(starts)} converged; their spread per component at the right")
    for j, (name, det, value) in enumerate(zip(result.names, result.determinate, values)):
        lo, hi, status = ranges[name]["min"], ranges[name]["max"], ranges[name]["status"]
        lo, hi = number_text(lo, ".4f", "-inf"), number_text(hi, ".4f", "+inf")
        if status != "solved":  # no interval found: not unbounded, unknown or empty
            lo = hi = "empty" if status == "infeasible" else status
            det = False
        spread = "" if starts is None or not len(starts) else \
            f"  paper: [{number_text(starts[:, j].min(), '.3f')}, " \
            f"{number_text(starts[:, j].max(), '.3f')}]"
        print(f"{name:{width}s} {'yes' if det else 'no':>11s} {number_text(value, '14.4f')} "
              f"{lo:>12s} {hi:>12s}{spread}")


def print_modes(modes) -> None:
    """The null-space directions in words, with the release each would need."""
    print(f"modes (null-space directions): {len(modes)}")
    for k, m in enumerate(modes, 1):
        print(f"  {k}. {m.kind}: {m.description}")
        shown = ", ".join(m.components[:6]) + (" ..." if len(m.components) > 6 else "")
        print(f"     moves {shown}; release: {m.release}")


def _advise(args, motion, applied) -> int:
    """``--release``: the advisor's release set on the (already released) line, and the
    table of the line with both the applied and the advised releases.
    """
    advice = advise(motion, 0)
    ranges = intervals(advice.operator, 0)
    member = signed_member(advice.operator)
    if args.json:
        report = advice.to_json()
        report["applied"] = [r.to_json() for r in applied]
        report["modes"] = [m.to_json() for m in advice.modes]
        report["released"] = _with_intervals(advice.released.to_json(), ranges, member)
        report["released"]["modes"] = [m.to_json() for m in advice.released_modes]
        print_json(report)
        return 0
    if applied:
        print(f"applied first: {'; '.join(r.words for r in applied)}")
    print_modes(advice.modes)
    words = "; ".join(r.words for r in advice.releases) or "none: only end-face pair modes"
    print(f"release advisor: {len(advice.releases)} release(s): {words}")
    print(f"  ({len(advice.alternatives)} other set(s) of the same size also work; "
          f"{advice.tried} set(s) built and checked by determinacy)")
    every = (*applied, *advice.releases)
    if every:
        print(f"  as --apply: {' '.join('--apply ' + r.label for r in every)}")
    print()
    print_table(advice.scene.name, advice.released, ranges, member)
    print_modes(advice.released_modes)
    return 0
