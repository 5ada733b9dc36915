"""The failure atlas: each failure mode it found, pinned on a hand-derived case.

Double pendulum (rods L = 1, m = 1, relative angles): the tip is at
``L (cos a1 + cos(a1 + a2), sin a1 + sin(a1 + a2))``, so its Jacobian columns are
``L (p(a1) + p(a1 + a2), p(a1 + a2))`` with ``p(a) = (-sin a, cos a)``. At a2 = pi (folded)
the first column vanishes, at a2 = 0 (stretched) it is twice the second: the tip can only
move along one direction d (unit), the contact-frame Jacobian is ``Jc = d u^T`` and the
Delassus matrix ``W = (u^T M^-1 u) d d^T`` has rank one.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import convimpact as ci
from convimpact.studies.atlas import (
    classify_impact,
    judge_compliant,
    judge_time_stepping,
    slider_crank_map,
    slider_crank_state,
)
from convimpact.problems._double_pendulum import build
from convimpact.scenes import load_scene
from convimpact.simulation import simulate
from convimpact.simulation.compliant import simulate_compliant
from convimpact.simulation.moreau import simulate_moreau
from convimpact.simulation.testing import PointMass, SliderCrank

PEND = build(True, 1.0, 1.0, -2.0, 0.5, 0.3).mechanism()


def hand_tip_direction(a1: float, a2: float) -> np.ndarray:
    """Unit direction of the tip's only motion at a2 in {0, pi}, in the frame (n = +y, t = -x)."""
    p = np.array([-math.sin(a1 + a2), math.cos(a1 + a2)])  # d tip / d a2, world (x, y)
    return np.array([p[1], -p[0]])  # (n, t) components


def folded(a1_deg: float, a2: float = math.pi):
    th = np.array([math.radians(a1_deg), a2])
    return th, np.asarray(PEND.mass_matrix(th), float), np.asarray(PEND.contact_jacobian(
        "tip", th), float)


@pytest.mark.parametrize("a2", [0.0, math.pi])
def test_folded_and_stretched_pendulum_singular_delassus_is_typed(a2):
    th, M, J = folded(-112.5, a2)
    d = hand_tip_direction(th[0], a2)
    # Jc has rank one along the hand direction d
    assert np.linalg.matrix_rank(J, tol=1e-12) == 1
    col = J[:, np.argmax(np.linalg.norm(J, axis=0))]
    assert abs(abs(col @ d) - np.linalg.norm(col)) < 1e-12
    dq = np.array([1.0, -1.0])
    assert (J @ dq)[0] < 0
    for law, method in [("pereira-nikravesh", "closed-form"), ("pereira-nikravesh", "fast"),
                        ("coulomb", "fast"), ("ccp", "fast"), ("dissipative", "fast")]:
        with pytest.raises(ci.SingularSystemError):
            ci.resolve_impact(M, J, dq, 0.5, 0.3, law=law, method=method)
        assert classify_impact(M, J, dq, 0.5, 0.3, law=law, method=method) == (
            "singular_delassus",)
    # the paper's law on its conic path has an answer there (the least-squares stick, else
    # the slide of eq. 55): Newton's restitution on the tip's only line, the impulse on the
    # cone's boundary (|pi_t| = mu pi_n), momentum balanced; the slide reverses the slip,
    # which the atlas reports
    r = ci.resolve_impact(M, J, dq, 0.5, 0.3, law="pereira-nikravesh", method="clarabel")
    v = J @ dq
    assert r.v_plus[0] == pytest.approx(-0.5 * v[0], rel=1e-6)
    assert abs(r.impulse[1]) == pytest.approx(0.3 * r.impulse[0], rel=1e-6)
    np.testing.assert_allclose(M @ (r.dq_plus - dq), J.T @ r.impulse, atol=1e-9)
    assert np.sign(r.v_plus[1]) == -np.sign(v[1])
    assert classify_impact(M, J, dq, 0.5, 0.3, law="pereira-nikravesh",
                           method="clarabel") == ("slip_reversal",)


def _rank_one(th, M, J, dq):
    a1, a2 = th
    d = hand_tip_direction(a1, a2)
    v = J @ dq
    s = float(v @ d)  # v- = s d
    u = J.T @ d  # Jc = d u^T
    return d, s, u


