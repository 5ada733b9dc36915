"""Closed loops, energy formulas (eqs. 58-61) and the stiction conditions (eq. 62).

Closed loops are checked against two independent computations: the same impact solved in
independent coordinates (null space N of C, M~ = N^T M N) and the paper's bordered systems of
eqs. (51)/(52) assembled literally in the test.
"""

import numpy as np
import pytest
import scipy.linalg as sla

import convimpact as ci


def _closed_loop_system(seed, k=5, m=2, d=2):
    rng = np.random.default_rng(seed)
    A = rng.normal(size=(k, k))
    M = A @ A.T + 0.5 * np.eye(k)
    C = rng.normal(size=(m, k))
    N = sla.null_space(C)
    dq = N @ rng.normal(size=k - m)
    Jc = rng.normal(size=(d, k))
    if Jc[0] @ dq > 0:
        Jc[0] *= -1
    return M, C, N, Jc, dq


def _bordered(M, C, columns, rows, rhs):
    """Solve [[C M^-1 C^T, C M^-1 G], [R^T M^-1 C^T, R^T M^-1 G]] [ds; x] = [0; rhs]."""
    Mi = np.linalg.inv(M)
    m = C.shape[0]
    top = np.hstack([C @ Mi @ C.T, C @ Mi @ columns])
    bottom = np.hstack([rows.T @ Mi @ C.T, rows.T @ Mi @ columns])
    sol = np.linalg.solve(np.vstack([top, bottom]), np.r_[np.zeros(m), rhs])
    return sol[:m], sol[m:]


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("mu", [0.0, 0.2, 5.0])
def test_closed_loop_matches_independent_coordinates(seed, mu):
    M, C, N, Jc, dq = _closed_loop_system(seed)
    e = 0.4
    r = ci.resolve_impact(M, Jc, dq, e=e, mu=mu, C=C)
    # independent coordinates z with dq = N z (N orthonormal): M~ = N^T M N, Jc~ = Jc N
    rz = ci.resolve_impact(N.T @ M @ N, Jc @ N, N.T @ dq, e=e, mu=mu)
    assert r.regime == rz.regime
    np.testing.assert_allclose(r.dq_plus, N @ rz.dq_plus, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(r.impulse, rz.impulse, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(C @ (r.dq_plus - dq), 0.0, atol=1e-12)  # eq. (43)
    # momentum balance with the loop impulses, eq. (44)
    np.testing.assert_allclose(M @ (r.dq_plus - dq), Jc.T @ r.impulse + C.T @ r.loop_impulse,
                               rtol=1e-10, atol=1e-12)


@pytest.mark.parametrize("seed", [0, 2, 4, 5])  # draws whose sticking impulse is compressive
def test_closed_loop_sticking_matches_eq52(seed):
    M, C, N, Jc, dq = _closed_loop_system(seed)
    e = 0.3
    cn, ct = Jc
    vn, vt = Jc @ dq
    ds, (pn, pt) = _bordered(M, C, np.c_[cn, ct], np.c_[cn, ct], [-(1 + e) * vn, -vt])  # (52)
    r = ci.resolve_impact(M, Jc, dq, e=e, mu=1e6, C=C)
    assert pn > 0
    assert r.regime == "stick"
    np.testing.assert_allclose(r.impulse, [pn, pt], rtol=1e-10)
    np.testing.assert_allclose(r.loop_impulse, ds, rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("seed", range(4))
def test_closed_loop_sliding_matches_eq51(seed):
    M, C, N, Jc, dq = _closed_loop_system(seed)
    e, mu = 0.6, 1e-3
    cn, ct = Jc
    vn, vt = Jc @ dq
    tdir = -np.sign(vt)  # eq. (55)
    g = cn + mu * tdir * ct
    ds, (pn,) = _bordered(M, C, g[:, None], cn[:, None], [-(1 + e) * vn])  # eq. (51)
    r = ci.resolve_impact(M, Jc, dq, e=e, mu=mu, C=C)
    assert r.regime == "slide"
    np.testing.assert_allclose(r.impulse, [pn, mu * tdir * pn], rtol=1e-10)
    np.testing.assert_allclose(r.loop_impulse, ds, rtol=1e-9, atol=1e-12)
    assert r.v_plus[0] == pytest.approx(-e * vn, rel=1e-10)


def test_frictionless_closed_loop_energy_is_eq59():
    M, C, N, Jc, dq = _closed_loop_system(7)
    e = 0.83
    r = ci.resolve_impact(M, Jc, dq, e=e, mu=0.0, C=C)
    # eq. (59) with the loop-constrained inverse written out by hand via the null space
    cn = Jc[0]
    m_nn = cn @ N @ np.linalg.inv(N.T @ M @ N) @ N.T @ cn
    expected = (1 - e**2) * (cn @ dq) ** 2 / (2 * m_nn)
    assert r.energy_loss == pytest.approx(expected, rel=1e-10)
    assert ci.central_energy_loss(M, cn, dq, e, C=C) == pytest.approx(expected, rel=1e-10)
    assert ci.energy_loss(M, dq, r.dq_plus) == pytest.approx(expected, rel=1e-9)  # eq. (58)


@pytest.mark.parametrize("seed", range(5))
def test_eq60_equals_eq58_for_slides(seed):
    rng = np.random.default_rng(100 + seed)
    A = rng.normal(size=(4, 4))
    M = A @ A.T + np.eye(4)
    Jc = rng.normal(size=(2, 4))
    dq = rng.normal(size=4)
    if Jc[0] @ dq > 0:
        Jc[0] *= -1
    e, mu = 0.5, 0.05
    r = ci.resolve_impact(M, Jc, dq, e=e, mu=mu)
    assert r.regime == "slide"
    c_t = -np.sign(Jc[1] @ dq) * Jc[1]  # the paper's t opposes the slip (eq. 55)
    tl60 = ci.oblique_energy_loss(M, Jc[0], c_t, dq, r.normal_impulse, mu)
    assert tl60 == pytest.approx(ci.energy_loss(M, dq, r.dq_plus), rel=1e-10)
    assert r.energy_loss == pytest.approx(tl60, rel=1e-10)
    m_nn, m_nt, m_tt = ci.oblique_coefficients(M, Jc[0], c_t)
    Mi = np.linalg.inv(M)
    np.testing.assert_allclose([m_nn, m_nt, m_tt],
                               [Jc[0] @ Mi @ Jc[0], Jc[0] @ Mi @ c_t, c_t @ Mi @ c_t], rtol=1e-12)


# --------------------------------------------------------------------------------------------
# stiction conditions, eq. (62)


def _cramer(M, Jc, dq, e):
    """Paper's Section 9.2: eq. (42) in the paper's tangent t = -v_t-/|v_t-|, Cramer's rule."""
    Mi = np.linalg.inv(M)
    cn = Jc[0]
    ct = -np.sign(Jc[1] @ dq) * Jc[1]
    mnn, mnt, mtt = cn @ Mi @ cn, cn @ Mi @ ct, ct @ Mi @ ct
    vn, vt = cn @ dq, ct @ dq
    D = mnn * mtt - mnt**2
    D1 = -(1 + e) * vn * mtt + mnt * vt
    D2 = -mnn * vt + (1 + e) * vn * mnt  # (62b) exactly as printed
    return D1 / D, D2 / D


@pytest.mark.parametrize("seed", range(12))
def test_stiction_interval_matches_cramer_conditions(seed):
    rng = np.random.default_rng(seed)
    A = rng.normal(size=(3, 3))
    M = A @ A.T + 0.3 * np.eye(3)
    Jc = rng.normal(size=(2, 3))
    dq = rng.normal(size=3)
    if Jc[0] @ dq > 0:
        Jc[0] *= -1
    mu = float(rng.uniform(0.1, 2.0))
    grid = np.linspace(0, 1, 2001)
    for use_mu in (None, mu):
        iv = ci.stiction_interval(M, Jc, dq, mu=use_mu)
        ok = []
        for e in grid:
            pn, pt = _cramer(M, Jc, dq, e)  # pt along the paper's t: > 0 opposes the slip
            good = pn >= 0 and pt >= 0 and (use_mu is None or abs(pt) <= use_mu * pn)
            ok.append(good)
        ok = np.array(ok)
        if not ok.any():
            assert iv.empty or iv.upper - iv.lower < 1e-3
            continue
        assert iv.lower == pytest.approx(grid[ok].min(), abs=6e-4)
        assert iv.upper == pytest.approx(grid[ok].max(), abs=6e-4)
        # and sticking really happens inside (Section 8 algorithm) when mu is imposed
        if use_mu is not None and iv.upper - iv.lower > 1e-3:
            mid = 0.5 * (iv.lower + iv.upper)
            assert ci.resolve_impact(M, Jc, dq, e=mid, mu=use_mu).regime == "stick"


def test_stiction_interval_printed_62a_is_a_typo():
    # Cramer's rule on eq. (42) gives D1 = m_nt v_t - (1+e) m_tt v_n; the paper prints (62a) as
    # m_tt v_t - (1+e) m_nt v_n. A case where the two differ in sign shows which one is right:
    M = np.diag([1.0, 1.0, 1.0 / 12.0])
    phi = np.radians(5.0)
    Jc = np.array([[0.0, 1.0, -0.5 * np.cos(phi)], [1.0, 0.0, 0.5 * np.sin(phi)]])
    dq = np.array([-2.0, -1.0, -2.0])
    e = 0.5
    pn, _ = _cramer(M, Jc, dq, e)
    Mi = np.linalg.inv(M)
    cn, ct = Jc[0], -np.sign(Jc[1] @ dq) * Jc[1]
    printed_62a = (ct @ Mi @ ct) * (ct @ dq) - (1 + e) * (ct @ Mi @ cn) * (cn @ dq)
    derived_D1 = (cn @ Mi @ ct) * (ct @ dq) - (1 + e) * (ct @ Mi @ ct) * (cn @ dq)
    assert np.sign(derived_D1) == np.sign(pn) != np.sign(printed_62a)
