"""Command line: ``convimpact study SPEC.toml --out STORE`` and ``convimpact atlas --out DIR``.

Both run on local processes (every usable core) by default, in this process with
``--executor serial``, or on a Dask cluster with ``--scheduler ADDRESS``; a progress bar goes
to stderr when it is a terminal (``--quiet``: none). Stopped with Ctrl-C, either resumes from
its store when run again with the same arguments.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from ..cli import command
from ..errors import ConvImpactError
from ..validation import arg_positive_int


def _executor_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("--scheduler", metavar="ADDRESS", default=None,
                   help="a Dask scheduler (e.g. tcp://host:8786): run the chunks on its "
                        "workers, which must reach the output path")
    p.add_argument("--executor", choices=("processes", "serial"), default="processes",
                   help="without --scheduler: local processes (default) or this process")
    p.add_argument("--workers", type=arg_positive_int, default=None,
                   help="local processes (default: one per usable core)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")


def _interrupted(what: str, out) -> int:
    print(f"convimpact: interrupted; the finished chunks are in {out}: run the same "
          f"command to resume the {what}", file=sys.stderr)
    return 130


def _study(args) -> int:
    from .study import run_study
    from .study_spec import load_spec

    spec = load_spec(args.spec)  # every error before any work
    try:
        run = run_study(spec, args.out, args.executor, workers=args.workers,
                        scheduler=args.scheduler, progress=False if args.quiet else None,
                        load=False)
    except KeyboardInterrupt:
        return _interrupted("study", args.out)
    except ConvImpactError as exc:
        from ..errors import InputError
        from .study_store import StudyStore, StudyStoreError

        # a run that failed after it started keeps its store (with any finished chunks): say
        # how to resume; bad arguments and a store of another study are not resumable
        if not isinstance(exc, (InputError, StudyStoreError)) and StudyStore(args.out).exists():
            raise type(exc)(f"{exc}; the finished chunks are in {args.out}: run the same "
                            "command to resume the study") from exc
        raise
    ds = run.dataset
    dims = ", ".join(f"{d} {n}" for d, n in ds.sizes.items())
    print(f"{spec.title or spec.kind}: {run.store} ({dims}; variables "
          f"{', '.join(ds.data_vars)})")
    if run.chunks_computed:
        print(f"computed {run.chunks_computed} of {run.n_chunks} chunks "
              f"({run.chunks_skipped} already in the store) on {run.executor} "
              f"({run.n_workers} workers) in {run.wall_time:.2f} s: "
              f"{run.points_per_second:.4g} points/s, scheduling overhead "
              f"{100 * run.overhead_fraction:.1f} %")
    else:
        print(f"all {run.n_chunks} chunks were already in the store")
    return 0


def _study_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("spec", help="the study's TOML spec (see convimpact.studies.study_spec)")
    p.add_argument("--out", required=True, help="the Zarr store (created, or resumed)")
    _executor_args(p)


_study.add_arguments = _study_args
command("study", "run a parameter study (a TOML spec) into a Zarr store, on local "
                 "processes or a Dask cluster")(_study)


def write_atlas(maps, out: str | Path) -> list[str]:
    """Write ``atlas.json`` (every map's JSON form without its wall time) and one PNG per map
    into ``out``; returns the files written."""
    import matplotlib.pyplot as plt

    from .atlas import plot_atlas

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    records = []
    files = ["atlas.json"]
    for m in maps:
        d = m.as_dict()
        d.pop("wall_time")
        records.append(d)
        name = f"atlas_{m.name}.png"
        plt.close(plot_atlas(m, out / name))
        files.append(name)
    (out / "atlas.json").write_text(json.dumps({"maps": records}, indent=1) + "\n")
    return files


def _atlas(args) -> int:
    from .atlas_study import run_atlas

    try:
        maps = run_atlas(args.out, quick=args.quick, executor=args.executor,
                         workers=args.workers, scheduler=args.scheduler,
                         progress=False if args.quiet else None)
    except KeyboardInterrupt:
        return _interrupted("atlas", args.out)
    files = write_atlas(maps, args.out)
    for m in maps:
        met = sum(1 for c in m.counts.values() for v in c.values() if v)
        print(f"{m.name}: {m.n_samples} samples per path, {met} (path, mode) pairs met, "
              f"{m.wall_time:.1f} s of work")
    print(f"wrote {', '.join(files)} and the stores in {Path(args.out) / 'stores'}")
    return 0


def _atlas_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("--quick", action="store_true", help="coarse grids (seconds)")
    p.add_argument("--out", required=True, help="output directory (maps, JSON, stores)")
    _executor_args(p)


_atlas.add_arguments = _atlas_args
command("atlas", "the failure atlas (every map), run as studies on local processes or a "
                 "Dask cluster")(_atlas)
