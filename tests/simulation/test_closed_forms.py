"""The closed-form references of closed_forms.py against independent means (ODE solves,
explicit momentum and energy balances, iteration of maps); nothing here calls convimpact."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import minimize_scalar

from tests.simulation import closed_forms as cf

G = 9.81


def _block(width=0.2, height=1.0):
    return np.arctan(width / height), 0.5 * np.hypot(width, height)


def _pendulum(alpha, p2, theta0, dtheta0, stop):
    """Pivoting block theta'' = -p^2 sin(alpha - theta) until ``stop`` ('flat' or 'rest')."""
    def rhs(t, y):
        return [y[1], -p2 * np.sin(alpha - y[0])]

    def event(t, y):
        return y[0] if stop == "flat" else y[1]
    event.terminal = True
    event.direction = -1
    sol = solve_ivp(rhs, (0.0, 20.0), [theta0, dtheta0], events=event, rtol=1e-12,
                    atol=1e-14, method="DOP853")
    return sol.t_events[0][0], sol.y_events[0][0]


@pytest.mark.parametrize("width,height,tilt", [(0.2, 1.0, 0.1), (0.2, 1.0, 0.19),
                                               (0.5, 1.0, 0.05), (0.2, 1.0, 1e-3)])
def test_housner_landing_time_against_the_pendulum_ode(width, height, tilt):
    alpha, R = _block(width, height)
    T = cf.housner_first_landing_time(tilt, alpha, R)
    t_ode, _ = _pendulum(alpha, cf.housner_p2(R), tilt, 0.0, "flat")
    assert T == pytest.approx(t_ode, rel=1e-9)


def test_housner_landing_time_tends_to_the_linearised_one_for_slender_blocks():
    for alpha in (1e-2, 1e-3):
        R = 0.5 / np.cos(alpha)
        T = cf.housner_first_landing_time(0.5 * alpha, alpha, R)
        lin = cf.housner_first_landing_time_linear(0.5 * alpha, alpha, R)
        assert T == pytest.approx(lin, rel=alpha)  # the error is O(alpha^2)
    with pytest.raises(ValueError):
        cf.housner_first_landing_time(0.3, 0.2, 0.5)  # it topples


def test_housner_restitution_from_explicit_angular_momentum():
    for w, h in ((0.2, 1.0), (0.5, 1.0), (1.0, 1.0)):
        m, omega = 2.0, 1.3
        O, O2, Gc = np.array([w / 2, 0.0]), np.array([-w / 2, 0.0]), np.array([0.0, h / 2])
        v_G = omega * np.array([-(Gc - O)[1], (Gc - O)[0]])  # omega z x (G - O)
        rel = Gc - O2
        H = m * (w * w + h * h) / 12 * omega + m * (rel[0] * v_G[1] - rel[1] * v_G[0])
        I_O2 = m * (w * w + h * h) / 12 + m * rel @ rel
        alpha, _ = _block(w, h)
        assert H / I_O2 / omega == pytest.approx(cf.housner_restitution(alpha), rel=1e-13)


def test_housner_amplitude_map_against_energy_and_the_ode():
    alpha, R = _block()
    p2 = cf.housner_p2(R)
    r = cf.housner_restitution(alpha)
    theta = 0.1
    for _ in range(4):
        # swing down from rest at theta to the landing, jump by r, swing up to rest
        _, y = _pendulum(alpha, p2, theta, 0.0, "flat")
        assert y[1] ** 2 == pytest.approx(2 * p2 * (np.cos(alpha - theta) - np.cos(alpha)),
                                          rel=1e-9)  # energy: omega_-^2 at the landing
        _, y2 = _pendulum(alpha, p2, 0.0, -r * y[1], "rest")
        nxt = cf.housner_amplitude_map(theta, alpha)
        assert nxt == pytest.approx(y2[0], rel=1e-8)
        assert 0 < nxt < theta
        theta = nxt


def test_housner_landing_times_and_rest_time():
    alpha, R = _block()
    p2 = cf.housner_p2(R)
    r = cf.housner_restitution(alpha)
    times = cf.housner_landing_times(0.1, alpha, R, 4)
    # chain the pendulum ODE: swing to the landing, jump by r, swing up and back, ...
    t, y = _pendulum(alpha, p2, 0.1, 0.0, "flat")
    ode = [t]
    for _ in range(3):
        w = -r * y[1]
        t_up, y_up = _pendulum(alpha, p2, 0.0, w, "rest")
        t_down, y = _pendulum(alpha, p2, y_up[0], 0.0, "flat")
        t += t_up + t_down
        ode.append(t)
    np.testing.assert_allclose(times, ode, rtol=1e-9)
    rest = cf.housner_rest_time(0.1, alpha, R)
    many = cf.housner_landing_times(0.1, alpha, R, 400)
    assert many[-1] < rest < many[-1] + 1e-3 * rest and np.all(np.diff(many) > 0)


def test_rimless_wheel_eta_from_explicit_angular_momentum():
    for n, rho in ((8, 0.1), (6, 0.3), (12, 0.0)):
        m, leg, w = 1.5, 0.8, 2.0
        a = np.pi / n
        P, P2 = np.array([0.0, 0.0]), np.array([-2 * leg * np.sin(a), 0.0])  # old, new foot
        hub = np.array([-leg * np.sin(a), leg * np.cos(a)])
        v = w * np.array([-(hub - P)[1], (hub - P)[0]])
        rel = hub - P2
        H = m * (rho * leg) ** 2 * w + m * (rel[0] * v[1] - rel[1] * v[0])
        ratio = H / (m * leg * leg * (1 + rho ** 2)) / w
        assert ratio == pytest.approx(cf.rimless_wheel_eta(n, rho), rel=1e-12)


@pytest.mark.parametrize("n,slope_deg,rho", [(8, 5.0, 0.1), (6, 12.0, 0.2), (10, 3.0, 0.05)])
def test_rimless_wheel_fixed_point_by_iterating_the_map_and_by_energy(n, slope_deg, rho):
    slope, leg = np.radians(slope_deg), 1.0
    w_minus, w_plus = cf.rimless_wheel_steady_speed(n, slope, leg, rho)
    w = 1.2 * w_minus
    for _ in range(200):
        w = cf.rimless_wheel_step_map(w, n, slope, leg, rho)
        assert w is not None
    assert w == pytest.approx(w_minus, rel=1e-12)
    assert w_plus == pytest.approx(cf.rimless_wheel_eta(n, rho) * w_minus, rel=1e-14)
    # per step the strike removes what the descent of the hub releases (m = 1)
    J = leg * leg * (1 + rho ** 2)
    lost = 0.5 * J * (w_minus ** 2 - w_plus ** 2)
    assert lost == pytest.approx(G * 2 * leg * np.sin(np.pi / n) * np.sin(slope), rel=1e-12)


def test_rimless_wheel_stance_phase_against_the_inverted_pendulum_ode():
    n, slope, leg, rho = 8, np.radians(5.0), 1.0, 0.1
    a = np.pi / n
    w_minus, w_plus = cf.rimless_wheel_steady_speed(n, slope, leg, rho)
    k = G / (leg * (1 + rho ** 2))
    # sigma: stance-leg angle from the vertical (forward positive); from slope - a to slope + a

    def ev(t, y):
        return y[0] - (slope + a)
    ev.terminal = True
    sol = solve_ivp(lambda t, y: [y[1], k * np.sin(y[0])], (0, 10), [slope - a, w_plus],
                    events=ev, rtol=1e-12, atol=1e-14)
    assert sol.y_events[0][0][1] == pytest.approx(w_minus, rel=1e-9)
    T = cf.rimless_wheel_stance_time(w_plus, slope - a, slope + a, 1.0, rho)
    assert T == pytest.approx(sol.t_events[0][0], rel=1e-9)
    # too slow a wheel does not pass the vertical; on 8 degrees a 6-spoke wheel has no gait
    assert cf.rimless_wheel_step_map(0.5, n, slope, leg, rho) is None
    w = cf.rimless_wheel_steady_speed(6, np.radians(8.0), leg, 0.2)[0]
    assert cf.rimless_wheel_step_map(w, 6, np.radians(8.0), leg, 0.2) is None


@pytest.mark.parametrize("v0,omega0", [(2.0, 0.0), (2.0, 10.0), (2.0, -40.0), (1.0, 80.0)])
def test_ball_rolling_against_the_sliding_ode(v0, omega0):
    r, mu, m = 0.1, 0.2, 1.0
    inertia = 0.4 * m * r * r

    def rhs(t, y):  # y = (v, omega); friction against the slip s = v + r omega
        F = -mu * m * G * np.sign(y[0] + r * y[1])
        return [F / m, r * F / inertia]

    def rolls(t, y):
        return y[0] + r * y[1]
    rolls.terminal = True
    sol = solve_ivp(rhs, (0, 10), [v0, omega0], events=rolls, rtol=1e-12, atol=1e-14)
    t_roll, v_final = cf.ball_rolling(v0, omega0, r, mu)
    assert t_roll == pytest.approx(sol.t_events[0][0], rel=1e-9)
    assert v_final == pytest.approx(sol.y_events[0][0][0], rel=1e-9, abs=1e-12)


def test_ball_rolling_spatial_reduces_to_the_planar_case_and_rolls():
    r, mu = 0.1, 0.2
    d = np.radians(30.0)
    u = np.array([np.cos(d), 0.0, np.sin(d)])
    spin_axis = np.array([-np.sin(d), 0.0, np.cos(d)])  # omega > 0 is backspin along u
    t, vf, wf = cf.ball_rolling_spatial(2.0 * u, 10.0 * spin_axis, r, mu)
    t2, v2 = cf.ball_rolling(2.0, 10.0, r, mu)
    assert t == pytest.approx(t2) and np.allclose(vf, v2 * u)
    # a skew spin: the final state rolls, and the slip decayed along a fixed direction
    t, vf, wf = cf.ball_rolling_spatial([1.0, 0.0, 0.5], [3.0, 0.0, -7.0], r, mu)
    assert np.allclose(vf + np.cross(wf, [0.0, -r, 0.0]), 0.0, atol=1e-14)
    s0 = np.array([1.0, 0.0, 0.5]) + np.cross([3.0, 0.0, -7.0], [0.0, -r, 0.0])
    assert np.allclose(np.array([1.0, 0.0, 0.5]) - vf, mu * G * t * s0 / np.linalg.norm(s0))


def test_box_and_incline_by_kinematics_and_force_balance():
    t, d = cf.box_stopping(3.0, 0.3)
    a = 0.3 * G
    assert t == pytest.approx(3.0 / a) and d == pytest.approx(3.0 * t - 0.5 * a * t * t)
    slope = np.radians(30.0)
    assert cf.incline(0.7, slope) == 0.0 and cf.incline(np.tan(slope), slope) == 0.0
    # forces along the slope on a sliding unit mass: gravity g sin, friction mu g cos
    assert cf.incline(0.5, slope) == pytest.approx(G * np.sin(slope) - 0.5 * G * np.cos(slope))
    t, s = cf.incline_stopping(1.0, 0.7, slope)
    dec = 0.7 * G * np.cos(slope) - G * np.sin(slope)
    assert t == pytest.approx(1.0 / dec) and s == pytest.approx(t - 0.5 * dec * t * t)
    t, s = cf.incline_stopping(-1.0, 0.5, slope)
    assert s < 0 and t == pytest.approx(1.0 / (G * (np.sin(slope) + 0.5 * np.cos(slope))))
    assert cf.incline_stopping(1.0, 0.5, slope) is None
    assert cf.incline_stopping(0.0, 0.5, slope) is None


@pytest.mark.parametrize("theta_deg,mu,slip", [(60.0, 1.5, -1), (60.0, 1.5, 1), (30.0, 0.4, -1),
                                               (75.0, 2.0, -1)])
def test_painleve_effective_mass_against_hand_built_matrices(theta_deg, mu, slip):
    """A = Jn M^-1 (Jn - mu slip Jt)^T with M = diag(m, m, I) in (x, y, theta) coordinates."""
    m, leg = 1.3, 0.5
    th = np.radians(theta_deg)
    M = np.diag([m, m, m * leg * leg / 3])
    # foot = (x, y) - l (cos th, sin th): its velocity rows in (x_dot, y_dot, th_dot)
    Jt = np.array([1.0, 0.0, leg * np.sin(th)])   # along the lean direction
    Jn = np.array([0.0, 1.0, -leg * np.cos(th)])  # vertical
    A = Jn @ np.linalg.solve(M, Jn - mu * slip * Jt)
    assert cf.painleve_effective_mass(th, mu, slip, m, leg) == pytest.approx(A, rel=1e-12)
    negative = A < 0
    assert negative == (slip < 0 and mu > cf.painleve_critical_mu(th))


def test_painleve_critical_mu_minimum_is_four_thirds_at_tan_two():
    res = minimize_scalar(cf.painleve_critical_mu, bounds=(0.1, 1.5), method="bounded",
                          options={"xatol": 1e-10})
    assert res.fun == pytest.approx(4 / 3, rel=1e-10)
    assert np.tan(res.x) == pytest.approx(2.0, rel=1e-4)
