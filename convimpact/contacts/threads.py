"""The contact engine's dense factorizations on one BLAS thread.

OpenBLAS spreads a factorization of a few hundred rows over its threads; on a machine whose
cores are busy with other processes its spinning threads then wait for one another (a
435-row Cholesky measured 0.43 s instead of 5 ms with two other CPU-bound processes on two
cores). The engine's factorizations run inside :func:`one_blas_thread`, which sets the
OpenBLAS libraries loaded by numpy and scipy to one thread (found once in
``/proc/self/maps``, set through their ``openblas_set_num_threads`` entry points) and restores
their counts afterwards; elsewhere (another BLAS, no ``/proc``) it changes nothing.
"""

from __future__ import annotations

import ctypes
import os
from contextlib import contextmanager
from typing import Iterator

_LIBRARIES: list | None = None


def _openblas() -> list:
    """``(get, set)`` thread-count functions of every OpenBLAS loaded (looked up once)."""
    global _LIBRARIES
    if _LIBRARIES is None:
        found = []
        try:
            with open("/proc/self/maps") as fh:
                paths = sorted({line.split()[-1] for line in fh
                                if "openblas" in os.path.basename(line.split()[-1]).lower()})
        except (OSError, IndexError):
            paths = []
        for path in paths:
            try:
                lib = ctypes.CDLL(path)
            except OSError:
                continue
            for prefix in ("scipy_openblas", "openblas"):
                for suffix in ("", "64_", "_64"):
                    get = getattr(lib, f"{prefix}_get_num_threads{suffix}", None)
                    setf = getattr(lib, f"{prefix}_set_num_threads{suffix}", None)
                    if get is not None and setf is not None:
                        found.append((get, setf))
        _LIBRARIES = found
    return _LIBRARIES


@contextmanager
def one_blas_thread() -> Iterator[None]:
    """Within the block every loaded OpenBLAS uses one thread."""
    restore = []
    for get, setf in _openblas():
        before = int(get())
        if before != 1:
            setf(1)
            restore.append((setf, before))
    try:
        yield
    finally:
        for setf, before in restore:
            setf(before)
