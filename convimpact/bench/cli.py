"""``convimpact bench``: the package benchmark (writes bench.json, summary.txt and PNG charts)."""

from __future__ import annotations

import argparse

from ..cli import command
from ..validation import arg_nonnegative_int, arg_positive_int
from .registry import DEFAULT_OUT, BenchConfig, run_bench, section_names, stderr_progress


def _add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--quick", action="store_true",
                   help="smoke run: one small problem per class, fewer settings and repeats")
    p.add_argument("--out", default=DEFAULT_OUT,
                   help=f"output directory (default ./{DEFAULT_OUT}/)")
    p.add_argument("--sections", nargs="+", choices=section_names(), metavar="SECTION",
                   help=f"sections to run (default all: {', '.join(section_names())})")
    p.add_argument("--repeat", type=arg_positive_int, default=None,
                   help="timed batches per median (default 7, quick 3)")
    p.add_argument("--seed", type=int, default=None, help="seed of the random problems")
    p.add_argument("--blas-threads", type=arg_nonnegative_int, default=1,
                   help="OpenBLAS threads during the run (default 1, as suits k <= 30; "
                        "0 leaves the library's own setting)")
    p.add_argument("--no-records", action="store_true",
                   help="leave the per-measurement records out of bench.json where a section "
                        "keeps their aggregates (a small file to commit)")


def _run(args) -> int:
    config = BenchConfig.make(args.out, args.quick, args.repeat, args.seed, args.blas_threads,
                              not args.no_records)
    report = run_bench(config, args.sections, stderr_progress())
    print(f"wrote {config.out}/bench.json, summary.txt and "
          f"{sum(len(s['figures']) for s in report['sections'].values())} charts")
    for line in report["summary"]:
        print(f"- {line}")
    return 0


_run.add_arguments = _add_arguments
command("bench", "package benchmark: per-impact solver speed against accuracy, landscape "
                 "throughput, machine facts (writes bench.json, summary.txt, PNG charts)")(_run)
