"""Run a study: a grid or a sample of parameters in, an ``xarray.Dataset`` out, chunk by chunk.

:func:`run_study` takes a validated :class:`~convimpact.studies.study_spec.StudySpec` (or a path
to its TOML), creates or reopens its Zarr store (:mod:`convimpact.studies.study_store`), skips
the chunks already complete there, runs the others on an executor
(:mod:`convimpact.studies.executors`: this process, local processes by default, or a Dask
cluster) and opens the dataset from the store. Each chunk is one task, :func:`run_chunk`: the
worker reads the spec from the store, evaluates its points with the study's kind, writes its
region and then its completion record. The same spec gives the same bytes whichever executor
ran it (the chunks, the sampled values and each point's arithmetic do not depend on it); an
interrupted study (Ctrl-C, a lost worker, a crash) resumes from its store by running the same
call again.

Example (8e6 impacts, about a minute on two cores)::

    from convimpact.studies.study import run_study
    run = run_study("studies/pendulum_impact_atlas.toml", "atlas.zarr")
    run.dataset.energy_gained.mean("theta2")
"""

from __future__ import annotations

import math
import os
import shutil
import socket
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Mapping

import numpy as np

from .executors import Executor, make_executor
from .study_kinds import get_kind
from .study_spec import StudySpec, load_spec
from .study_store import StudyStore, StudyStoreError


@dataclass(frozen=True)
class StudyRun:
    """What :func:`run_study` did.

    Attributes
    ----------
    store : the store's path.
    dataset : the study's dataset (loaded), or None with ``load=False``.
    n_chunks : chunks of the study.
    chunks_computed : chunks computed by this run.
    chunks_skipped : chunks found complete in the store (a resumed study).
    executor : the executor's name; n_workers : its parallel workers.
    wall_time : seconds from starting the executor to the last chunk's completion.
    compute_time : seconds spent inside the kind's evaluation, summed over this run's chunks.
    write_time : seconds spent writing those chunks to the store, summed.
    setup_time : seconds to create or open the store.
    points_computed : points evaluated by this run.
    compute_cpu_time : CPU seconds of the workers' processes inside the evaluation (below
        ``compute_time`` when other processes share the cores).
    """

    store: Path
    dataset: Any
    n_chunks: int
    chunks_computed: int
    chunks_skipped: int
    executor: str
    n_workers: int
    wall_time: float
    compute_time: float
    write_time: float
    setup_time: float
    points_computed: int = 0
    compute_cpu_time: float = 0.0

    @property
    def overhead_fraction(self) -> float:
        """Share of the workers' time not spent evaluating or writing chunks (scheduling,
        serialization, process start, idle workers at the tail): 1 - (compute + write) /
        (n_workers x wall_time). NaN when nothing was computed."""
        if not self.chunks_computed or self.wall_time <= 0:
            return float("nan")
        busy = self.compute_time + self.write_time
        return max(0.0, 1.0 - busy / (self.n_workers * self.wall_time))

    @property
    def points_per_second(self) -> float:
        """Points computed per second of wall time by this run."""
        return self.points_computed / self.wall_time if self.wall_time > 0 else float("nan")


def chunk_points(spec: StudySpec, region: tuple[slice, ...]) -> dict[str, np.ndarray]:
    """Each swept parameter over a chunk's region (arrays of the chunk's shape)."""
    shape = tuple(s.stop - s.start for s in region)
    out: dict[str, np.ndarray] = {}
    for i, axis in enumerate(spec.grid):
        v = (np.array(axis.values[region[i]], dtype=object) if isinstance(axis.values[0], str)
             else np.asarray(axis.values[region[i]]))
        out[axis.name] = np.broadcast_to(v.reshape([1] * i + [-1] + [1] * (len(shape) - i - 1)),
                                         shape)
    if spec.sample_size:
        drawn = _sample_values(spec)
        for p in spec.sampled:
            out[p.name] = np.broadcast_to(drawn[p.name][region[-1]].reshape(
                [1] * (len(shape) - 1) + [-1]), shape)
    return out


