"""Law "chatterjee-ruina" (Chatterjee & Ruina 1998) against hand derivations.

J_I = -(v_n / W_nn) n (frictionless plastic), J_II = -W^-1 v (sticking plastic),
J^ = (1 + e) J_I + (1 + e_t) (J_II - J_I); outside the friction cone J is the point where the
segment from (1 + e) J_I along J_II - J_I leaves it. J_I and b = J_II - J_I are W-orthogonal,
so with J = s J_I + k b (s = 1 + e): v_n+ = -e v_n- exactly, and
T+ - T- = 1/2 s (s - 2) |J_I|_W^2 + 1/2 k (k - 2) |b|_W^2 <= 0 for k in [0, 2].
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import convimpact as ci
from convimpact.impact.batch.impacts import contact_impulses, resolve_impacts
from convimpact.impact.exact.dispatch import solve_contact

LAW = "chatterjee-ruina"


def disk(m=2.0, r=0.5, ratio=0.4):
    """A ball (I = ratio m r^2) on a floor, coordinates (x, y, phi); contact rows n = y,
    t = x - r phi (the contact point's slip)."""
    M = np.diag([m, m, ratio * m * r * r])
    Jc = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, -r]])
    return M, Jc


@pytest.mark.parametrize("e_t", [-1.0, -0.3, 0.0, 0.5, 1.0])
def test_ball_restitutes_its_slip_by_e_t_inside_the_cone(e_t):
    """W is diagonal for a ball: W_nn = 1/m, W_tt = 1/m + r^2/I = 7/(2m), so J_II,t =
    -(2m/7) v_t and, inside the cone, pi_t = -(1 + e_t) (2m/7) v_t: v_t+ = -e_t v_t-."""
    m, e = 2.0, 0.5
    M, Jc = disk(m)
    vn, vt = -2.0, 1.0
    dq = np.array([vt, vn, 0.0])
    r = ci.resolve_impact(M, Jc, dq, e=e, mu=5.0, law=LAW, e_t=e_t)
    assert r.regime == "stick"
    np.testing.assert_allclose(r.impulse, [(1 + e) * m * -vn, -(1 + e_t) * 2 * m / 7 * vt],
                               rtol=1e-14, atol=1e-15)
    np.testing.assert_allclose(r.v_plus, [-e * vn, -e_t * vt], rtol=1e-13, atol=1e-15)
    assert r.diagnostics.extras["sticking_weight"] == pytest.approx(1 + e_t, rel=1e-15)


def test_ball_outside_the_cone_keeps_the_normal_impulse_and_saturates_friction():
    """b = J_II - J_I is tangential for a ball (b_n = 0), so kappa = mu (1 + e) J_I,n / |b_t|
    and the impulse is ((1 + e) m |v_n|, -mu (1 + e) m |v_n| sign(v_t))."""
    m, e, mu = 2.0, 0.5, 0.1
    M, Jc = disk(m)
    r = ci.resolve_impact(M, Jc, [1.0, -2.0, 0.0], e=e, mu=mu, law=LAW, e_t=0.5)
    pn = (1 + e) * m * 2.0
    assert r.regime == "slide"
    np.testing.assert_allclose(r.impulse, [pn, -mu * pn], rtol=1e-14)
    kappa = mu * (1 + e) * m * 2.0 / (2 * m / 7 * 1.0)
    assert r.diagnostics.extras["sticking_weight"] == pytest.approx(kappa, rel=1e-14)


def rod(theta, m=3.0, length=2.0):
    """A rod striking the floor with its lower end, at angle theta above the floor; center
    coordinates (x, y, phi). By hand: W_nn = (1 + 3c^2)/m, W_nt = -3cs/m, W_tt = (1 + 3s^2)/m,
    det W = 4/m^2, W^-1 = (m/4) [[1 + 3s^2, 3cs], [3cs, 1 + 3c^2]] (c, s of theta)."""
    c, s = math.cos(theta), math.sin(theta)
    M = np.diag([m, m, m * length ** 2 / 12])
    Jc = np.array([[0.0, 1.0, -length / 2 * c], [1.0, 0.0, length / 2 * s]])
    W = np.array([[1 + 3 * c * c, -3 * c * s], [-3 * c * s, 1 + 3 * s * s]]) / m
    Winv = m / 4 * np.array([[1 + 3 * s * s, 3 * c * s], [3 * c * s, 1 + 3 * c * c]])
    return M, Jc, W, Winv


