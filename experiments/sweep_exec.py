"""Executors of ``cardan sweep``: a local process pool, or a Dask distributed cluster.

Both take :class:`~.sweep_point.Point` items and yield each with its rows, or with the
error that lost it (a dead worker: the point is retried by the next run).

Local workers die with the sweep: a sweep killed outright (SIGKILL, an out-of-memory
kill), which runs no cleanup, leaves no worker computing for nobody
(:func:`_follow_parent`). A Dask run whose workers are all gone ends after
:data:`NO_WORKERS_S` seconds without one, keeping the rows it got.
"""

from __future__ import annotations

import contextlib
import ctypes
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
    """A Dask client on the scheduler at ``address``; :class:`SweepError` if dask is
    missing or the scheduler does not answer within ``timeout`` s.
    """
    try:
        from dask.distributed import Client
    except ImportError:
        raise SweepError('--scheduler needs dask.distributed: pip install -e ".[dask]"') \
            from None
    try:
        return Client(address, timeout=timeout)
    except (OSError, ValueError) as err:
        raise SweepError(f"cannot reach the Dask scheduler at {address}: {err}") from None


NO_WORKERS_S = 10.0
"""Default seconds a Dask run waits with no worker on its scheduler before it ends
(``cardan sweep --timeout`` sets it, as it sets the wait for the scheduler)."""

POLL_S = 0.5
"""How often (s) a Dask run looks for finished points and for workers."""


class NoWorkers(SweepError):
    """The Dask scheduler had no worker for the stated time: the points not finished
    are lost to this run (a rerun computes them).
    """


def dask(client, tasks: list[Point], no_workers_s: float = NO_WORKERS_S
         ) -> Iterator[tuple[Point, list[Row] | Exception]]:
    """Run ``tasks`` on a Dask cluster; yield each with its rows or the error. When the
    scheduler has had no worker for ``no_workers_s`` s, the unfinished points are
    cancelled and each yielded with one :class:`NoWorkers` error (the rows yielded
    before are kept by the caller).
    """
    from dask.distributed import wait

    futures = [client.submit(run_point, task, pure=False) for task in tasks]
    owner = {future.key: task for future, task in zip(futures, tasks)}
    pending, seen = set(futures), time.monotonic()
    while pending:
        try:
            done, pending = wait(pending, timeout=POLL_S, return_when="FIRST_COMPLETED")
        except TimeoutError:
            done = set()
        for future in done:
            try:
                yield owner[future.key], future.result()
            except Exception as exc:  # a lost worker: the point is retried next run
                yield owner[future.key], exc
        if not pending or client.nthreads():
            seen = time.monotonic()
        elif time.monotonic() - seen > no_workers_s:
            client.cancel(list(pending))
            lost = NoWorkers(f"the Dask scheduler at {client.scheduler.address} has had no "
                             f"worker for {no_workers_s:g} s (--timeout); {len(pending)} "
                             "point(s) not computed, a rerun computes them")
            for future in pending:
                yield owner[future.key], lost
            return
