"""The exact single-contact solvers (method="fast") against independent oracles.

Oracles: the closed form (planar law and every stick), brute-force angle grids refined with
scipy on eq. (60) written out here, a brute-force scan of the Coulomb sliding conditions, the
KKT conditions of the SOC programs (tests/impact/convex_systems.py, written from the law
definitions), Clarabel through cvxpy on a few cases, and the energy identity of the
dissipative law. Delassus matrices come from the null-space formula of convex_systems, not
from convimpact.impact.problem.build.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import brentq, minimize_scalar

import convimpact as ci
from convimpact.impact.laws.pereira_nikravesh import pereira_nikravesh as closed_form_pn
from convimpact.impact.laws.algebra import _candidates, _refine
from convimpact.impact.exact.dispatch import solve_contact
from convimpact.impact.laws.max_dissipation import max_dissipation_direction

from .convex_systems import ccp_residual, coulomb_conditions, delassus, random_system

LAWS = ("pereira-nikravesh", "coulomb", "ccp", "dissipative")
GRID = np.linspace(0.0, 2.0 * np.pi, 4001)[:-1]


def contact_data(seed: int, d: int, loops: int = 0):
    M, Jc, dq, C = random_system(seed, d, 1, loops)
    W = delassus(M, Jc, C)
    return M, Jc, dq, C, 0.5 * (W + W.T), Jc @ dq


def tangent(theta):
    return np.stack([np.cos(theta), np.sin(theta)], axis=-1)


def energy_loss_eq60(W, v, e, mu, t):
    """T_L of pi = pi_n (n + mu t), pi_n from eq. (38); -inf where the denominator is <= 0."""
    t = np.atleast_2d(t)
    p = np.concatenate([np.ones((len(t), 1)), mu * t], axis=1)
    D = p @ W[0]
    pn = -(1 + e) * v[0] / np.where(D > 0, D, 1.0)
    tl = -pn * (p @ v) - 0.5 * pn ** 2 * np.einsum("ij,jk,ik->i", p, W, p)
    return np.where(D > 0, tl, -np.inf)


def brute_max_dissipation(W, v, e, mu):
    """Grid over the circle, densified geometrically toward the poles of pi_n (where the
    denominator w_nn + mu w_nt . t of eq. 38 vanishes, T_L can peak in a sliver narrower than
    the grid), then scipy's bounded Brent around the best sample."""
    angles = [GRID]
    r = math.hypot(W[0, 1], W[0, 2])
    if mu * r > W[0, 0]:  # the denominator has zeros: alpha = phi +- acos(-w_nn / (mu r))
        phi, half = math.atan2(W[0, 2], W[0, 1]), math.acos(-W[0, 0] / (mu * r))
        offsets = np.geomspace(1e-13, GRID[1], 60)
        for pole in (phi + half, phi - half):
            angles += [pole + offsets, pole - offsets]
    grid = np.concatenate(angles)
    tl = energy_loss_eq60(W, v, e, mu, tangent(grid))
    k = int(np.argmax(tl))
    f = lambda a: -float(energy_loss_eq60(W, v, e, mu, tangent(a))[0])  # noqa: E731
    near = np.sort(np.abs(np.angle(np.exp(1j * (grid - grid[k])))))
    h = max(float(near[1]), 1e-15) if near.size > 1 else GRID[1]
    res = minimize_scalar(f, bounds=(grid[k] - h, grid[k] + h), method="bounded",
                          options={"xatol": 1e-15})
    best = -res.fun
    if tl[k] > best:
        return float(tl[k]), float(grid[k])
    return best, float(res.x)


