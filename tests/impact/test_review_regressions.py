"""Regressions from the adversarial review: each case once gave a wrong answer or an untyped
error; the expected behaviour is derived by hand in each test."""

import numpy as np
import pytest

import convimpact as ci
from convimpact.impact.exact.dispatch import solve_contact


def test_unbounded_program_raises_instead_of_returning_a_huge_iterate():
    # two contacts whose cones admit an impulse direction that lowers 1/2 pi.W.pi + pi.b
    # without bound (W singular along it): no finite answer exists for ccp/coulomb
    J = [np.array([[-.2, .5], [.1, -1.2]]), np.array([[.6, .2], [.9, 1.1]])]
    for law in ("ccp", "coulomb"):
        for method in ("cvxpy", "clarabel"):
            with pytest.raises(ci.SolverError):
                ci.resolve_impact(np.eye(2), J, [-1.3, -.8], e=[.3, .9], mu=.5, law=law,
                                  method=method)


def test_non_approaching_contact_is_not_kicked():
    # two independent particles (W block diagonal): B moves away from its surface
    # (v_n = +0.1) while sliding; alone it takes no impulse, so together neither
    M = np.eye(4)
    JA = np.array([[0, 1, 0, 0], [1, 0, 0, 0.]])
    JB = np.array([[0, 0, 0, 1], [0, 0, 1, 0.]])
    dq = [0, -1, 1, 0.1]
    for law in ci.LAWS[1:]:
        r = ci.resolve_impact(M, [JA, JB], dq, e=.5, mu=.5, law=law)
        np.testing.assert_allclose(r.impulse[1], 0.0, atol=1e-12)
        alone = ci.resolve_impact(M, JA, dq, e=.5, mu=.5, law=law)
        np.testing.assert_allclose(r.impulse[0], alone.impulse, rtol=1e-8, atol=1e-12)


def test_dissipative_poisson_scaling_penetration_is_flagged():
    # contact 2 separates (v_n = +4) but the (1 + e)-scaled impulse of contact 1 drives it
    # to v_n+ = -0.5: the law (Poisson scaling) does this by definition; it must say so
    J = [np.array([[0, 0, 0, 1], [-1, 1, 2, 0]]), np.array([[1, -3, -1, 0], [1, 0, 0, 0]])]
    r = ci.resolve_impact(np.eye(4), J, [0, -1, -1, -1], e=.5, mu=.5, law="dissipative")
    assert r.v_plus[1, 0] < 0
    assert r.diagnostics.penetration and not r.diagnostics.held()["no_penetration"]
    for law in ("ccp", "coulomb"):
        r = ci.resolve_impact(np.eye(4), J, [0, -1, -1, -1], e=.5, mu=.5, law=law)
        assert not r.diagnostics.penetration


def test_nearly_dependent_loop_rows_give_a_typed_error():
    Jc = np.array([[0, 0, 1., 0], [0, 0, 0, 1.]])
    for eps in (2e-9, 3e-8):
        C = np.array([[1., 1, 0, 0], [1, 1 + eps, 0, 0]])
        with pytest.raises(ci.LoopConstraintError):
            ci.resolve_impact(np.eye(4), Jc, [0, 0, -1., 1], e=.5, mu=.3, C=C)


def test_nested_list_is_one_contact():
    r = ci.resolve_impact([[2, 0], [0, 2]], [[0, 1], [1, 0]], [1, -1], e=.5, mu=.3)
    assert r.regime == "slide" and r.impulse.shape == (2,)
    # hand: W = I/2, v = (-1, 1): slide, pi_n = 1.5 / 0.5 = 3, pi_t = -0.9
    np.testing.assert_allclose(r.impulse, [3.0, -0.9], rtol=1e-12)
    r = ci.resolve_impact(np.eye(2), [np.array([[0, 1], [1, 0.]])], [1, -1], e=.5)
    assert r.regime == ("frictionless",)


