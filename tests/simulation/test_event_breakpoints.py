"""Breakpoints of the event-driven run: the integration restarts at declared kinks of the
applied forces, with the physics unchanged (the box stack's closed-form tipping time,
problems/box_stack.py: t_tip = t_push + n m g w / ((2n - 1) h) / (ramp m g) = 0.44 s)."""

from __future__ import annotations

import numpy as np
import pytest

from convimpact.errors import NonFiniteError, ParameterError, ShapeError
from convimpact.scenes import load_scene
from convimpact.simulation import simulate


@pytest.fixture(scope="module")
def stack():
    return load_scene("box_stack", t_end=0.5)


def _tip_time(res) -> float:
    return next(iv.t_start for iv in res.modes_of("box0_c0") if iv.mode == "open")


def test_a_breakpoint_at_the_push_keeps_the_tipping_time_and_saves_steps(stack):
    p = stack.parameters
    plain = simulate(stack.mechanism, (0.0, stack.t_end), (stack.theta0, stack.dtheta0))
    res = simulate(stack.mechanism, (0.0, stack.t_end), (stack.theta0, stack.dtheta0),
                   breakpoints=[p["t_push"]])
    assert res.status == 0 and res.settings["breakpoints"] == [p["t_push"]]
    # t_tip = t_push + n w / ((2n - 1) h) / ramp, derived in problems/box_stack.py
    n, w, h = p["n_boxes"], p["width"], p["height"]
    t_tip = p["t_push"] + n * w / ((2 * n - 1) * h) / p["ramp"]
    assert t_tip == pytest.approx(0.44, abs=1e-12)
    assert abs(_tip_time(res) - t_tip) < 1e-8
    assert p["t_push"] in res.t  # the segment ended at the breakpoint
    # the kink is not stepped across: the steps onto it are saved
    assert res.n_steps < plain.n_steps and res.nfev < plain.nfev
    # at rest before tipping: the floor carries the stack's weight at every sample
    before = (res.t < t_tip) & (res.held == 4 * n)
    np.testing.assert_allclose(res.contact_force[before][:, :4, 0].sum(axis=1),
                               n * p["mass"] * p["gravity"], rtol=1e-8)


@pytest.mark.parametrize("bad, error", [([0.4, 0.3], ParameterError),
                                        ([0.7], ParameterError),
                                        (["0.2"], ShapeError),
                                        ([True], ShapeError),
                                        ([float("nan")], NonFiniteError)])
def test_bad_breakpoints_are_refused(stack, bad, error):
    with pytest.raises(error):
        simulate(stack.mechanism, (0.0, stack.t_end), (stack.theta0, stack.dtheta0),
                 breakpoints=bad)