def brute_coulomb_slides(W, v, e, mu):
    """All directions t with u_n = 0 and u_t = -sigma t, sigma >= 0 (scan + brentq)."""
    c = -(1 + e) * v[0]

    def parts(a):
        t = np.array([math.cos(a), math.sin(a)])
        p = np.r_[1.0, mu * t]
        D = W[0] @ p
        pn = c / D
        ut = v[1:] + pn * (W[1:] @ p)
        return D, pn, t, ut

    def g(a):
        D, pn, t, ut = parts(a)
        return ut[0] * t[1] - ut[1] * t[0]

    vals = [g(a) for a in GRID]
    dens = [parts(a)[0] for a in GRID]
    out = []
    for i in range(len(GRID)):
        j = (i + 1) % len(GRID)
        a0, a1 = GRID[i], GRID[i] + GRID[1]
        if dens[i] > 0 and dens[j] > 0 and vals[i] * vals[j] <= 0:
            a = brentq(g, a0, a1, xtol=1e-14) if vals[i] != vals[j] else a0
            D, pn, t, ut = parts(a)
            if -(ut @ t) >= -1e-9:
                out.append(pn * np.r_[1.0, mu * t])
    return out


def unit(x):
    """x / |x| without underflow; None for x = 0."""
    m = np.abs(x).max()
    if m == 0.0:
        return None
    y = x / m
    return y / np.linalg.norm(y)


def newton_b(v, e):
    b = np.array(v, dtype=float)
    b[0] *= 1.0 + e
    return b


# --------------------------------------------------------------------------------------------
# the Pereira-Nikravesh law


@settings(max_examples=150, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), loops=st.integers(0, 1), e=st.floats(0, 1),
       mu=st.floats(0, 2))
def test_planar_pereira_nikravesh_equals_closed_form(seed, loops, e, mu):
    M, Jc, dq, C, W, v = contact_data(seed, 2, loops)
    try:
        ref = ci.resolve_impact(M, Jc, dq, e, mu, C, method="closed-form")
    except ci.ConvImpactError as exc:
        with pytest.raises(type(exc)):
            ci.resolve_impact(M, Jc, dq, e, mu, C, method="fast")
        return
    r = ci.resolve_impact(M, Jc, dq, e, mu, C, method="fast")
    assert r.regime == ref.regime and r.method == "fast"
    np.testing.assert_allclose(r.impulse, ref.impulse, rtol=1e-11,
                               atol=1e-12 * np.abs(ref.impulse).max())
    np.testing.assert_allclose(r.dq_plus, ref.dq_plus, rtol=1e-10, atol=1e-10)


@settings(max_examples=150, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), loops=st.integers(0, 1), e=st.floats(0, 1),
       mu=st.floats(0, 2))
def test_spatial_stick_equals_closed_form_and_slide_maximizes_eq60(seed, loops, e, mu):
    M, Jc, dq, C, W, v = contact_data(seed, 3, loops)
    sol = solve_contact(W, v, e, mu, "pereira-nikravesh")
    assert np.all(np.isfinite(sol.impulse))
    if sol.regime in ("stick", "frictionless"):
        ref, regime, _ = closed_form_pn(W, v, e, mu)
        assert regime == sol.regime
        np.testing.assert_allclose(sol.impulse, ref, rtol=1e-9, atol=1e-11 * np.abs(ref).max())
        for law in ("coulomb",) if sol.regime == "stick" else LAWS:
            np.testing.assert_allclose(solve_contact(W, v, e, mu, law).impulse, ref,
                                       rtol=1e-9, atol=1e-11 * np.abs(ref).max())
        return
    assert sol.regime == "slide"
    pi = sol.impulse
    # on the cone boundary, restitution eq. (37) exactly
    assert math.hypot(*pi[1:]) == pytest.approx(mu * pi[0], rel=1e-12, abs=1e-300)
    assert (W @ pi + v)[0] == pytest.approx(-e * v[0], rel=1e-10, abs=1e-12 * abs(v[0]))
    t = np.array(sol.extras["direction"])  # pi_t / |pi_t| underflows for tiny mu
    assert np.linalg.norm(t) == pytest.approx(1.0, rel=1e-14)
    tl_fast = float(energy_loss_eq60(W, v, e, mu, t)[0])
    tl_ref, a_ref = brute_max_dissipation(W, v, e, mu)
    scale = abs(tl_ref) + 0.5 * pi @ W @ pi
    assert tl_fast >= tl_ref - 1e-12 * scale
    assert tl_fast == pytest.approx(tl_ref, rel=1e-9, abs=1e-12 * scale)
    assert sol.extras["energy_loss_max"] == pytest.approx(tl_fast, rel=1e-12, abs=1e-14 * scale)
    # the direction (unless T_L is flat there, which scipy cannot resolve)
    t_ref = tangent(a_ref)
    h = 1e-4
    curv = abs(float(energy_loss_eq60(W, v, e, mu, tangent(a_ref + h))[0]
                     + energy_loss_eq60(W, v, e, mu, tangent(a_ref - h))[0] - 2 * tl_ref)) / h**2
    if curv > 1e-3 * scale:
        assert np.linalg.norm(t - t_ref) < 1e-5
    t_pub = max_dissipation_direction(W, v, e, mu)  # the public entry, against brute force
    assert float(energy_loss_eq60(W, v, e, mu, t_pub)[0]) == pytest.approx(
        tl_ref, rel=1e-9, abs=1e-12 * scale)


