"""Bench section ``public``: records, chart and summary of a quick run; the public call's
answers against independent references (Clarabel's convex programs, Coulomb's own residual,
the Python kernels) and Pinocchio's answers against them at its tolerance.

No timing is asserted (the machine is shared); what is asserted: every law and shape has the
public call, the Python kernel and the compiled kernel timed, their errors are at round-off,
the peers agree to their tolerance, the chart is a real PNG and the summary states the targets.
"""

from __future__ import annotations

import json

import pytest

from convimpact.bench import BenchConfig, section_names
from convimpact.bench.public_section import LAWS, SHAPES, public_section
from convimpact.bench.registry import strict_json
from convimpact.bench.threads import blas_threads


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    out = tmp_path_factory.mktemp("bench_public")
    messages: list[str] = []
    with blas_threads(1):
        res = public_section(BenchConfig.make(out, quick=True, repeat=1), messages.append)
    return out, res


def test_registered():
    assert "public" in section_names()


def test_every_path_is_timed_and_at_round_off(run):
    out, res = run
    for law in LAWS:
        for d, k in SHAPES:
            rows = {r["path"]: r for r in res.records
                    if r["law"] == law and r["d"] == d and r["k"] == k}
            assert {"resolve_impact", "kernel from Python", "compiled kernel"} <= set(rows)
            for path in ("resolve_impact", "kernel from Python", "compiled kernel"):
                assert rows[path]["seconds_per_impact"] > 0
                assert rows[path]["max_error"] <= 1e-9, (law, d, k, rows[path])
            for path in ("pinocchio ADMM", "pinocchio PGS"):
                if path in rows:  # a peer library at its tolerance 1e-10
                    assert rows[path]["max_error"] <= 1e-6, rows[path]
    png = out / "public_call.png"
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 10_000
    assert sum("target" in s for s in res.summary) == 2
    json.dumps(strict_json(res.records))
