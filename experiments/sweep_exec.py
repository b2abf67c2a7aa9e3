"""Executors of ``cardan sweep``: a local process pool, or a Dask distributed cluster.

Both take :class:`~.sweep_point.Point` items and yield each with its rows, or with the
error that lost it (a dead worker: the point is retried by the next run); the Dask one
runs any function on any tasks (``cardan tolerances`` runs its samples on it).

Local workers die with the sweep: a sweep killed outright (SIGKILL, an out-of-memory
kill), which runs no cleanup, leaves no worker computing for nobody
(:func:`_follow_parent`). A Dask run whose workers are all gone ends after
:data:`NO_WORKERS_S` seconds (``--timeout``) without one, keeping the rows it got:
every wait on Dask (for finished tasks, for a result, for the scheduler's workers) is
bounded by that deadline, whatever Dask's client is doing.
"""

from __future__ import annotations

import asyncio
import contextlib
import ctypes
import logging
import os
import signal
import threading
import time
from collections.abc import Iterator
from concurrent.futures import ProcessPoolExecutor, as_completed

from .sweep_point import Point, Row, SweepError, run_point


def pool(tasks: list[Point], workers: int) -> Iterator[tuple[Point, list[Row] | Exception]]:
    """Run ``tasks`` in a local process pool; yield each with its rows or the error.

    The workers ignore SIGINT (a Ctrl-C reaches the whole process group): the main
    process alone handles it, and on an interrupt (or the generator closed early) drops
    the queued points and ends the workers at once, losing only the points in flight.
    """
    executor = ProcessPoolExecutor(max_workers=min(workers, len(tasks)),
                                   initializer=_worker_start, initargs=(os.getpid(),))
    try:
        owner = {executor.submit(run_point, task): task for task in tasks}
        for future in as_completed(owner):
            try:
                yield owner[future], future.result()
            except Exception as exc:  # a worker that died: the point is retried next run
                yield owner[future], exc
    except BaseException:
        _stop(executor)
        raise
    executor.shutdown()


PARENT_POLL_S = 1.0
"""How often (s) a worker checks that its sweep is alive where the system cannot tell it."""