def test_max_dissipation_direction_planar_picks_the_better_tangent():
    W = np.array([[1.0, 0.3], [0.3, 2.0]])
    v = np.array([-1.0, 0.4])
    e, mu = 0.5, 0.8
    best = max((float(energy_loss_eq60(W, v, e, mu, np.array([[s]]))[0]), s) for s in (-1, 1))
    assert max_dissipation_direction(W, v, e, mu).tolist() == [best[1]]


def test_pn_interior_optimum_is_flagged():
    # W = I: P_N's plane optimum is pi* = lam n - v, interior when |v_t| <= mu (c + 2 v_n)...
    # search a case where the stick test fails but P_N's optimum is interior (e > 0)
    rng = np.random.default_rng(7)
    flagged = 0
    for _ in range(400):
        A = rng.normal(size=(3, 3))
        W = A @ A.T + 0.1 * np.eye(3)
        v = rng.normal(size=3)
        v[0] = -abs(v[0])
        e, mu = rng.uniform(0.3, 1.0), rng.uniform(0.1, 2.0)
        sol = solve_contact(W, v, e, mu, "pereira-nikravesh")
        if sol.regime != "slide":
            continue
        # independent P_N plane optimum: min 1/2 pi W pi + pi v s.t. (W pi)_n = c
        c = -(1 + e) * v[0]
        K = np.block([[W, W[:, :1]], [W[:1, :], np.zeros((1, 1))]])
        x = np.linalg.solve(K, np.r_[-v, c])[:3]
        interior = np.linalg.norm(x[1:]) <= mu * x[0]
        assert sol.extras["pn_optimum_interior"] == interior
        if interior:
            flagged += 1
            assert any("interior" in w for w in sol.warnings)
    assert flagged > 0


# --------------------------------------------------------------------------------------------
# Coulomb


@settings(max_examples=100, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), d=st.sampled_from([2, 3]), loops=st.integers(0, 1),
       e=st.floats(0, 1), mu=st.floats(0, 2))
def test_coulomb_conditions_hold_and_match_a_brute_force_scan(seed, d, loops, e, mu):
    M, Jc, dq, C, W, v = contact_data(seed, d, loops)
    try:
        sol = solve_contact(W, v, e, mu, "coulomb")
    except ci.NonPositiveEffectiveMassError:
        if d == 3:
            assert not any(p[0] > 0 for p in brute_coulomb_slides(W, v, e, mu))
        return
    pi = sol.impulse
    assert np.all(np.isfinite(pi))
    b = newton_b(v, e)
    assert coulomb_conditions(W, b, [mu], d, pi) < 1e-9
    u = W @ pi + b
    if sol.regime == "slide":
        assert abs(u[0]) < 1e-10 * np.abs(v).max()  # u_n = 0
        ut = u[1:]
        if np.linalg.norm(ut) > 1e-9 and mu * pi[0] > 1e-200:  # pi_t not lost to underflow
            cosang = unit(ut) @ unit(pi[1:])
            assert cosang == pytest.approx(-1.0, abs=1e-9)  # anti-parallel
        if d == 3:
            slides = brute_coulomb_slides(W, v, e, mu)
            assert slides, "brute force finds no slide where the kernel found one"
            assert min(np.linalg.norm(s - pi) for s in slides) < 1e-7 * np.linalg.norm(pi)
    elif sol.regime == "stick":
        assert np.linalg.norm(u) < 1e-10 * np.abs(v).max()


