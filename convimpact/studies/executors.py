"""Where a study's chunks run: in this process, on local processes, or on a Dask cluster.

An executor runs ``fn(*args)`` for each argument tuple and yields the results as they
complete (:meth:`Executor.run_unordered`); it is a context manager that releases its workers.

* :class:`SerialExecutor` -- this process, one chunk after another;
* :class:`ProcessExecutor` -- a pool of local processes (default: one per usable core);
* :class:`DaskExecutor` -- a ``distributed`` cluster given by a scheduler address or a
  ``Client``; a task whose worker dies is retried on another (``retries``).

:func:`make_executor` picks one from the command line's choices. The workers must reach the
study's store at the same path (one machine, or a shared file system on a cluster).
"""

from __future__ import annotations

import os
from typing import Any, Callable, Iterator, Sequence

from ..errors import UnknownOptionError

#: executor names of :func:`make_executor`
EXECUTORS = ("serial", "processes", "dask")


def usable_cores() -> int:
    """Cores this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - not Linux
        return os.cpu_count() or 1


class Executor:
    """Base: ``name``, ``n_workers`` and :meth:`run_unordered`."""

    name = "executor"
    n_workers = 1

    def run_unordered(self, fn: Callable, args: Sequence[tuple]) -> Iterator[Any]:
        raise NotImplementedError

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        """Release the workers."""


class SerialExecutor(Executor):
    """Every chunk in this process, in order."""

    name = "serial"

    def run_unordered(self, fn, args):
        for a in args:
            yield fn(*a)


class ProcessExecutor(Executor):
    """A pool of ``workers`` local processes (default one per usable core), started with
    ``spawn`` (no inherited threads or locks); on an interrupt (Ctrl-C) the queued chunks are
    cancelled, the running ones finish and are recorded, and the pool shuts down."""

    name = "processes"

    def __init__(self, workers: int | None = None):
        from ..validation import integer

        # None: every usable core; 0, -1, 2.5 or "2" are refused (ParameterError), not read
        # as the default
        self.n_workers = (usable_cores() if workers is None
                          else integer("workers", workers, minimum=1))
        self._pool = None

    def _ensure(self):
        if self._pool is None:
            import multiprocessing
            from concurrent.futures import ProcessPoolExecutor

            self._pool = ProcessPoolExecutor(self.n_workers,
                                             mp_context=multiprocessing.get_context("spawn"),
                                             initializer=_ignore_interrupts)
        return self._pool

    def run_unordered(self, fn, args):
        from concurrent.futures import as_completed

        pool = self._ensure()
        futures = [pool.submit(fn, *a) for a in args]
        try:
            for f in as_completed(futures):
                yield f.result()
        except BaseException:
            for f in futures:
                f.cancel()
            raise

    def close(self) -> None:
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=True)
            self._pool = None


def _ignore_interrupts() -> None:
    """Pool workers ignore Ctrl-C (sent to the whole process group): the parent cancels the
    queued chunks and the running ones finish and are recorded."""
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)


class DaskExecutor(Executor):
    """A Dask ``distributed`` cluster: ``client`` (used as is, left open) or ``address`` of a
    scheduler (a client is opened and closed here). Each chunk is one task with ``retries``
    retries (a worker killed mid-chunk: the task runs again elsewhere)."""

    name = "dask"

    def __init__(self, address: str | None = None, client=None, retries: int = 3):
        from distributed import Client

        if client is None and address is None:
            raise UnknownOptionError("the dask executor needs a scheduler address or a Client")
        self._own = client is None
        self.client = Client(address) if client is None else client
        self.retries = int(retries)
        self._futures: list = []

    @property
    def n_workers(self) -> int:  # type: ignore[override]
        info = self.client.scheduler_info(n_workers=-1)
        return max(1, sum(int(w.get("nthreads", 1)) for w in info["workers"].values()))

    def run_unordered(self, fn, args):
        from distributed import as_completed

        self._futures = [self.client.submit(fn, *a, pure=False, retries=self.retries)
                         for a in args]
        try:
            for f in as_completed(self._futures):
                yield f.result()
        except BaseException:
            self.client.cancel(self._futures)
            raise
        finally:
            self._futures = []

    def close(self) -> None:
        if self._own:
            self.client.close()


def make_executor(name: str | None = None, workers: int | None = None,
                  scheduler: str | None = None, client=None) -> Executor:
    """An executor: ``client`` or ``scheduler`` give Dask; else ``name`` (default
    ``"processes"``) with ``workers`` processes."""
    if workers is not None:
        from ..validation import integer

        workers = integer("workers", workers, minimum=1)
    if client is not None or scheduler:
        return DaskExecutor(scheduler, client)
    name = name or "processes"
    if name == "serial":
        return SerialExecutor()
    if name == "processes":
        return ProcessExecutor(workers)
    if name == "dask":
        raise UnknownOptionError("the dask executor needs --scheduler ADDRESS")
    raise UnknownOptionError(f"unknown executor {name!r}; choose from {', '.join(EXECUTORS)}")
