"""Regression tests for the simulator review: missed impacts inside a step, false Zeno
alarms, held contacts that slide without friction.

Expected numbers come from closed forms (free flight of a rod: parabola + linear angle), the
ball's geometric bounce sequence, or a second run with a much smaller ``max_step``.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import brentq

import convimpact as ci
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


def test_no_dip_keeps_the_step_end_crossing():
    """A plain drop (gap monotone in the step): impact time still at the closed form."""
    scene = ci.load_scene("bouncing_rod")
    h = 0.5
    res = simulate(scene.mechanism, (0.0, 0.4), ((0.0, h + 0.3, np.pi / 2), (0.0, 0.0, 0.0)))
    # vertical rod: the lower end (at centre - L/2) touches after falling h + 0.3 - L/2
    L = scene.parameters["length"]
    assert res.impacts[0].time == pytest.approx(np.sqrt(2 * (h + 0.3 - L / 2) / G), abs=1e-10)
