"""Bench section ``coldstart``: a quick run (the single-contact scenario only, cold then warm
in fresh processes on a temporary cache) gives its records, chart and summary.

No timing is asserted (the machine is shared); what is asserted: the cold run compiled (and
said so on stderr, once), the warm run compiled nothing and said nothing, the chart is a real
PNG and the summary states the target.
"""

from __future__ import annotations

import json

import pytest

from convimpact.bench import BenchConfig, section_names
from convimpact.bench.registry import strict_json

pytest.importorskip("numba")

#: slow: compiles the kernels from nothing in fresh processes, whatever the cache holds; the
#: fast suite checks the same cold compile and warm load in tests/test_compile_cache.py
pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    from convimpact.bench.coldstart_section import coldstart_section

    out = tmp_path_factory.mktemp("bench_coldstart")
    messages: list[str] = []
    res = coldstart_section(BenchConfig.make(out, quick=True, repeat=1), messages.append)
    return out, res, messages


def test_registered():
    assert "coldstart" in section_names()


def test_cold_compiles_and_warm_loads(run):
    out, res, messages = run
    rows = {(r["scenario"], r["cache"]): r for r in res.records}
    assert set(rows) == {("single", "cold"), ("single", "warm")}
    cold, warm = rows["single", "cold"], rows["single", "warm"]
    assert "error" not in cold and "error" not in warm
    assert cold["compile_cpu"] > 0.0 and warm["compile_cpu"] == 0.0
    assert len(cold["messages"]) == 1 and "single-contact lane" in cold["messages"][0]
    assert warm["messages"] == []
    assert cold["total"] == pytest.approx(cold["import_convimpact"] + cold["first_use"])
    assert cold["key_seconds"] and all(0.0 < s < 5.0 for s in cold["key_seconds"])
    single = res.meta["breakdown"]["single"]
    top = single["top"]
    assert top and all(f["signatures"] >= 1 for f in top if "signatures" in f)
    assert any("reduce_one" in f["function"] for f in top)
    assert single["functions_compiled"] >= len([f for f in top if "numba." not in f["function"]])
    json.dumps(strict_json(res.records))  # JSON-ready


def test_chart_and_summary(run):
    out, res, _ = run
    assert res.figures == ["coldstart.png"]
    assert (out / "coldstart.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    text = " ".join(res.summary)
    assert "import + first single-contact call <= 10 s" in text
    assert "warm" in text