def test_coulomb_with_a_huge_mu_sticks_on_every_path():
    rng = np.random.default_rng(0)
    A = rng.normal(size=(4, 4))
    M = A @ A.T + np.eye(4)
    Jc = rng.normal(size=(3, 4))
    dq = rng.normal(size=4)
    if Jc[0] @ dq > 0:
        Jc[0] *= -1
    # the sticking answer does not depend on mu: the stick solve of eq. (42) in space
    W = Jc @ np.linalg.inv(M) @ Jc.T
    v = Jc @ dq
    stick = np.linalg.solve(W, -np.r_[1.5 * v[0], v[1:]])
    for method in ("fast", "clarabel", "cvxpy"):
        r = ci.resolve_impact(M, Jc, dq, e=.5, mu=1e8, law="coulomb", method=method)
        assert r.regime == "stick"
        np.testing.assert_allclose(r.impulse, stick, rtol=1e-7)


def test_energy_helpers_give_typed_errors():
    with pytest.raises(ci.SingularSystemError):
        ci.central_energy_loss(np.eye(2), [0, 0], [1, 1], .5)
    with pytest.raises(ci.SingularSystemError):
        ci.stiction_interval(np.eye(2), [[0, 1], [0, 0]], [1, -1], mu=.3)
    with pytest.raises(ci.NonFiniteError):
        ci.oblique_energy_loss(np.eye(2), [0, 1], [1, 0], [1, -1], 1.0, np.nan)
    with pytest.raises(ci.ParameterError):
        ci.stiction_interval(np.eye(2), [[0, 1], [1, 0]], [1, -1], mu=-.3)


def test_overflowing_impact_is_a_typed_error():
    with pytest.raises(ci.NonFiniteError, match="rescale"):
        ci.resolve_impact(np.eye(2), [[0, 1], [1, 0]], [1e200, -1e200], e=.5)


@pytest.mark.parametrize("scale", [1e-300, 1e-150, 1e150, 1e300])
def test_fast_kernel_is_scale_invariant(scale):
    # every law is homogeneous: W -> s W gives pi -> pi / s (hand: same contact velocities)
    for d in (2, 3):
        W = np.eye(d)
        W[0, 1] = W[1, 0] = 0.3
        v = np.r_[-1.0, 0.5, 0.2][:d]
        for law in ci.LAWS:
            for mu in (0.2, 5.0):
                ref = solve_contact(W, v, .5, mu, law)
                got = solve_contact(scale * W, v, .5, mu, law)
                np.testing.assert_allclose(got.impulse * scale, ref.impulse, rtol=1e-10)
                assert got.regime == ref.regime


def test_auto_falls_back_to_a_conic_path_on_a_singular_delassus():
    # the tangent row is parallel to the normal: W is singular; fast cannot invert it, the
    # conic paths answer (checked against cvxpy and against Newton's law on the normal)
    M = np.diag([1., 3.])
    J = np.array([[-1., 1], [-0.5, 0.5]])
    dq = [2., 0]
    for law in ("coulomb", "dissipative"):
        r = ci.resolve_impact(M, J, dq, e=.5, mu=.3, law=law)
        assert r.method == "clarabel"
        assert any("used clarabel" in w for w in r.diagnostics.warnings)
        ref = ci.resolve_impact(M, J, dq, e=.5, mu=.3, law=law, method="cvxpy")
        np.testing.assert_allclose(r.dq_plus, ref.dq_plus, rtol=1e-7, atol=1e-9)
    r = ci.resolve_impact(M, J, dq, e=.5, mu=.3, law="coulomb")
    assert r.v_plus[0] == pytest.approx(0.5 * 2.0, rel=1e-8)  # v_n: -2 -> +1
    # the paper's law needs W^-1 for its stick test (eq. 42): fast raises, and auto falls
    # back to the conic path like the other laws (issue 29), which slides along eq. (55)
    with pytest.raises(ci.SingularSystemError):
        ci.resolve_impact(M, J, dq, e=.5, mu=.3, method="fast")
    r = ci.resolve_impact(M, J, dq, e=.5, mu=.3)
    assert r.method == "clarabel" and r.regime == "slide"
    assert r.v_plus[0] == pytest.approx(0.5 * 2.0, rel=1e-12)  # Newton: v_n -2 -> +1


def test_single_contact_methods_refuse_several_contacts_even_when_separating():
    J = np.array([[0, 1], [1, 0.]])
    with pytest.raises(ci.NotSupportedError):
        ci.resolve_impact(np.eye(2), [J, J], [1, 1], method="fast")
    r = ci.resolve_impact(np.eye(2), J, [1, 1])
    assert r.regime == "separating" and r.method == "fast"
