"""The chain from a law's derivative to ``result.jacobian`` (issue 27): closed forms, shapes,
conventions, the separating impact, and bad input to ``derivatives=``."""

from __future__ import annotations

import numpy as np
import pytest

import convimpact as ci
from convimpact.errors import NotSupportedError, UnknownOptionError
from convimpact.impact.laws import law_module

from .derivative_checks import scene


@pytest.mark.parametrize("law", ["pereira-nikravesh", "coulomb", "ccp", "dissipative"])
@pytest.mark.parametrize("d", [2, 3])
def test_frictionless_newton_impact_closed_form(law, d):
    """mu = 0: d dq+/d dq- = I - (1 + e) M^-1 Jn^T Jn / (Jn M^-1 Jn^T), and
    d dq+/d e = -M^-1 Jn^T (Jn dq-) / (Jn M^-1 Jn^T), derived by hand from
    dq+ = dq- - (1 + e) M^-1 Jn^T (Jn dq-) / (Jn M^-1 Jn^T)."""
    M, Jc, dq, _ = scene(d, seed=1)
    e = 0.7
    r = ci.resolve_impact(M, Jc, dq, e=e, mu=0.0, law=law, derivatives=True)
    Jn = Jc[0]
    Minv = np.linalg.inv(M)
    m = Jn @ Minv @ Jn
    expected = np.eye(dq.size) - (1.0 + e) * np.outer(Minv @ Jn, Jn) / m
    np.testing.assert_allclose(r.jacobian["dq"], expected, atol=1e-12)
    np.testing.assert_allclose(r.jacobian["e"], -(Minv @ Jn) * (Jn @ dq) / m, atol=1e-12)
    # the impulse: pi_n = -(1 + e) Jn dq / m, so d pi_n / d dq = -(1 + e) Jn / m
    np.testing.assert_allclose(r.impulse_jacobian["dq"][0], -(1.0 + e) * Jn / m, atol=1e-12)
    np.testing.assert_allclose(r.impulse_jacobian["dq"][1:], 0.0, atol=1e-14)


def test_particle_sliding_on_the_floor_by_hand():
    """A particle of mass m on the floor, rows (n, t) = (y, x): sliding, pi_n = -(1 + e) m v_y,
    pi_t = -mu pi_n sgn(v_x), so dx+ = dx - mu (1 + e) |v_y| sgn(v_x), dy+ = -e dy."""
    m, e, mu = 2.0, 0.5, 0.3
    M = m * np.eye(2)
    Jc = np.array([[0.0, 1.0], [1.0, 0.0]])
    r = ci.resolve_impact(M, Jc, [1.0, -1.0], e=e, mu=mu, derivatives=True)
    assert r.regime == "slide"
    np.testing.assert_allclose(r.jacobian["dq"], [[1.0, mu * (1 + e)], [0.0, -e]])
    np.testing.assert_allclose(r.jacobian["e"], [-mu * 1.0, 1.0])   # dx+ = 1 - mu (1+e)
    np.testing.assert_allclose(r.jacobian["mu"], [-(1 + e), 0.0])
    # M = [[m_x, eps], [eps, m_y]] by hand: dx+ = dx - mu (1 + e) |v_y| m_y / m_x, so
    # d/dm_x = mu (1+e) |v_y| m_y / m_x^2 = 0.225 and d/dm_y = -mu (1+e) |v_y| / m_x = -0.225;
    # the coupling eps gives W_nt = -eps / 4, D = 1/2 + 0.075 eps, pi_n = 3 (1 - 0.15 eps),
    # dx+ = 1 - 0.45 (1 - 0.15 eps) - 0.75 eps: d/d eps = -0.6825 (the pair M_xy = M_yx)
    JM = r.jacobian["M"]
    assert JM[0, 0, 0] == pytest.approx(0.225) and JM[0, 1, 1] == pytest.approx(-0.225)
    assert JM[0, 0, 1] + JM[0, 1, 0] == pytest.approx(-0.6825)
    # dy+ = -e dy whatever M
    np.testing.assert_allclose(JM[1], 0.0, atol=1e-14)


@pytest.mark.parametrize("law", ["pereira-nikravesh", "coulomb", "ccp", "dissipative",
                                 "chatterjee-ruina"])
@pytest.mark.parametrize("mu", [0.1, 3.0])
def test_homogeneity(law, mu):
    """Every law is homogeneous: dq+(a M, b dq) = b dq+(M, dq) and pi(a M) = a pi, so (Euler)
    J_dq dq = dq+, sum_ij J_M[..., i, j] M_ij = 0 and the impulse's contraction with M is pi."""
    M, Jc, dq, _ = scene(3, seed=0)
    r = ci.resolve_impact(M, Jc, dq, e=0.4, mu=mu, law=law, derivatives=True)
    np.testing.assert_allclose(r.jacobian["dq"] @ dq, r.dq_plus, atol=1e-12)
    np.testing.assert_allclose(np.einsum("aij,ij->a", r.jacobian["M"], M), 0.0, atol=1e-12)
    np.testing.assert_allclose(np.einsum("aij,ij->a", r.impulse_jacobian["M"], M), r.impulse,
                               atol=1e-12)
    # Jc scaled by c: W by c^2, v- by c, pi by 1/c, Jc^T pi and dq+ unchanged
    np.testing.assert_allclose(np.einsum("aij,ij->a", r.jacobian["Jc"], Jc), 0.0, atol=1e-12)


