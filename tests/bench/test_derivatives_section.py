"""Bench section ``derivatives``: a quick run's records, chart and summary. No timing is
asserted (the machine is shared); what is asserted: every law with a single-contact derivative
is measured planar and spatial, the analytic answer equals the plain call's, the finite
differences agree with the analytic jacobians to their own accuracy, the finite-difference
call count is the one the module states, and the chart is a real PNG."""

from __future__ import annotations

import json

import pytest

from convimpact.bench import BenchConfig, section_names
from convimpact.bench.derivatives_section import derivatives_section, fd_calls
from convimpact.bench.registry import strict_json
from convimpact.bench.threads import blas_threads


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    out = tmp_path_factory.mktemp("bench_derivatives")
    messages: list[str] = []
    with blas_threads(1):
        res = derivatives_section(BenchConfig.make(out, quick=True, repeat=1),
                                  messages.append)
    return out, res, messages


def test_registered():
    assert "derivatives" in section_names()


def test_records(run):
    out, res, messages = run
    assert {(r["law"], r["d"]) for r in res.records} >= {("pereira-nikravesh", 2),
                                                         ("pereira-nikravesh", 3)}
    for r in res.records:
        assert r["answer_matches"]
        assert r["fd_deviation"] < 1e-7
        assert r["regime"] in ("stick", "slide")
        # k = 6: 6 for dq, 21 symmetric pairs of M, d k for Jc, e and mu, twice
        assert r["fd_calls"] == 2 * (6 + 21 + 6 * r["d"] + 2 + (r["law"] == "chatterjee-ruina"))
        assert r["time_solve"] > 0 and r["time_derivatives"] > 0 and r["time_fd"] > 0
    assert fd_calls(24, 3, False) == 796
    json.dumps(strict_json(res.records))
    assert messages and res.summary


def test_chart(run):
    out, res, _ = run
    (name,) = res.figures
    assert (out / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