def test_dissipative_on_rank_one_delassus_reverses_the_line_velocity():
    """Dissipative law: the plastic max-dissipation impact stops the tip's only motion (a
    normal impulse suffices, so it lies in any cone) and Poisson scaling by 1 + e gives
    v+ = -e v-: dq+ = dq- - (1 + e) M^-1 u (u^T dq-) / (u^T M^-1 u)."""
    th, M, J = folded(-112.5)
    dq = np.array([1.0, -1.0])
    e = 0.5
    d, s, u = _rank_one(th, M, J, dq)
    Minv_u = np.linalg.solve(M, u)
    expected = dq - (1 + e) * Minv_u * (u @ dq) / (u @ Minv_u)
    r = ci.resolve_impact(M, J, dq, e, 0.8, law="dissipative", method="clarabel")
    np.testing.assert_allclose(r.dq_plus, expected, atol=1e-7)
    assert not r.diagnostics.energy_gained


@pytest.mark.parametrize("a1_deg,rate,mu", [(-135.0, (1, -1), 0.8), (-112.5, (1, -1), 0.3),
                                            (-45.0, (1, 1), 0.8)])
def test_ccp_gains_energy_on_rank_one_delassus_and_flags_it(a1_deg, rate, mu):
    """CCP imposes v_n+ >= -e v_n- + mu |v_t+| (its normal-velocity lift). Along the line d
    (v+ = lam d, v- = s d with s < 0 approaching, d_n > 0 after orienting d):
    lam d_n = e |s| d_n + mu lam |d_t|, so lam = e |s| d_n / (d_n - mu |d_t|) when
    d_n > mu |d_t|. It exceeds |s| (energy gain) when mu |d_t| > (1 - e) d_n."""
    th, M, J = folded(a1_deg)
    dq = np.array(rate, float)
    e = 0.5
    d, s, u = _rank_one(th, M, J, dq)
    if d[0] < 0:
        d, s = -d, -s
    assert s < 0 and d[0] > mu * abs(d[1]) and mu * abs(d[1]) > (1 - e) * d[0]
    lam = e * abs(s) * d[0] / (d[0] - mu * abs(d[1]))
    r = ci.resolve_impact(M, J, dq, e, mu, law="ccp", method="clarabel")
    np.testing.assert_allclose(J @ r.dq_plus, lam * d, atol=1e-6)
    T_minus = 0.5 * dq @ M @ dq
    T_plus = 0.5 * r.dq_plus @ M @ r.dq_plus
    assert T_plus > T_minus
    assert r.diagnostics.energy_gained
    assert "energy_gain" in classify_impact(M, J, dq, e, mu, law="ccp", method="clarabel")


def test_ccp_and_coulomb_without_solution_on_rank_one_delassus_raise_solver_error():
    """With d_n <= mu |d_t| the lift cannot be met along d (CCP's program is unbounded below
    along the null direction of W): a typed SolverError, never a silent answer."""
    th, M, J = folded(-112.5)
    dq = np.array([1.0, -1.0])
    d, s, _ = _rank_one(th, M, J, dq)
    mu = 0.8
    assert abs(d[0]) <= mu * abs(d[1])
    for law in ("ccp", "coulomb"):
        with pytest.raises(ci.SolverError):
            ci.resolve_impact(M, J, dq, 0.5, mu, law=law, method="clarabel")
        assert classify_impact(M, J, dq, 0.5, mu, law=law, method="clarabel") == (
            "no_convergence",)


@given(a1=st.floats(-math.pi, 0.0), a2=st.floats(0.05, math.pi - 0.05),
       sign=st.sampled_from([-1.0, 1.0]), w1=st.floats(-3, 3), w2=st.floats(-3, 3),
       e=st.floats(0.0, 1.0), mu=st.floats(0.0, 5.0))
