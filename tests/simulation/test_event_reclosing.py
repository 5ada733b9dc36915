"""Re-closing of a contact that starts a step touching and separating (just released or
impacted), located on gaps evaluated with round-off (regression: the humanoid_push scene looped
at t = 0.7963833754930864 when a one-rounding-unit test point read an unchanged gap as a
return below the start: an "impact" of a contact still separating, which the instant's
handling left as it was, again and again).

The reference: a contact separating at v0 under a constant normal acceleration -A has the gap
g0 + v0 s - A s^2 / 2 (s = t - ta), back at its start level at s = 2 v0 / A.
"""

from __future__ import annotations

import numpy as np
import pytest

from convimpact.errors import SimulationError
from convimpact.simulation import simulate
from convimpact.simulation.events import gap_event, reclosing
from convimpact.simulation.testing import PointMass

#: the humanoid's instant: one rounding unit of t is 1.1e-16 s, 1e-9 of its 9.3e-8 s step less
TA, DT = 0.7963833754930864, 9.313e-8
XTOL = 1e-12


def _quantized(v0: float, A: float, level: float = 1.0):
    """The gap (and its rate) of a point at height ``level`` + x(t) over a floor at
    ``level``, computed as positions are: the difference of two numbers of order
    ``level``, so the gap carries round-off of ulp(level) (2.2e-16 m at 1 m)."""
    def gap(t):
        s = t - TA
        return (level + (v0 * s - 0.5 * A * s * s)) - level

    def speed(t):
        return v0 - A * (t - TA)
    return gap, speed


@pytest.mark.parametrize("v0, A", [(3.374e-6, 150.0), (1.125e-6, 60.0), (3.872e-6, 100.0)])
def test_separating_contact_recloses_where_the_gap_comes_back_not_at_the_start(v0, A):
    gap, speed = _quantized(v0, A)
    a = max(TA + 1e-9 * DT, float(np.nextafter(TA, TA + DT)))  # the first test point:
    assert a == np.nextafter(TA, TA + DT)  # one rounding unit (1.1e-16 s) away
    assert gap(a) - gap(TA) == 0.0  # where the gap's rise (4e-22 m) is below its round-off
    t_back = TA + 2.0 * v0 / A
    assert TA < t_back < TA + DT and gap(TA + DT) < gap(TA)  # back below the start inside
    event = gap_event(gap, speed, TA, TA + DT, gap(TA), gap(TA + DT), XTOL)
    assert event is not None and event[1] == "impact"
    # located to the gap's resolution: round-off 2.2e-16 m over the slope v0 at the return
    assert event[0] == pytest.approx(t_back, abs=4 * 2.2e-16 / v0 + XTOL)


def test_separating_contact_that_stays_open_has_no_event():
    v0, A = 3.374e-6, 10.0  # back at 2 v0 / A = 0.67 ms, past the step
    gap, speed = _quantized(v0, A)
    assert gap(TA + DT) > gap(TA)
    assert gap_event(gap, speed, TA, TA + DT, gap(TA), gap(TA + DT), XTOL) is None


def test_a_return_within_the_first_billionth_of_the_step_is_still_the_start():
    """v0 = 1e-13 m/s against A = 10 m/s^2: back at 2e-14 s, before the first test point
    (1e-12 s into a 1 ms step), where the normal speed has already turned negative: the
    contact closes at that first point, as before."""
    ta, dt, v0, A = 0.5, 1e-3, 1e-13, 10.0

    def gap(t):
        return v0 * (t - ta) - 0.5 * A * (t - ta) ** 2

    def speed(t):
        return v0 - A * (t - ta)
    te = reclosing(gap, ta, ta + dt, 0.0, v0, gap(ta + dt), XTOL, dfun=speed)
    assert te is not None and ta < te <= ta + 1e-9 * dt * (1 + 1e-6)
    assert speed(te) < 0.0


def test_events_recurring_at_one_instant_name_what_can_help(monkeypatch):
    """An instant whose handling changes nothing (here: forced so) repeats its events; the
    run stops with a message that names the contact, its normal speed and rest_velocity, and
    says that zeno='stop' does not apply."""
    from convimpact.simulation.event_driven import EventDrivenRun

    def unchanged(self, t, y, closing, touching):
        return y, None
    monkeypatch.setattr(EventDrivenRun, "handle", unchanged)
    with pytest.raises(SimulationError) as info:
        simulate(PointMass(e=0.5), (0.0, 1.0), (np.array([0.0, 0.1]), np.zeros(2)))
    text = str(info.value)
    assert "without progress" in text and "v_n = -1.4" in text  # sqrt(2 g 0.1) = 1.40 m/s
    assert "rest_velocity" in text and "zeno='stop' does not" in text
