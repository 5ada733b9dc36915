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
from convimpact.bench.model_section import (KINDS, QUANTITIES, SIM_KINDS, aba_free_motion,
                                            chain_sizes, evaluation_calls, exponent, run_model,
                                            sizes, tree_sizes)
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
    sims = [r for r in res.records if r["quantity"] in ("simulation", "free motion")]
    assert {(r["kind"], r["quantity"], r["implementation"]) for r in sims} == {
        (kind, qty, impl) for kind in SIM_KINDS for qty, impl in
        [("simulation", "ours"), ("simulation", "pinocchio"), ("free motion", "ours"),
         ("free motion", "pinocchio aba")]}
    assert all(r["median"] > 0 and r["nfev"] > 0 for r in sims)
    n_sizes = 2 * len(chain_sizes(True)) + 2 * len(tree_sizes(True))
    assert len(sims) == 4 * n_sizes
    # both backends of the simulator and ABA follow the same motion (small n: not chaotic)
    for r in sims:
        if r["n_bodies"] <= 5 and "final_state_difference" in r:
            assert r["final_state_difference"] < 1e-5, r
    assert sum("final_state_difference" in r for r in sims) == 3 * n_sizes
    for qty in QUANTITIES:
        assert any(s.startswith(f"{qty}: ours") and "ratio ours/Pinocchio" in s
                   for s in res.summary)
    assert any(s.startswith("one simulated second with contacts") for s in res.summary)
    assert any(s.startswith("one simulated second of the free motion") for s in res.summary)
    assert any("growth exponent" in s for s in res.summary)
    assert set(res.meta["ratios"]) >= set(QUANTITIES) | {"simulation", "free motion"}
    assert set(res.meta["exponents"]["M"]) >= {"ours", "pinocchio"}
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


def test_exponent_is_the_log_log_slope():
    # time = 3 n^1.5 in one kind, 2 n^0.5 in another: the median of the slopes is 1.0
    recs = [{"kind": kind, "n_bodies": n, "quantity": "M", "implementation": "ours",
             "median": c * n ** p} for kind, c, p in (("a", 3.0, 1.5), ("b", 2.0, 0.5))
            for n in (2, 5, 10, 50)]
    assert exponent(recs, "M", "ours") == pytest.approx(1.0, abs=1e-12)
    assert exponent(recs[:2], "M", "ours") is None  # fewer than three sizes


def test_aba_free_motion_is_the_closed_form_pendulum_for_small_swings():
    # one uniform link (1 m, 1 kg) on a pivot, hanging at theta = -pi/2, released at a = 1e-3
    # rad from it: theta(t) = -pi/2 + a cos(w t), w^2 = m g (L/2) / (m L^2 / 3), up to O(a^3)
    from convimpact.bench.model_problems import without_contacts
    model, _, _ = dropped_chain(1, True)
    twin = pinocchio_twin(without_contacts(model))
    a, t1 = 1e-3, 0.7
    w = np.sqrt(9.81 * 0.5 / (1.0 / 3.0))
    wall, nfev, q_end = aba_free_motion(twin, np.array([-np.pi / 2 + a]), np.zeros(1), (0.0, t1))
    assert wall > 0 and nfev > 0
    assert q_end[0] == pytest.approx(-np.pi / 2 + a * np.cos(w * t1), abs=1e-8)
