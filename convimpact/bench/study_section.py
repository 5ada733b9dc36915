"""Section ``study``: throughput of the study runner on one process, local processes, Dask.

One ``impacts`` study (:mod:`convimpact.studies.study_impacts`: the double pendulum's tip
impacts over theta1 x theta2 x law, compiled batches) is run into a fresh Zarr store by

* ``serial``: this process;
* ``processes``: a pool of local processes, one per usable core;
* ``dask``: a local Dask cluster (a scheduler and one single-threaded worker process per
  usable core), the path a cluster takes.

Each executor is started and warmed first by a small study (process start, imports, loading
the compiled kernels from numba's cache: ``startup_seconds``), then the measured study runs on
the warm workers: ``impacts_per_second`` (points over wall time), ``speedup`` against serial
and the **scheduling overhead** ``1 - (compute + write) / (workers x wall)``: the share of the
workers' time not spent evaluating or writing chunks (task dispatch, serialization, store
bookkeeping, idle workers at the tail). The same study on ``processes`` at several chunk sizes
shows how the overhead falls with the chunk's work; the kind's default chunk is chosen where it
is under 5 %. Every run's dataset is checked bit for bit against the serial one.
"""

from __future__ import annotations

import shutil
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

from .charts import save_chart
from .registry import BenchConfig, Progress, SectionResult, register_section

#: (theta1 points, theta2 points, laws) of the measured study (full, quick)
SIZES = ((600, 600, 4), (60, 60, 2))
#: chunk sizes of the overhead sweep (full, quick); None: the runner's default chunking
CHUNKS = ((10_000, 50_000, None), (None,))
LAWS = ("pereira-nikravesh", "coulomb", "ccp", "dissipative")


def study_dict(n1: int, n2: int, n_laws: int, chunk: int | None) -> dict[str, Any]:
    """The measured study (``chunk`` None: the runner's default chunking)."""
    study: dict[str, Any] = {"kind": "impacts", "title": "bench: double pendulum impacts"}
    if chunk is not None:
        study["chunk_points"] = int(chunk)
    return {"study": study,
            "options": {"scene": "pendulum_planar", "dtheta": [1.0, 1.0]},
            "grid": {"theta1": {"start": -3.0, "stop": -0.1, "num": n1},
                     "theta2": {"start": -3.0, "stop": 3.0, "num": n2},
                     "law": {"values": list(LAWS[:n_laws])}}}


def _same(a, b) -> bool:
    """Equal data and coordinates to the last bit (the global attrs name the chunk size)."""
    a, b = a.drop_attrs(deep=False), b.drop_attrs(deep=False)
    return a.identical(b) and all(
        np.array_equal(a[v].values.view(np.uint8), b[v].values.view(np.uint8))
        for v in a.data_vars)


def _run(spec, ex, root: Path, tag: str):
    from ..studies.study import run_study

    path = root / f"{tag}.zarr"
    shutil.rmtree(path, ignore_errors=True)
    run = run_study(spec, path, ex, progress=False)
    shutil.rmtree(path, ignore_errors=True)
    return run


def _record(run, executor: str, chunk: int, startup: float, serial_rate: float | None,
            identical: bool) -> dict[str, Any]:
    return {"executor": executor, "chunk_points": chunk, "workers": run.n_workers,
            "chunks": run.n_chunks, "points": run.points_computed,
            "wall_seconds": run.wall_time, "compute_seconds": run.compute_time,
            "write_seconds": run.write_time, "startup_seconds": startup,
            "compute_cpu_seconds": run.compute_cpu_time,
            "cpu_share": run.compute_cpu_time / run.compute_time if run.compute_time else None,
            "impacts_per_second": run.points_per_second,
            "speedup": (run.points_per_second / serial_rate) if serial_rate else 1.0,
            "overhead_fraction": run.overhead_fraction, "identical_to_serial": identical}


@register_section("study", "study runner throughput: one process, local processes, a local "
                           "Dask cluster; scheduling overhead against chunk size")
