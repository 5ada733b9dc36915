"""Bench section ``model``: its records, chart and summary, and that it times like for like.

The section runs in quick mode (no timing is asserted: the machine is shared). What is
asserted: every (kind, n, quantity) has ours, ours unchecked and Pinocchio's rows; the timed
calls of both sides compute the same M, f and contact Jacobian rows (so the ratios compare
equal work); the dropped chain simulates on both backends to the same final state for a
few links; the summary quotes a ratio per quantity.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from convimpact.bench import BenchConfig, section_names
from convimpact.bench.model_problems import dropped_chain, pinocchio_twin, random_mechanism
from convimpact.bench.model_section import (KINDS, QUANTITIES, chain_sizes, evaluation_calls,
                                            run_model, sizes)
from convimpact.bench.registry import strict_json
from convimpact.bench.threads import blas_threads

pin = pytest.importorskip("pinocchio")


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    out = tmp_path_factory.mktemp("bench_model")
    messages: list[str] = []
    with blas_threads(1):
        res = run_model(BenchConfig.make(out, quick=True), messages.append)
    return out, res, messages


def test_registered():
    assert "model" in section_names()


def test_records_chart_and_summary(run):
    out, res, messages = run
    assert res.name == "model"
    assert (out / "model_scaling.png").stat().st_size > 10_000
    for kind in KINDS:
        for n in sizes(True):
            for qty in QUANTITIES:
                impls = {r["implementation"] for r in res.records if r["kind"] == kind
                         and r["n_bodies"] == n and r["quantity"] == qty}
                assert impls == {"ours", "ours (unchecked)", "pinocchio"}
    sims = [r for r in res.records if r["quantity"] == "simulation"]
    assert {(r["kind"], r["implementation"]) for r in sims} == {
        ("planar chain", "ours"), ("spatial chain", "ours"), ("spatial chain", "pinocchio")}
    assert all(r["median"] > 0 and r["nfev"] > 0 for r in sims)
    assert len(sims) == 3 * len(chain_sizes(True))
    for qty in QUANTITIES:
        assert any(s.startswith(f"{qty}: ours") and "ratio ours/Pinocchio" in s
                   for s in res.summary)
    assert any("dropped chain" in s for s in res.summary)
    assert set(res.meta["ratios"]) >= set(QUANTITIES)
    json.dumps(strict_json(res.records))
    assert any("compiling" in m for m in messages)


@pytest.mark.parametrize("planar,chain", [(True, True), (True, False), (False, True),
                                          (False, False)])
def test_both_sides_compute_the_same_quantities(planar, chain):
    model, theta, dtheta = random_mechanism(6, planar, chain, seed=3)
    twin = pinocchio_twin(model)
    calls = evaluation_calls(model, theta, dtheta, twin)
    inv = np.argsort(twin["permutation"])
    # every call's first evaluation is at theta + 0.1
    M = calls[("M", "ours")]()
    Mp = np.array(calls[("M", "pinocchio")]()).reshape(M.shape)
    Mp = np.triu(Mp) + np.triu(Mp, 1).T
    assert np.allclose(M, Mp[np.ix_(inv, inv)], atol=1e-12)
    f = calls[("f", "ours")]()
    fp = -np.array(calls[("f", "pinocchio")]())[inv]
    assert np.allclose(f, fp, atol=1e-11 * max(1.0, np.abs(f).max()))
    J = calls[("Jc", "ours")]()
    Jp = np.array(calls[("Jc", "pinocchio")]()).reshape(6, -1)[:, inv]
    n = np.asarray(model.contacts[0].normal)  # the normal row: n . (linear rows)
    assert np.allclose(J[0], n @ Jp[:model.dim], atol=1e-12)
    assert np.allclose(calls[("M", "ours (unchecked)")](), M, atol=0)
    assert np.allclose(calls[("f", "ours (unchecked)")](), f, atol=0)
    assert np.allclose(calls[("Jc", "ours (unchecked)")]()[:model.dim], J, atol=0)


def test_the_dropped_chain_runs_alike_on_both_backends():
    from convimpact.simulation import simulate
    model, th0, dth0 = dropped_chain(4, planar=False)
    twin = pinocchio_twin(model)
    ours = simulate(model.mechanism(), (0.0, 0.6), (th0, dth0))
    theirs = simulate(twin["mechanism"], (0.0, 0.6), (th0, dth0))
    assert len(ours.impacts) == len(theirs.impacts) >= 1
    assert np.allclose(ours.theta[-1], theirs.theta[-1], atol=1e-7)
    assert np.allclose(ours.dtheta[-1], theirs.dtheta[-1], atol=1e-6)
