"""Bench section ``several``: records, charts and summary of a quick run, and that Pinocchio's
ADMM (a peer library) and Clarabel answer the same problems as the interior solver.

No timing is asserted (the machine is shared); what is asserted: every law has the interior
solver's rows (kernel and the public resolve_impact) and Clarabel's on every problem, the interior answers
carry round-off accuracy, the peers' answers agree with them to the peers' own tolerance, the
charts are real PNGs, and the summary quotes the ratios and the first call's cost.
"""

from __future__ import annotations

import json

import pytest

from convimpact.bench import BenchConfig, section_names
from convimpact.bench.registry import strict_json
from convimpact.bench.several_contacts_section import LAWS, several_contacts_section
from convimpact.bench.threads import blas_threads


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    out = tmp_path_factory.mktemp("bench_several")
    messages: list[str] = []
    with blas_threads(1):
        res = several_contacts_section(BenchConfig.make(out, quick=True, repeat=1),
                                       messages.append)
    return out, res, messages


def test_registered():
    assert "several" in section_names()


def test_records_charts_and_summary(run):
    out, res, _ = run
    problems = {r["problem"] for r in res.records}
    assert any(p.startswith("box") for p in problems) and len(problems) >= 2
    for p in problems:
        for law in LAWS:
            paths = {r["path"] for r in res.records if r["problem"] == p and r["law"] == law
                     and "wall_time" in r}
            assert {"interior", "resolve_impact", "clarabel tol 1e-10"} <= paths
    for law in LAWS:
        png = out / f"several_contacts_{law}.png"
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 10_000
    assert any(s.startswith("first call of the interior kernels") for s in res.summary)
    assert res.meta["compile_seconds"]["this_process"] > 0
    json.dumps(strict_json(res.records))


def test_interior_answers_are_exact_and_the_peers_agree(run):
    _, res, _ = run
    for r in res.records:
        assert "failed" not in r or r["path"].startswith("pinocchio"), r
        if "wall_time" not in r:
            continue
        ours = r["path"] in ("interior", "resolve_impact")
        if ours or r["path"] == "clarabel tol 1e-10":
            assert r["law_residual"] <= 1e-10, r
        if ours and r["law"] == "ccp":
            # against Clarabel at 1e-12: a second, independent method
            assert r["error"] <= 1e-10, r
        if r["path"] == "pinocchio ADMM tol 1e-10" and r["law"] == "ccp":
            # a peer library solving the same program at its own tolerance
            assert r["error"] <= 1e-6, r
    if any(r["path"].startswith("pinocchio") for r in res.records):
        assert any(s.startswith("ccp: interior / Pinocchio ADMM") for s in res.summary)