@pytest.mark.parametrize("theta,mu,e_t", [(0.6, 2.0, 0.3), (0.6, 0.15, 0.3),
                                          (1.1, 0.4, -0.5), (0.3, 0.05, 1.0)])
def test_rod_by_hand(theta, mu, e_t):
    e = 0.4
    M, Jc, W, Winv = rod(theta)
    dq = np.array([0.7, -1.3, 0.9])
    v = Jc @ dq
    assert v[0] < 0
    JI = np.array([-v[0] / W[0, 0], 0.0])
    JII = -Winv @ v
    b = JII - JI
    s, k = 1 + e, 1 + e_t
    J = s * JI + k * b
    stick = abs(J[1]) <= mu * J[0]
    if not stick:
        k = mu * s * JI[0] / (abs(b[1]) - mu * b[0])
        J = s * JI + k * b
    r = ci.resolve_impact(M, Jc, dq, e=e, mu=mu, law=LAW, e_t=e_t)
    assert r.regime == ("stick" if stick else "slide")
    np.testing.assert_allclose(r.impulse, J, rtol=1e-12)
    assert r.v_plus[0] == pytest.approx(-e * v[0], rel=1e-12)  # Newton, whatever k
    assert JI @ W @ b == pytest.approx(0.0, abs=1e-12 * np.abs(W).max() * np.abs(JI).max()
                                       * np.abs(b).max())
    dT = 0.5 * s * (s - 2) * JI @ W @ JI + 0.5 * k * (k - 2) * b @ W @ b
    assert -r.energy_loss == pytest.approx(dT, rel=1e-11)
    assert not r.diagnostics.energy_gained


def test_random_contacts_never_gain_energy_and_follow_the_closed_form():
    rng = np.random.default_rng(17)
    for d in (2, 3):
        for _ in range(300):
            A = rng.normal(size=(d, d))
            W = A @ A.T + rng.uniform(0.01, 1.0) * np.eye(d)
            v = rng.normal(size=d)
            v[0] = -abs(v[0]) - 1e-3
            e, mu, e_t = rng.uniform(), rng.uniform(0, 2), rng.uniform(-1, 1)
            sol = solve_contact(W, v, e, mu, LAW, e_t)
            pi = sol.impulse
            JI = np.zeros(d)
            JI[0] = -v[0] / W[0, 0]
            b = -np.linalg.solve(W, v) - JI
            k = sol.extras["sticking_weight"]
            s = 1 + e
            np.testing.assert_allclose(pi, s * JI + k * b, rtol=1e-9,
                                       atol=1e-12 * np.abs(pi).max())
            assert 0.0 <= k <= 1 + e_t + 1e-12
            assert (sol.regime == "stick") == (k == 1 + e_t)
            assert np.linalg.norm(pi[1:]) <= mu * pi[0] * (1 + 1e-12)
            u = v + W @ pi
            assert u[0] == pytest.approx(-e * v[0], rel=1e-9, abs=1e-12 * abs(v[0]))
            dT = pi @ v + 0.5 * pi @ W @ pi
            ref = 0.5 * s * (s - 2) * JI @ W @ JI + 0.5 * k * (k - 2) * b @ W @ b
            scale = 0.5 * abs(v @ np.linalg.solve(W, v))
            assert dT == pytest.approx(ref, abs=1e-9 * scale)
            assert dT <= 1e-12 * scale