def test_shapes_read_only_and_the_record():
    M, Jc, dq, _ = scene(3, seed=0)
    k = dq.size
    r = ci.resolve_impact(M, Jc, dq, e=0.4, mu=0.1, derivatives=True)
    assert r.jacobian["dq"].shape == (k, k)
    assert r.jacobian["M"].shape == (k, k, k)
    assert r.jacobian["Jc"].shape == (k, 3, k)
    assert r.jacobian["e"].shape == r.jacobian["mu"].shape == (k,)
    assert r.impulse_jacobian["M"].shape == (3, k, k)
    assert r.impulse_jacobian["Jc"].shape == (3, 3, k)
    # "M" is the symmetric gradient (the derivative for symmetric perturbations)
    np.testing.assert_allclose(r.jacobian["M"], np.swapaxes(r.jacobian["M"], 1, 2))
    with pytest.raises((TypeError, ValueError)):
        r.jacobian["dq"][0, 0] = 1.0
    with pytest.raises(TypeError):
        r.jacobian["new"] = np.zeros(1)
    assert r.derivatives.modes == ("slide",) and r.derivatives.one_sided == ()
    assert r.derivatives.other_jacobian is None
    d = r.as_dict()  # plain JSON
    assert np.allclose(d["jacobian"]["dq"], r.jacobian["dq"]) and d["derivatives"]["modes"] == [
        "slide"]
    import json
    json.dumps(d)
    plain = ci.resolve_impact(M, Jc, dq, e=0.4, mu=0.1)
    assert "jacobian" not in plain.as_dict()
    assert plain.jacobian is None and plain.impulse_jacobian is None and plain.derivatives is None
    np.testing.assert_allclose(r.dq_plus, plain.dq_plus, rtol=1e-13, atol=1e-15)


@pytest.mark.parametrize("law", ["pereira-nikravesh", "coulomb", "ccp", "dissipative",
                                 "chatterjee-ruina"])
def test_a_separating_impact_has_the_identity_derivative(law):
    M, Jc, dq, _ = scene(2, seed=0, v=[0.5, -0.3])
    r = ci.resolve_impact(M, Jc, dq, e=0.4, mu=0.3, law=law, derivatives=True)
    assert r.regime == "separating"
    k = dq.size
    np.testing.assert_array_equal(r.jacobian["dq"], np.eye(k))
    for name in ("M", "Jc", "e", "mu"):
        assert not r.jacobian[name].any() and not r.impulse_jacobian[name].any()
    assert r.derivatives.one_sided == ()


def test_solve_problem_takes_derivatives_too():
    M, Jc, dq, _ = scene(2, seed=0)
    P = ci.build_problem(M, Jc, dq, e=0.4, mu=0.1)
    a = ci.solve_problem(P, "ccp", derivatives=True)
    b = ci.resolve_impact(M, Jc, dq, e=0.4, mu=0.1, law="ccp", derivatives=True)
    for name in b.jacobian:
        np.testing.assert_array_equal(a.jacobian[name], b.jacobian[name])


@pytest.mark.parametrize("bad", ["yes", "other", "", 1, 0, 1.0, None, [True], np.array(1)])
def test_bad_values_of_derivatives(bad):
    M, Jc, dq, _ = scene(2, seed=0)
    with pytest.raises(UnknownOptionError, match="derivatives"):
        ci.resolve_impact(M, Jc, dq, e=0.4, mu=0.1, derivatives=bad)
    P = ci.build_problem(M, Jc, dq, e=0.4, mu=0.1)
    with pytest.raises(UnknownOptionError, match="derivatives"):
        ci.solve_problem(P, derivatives=bad)


def test_a_law_without_a_derivative_is_named(monkeypatch):
    M, Jc, dq, _ = scene(2, seed=0)
    monkeypatch.delattr(law_module("ccp"), "impulse_derivative")
    with pytest.raises(NotSupportedError, match="'ccp'"):
        ci.resolve_impact(M, Jc, dq, e=0.4, mu=0.1, law="ccp", derivatives=True)
    monkeypatch.delattr(law_module("coulomb"), "several_impulse_derivative", raising=False)
    M, J1, dq, _ = scene(2, seed=0)
    J2 = np.roll(J1, 1, axis=1)
    with pytest.raises(NotSupportedError, match="'coulomb'"):
        ci.resolve_impact(M, [J1, J2], dq, e=0.4, mu=0.1, law="coulomb", derivatives=True)


def test_a_singular_mode_raises_a_typed_error():
    """W = [[1, 2], [2, 4]] is singular: the dissipative law's stick impulse (found by the
    conic path) is not unique, so it has no derivative -- a typed error, never NaN; the
    paper's law slides there along eq. (55), whose denominator W_nn + mu s W_nt = 2 is
    regular: dq+_x = dq_x - (1 + e) dq_x (1 + 2 mu s) / 2 = -0.5 dq_x."""
    M, Jc, dq = np.eye(2), np.array([[1.0, 0.0], [2.0, 0.0]]), [-1.0, 0.0]
    with pytest.raises(ci.SingularSystemError, match="not a differentiable"):
        ci.resolve_impact(M, Jc, dq, e=0.5, mu=0.5, law="dissipative", derivatives=True)
    r = ci.resolve_impact(M, Jc, dq, e=0.5, mu=0.5, derivatives=True)
    assert r.regime == "slide"
    np.testing.assert_allclose(r.jacobian["dq"], [[-0.5, 0.0], [0.0, 1.0]], atol=1e-12)