_SAMPLES: dict[str, dict[str, np.ndarray]] = {}
_OPEN_STORES: dict[tuple[str, str], StudyStore] = {}


def _sample_values(spec: StudySpec) -> dict[str, np.ndarray]:
    key = spec.digest()
    if key not in _SAMPLES:
        _SAMPLES[key] = spec.sample_values()
    return _SAMPLES[key]


def _open_store(path: str, digest: str) -> StudyStore:
    key = (path, digest)
    if key not in _OPEN_STORES:
        store = StudyStore(path)
        if store.stored()["digest"] != digest:
            raise StudyStoreError(f"{path} holds another study than the one scheduled")
        _OPEN_STORES[key] = store
    return _OPEN_STORES[key]


def run_chunk(store_path: str, digest: str, index: int) -> dict[str, Any]:
    """Evaluate chunk ``index`` of the study in ``store_path`` and write it (the task run by
    every executor). Returns the chunk's completion record: ``chunk``, ``points``,
    ``compute_seconds``, ``write_seconds``, ``worker`` and the kind's ``meta``."""
    store = _open_store(store_path, digest)
    spec = store.spec
    region = store.regions()[index]
    points = chunk_points(spec, region)
    t0, c0 = time.perf_counter(), time.process_time()
    result = get_kind(spec.kind).evaluate(spec, points)
    t1, c1 = time.perf_counter(), time.process_time()
    store.write_chunk(index, result.arrays)
    t2 = time.perf_counter()
    record = {"chunk": int(index), "points": int(np.prod([s.stop - s.start for s in region])),
              "compute_seconds": t1 - t0, "compute_cpu_seconds": c1 - c0,
              "write_seconds": t2 - t1,
              "worker": f"{socket.gethostname()}:{os.getpid()}", "meta": dict(result.meta)}
    store.mark_done(index, record)
    return record


class _LineProgress:
    """Progress as plain lines on a stream that is not a terminal (a log, a pipe, a batch
    job's output): a line at the start, then one each tenth of the chunks and at the end."""

    def __init__(self, total: int, initial: int, label: str, stream=None):
        self.total, self.done, self.label = total, initial, label
        self.stream = stream or sys.stderr
        self.start = time.perf_counter()
        self.next = initial
        self._step = max(1, math.ceil((total - initial) / 10))
        self._say(f"{total - initial} of {total} chunks to compute"
                  + (f" ({initial} already in the store)" if initial else ""))
        self.next = initial + self._step

    def _say(self, text: str) -> None:
        self.stream.write(f"[{time.perf_counter() - self.start:7.1f}s] {self.label}: {text}\n")
        self.stream.flush()

    def update(self, n: int = 1) -> None:
        self.done += n
        if self.done >= self.next or self.done == self.total:
            self._say(f"{self.done}/{self.total} chunks ({100 * self.done // self.total} %)")
            self.next = self.done + self._step

    def close(self) -> None:
        pass


def _progress_bar(enabled: bool | None, total: int, initial: int, label: str):
    """tqdm's bar on a terminal; plain lines on any other stderr unless ``enabled`` is False
    (``None``: a bar on a terminal, lines otherwise)."""
    from tqdm import tqdm

    if enabled is False or (enabled is None and not sys.stderr.isatty()):
        if enabled is None and initial < total:
            return _LineProgress(total, initial, label)
        return tqdm(total=total, initial=initial, disable=True)
    return tqdm(total=total, initial=initial, file=sys.stderr, unit="chunk", desc=label,
                dynamic_ncols=True)


