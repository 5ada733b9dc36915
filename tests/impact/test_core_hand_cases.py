"""The closed-form law against hand derivations: particles, a slender rod, a rolling ball.

Every expected number here is computed from textbook impulse-momentum formulas written out in
the test (reduced mass, Newton-Euler equations of a rigid body), never from the library's own
Delassus matrix or solves.
"""

import numpy as np
import pytest

import convimpact as ci


# --------------------------------------------------------------------------------------------
# two particles


def test_two_particles_1d_frictionless_central():
    # x1, x2 on a line; body i = particle 2, so n = +x and v_n = x2_dot - x1_dot
    m1, m2, v1, v2, e = 1.0, 3.0, 2.0, -0.5, 0.6
    M = np.diag([m1, m2])
    Jc = np.array([[-1.0, 1.0], [0.0, 0.0]])
    r = ci.resolve_impact(M, Jc, [v1, v2], e=e, mu=0.0)
    # textbook: common velocity and restitution
    vc = (m1 * v1 + m2 * v2) / (m1 + m2)
    assert r.regime == "frictionless"
    assert r.dq_plus[0] == pytest.approx(vc - e * m2 / (m1 + m2) * (v1 - v2), rel=1e-13)
    assert r.dq_plus[1] == pytest.approx(vc + e * m1 / (m1 + m2) * (v1 - v2), rel=1e-13)
    m_eff = m1 * m2 / (m1 + m2)
    assert r.normal_impulse == pytest.approx((1 + e) * m_eff * (v1 - v2), rel=1e-13)
    assert r.energy_loss == pytest.approx(0.5 * m_eff * (1 - e**2) * (v1 - v2) ** 2, rel=1e-12)


def _disks(m1, m2, angle):
    """Two disks in the plane, q = (x1, y1, x2, y2); n from disk 1 toward disk 2 (body i)."""
    n = np.array([np.cos(angle), np.sin(angle)])
    t = np.array([-n[1], n[0]])
    M = np.diag([m1, m1, m2, m2])
    Jc = np.array([np.r_[-n, n], np.r_[-t, t]])
    return M, Jc, n, t


