"""Bench section ``contact-scale``: a quick run on three tiny problems of the corpus (the quick
corpus monkeypatched), its bench.json checked against numbers derived here independently, and
the section's measures (power-law fit, performance profile, ADMM's 1e-10 fold, the worker's
time limit) on hand-made data.

No timing is asserted (the machine is shared).
"""

from __future__ import annotations

import json
import math
import os
import signal
import time

import numpy as np
import pytest

from convimpact.bench import BenchConfig, run_bench, section_names
from convimpact.bench import contact_scale_charts as csc
from convimpact.bench import contact_scale_section as css
from convimpact.bench import contact_scale_workers as csw
from convimpact.bench.contact_corpus import corpus
from convimpact.bench.contact_peers import natural_map_residual

TINY = ("rod-on-rod-3", "random-several-n2-d2", "four-corner-box")
KEYS = {"problem", "family", "n", "dim", "law", "solver", "time_median", "residual",
        "certified", "iterations", "status", "claimed", "tol"}


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    out = tmp_path_factory.mktemp("bench_contact_scale")
    cases = {c.name: c for c in corpus(names=TINY)}
    messages: list[str] = []
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(css, "quick_corpus", lambda: list(cases.values()))
        # the section's limits on a peer's build (120 s) and call (60 s) made generous: on a
        # loaded machine with a cold cache a worker compiles its kernels first, and a tiny
        # problem should never be reported as timed out here
        mp.setattr(csw, "BUILD_LIMIT", 1800.0)
        mp.setattr(css, "TIME_LIMIT", 1800.0)
        run_bench(BenchConfig.make(out, quick=True, repeat=2), ["contact-scale"],
                  messages.append)
    report = json.loads((out / "bench.json").read_text())
    return out, report["sections"]["contact-scale"], cases, messages


def test_registered():
    assert "contact-scale" in section_names()


def test_json_structure_and_charts(run):
    out, sec, cases, messages = run
    recs = sec["records"]
    assert {r["problem"] for r in recs} == set(TINY)
    assert {r["law"] for r in recs} == {"ccp"}  # quick: the ccp law only
    for r in recs:
        assert KEYS <= set(r), r
        c = cases[r["problem"]]
        assert (r["n"], r["dim"], r["family"]) == (c.n_contacts, c.dim, c.family)
    for p in TINY:
        solvers = {r["solver"] for r in recs if r["problem"] == p}
        assert {"ours", "admm", "pgs"} <= solvers <= {"ours", "admm", "admm-1e-10", "pgs"}
        ours = next(r for r in recs if r["problem"] == p and r["solver"] == "ours")
        assert ours["time_median"] > 0 and ours["n_timed"] == 2 and ours["iterations"] >= 1
    assert sec["figures"] == ["contact_scale_times.png", "contact_scale_profile.png"]
    for name in sec["figures"]:
        png = (out / name).read_bytes()
        assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 10_000
    assert sum("contact-scale [" in m for m in messages) == len(TINY)


def test_residuals_recomputed_from_the_recorded_impulses(run):
    out, sec, cases, _ = run
    impulses = np.load(out / css.NPZ)
    checked = 0
    for r in sec["records"]:
        if r["status"] in ("ok", "uncertified"):
            c = cases[r["problem"]]
            imp = impulses[r["impulse_key"]]
            assert imp.shape == (c.n_contacts, c.dim)
            res = natural_map_residual(c.W, c.b, c.mu, imp, r["law"])
            assert res == pytest.approx(r["residual"], rel=1e-5, abs=1e-300)
            assert r["certified"] == (r["status"] == "ok" and res <= 1e-8)
            checked += 1
        else:
            assert r["certified"] is False
    assert checked >= 2 * len(TINY)
    # the engine certifies these three, and the independent residual agrees
    assert all(r["certified"] for r in sec["records"] if r["solver"] == "ours")


