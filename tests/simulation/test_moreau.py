"""Moreau–Jean time stepping against hand-derived particle results and the event-driven run.

Particle of mass m dropped from height H under gravity g onto the floor (PointMass):
with theta = 1/2 the free flight is exact at the grid points for a constant force
(q_{k+1} = q_k + h v_k - g h^2 / 2, v_{k+1} = v_k - g h), so v_k = -g t_k before the impact.
The impact step is the one whose free end-of-step gap closes, t_k < t* = sqrt(2 H / g) <=
t_k + h, and Moreau–Jean's Newton law on the step-start velocity gives v+ = -e v_k = e g t_k:
    e g (t* - h) < v+ <= e g t*.
"""

from __future__ import annotations

import numpy as np
import pytest

from convimpact.errors import LoopConstraintError, ParameterError, UnknownOptionError
from convimpact.scenes import load_scene
from convimpact.simulation import simulate, simulate_with
from convimpact.simulation.moreau import MoreauResult, simulate_moreau
from convimpact.simulation.testing import PointMass

G, H = 9.81, 1.0
T_STAR = np.sqrt(2 * H / G)


def drop(h, e=0.5, mu=0.0, vx=0.0, t1=0.5, **kw):
    return simulate_moreau(PointMass(e=e, mu=mu), (0.0, t1),
                           (np.array([0.0, H]), np.array([vx, 0.0])), h=h, **kw)


@pytest.mark.parametrize("h", [1e-2, 3e-3, 1e-3, 3e-4])
def test_particle_post_impact_velocity_brackets_and_converges(h):
    e = 0.5
    r = drop(h, e)
    assert isinstance(r, MoreauResult) and r.status == 0
    imp = r.impacts[0]
    v_plus = imp.dtheta_plus[1]
    assert e * G * (T_STAR - h) - 1e-9 < v_plus <= e * G * T_STAR + 1e-9
    # the impulse acts at the step's midpoint, within h of the true instant
    assert abs(imp.time - T_STAR) <= h
    assert imp.dtheta_minus[1] == pytest.approx(-G * (imp.time - h / 2), abs=1e-9)


@pytest.mark.parametrize("law", ["coulomb", "dissipative"])
@pytest.mark.parametrize("e", [0.0, 0.5, 1.0])
def test_particle_energy_never_rises_on_impact_steps(law, e):
    """On a step whose contact approaches at t_k (an impact step), with v+_y = -e v_y and
    |v+_x| <= |v_x| (friction opposes the slip): dT = m/2 ((e^2 - 1) v_y^2 + ...) <= 0 and
    dV = m g h/2 (v_y + v+_y) = m g h/2 (1 - e) v_y <= 0. On a step where a slowly *separating*
    contact (0 <= v_y < g h) is predicted to close, the plastic impulse stops it at the raised
    midpoint: dE = m/2 v_y (g h - v_y) <= m g^2 h^2 / 8 -- the scheme's documented O(h^2) rise.
    """
    h = 1e-2
    r = drop(h, e, mu=0.3, vx=1.0, t1=2.0, law=law)
    E = r.total_energy
    dE = np.diff(E)
    assert dE.max() <= G ** 2 * h ** 2 / 8 + 1e-12
    assert E[-1] <= E[0] + 1e-12
    for imp in r.impacts:
        i = int(np.searchsorted(r.t, imp.time))  # the step ending after the impulse
        assert E[i] <= E[i - 1] + 1e-12


def test_slowly_separating_contact_gains_bounded_energy():
    """The O(h^2) rise of the docstring above occurs (e = 0.5 bouncing to rest) and is bounded."""
    h = 1e-2
    r = drop(h, 0.5, t1=2.0)
    dE = np.diff(r.total_energy)
    assert 0.0 < dE.max() <= G ** 2 * h ** 2 / 8


