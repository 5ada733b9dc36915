"""Regression tests for the simulator review: missed impacts inside a step, false Zeno
alarms, held contacts that slide without friction.

Expected numbers come from closed forms (free flight of a rod: parabola + linear angle), the
ball's geometric bounce sequence, or a second run with a much smaller ``max_step``.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import brentq

import convimpact as ci

from .coulomb_checks import assert_coulomb
from convimpact.simulation import simulate

G = 9.81


# ---------------------------------------------------------------------------------------------
# 1. an impact inside one long free-flight step (the gap dips below zero and comes back)
# ---------------------------------------------------------------------------------------------
def test_rod_impact_inside_one_step_is_found():
    scene = ci.load_scene("bouncing_rod")
    L = scene.parameters["length"]
    y0, omega = 0.505, 10.0
    res = simulate(scene.mechanism, (0.0, 0.4), ((0.0, y0, 0.0), (0.0, 0.0, omega)))

    # free flight: centre height y0 - g t^2 / 2, angle omega t; end_a is at -L/2 along the rod
    def end_a_height(t):
        return y0 - 0.5 * G * t * t - 0.5 * L * np.sin(omega * t)

    t_star = brentq(end_a_height, 0.01, 0.13, xtol=1e-14)
    assert end_a_height(0.01) > 0 and 0.10 < t_star < 0.12  # a genuine first crossing
    assert res.impacts, "the dip of end_a below the floor was missed"
    first = res.impacts[0]
    assert first.contacts == ("end_a",)
    assert first.time == pytest.approx(t_star, abs=1e-9)
    # the rod was never under the floor by more than the contact tolerance before it
    fine = simulate(scene.mechanism, (0.0, 0.4), ((0.0, y0, 0.0), (0.0, 0.0, omega)),
                    max_step=1e-3)
    assert fine.impacts[0].time == pytest.approx(first.time, abs=1e-9)
    assert fine.impacts[0].contacts == first.contacts


def test_grazing_dip_shorter_than_the_sample_spacing_is_found():
    """omega = 40 rad/s: end_a grazes the floor ~0.3 ms into a 70 ms step (a dip far shorter
    than 1/8 of the step); the normal-velocity (Hermite) check finds it."""
    scene = ci.load_scene("bouncing_rod")
    L = scene.parameters["length"]
    y0, omega = 0.505, 40.0
    res = simulate(scene.mechanism, (0.0, 0.2), ((0.0, y0, 0.0), (0.0, 0.0, omega)))

    def end_a_height(t):
        return y0 - 0.5 * G * t * t - 0.5 * L * np.sin(omega * t)

    ts = np.linspace(0.0, 0.2, 200_001)
    t_first = ts[np.argmax(end_a_height(ts) < 0.0)]  # first sampled time under the floor
    t_star = brentq(end_a_height, t_first - 1e-6, t_first, xtol=1e-14)
    assert 0.035 < t_star < 0.04
    assert res.impacts[0].contacts == ("end_a",)
    assert res.impacts[0].time == pytest.approx(t_star, abs=1e-9)


@pytest.mark.parametrize("omega, vy", [(30.0, 2.0), (30.0, 3.0)])
def test_fast_spin_from_the_floor_matches_the_closed_form(omega, vy):
    """The rod starts with end_a on the floor and separating; end_b (0.56 above the floor)
    comes down within the first long step. Reference: the closed-form free flight."""
    scene = ci.load_scene("bouncing_rod")
    L = scene.parameters["length"]
    phi0 = np.pi - 0.6
    y0 = 0.5 * L * np.sin(phi0)
    res = simulate(scene.mechanism, (0.0, 0.5), ((0.0, y0, phi0), (0.0, vy, omega)))

    def end_b_height(t):  # end_b at +L/2 along the rod
        return y0 + vy * t - 0.5 * G * t * t + 0.5 * L * np.sin(phi0 + omega * t)

    ts = np.linspace(1e-6, 0.1, 100_001)
    t_first = ts[np.argmax(end_b_height(ts) < 0.0)]
    t_star = brentq(end_b_height, t_first - 1e-6, t_first, xtol=1e-14)
    assert 0.04 < t_star < 0.06
    assert res.impacts and res.impacts[0].contacts == ("end_b",)
    assert res.impacts[0].time == pytest.approx(t_star, abs=1e-9)


def test_no_dip_keeps_the_step_end_crossing():
    """A plain drop (gap monotone in the step): impact time still at the closed form."""
    scene = ci.load_scene("bouncing_rod")
    h = 0.5
    res = simulate(scene.mechanism, (0.0, 0.4), ((0.0, h + 0.3, np.pi / 2), (0.0, 0.0, 0.0)))
    # vertical rod: the lower end (at centre - L/2) touches after falling h + 0.3 - L/2
    L = scene.parameters["length"]
    assert res.impacts[0].time == pytest.approx(np.sqrt(2 * (h + 0.3 - L / 2) / G), abs=1e-10)


# ---------------------------------------------------------------------------------------------
# 2. accumulation (Zeno) needs several consistent interval ratios; default tolerance absolute
# ---------------------------------------------------------------------------------------------
def _times_from_intervals(intervals, t0=1.0):
    return list(t0 + np.concatenate([[0.0], np.cumsum(intervals)]))


def test_double_tap_is_not_an_accumulation():
    from convimpact.simulation.zeno import AccumulationDetector
    det = AccumulationDetector(time_tol=1.0, rest_velocity=1e-6)  # generous tolerance
    # a flight of 0.3 s, then two quick taps: ratios 1e-4 and 6e-4 (then 0.5 once)
    for t in _times_from_intervals([0.3, 0.3, 3e-5, 1.8e-8]):
        det.record("end_a", t)
    verdict = det.check("end_a", separation_speed=0.5)
    assert not verdict.accumulating and verdict.limit_time is None


def test_geometric_sequence_needs_three_consistent_ratios():
    from convimpact.simulation.zeno import AccumulationDetector
    e = 0.5
    det = AccumulationDetector(time_tol=1.0, rest_velocity=1e-6)
    ts = _times_from_intervals([0.4 * e**j for j in range(4)])  # 5 impacts, 3 ratios = e
    for t in ts[:4]:
        det.record("floor", t)
    assert not det.check("floor", 0.1).accumulating  # only two ratios so far
    det.record("floor", ts[4])
    verdict = det.check("floor", 0.1)
    assert verdict.accumulating and verdict.kind == "accumulation"
    # t_inf = t_1 + sum of all intervals = t_1 + 0.4 / (1 - e)
    assert verdict.limit_time == pytest.approx(ts[0] + 0.4 / (1 - e), abs=1e-12)
    # inconsistent ratios (0.5, 0.5, 0.2): not declared
    det2 = AccumulationDetector(time_tol=1.0, rest_velocity=1e-6)
    for t in _times_from_intervals([0.4, 0.2, 0.1, 0.02]):
        det2.record("floor", t)
    assert not det2.check("floor", 0.1).accumulating


def test_rod_accumulations_are_genuinely_geometric_and_span_independent():
    scene = ci.load_scene("bouncing_rod")
    runs = [simulate(scene, (0.0, te)) for te in (3.0, 30.0)]
    for res in runs:
        for ce in res.contact_events:
            if ce.kind != "persist" or ce.accumulation_time is None:
                continue
            ts = [ev.time for ev in res.impacts if ce.contact in ev.contacts
                  and ev.time <= ce.time]
            d = np.diff(ts[-5:])
            r = d[1:] / d[:-1]
            assert len(r) == 3 and np.all((r > 0.05) & (r < 0.98))
            assert (r.max() - r.min()) / r.mean() < 0.2
    a, b = runs
    assert len(a.impacts) == len(b.impacts)
    np.testing.assert_allclose([c.time for c in a.contact_events],
                               [c.time for c in b.contact_events], atol=1e-9)


def test_ball_hold_does_not_depend_on_t_end():
    scene = ci.load_scene("bouncing_ball")
    e = scene.parameters["e"]
    h = scene.parameters["height"] - scene.parameters["radius"]
    t1, v1 = np.sqrt(2 * h / G), np.sqrt(2 * G * h)
    t_inf = t1 + 2 * e * v1 / (G * (1 - e))  # closed form of the bounce sequence
    runs = [simulate(scene, (0.0, te)) for te in (2.0, 1e5)]
    holds = []
    for res in runs:
        (p,) = [c for c in res.contact_events if c.kind == "persist"]
        holds.append(p.time)
        assert 0.0 <= t_inf - p.time <= 2e-6  # default tolerance 1e-6 s (absolute)
        # the last (plastic) impact is at a tiny speed, not a forced stop of a real bounce
        assert abs(res.impacts[-1].dtheta_minus[1]) < 1e-4
    assert len(runs[0].impacts) == len(runs[1].impacts)
    assert holds[0] == pytest.approx(holds[1], abs=1e-6)


# ---------------------------------------------------------------------------------------------
# 3. a held contact carries Coulomb friction: the pendulum's tip slides, then sticks
# ---------------------------------------------------------------------------------------------
def test_pendulum_held_tip_slides_with_friction_then_sticks():
    scene = ci.load_scene("pendulum_planar")
    mech = scene.mechanism
    res = simulate(scene)
    assert res.status == 0 and res.warnings == ()
    modes = [iv.mode for iv in res.modes_of("tip")]
    assert "slip" in modes and modes[-1] == "stick"  # slides after its impacts, then rests
    counts = assert_coulomb(res, mech)
    # (at rest its held rows fix every velocity: the rest is one step, two samples)
    assert counts["slip"] >= 3 and counts["stick"] >= 2
    # the dissipation is friction's: energy falls while sliding and is constant while sticking
    E = res.total_energy
    stick = res.contact_mode[:, 0] == 1
    assert np.ptp(E[stick]) < 1e-7
    assert res.friction_dissipation[-1] > 0.1


def test_no_slip_warning_without_friction_or_sliding():
    ball = simulate(ci.load_scene("bouncing_ball", speed=0.2))  # mu = 0: nothing to warn
    assert ball.warnings == () and "WARNING" not in ball.message
    assert ball.as_dict(series=False)["warnings"] == []


# property: the first impact of a spinning, falling rod is the closed-form first crossing


@settings(max_examples=40, deadline=None)
@given(y0=st.floats(0.3, 1.5), phi0=st.floats(-0.5, 0.5), vy=st.floats(-1.0, 2.0),
       omega=st.floats(-40.0, 40.0))
def test_first_impact_of_a_spinning_rod_is_the_closed_form_first_crossing(y0, phi0, vy, omega):
    scene = ci.load_scene("bouncing_rod")
    L = scene.parameters["length"]
    if y0 - 0.5 * L * abs(np.sin(phi0)) < 0.05:
        return  # start clear of the floor

    def end(t, sign):  # sign -1: end_a, +1: end_b
        return y0 + vy * t - 0.5 * G * t * t + sign * 0.5 * L * np.sin(phi0 + omega * t)

    ts = np.linspace(0.0, 1.0, 400_001)
    firsts = []
    for sign, name in ((-1, "end_a"), (1, "end_b")):
        g = end(ts, sign)
        assert g.min() < 0.0  # both ends reach the floor within 1 s
        i = int(np.argmax(g < 0.0))
        # skip tangential grazes (dip depth below 1e-7 m): they are at the resolution limit
        dip = -g[i:i + 4000].min()
        if dip < 1e-7:
            return
        firsts.append((brentq(end, ts[i - 1], ts[i], args=(sign,), xtol=1e-14), name))
    t_star, name = min(firsts)
    res = simulate(scene.mechanism, (0.0, t_star + 0.05),
                   ((0.0, y0, phi0), (0.0, vy, omega)))
    assert res.impacts, f"missed the impact of {name} at t = {t_star}"
    assert res.impacts[0].time == pytest.approx(t_star, abs=1e-8)
    assert name in res.impacts[0].contacts
