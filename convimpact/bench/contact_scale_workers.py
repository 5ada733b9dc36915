"""Forked worker processes for the peers of the bench section ``contact-scale``: each holds
one peer call (Pinocchio's ADMM or PGS on one problem), times batches of it on demand, and
is killed when a batch lasts longer than its limit (:data:`TIME_LIMIT`) or when building the
peer does (:data:`BUILD_LIMIT`); a worker whose process dies (Pinocchio 4.1's PGS
overflowed the default 8 MB stack from about 400 contacts on) reports ``crashed`` with the
signal.
"""

from __future__ import annotations

import multiprocessing
import signal
import time
from typing import Any, Callable

import numpy as np

from .threads import blas_threads

#: seconds one peer call may last before its worker is killed
TIME_LIMIT = 60.0
#: seconds a worker may take to build the peer (embedding, Delassus operator)
BUILD_LIMIT = 120.0


def _raise_stack_limit() -> None:
    """Lift this process's soft stack limit to the hard one: Pinocchio 4.1's PGS overflows the
    default 8 MB stack from about 400 contacts on (a segmentation fault; it runs with more)."""
    try:
        import resource

        soft, hard = resource.getrlimit(resource.RLIMIT_STACK)
        if soft != resource.RLIM_INFINITY and (hard == resource.RLIM_INFINITY or hard > soft):
            resource.setrlimit(resource.RLIMIT_STACK, (hard, hard))
    except (ImportError, ValueError, OSError):
        pass


def _serve(make_call: Callable[[], Callable[[], Any]], conn) -> None:
    """The worker: build the call, then time batches of it on demand."""
    _raise_stack_limit()
    try:
        with blas_threads(1):
            call = make_call()
            conn.send(("ready", None, None, None, None))
            while True:
                n_inner = conn.recv()
                if n_inner is None:
                    break
                t = time.perf_counter()
                try:
                    for _ in range(n_inner):
                        value = call()
                except Exception as exc:  # a peer reporting no convergence
                    conn.send(("failed", time.perf_counter() - t, None, None,
                               f"{type(exc).__name__}: {exc}"))
                    continue
                conn.send(("ok", (time.perf_counter() - t) / n_inner, np.asarray(value),
                           None, None))
    except (EOFError, BrokenPipeError, KeyboardInterrupt):
        pass
    except Exception as exc:  # the peer could not be built
        try:
            conn.send(("failed", None, None, None, f"{type(exc).__name__}: {exc}"))
        except (BrokenPipeError, OSError):
            pass


def _signal_name(number: int) -> str:
    try:
        return signal.Signals(number).name
    except ValueError:
        return "unknown signal"


class PeerWorker:
    """A forked process holding one peer call; :meth:`run` times a batch of it, and kills the
    process when the batch lasts longer than ``limit`` seconds."""

    def __init__(self, make_call: Callable[[], Callable[[], Any]]):
        ctx = multiprocessing.get_context("fork")
        self.conn, child = ctx.Pipe()
        self.proc = ctx.Process(target=_serve, args=(make_call, child), daemon=True)
        self.proc.start()
        child.close()
        self.ready = self._receive(BUILD_LIMIT)

    def _receive(self, limit: float) -> tuple:
        try:
            if self.conn.poll(limit):
                return self.conn.recv()
        except (EOFError, OSError):  # the peer crashed its process (a segmentation fault)
            self.proc.join(5.0)
            code = self.proc.exitcode
            self.close()
            how = (f"killed by signal {-code} ({_signal_name(-code)})" if code and code < 0
                   else f"exit code {code}")
            return ("crashed", None, None, None, f"the worker process died: {how}")
        self.close()
        return ("timeout", limit, None, None, f"no answer within {limit:g} s")

    def run(self, n_inner: int = 1, limit: float = TIME_LIMIT) -> tuple:
        """``(status, seconds per call, impulse, None, error)``; status ok, failed, timeout
        or crashed (the seconds then: to the failure, the limit, or None)."""
        if self.proc is None:
            return ("failed", None, None, None, "the worker was closed")
        self.conn.send(int(n_inner))
        return self._receive(limit)

    def close(self) -> None:
        if self.proc is None:
            return
        try:
            self.conn.send(None)
        except (BrokenPipeError, OSError):
            pass
        self.proc.join(0.5)
        if self.proc.is_alive():
            self.proc.kill()
            self.proc.join()
        self.conn.close()
        self.proc = None
