"""Segments whose held rows fix every velocity (a table at rest, a resting stack): theta_dot
is zero and p changes with the applied forces alone, so the event-driven run's first trial
step is the whole segment (event_driven.EventDrivenRun.integrate_segment), which the
integrator keeps: one step, the state unchanged, the forces the statics' closed forms."""

from __future__ import annotations

import numpy as np
import pytest

from convimpact.scenes import load_scene
from convimpact.simulation import simulate


@pytest.mark.parametrize("legs", [3, 4, 8])
def test_a_table_at_rest_takes_one_step_with_its_legs_equal_shares(legs):
    """Legs equally spaced on a circle around the centre of mass: the normal forces balance
    m g and the moments for any equal shares m g / n (for n >= 4 the least-norm choice among
    the indeterminate ones); no friction."""
    sc = load_scene("table", legs=legs, v0=0.0, t_end=0.5)
    p = sc.parameters
    res = simulate(sc.mechanism, (0.0, sc.t_end), (sc.theta0, sc.dtheta0))
    assert res.status == 0
    assert res.n_steps == 1
    np.testing.assert_allclose(res.theta, np.broadcast_to(sc.theta0, res.theta.shape),
                               atol=1e-12)
    np.testing.assert_allclose(res.dtheta, 0.0, atol=1e-12)
    held = res.held == legs
    assert held[-1] and held.sum() >= 2
    F = res.contact_force[held]
    np.testing.assert_allclose(F[:, :, 0], p["mass"] * p["gravity"] / legs, rtol=1e-9)
    np.testing.assert_allclose(F[:, :, 1:], 0.0, atol=1e-9 * p["mass"] * p["gravity"])


def test_the_box_stack_rests_in_one_step_until_its_push():
    """Before the push's onset (a breakpoint) the stack is held still: one step from 0 to
    t_push, each box's corners carrying the boxes above, (n - i) m g / 4 each."""
    sc = load_scene("box_stack")
    p = sc.parameters
    n, m, g = p["n_boxes"], p["mass"], 9.81
    res = simulate(sc.mechanism, (0.0, p["t_push"]), (sc.theta0, sc.dtheta0),
                   breakpoints=(p["t_push"],))
    assert res.status == 0
    assert res.n_steps == 1
    end = res.t == p["t_push"]
    assert end.any()
    names = list(res.contact_names)
    for i in range(n):
        cols = [names.index(f"box{i}_c{j}") for j in range(4)]
        np.testing.assert_allclose(res.contact_force[end][:, cols, 0], (n - i) * m * g / 4,
                                   rtol=1e-9)
    np.testing.assert_allclose(res.theta[-1], sc.theta0, atol=1e-12)
