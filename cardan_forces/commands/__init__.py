"""The ``cardan`` commands that sit directly on the layers, one module each with
``add_parser(subparsers)`` and ``run(args) -> exit code``: ``scene``, ``sets``,
``solvers``, ``solve``, ``repro``. The study commands (``bench``, ``hard``, ``sweep``,
``report``, ``secondary``) follow the same convention in ``cardan_forces.experiments``.
:mod:`cardan_forces.cli` assembles them, owns output and exit codes.

What only the commands share is here: progress lines on stderr, the check of ``--t``
against a scene's span and JSON output; the error for a request that cannot be carried
out and the argument types, which the study commands take too, are
:mod:`cardan_forces.experiments.arguments`'.
"""

from __future__ import annotations

from cardan_forces.experiments import progress as progress_bars
from cardan_forces.experiments.arguments import UsageError, formulation_name, whole_number
from cardan_forces.experiments.environment import json_text

__all__ = ["UsageError", "check_time", "formulation_name", "print_json", "progress",
           "whole_number"]


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