@settings(max_examples=150, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), loops=st.integers(0, 1), e=st.floats(0, 1),
       mu=st.floats(0, 2))
def test_planar_coulomb_equals_closed_form_unless_the_slip_reverses(seed, loops, e, mu):
    M, Jc, dq, C, W, v = contact_data(seed, 2, loops)
    try:
        ref = ci.resolve_impact(M, Jc, dq, e, mu, C, method="closed-form")
    except ci.ConvImpactError:
        return
    r = ci.resolve_impact(M, Jc, dq, e, mu, C, law="coulomb", method="fast")
    reversed_ = ref.regime == "slide" and ref.impulse[1] * ref.v_plus[1] > 0
    if not reversed_:
        np.testing.assert_allclose(r.impulse, ref.impulse, rtol=1e-10,
                                   atol=1e-12 * np.abs(ref.impulse).max())
    else:
        assert r.diagnostics.coulomb_residual < 1e-9


def test_coulomb_slides_by_hand_and_every_slide_by_brute_force():
    """The planar slide derived by hand; a spatial contact with three sliding solutions: the
    count, the warning and the most dissipative one against the brute-force scan, the extras
    from their definitions (u = W pi + b), and the conic path landing on one of the three."""
    # planar: W = [[1, .3], [.3, 2]], v- = (-1, .8), e = .5, mu = .3. The stick impulse
    # W^-1 (1.5, -.8) = (3.24, -1.25) / 1.91 leaves the cone (1.25 > .3 * 3.24). Against v_t
    # (s = -1): pi_n = 1.5 / (1 - .3 * .3) and u_t = .8 + pi_n (.3 - .3 * 2) = .8 - .3 pi_n
    # = .31 > 0, opposite to s: a slide. s = +1: u_t = .8 + 1.5 (.3 + .3 * 2) / 1.09 > 0,
    # along s: not one
    W = np.array([[1.0, 0.3], [0.3, 2.0]])
    sol = solve_contact(W, [-1.0, 0.8], 0.5, 0.3, "coulomb")
    pn = 1.5 / 0.91
    assert sol.regime == "slide" and sol.effective_mass == pytest.approx(0.91, rel=1e-15)
    np.testing.assert_allclose(sol.impulse, [pn, -0.3 * pn], rtol=1e-15)
    assert sol.extras["n_slide_solutions"] == 1 and not sol.warnings
    assert sol.extras["post_slip"][0] == pytest.approx(0.8 - 0.3 * pn, rel=1e-14)
    # spatial, three slides; one by hand: t = (0, 1), D = 7 + mu (-6) = 1, pi_n = .75 / D,
    # pi = (.75, 0, .75), u = W pi + b = (.75, -1.5, .75) + (-.75, 1.5, -2) = (0, 0, -1.25):
    # u_n = 0 and u_t = -1.25 t, opposite to t
    W = np.array([[7.0, -3.0, -6.0], [-3.0, 4.5, 1.0], [-6.0, 1.0, 7.0]])
    v = np.array([-0.5, 1.5, -2.0])
    e, mu = 0.5, 1.0
    sol = solve_contact(W, v, e, mu, "coulomb")
    slides = brute_coulomb_slides(W, v, e, mu)
    assert sol.regime == "slide" and len(slides) == 3 == sol.extras["n_slide_solutions"]
    assert any("several sliding solutions" in w for w in sol.warnings)
    assert min(np.abs(s - [0.75, 0.0, 0.75]).max() for s in slides) < 1e-12
    best = max(slides, key=lambda p: -p @ v - 0.5 * p @ W @ p)  # T- - T+
    np.testing.assert_allclose(sol.impulse, best, rtol=1e-9)
    pi = sol.impulse
    t = pi[1:] / np.linalg.norm(pi[1:])
    np.testing.assert_allclose(sol.extras["direction"], t, rtol=1e-12, atol=1e-14)
    ut = (W @ pi + newton_b(v, e))[1:]
    assert ut @ t < 0.0
    assert sol.extras["post_slip_speed"] == pytest.approx(np.linalg.norm(ut), rel=1e-9)
    alpha = math.atan2(v[1] * t[1] - v[2] * t[0], v[1] * t[0] + v[2] * t[1]) % math.tau
    assert sol.extras["alpha"] == pytest.approx(alpha, rel=1e-12)
    L = np.linalg.cholesky(W)  # M = I, Jc = L: W = Jc M^-1 Jc^T
    r = ci.resolve_impact(np.eye(3), L, np.linalg.solve(L, v), e=e, mu=mu, law="coulomb",
                          method="clarabel")
    assert r.diagnostics.extras["single_contact_solutions"] == 3
    assert min(np.abs(r.impulse - s).max() for s in slides) < 1e-9