def _worker_start(parent: int) -> None:
    """A pool worker's start: SIGINT ignored (a Ctrl-C reaches the whole process group;
    the sweep handles it) and the worker bound to the sweep's life (:func:`_follow_parent`).
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    _follow_parent(parent)


def _follow_parent(parent: int) -> None:
    """End this process when process ``parent`` ends, however it ends: on Linux the
    kernel sends SIGKILL (``prctl(PR_SET_PDEATHSIG)``); elsewhere, and in case the
    parent ended before the request, a daemon thread polls every :data:`PARENT_POLL_S`
    s whether this process was handed to another parent and exits at once if so.
    """
    with contextlib.suppress(OSError, AttributeError):
        ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGKILL, 0, 0, 0)  # PR_SET_PDEATHSIG
    if os.getppid() != parent:
        os._exit(1)

    def watch():
        while os.getppid() == parent:
            time.sleep(PARENT_POLL_S)
        os._exit(1)

    threading.Thread(target=watch, daemon=True, name="follow-parent").start()


def _stop(pool: ProcessPoolExecutor) -> None:
    """Cancel the queued points and terminate the workers instead of letting them finish
    their points (``shutdown`` alone waits for those at exit).
    """
    workers = list((pool._processes or {}).values())  # no public handle before Python 3.14
    pool.shutdown(wait=False, cancel_futures=True)
    for process in workers:
        process.terminate()
    for process in workers:
        process.join(timeout=5.0)


def connect(address: str, timeout: float):
    """A Dask client on the scheduler at ``address``; :class:`SweepError` if the address
    is empty, dask is missing or the scheduler does not answer within ``timeout`` s.
    """
    if not address.strip():
        raise SweepError("--scheduler: the address is empty; give the scheduler's (as "
                         "tcp://HOST:PORT), or leave --scheduler out to run here")
    try:
        from dask.distributed import Client
    except ImportError:
        raise SweepError('--scheduler needs dask.distributed: pip install -e ".[dask]"') \
            from None
    try:
        return Client(address, timeout=timeout)
    except (OSError, ValueError, TypeError) as err:
        raise SweepError(f"cannot reach the Dask scheduler at {address}: {err}") from None


def close(client, timeout: float) -> None:
    """Close ``client``, waiting at most ``timeout`` s for its scheduler to take note
    (a scheduler gone or slow leaves nothing to wait for: the run's answer stands).
    """
    with contextlib.suppress(*TIMEOUTS, OSError):
        client.close(timeout=timeout)


NO_WORKERS_S = 10.0
"""Default seconds a Dask run waits with no worker on its scheduler before it ends
(``--timeout`` sets it, as it sets the wait for the scheduler)."""

POLL_S = 0.5
"""How often (s) a Dask run looks for finished tasks and for workers."""

TIMEOUTS = (TimeoutError, asyncio.TimeoutError)
"""What a Dask call bounded by a timeout raises when it runs out (one class from 3.11)."""


class NoWorkers(SweepError):
    """The Dask scheduler had no worker (or did not answer) for the stated time: the
    tasks not finished are lost to this run (a rerun computes them).
    """


def worker_threads(client, timeout: float) -> int | None:
    """The worker threads on ``client``'s scheduler; ``None`` if it does not say within
    ``timeout`` s.
    """
    try:
        return sum(client.nthreads(callback_timeout=timeout).values())
    except (*TIMEOUTS, OSError):
        return None


def dask(client, tasks: list, no_workers_s: float = NO_WORKERS_S, func=run_point,
         unit: str = "point") -> Iterator[tuple]:
    """Run ``func`` on each of ``tasks`` on a Dask cluster; yield each task with its
    result or the error that lost it.

    No call into Dask waits past a deadline, ``no_workers_s`` s after the scheduler last
    had a worker: a result that cannot be gathered by then (its data went with a dead
    worker, and Dask computes it again) goes back among the unfinished. At the deadline
    the unfinished tasks (``unit`` names one in the message) are cancelled and each is
    yielded with one :class:`NoWorkers` error; what was yielded before is the caller's.
    """
    _quiet_given_up_gathers()
    futures = [client.submit(func, task, pure=False) for task in tasks]
    owner = {future.key: task for future, task in zip(futures, tasks)}
    pending, seen = set(futures), time.monotonic()
    while pending:
        deadline = seen + no_workers_s
        for future in _finished(pending, min(POLL_S, _left(deadline))):
            outcome = _outcome(future, deadline)
            if outcome is not _AGAIN:
                pending.discard(future)
                yield owner[future.key], outcome
        if not pending:
            return
        if worker_threads(client, max(_left(deadline), POLL_S)):
            seen = time.monotonic()
        elif _left(deadline) <= 0:
            client.cancel(list(pending))
            lost = NoWorkers(f"the Dask scheduler at {client.scheduler.address} has had no "
                             f"worker for {no_workers_s:g} s (--timeout); {len(pending)} "
                             f"{unit}(s) not computed, a rerun computes them")
            for future in pending:
                yield owner[future.key], lost
            return


class _GivenUpGathers(logging.Filter):
    """Drops asyncio's report of a Dask client's inner gather task ending in
    ``AllExit`` once nobody awaits it: Dask quiets that exception itself
    (``quiet_exceptions``), but a gather given up at a deadline (:func:`_outcome`)
    leaves the task behind, and its report would read as a traceback on stderr.
    """

    def filter(self, record: logging.LogRecord) -> bool:
        error = record.exc_info[1] if record.exc_info else None
        return type(error).__name__ != "AllExit"


def _quiet_given_up_gathers() -> None:
    """Install :class:`_GivenUpGathers` on asyncio's logger, once."""
    log = logging.getLogger("asyncio")
    if not any(isinstance(f, _GivenUpGathers) for f in log.filters):
        log.addFilter(_GivenUpGathers())


_AGAIN = object()
"""A finished task whose result was not gathered in time (it stays unfinished)."""


def _left(deadline: float) -> float:
    """Seconds until ``deadline`` (monotonic clock), at least 0."""
    return max(deadline - time.monotonic(), 0.0)


def _finished(pending: set, timeout: float) -> set:
    """The futures of ``pending`` done now or within ``timeout`` s."""
    from dask.distributed import wait

    try:
        return wait(pending, timeout=timeout, return_when="FIRST_COMPLETED").done
    except TIMEOUTS:
        return set()


def _outcome(future, deadline: float):
    """``future``'s result, or the error that lost its task; :data:`_AGAIN` if it is not
    gathered before ``deadline``.
    """
    if _left(deadline) <= 0:
        return _AGAIN
    try:
        return future.result(timeout=_left(deadline))
    except TIMEOUTS:
        return _AGAIN
    except Exception as exc:  # a failed task or a worker lost while computing it
        return exc
