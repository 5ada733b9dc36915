"""``convimpact bench --quick --sections simulation atlas``: JSON, charts and measured facts.

Smoke test of the two sections (no timing assertions); the facts checked are derived
independently: the event-driven runs converge to the tight reference, Moreau–Jean's
post-impact error falls with h on the pendulum drop (it is O(h)), the compliant model's
penetration falls about as k^(-1/(n+1)) (100^(1/2.5) ~ 6.3 between k = 1e5 and 1e7), the
fast paths' singular cells of the pendulum map lie on the folded/stretched lines
theta2 in {0, +-pi} (rank-one tip Jacobian, see tests/studies/test_atlas.py).
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from convimpact import cli

#: slow: the two sections run every scheme on three scenes and build the six atlas maps (about
#: a minute quiet, several on a cold cache). The fast suite keeps the facts they rest on:
#: event-driven convergence (tests/simulation/test_simulate*.py), Moreau-Jean's O(h) approach
#: (tests/simulation/test_moreau.py), the compliant model's k-scaling
#: (tests/simulation/test_compliant.py), the atlas maps and the singular lines theta2 in
#: {0, +-pi} (tests/studies/test_atlas.py, and the atlas as studies in test_study.py), and the
#: bench's JSON and charts (tests/bench/test_bench.py and the other sections' tests).
pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    out = tmp_path_factory.mktemp("bench_sim_atlas")
    code = cli.main(["bench", "--quick", "--out", str(out), "--sections", "simulation",
                     "atlas"])
    assert code == 0
    report = json.loads((out / "bench.json").read_text(),
                        parse_constant=lambda c: pytest.fail(f"non-strict JSON {c}"))
    return out, report


def test_sections_write_charts(run):
    out, report = run
    for name in ("simulation", "atlas"):
        sec = report["sections"][name]
        assert sec["figures"] and sec["summary"]
        for f in sec["figures"]:
            assert (out / f).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    text = (out / "summary.txt").read_text()
    assert "[simulation]" in text and "[atlas]" in text


def test_simulation_records(run):
    _, report = run
    sec = report["sections"]["simulation"]
    recs = sec["records"]
    assert {r["scene"] for r in recs} == {"pendulum drop", "slider-crank", "bouncing rod"}
    assert {r["scheme"] for r in recs} == {"event-driven", "moreau-jean", "compliant"}
    for r in recs:
        assert r["error"] is None and r["status"] == 0
        for key in ("wall_time", "nfev", "rhs_per_second", "wall_per_simulated_second",
                    "impact_velocity_error", "final_state_error", "energy_error"):
            assert r[key] is not None
    ed = [r for r in recs if r["scheme"] == "event-driven" and r["options"]["rtol"] <= 1e-7]
    assert all(r["impact_velocity_error"] < 1e-5 for r in ed)
    mj = sorted((r for r in recs if r["scheme"] == "moreau-jean"
                 and r["scene"] == "pendulum drop"), key=lambda r: -r["options"]["h"])
    assert mj[-1]["impact_velocity_error"] < mj[0]["impact_velocity_error"]
    for scene in ("pendulum drop", "bouncing rod"):
        co = {r["options"]["stiffness"]: r for r in recs
              if r["scheme"] == "compliant" and r["scene"] == scene}
        ratio = co[1e5]["max_penetration"] / co[1e7]["max_penetration"]
        assert 100 ** (1 / 2.5) / 2 < ratio < 100 ** (1 / 2.5) * 2
    rows = sec["meta"]["throughput"]
    assert {r["scene"] for r in rows} == {"pendulum_planar", "slider_crank", "bouncing_rod"}
    for r in rows:
        assert r["rhs_per_second"] > 0 and 0 <= r["impact_share"] <= 1


def test_atlas_records(run):
    _, report = run
    sec = report["sections"]["atlas"]
    maps = {r["name"]: r for r in sec["records"]}
    assert set(maps) == {"pendulum_angles", "pendulum_friction", "slider_crank_scene",
                         "slider_crank_isosceles", "pendulum_drop", "rod_zeno"}
    pend = maps["pendulum_angles"]
    region = np.array(pend["regions"]["coulomb/fast"]["singular_delassus"], bool)
    for i in np.nonzero(region.any(axis=1))[0]:
        y = pend["y"][i]
        assert min(abs(y), abs(abs(y) - math.pi)) < 1e-5  # bench.json keeps 6 digits
    for m in maps.values():
        for path, counts in m["counts"].items():
            for mode, n in counts.items():
                assert (n > 0) == (mode in m["regions"].get(path, {}))
    impact_maps = ("pendulum_angles", "pendulum_friction", "slider_crank_scene",
                   "slider_crank_isosceles")
    assert all(c["unexpected_error"] == 0 for k in impact_maps
               for c in maps[k]["counts"].values())
    assert all(c["singular_loop"] > 0 for c in maps["slider_crank_isosceles"]["counts"].values())
    totals = sec["meta"]["totals"]
    assert totals["pereira-nikravesh/closed-form"]["non_positive_effective_mass"] == 0
