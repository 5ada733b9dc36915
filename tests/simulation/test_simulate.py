"""Event-driven simulation of the canonical equations, against independent oracles.

Oracles: closed-form free fall and the geometric bouncing sequence (impact times, rebound
heights, accumulation time t_inf); conservation of energy; an independent scipy ``solve_ivp``
integration of the second-order Lagrangian form M theta_ddot = f with its own root finding;
symmetry (a flat rod landing on both ends); finite differences for the test mechanisms.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

import convimpact as ci
from convimpact.errors import (
    AssemblyError,
    InputError,
    LoopConstraintError,
    NonFiniteError,
    ParameterError,
    ShapeError,
    UnknownOptionError,
)
from convimpact.simulation import CanonicalEquations, PenetrationError, simulate
from convimpact.simulation.testing import DoublePendulum, FallingRod, PointMass, SliderCrank

G = 9.81


# ---------------------------------------------------------------------------------------------
# the analytic test mechanisms themselves (finite differences)
# ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize("mech, k", [(DoublePendulum(), 2), (SliderCrank(g=9.81), 4),
                                     (FallingRod(), 3)])
def test_test_mechanisms_finite_differences(mech, k):
    rng = np.random.default_rng(0)
    th, dth = rng.normal(size=k), rng.normal(size=k)
    h = 1e-6
    Mdot_fd = (mech.mass_matrix(th + h * dth) - mech.mass_matrix(th - h * dth)) / (2 * h)
    np.testing.assert_allclose(mech.mass_matrix_dot(th, dth), Mdot_fd, atol=1e-8)
    # f = p_dot - M_dot dq with p_dot = dL/dtheta (Lagrangian L = T - V)
    def lag(q):
        return mech.kinetic_energy(q, dth) - mech.potential_energy(q)
    dL = np.array([(lag(th + h * e) - lag(th - h * e)) / (2 * h) for e in np.eye(k)])
    f = mech.generalized_forces(0.0, th, dth)
    np.testing.assert_allclose(f + mech.mass_matrix_dot(th, dth) @ dth, dL, atol=1e-7)
    for c in mech.contact_names:
        dgap = (mech.contact_gap(c, th + h * dth) - mech.contact_gap(c, th - h * dth)) / (2 * h)
        assert mech.contact_jacobian(c, th)[0] @ dth == pytest.approx(dgap, abs=1e-8)
    if mech.n_loop_constraints:
        C_fd = np.column_stack([(mech.loop_residual(th + h * e) - mech.loop_residual(th - h * e))
                                / (2 * h) for e in np.eye(k)])
        np.testing.assert_allclose(mech.loop_jacobian(th), C_fd, atol=1e-8)
        Cdot_fd = (mech.loop_jacobian(th + h * dth) - mech.loop_jacobian(th - h * dth)) / (2 * h)
        np.testing.assert_allclose(mech.loop_jacobian_dot(th, dth), Cdot_fd, atol=1e-8)


def test_canonical_velocities_solve_eqs_7_and_13():
    sc = SliderCrank()
    th, dth = sc.assembled(0.7, 3.0, 1.0, 0.0)
    eqs = CanonicalEquations(sc)
    sigma = np.array([0.3, -0.2])
    p = sc.mass_matrix(th) @ dth - sc.loop_jacobian(th).T @ sigma  # eq. (13)
    dth2, sig2, _ = eqs.velocities(th, p)
    np.testing.assert_allclose(dth2, dth, atol=1e-12)
    np.testing.assert_allclose(sig2, sigma, atol=1e-12)


# ---------------------------------------------------------------------------------------------
# particle drop: closed-form impact times, rebound heights, accumulation time
# ---------------------------------------------------------------------------------------------
H0, E, VX = 1.0, 0.5, 0.3
V1 = np.sqrt(2 * G * H0)
T1 = np.sqrt(2 * H0 / G)
T_INF = T1 + 2 * E * V1 / (G * (1 - E))  # accumulation time of the bouncing sequence


@pytest.fixture(scope="module")
def drop():
    return simulate(PointMass(e=E), (0.0, 3.0), (np.array([0.0, H0]), np.array([VX, 0.0])),
                    dense_output=True, zeno_time_tol=1e-4)


def test_drop_impact_times_and_rebound_heights(drop):
    assert drop.status == 0 and drop.success
    n = 8
    times = [T1]
    for j in range(1, n):
        times.append(times[-1] + 2 * E**j * V1 / G)
    got = [ev.time for ev in drop.impacts[:n]]
    np.testing.assert_allclose(got, times, rtol=0, atol=1e-10)
    for j, ev in enumerate(drop.impacts[:n]):
        v_in = E**j * V1
        np.testing.assert_allclose(ev.dtheta_minus, [VX, -v_in], atol=1e-9)
        np.testing.assert_allclose(ev.dtheta_plus, [VX, E * v_in], atol=1e-9)
        # rebound apex from the dense output: height (e v)^2 / (2 g) at t_j + e v / g
        apex = drop.sol(ev.time + E * v_in / G)[:2]
        assert apex[1] == pytest.approx((E * v_in) ** 2 / (2 * G), abs=1e-10)
        assert apex[0] == pytest.approx(VX * (ev.time + E * v_in / G), abs=1e-10)


def test_drop_energy_loss_matches_law_and_closed_form(drop):
    for j, ev in enumerate(drop.impacts):
        measured = ev.kinetic_energy_minus - ev.kinetic_energy_plus
        assert ev.energy_loss == pytest.approx(measured, abs=1e-12)
    for j, ev in enumerate(drop.impacts[:6]):
        v_in = E**j * V1
        assert ev.energy_loss == pytest.approx(0.5 * (1 - E**2) * v_in**2, rel=1e-9)  # eq. (59)


def test_drop_accumulates_then_rests_and_goes_on(drop):
    persist = [c for c in drop.contact_events if c.kind == "persist"]
    assert len(persist) == 1 and persist[0].contact == "floor"
    t_p = persist[0].time
    # stopped bouncing before t_inf, within the stated remaining-time tolerance
    assert 0.0 <= T_INF - t_p <= 1e-4
    assert persist[0].accumulation_time == pytest.approx(T_INF, abs=1e-9)
    # last impact is plastic (redone with e = 0) so the particle rests on the floor
    assert drop.impacts[-1].dtheta_plus[1] == pytest.approx(0.0, abs=1e-12)
    after = drop.t > t_p
    assert np.all(np.abs(drop.theta[after, 1]) < 1e-9)
    np.testing.assert_allclose(drop.theta[after, 0], VX * drop.t[after], atol=1e-9)
    assert drop.t[-1] == 3.0 and np.all(drop.held[after] == 1)
    # impact j (j >= 3) follows the interval 2 e^(j-1) v1 / g; the remaining time
    # interval * e / (1 - e) first drops below 1e-4 at impact j = 15
    n_expected = next(j for j in range(3, 100)
                      if 2 * E**(j - 1) * V1 / G * E / (1 - E) <= 1e-4)
    assert len(drop.impacts) == n_expected


def test_drop_zeno_stop_policy_reports():
    res = simulate(PointMass(e=E), (0.0, 3.0), (np.array([0.0, H0]), np.zeros(2)),
                   zeno="stop", zeno_time_tol=1e-3)
    assert res.status == 1 and not res.contact_events
    assert "accumulating" in res.message and "t_inf" in res.message
    assert res.t[-1] < T_INF and T_INF - res.t[-1] <= 1e-3


def test_max_impacts_stops_cleanly():
    res = simulate(PointMass(e=0.9), (0.0, 10.0), (np.array([0.0, 1.0]), np.zeros(2)),
                   max_impacts=5)
    assert res.status == 1 and len(res.impacts) == 5 and "max_impacts" in res.message


def test_plastic_drop_rests_then_released_when_pulled_up():
    """e = 0: held at the first impact; an upward force larger than gravity releases it."""

    class Lifted(PointMass):
        def generalized_forces(self, t, theta, dtheta):
            return np.array([0.0, -self.m * self.g + (2 * self.m * self.g if t > 1.0 else 0.0)])

    res = simulate(Lifted(e=0.0), (0.0, 1.5), (np.array([0.0, 0.5]), np.zeros(2)))
    kinds = [(c.kind, c.contact) for c in res.contact_events]
    assert kinds == [("persist", "floor"), ("release", "floor")]
    assert res.contact_events[1].time == pytest.approx(1.0, abs=1e-9)
    # after release: y = g/2 (t - 1)^2 upwards (net acceleration +g)
    assert res.theta[-1, 1] == pytest.approx(0.5 * G * 0.5**2, rel=1e-7)


# ---------------------------------------------------------------------------------------------
# energy without impacts; a second, independent integration
# ---------------------------------------------------------------------------------------------
def _lagrangian_reference(mech, theta0, dtheta0, t_end, events=None):
    k = mech.n_coordinates

    def rhs(t, y):
        th, dth = y[:k], y[k:]
        return np.concatenate([dth, np.linalg.solve(mech.mass_matrix(th),
                                                    mech.generalized_forces(t, th, dth))])

    return solve_ivp(rhs, (0.0, t_end), np.concatenate([theta0, dtheta0]), method="DOP853",
                     rtol=1e-12, atol=1e-12, dense_output=True, events=events)


@pytest.mark.parametrize("integrator, rtol, bound", [("DOP853", 1e-10, 1e-8),
                                                     ("RK45", 1e-7, 1e-5),
                                                     ("Radau", 1e-7, 1e-5)])
def test_energy_drift_without_impacts(integrator, rtol, bound):
    dp = DoublePendulum(height=10.0)  # the floor is out of reach
    th0, dth0 = np.array([1.0, 2.0]), np.array([0.0, 1.0])
    res = simulate(dp, (0.0, 3.0), (th0, dth0), integrator=integrator, rtol=rtol,
                   atol=rtol * 1e-2, dense_output=True)
    E = res.total_energy
    # stated: relative energy drift <= 100 rtol over this chaotic 3 s run
    assert np.max(np.abs(E - E[0])) / abs(E[0]) <= bound
    assert not res.impacts
    ref = _lagrangian_reference(dp, th0, dth0, 3.0)
    if integrator == "DOP853":
        np.testing.assert_allclose(res.theta[-1], ref.y[:2, -1], atol=1e-6)
        np.testing.assert_allclose(res.dtheta[-1], ref.y[2:, -1], atol=1e-6)


def test_impact_jump_equals_resolve_impact_at_independently_located_instant():
    dp = DoublePendulum(height=1.8, e=0.7, mu=0.3)
    th0, dth0 = np.array([1.2, 1.4]), np.zeros(2)
    res = simulate(dp, (0.0, 1.0), (th0, dth0), rtol=1e-11, atol=1e-12)
    ev = res.impacts[0]

    def hit(t, y):
        return dp.contact_gap("tip", y[:2])
    hit.terminal, hit.direction = True, -1
    ref = _lagrangian_reference(dp, th0, dth0, 1.0, events=hit)
    t_hit = ref.t_events[0][0]
    y_hit = ref.y_events[0][0]
    assert ev.time == pytest.approx(t_hit, abs=1e-9)
    np.testing.assert_allclose(ev.theta, y_hit[:2], atol=1e-8)
    np.testing.assert_allclose(ev.dtheta_minus, y_hit[2:], atol=1e-7)
    r = ci.resolve_impact(dp.mass_matrix(y_hit[:2]), dp.contact_jacobian("tip", y_hit[:2]),
                          y_hit[2:], e=0.7, mu=0.3)
    np.testing.assert_allclose(ev.dtheta_plus, r.dq_plus, atol=1e-6)
    np.testing.assert_allclose(ev.impulse[0], r.impulse, atol=1e-6)
    assert ev.regime == (r.regime,)


def test_double_pendulum_strikes_repeatedly_energy_bookkeeping():
    dp = DoublePendulum(height=1.5, e=0.8, mu=0.2)
    res = simulate(dp, (0.0, 4.0), (np.array([1.5, 1.5]), np.zeros(2)))
    assert res.status == 0 and len(res.impacts) >= 5
    assert {ev.regime[0] for ev in res.impacts} == {"stick", "slide"}
    E = res.total_energy
    # total energy is piecewise constant: every drop of E is an impact's reported energy loss
    losses = sum(ev.energy_loss for ev in res.impacts)
    losses += -sum(c.energy_change for c in res.contact_events)
    assert E[0] - E[-1] == pytest.approx(losses, abs=1e-6)
    for ev in res.impacts:
        assert ev.energy_loss == pytest.approx(ev.kinetic_energy_minus - ev.kinetic_energy_plus,
                                               abs=1e-10)
        assert ev.energy_loss >= -1e-12
    # the located impacts are on the floor
    for ev in res.impacts:
        assert abs(dp.contact_gap("tip", ev.theta)) <= 1e-8


# ---------------------------------------------------------------------------------------------
# closed loop: slider-crank
# ---------------------------------------------------------------------------------------------
def test_slider_crank_long_run_loop_drift_and_energy():
    sc = SliderCrank()
    th, dth = sc.assembled(0.3, 10.0, 5.0, 0.0)  # free slider out of reach
    res = simulate(sc, (0.0, 10.0), (th, dth))
    # stated bounds: |Psi| <= projection_tol (1e-10) at every stored state, |C dq| round-off
    assert res.max_loop_residual <= 1e-10
    assert res.max_loop_velocity_residual <= 1e-12
    E = res.total_energy
    assert np.max(np.abs(E - E[0])) / E[0] <= 1e-6
    # 1 DOF, 10 rad/s initially, no gravity: the crank keeps turning (about 15 turns)
    assert res.theta[-1, 0] - th[0] > 2 * np.pi * 10


@pytest.mark.parametrize("integrator, bound", [("RK45", 1e-10), ("Radau", 1e-10),
                                               ("LSODA", 1e3 * 1e-9), ("BDF", 1e3 * 1e-9)])
def test_slider_crank_drift_bound_per_integrator(integrator, bound):
    """Stated bound: projection_tol for one-step methods, max(projection_tol, 1000 atol) for
    multistep ones (which restart on projection)."""
    sc = SliderCrank()
    th, dth = sc.assembled(0.3, 10.0, 5.0, 0.0)
    res = simulate(sc, (0.0, 1.0), (th, dth), integrator=integrator, rtol=1e-7, atol=1e-9)
    assert res.status == 0
    assert res.max_loop_residual <= bound
    assert res.max_loop_velocity_residual <= 1e-12
    assert res.n_restarts <= 2  # no restart storm


def test_slider_crank_stays_closed_through_impact():
    sc = SliderCrank(damping=0.5, omega=10.0)
    th, dth = sc.assembled(0.3, 10.0, 0.6, -1.0)
    res = simulate(sc, (0.0, 1.0), (th, dth))
    assert len(res.impacts) >= 1
    ev = res.impacts[0]
    C = sc.loop_jacobian(ev.theta)
    assert np.max(np.abs(C @ ev.dtheta_plus)) <= 1e-10
    assert ev.loop_impulse.shape == (2,) and np.any(np.abs(ev.loop_impulse) > 1e-3)
    # central impact: relative normal velocity reversed with e = 0.83 (eq. 21)
    Jn = sc.contact_jacobian("slider", ev.theta)[0]
    assert Jn @ ev.dtheta_plus == pytest.approx(-0.83 * (Jn @ ev.dtheta_minus), rel=1e-9)
    # eq. (59) with the loop-constrained effective mass (independent null-space computation)
    M = sc.mass_matrix(ev.theta)
    N = np.linalg.svd(C)[2][2:].T  # null space of C
    m_nn = Jn @ N @ np.linalg.solve(N.T @ M @ N, N.T @ Jn)
    vn = Jn @ ev.dtheta_minus
    assert ev.energy_loss == pytest.approx((1 - 0.83**2) * vn**2 / (2 * m_nn), rel=1e-9)
    assert res.max_loop_residual <= 1e-10


# ---------------------------------------------------------------------------------------------
# several contacts at once; bouncing to rest
# ---------------------------------------------------------------------------------------------
def test_flat_rod_lands_on_both_ends_together():
    if "clarabel" not in ci.available_methods("coulomb"):
        pytest.skip("multi-contact solver not available")
    rod = FallingRod(e=0.5)
    h = 0.5
    res = simulate(rod, (0.0, 0.5), (np.array([0.0, h, 0.0]), np.zeros(3)),
                   law="coulomb", method="clarabel")
    ev = res.impacts[0]
    assert set(ev.contacts) == {"left", "right"}
    assert ev.time == pytest.approx(np.sqrt(2 * h / G), abs=1e-10)
    v = np.sqrt(2 * G * h)
    np.testing.assert_allclose(ev.dtheta_plus, [0.0, E * v, 0.0], atol=1e-6)  # symmetry


def test_tilted_rod_bounces_to_rest():
    if "clarabel" not in ci.available_methods("coulomb"):
        pytest.skip("multi-contact solver not available")
    rod = FallingRod(e=0.5)
    res = simulate(rod, (0.0, 2.0), (np.array([0.0, 0.5, 0.4]), np.array([0.0, 0.0, 1.0])),
                   law="coulomb", method="clarabel")
    assert res.status == 0 and res.t[-1] == 2.0
    assert res.held[-1] == 2  # both ends held: lying on the floor
    np.testing.assert_allclose(res.theta[-1, 1:], [0.0, 0.0], atol=1e-9)
    assert res.kinetic_energy[-1] == pytest.approx(0.0, abs=1e-12)
    assert res.n_steps < 5000 and len(res.impacts) < 200


# ---------------------------------------------------------------------------------------------
# result object, dense output
# ---------------------------------------------------------------------------------------------
def test_dense_output_is_free_fall_between_impacts(drop):
    ts = np.linspace(0.0, T1, 7)
    y = drop.sol(ts)
    np.testing.assert_allclose(y[1], H0 - 0.5 * G * ts**2, atol=1e-12)
    np.testing.assert_allclose(y[3], -G * ts, atol=1e-12)  # p_y = m dy/dt, m = 1
    # right-continuous at an impact: post-impact momentum
    assert drop.sol(drop.impacts[0].time)[3] == pytest.approx(E * V1, abs=1e-8)
    assert drop.sol(drop.impacts[0].time - 1e-9)[3] == pytest.approx(-V1, abs=1e-7)


def test_t_eval_and_counters():
    res = simulate(PointMass(e=E), (0.0, 1.0), (np.array([0.0, H0]), np.zeros(2)),
                   t_eval=np.linspace(0.0, 0.4, 5))
    np.testing.assert_allclose(res.theta[:, 1], H0 - 0.5 * G * np.linspace(0, 0.4, 5) ** 2,
                               atol=1e-12)
    assert res.nfev > 0 and res.wall_time > 0 and 0 <= res.impact_time <= res.wall_time
    assert res.as_dict(series=False)["impacts"][0]["time"] == pytest.approx(T1, abs=1e-10)


def test_scene_like_object_is_accepted():
    from convimpact.scenes import Scene
    scene = Scene(name="drop", description="a particle drop", mechanism=PointMass(e=E),
                  theta0=np.array([0.0, H0]), dtheta0=np.zeros(2), t_end=0.5)
    res = simulate(scene)
    assert res.t[-1] == 0.5 and res.impacts[0].time == pytest.approx(T1, abs=1e-10)


# ---------------------------------------------------------------------------------------------
# bad input
# ---------------------------------------------------------------------------------------------
def test_bad_input_typed_errors():
    pm = PointMass()
    y0 = (np.array([0.0, 1.0]), np.zeros(2))
    with pytest.raises(ParameterError, match="increasing"):
        simulate(pm, (1.0, 1.0), y0)
    with pytest.raises(ParameterError):
        simulate(pm, (2.0, 1.0), y0)
    with pytest.raises(NonFiniteError):
        simulate(pm, (0.0, 1.0), (np.array([np.nan, 1.0]), np.zeros(2)))
    with pytest.raises(NonFiniteError):
        simulate(pm, (0.0, 1.0), np.array([0.0, 1.0, np.inf, 0.0]))
    with pytest.raises(PenetrationError, match="penetrates"):
        simulate(pm, (0.0, 1.0), (np.array([0.0, -0.01]), np.zeros(2)))
    assert issubclass(PenetrationError, InputError)
    with pytest.raises(ShapeError):
        simulate(pm, (0.0, 1.0), (np.zeros(3), np.zeros(3)))
    with pytest.raises(UnknownOptionError):
        simulate(pm, (0.0, 1.0), y0, integrator="Euler")
    with pytest.raises(UnknownOptionError):
        simulate(pm, (0.0, 1.0), y0, law="newton")
    with pytest.raises(UnknownOptionError):
        simulate(pm, (0.0, 1.0), y0, zeno="ignore")
    with pytest.raises(ShapeError):
        simulate(pm, (0.0, 1.0))  # a bare mechanism needs y0


def test_inconsistent_closed_loop_initial_conditions():
    sc = SliderCrank()
    th, dth = sc.assembled(0.3, 10.0, 5.0, 0.0)
    bad_th = th + np.array([0.0, 0.02, 0.01, 0.0])
    with pytest.raises(LoopConstraintError, match="assemble=True"):
        simulate(sc, (0.0, 0.1), (bad_th, dth))
    bad_dth = dth + np.array([0.0, 0.5, 0.0, 0.0])
    with pytest.raises(LoopConstraintError, match="C theta_dot"):
        simulate(sc, (0.0, 0.1), (th, bad_dth))
    res = simulate(sc, (0.0, 0.1), (bad_th, bad_dth), assemble=True)
    assert np.max(np.abs(sc.loop_residual(res.theta[0]))) <= 1e-10
    assert np.max(np.abs(sc.loop_jacobian(res.theta[0]) @ res.dtheta[0])) <= 1e-12

    class OffsetGuide(SliderCrank):
        """Slide line 1 m above the crank pivot: out of reach of the 0.4 m chain."""

        def loop_residual(self, theta):
            return super().loop_residual(theta) - np.array([0.0, 1.0])

    with pytest.raises(AssemblyError, match="Psi"):
        simulate(OffsetGuide(), (0.0, 0.1), (th, np.zeros(4)), assemble=True)


class _RampParticle(PointMass):
    """Particle on the floor sliding into a 45-degree ramp x + y = 0 (normal (1, 1)/sqrt 2)."""

    contact_names = ("floor", "ramp")

    def contact_gap(self, name, theta):
        if name == "floor":
            return float(theta[1])
        return float((theta[0] + theta[1]) / np.sqrt(2.0))

    def contact_jacobian(self, name, theta):
        if name == "floor":
            return np.array([[0.0, 1.0], [1.0, 0.0]])
        s = 1.0 / np.sqrt(2.0)
        return np.array([[s, s], [-s, s]])


def test_held_contact_released_when_an_impact_pulls_on_it():
    res = simulate(_RampParticle(e=0.5), (0.0, 1.2), (np.array([1.0, 0.0]), np.array([-1.0, 0.0])))
    assert [(c.kind, c.contact) for c in res.contact_events][:2] == [("persist", "floor"),
                                                                     ("release", "floor")]
    ev = res.impacts[0]
    assert ev.contacts == ("ramp",) and ev.released == ("floor",)
    assert ev.time == pytest.approx(1.0, abs=1e-10)  # slides 1 m at 1 m/s (frictionless hold)
    # free reflection on the ramp: v_n+ = e / sqrt 2, tangential kept -> ((e-1)/2, (e+1)/2)
    np.testing.assert_allclose(ev.dtheta_plus, [-0.25, 0.75], atol=1e-12)
    # ballistic flight afterwards: gap rate along n is (0.5 - g t)/sqrt 2, so the particle
    # falls back onto the ramp at t = 1 + 1/g with velocity (-0.25, 0.75 - 1)
    assert res.impacts[1].contacts == ("ramp",)
    assert res.impacts[1].time == pytest.approx(1.0 + 1.0 / G, abs=1e-10)
    np.testing.assert_allclose(res.impacts[1].dtheta_minus, [-0.25, -0.25], atol=1e-9)


def test_multi_contact_needs_a_multi_contact_method():
    with pytest.raises(ci.NotSupportedError) as info:
        simulate(FallingRod(), (0.0, 1.0), (np.array([0.0, 0.5, 0.0]), np.zeros(3)),
                 method="closed-form")
    assert any("left, right" in n for n in getattr(info.value, "__notes__", []))


@settings(max_examples=30, deadline=None)
@given(h=st.floats(0.05, 3.0), e=st.floats(0.1, 0.9), vx=st.floats(-2.0, 2.0),
       vy=st.floats(-3.0, 3.0))
def test_drop_first_impacts_closed_form_property(h, e, vx, vy):
    res = simulate(PointMass(e=e), (0.0, 20.0), (np.array([0.0, h]), np.array([vx, vy])),
                   max_impacts=3)
    v1 = np.sqrt(vy**2 + 2 * G * h)  # impact speed
    t1 = (vy + v1) / G  # root of h + vy t - g t^2 / 2 = 0
    expected = [t1, t1 + 2 * e * v1 / G, t1 + 2 * e * v1 / G + 2 * e**2 * v1 / G]
    got = [ev.time for ev in res.impacts]
    np.testing.assert_allclose(got, expected, atol=1e-9 * max(1.0, t1))
    for j, ev in enumerate(res.impacts):
        assert ev.dtheta_minus[1] == pytest.approx(-(e**j) * v1, rel=1e-8)
        assert ev.dtheta_plus[0] == pytest.approx(vx, abs=1e-12)