@settings(max_examples=150, deadline=None)
def test_no_painleve_jam_for_one_planar_contact(a1, a2, sign, w1, w2, e, mu):
    """The atlas never met NonPositiveEffectiveMassError with mu >= 0; why: the seed law
    slides only when the stick impulse pi* (W pi* = -((1+e) v_n, v_t)) leaves the cone,
    |pi*_t| > mu pi*_n, and its friction then acts along sigma = sign(pi*_t). A jam needs
    W_nn + mu sigma W_nt <= 0, i.e. sigma W_nt < 0 and mu |W_nt| >= W_nn; but the stick
    equations give W_nn pi*_n = (1+e)|v_n| + |W_nt| |pi*_t| > mu |W_nt| pi*_n >= W_nn pi*_n,
    a contradiction. So every regular planar single-contact problem resolves."""
    th = np.array([a1, sign * a2])
    M = np.asarray(PEND.mass_matrix(th), float)
    J = np.asarray(PEND.contact_jacobian("tip", th), float)
    dq = np.array([w1, w2])
    if (J @ dq)[0] >= -1e-3:
        return
    modes = classify_impact(M, J, dq, e, mu, law="pereira-nikravesh", method="closed-form")
    assert "non_positive_effective_mass" not in modes and "singular_delassus" not in modes


def _null_space_inverse(M, C):
    """Loop-constrained inverse mass G = N (N^T M N)^-1 N^T, N a basis of ker C (SVD)."""
    _, sv, vt = np.linalg.svd(C)
    N = vt[np.sum(sv > 1e-12):].T
    return N @ np.linalg.solve(N.T @ M @ N, N.T)


def test_central_impact_with_friction_is_frictionless_on_every_path():
    """Slider-crank striking the free slider: both sliders move along x only, so the tangent
    row of Jc is zero and a friction impulse could do no work (it is undetermined): every law
    and path returns the frictionless central impact dq+ = dq- + (1+e)|v_n| G n / w."""
    mech = load_scene("slider_crank").mechanism
    th, dq = slider_crank_state(mech, math.radians(-60.0))
    M, C = mech.mass_matrix(th), mech.loop_jacobian(th)
    J = np.asarray(mech.contact_jacobian("blocks", th), float)
    assert np.allclose(J[1], 0.0)
    G = _null_space_inverse(M, C)
    n = J[0]
    vn = float(n @ dq)
    assert vn < 0
    expected = dq + (1 + 0.83) * (-vn) * (G @ n) / float(n @ G @ n)
    for law in ("pereira-nikravesh", "coulomb", "ccp", "dissipative"):
        for meth in ci.available_methods(law):
            r = ci.resolve_impact(M, J, dq, 0.83, 0.5, C, law=law, method=meth)
            assert r.regime == "frictionless"
            np.testing.assert_allclose(r.dq_plus, expected, atol=1e-6)


@pytest.mark.parametrize("crank_deg", [0.0, 180.0])
def test_dead_centres_lock_slider_but_loop_matrix_stays_regular(crank_deg):
    """At a dead centre C theta_dot = 0 forces slider 3's velocity to zero (it cannot move to
    first order), yet C keeps full rank in these coordinates; the free slider rebounds as from
    a wall: its velocity becomes -e times its own, the crank-slider is untouched."""
    mech = load_scene("slider_crank").mechanism
    th, dq = slider_crank_state(mech, math.radians(crank_deg))
    M, C = mech.mass_matrix(th), mech.loop_jacobian(th)
    assert np.linalg.cond(C @ np.linalg.solve(M, C.T)) < 10
    G = _null_space_inverse(M, C)
    assert abs(G[2, 2]) < 1e-12  # slider 3 is immobile
    J = mech.contact_jacobian("blocks", th)
    r = ci.resolve_impact(M, J, dq, 0.83, 0.0, C)
    expected = dq.copy()
    expected[3] = -0.83 * dq[3]
    np.testing.assert_allclose(r.dq_plus, expected, atol=1e-9)


