"""Second method: Moreau-Jean time stepping (velocity-level Coulomb law on every step)
converges to the event-driven answer with sustained contact as h -> 0, on every new scene.

The measure is the final state's relative error |(theta, theta_dot)(t1) - ref| / |ref| against
the event-driven run; Moreau-Jean is first order where contacts open, close or stick (the
transition falls inside a step), so each halving of h roughly halves the error.
"""

from __future__ import annotations

import numpy as np
import pytest

import convimpact as ci
from convimpact.simulation.moreau import simulate_moreau

# (scene, parameters, span, coarse h, fine h, error bound at the fine h)
CASES = [
    ("spinning_ball", {}, 0.4, 4e-3, 1e-3, 1e-6),
    ("spinning_ball", {"spatial": True}, 0.4, 4e-3, 1e-3, 1e-6),
    ("sliding_box", {}, 1.2, 1e-2, 2.5e-3, 5e-6),
    ("rocking_block", {}, 0.8, 4e-3, 1e-3, 5e-3),
    ("rimless_wheel", {}, 0.7, 8e-3, 2e-3, 1e-2),
    ("painleve_rod", {"mu": 0.5}, 0.2, 4e-3, 1e-3, 1e-3),
]


def _state(res):
    return np.concatenate([res.theta[-1], res.dtheta[-1]])


@pytest.mark.parametrize("name,params,t1,h_coarse,h_fine,bound", CASES,
                         ids=[f"{c[0]}{'-spatial' if c[1].get('spatial') else ''}"
                              for c in CASES])
def test_moreau_jean_converges_to_the_event_driven_answer(name, params, t1, h_coarse, h_fine,
                                                          bound):
    scene = ci.load_scene(name, **params)
    ref = ci.simulate(scene, (0.0, t1), rtol=1e-10, atol=1e-12)
    assert ref.status == 0
    y = _state(ref)
    err = []
    for h in (h_coarse, h_fine):
        mj = simulate_moreau(scene, (0.0, t1), h=h, law="coulomb")
        err.append(float(np.linalg.norm(_state(mj) - y) / np.linalg.norm(y)))
    assert err[1] < 0.5 * err[0] or err[1] < 1e-10
    assert err[1] < bound


@pytest.mark.parametrize("mu", [0.5, 0.7])
def test_incline_moreau_jean_and_event_driven_agree_to_round_off(mu):
    """Holding or sliding at constant acceleration, both schemes are exact."""
    scene = ci.load_scene("incline_box", mu=mu)
    ref = ci.simulate(scene, (0.0, 0.5))
    mj = simulate_moreau(scene, (0.0, 0.5), h=1e-2, law="coulomb")
    np.testing.assert_allclose(_state(mj), _state(ref), atol=1e-10)