def test_outside_its_range_e_t_would_create_energy_and_is_refused():
    """k = 1 + e_t > 2 makes the second term of T+ - T- positive: for a ball inside the cone
    the slip comes back faster than it arrived. The compiled kernel shows the gain; the API
    refuses e_t outside [-1, 1]."""
    from convimpact.impact.laws.chatterjee_ruina import _cr_planar

    W, v, e, e_t = np.diag([0.5, 1.75]), np.array([-2.0, 1.0]), 1.0, 1.5  # e = 1: no normal loss
    out = np.zeros(32)
    st, rg, p0, p1, _, _ = _cr_planar(W[0, 0], W[0, 1], W[1, 1], v[0], v[1], e, 10.0, e_t, out)
    pi = np.array([p0, p1])
    assert pi @ v + 0.5 * pi @ W @ pi > 0.0  # energy created: |v_t+| = 1.5 |v_t-|
    M, Jc = disk()
    for bad in (1.5, -1.2):
        with pytest.raises(ci.ParameterError, match="creates energy"):
            ci.resolve_impact(M, Jc, [1.0, -2.0, 0.0], e=0.5, mu=0.3, law=LAW, e_t=bad)
        with pytest.raises(ci.ParameterError):
            resolve_impacts(M, Jc, [1.0, -2.0, 0.0], e=0.5, mu=0.3, law=LAW, e_t=[bad])
    with pytest.raises(ci.UnknownOptionError, match="e_t"):
        ci.resolve_impact(M, Jc, [1.0, -2.0, 0.0], e=0.5, mu=0.3, law="ccp", e_t=0.2)
    with pytest.raises(ci.ParameterError):
        ci.resolve_impact(M, Jc, [1.0, -2.0, 0.0], e=0.5, mu=0.3, law=LAW, e_t="0.2")


def test_several_contacts_per_contact_when_independent_else_refused():
    """Two balls side by side: W is block-diagonal and each contact gets its own answer;
    one body on two contacts is coupled and refused with the laws that treat it."""
    M1, J1 = disk()
    M = np.zeros((6, 6))
    M[:3, :3] = M[3:, 3:] = M1
    Ja = np.hstack([J1, np.zeros((2, 3))])
    Jb = np.hstack([np.zeros((2, 3)), J1])
    dq = np.array([1.0, -2.0, 0.0, -0.5, -1.0, 0.0])
    r = ci.resolve_impact(M, [Ja, Jb], dq, e=[0.5, 0.2], mu=[5.0, 0.1], law=LAW,
                          e_t=[0.5, 0.0])
    for i, (e, mu, et, q) in enumerate([(0.5, 5.0, 0.5, dq[:3]), (0.2, 0.1, 0.0, dq[3:])]):
        one = ci.resolve_impact(M1, J1, q, e=e, mu=mu, law=LAW, e_t=et)
        np.testing.assert_allclose(r.impulse[i], one.impulse, rtol=1e-14)
    Jc2 = np.array([[0.0, 1.0, 0.3], [1.0, 0.0, -0.5]])
    with pytest.raises(ci.NotSupportedError, match="defined per contact"):
        ci.resolve_impact(M1, [disk()[1], Jc2], [1.0, -2.0, 0.0], e=0.5, mu=0.3, law=LAW)


def test_batch_equals_the_public_call():
    rng = np.random.default_rng(3)
    n, k = 200, 4
    A = rng.normal(size=(n, k, k))
    M = A @ A.transpose(0, 2, 1) + 0.5 * np.eye(k)
    J = rng.normal(size=(n, 3, k))
    dq = rng.normal(size=(n, k))
    e, mu, et = rng.uniform(size=n), rng.uniform(0, 1.5, n), rng.uniform(-1, 1, n)
    b = resolve_impacts(M, J, dq, e, mu, law=LAW, e_t=et)
    for i in range(0, n, 7):
        r = ci.resolve_impact(M[i], J[i], dq[i], e=e[i], mu=mu[i], law=LAW, e_t=et[i])
        np.testing.assert_allclose(b.impulse[i], r.impulse, rtol=1e-12, atol=1e-14)
    c = contact_impulses(b.delassus, b.v_minus, e, mu, law=LAW, e_t=et)
    np.testing.assert_allclose(c.impulse, b.impulse, rtol=1e-12, atol=1e-14)