@pytest.mark.parametrize("mu", [0.0, 0.1, 0.3, 2.0])
def test_two_disks_oblique(mu):
    m1, m2, e = 2.0, 0.5, 0.4
    M, Jc, n, t = _disks(m1, m2, angle=0.7)
    v1, v2 = np.array([1.5, 0.8]), np.array([-0.3, -0.6])
    vr = v2 - v1
    vn, vt = vr @ n, vr @ t
    assert vn < 0
    m_eff = m1 * m2 / (m1 + m2)
    Pn = (1 + e) * m_eff * -vn
    # particles: sticking needs |P_t| = m_eff |v_t| <= mu P_n
    if m_eff * abs(vt) <= mu * Pn:
        Pt, regime = -m_eff * vt, "stick"
    else:
        Pt, regime = -mu * Pn * np.sign(vt), "slide"
    if mu == 0.0:
        regime = "frictionless"
    P = Pn * n + Pt * t
    r = ci.resolve_impact(M, Jc, np.r_[v1, v2], e=e, mu=mu)
    assert r.regime == regime
    np.testing.assert_allclose(r.dq_plus, np.r_[v1 - P / m1, v2 + P / m2], rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(r.impulse, [Pn, Pt], rtol=1e-12, atol=1e-14)
    assert r.v_plus[0] == pytest.approx(-e * vn, rel=1e-12)


# --------------------------------------------------------------------------------------------
# slender rod striking a rough floor


def _rod(phi, m=1.0, L=1.0):
    """Rod (x, y, phi) with its lower end at c - L/2 (cos phi, sin phi); floor n = +y, t = +x."""
    h = L / 2
    M = np.diag([m, m, m * L**2 / 12])
    # end velocity = (x_dot + h sin(phi) phi_dot, y_dot - h cos(phi) phi_dot)
    Jc = np.array([[0.0, 1.0, -h * np.cos(phi)], [1.0, 0.0, h * np.sin(phi)]])
    return M, Jc


def _rod_hand(phi, v, e, mu, m=1.0, L=1.0):
    """Stick/slide of the rod by hand: Newton-Euler with scalar formulas and Cramer's rule."""
    I, h = m * L**2 / 12, L / 2
    c, s = np.cos(phi), np.sin(phi)
    # end-point velocity change per unit impulse (normal, tangential), Newton-Euler:
    # m dv = P, I dw = r x P with r = -h (c, s):  dw = h (s Pt - c Pn) / I
    a_nn = 1 / m + h * h * c * c / I
    a_tt = 1 / m + h * h * s * s / I
    a_nt = -h * h * s * c / I
    vn, vt = v
    D = a_nn * a_tt - a_nt**2
    Pn_st = (-(1 + e) * vn * a_tt + vt * a_nt) / D  # Cramer
    Pt_st = (-vt * a_nn + (1 + e) * vn * a_nt) / D
    mu_star = abs(Pt_st) / Pn_st
    sg = np.sign(vt)
    Pn_sl = -(1 + e) * vn / (a_nn - mu * sg * a_nt)
    return dict(stick=(Pn_st, Pt_st), slide=(Pn_sl, -mu * sg * Pn_sl), mu_star=mu_star,
                newton_euler=lambda Pn, Pt: np.array([Pt / m, Pn / m, h * (s * Pt - c * Pn) / I]))


@pytest.mark.parametrize("phi_deg, dq", [(30.0, [1.0, -1.0, 0.0]), (60.0, [-0.5, -2.0, 1.5]),
                                         (-45.0, [2.0, -0.5, -1.0])])
def test_rod_stick_slide_boundary(phi_deg, dq):
    phi, e = np.radians(phi_deg), 0.5
    M, Jc = _rod(phi)
    dq = np.array(dq)
    v = Jc @ dq
    hand = _rod_hand(phi, v, e, mu=0.0)
    mu_star = hand["mu_star"]
    assert hand["stick"][0] > 0 and 0 < mu_star < 10
    # just above the boundary: stick, with the hand sticking impulse
    r = ci.resolve_impact(M, Jc, dq, e=e, mu=mu_star * (1 + 1e-6))
    assert r.regime == "stick"
    np.testing.assert_allclose(r.impulse, hand["stick"], rtol=1e-10)
    np.testing.assert_allclose(r.dq_plus - dq, hand["newton_euler"](*hand["stick"]), rtol=1e-10,
                               atol=1e-14)
    assert abs(r.v_plus[1]) < 1e-12 and r.v_plus[0] == pytest.approx(-e * v[0], rel=1e-12)
    # just below: slide, with the hand sliding impulse (eq. 38)
    mu = mu_star * (1 - 1e-6)
    r_slide = ci.resolve_impact(M, Jc, dq, e=e, mu=mu)
    slide = _rod_hand(phi, v, e, mu)["slide"]
    assert r_slide.regime == "slide"
    np.testing.assert_allclose(r_slide.impulse, slide, rtol=1e-10)
    assert r_slide.diagnostics.effective_mass == pytest.approx(-(1 + e) * v[0] / slide[0])
    if hand["stick"][1] * v[1] < 0:
        # friction opposes the slip: the algorithm is continuous across mu*
        np.testing.assert_allclose(r_slide.impulse, hand["stick"], rtol=1e-4)
        assert not r.diagnostics.friction_pushes_slip and not r_slide.diagnostics.slip_reversal
    else:
        # the sticking impulse pushes along the slip: Section 8 jumps at mu*, and the slide
        # just below it reverses the slip; both are flagged
        assert r.diagnostics.friction_pushes_slip
        assert r_slide.diagnostics.slip_reversal
        assert r_slide.v_plus[1] * v[1] < 0


def test_rod_section8_gains_energy_and_says_so():
    # found by a search on the hand formulas above: phi = 60 deg, mu just below mu*
    phi, e = np.radians(60.0), 0.5
    M, Jc = _rod(phi)
    dq = np.array([-0.5, -2.0, 1.5])
    hand = _rod_hand(phi, Jc @ dq, e, 0.0)
    mu = hand["mu_star"] * 0.999
    Pn, Pt = _rod_hand(phi, Jc @ dq, e, mu)["slide"]
    dv = hand["newton_euler"](Pn, Pt)
    T = lambda q: 0.5 * q @ M @ q  # noqa: E731
    gain = T(dq + dv) - T(dq)
    assert gain > 0.15  # Newton's law with friction creates energy here
    r = ci.resolve_impact(M, Jc, dq, e=e, mu=mu)
    assert r.energy_loss == pytest.approx(-gain, rel=1e-10)
    assert r.diagnostics.energy_gained and not r.diagnostics.held()["energy_not_gained"]
    assert any("energy gained" in w for w in r.diagnostics.warnings)


def test_rod_far_from_boundary_slides_with_eq38():
    phi, e, mu = np.radians(30.0), 0.5, 0.3
    M, Jc = _rod(phi)
    dq = np.array([1.0, -1.0, 0.0])
    r = ci.resolve_impact(M, Jc, dq, e=e, mu=mu)
    Pn, Pt = _rod_hand(phi, Jc @ dq, e, mu)["slide"]
    # hand: a_nn = 1 + 3 cos^2 = 3.25, a_nt = -3 sin cos = -1.299, v_t = 1 > 0
    # eq. (38): pi_n = -(1+e) v_n / (a_nn - mu sign(v_t) a_nt) = 1.5 / (3.25 + 0.3 * 1.299)
    assert Pn == pytest.approx(1.5 / (3.25 + 0.3 * 3 * np.sin(phi) * np.cos(phi)), rel=1e-12)
    np.testing.assert_allclose(r.impulse, [Pn, Pt], rtol=1e-12)


# --------------------------------------------------------------------------------------------
# spatial: a solid ball on a rough floor (classic rolling result)


def _ball(m=2.0, radius=0.1):
    """Ball (v, omega) in 3D; floor n = +z, t1 = +x, t2 = +y; contact point at -r z."""
    I = 0.4 * m * radius**2
    M = np.diag([m, m, m, I, I, I])
    # contact point velocity v + omega x (0, 0, -r) = (vx - r wy, vy + r wx, vz)
    Jc = np.array([[0, 0, 1, 0, 0, 0],
                   [1, 0, 0, 0, -radius, 0],
                   [0, 1, 0, radius, 0, 0]], dtype=float)
    return M, Jc, radius


def test_ball_sticks_and_rolls_away():
    M, Jc, r_ = _ball()
    m = M[0, 0]
    dq = np.array([0.6, -0.2, -1.0, 1.0, 2.0, 0.5])
    v = Jc @ dq
    e, mu = 0.5, 0.5
    # classic: tangential effective mass m/3.5; sticks iff |v_t| <= 3.5 mu (1 + e) |v_n|
    assert np.linalg.norm(v[1:]) <= 3.5 * mu * (1 + e) * abs(v[0])
    r = ci.resolve_impact(M, Jc, dq, e=e, mu=mu)
    assert r.regime == "stick"
    np.testing.assert_allclose(r.impulse, [(1 + e) * m * -v[0], *(-m / 3.5 * v[1:])], rtol=1e-12)
    vx, vy, wx, wy = r.dq_plus[0], r.dq_plus[1], r.dq_plus[3], r.dq_plus[4]
    assert vx == pytest.approx(r_ * wy, abs=1e-12) and vy == pytest.approx(-r_ * wx, abs=1e-12)


def test_ball_spatial_slide_closed_form_names_other_methods():
    M, Jc, _ = _ball()
    dq = np.array([3.0, -2.0, -1.0, 0.0, 0.0, 0.0])
    with pytest.raises(ci.NotSupportedError, match="fast"):
        ci.resolve_impact(M, Jc, dq, e=0.5, mu=0.1, method="closed-form")


def test_separating_contact_gets_no_impulse():
    M, Jc = _rod(np.radians(30.0))
    dq = np.array([1.0, 0.5, 0.0])  # end moving up: v_n >= 0
    r = ci.resolve_impact(M, Jc, dq, e=0.5, mu=0.3)
    assert r.regime == "separating"
    assert np.all(r.impulse == 0) and np.all(r.dq_plus == dq) and r.energy_loss == 0.0
    assert any("no impulse" in w for w in r.diagnostics.warnings)
