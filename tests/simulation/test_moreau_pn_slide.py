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


def test_a_box_sliding_straight_loses_mu_g_h_per_step_through_the_certificates():
    """Every step after the first answered by the pruned search through its certificates
    (the edges, corners and stick sets excluded, the previous impulse re-certified): the
    speed falls by exactly mu g h per step (friction mu m g h against the slip, normal
    impulse m g h), the box neither pitches nor rolls, and the trajectory is the law's own
    search's."""
    mech, q, v = box_row(1, True)
    fast = _run(mech, q, v, 0.1)
    slow = _run(mech, q, v, 0.1, own_search=True)
    k = np.arange(fast.dtheta.shape[0])
    np.testing.assert_allclose(fast.dtheta[:, 0], 2.0 - k * MU * GRAVITY * H, rtol=0,
                               atol=1e-12)
    assert np.abs(fast.dtheta[1:, 2:]).max() < 1e-12
    assert fast.contact_solver["pruned"] == fast.n_steps - 1
    np.testing.assert_allclose(fast.theta, slow.theta, rtol=0, atol=1e-13)
    np.testing.assert_allclose(fast.dtheta, slow.dtheta, rtol=0, atol=1e-11)


def _tall_box(mu):
    """A box of half sizes (0.05, 0.15, 0.3), 1 kg, on its four bottom corners, sliding at
    2 m/s along x: friction tips it onto its front edge where mu c / a > 1."""
    from convimpact.model import Joint, ModelBuilder

    a, b, c = 0.05, 0.15, 0.3
    inertia = np.diag([b * b + c * c, a * a + c * c, a * a + b * b]) / 3.0
    builder = ModelBuilder(planar=False, gravity=(0.0, 0.0, -GRAVITY))
    builder.add_body("box", "ground", Joint.free(), 1.0, (0.0, 0.0, 0.0), inertia,
                     joint_name="float")
    for j, (sx, sy) in enumerate(((-1, -1), (1, -1), (1, 1), (-1, 1))):
        builder.add_contact(f"corner{j}", body="box", point=(sx * a, sy * b, -c),
                            normal=(0.0, 0.0, 1.0), e=0.0, mu=mu)
    q = np.zeros(6)
    q[2] = c
    v = np.zeros(6)
    v[0] = 2.0
    return builder.build().mechanism(), q, v


def test_a_tall_box_that_tips_takes_the_full_search_and_follows_the_law():
    """mu c / a = 3: the edge-pair certificate must not fire (the front edge is the law's
    answer: the back corners lift); the trajectory with the one-call islands and the pruned
    search is the law's own search's, and the box pitches forward (it tips)."""
    mech, q, v = _tall_box(0.5)
    fast = _run(mech, q, v, 0.02)
    slow = _run(mech, q, v, 0.02, own_search=True)
    np.testing.assert_allclose(fast.theta, slow.theta, rtol=0, atol=1e-13)
    np.testing.assert_allclose(fast.dtheta, slow.dtheta, rtol=0, atol=1e-11)
    assert fast.theta[-1, 2] > q[2] + 1e-4  # the centre rises as it pitches onto the edge