def test_summary_and_aggregates_follow_from_the_records(run):
    _, sec, _, _ = run
    recs = sec["records"]
    agg = sec["meta"]["aggregates"]["ccp"]
    by = {(r["problem"], r["solver"]): r for r in recs}

    def solved(p, s):
        r = by.get((p, s))
        if s == "admm" and not (r and r["certified"]):
            r = by.get((p, "admm-1e-10"))
        return r["time_median"] if r and r["certified"] else None

    counts = {s: sum(solved(p, s) is not None for p in TINY) for s in css.SOLVERS}
    assert agg["certified"] == counts
    ratios = [solved(p, "ours") / solved(p, "admm") for p in TINY
              if solved(p, "ours") and solved(p, "admm")]
    if ratios:
        assert agg["ratio_ours_admm_median"] == pytest.approx(float(np.median(ratios)),
                                                              rel=1e-4)
    assert agg["ratio_ours_admm_worst_past_40"] is None  # no problem past 40 contacts
    line = sec["summary"][0]
    assert line.startswith(f"ccp: certified at 1e-8 by the natural-map residual on "
                           f"{len(TINY)} problems: ours {counts['ours']}/{len(TINY)}")
    assert f"PGS {counts['pgs']}/{len(TINY)}" in line


def test_power_law_fit_recovers_a_synthetic_exponent():
    n = np.array([10, 20, 50, 100, 300, 1000])
    t = 3.7e-5 * n ** 1.5
    p, c = csc.power_law_fit(n, t)
    assert abs(p - 1.5) < 1e-9 and abs(c / 3.7e-5 - 1.0) < 1e-9
    assert math.isnan(csc.power_law_fit([10, 10], [1.0, 2.0])[0])


def test_performance_profile_of_a_hand_made_table():
    # problems: A 1 s / B 2 s;  A 4 s / B 2 s;  A unsolved / B 3 s
    # ratios to the fastest: A 1, 2, inf;  B 2, 1, 1
    table = {"A": [1.0, 4.0, None], "B": [2.0, 2.0, 3.0]}
    prof = csc.performance_profile(table, [1.0, 1.5, 2.0, 100.0])
    np.testing.assert_allclose(prof["A"], [1 / 3, 1 / 3, 2 / 3, 2 / 3])
    np.testing.assert_allclose(prof["B"], [2 / 3, 2 / 3, 1.0, 1.0])
    # a problem nobody solves counts against everyone
    prof = csc.performance_profile({"A": [1.0, None], "B": [None, math.inf]}, [1.0, 10.0])
    np.testing.assert_allclose(prof["A"], [0.5, 0.5])
    np.testing.assert_allclose(prof["B"], [0.0, 0.0])


def test_admm_counts_its_1e10_rerun_at_equal_accuracy():
    base = {"law": "ccp", "n": 5}
    recs = [
        {**base, "problem": "p", "solver": "ours", "certified": True, "time_median": 2.0},
        {**base, "problem": "p", "solver": "admm", "certified": False, "time_median": 0.5},
        {**base, "problem": "p", "solver": "admm-1e-10", "certified": True, "time_median": 1.0},
        {**base, "problem": "p", "solver": "pgs", "certified": False, "time_median": 0.1},
        {**base, "problem": "q", "solver": "ours", "certified": False, "time_median": 3.0},
        {**base, "problem": "q", "solver": "admm", "certified": True, "time_median": 4.0},
        {**base, "problem": "q", "solver": "pgs", "certified": True, "time_median": 5.0},
    ]
    problems, table = csc.certified_times(recs, "ccp")
    assert problems == ["p", "q"]
    assert table == {"ours": [2.0, None], "admm": [1.0, 4.0], "pgs": [None, 5.0]}


#: how long the sleepy peer sleeps: far longer than any test waits
SLEEP = 600.0
#: a limit no answer that comes at once can exceed, however loaded the machine
GENEROUS = 300.0


def _sleepy():
    def call():
        time.sleep(SLEEP)
        return np.zeros((1, 3))
    return call