def study_section(config: BenchConfig, progress: Progress) -> SectionResult:
    """Run the measured study on every executor (warm) and the chunk-size sweep."""
    from distributed import Client, LocalCluster

    from ..studies.executors import ProcessExecutor, SerialExecutor, usable_cores
    from ..studies.study_spec import spec_from_dict

    from ..studies.study_kinds import get_kind
    from ..studies.study_store import default_chunk_points

    q = 1 if config.quick else 0
    n1, n2, nl = SIZES[q]
    spec = spec_from_dict(study_dict(n1, n2, nl, None))
    default = default_chunk_points(spec, get_kind("impacts"))
    chunks = tuple(default if c is None else c for c in CHUNKS[q])
    warm = spec_from_dict(study_dict(8, 8, nl, 64))
    cores = usable_cores()
    records: list[dict[str, Any]] = []
    root = Path(tempfile.mkdtemp(prefix="convimpact-bench-study-"))
    try:
        t = time.perf_counter()
        ex = SerialExecutor()
        _run(warm, ex, root, "warm")
        startup = time.perf_counter() - t
        ref = _run(spec, ex, root, "serial")
        serial_rate = ref.points_per_second
        records.append(_record(ref, "serial", default, startup, None, True))
        progress(f"study serial: {serial_rate:.3g} impacts/s")
        def chunk_sweep(ex, name: str, started: float) -> None:
            """Warm the executor's workers, then run the study at every chunk size."""
            _run(warm, ex, root, "warm")
            startup = time.perf_counter() - started
            for c in chunks:
                s = spec if c == default else spec_from_dict(study_dict(n1, n2, nl, c))
                run = _run(s, ex, root, f"{name}{c}")
                records.append(_record(run, name, c, startup, serial_rate,
                                       _same(run.dataset, ref.dataset)))
                progress(f"study {name} chunk {c}: {run.points_per_second:.3g} impacts/s, "
                         f"overhead {100 * run.overhead_fraction:.1f} %")

        t = time.perf_counter()
        with ProcessExecutor(cores) as ex:
            chunk_sweep(ex, "processes", t)
        t = time.perf_counter()
        with LocalCluster(n_workers=cores, threads_per_worker=1, processes=True,
                          dashboard_address=None) as cluster, Client(cluster) as client:
            from ..studies.executors import DaskExecutor

            chunk_sweep(DaskExecutor(client=client), "dask", t)
    finally:
        shutil.rmtree(root, ignore_errors=True)
    figures = [_chart(records, config.out, spec.n_points, cores)]
    by = {(r["executor"], r["chunk_points"]): r for r in records}
    summary = [f"study runner on {spec.n_points} impacts ({n1} x {n2} configurations x {nl} "
               f"laws, default chunks of {default} points, {cores} usable cores): serial "
               f"{by[('serial', default)]['impacts_per_second']:.3g}/s; local processes "
               f"{by[('processes', default)]['impacts_per_second']:.3g}/s "
               f"({by[('processes', default)]['speedup']:.2f}x, overhead "
               f"{100 * by[('processes', default)]['overhead_fraction']:.1f} %); local Dask "
               f"{by[('dask', default)]['impacts_per_second']:.3g}/s "
               f"({by[('dask', default)]['speedup']:.2f}x, overhead "
               f"{100 * by[('dask', default)]['overhead_fraction']:.1f} %); every dataset "
               f"bit-identical to serial: {all(r['identical_to_serial'] for r in records)}",
               "CPU share of the chunk evaluations (CPU time / wall time inside them; below 1 "
               "when other processes share the cores): " + ", ".join(
                   f"{r['executor']} {r['cpu_share']:.2f}" for r in records
                   if r["chunk_points"] == default and r["cpu_share"] is not None),
               "scheduling overhead against chunk size: " + "; ".join(
                   f"{c} points: processes {100 * by[('processes', c)]['overhead_fraction']:.1f}"
                   f" %, Dask {100 * by[('dask', c)]['overhead_fraction']:.1f} %"
                   for c in chunks)]
    meta = {"definitions": "impacts_per_second = points / wall (warm workers); overhead = 1 - "
                           "(compute + write) / (workers x wall); startup = the warm-up "
                           "study's wall time (process start, imports, kernels)",
            "study": study_dict(n1, n2, nl, default)}
    return SectionResult("study", records, figures, summary, meta)


def _chart(records, out, n_points: int, cores: int) -> str:
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    fig, (a, b) = plt.subplots(1, 2, figsize=(10, 4))
    best = {}
    for r in records:
        if r["executor"] not in best or r["chunk_points"] > best[r["executor"]]["chunk_points"]:
            best[r["executor"]] = r
    names = list(best)
    rates = [best[n]["impacts_per_second"] for n in names]
    bars = a.bar(names, rates, color=["0.6", "#1f78b4", "#33a02c"][:len(names)])
    for bar, n in zip(bars, names):
        r = best[n]
        a.annotate(f"{r['speedup']:.2f}x\noverhead {100 * r['overhead_fraction']:.1f} %"
                   if n != "serial" else "1x", (bar.get_x() + bar.get_width() / 2,
                                                bar.get_height()),
                   ha="center", va="bottom", fontsize=8)
    a.set_ylabel("impacts per second (warm workers)")
    a.set_ylim(0, 1.25 * max(rates))
    a.set_title(f"{n_points:,} impacts, {cores} workers", fontsize=9)
    sweep = sorted((r for r in records if r["executor"] == "processes"),
                   key=lambda r: r["chunk_points"])
    b.plot([r["chunk_points"] for r in sweep], [100 * r["overhead_fraction"] for r in sweep],
           "o-", color="#1f78b4", label="local processes")
    d = sorted((r for r in records if r["executor"] == "dask"), key=lambda r: r["chunk_points"])
    b.plot([r["chunk_points"] for r in d], [100 * r["overhead_fraction"] for r in d], "s-",
           color="#33a02c", label="local Dask")
    b.axhline(5.0, color="r", lw=0.8, ls="--", label="5 % target")
    b.set_xscale("log")
    b.set_xlabel("points per chunk")
    b.set_ylabel("scheduling overhead [% of workers' time]")
    b.legend(fontsize=8)
    b.set_title("overhead against chunk size", fontsize=9)
    fig.tight_layout()
    return save_chart(fig, out, "study_throughput.png")
