"""The ``cardan`` commands that sit directly on the layers, one module each with
``add_parser(subparsers)`` and ``run(args) -> exit code``: ``scene``, ``sets``,
``solvers``, ``solve``, ``repro``. The study commands (``bench``, ``hard``, ``sweep``,
``report``, ``secondary``) follow the same convention in ``cardan_forces.experiments``.
:mod:`cardan_forces.cli` assembles them, owns output and exit codes.

What the commands share is here: the error for a request that cannot be carried out,
the argument types of sizes and formulations, progress lines on stderr, the check of
``--t`` against a scene's span and JSON output.
"""

from __future__ import annotations

import argparse

from cardan_forces.experiments import progress as progress_bars
from cardan_forces.experiments.environment import json_text
from cardan_forces.formulations import UnknownFormulation, formulation


class UsageError(ValueError):
    """A command-line request that cannot be carried out (exit code 2)."""


def whole_number(least: int, most: int):
    """An argparse type: a whole number from ``least`` to ``most`` (a size, a count, a
    seed), refused with one line before any work.
    """
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            value = least - 1
        if not least <= value <= most:
            raise argparse.ArgumentTypeError(f"expected a whole number from {least} to "
                                             f"{most}, got {text!r}")
        return value
    return parse


def formulation_name(text: str) -> str:
    """An argparse type: a formulation's name, a typo refused in one line naming the
    nearest names (:func:`~cardan_forces.formulations.formulation`).
    """
    try:
        return formulation(text).name
    except UnknownFormulation as err:
        raise argparse.ArgumentTypeError(str(err)) from None


def progress(message: str) -> None:
    """One line of progress on stderr (stdout stays the command's answer; none with
    ``--quiet``).
    """
    progress_bars.line(message)


def print_json(value) -> None:
    """``value`` as strict JSON on stdout (:func:`json_text`: non-finite numbers null)."""
    print(json_text(value))


def check_time(scene, t: float) -> None:
    """``--t`` within the scene's time span (UsageError otherwise), before any work."""
    if not scene.time.start_s <= t <= scene.time.stop_s:
        raise UsageError(
            f"--t {t}: outside the scene's time span [{scene.time.start_s}, "
            f"{scene.time.stop_s}] s"
        )
