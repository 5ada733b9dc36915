"""Property tests (hypothesis) of the closed-form law on random SPD systems.

The oracle for the Section 8 decision is recomputed here from M^-1 formed by np.linalg.inv
(not the library's Cholesky/Schur path), and the invariants are checked on the answer.
"""

import numpy as np
import pytest
import scipy.linalg as sla
from hypothesis import assume, given, settings
from hypothesis import strategies as st

import convimpact as ci

SETTINGS = settings(max_examples=150, deadline=None)


def _system(seed, k, d, loops=0):
    rng = np.random.default_rng(seed)
    A = rng.normal(size=(k, k))
    M = A @ A.T + 0.2 * np.eye(k)
    Jc = rng.normal(size=(d, k))
    C = rng.normal(size=(loops, k)) if loops else None
    N = sla.null_space(C) if loops else np.eye(k)
    dq = N @ rng.normal(size=N.shape[1])
    if Jc[0] @ dq > 0:
        Jc[0] *= -1
    return M, Jc, dq, C


def _stick_oracle(M, Jc, dq, e, C):
    Mi = np.linalg.inv(M)
    if C is not None:  # loop-constrained inverse written out
        Mi = Mi - Mi @ C.T @ np.linalg.inv(C @ Mi @ C.T) @ C @ Mi
    W = Jc @ Mi @ Jc.T
    v = Jc @ dq
    b = v.copy()
    b[0] *= 1 + e
    return np.linalg.solve(W, -b), W, v


@SETTINGS
@given(seed=st.integers(0, 2**31), k=st.integers(2, 7), loops=st.integers(0, 1),
       e=st.floats(0, 1), mu=st.floats(0, 3))
def test_planar_section8_invariants(seed, k, loops, e, mu):
    assume(k - loops >= 2)
    M, Jc, dq, C = _system(seed, k, 2, loops)
    assume(Jc[0] @ dq < -1e-3)
    r = ci.resolve_impact(M, Jc, dq, e=e, mu=mu, C=C)
    stick, W, v = _stick_oracle(M, Jc, dq, e, C)
    in_cone = stick[0] >= 0 and abs(stick[1]) <= mu * stick[0]
    margin = abs(abs(stick[1]) - mu * stick[0]) > 1e-9 * np.abs(stick).max()
    # restitution (eq. 21) in every regime
    assert r.v_plus[0] == pytest.approx(-e * v[0], rel=1e-9, abs=1e-12)
    # momentum balance (eqs. 29, 33, 44)
    lhs = M @ (r.dq_plus - dq)
    rhs = Jc.T @ r.impulse + (C.T @ r.loop_impulse if C is not None else 0)
    np.testing.assert_allclose(lhs, rhs, rtol=1e-9, atol=1e-11 * np.abs(lhs).max())
    if C is not None:
        np.testing.assert_allclose(C @ r.dq_plus, 0, atol=1e-10 * np.abs(C).max() * np.abs(dq).max())
    if mu == 0:
        assert r.regime == "frictionless"
        return
    assume(margin)
    if in_cone:  # Section 8, step 2
        assert r.regime == "stick"
        np.testing.assert_allclose(r.impulse, stick, rtol=1e-8, atol=1e-12)
        assert abs(r.v_plus[1]) <= 1e-9 * np.abs(v).max()
    else:  # step 3: cone boundary, tangent opposite to v_t- (eq. 55)
        assert r.regime == "slide"
        assert abs(r.impulse[1]) == pytest.approx(mu * r.impulse[0], rel=1e-12)
        assert r.impulse[1] * v[1] <= 0
    # the energy flag agrees with eq. (58) computed here
    T = lambda q: 0.5 * q @ M @ q  # noqa: E731
    gain = T(r.dq_plus) - T(dq)
    if abs(gain) > 1e-7 * T(dq):
        assert r.diagnostics.energy_gained == (gain > 0)
        assert r.energy_loss == pytest.approx(-gain, rel=1e-6)


@SETTINGS
@given(seed=st.integers(0, 2**31), k=st.integers(2, 6), e=st.floats(0, 1),
       mu=st.floats(0, 50))
def test_section8_never_jams_on_one_planar_contact(seed, k, e, mu):
    """If the sliding denominator W_nn - mu sign(v_t) W_nt is <= 0, the sticking impulse is in
    the cone (mu |W_nt| >= W_nn implies mu W_tt >= |W_nt| for SPD W), so Section 8 sticks and
    never divides by it. Random systems with large mu probe exactly that region."""
    M, Jc, dq, _ = _system(seed, k, 2)
    assume(Jc[0] @ dq < -1e-3 and abs(Jc[1] @ dq) > 1e-6)
    r = ci.resolve_impact(M, Jc, dq, e=e, mu=mu)
    stick, W, v = _stick_oracle(M, Jc, dq, e, None)
    denom = W[0, 0] - mu * np.sign(v[1]) * W[0, 1]
    if denom <= 0:
        assert r.regime == "stick"


@SETTINGS
@given(seed=st.integers(0, 2**31), k=st.integers(3, 7), e=st.floats(0, 1), mu=st.floats(0, 3))
def test_spatial_stick_or_clear_refusal(seed, k, e, mu):
    M, Jc, dq, _ = _system(seed, k, 3)
    assume(Jc[0] @ dq < -1e-3)
    stick, W, v = _stick_oracle(M, Jc, dq, e, None)
    in_cone = stick[0] >= 0 and np.linalg.norm(stick[1:]) <= mu * stick[0]
    assume(abs(np.linalg.norm(stick[1:]) - mu * stick[0]) > 1e-9 * np.abs(stick).max())
    if mu == 0 or in_cone:
        r = ci.resolve_impact(M, Jc, dq, e=e, mu=mu, method="closed-form")
        assert r.regime == ("frictionless" if mu == 0 else "stick")
        assert r.v_plus[0] == pytest.approx(-e * v[0], rel=1e-9, abs=1e-12)
        if mu > 0:
            np.testing.assert_allclose(r.v_plus[1:], 0, atol=1e-9 * np.abs(v).max())
    else:
        with pytest.raises(ci.NotSupportedError):
            ci.resolve_impact(M, Jc, dq, e=e, mu=mu, method="closed-form")


@pytest.mark.parametrize("log_cond", [4, 8, 11])
def test_ill_conditioned_mass_matrix(log_cond):
    rng = np.random.default_rng(3)
    Q, _ = np.linalg.qr(rng.normal(size=(5, 5)))
    M = Q @ np.diag(np.logspace(0, log_cond, 5)) @ Q.T
    M = 0.5 * (M + M.T)
    Jc = rng.normal(size=(2, 5))
    dq = rng.normal(size=5)
    if Jc[0] @ dq > 0:
        Jc[0] *= -1
    r = ci.resolve_impact(M, Jc, dq, e=0.5, mu=0.4)
    assert np.all(np.isfinite(r.dq_plus))
    assert r.diagnostics.mass_condition == pytest.approx(10.0**log_cond, rel=1e-2)
    assert r.diagnostics.restitution_residual < 1e-12 * 10**log_cond
    assert r.diagnostics.momentum_residual < 1e-14 * 10**log_cond