# --------------------------------------------------------------------------------------------
# CCP and the dissipative law


@settings(max_examples=150, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), d=st.sampled_from([2, 3]), loops=st.integers(0, 1),
       e=st.floats(0, 1), mu=st.floats(0, 2))
def test_ccp_satisfies_the_kkt_conditions_of_its_soc_program(seed, d, loops, e, mu):
    M, Jc, dq, C, W, v = contact_data(seed, d, loops)
    sol = solve_contact(W, v, e, mu, "ccp")
    b = newton_b(v, e)
    assert ccp_residual(W, b, [mu], d, sol.impulse) < 1e-11
    u = W @ sol.impulse + b
    if sol.regime == "slide":
        # the lift of the normal velocity is mu |u_t| (K* boundary), and it is reported
        assert sol.extras["normal_velocity_lift"] == pytest.approx(u[0], abs=1e-12)
        assert u[0] == pytest.approx(mu * np.linalg.norm(u[1:]), rel=1e-9, abs=1e-12)


@settings(max_examples=150, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), d=st.sampled_from([2, 3]), loops=st.integers(0, 1),
       e=st.floats(0, 1), mu=st.floats(0, 2))
def test_dissipative_never_gains_energy(seed, d, loops, e, mu):
    M, Jc, dq, C, W, v = contact_data(seed, d, loops)
    r = ci.resolve_impact(M, Jc, dq, e, mu, C, law="dissipative", method="fast")
    plastic = np.array(r.diagnostics.extras["plastic_impulse"])
    assert ccp_residual(W, v, [mu], d, plastic) < 1e-11  # plastic maximal dissipation
    np.testing.assert_allclose(r.impulse, (1 + e) * plastic, rtol=1e-14, atol=0)
    T_minus = 0.5 * dq @ M @ dq
    T_plus = 0.5 * r.dq_plus @ M @ r.dq_plus  # eq. (58) in joint space
    expected = 0.5 * (1 - e * e) * plastic @ W @ plastic
    assert T_minus - T_plus == pytest.approx(expected, rel=1e-8, abs=1e-12 * T_minus)
    assert T_minus - T_plus >= -1e-12 * T_minus