def _refusing():
    def call():
        raise RuntimeError("did not converge")
    return call


def _crashing():
    def call():
        os.kill(os.getpid(), signal.SIGKILL)
    return call


def test_peer_worker_is_killed_past_its_time_limit():
    # the peer sleeps 600 s: its worker is killed at the 0.3 s limit (the bound on the wait is
    # generous, for a loaded machine; only a worker left to sleep to the end can exceed it)
    w = csw.PeerWorker(_sleepy)
    t = time.perf_counter()
    status, seconds, impulse, _, err = w.run(1, limit=0.3)
    waited = time.perf_counter() - t
    assert status == "timeout" and impulse is None and seconds == 0.3, (status, err)
    assert waited < GENEROUS, f"the worker was not killed at its 0.3 s limit: {waited:.0f} s"
    assert w.proc is None  # killed and closed
    # peers that answer at once: a failure, a crash (the generous limits are never reached)
    w = csw.PeerWorker(_refusing)
    try:
        status, _, impulse, _, err = w.run(1, limit=GENEROUS)
        assert status == "failed" and impulse is None and "did not converge" in err
    finally:
        w.close()
    w = csw.PeerWorker(_crashing)  # a peer that kills its process (as PGS's segfaults)
    status, seconds, impulse, _, err = w.run(1, limit=GENEROUS)
    assert status == "crashed" and seconds is None and "SIGKILL" in err and w.proc is None


def test_ours_call_passes_m_and_j_where_the_engine_rule_uses_them():
    # the rule (contact_problem.generalized_serves): the engine's sparse path, W sparse with at
    # least 200 rows; a 72-sphere pile has 216 rows, the tiny problems fewer than 200
    import scipy.sparse as sp

    from convimpact.contacts.contact_problem import generalized_serves

    big = corpus(names=("sphere-pile-sq-72",))[0]
    tiny = corpus(names=("four-corner-box",))[0]
    assert sp.issparse(big.W) and big.W.shape[0] >= 200 and generalized_serves(big.W)
    assert not generalized_serves(tiny.W)
    for case, expected in ((big, True), (tiny, False)):
        status, r, facts, err = css._ours_call(case, "coulomb")()
        assert status == "ok" and facts["generalized"] is expected
        assert natural_map_residual(case.W, case.b, case.mu, r, "coulomb") <= 1e-8


def test_family_exponents_are_fitted_per_family():
    # two families with exact power laws of different exponents (and a mixed overall slope)
    recs = []
    for fam, p, c in (("stack", 1.0, 1e-5), ("pile", 2.5, 1e-7)):
        for n in (10, 30, 100, 300, 1000):
            prob = f"{fam}-{n}"
            for solver, scale in (("ours", 1.0), ("admm", 2.0)):
                recs.append({"law": "coulomb", "problem": prob, "family": fam, "n": n,
                             "solver": solver, "status": "ok", "certified": True,
                             "time_median": scale * c * n ** p, "residual": 1e-12})
            recs.append({"law": "coulomb", "problem": prob, "family": fam, "n": n,
                         "solver": "pgs", "status": "ok", "certified": False,
                         "time_median": 1.0, "residual": 1e-3})
    agg = css.aggregate(recs, ["coulomb"])["coulomb"]
    fe = agg["family_exponents"]
    assert set(fe) == {"stack", "pile"}
    assert fe["stack"]["ours"]["exponent"] == pytest.approx(1.0, abs=1e-9)
    assert fe["pile"]["ours"]["exponent"] == pytest.approx(2.5, abs=1e-9)
    assert fe["pile"]["admm"]["coefficient"] == pytest.approx(2e-7, rel=1e-9)
    assert fe["stack"]["ours"]["points"] == 5
    line = [x for x in css.summary_lines({"coulomb": agg}) if "per family" in x][0]
    assert "pile n^2.50 (n^2.50)" in line and "stack n^1.00 (n^1.00)" in line
