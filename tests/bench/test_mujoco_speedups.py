"""The event-driven simulator's speed-ups made for the MuJoCo comparison keep its numbers:
the fast dense-output evaluation equals scipy's, the free-motion right-hand side equals
M^-1 p and f + M_dot theta_dot from the model's public functions, and the event-driven run
still meets the bouncing ball's closed form."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import DOP853, RK23, RK45

from convimpact.scenes import load_scene
from convimpact.simulation import simulate
from convimpact.simulation.canonical import CanonicalEquations
from convimpact.simulation.events import FastInterpolant, fast_interpolant


def _pendulum(t, y):
    return np.array([y[1], -np.sin(y[0]) + 0.1 * t, y[3], -y[2] * (1 + y[0] ** 2)])


@pytest.mark.parametrize("cls", [DOP853, RK45, RK23])
def test_fast_interpolant_equals_scipys_dense_output(cls):
    solver = cls(_pendulum, 0.0, np.array([1.0, 0.3, 0.2, -1.0]), 10.0, rtol=1e-6,
                 atol=1e-9, first_step=0.3)
    for _ in range(3):
        solver.step()
        interp = solver.dense_output()
        fast = fast_interpolant(interp)
        assert isinstance(fast, FastInterpolant)
        ts = np.linspace(solver.t_old, solver.t, 11)
        np.testing.assert_allclose(fast(ts), interp(ts), rtol=0, atol=1e-15)
        for t in ts:
            assert fast(t).shape == (4,)
            np.testing.assert_allclose(fast(t), interp(t), rtol=0, atol=1e-15)
        np.testing.assert_allclose(fast(solver.t), solver.y, rtol=0, atol=1e-14)


def test_other_dense_outputs_pass_through():
    class Other:
        pass

    other = Other()
    assert fast_interpolant(other) is other


@pytest.mark.parametrize("name,params", [("bouncing_rod", {}),
                                         ("pendulum_planar", {"case": "drop"})])
def test_free_motion_rhs_from_the_public_model_functions(name, params):
    scene = load_scene(name, **params)
    mech = scene.mechanism
    eq = CanonicalEquations(mech)
    rng = np.random.default_rng(3)
    for _ in range(4):
        th = scene.theta0 + rng.normal(scale=0.5, size=mech.n_coordinates)
        dth = rng.normal(size=mech.n_coordinates)
        M = mech.mass_matrix(th)
        y = np.concatenate([th, M @ dth])
        out = eq(0.3, y)
        pdot = mech.generalized_forces(0.3, th, dth) + mech.mass_matrix_dot(th, dth) @ dth
        np.testing.assert_allclose(out[:mech.n_coordinates], dth, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(out[mech.n_coordinates:], pdot, rtol=1e-12, atol=1e-12)


def test_ball_impacts_at_the_closed_form_times():
    """Impacts at t1 (1 + 2e + 2e^2 ...) with rebound speeds e^i g t1 (e = 1/2, h - r = 0.9)."""
    res = simulate(load_scene("bouncing_ball"), (0.0, 1.2), law="coulomb", rtol=1e-6,
                   atol=1e-8)
    t1 = math.sqrt(2 * 0.9 / 9.81)
    expected = [t1, 2 * t1, 2.5 * t1]
    assert [i.time for i in res.impacts[:3]] == pytest.approx(expected, abs=1e-9)
    for j, imp in enumerate(res.impacts[:3]):
        assert imp.dtheta_plus[1] == pytest.approx(0.5 ** (j + 1) * 9.81 * t1, rel=1e-9)
