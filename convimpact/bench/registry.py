"""Bench sections: a registry of named measurements and the run that writes their report.

A *section* is a plain function ``section(config, progress) -> SectionResult``: it measures one
thing (per-impact solvers, landscape throughput, ...), returns JSON-ready ``records`` and the
paths of the PNG charts it drew into ``config.out``, plus a few summary sentences quoting its
own measured medians and ratios. :func:`register_section` adds one; :func:`run_bench` runs the
selected sections in registration order and writes ``bench.json`` and ``summary.txt``.
Later work (simulation work-precision, the failure atlas) plugs in as further sections.
"""

from __future__ import annotations

import json
import math
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from ..files import write_whole
from ..errors import UnknownOptionError

#: schema version of bench.json
SCHEMA = 1
#: significant digits of the floats written to bench.json (measurements carry no more)
SIGNIFICANT = 6
#: default output directory of ``convimpact bench``
DEFAULT_OUT = "convimpact-bench"

Progress = Callable[[str], None]


@dataclass(frozen=True)
class BenchConfig:
    """What a bench run measures and where it writes.

    Attributes
    ----------
    out : directory for bench.json, summary.txt and the PNG charts.
    quick : smoke run (few, small problems; every section still runs every path once).
    repeat : timed batches per measurement (the median and interquartile range are over them).
    seed : seed of every random problem (fixed, so runs compare).
    min_batch_time : a timed batch repeats a call until it lasts at least this long (seconds),
        so that microsecond calls are not dominated by the timer.
    blas_threads : threads of the loaded OpenBLAS libraries during the run (None: leave them;
        see :mod:`convimpact.bench.threads`).
    keep_records : False writes bench.json without the per-measurement records of sections
        that summarize them in ``meta["aggregates"]`` (a small file to commit).
    """

    out: Path = Path(DEFAULT_OUT)
    quick: bool = False
    repeat: int = 7
    seed: int = 20260521
    min_batch_time: float = 2e-3
    blas_threads: int | None = 1
    keep_records: bool = True

    @classmethod
    def make(cls, out: str | Path = DEFAULT_OUT, quick: bool = False, repeat: int | None = None,
             seed: int | None = None, blas_threads: int | None = 1,
             keep_records: bool = True) -> "BenchConfig":
        """Defaults for a full or a quick run (quick: 3 repeats, 0.5 ms batches)."""
        rep = repeat if repeat is not None else (3 if quick else 7)
        if int(rep) < 1:
            from ..errors import ParameterError
            raise ParameterError(f"repeat must be a positive integer, got {rep!r}")
        return cls(out=Path(out), quick=bool(quick), repeat=int(rep),
                   seed=cls.seed if seed is None else int(seed),
                   min_batch_time=5e-4 if quick else 2e-3,
                   blas_threads=None if not blas_threads else int(blas_threads),
                   keep_records=bool(keep_records))


@dataclass(frozen=True)
class SectionResult:
    """What one section measured.

    Attributes
    ----------
    name : the section's registered name.
    records : JSON-ready rows, one per measurement.
    figures : paths of the PNG charts written (relative to ``config.out``).
    summary : sentences for summary.txt quoting medians and ratios of this run.
    meta : JSON-ready definitions and settings of the section.
    """

    name: str
    records: list[dict[str, Any]]
    figures: list[str] = field(default_factory=list)
    summary: list[str] = field(default_factory=list)
    meta: Mapping[str, Any] = field(default_factory=dict)


Section = Callable[[BenchConfig, Progress], SectionResult]
_SECTIONS: dict[str, tuple[str, Section]] = {}


def register_section(name: str, description: str) -> Callable[[Section], Section]:
    """Decorator registering ``section(config, progress) -> SectionResult`` under ``name``."""

    def deco(fn: Section) -> Section:
        _SECTIONS[name] = (description, fn)
        return fn

    return deco


def section_names() -> list[str]:
    """Registered sections in run order."""
    return list(_SECTIONS)


def section_description(name: str) -> str:
    return _SECTIONS[name][0]


def stderr_progress(start: float | None = None, stream=None) -> Progress:
    """A progress callback printing ``[  12.3s] message`` lines on stderr."""
    t0 = time.perf_counter() if start is None else start
    out = stream or sys.stderr

    def progress(message: str) -> None:
        out.write(f"[{time.perf_counter() - t0:7.1f}s] {message}\n")
        out.flush()

    return progress


