"""Bench section ``busy``: records, ratios, chart and summary of a quick run.

No timing is asserted (the machine is shared); what is asserted: every case is timed in every
phase with finite positive latencies, the ratios are formed from them, the CPU-bound processes
the section started are gone afterwards, the chart is a real PNG and the summary states the
target.
"""

from __future__ import annotations

import json
import math
import subprocess

import pytest

from convimpact.bench import BenchConfig, section_names
from convimpact.bench import busy_section as busy
from convimpact.bench.registry import strict_json


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    out = tmp_path_factory.mktemp("bench_busy")
    messages: list[str] = []
    res = busy.busy_section(BenchConfig.make(out, quick=True, repeat=1), messages.append)
    return out, res, messages


def test_registered():
    assert "busy" in section_names()


def test_every_case_in_every_phase(run):
    out, res, _ = run
    seen = {(r["case"], r["phase"]) for r in res.records}
    assert seen == {(c[0], p) for c in busy.CASES for p in busy.PHASES}
    for r in res.records:
        for key in ("median_s", "mean_s", "p90_s", "max_s"):
            assert math.isfinite(r[key]) and r[key] > 0, r
        assert r["p90_s"] <= r["max_s"] and r["n_calls"] >= busy.N_PROBLEMS
        assert r["hogs"] == (busy.N_HOGS if r["phase"].endswith("busy") else 0)
        assert r["path"] == ("lane" if r["case"].endswith("lane") else "full")
        # the phase's median pools its windows' calls: it lies between their medians
        assert len(r["window_medians_s"]) == r["windows"] == res.meta["rounds"]
        assert min(r["window_medians_s"]) <= r["median_s"] <= max(r["window_medians_s"])
        share = r["other_threads_cpu_share"]
        assert share is None or (math.isfinite(share) and share >= 0)
    for r in res.meta["ratios"]:
        for key in ("busy", "clarabel quiet", "clarabel busy", "clarabel busy / clarabel quiet"):
            assert math.isfinite(r[key]) and r[key] > 0, r
    facts = res.meta["process"]
    assert facts["clarabel_solve_seconds"] > 0
    png = out / "busy_latency.png"
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 10_000
    assert sum("target busy / quiet" in s for s in res.summary) == len(busy.CASES)
    json.dumps(strict_json({"records": res.records, "meta": res.meta}))


def test_hogs_are_bounded_and_stopped():
    hogs = busy._start_hogs(2, deadline=30.0)
    try:
        assert all(p.poll() is None for p in hogs)
    finally:
        busy._stop_hogs(hogs)
    assert all(p.returncode is not None for p in hogs)
    # a hog left alone ends by itself at its deadline (0.2 s of spinning; the wait allows for
    # a loaded machine's slow start of Python)
    hog = busy._start_hogs(1, deadline=0.2)[0]
    try:
        hog.wait(timeout=300)
    except subprocess.TimeoutExpired:  # pragma: no cover
        hog.kill()
        pytest.fail("a hog given a 0.2 s deadline still ran 300 s later: it ignores its deadline")
    assert hog.returncode == 0


def test_a_failing_measurement_is_reported(monkeypatch):
    monkeypatch.setattr(busy, "_CHILD", "import sys\nsys.exit('no measurement here')\n")
    with pytest.raises(RuntimeError, match="no measurement here"):
        busy.run_child({"quick": True}, timeout=600.0)  # it exits at once
