"""Bench section ``moreau-scale``: a quick run (rows of 1 and 2 boxes, a 4 x 3 disc pile,
short spans), its bench.json checked against numbers recomputed here from its own records
(ratios, least-squares exponents) and against closed forms (Coulomb's sliding speed), and
its charts as real PNGs. No timing is asserted (the machine is shared).
"""

from __future__ import annotations

import json
import math

import pytest

pytest.importorskip("mujoco")

from convimpact.bench import BenchConfig, run_bench, section_names  # noqa: E402
from convimpact.bench import moreau_scale_section as mss  # noqa: E402


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    out = tmp_path_factory.mktemp("bench_moreau_scale")
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(mss, "QUICK_BOXES", (1, 2))
        mp.setattr(mss, "QUICK_SPAN", 0.04)
        mp.setattr(mss, "QUICK_OTHER_SPAN", 0.02)
        mp.setattr(mss, "QUICK_PILE_SPAN", 0.1)  # the lowest discs land at 0.045 s
        mp.setattr(mss, "REPEATS", 1)
        mp.setattr(mss, "MUJOCO_REPEATS", 1)
        run_bench(BenchConfig.make(out, quick=True, repeat=1), ["moreau-scale"],
                  lambda m: None)
    report = json.loads((out / "bench.json").read_text())
    return out, report["sections"]["moreau-scale"]


def test_registered():
    assert "moreau-scale" in section_names()


def test_ratios_and_exponents_follow_from_the_records(run):
    _, sec = run
    recs = sec["records"]
    rows = [r for r in recs if r.get("motion") and not r.get("ablation")]
    assert {(r["simulator"], r["law"], r["boxes"]) for r in rows} == {
        (s, law, n) for s, laws in (("moreau-jean", mss.LAWS + mss.OTHER_LAWS),
                                    ("mujoco", ("mujoco",))) for law in laws for n in (1, 2)}
    mj = {(r["contacts"], r["motion"]): r["wall_per_simulated_second"] for r in rows
          if r["simulator"] == "mujoco"}
    for t in sec["meta"]["table"]:
        assert t["ratio"] == pytest.approx(t["ours"] / mj[(t["contacts"], t["motion"])],
                                           rel=1e-5)
    for key, fit in sec["meta"]["exponents"].items():
        law, motion = key.split("/")
        pts = sorted((r["contacts"], r["wall_per_simulated_second"]) for r in rows
                     if r["law"] == law and r["motion"] == motion)
        (n1, t1), (n2, t2) = pts
        # (bench.json keeps 6 significant digits of each time: the exponent recomputed from
        # them is off by ~1e-6 absolute, which is large relative to an exponent near 0)
        assert fit["exponent"] == pytest.approx(math.log(t2 / t1) / math.log(n2 / n1),
                                                rel=1e-4, abs=1e-5)


def test_physics_of_the_runs(run):
    _, sec = run
    for r in sec["records"]:
        if r.get("motion") == "sliding" and r["law"] == "coulomb":
            # Coulomb's closed form: v(t) = v0 - mu g t on every box (to the certificate)
            assert r["speed_error"] < 1e-6
        if r.get("motion") == "rest" and r["simulator"] == "moreau-jean":
            assert r["max_penetration"] < 1e-12 and r["energy_rise"] < 1e-9
        if r.get("motion") == "sliding" and r["law"] in ("pereira-nikravesh", "stronge"):
            # the same closed form through resolve_impact, island by island
            assert r["speed_error"] < 1e-9 and r["max_lift"] < 1e-12
        if r["simulator"] == "moreau-jean" and not (r["law"] in ("ccp", "dissipative")
                                                    and r.get("motion") == "sliding"):
            # (CCP's sliding box takes off: u_n = mu |u_t| = 0.6 m/s at 2 m/s of slip; the
            # dissipative law is CCP's plastic program scaled)
            solver = r["contact_solver"]
            if r["law"] in mss.LAWS:
                assert solver["problems"] > 0
            elif "boxes" in r:
                # one resolve_impact call per box (island) and step, 4 contacts each
                steps = round(r["span"] / mss.STEP)
                assert solver["resolve_impact_calls"] == r["boxes"] * steps
                assert solver["largest_island"] == 4
    pile = [r for r in sec["records"] if r.get("scene") == "disc_pile"]
    assert {r["law"] for r in pile} == {"ccp", "coulomb", "mujoco"}
    assert all(r.get("unlisted_overlap", 0.0) == 0.0 for r in pile)


def test_charts_are_real_pngs(run):
    out, sec = run
    assert sec["figures"] == ["moreau_scale_growth.png", "moreau_pile.png"]
    for name in sec["figures"]:
        data = (out / name).read_bytes()
        assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 10_000