def require_studies_extra() -> None:
    """Raise :class:`~convimpact.errors.NotSupportedError` naming the ``studies`` extra
    unless xarray, zarr, dask and tqdm are importable."""
    import importlib

    from ..errors import NotSupportedError

    missing = []
    for name in ("xarray", "zarr", "dask", "tqdm"):
        try:
            importlib.import_module(name)
        except ImportError:
            missing.append(name)
    if missing:
        raise NotSupportedError(
            f"studies need {', '.join(missing)}: pip install \"convimpact[studies]\"")


def run_study(spec: StudySpec | str | Path, store: str | Path, executor: Executor | str |
              None = None, *, workers: int | None = None, scheduler: str | None = None,
              client=None, progress: bool | None = None, load: bool = True,
              on_chunk: Callable[[Mapping[str, Any]], None] | None = None) -> StudyRun:
    """Run (or resume) a study into its Zarr store and return its dataset.

    Parameters
    ----------
    spec : the spec, or the path of its TOML file (validated before any work starts).
    store : the Zarr store's path (created when absent; a store of the same spec resumes).
    executor : an :class:`~convimpact.studies.executors.Executor`, or a name ("serial",
        "processes"); default local processes on every usable core, or Dask when
        ``scheduler`` or ``client`` is given.
    workers : processes of the local pool (default: usable cores).
    scheduler, client : a Dask scheduler address or ``distributed.Client``.
    progress : a tqdm progress bar on stderr (True); none (False); default: the bar when
        stderr is a terminal, else plain lines (the start, each tenth of the chunks, the end).
    load : load the dataset into memory (False: a lazy, Dask-backed dataset).
    on_chunk : called with each completed chunk's record, in completion order.

    Returns
    -------
    StudyRun
        The dataset and what this run computed, with its timings.

    Raises
    ------
    StudySpecError
        for a bad spec (before any work and before the store is touched);
    StudyStoreError
        when ``store`` holds another study or is not a study store;
    NotSupportedError
        when xarray, zarr, dask or tqdm (the ``studies`` extra) are not installed.
    """
    if not isinstance(spec, StudySpec):
        spec = load_spec(spec)
    require_studies_extra()
    t0 = time.perf_counter()
    # the executor first (its arguments checked, e.g. workers >= 1), then the store: a study
    # that cannot start leaves no store behind
    own = not isinstance(executor, Executor)
    ex = (make_executor(executor if isinstance(executor, str) else None, workers, scheduler,
                        client) if own else executor)
    try:
        created = not Path(store).exists()  # this run creates the store's folder
        st = StudyStore.open_or_create(store, spec)
    except BaseException:
        if own:
            ex.close()
        raise
    n = len(st.regions())
    done = st.done()
    todo = [i for i in range(n) if i not in done]
    setup = time.perf_counter() - t0
    compute = write = cpu = 0.0
    computed = points = 0
    bar = _progress_bar(progress, n, n - len(todo), spec.title or spec.kind)
    t1 = time.perf_counter()
    try:
        if todo:
            args = [(str(st.path), spec.digest(), i) for i in todo]
            for record in ex.run_unordered(run_chunk, args):
                computed += 1
                points += record["points"]
                compute += record["compute_seconds"]
                cpu += record["compute_cpu_seconds"]
                write += record["write_seconds"]
                bar.update(1)
                if on_chunk is not None:
                    on_chunk(record)
        wall = time.perf_counter() - t1
        n_workers = ex.n_workers
    except BaseException:
        if created and computed == 0:
            # nothing was computed into the store this run created: remove it (a store with
            # finished chunks stays, and the same command resumes it)
            shutil.rmtree(st.path, ignore_errors=True)
        raise
    finally:
        bar.close()
        if own:
            ex.close()
    missing = n - len(st.done())
    if missing:
        raise StudyStoreError(f"{st.path}: {missing} of {n} chunks have no completion record "
                              "after the run; run the study again to resume")
    ds = st.open_dataset(load=load)
    return StudyRun(st.path, ds, n, computed, n - len(todo), ex.name, n_workers, wall,
                    compute, write, setup, points, cpu)
