"""The seed's angle sweep (method="sweep") against independent oracles.

Oracles: the energy loss of eq. (58) computed in joint coordinates from the velocity jump
(not the contact-space eq. 60 the sweep uses), fine brute-force grids, the exact quartic
solve of method="fast" (a different algorithm), and the closed form in the plane.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import convimpact as ci
from convimpact.impact.exact.sweep import energy_loss_versus_angle, sweep_direction

from .convex_systems import delassus, random_system


def contact_data(seed: int, d: int, loops: int = 0):
    M, Jc, dq, C = random_system(seed, d, 1, loops)
    W = delassus(M, Jc, C)
    return M, Jc, dq, C, 0.5 * (W + W.T), Jc @ dq


def joint_space_energy_loss(M, Jc, dq, C, e, mu, t):
    """T- - T+ (eq. 58) for pi = pi_n (n + mu t), with pi_n fixed by v_n+ = -e v_n- (eq. 21),
    the jump from the bordered system of eqs. (44)/(45) solved in joint coordinates."""
    k = M.shape[0]
    c = Jc[0] + mu * (t[0] * Jc[1] + t[1] * Jc[2])  # c_n + mu c_t
    Cm = np.zeros((0, k)) if C is None else np.atleast_2d(C)
    m = Cm.shape[0]
    K = np.block([[M, -Cm.T], [Cm, np.zeros((m, m))]])
    # unit normal impulse: M d = c + C^T s, C d = 0
    sol = np.linalg.solve(K, np.r_[c, np.zeros(m)])
    d_unit = sol[:k]
    vn = Jc[0] @ dq
    pn = -(1 + e) * vn / (Jc[0] @ d_unit)
    dq_plus = dq + pn * d_unit
    return 0.5 * dq @ M @ dq - 0.5 * dq_plus @ M @ dq_plus, pn


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), loops=st.integers(0, 1), e=st.floats(0, 1),
       mu=st.floats(0.01, 2))
def test_curve_equals_eq58_in_joint_space(seed, loops, e, mu):
    M, Jc, dq, C, W, v = contact_data(seed, 3, loops)
    alpha = np.linspace(0, 2 * np.pi, 13)
    curve = energy_loss_versus_angle(W, v, e, mu, alpha)
    ref_dir = v[1:] / np.linalg.norm(v[1:])
    for a, tl, pn, ok in zip(alpha, curve.energy_loss, curve.normal_impulse, curve.admissible):
        ca, sa = math.cos(a), math.sin(a)
        t = np.array([ca * ref_dir[0] - sa * ref_dir[1], ca * ref_dir[1] + sa * ref_dir[0]])
        tl_ref, pn_ref = joint_space_energy_loss(M, Jc, dq, C, e, mu, t)
        if ok:
            assert pn == pytest.approx(pn_ref, rel=1e-8)
            assert tl == pytest.approx(tl_ref, rel=1e-7, abs=1e-9 * (abs(tl_ref) + pn_ref**2))
        else:
            assert tl == -np.inf and pn == np.inf
            assert pn_ref <= 0 or abs(pn_ref) > 1e8  # D <= 0 (up to round-off at D = 0)


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), loops=st.integers(0, 1), e=st.floats(0, 1),
       mu=st.floats(0.01, 2))
def test_sweep_agrees_with_fast_and_a_fine_grid_on_spatial_slides(seed, loops, e, mu):
    M, Jc, dq, C, W, v = contact_data(seed, 3, loops)
    fast = ci.resolve_impact(M, Jc, dq, e, mu, C, method="fast")
    if fast.regime != "slide":
        sw = ci.resolve_impact(M, Jc, dq, e, mu, C, method="sweep")
        assert sw.regime == fast.regime
        np.testing.assert_allclose(sw.impulse, fast.impulse, rtol=1e-10, atol=1e-12)
        return
    r = ci.resolve_impact(M, Jc, dq, e, mu, C, method="sweep")
    x = r.diagnostics.extras
    fx = fast.diagnostics.extras
    scale = abs(fast.energy_loss) + fast.impulse[0] ** 2 * W[0, 0]
    # T_L agrees to round-off; the angle to the sweep's reach (T_L is flat at its maximum)
    assert x["energy_loss_max"] == pytest.approx(fx["energy_loss_max"], abs=1e-11 * scale)
    assert x["energy_loss_max"] <= fx["energy_loss_max"] + 1e-12 * scale
    assert abs(math.remainder(x["alpha_m"] - fx["alpha_m"], 2 * math.pi)) < 1e-5
    assert r.energy_loss == pytest.approx(fast.energy_loss, abs=1e-10 * scale)
    # never below the best of a fine grid
    fine = energy_loss_versus_angle(W, v, e, mu, np.linspace(0, 2 * np.pi, 20001))
    assert x["energy_loss_max"] >= fine.energy_loss.max() - 1e-12 * scale
    assert x["n_evaluations"] < 1000
    # Newton's restitution held
    assert r.v_plus[0] == pytest.approx(-e * r.v_minus[0], rel=1e-9)


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), e=st.floats(0, 1), mu=st.floats(0.01, 2))
def test_energy_gain_sectors_match_a_fine_grid(seed, e, mu):
    M, Jc, dq, C, W, v = contact_data(seed, 3)
    sw = sweep_direction(W, v, e, mu)
    a = np.linspace(0, 2 * np.pi, 50000, endpoint=False)
    c = energy_loss_versus_angle(W, v, e, mu, a)
    gain = (~c.admissible) | (c.energy_loss < 0)
    inside = np.zeros_like(gain)
    for a0, a1 in sw.energy_gain_sectors:
        inside |= ((a >= a0) & (a <= a1)) if a1 >= a0 else ((a >= a0) | (a <= a1))
    # only grid points within ~1e-6 of a sector end may disagree
    assert np.sum(gain != inside) <= 2 * len(sw.energy_gain_sectors)
    if sw.excluded_sector is None:
        # the largest normal impulse, closed form, against the grid
        assert sw.max_normal_impulse == pytest.approx(c.normal_impulse.max(), rel=1e-6)


def test_planar_sweep_follows_eq55_and_measures_its_claim():
    rng = np.random.default_rng(4)
    n_slides = not_max = 0
    for _ in range(300):
        A = rng.normal(size=(3, 3))
        M = A @ A.T + 0.3 * np.eye(3)
        Jc = rng.normal(size=(2, 3))
        dq = rng.normal(size=3)
        if Jc[0] @ dq > 0:
            Jc[0] *= -1
        e, mu = rng.uniform(), rng.uniform(0.05, 2)
        cf = ci.resolve_impact(M, Jc, dq, e, mu, method="closed-form")
        sw = ci.resolve_impact(M, Jc, dq, e, mu, method="sweep")
        # the law is eq. (55) in the plane: every path gives the same impulse
        np.testing.assert_allclose(sw.impulse, cf.impulse, rtol=1e-12)
        if cf.regime != "slide":
            continue
        n_slides += 1
        # independent: the opposite tangent's energy loss from joint space (eq. 58)
        v = Jc @ dq
        s = np.sign(v[1])
        g = np.array([1.0, s * mu])  # friction along the slip
        Mi = np.linalg.inv(M)
        denom = Jc[0] @ Mi @ Jc.T @ g
        x = sw.diagnostics.extras
        if denom <= 0:
            assert x["energy_loss_opposite"] is None
            continue
        dq_plus = dq + Mi @ Jc.T @ g * (-(1 + e) * v[0] / denom)
        tl_opp = 0.5 * dq @ M @ dq - 0.5 * dq_plus @ M @ dq_plus
        assert x["energy_loss_opposite"] == pytest.approx(tl_opp, rel=1e-9, abs=1e-12)
        assert x["eq55_is_max_dissipation"] == (cf.energy_loss >= tl_opp)
        not_max += not x["eq55_is_max_dissipation"]
    assert n_slides > 50
    # eq. (55)'s claim (maximal dissipation in the plane) fails in a minority of slides
    assert 0 < not_max < n_slides / 2


def test_sweep_input_errors():
    W = np.eye(3)
    v = np.array([-1.0, 1.0, 0.0])
    with pytest.raises(ci.ParameterError):
        sweep_direction(W, v, 0.5, 0.3, xtol=0.0)
    with pytest.raises(ci.ParameterError):
        sweep_direction(W, v, 0.5, 0.3, n_grid=3)
    with pytest.raises(ci.ShapeError):
        sweep_direction(np.eye(2), v[:2], 0.5, 0.3)
    with pytest.raises(ci.ShapeError):
        energy_loss_versus_angle(np.eye(2), v[:2], 0.5, 0.3, [0.0])
    M, Jc, dq, C = random_system(1, 3, 1, 0)
    with pytest.raises(ci.UnknownOptionError):
        ci.resolve_impact(M, Jc, dq, 0.5, 0.3, method="sweep", tolerance=1e-3)
    M, Jc, dq, C = random_system(1, 3, 2, 0)
    with pytest.raises(ci.NotSupportedError, match="clarabel"):
        ci.resolve_impact(M, Jc, dq, 0.5, 0.3, method="sweep")


def test_excluded_sector_in_closed_form():
    # W_n = (1, 1.5, 0) with mu = 1: D = 1 + 1.5 cos(phi) <= 0 for |phi - pi| <= acos(2/3)
    W = np.array([[1.0, 1.5, 0.0], [1.5, 3.0, 0.0], [0.0, 0.0, 1.0]])
    v = np.array([-1.0, 1.0, 0.0])  # slip along +t1: alpha is measured from t1
    sw = sweep_direction(W, v, 0.5, 1.0)
    half = math.acos(1.0 / 1.5)
    assert sw.excluded_sector == pytest.approx((math.pi - half, math.pi + half), abs=1e-14)
    assert sw.max_normal_impulse == math.inf
    a = np.array([math.pi - half - 1e-6, math.pi, math.pi + half + 1e-6])
    assert energy_loss_versus_angle(W, v, 0.5, 1.0, a).admissible.tolist() == [True, False,
                                                                                True]


def test_pendulum_3d_sweep():
    mod = pytest.importorskip("convimpact.problems.pendulum_3d")
    args = mod.impact_arguments(e=0.7, mu=0.4)
    r = ci.resolve_impact(**args, method="sweep")
    f = ci.resolve_impact(**args, method="fast")
    assert r.regime == "slide"
    assert r.v_plus[0] == pytest.approx(0.7 * 1.3090169943749475, rel=1e-9)  # 0.916
    x = r.diagnostics.extras
    assert abs(math.remainder(x["alpha_m"] - f.diagnostics.extras["alpha_m"], 2 * math.pi)) < 1e-6
    assert r.energy_loss == pytest.approx(f.energy_loss, rel=1e-10)
    (a0, a1), = x["energy_gain_sectors"]  # one sector of energy gain, as in Fig. 9
    assert (x["alpha_0"], x["alpha_1"]) == (a0, a1)
    am = x["alpha_m"]
    assert not ((am - a0) % (2 * math.pi) <= (a1 - a0) % (2 * math.pi))  # alpha_m outside it
    assert x["energy_loss_max"] > 0
