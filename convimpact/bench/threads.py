"""Pin the BLAS libraries loaded in this process to a number of threads during a bench run.

The benchmark's matrices are small (k <= 30): a multi-threaded BLAS only adds
synchronisation, and on a busy machine its spinning threads slowed 2 x 2 triangular solves by
a factor of about 50 in our measurements. Setting ``OPENBLAS_NUM_THREADS`` before Python
starts works too; this module does the same at run time for the OpenBLAS builds shipped with
numpy and scipy (found in ``/proc/self/maps``, set through their ``*openblas_set_num_threads*``
entry points with ctypes) and restores the previous counts afterwards. Elsewhere (no
``/proc``, another BLAS) it changes nothing and says so.
"""

from __future__ import annotations

import ctypes
import os
from contextlib import contextmanager
from typing import Iterator

_SUFFIXES = ("", "64_", "_64")


def _loaded_openblas() -> list[str]:
    try:
        with open("/proc/self/maps") as fh:
            paths = {line.split()[-1] for line in fh if "openblas" in line.lower()}
    except OSError:
        return []
    return sorted(p for p in paths if "openblas" in os.path.basename(p).lower())


def _functions(lib: ctypes.CDLL):
    get = setf = None
    for prefix in ("scipy_openblas", "openblas"):
        for suf in _SUFFIXES:
            try:
                get = get or getattr(lib, f"{prefix}_get_num_threads{suf}")
                setf = setf or getattr(lib, f"{prefix}_set_num_threads{suf}")
            except AttributeError:
                continue
    return get, setf


@contextmanager
def blas_threads(n: int | None) -> Iterator[dict]:
    """Within the block the loaded OpenBLAS libraries use ``n`` threads (None: unchanged).

    Yields a JSON-ready dict: requested count, the libraries set and their previous counts,
    and the ``OPENBLAS_NUM_THREADS`` / ``OMP_NUM_THREADS`` environment.
    """
    info = {"requested": n, "libraries": [],
            "env": {k: os.environ.get(k) for k in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS",
                                                  "MKL_NUM_THREADS")}}
    restore = []
    if n is not None:
        for path in _loaded_openblas():
            try:
                lib = ctypes.CDLL(path)
            except OSError:
                continue
            get, setf = _functions(lib)
            if get is None or setf is None:
                continue
            before = int(get())
            setf(int(n))
            restore.append((setf, before))
            info["libraries"].append({"library": os.path.basename(path), "before": before,
                                      "during": int(get())})
        if not info["libraries"]:
            info["note"] = "no OpenBLAS found to set; thread count unchanged"
    try:
        yield info
    finally:
        for setf, before in restore:
            setf(before)