@pytest.mark.filterwarnings("ignore:Solution may be inaccurate")
def test_ccp_and_dissipative_agree_with_clarabel():
    cp = pytest.importorskip("cvxpy")
    for seed in range(8):
        for d in (2, 3):
            M, Jc, dq, C, W, v = contact_data(seed, d, seed % 2)
            e, mu = 0.2 + 0.1 * seed, 0.15 + 0.2 * seed
            for law, ee in (("ccp", e), ("dissipative", 0.0)):
                b = newton_b(v, ee)
                x = cp.Variable(d)
                L = np.linalg.cholesky(W)
                prob = cp.Problem(cp.Minimize(0.5 * cp.sum_squares(L.T @ x) + b @ x),
                                  [cp.SOC(mu * x[0], x[1:])])
                prob.solve(solver=cp.CLARABEL, tol_gap_abs=1e-11, tol_gap_rel=1e-11,
                           tol_feas=1e-11)
                ref = x.value * (1.0 if law == "ccp" else 1.0 + e)
                got = solve_contact(W, v, e, mu, law).impulse
                assert np.linalg.norm(got - ref) <= 1e-5 * np.linalg.norm(ref)


# --------------------------------------------------------------------------------------------
# degenerate cases


@pytest.mark.parametrize("law", LAWS)
@pytest.mark.parametrize("d", [2, 3])
def test_frictionless_every_law(law, d):
    W = np.diag([2.0, 1.0, 3.0][:d]) + 0.1
    v = np.array([-1.0, 0.5, -0.2][:d])
    sol = solve_contact(W, v, 0.6, 0.0, law)
    assert sol.regime == "frictionless"
    assert sol.impulse[0] == pytest.approx(1.6 / W[0, 0], rel=1e-15)
    assert np.all(sol.impulse[1:] == 0.0)


@pytest.mark.parametrize("law", LAWS)
def test_no_pre_impact_slip_spatial(law):
    # v_t- = 0 with a coupled W: every law still slides (or sticks) to a finite answer
    W = np.array([[1.0, 0.8, 0.1], [0.8, 1.5, 0.2], [0.1, 0.2, 0.9]])
    v = np.array([-1.0, 0.0, 0.0])
    for mu in (0.05, 0.3, 1.0, 3.0):
        sol = solve_contact(W, v, 0.5, mu, law)
        assert np.all(np.isfinite(sol.impulse))
        if law == "pereira-nikravesh" and sol.regime == "slide":
            t = sol.impulse[1:] / np.linalg.norm(sol.impulse[1:])
            tl = float(energy_loss_eq60(W, v, 0.5, mu, t)[0])
            assert tl == pytest.approx(brute_max_dissipation(W, v, 0.5, mu)[0], rel=1e-10)


def test_isotropic_no_slip_sticks_in_every_law():
    W = np.diag([2.0, 1.0, 1.0])
    v = np.array([-1.0, 0.0, 0.0])
    for law in LAWS:
        sol = solve_contact(W, v, 0.5, 0.3, law)
        np.testing.assert_allclose(sol.impulse[1:], 0.0, atol=1e-15)


@pytest.mark.parametrize("law", ["pereira-nikravesh", "coulomb", "ccp", "dissipative"])
def test_singular_delassus_is_a_typed_error(law):
    J = np.array([[1.0, 0.0], [0.0, 1.0], [1.0, 1.0]])  # t2 = n + t1: W = J J^T singular
    W = J @ J.T
    v = np.array([-1.0, 0.8, -0.2])
    with pytest.raises(ci.SingularSystemError, match="clarabel"):
        solve_contact(W, v, 0.5, 0.1, law)
    with pytest.raises(ci.SingularSystemError):
        solve_contact(np.array([[1.0, 1.0], [1.0, 1.0]]), v[:2], 0.5, 0.1, law)


def test_jam_direction_always_sticks_in_the_plane():
    # Where eq. (55)'s tangent has a non-positive denominator (Painleve-like), the stick
    # impulse of eq. (42) is admissible in every random draw: the seed's law never jams
    # (measured here; NonPositiveEffectiveMassError stays the typed answer if it did)
    rng = np.random.default_rng(11)
    seen = 0
    for _ in range(3000):
        A = rng.normal(size=(2, 2))
        W = A @ A.T + 1e-3 * np.eye(2)
        v = rng.normal(size=2)
        v[0] = -abs(v[0])
        mu, e = rng.uniform(0.5, 5.0), rng.uniform()
        s = -np.sign(v[1])
        if W[0, 0] + mu * s * W[0, 1] > 0:
            continue
        seen += 1
        stick = -np.linalg.solve(W, [(1 + e) * v[0], v[1]])
        assert abs(stick[1]) <= mu * stick[0] * (1 + 1e-9)
        for law in ("pereira-nikravesh", "coulomb"):
            sol = solve_contact(W, v, e, mu, law)
            assert sol.regime == "stick"
            np.testing.assert_allclose(sol.impulse, stick, rtol=1e-8)
    assert seen > 50


