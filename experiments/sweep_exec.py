"""Executors of ``cardan sweep``: a local process pool, or a Dask distributed cluster.

Both take :class:`~.sweep_point.Point` items and yield each with its rows, or with the
error that lost it (a dead worker: the point is retried by the next run).
"""

from __future__ import annotations

import signal
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
                                   initializer=signal.signal,
                                   initargs=(signal.SIGINT, signal.SIG_IGN))
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


def dask(client, tasks: list[Point]) -> Iterator[tuple[Point, list[Row] | Exception]]:
    """Run ``tasks`` on a Dask cluster; yield each with its rows or the error."""
    from dask.distributed import as_completed as dask_completed

    futures = [client.submit(run_point, task, pure=False) for task in tasks]
    owner = {future.key: task for future, task in zip(futures, tasks)}
    for future in dask_completed(futures):
        try:
            yield owner[future.key], future.result()
        except Exception as exc:  # a lost worker: the point is retried next run
            yield owner[future.key], exc