def test_sliding_particle_friction_decrement():
    """A particle resting on the floor (e = 0) sliding at 1 m/s: each step the plastic normal
    impulse is m g h and Coulomb friction removes mu g h of the slip until it sticks."""
    h, mu = 1e-2, 0.3
    r = simulate_moreau(PointMass(e=0.0, mu=mu), (0.0, 0.5),
                        (np.array([0.0, 0.0]), np.array([1.0, 0.0])), h=h)
    n = np.arange(len(r.t))
    expected = np.maximum(1.0 - mu * G * h * n, 0.0)
    assert np.allclose(r.dtheta[:, 0], expected, atol=1e-9)
    assert np.allclose(r.dtheta[:, 1], 0.0, atol=1e-12)
    assert np.allclose(r.theta[:, 1], 0.0, atol=1e-12)


def test_theta_one_never_penetrates_plastic_drop():
    """theta = 1 advances positions with the post-impulse velocity: a plastic contact stops
    at its start-of-step position, which is above the floor; theta = 1/2 penetrates by
    about h |v| / 2 on the impact step (the scheme's documented artefact)."""
    h = 1e-2
    r1 = drop(h, 0.0, theta=1.0, t1=1.0)
    r_half = drop(h, 0.0, theta=0.5, t1=1.0)
    assert r1.max_penetration == 0.0
    assert 0.0 < r_half.max_penetration <= h * G * T_STAR / 2 + 1e-12


def test_slider_crank_converges_to_event_driven_and_keeps_loops():
    scene = load_scene("slider_crank")
    span = (0.0, 0.012)
    ref = simulate(scene, span, law="coulomb", rtol=1e-10, atol=1e-12)
    dq_ref = ref.impacts[0].dtheta_plus
    errs = []
    for h in (1e-3, 2e-4):
        r = simulate_moreau(scene, span, h=h)
        assert len(r.impacts) >= 1
        errs.append(np.linalg.norm(r.impacts[0].dtheta_plus - dq_ref) / np.linalg.norm(dq_ref))
        assert r.max_loop_residual <= 1e-10
        assert r.max_loop_velocity_residual <= 1e-8
    assert errs[1] < errs[0] / 3


def test_dispatcher_and_bad_input():
    r = simulate_with(PointMass(), (0.0, 0.1), (np.array([0.0, 1.0]), np.zeros(2)),
                      scheme="moreau-jean", h=1e-2)
    assert isinstance(r, MoreauResult)
    y0 = (np.array([0.0, 1.0]), np.zeros(2))
    with pytest.raises(ParameterError):
        simulate_moreau(PointMass(), (0.0, 1.0), y0, h=0.0)
    with pytest.raises(ParameterError):
        simulate_moreau(PointMass(), (0.0, 1.0), y0, h=1e-3, theta=1.5)
    with pytest.raises(UnknownOptionError):
        simulate_moreau(PointMass(), (0.0, 1.0), y0, h=1e-3, law="newton")
    with pytest.raises(UnknownOptionError):
        simulate_with(PointMass(), (0.0, 1.0), y0, scheme="verlet")
    with pytest.raises(UnknownOptionError):
        simulate_with(PointMass(), (0.0, 1.0), y0, scheme="moreau-jean", h=1e-3, rtol=1e-6)
    scene = load_scene("slider_crank")
    bad = scene.dtheta0.copy()
    bad[0] += 1.0
    with pytest.raises(LoopConstraintError):
        simulate_moreau(scene, (0.0, 0.01), (scene.theta0, bad), h=1e-3)


def test_free_flight_energy_error_order_by_theta():
    """A double pendulum swinging clear of its floor conserves T + V: Moreau–Jean's energy
    error over 2 s falls like h^2 for theta = 1/2 (midpoint, force at the predicted midpoint
    velocity) and like h for theta = 1 (first order)."""
    from convimpact.simulation.testing import DoublePendulum

    dp = DoublePendulum(height=10.0)
    y0 = (np.array([1.0, 0.5]), np.zeros(2))

    def err(h, theta):
        E = simulate_moreau(dp, (0.0, 2.0), y0, h=h, theta=theta).total_energy
        return float(np.max(np.abs(E - E[0])))

    r_half = err(1e-2, 0.5) / err(5e-3, 0.5)
    r_one = err(1e-2, 1.0) / err(5e-3, 1.0)
    assert 3.5 < r_half < 4.5
    assert 1.8 < r_one < 2.2
    assert err(5e-3, 0.5) < 0.02 * err(5e-3, 1.0)
