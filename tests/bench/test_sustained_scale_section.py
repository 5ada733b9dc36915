"""The ``sustained-scale`` bench section: its MuJoCo observables on hand-made trajectories,
its growth exponents on a known power law, and its stop measurement agreeing with the
enumerator (checked in the section itself) on the quick tables."""

from __future__ import annotations

import math

import numpy as np
import pytest

from convimpact.bench.registry import BenchConfig
from convimpact.bench.sustained_scale_peers import FOOT_RADIUS, PeerRun, table_observables
from convimpact.bench.sustained_scale_section import growth, measure_stops
from convimpact.scenes import load_scene

G = 9.81


def test_table_observables_of_a_hand_made_slide():
    """A table translating at v(t) = v0 - mu g t until it stops, its feet exactly on the
    floor (z = height, identity attitude): stop time v0 / (mu g), distance v0^2 / (2 mu g),
    no penetration, the energy lost 1/2 m v0^2."""
    p = dict(load_scene("table", legs=5, v0=0.6).parameters)
    v0, mu, h = p["v0"], p["mu"], p["height"]
    t = np.arange(1, 251) * 2e-3
    t_stop = v0 / (mu * G)
    speed = np.maximum(v0 - mu * G * t, 0.0)
    dist = np.where(t < t_stop, v0 * t - 0.5 * mu * G * t ** 2, v0 ** 2 / (2 * mu * G))
    psi = math.radians(p["direction_deg"])
    qpos = np.zeros((t.size, 7))
    qpos[:, 0], qpos[:, 1] = dist * math.cos(psi), dist * math.sin(psi)
    qpos[:, 2] = h
    qpos[:, 3] = 1.0
    qvel = np.zeros((t.size, 6))
    qvel[:, 0], qvel[:, 1] = speed * math.cos(psi), speed * math.sin(psi)
    obs = table_observables(p, PeerRun(t, qpos, qvel, 0.1))
    assert obs["stop_time"] == pytest.approx(t_stop, abs=2e-3)
    assert obs["distance"] == pytest.approx(v0 ** 2 / (2 * mu * G), rel=1e-12)
    assert obs["penetration"] == pytest.approx(0.0, abs=1e-15)
    assert obs["energy_lost"] == pytest.approx(1.0, rel=1e-12)
    assert FOOT_RADIUS > 0


def test_growth_is_the_power_law_exponent():
    records = [{"contacts": n, "t": 3e-4 * n ** 1.5} for n in (4, 8, 16, 32)]
    assert growth(records, "t") == pytest.approx(1.5, rel=1e-12)
    assert growth(records[:1], "t") is None


def test_stops_agree_with_the_enumerator_on_the_quick_tables():
    records = measure_stops(BenchConfig.make(quick=True, repeat=1), lambda line: None)
    assert {r["contacts"] for r in records} == {3, 4, 8, 16}
    enumerated = [r for r in records if r["enumerator_time"] is not None]
    assert enumerated and all(r["agree"] for r in enumerated if r["agree"] is not None)
    assert all(r["ours_time"] > 0 for r in records)
    rest = {r["contacts"]: r for r in records if r["scene"] == "table-rest"}
    assert all(set(r["ours_modes"]) == {"stick"} for r in rest.values())


def test_aggregate_reports_wall_and_cpu_ratios_per_contact_count():
    """Hand-made records: the ratios ours / MuJoCo are those of the given times, wall and
    CPU apart, and the summary quotes both."""
    from convimpact.bench.sustained_scale_section import aggregate, summary_lines

    def rec(scheme, n, wall, cpu):
        return {"part": "simulation", "scene": "table-slide", "contacts": n, "scheme": scheme,
                "wall_per_second": wall, "cpu_per_second": cpu, "penetration": 0.0}

    stops = [{"part": "stop", "scene": f"table-{k}", "contacts": n, "ours_time": 1e-3 * n,
              "enumerator_time": None, "agree": None} for k in ("rest", "slide") for n in (4, 8)]
    records = stops + [rec("event-driven", 4, 0.04, 0.02), rec("mujoco", 4, 0.002, 0.0025),
                       rec("event-driven", 8, 0.06, 0.03), rec("mujoco", 8, 0.004, 0.005)]
    agg = aggregate(records)["table-slide"]
    assert agg["ratio_ours_over_mujoco"] == pytest.approx({4: 20.0, 8: 15.0}, rel=1e-12)
    assert agg["ratio_ours_over_mujoco_cpu"] == pytest.approx({4: 8.0, 8: 6.0}, rel=1e-12)
    lines = summary_lines(aggregate(records))
    assert any("4: 20.0x, 8: 15.0x" in line for line in lines)
    assert any("CPU time" in line and "4: 8.0x, 8: 6.0x" in line for line in lines)
