"""Progress bars of the long commands (``repro``, ``bench``, ``hard``, ``report``,
``sweep``): tqdm on stderr, with the count, rate and time left.

Bars are off by default, so the Python API prints nothing; the command line turns them
on (:func:`configure`) unless ``--quiet`` is given, and they stay off whenever stderr is
not a terminal (a log file or a pipe gets the plain progress lines and the 30 s
heartbeat instead). stdout, the command's answer, is never touched.
"""

from __future__ import annotations

import contextlib
import sys
from collections.abc import Callable, Iterable

from tqdm import tqdm

_STATE = {"on": False, "quiet": False}


def configure(quiet: bool) -> None:
    """What the command line asks: bars (when stderr is a terminal) and progress lines,
    or with ``quiet`` neither.
    """
    _STATE.update(on=not quiet, quiet=bool(quiet))


def quiet() -> bool:
    """Whether ``--quiet`` asked for no progress at all (no lines, no heartbeat)."""
    return _STATE["quiet"]


def shown() -> bool:
    """Whether a bar is drawn now: enabled and stderr is a terminal."""
    isatty = getattr(sys.stderr, "isatty", None)
    return _STATE["on"] and bool(isatty and isatty())


def bar(items: Iterable, desc: str, total: int | None = None, unit: str = "it") -> Iterable:
    """``items`` as they come, with a bar on stderr when :func:`shown` (else ``items``
    unchanged): ``desc`` before it, ``total`` items (default ``len(items)``) counted in
    ``unit``.
    """
    if not shown():
        return items
    return tqdm(items, desc=desc, total=total, unit=unit, file=sys.stderr, leave=False,
                dynamic_ncols=True, mininterval=0.5)


@contextlib.contextmanager
def ticks(total: int, desc: str, unit: str = "it",
          lines: Callable[[str], None] | None = None):
    """A progress callback for a study-layer loop that calls it once per item (as
    ``interval_history`` does per instant): a bar of ``total`` items when :func:`shown`,
    else ``lines`` (the plain progress lines, or ``None``) unchanged.
    """
    if not shown():
        yield lines
        return
    with tqdm(total=total, desc=desc, unit=unit, file=sys.stderr, leave=False,
              dynamic_ncols=True, mininterval=0.5) as counter:
        yield lambda _message: counter.update()


def line(message: str) -> None:
    """One progress line on stderr (none with ``--quiet``); above a bar being drawn,
    written through tqdm so the bar is redrawn under it, not torn.
    """
    if quiet():
        return
    if shown():
        tqdm.write(message, file=sys.stderr)
    else:
        print(message, file=sys.stderr, flush=True)
