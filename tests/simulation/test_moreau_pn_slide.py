"""Law pereira-nikravesh's sliding islands in Moreau–Jean: the search in one compiled call,
warm-started, pruned of the dominated sets within a sliding mode
(:mod:`convimpact.impact.laws.pn_complementarity_search`); the law's own search on every
step as the second method, and Coulomb's closed-form stopping distance."""

import numpy as np
import pytest

from convimpact.bench.moreau_scenes import GRAVITY, MU, box_row
from convimpact.impact.laws import pn_complementarity_impulse as pimp
from convimpact.simulation import moreau_impact as mi
from convimpact.simulation.moreau import simulate_moreau

H = 2e-3
LAW = "pereira-nikravesh"


@pytest.fixture(scope="module", autouse=True)
def compiled_path():
    pimp.compile_kernels()


def _run(mech, q, v, span, own_search=False):
    """``own_search``: the law's own search (``_search`` and ``_pick``) on every step."""
    saved, saved_islands = pimp.compiled_impulse, mi.PnIslands.applies
    if own_search:  # (nor the modes' one-call path, moreau_pn_islands)
        pimp.compiled_impulse = lambda *args: None
        mi.PnIslands.applies = classmethod(lambda cls, *args: None)
    try:
        return simulate_moreau(mech, (0.0, span), (q, v), h=H, law=LAW)
    finally:
        pimp.compiled_impulse = saved
        mi.PnIslands.applies = saved_islands


def test_sliding_boxes_follow_the_laws_own_search():
    """Two boxes sliding at 2 and 1.2 m/s, one turning: the same trajectory (to round-off)
    as with the law's own search on every step; after the first step every step is pruned."""
    mech, q, v = box_row(2, True)
    v = v.copy()
    v[6], v[7], v[11] = 1.2, 0.3, 0.5  # the second box: slower, sideways, turning
    fast = _run(mech, q, v, 0.04)
    slow = _run(mech, q, v, 0.04, own_search=True)
    assert fast.contact_solver["pruned"] >= 2 * (fast.n_steps - 2)
    assert slow.contact_solver["pruned"] == 0
    np.testing.assert_allclose(fast.theta, slow.theta, rtol=0, atol=1e-13)
    np.testing.assert_allclose(fast.dtheta, slow.dtheta, rtol=0, atol=1e-11)


def test_a_box_slides_to_coulombs_stopping_distance():
    """v0 = 0.3 m/s on four corners: Coulomb's law stops it after v0 / (mu g) = 0.102 s,
    v0^2 / (2 mu g) = 15.3 mm further (to the step's order, v0 h); the same trajectory as
    the law's own search; it then rests, certified."""
    v0 = 0.3
    mech, q, v = box_row(1, True)
    v = v.copy()
    v[0] = v0
    fast = _run(mech, q, v, 0.14)
    slow = _run(mech, q, v, 0.14, own_search=True)
    distance = fast.theta[-1, 0] - q[0]
    assert abs(distance - v0 ** 2 / (2 * MU * GRAVITY)) <= v0 * H
    moving = fast.t[np.abs(fast.dtheta[:, 0]) > 1e-12]
    assert abs(moving[-1] + H - v0 / (MU * GRAVITY)) <= H
    assert np.max(np.abs(fast.dtheta[-1])) < 1e-12
    cs = fast.contact_solver
    assert cs["pruned"] > 40 and cs["certified"] > 10
    np.testing.assert_allclose(fast.theta, slow.theta, rtol=0, atol=1e-13)
    np.testing.assert_allclose(fast.dtheta, slow.dtheta, rtol=0, atol=1e-11)
