"""``cardan solvers``: the backends present, their problem classes, where each that is
not the package's own comes from (a plugin's distribution and entry point), and how to
install the absent ones.
"""

from __future__ import annotations

import sys

from cardan_forces.solvers import available
from cardan_forces.solvers.plugins import ORIGINS
from cardan_forces.solvers.registry import known_backends, plugin_errors

from . import print_json


def add_parser(subparsers) -> None:
    """Register ``cardan solvers``."""
    sv = subparsers.add_parser("solvers",
                               help="solver backends present, with their problem classes")
    sv.add_argument("--json", action="store_true", help="print JSON")
    sv.set_defaults(func=run)


def say_plugin_errors(command: str) -> None:
    """One stderr line per plugin that could not be loaded, with why (stderr: ``--json``
    stays strict JSON); the command runs on with the other backends.
    """
    for plugin, why in plugin_errors().items():
        print(f"cardan {command}: plugin {plugin} not loaded: {why}", file=sys.stderr)


def run(args) -> int:
    backends = available()
    say_plugin_errors("solvers")
    if args.json:
        print_json([{"name": b.name, "family": b.family, "version": b.version,
                     "classes": [c.__name__ for c in b.accepts], "extra": b.extra,
                     "origin": ORIGINS.get(b.name)} for b in backends.values()])
        return 0
    for b in backends.values():
        origin = f"  ({ORIGINS[b.name]})" if b.name in ORIGINS else ""
        print(f"{b.name:22s} {'/'.join(c.__name__ for c in b.accepts):18s} {b.version}{origin}")
    for name in sorted(set(known_backends()) - set(backends)):
        extra = known_backends()[name]
        target = "cardan-forces" if extra is None else f"cardan-forces[{extra}]"
        print(f"{name:22s} absent: pip install \"{target}\"")
    return 0
