"""The largest-smallest-margin program solved from another program's active set by
correcting it (simulation/force_active_set.py): against the closed form of
test_sustained_margin_programs.py (four sticking corners under m g and a tangential load T:
t* = (mu m g - T) / 4) and against Clarabel on the programs the box stack's run corrected."""

from __future__ import annotations

import numpy as np
import pytest

from convimpact.scenes import load_scene
from convimpact.simulation import force_distribution, simulate
from convimpact.simulation.force_active_set import corrected_max_min, warm_corrected

from .test_force_dual import SCALE, _blocks, _solver_optimum
from .test_sustained_margin_programs import _largest


@pytest.mark.parametrize("T", [1.0, 4.0, 6.0])
def test_a_set_with_a_corner_at_its_apex_reaches_the_closed_form_optimum(T):
    _, _, blocks = _blocks(T)
    r = blocks[0][1].shape[1]
    kinds = [("ray", 3)] * 3 + ["zero", None]
    parts = [np.array([0.1, 0.25, 0.0])] * 3 + [np.array([0.25, -0.25, 0.0]), np.zeros(0)]
    got = corrected_max_min(blocks, kinds, parts, np.zeros(r + 1))
    assert got is not None
    assert got[0][r] == pytest.approx(_largest(T) / SCALE, abs=1e-12)


def test_no_active_cone_to_start_from_is_left_to_the_solver():
    lam0, Z, blocks = _blocks(6.0)
    kinds = [None] * 5
    parts = [np.zeros(0)] * 5
    warm = {"active": (kinds, parts), "lam": lam0.copy(), "tau": 0.0}
    assert warm_corrected(blocks, warm, lam0, np.linalg.qr(Z)[0], SCALE) is None


def test_the_box_stacks_corrected_margins_are_clarabels():
    """Locating the stack's tip, the margin at the predicted instant has an active set none
    of the nearby programs had: corrected from the last one, its optimum is the one
    Clarabel finds on the same program (to the solver's accuracy)."""
    seen = []
    correct = force_distribution.warm_corrected

    def spy(blocks, warm, lam0, Q, scale):
        out = correct(blocks, warm, lam0, Q, scale)
        seen.append((blocks, out))
        return out
    force_distribution.warm_corrected = spy
    try:
        sc = load_scene("box_stack")
        p = sc.parameters
        res = simulate(sc.mechanism, (0.0, sc.t_end), (sc.theta0, sc.dtheta0),
                       breakpoints=(p["t_push"],))
    finally:
        force_distribution.warm_corrected = correct
    assert res.status == 0
    solved = [(blocks, out) for blocks, out in seen if out is not None]
    assert solved
    for blocks, (_, t_star) in solved:
        assert t_star == pytest.approx(_solver_optimum(blocks)[0], abs=1e-8)