def test_isosceles_change_point_raises_loop_constraint_error():
    """r = l at phi1 = 90 deg: the pin sits on the crank axis, C's second row
    (r cos phi1, l cos phi2, 0, 0) vanishes: every path meets a LoopConstraintError."""
    sc = SliderCrank(r=0.2, l=0.2)
    th, dq = slider_crank_state(sc, math.pi / 2, geometry="isosceles")
    C = sc.loop_jacobian(th)
    assert np.allclose(C[1], 0.0, atol=1e-15)
    with pytest.raises(ci.LoopConstraintError):
        ci.resolve_impact(sc.mass_matrix(th), sc.contact_jacobian("slider", th), dq, 0.8, 0.0, C)
    m = slider_crank_map([math.pi / 2, math.pi / 4], [0.0], geometry="isosceles")
    for p in m.paths:
        assert m.region(p, "singular_loop").tolist() == [[True, False]]


def test_moreau_jean_misses_accumulating_impacts_and_smears_a_late_one():
    """Particle (e = 0.5) dropped from 1 m: the event-driven run resolves impacts until the
    accumulation; Moreau–Jean with h = 0.01 settles the contact plastically (e_eff = 0 once the
    step-start velocity is above -rest_velocity), so late impacts are missed. Its first
    impact acts on the step-start velocity -g t_k: relative error (t* - t_k) / t* by hand."""
    pm = PointMass(e=0.5)
    y0 = (np.array([0.0, 1.0]), np.zeros(2))
    ref = simulate(pm, (0.0, 1.6), y0, rtol=1e-10, atol=1e-12)
    h = 0.01
    mj = simulate_moreau(pm, (0.0, 1.6), y0, h=h)
    judged = judge_time_stepping(ref, mj, h)
    assert judged["missed"] > 0
    h = 0.1
    mj = simulate_moreau(pm, (0.0, 0.8), y0, h=h)
    t_star = math.sqrt(2 / 9.81)
    t_k = math.floor(t_star / h) * h
    assert (t_star - t_k) / t_star > 1e-2  # beyond the default smear_tol
    ref1 = simulate(pm, (0.0, 0.8), y0, rtol=1e-10, atol=1e-12)
    judged = judge_time_stepping(ref1, mj, h)
    assert judged["velocity_error"] == pytest.approx((t_star - t_k) / t_star, rel=1e-6)
    assert judged["smeared"] == 1 and judged["missed"] == 0


def test_event_driven_zeno_detection_at_the_hand_accumulation_time():
    """Particle bouncing with e: impact speeds v_j = e^j v_1, flight times 2 v_j / g, so the
    impacts accumulate at t_inf = t_1 + 2 e v_1 / (g (1 - e))."""
    e, g = 0.5, 9.81
    pm = PointMass(e=e)
    ref = simulate(pm, (0.0, 2.0), (np.array([0.0, 1.0]), np.zeros(2)), rtol=1e-10,
                   atol=1e-12)
    t1, v1 = math.sqrt(2 / g), math.sqrt(2 * g)
    t_inf = t1 + 2 * e * v1 / (g * (1 - e))
    acc = [ev.accumulation_time for ev in ref.contact_events if ev.accumulation_time]
    assert acc and acc[0] == pytest.approx(t_inf, rel=1e-6)


def test_compliant_deep_and_stiff_flags_against_hand_penetration():
    """Undamped Hertz particle without gravity: delta_max = ((n+1) m v^2 / (2 k))^(1/(n+1));
    at k = 1e5, m = v = 1, n = 1.5 it is (1.25e-5)^0.4 ~ 1.09e-2 m > 1 mm (deep); at
    k = 1e9 about 2.7e-4 m (not deep). The stiffer contact costs more steps per second of
    contact."""
    pm = PointMass(g=0.0, e=1.0)
    y0 = (np.array([0.0, 0.01]), np.array([0.0, -1.0]))
    runs = {k: simulate_compliant(pm, (0.0, 0.1), y0, stiffness=k, rtol=1e-8, atol=1e-11)
            for k in (1e5, 1e9)}
    for k, r in runs.items():
        dmax = (1.25 / k) ** 0.4
        j = judge_compliant(r, depth_tol=1e-3)
        assert j["max_penetration"] == pytest.approx(dmax, rel=1e-2)
        assert j["deep"] == (dmax > 1e-3)
    assert judge_compliant(runs[1e9])["step_ratio"] > judge_compliant(runs[1e5])["step_ratio"]
    assert judge_compliant(runs[1e9])["stiff"]