def strict_json(v):
    """Strict JSON values: numpy scalars/arrays become Python, floats keep
    :data:`SIGNIFICANT` digits, non-finite floats become None."""
    if isinstance(v, np.ndarray):
        return strict_json(v.tolist())
    if isinstance(v, (np.floating, float)):
        f = float(v)
        return float(f"{f:.{SIGNIFICANT}g}") if math.isfinite(f) else None
    if isinstance(v, (np.integer,)):
        return int(v)
    if isinstance(v, (np.bool_,)):
        return bool(v)
    if isinstance(v, Mapping):
        return {str(k): strict_json(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [strict_json(x) for x in v]
    if isinstance(v, Path):
        return str(v)
    return v


def run_bench(config: BenchConfig, sections: Sequence[str] | None = None,
              progress: Progress | None = None) -> dict[str, Any]:
    """Run the selected sections (all by default); write bench.json and summary.txt.

    Returns
    -------
    dict
        The report written to ``bench.json``: ``schema``, ``command``, ``config``, ``machine``,
        ``sections`` (name -> {description, records, figures, summary, meta, wall_time}),
        ``summary`` (all sentences) and ``wall_time``.
    """
    from .machine import machine_facts
    from .threads import blas_threads

    names = list(sections) if sections else section_names()
    unknown = [n for n in names if n not in _SECTIONS]
    if unknown:
        raise UnknownOptionError(f"unknown bench section(s) {', '.join(unknown)}; choose from "
                                 f"{', '.join(section_names())}")
    progress = progress or stderr_progress()
    out = Path(config.out)
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    report: dict[str, Any] = {
        "schema": SCHEMA,
        "command": "convimpact bench" + (" --quick" if config.quick else ""),
        "config": {"quick": config.quick, "repeat": config.repeat, "seed": config.seed,
                   "min_batch_time": config.min_batch_time, "blas_threads": config.blas_threads,
                   "sections": names},
        "machine": machine_facts(),
        "sections": {},
    }
    summary: list[str] = []
    with blas_threads(config.blas_threads) as threads:
        report["machine"]["blas_threads"] = threads
        _run_sections(config, names, progress, report, summary)
    report["summary"] = summary
    report["wall_time"] = time.perf_counter() - t0
    report = strict_json(report)
    write_whole(out / "bench.json", json.dumps(report, separators=(",", ":")) + "\n")
    write_whole(out / "summary.txt", format_summary(report))
    progress(f"wrote {out / 'bench.json'}, {out / 'summary.txt'} in {report['wall_time']:.1f}s")
    return report


def _run_sections(config: BenchConfig, names: list[str], progress: Progress,
                  report: dict[str, Any], summary: list[str]) -> None:
    for name in names:
        progress(f"section {name}: {section_description(name)}")
        ts = time.perf_counter()
        res = _SECTIONS[name][1](config, progress)
        wall = time.perf_counter() - ts
        records = res.records
        dropped = 0
        if not config.keep_records and "aggregates" in res.meta:
            records, dropped = [], len(res.records)
        report["sections"][name] = {
            "description": section_description(name), "wall_time": wall,
            "records": records, "records_dropped": dropped, "figures": list(res.figures),
            "summary": list(res.summary), "meta": dict(res.meta),
        }
        summary += res.summary
        progress(f"section {name} done in {wall:.1f}s ({len(res.records)} records, "
                 f"{len(res.figures)} figures)")


def format_summary(report: Mapping[str, Any]) -> str:
    """The text of summary.txt: machine facts, then every section's sentences."""
    m = report["machine"]
    lines = [
        f"convimpact bench ({'quick' if report['config']['quick'] else 'full'} run, "
        f"{report['config']['repeat']} timed batches per median), {m.get('timestamp')}",
        f"machine: {m.get('cpu_model')}, {m.get('cpu_count')} logical cores "
        f"({m.get('cpus_usable')} usable), load average {m.get('load_average')}, "
        f"BLAS threads {report['config'].get('blas_threads') or 'unchanged'}",
        "versions: " + ", ".join(f"{k} {v}" for k, v in m.get("versions", {}).items()),
        "",
    ]
    for name, sec in report["sections"].items():
        lines.append(f"[{name}] {sec['description']} ({sec['wall_time']:.1f} s)")
        lines += [f"  - {s}" for s in sec["summary"]]
        if sec["figures"]:
            lines.append("  charts: " + ", ".join(sec["figures"]))
        lines.append("")
    return "\n".join(lines)
