"""Wall-clock timing of one call: warm-up, batches, median and interquartile range."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any, Callable

import numpy as np

#: most calls in one timed batch
MAX_INNER = 2000


@dataclass(frozen=True)
class Timing:
    """Seconds per call over ``n_batches`` timed batches of ``n_inner`` calls each.

    Attributes
    ----------
    median, q1, q3 : median and quartiles of the per-call time over the batches.
    iqr : q3 - q1.
    best : fastest batch's per-call time.
    n_batches, n_inner : the batch layout.
    """

    median: float
    q1: float
    q3: float
    iqr: float
    best: float
    n_batches: int
    n_inner: int

    def as_dict(self) -> dict[str, Any]:
        return {"median": self.median, "q1": self.q1, "q3": self.q3, "iqr": self.iqr,
                "n_batches": self.n_batches, "n_inner": self.n_inner}


def time_call(fn: Callable[[], Any], repeat: int = 7, min_batch_time: float = 2e-3,
              warmup: int = 1) -> tuple[Timing, Any]:
    """Time ``fn()`` (``time.perf_counter``) after ``warmup`` untimed calls.

    Each of the ``repeat`` batches calls ``fn`` ``n_inner`` times, ``n_inner`` chosen from the
    last warm-up call so a batch lasts about ``min_batch_time`` (at most :data:`MAX_INNER`).
    Exceptions of ``fn`` propagate (from the warm-up, before any timing).

    Returns
    -------
    (Timing, the value of the last call)
    """
    value = None
    dt = 0.0
    for _ in range(max(1, warmup)):
        t = time.perf_counter()
        value = fn()
        dt = time.perf_counter() - t
    n_inner = int(min(MAX_INNER, max(1, math.ceil(min_batch_time / max(dt, 1e-9)))))
    per_call = []
    for _ in range(max(1, repeat)):
        t = time.perf_counter()
        for _ in range(n_inner):
            value = fn()
        per_call.append((time.perf_counter() - t) / n_inner)
    a = np.asarray(per_call)
    q1, med, q3 = (float(x) for x in np.percentile(a, [25, 50, 75]))
    return Timing(med, q1, q3, q3 - q1, float(a.min()), len(per_call), n_inner), value


def timed(fn, repeat: int, batch_time: float) -> tuple[dict[str, float], Any]:
    """Median process CPU time and wall time per call of ``fn`` over ``repeat`` batches of
    about ``batch_time`` seconds each, after a warm-up call. CPU time is the section's measure:
    on a shared machine the wall time also counts the other processes' turns."""
    value = fn()
    t = time.perf_counter()
    value = fn()
    n_inner = int(min(MAX_INNER, max(1, math.ceil(batch_time / max(
        time.perf_counter() - t, 1e-9)))))
    cpu, wall = [], []
    for _ in range(max(1, repeat)):
        c, w = time.process_time(), time.perf_counter()
        for _ in range(n_inner):
            value = fn()
        cpu.append((time.process_time() - c) / n_inner)
        wall.append((time.perf_counter() - w) / n_inner)
    return {"cpu": float(np.median(cpu)), "wall": float(np.median(wall)),
            "n_inner": n_inner}, value
