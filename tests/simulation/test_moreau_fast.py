"""The fast path of Moreau–Jean on the contact engine (:mod:`convimpact.simulation.moreau_fast`)
and the per-step answers of the box row under every law of the bench (pereira-nikravesh
included, on its own step solver).

References: the general path of the same step loop (the fast path switched off: the previous
code path, which the fast path must reproduce bit for bit), and closed forms: a box sliding
on its four corners under Coulomb's law decelerates at ``mu g`` (``v_x(t_k) = v0 - mu g t_k``
at the grid points: the scheme is exact under a constant force), and a box at rest on its
four corners (centre of mass above the centre of the rectangle) carries ``m g h / 4`` per
corner and step.
"""

from __future__ import annotations

import numpy as np
import pytest

from convimpact.bench.moreau_scenes import BOX_MASS, GRAVITY, HALF, MU, SLIDE_SPEED, box_row
from convimpact.simulation import moreau_fast
from convimpact.simulation.moreau import simulate_moreau
from convimpact.simulation.moreau_engine import EngineSolver
from convimpact.simulation.moreau_impact import ImpactSolver
from convimpact.simulation.moreau_loop import run_steps

H = 0.002


@pytest.fixture
def fast_steps(monkeypatch):
    """The FastStep objects made by the runs of a test."""
    made = []
    init = moreau_fast.FastStep.__init__

    def record(self, *args):
        init(self, *args)
        made.append(self)

    monkeypatch.setattr(moreau_fast.FastStep, "__init__", record)
    return made


def _general_only(monkeypatch):
    monkeypatch.setattr(moreau_fast.FastStep, "applies", staticmethod(lambda *a: False))


@pytest.mark.parametrize("law", ["ccp", "coulomb", "dissipative"])
@pytest.mark.parametrize("sliding", [True, False])
def test_fast_path_reproduces_the_general_path_bitwise(law, sliding, fast_steps, monkeypatch):
    mech, q, v = box_row(2, sliding)
    fast = simulate_moreau(mech, (0.0, 0.1), (q, v), h=H, law=law)
    # the fast path took most steps (all but the first one or two and the layout changes)
    assert fast_steps[-1].steps >= 40
    _general_only(monkeypatch)
    general = simulate_moreau(mech, (0.0, 0.1), (q, v), h=H, law=law)
    assert np.array_equal(fast.theta, general.theta)
    assert np.array_equal(fast.dtheta, general.dtheta)
    assert fast.n_contact_steps == general.n_contact_steps
    assert fast.max_active_contacts == general.max_active_contacts
    assert len(fast.impacts) == len(general.impacts)
    for a, b in zip(fast.impacts, general.impacts):
        assert a.time == b.time and a.contacts == b.contacts and a.regime == b.regime
        assert np.array_equal(a.impulse, b.impulse)
        assert np.array_equal(a.dtheta_plus, b.dtheta_plus)
    for key in ("problems", "warm_started", "iterations", "newton_finished", "engine_calls",
                "largest_island"):
        assert fast.contact_solver[key] == general.contact_solver[key], key


def test_sliding_box_decelerates_at_mu_g(fast_steps):
    mech, q, v = box_row(1, True)
    res = simulate_moreau(mech, (0.0, 0.3), (q, v), h=H, law="coulomb")
    assert fast_steps[-1].steps >= 140
    exact = SLIDE_SPEED - MU * GRAVITY * res.t
    np.testing.assert_allclose(res.dtheta[:, 0], exact, rtol=0, atol=1e-7)
    # no lift, no turn: z at its half height, the angles at zero
    np.testing.assert_allclose(res.theta[:, 2], HALF[2], rtol=0, atol=1e-9)
    np.testing.assert_allclose(res.theta[:, 3:6], 0.0, rtol=0, atol=1e-9)


@pytest.mark.parametrize("law", ["ccp", "coulomb", "dissipative"])
def test_resting_box_carries_a_quarter_of_its_weight_per_corner(law, fast_steps):
    mech, q, v = box_row(1, False)
    solver = EngineSolver(mech, law=law, tol=1e-8, warm_start=True, islands=True,
                          rest_velocity=1e-6)
    out = run_steps(mech, q, v, solver, t0=0.0, t1=0.1, h=H, theta=0.5, n_steps=50,
                    gap_tol=0.0, rest_velocity=1e-6, projection_tol=1e-10)
    assert fast_steps[-1].steps >= 45
    # the last step's impulses (taken on the fast path): m g h / 4 per corner, no friction
    last = solver.last
    np.testing.assert_allclose(last[:, 0], BOX_MASS * GRAVITY * H / 4, rtol=1e-6)
    np.testing.assert_allclose(last[:, 1:], 0.0, rtol=0, atol=1e-9 * BOX_MASS * GRAVITY * H)
    np.testing.assert_allclose(out["series"]["dtheta"], 0.0, rtol=0, atol=1e-9)


def test_pereira_nikravesh_sliding_box_decelerates_at_mu_g():
    mech, q, v = box_row(1, True)
    res = simulate_moreau(mech, (0.0, 0.03), (q, v), h=H, law="pereira-nikravesh")
    np.testing.assert_allclose(res.dtheta[:, 0], SLIDE_SPEED - MU * GRAVITY * res.t, rtol=0,
                               atol=1e-9)
    np.testing.assert_allclose(res.theta[:, 2], HALF[2], rtol=0, atol=1e-12)


def test_pereira_nikravesh_resting_box_carries_a_quarter_per_corner():
    mech, q, v = box_row(1, False)
    solver = ImpactSolver(mech, law="pereira-nikravesh", method="auto", impact_options={},
                          e_t=None, rest_velocity=1e-6)
    out = run_steps(mech, q, v, solver, t0=0.0, t1=0.1, h=H, theta=0.5, n_steps=50,
                    gap_tol=0.0, rest_velocity=1e-6, projection_tol=1e-10)
    # the last step's impulse (by the resting islands' certificate once the law's compiled
    # path is taken in the process, else by the law's search: the same answer to round-off)
    np.testing.assert_allclose(solver.impulse[:, 0], BOX_MASS * GRAVITY * H / 4, rtol=1e-9)
    np.testing.assert_allclose(solver.impulse[:, 1:], 0.0, rtol=0,
                               atol=1e-12 * BOX_MASS * GRAVITY * H)
    np.testing.assert_allclose(out["series"]["dtheta"], 0.0, rtol=0, atol=1e-12)