def _points(E, robust=False):
    """The compiled candidates of E's roots as (x, y) pairs, raw and Newton-refined."""
    has, c4, c3, c2, c1, c0, cp, sp, n, xs, ys, ts, rs = _candidates(*E, robust)
    raw = [(xs[j], ys[j]) for j in range(n)]
    refined = [_refine(has, c4, c3, c2, c1, c0, cp, sp, xs[j], ys[j], ts[j], rs[j])
               for j in range(n)]
    return has, raw, refined


@pytest.mark.parametrize("robust", [False, True])
def test_boundary_root_at_infinity_and_double_root(robust):
    # E = sin th: roots th = 0 and th = pi (tau = infinity, vanishing leading coefficient)
    _, pts, _ = _points((0.0, 0.0, 1.0, 0.0, 0.0, 0.0), robust)
    assert any(abs(x + 1.0) < 1e-15 and abs(y) < 1e-15 for x, y in pts)
    assert any(abs(x - 1.0) < 1e-15 and abs(y) < 1e-15 for x, y in pts)
    # E = (cos th - cos 1)^2 = cos^2 - 2 cos1 cos + cos1^2: double roots at th = +-1
    c1 = math.cos(1.0)
    _, _, got = _points((c1 * c1, -2 * c1, 0.0, 1.0, 0.0, 0.0), robust)
    for th in (1.0, -1.0):
        assert min(math.hypot(x - math.cos(th), y - math.sin(th)) for x, y in got) < 1e-7
    # a root just short of tau = infinity (th = pi - 1e-9) is recovered to round-off
    th0 = math.pi - 1e-9
    _, _, got = _points((0.0, -math.sin(th0), math.cos(th0), 0.0, 0.0, 0.0), robust)  # sin(th-th0)
    assert min(math.hypot(x - math.cos(th0), y - math.sin(th0)) for x, y in got) < 1e-14
    # E identically zero: every direction stationary, one candidate
    has, pts, _ = _points((0.0, 0.0, 0.0, 0.0, 0.0, 0.0), robust)
    assert not has and pts == [(1.0, 0.0)]


def test_kernel_input_errors_and_separation():
    W = np.eye(3)
    with pytest.raises(ci.UnknownOptionError):
        solve_contact(W, [-1.0, 0.0, 0.0], 0.5, 0.3, "newton")
    with pytest.raises(ci.ShapeError):
        solve_contact(np.eye(4), [-1.0, 0, 0, 0], 0.5, 0.3, "ccp")
    with pytest.raises(ci.NonFiniteError):
        solve_contact(W, [-1.0, np.nan, 0.0], 0.5, 0.3, "ccp")
    with pytest.raises(ci.NonFiniteError):
        solve_contact(np.diag([1.0, np.inf, 1.0]), [-1.0, 0.0, 0.0], 0.5, 0.3, "coulomb")
    with pytest.raises(ci.ParameterError):
        solve_contact(W, [-1.0, 0.0, 0.0], 1.5, 0.3, "coulomb")
    with pytest.raises(ci.ParameterError):
        solve_contact(W, [-1.0, 0.0, 0.0], 0.5, -0.3, "coulomb")
    sol = solve_contact(W, [0.5, 1.0, 0.0], 0.5, 0.3, "coulomb")
    assert sol.regime == "separating" and not np.any(sol.impulse)
    with pytest.raises(ci.SingularSystemError):
        solve_contact(np.diag([0.0, 1.0, 1.0]), [-1.0, 0.0, 0.0], 0.5, 0.3, "ccp")


