"""The ``cardan`` command line: assembles the commands' parsers, owns output and exit codes.

Every command is a module with ``add_parser(subparsers)`` and ``run(args) -> exit
code``: ``scene``, ``sets``, ``solvers``, ``solve``, ``repro`` in
:mod:`cardan_forces.commands`; ``bench``, ``hard``, ``sweep``, ``report``,
``secondary``, ``engine`` in :mod:`cardan_forces.experiments`. A command prints its
answer on stdout (JSON through the one encoder, ``experiments.environment.json_text``:
strict, non-finite numbers as ``null``) and its progress on stderr.

Here, around every command: numeric options checked against their ranges before any
work; errors in the user's input (scene or arguments) end with one line ``cardan:
error: ...`` on stderr and exit code 2; Ctrl-C ends a run with one line and exit code
130; whatever a solver library writes on file descriptor 1 (HiGHS's banner) goes to
stderr, so stdout carries the command's answer alone; one BLAS/OpenMP thread per
process (the problems are small dense matrices; more threads only contend, above all
when several processes share a small machine), also in the processes a command starts.
"""

from __future__ import annotations

import argparse
import contextlib
import ctypes
import io
import math
import os
import sys
import threading
import time
from importlib import metadata

import numpy as np
from threadpoolctl import threadpool_limits

from cardan_forces.commands import UsageError, progress
from cardan_forces.commands import compile as compile_command
from cardan_forces.commands import repro as repro_command
from cardan_forces.commands import scene as scene_command
from cardan_forces.commands import sets as sets_command
from cardan_forces.commands import solve as solve_command
from cardan_forces.commands import solvers as solvers_command
from cardan_forces.driveline.dynamics import DynamicsError
from cardan_forces.driveline.scene import LIMITS, SceneError
from cardan_forces.experiments import (
    bench,
    engine,
    export,
    hard,
    life,
    report,
    secondary,
    sweep,
    tolerances,
)
from cardan_forces.experiments import progress as progress_bars
from cardan_forces.formulations.convex import NotApplicable
from cardan_forces.solvers import SolverNotFound

COMMANDS = (scene_command, sets_command, solvers_command, solve_command, repro_command,
            bench, export, hard, sweep, report, secondary, engine, compile_command, life,
            tolerances)
"""The command modules, in the order ``cardan --help`` lists them."""

HEARTBEAT_S = 30.0
"""A run still going after this many seconds says so on stderr, and again every as many."""

THREADS = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")
"""Environment variables that set the BLAS/OpenMP threads of processes a command starts."""

MALLOC = {"MALLOC_MMAP_THRESHOLD_": 64 << 20, "MALLOC_TRIM_THRESHOLD_": 256 << 20}
"""glibc's malloc thresholds (bytes) for a command's process and the processes it
starts: freed blocks up to 64 MiB stay in the process (:func:`_keep_freed_memory`)."""

ARGUMENTS = (
    # attribute, flag, least, most, least allowed (else: above least)
    ("t", "--t", 0.0, LIMITS["time_s"][1], True),
    ("tol", "--tol", 0.0, 1.0, False),
    ("multistart", "--multistart", 0, 1000, True),
)
"""Ranges of the numeric options ``sets``, ``solve`` and ``hard`` share, checked before
any work; the other commands check their own (``sweep`` its window and workers against
the scene, ``report``/``export`` their instants by argument type)."""


class _Parser(argparse.ArgumentParser):
    """An argument parser whose errors are :class:`UsageError` (one line, exit code 2)."""

    def error(self, message: str):
        raise UsageError(f"{message} (see '{self.prog} --help')")


def _parser() -> argparse.ArgumentParser:
    p = _Parser(
        prog="cardan",
        description="Reaction forces in drive shafts with Cardan joints (two, three or more).",
    )
    p.add_argument("--version", action="version", version=f"%(prog)s {_version()}")
    sub = p.add_subparsers(dest="command", required=True)
    for command in COMMANDS:
        command.add_parser(sub)
    _add_quiet(sub)
    return p


def _version() -> str:
    """The installed distribution's version (``unknown`` when it is not installed)."""
    try:
        return metadata.version("cardan-forces")
    except metadata.PackageNotFoundError:
        return "unknown (not installed)"


def _add_quiet(sub) -> None:
    """``--quiet`` on every command (the innermost parsers, ``scene list`` too)."""
    for parser in sub.choices.values():
        inner = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
        for action in inner:
            _add_quiet(action)
        if not inner:
            parser.add_argument("--quiet", action="store_true",
                                help="no progress bars, progress lines or heartbeat on stderr")


def _check_args(args) -> None:
    """Every numeric option within its range (:data:`ARGUMENTS`), before any work (what
    depends on the scene, each command checks: ``sets --t`` its span, ``sweep`` its
    angles and amplitudes).
    """
    for attribute, flag, least, most, inclusive in ARGUMENTS:
        value = getattr(args, attribute, None)
        if value is None:
            continue
        low = value >= least if inclusive else value > least
        if not (math.isfinite(value) and low and value <= most):
            bound = f"[{least:g}, {most:g}]" if inclusive else f"({least:g}, {most:g}]"
            raise UsageError(f"{flag} {value}: must be a finite number in {bound}")


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


def _keep_freed_memory() -> None:
    """Keep freed memory in this process (glibc's ``mallopt``; nothing elsewhere).

    By default glibc returns every freed block over 128 KiB to the system, so a pass
    vectorized over hundreds of instants, which allocates and frees arrays of a few
    MiB, page-faults its way through each of them again, several times slower than with
    the memory kept. The worker processes a command starts read :data:`MALLOC` from
    their environment.
    """
    try:
        mallopt = ctypes.CDLL(None).mallopt
    except (OSError, AttributeError):  # not glibc
        return
    mallopt(-3, MALLOC["MALLOC_MMAP_THRESHOLD_"])  # M_MMAP_THRESHOLD
    mallopt(-1, MALLOC["MALLOC_TRIM_THRESHOLD_"])  # M_TRIM_THRESHOLD


@contextlib.contextmanager
def _one_thread_each():
    """One BLAS/OpenMP thread in this process while a command runs (threadpoolctl), and
    in the worker processes it starts (their environment, unless the user set it), with
    freed memory kept in each (:func:`_keep_freed_memory`).
    """
    unset = [name for name in (*THREADS, *MALLOC) if name not in os.environ]
    os.environ.update({name: str(MALLOC.get(name, 1)) for name in unset})
    _keep_freed_memory()
    try:
        with threadpool_limits(limits=1):
            yield
    finally:
        for name in unset:
            os.environ.pop(name, None)


@contextlib.contextmanager
def _heartbeat(command: str):
    """Say on stderr every :data:`HEARTBEAT_S` s that a long run is still going."""
    done, started = threading.Event(), time.monotonic()

    def beat():
        while not done.wait(HEARTBEAT_S) and not progress_bars.quiet():
            progress(f"cardan {command}: still running after "
                     f"{time.monotonic() - started:.0f} s (Ctrl-C stops it)")

    thread = threading.Thread(target=beat, daemon=True)
    thread.start()
    try:
        yield
    finally:
        done.set()


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
        progress_bars.configure(quiet=getattr(args, "quiet", False))
        with _heartbeat(args.command), _one_thread_each(), _library_output_to_stderr(), \
                contextlib.redirect_stdout(buffer):
            code = args.func(args)
        sys.stdout.write(buffer.getvalue())
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
