"""Bench section ``sustained``: its records, charts and the facts it measures.

The section runs in quick mode on the planar ball, the rocking block and Painleve's rod at
mu = 1.5 (no timing is asserted; the machine is shared). What is asserted, besides the
documented structure: Moreau–Jean converges to the event-driven reference as h -> 0 (its
final-state error at h = 1e-3 is below half its error at h = 4e-3; the scheme is O(h) through
a transition, so a factor 4 in h gives about 4), and the event-driven run at rtol = 1e-8 meets
the closed forms (the ball's roll time 2|v0|/(7 mu g) and final speed 5 v0/7, Housner's exact
first landing time) to 1e-6 relative. The helpers are checked against hand values.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from convimpact.bench import BenchConfig, section_names
from convimpact.bench.registry import strict_json
from convimpact.bench.sustained_references import (
    housner_first_landing_time,
    wheel_first_strike_time,
)
from convimpact.bench.sustained_section import equal_error_ratio, run_sustained, scene_keys
from convimpact.bench.threads import blas_threads
from convimpact.errors import UnknownOptionError

SCENES = ["ball", "rocking-block", "painleve-paradox"]


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    out = tmp_path_factory.mktemp("bench_sustained")
    messages: list[str] = []
    with blas_threads(1):
        res = run_sustained(BenchConfig.make(out, quick=True), messages.append, scenes=SCENES)
    return out, res, messages


def _rows(res, scene, scheme):
    return [r for r in res.records if r["scene"] == scene and r["scheme"] == scheme]


def test_registered_and_scene_keys():
    assert "sustained" in section_names()
    assert set(SCENES) <= set(scene_keys())
    with pytest.raises(UnknownOptionError):
        run_sustained(BenchConfig.make("unused", quick=True), print, scenes=["no-such-scene"])


def test_records_charts_and_summary(run):
    out, res, messages = run
    assert res.name == "sustained"
    assert {r["scene"] for r in res.records} == {"ball", "rocking-block"}
    for scene in ("ball", "rocking-block"):
        ed, mj = _rows(res, scene, "event-driven"), _rows(res, scene, "moreau-jean")
        assert sorted(r["options"]["rtol"] for r in ed) == [1e-8, 1e-6]
        assert sorted(r["options"]["h"] for r in mj) == [1e-3, 4e-3]
    for r in res.records:
        assert r["error"] is None and r["status"] == 0
        for key in ("wall_time", "n_steps", "final_state_error", "energy_error",
                    "observable_error", "closed_form", "span", "setting"):
            assert r[key] is not None, key
        assert r["wall_time"] > 0
    assert res.figures == ["sustained_work_precision.png", "sustained_convergence.png"]
    for f in res.figures:
        data = (out / f).read_bytes()
        assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 10_000
    # one sentence per scene, the ratio over scenes, the paradox
    assert len(res.summary) == 4
    assert res.summary[0].startswith("ball (planar)") and "observed order" in res.summary[0]
    assert "Painleve" in res.summary[-1]
    assert any("moreau-jean h=0.001" in m for m in messages)
    agg = res.meta["aggregates"]
    assert set(agg) == {"ball", "rocking-block"}
    for a in agg.values():
        assert a["mj_h"] == [4e-3, 1e-3] and a["order_final_state"] is not None
        assert a["equal_error"]["ratio"] > 0
    # strict JSON (the bench writes it so)
    json.dumps(strict_json({"records": res.records, "meta": dict(res.meta)}), allow_nan=False)


def test_moreau_jean_error_falls_with_h(run):
    _, res, _ = run
    for scene in ("ball", "rocking-block"):
        mj = {r["options"]["h"]: r for r in _rows(res, scene, "moreau-jean")}
        assert mj[1e-3]["final_state_error"] < 0.5 * mj[4e-3]["final_state_error"], scene
        # ... and at the smallest h it is still far from the event-driven runs
        ed = min(r["final_state_error"] for r in _rows(res, scene, "event-driven"))
        assert ed < mj[1e-3]["final_state_error"]
    # the block lands within a step of Housner's time
    block = {r["options"]["h"]: r for r in _rows(res, "rocking-block", "moreau-jean")}
    t_land = block[1e-3]["closed_form"]["first_landing_time"]["exact"]
    for h, r in block.items():
        assert abs(r["closed_form"]["first_landing_time"]["value"] - t_land) <= h


def test_event_driven_meets_the_closed_forms(run):
    _, res, _ = run
    (ball,) = [r for r in _rows(res, "ball", "event-driven") if r["options"]["rtol"] == 1e-8]
    cf = ball["closed_form"]
    g, mu, v0 = 9.81, 0.2, 2.0  # the scene's defaults
    assert cf["roll_time"]["exact"] == pytest.approx(v0 / (3.5 * mu * g), rel=1e-14)
    assert cf["final_speed"]["exact"] == pytest.approx(5 * v0 / 7, rel=1e-14)
    assert cf["roll_time"]["error"] < 1e-6 and cf["final_speed"]["error"] < 1e-6
    (block,) = [r for r in _rows(res, "rocking-block", "event-driven")
                if r["options"]["rtol"] == 1e-8]
    assert block["closed_form"]["first_landing_time"]["error"] < 1e-6
    refs = res.meta["references"]
    for key in ("ball", "rocking-block"):
        assert refs[key]["status"] == 0
        assert all(v["error"] < 1e-9 for v in refs[key]["closed_form"].values())
    assert refs["rocking-block"]["impact_times"][0] == pytest.approx(
        block["closed_form"]["first_landing_time"]["exact"], rel=1e-9)


def test_painleve_paradox_is_recorded_not_compared(run):
    _, res, _ = run
    px = res.meta["painleve_paradox"]
    assert px["params"]["mu"] == 1.5 and px["painleve_A"] < 0
    ed = px["event_driven"]
    assert ed["status"] == 2 and ed["t_stop"] == 0.0 and ed["painleve"][0]["kind"] == \
        "inconsistent"
    assert [r["h"] for r in px["moreau_jean"]] == [4e-3, 1e-3]
    for r in px["moreau_jean"]:
        assert r["completed"] and r["t_end"] == pytest.approx(px["span"][1])
        assert math.isfinite(r["energy_end"]) and r["energy_end"] < r["energy_start"]
    assert not any(r["scene"].startswith("painleve") for r in res.records)


def test_housner_and_wheel_quadratures():
    # small tilt: the block falls under the constant angular acceleration p^2 sin(alpha)
    # (the linearized p^2 alpha is 0.3 % off here), T ~ sqrt(2 tilt / (p^2 sin alpha))
    alpha, R = math.atan(0.2), 0.5 * math.hypot(0.2, 1.0)
    p2 = 3 * 9.81 / (4 * R)
    tilt = 1e-4 * alpha
    assert housner_first_landing_time(tilt, alpha, R) == pytest.approx(
        math.sqrt(2 * tilt / (p2 * math.sin(alpha))), rel=1e-4)
    # a nearly upright leg barely moves: T ~ angle / omega0 for a fast wheel
    assert wheel_first_strike_time(100.0, 0.01, 1.0, 0.1) == pytest.approx(1e-4, rel=1e-6)


def test_equal_error_ratio_interpolates_and_falls_back():
    def row(scheme, setting, err, wall):
        return {"scheme": scheme, "setting": setting, "final_state_error": err,
                "wall_time": wall}

    ed = [row("event-driven", "a", 1e-4, 1.0), row("event-driven", "b", 1e-8, 10.0)]
    mj = [row("moreau-jean", "h1", 1e-3, 1.0), row("moreau-jean", "h2", 1e-6, 50.0)]
    q = equal_error_ratio(mj, ed)
    assert q["how"] == "interpolated" and q["mj_setting"] == "h2"
    assert q["ed_wall_time"] == pytest.approx(10 ** 0.5) and q["ratio"] == pytest.approx(
        50 / 10 ** 0.5)
    q = equal_error_ratio([row("moreau-jean", "h", 1e-2, 3.0)], ed)
    assert q["how"] == "cheapest" and q["ratio"] == pytest.approx(3.0)
    q = equal_error_ratio([row("moreau-jean", "h", 1e-9, 3.0)], ed)
    assert q["how"] is None and q["ratio"] is None
    # round-off counts as equal: the cheapest of each
    ed0 = [row("event-driven", "a", 1e-15, 2.0), row("event-driven", "b", 1e-16, 4.0)]
    mj0 = [row("moreau-jean", "h1", 3e-15, 1.0), row("moreau-jean", "h2", 1e-15, 8.0)]
    q = equal_error_ratio(mj0, ed0)
    assert q["roundoff"] and q["mj_setting"] == "h1" and q["ed_setting"] == "a"
    assert q["ratio"] == pytest.approx(0.5)
    assert np.isfinite(q["ratio"])