def test_several_contacts_name_the_conic_paths():
    M, Jc, dq, C = random_system(3, 3, 2, 0)
    with pytest.raises(ci.NotSupportedError, match="clarabel"):
        ci.resolve_impact(M, Jc, dq, 0.5, 0.3, law="coulomb", method="fast")
    with pytest.raises(ci.UnknownOptionError):
        M, Jc, dq, C = random_system(3, 3, 1, 0)
        ci.resolve_impact(M, Jc, dq, 0.5, 0.3, method="fast", tol=1e-3)


# --------------------------------------------------------------------------------------------
# the paper's 3D pendulum (Section 9.3)


def test_pendulum_3d_newton_laws_rebound_exactly():
    mod = pytest.importorskip("convimpact.problems.pendulum_3d")
    args = mod.impact_arguments(e=0.7, mu=0.4)
    P = ci.build_problem(args["M"], args["Jc"], args["dq"], 0.7, 0.4, args["C"])
    np.testing.assert_allclose(P.v_minus[0], [-1.309, -2.683, 0.809], atol=5e-4)
    vn = P.v_minus[0, 0]
    for law in ("pereira-nikravesh", "coulomb"):
        r = ci.resolve_impact(**args, law=law, method="fast")
        assert r.regime == "slide"
        assert r.v_plus[0] == pytest.approx(-0.7 * vn, rel=1e-12)  # 1.309 -> 0.916
        assert round(r.v_plus[0], 3) == 0.916
    W, v = P.contact_block(0)
    pn = ci.resolve_impact(**args, method="fast")
    tl_ref, _ = brute_max_dissipation(W, v, 0.7, 0.4)
    assert pn.energy_loss == pytest.approx(tl_ref, rel=1e-10)
    co = ci.resolve_impact(**args, law="coulomb", method="fast")
    assert coulomb_conditions(W, newton_b(v, 0.7), [0.4], 3, co.impulse) < 1e-10
    d = ci.resolve_impact(**args, law="dissipative", method="fast")
    assert d.energy_loss >= 0.0


def test_excluded_directions_and_near_isotropic_regressions():
    # strong normal-tangent coupling: D = W_nn + mu w.t <= 0 on a sector of directions; the
    # seed's law slides within D > 0 at the maximum of eq. (60) (brute force)
    W = np.array([[1.0, 1.5, 0.3], [1.5, 3.0, 0.2], [0.3, 0.2, 1.2]])
    v = np.array([-0.2, -3.0, -2.0])
    e, mu = 0.6, 1.2
    assert mu * np.linalg.norm(W[0, 1:]) > W[0, 0]
    sol = solve_contact(W, v, e, mu, "pereira-nikravesh")
    assert sol.regime == "slide" and sol.effective_mass > 0
    t = np.array(sol.extras["direction"])
    tl_ref, _ = brute_max_dissipation(W, v, e, mu)
    assert float(energy_loss_eq60(W, v, e, mu, t)[0]) == pytest.approx(tl_ref, rel=1e-10)
    # a near-isotropic W with huge mu puts roots of the boundary quartic near tau = 0 and
    # tau = infinity at once (Ferrari lost them before the reference rotation): KKT holds
    W = np.diag([1.3845051800135775, 0.1156404397889843, 0.11512941783089871])
    v = np.array([-0.044928629752366916, 0.21793617360206702, 1.4083420965233502])
    for law, b in (("ccp", newton_b(v, 1.0)), ("dissipative", v)):
        sol = solve_contact(W, v, 1.0, 100.0, law)
        pi = sol.impulse if law == "ccp" else sol.impulse / 2.0
        assert ccp_residual(W, b, [100.0], 3, pi) < 1e-10
    co = solve_contact(W, v, 1.0, 100.0, "coulomb")
    assert coulomb_conditions(W, newton_b(v, 1.0), [100.0], 3, co.impulse) < 1e-10
