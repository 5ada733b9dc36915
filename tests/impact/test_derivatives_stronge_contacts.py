"""Law "stronge" at several contacts: the derivative (several_impulse_derivative) against
central differences of the public law -- independent contacts, one approaching contact among
coupled ones, coupled contacts in the two-phase formulation -- and the cases it refuses."""

from __future__ import annotations

import numpy as np
import pytest

from convimpact.errors import NotSupportedError
from convimpact.impact.laws.stronge import impulse_derivative, several_impulse_derivative
from convimpact.impact.problem.build import build_problem
from convimpact.impact.resolve import solve_problem

from .test_derivatives_stronge import H, W2, central, derivative

def _two_contacts(dq, coupling=0.0):
    from scipy.linalg import block_diag
    M = np.linalg.inv(block_diag(np.array(W2), np.array([[1.5, -0.3], [-0.3, 0.8]])))
    J = np.zeros((2, 2, 4))
    J[0, :, :2] = np.eye(2)
    J[1, :, 2:] = np.eye(2)
    J[0, 0, 2] = coupling
    return M, J, np.asarray(dq, dtype=float)


def test_independent_contacts_block_by_block():
    M, J, dq = _two_contacts([-1.0, 0.2, -0.5, 0.3])
    e, mu = np.array([0.5, 0.3]), np.array([0.8, 0.4])
    P = build_problem(M, J, dq, e, mu)
    D = several_impulse_derivative(P, solve_problem(P, "stronge"))
    assert D.W.shape == (4, 4, 4) and D.v.shape == (4, 4) and D.e.shape == (4, 2)
    assert D.regimes == ("slip-stick", "slip")
    assert any("off-diagonal blocks" in t for t in D.one_sided)
    for i, (Wi, vi) in enumerate(((W2, [-1.0, 0.2]), ([[1.5, -0.3], [-0.3, 0.8]],
                                                       [-0.5, 0.3]))):
        sl = slice(2 * i, 2 * i + 2)
        one, _ = derivative(Wi, vi, e[i], mu[i])
        np.testing.assert_allclose(D.v[sl, sl], central(Wi, vi, e[i], mu[i], ("v", 0))[:, None]
                                   * [1, 0] + central(Wi, vi, e[i], mu[i], ("v", 1))[:, None]
                                   * [0, 1], rtol=1e-8, atol=1e-12)
        np.testing.assert_allclose(D.mu[sl, i], central(Wi, vi, e[i], mu[i], "mu"),
                                   rtol=1e-8, atol=1e-12)
        assert np.all(D.v[sl, 2 - 2 * i:4 - 2 * i] == 0.0)


J6 = np.zeros((2, 3, 6))
J6[0] = [[1.0, 0, 0.3, 0, 0, 0.1], [0, 1.0, 0, 0, 0.2, 0], [0, 0, 0, 1.0, 0, 0]]
J6[1] = [[0.2, 0, 1.0, 0, 0, 0], [0, 0, 0, 0, 1.0, 0], [0, 0.1, 0, 0, 0, 1.0]]


def _coupled(v, e, mu):
    return build_problem(np.eye(6), J6, np.linalg.solve(J6.reshape(6, 6), v), e, mu)


@pytest.mark.parametrize("v, mu, regimes", [
    ([-1.0, 0.2, 0.1, -0.5, 0.3, -0.1], 0.4, ("stick", "slide")),
    ([-1.0, 0.5, 0.1, -0.5, 0.3, -0.4], 0.2, ("slide", "slide")),
])
def test_coupled_contacts_two_phase_formulation(v, mu, regimes):
    """Two coupled spatial contacts (compression by Coulomb's plastic program, expansion by
    Poisson's normals and maximal dissipation): against central differences of the public
    law in v- (dq = Jc^-1 (v- + t e_k)), in W (the problem rebuilt with W + t (E_ij + E_ji):
    the law reads W and v- only), in e and mu per contact."""
    import dataclasses
    v = np.array(v)
    e = 0.5
    P = _coupled(v, e, mu)
    r = solve_problem(P, "stronge")
    assert r.diagnostics.extras["formulation"].startswith("compression then expansion")
    D = several_impulse_derivative(P, r)
    assert D.regimes == regimes and D.W.shape == (6, 6, 6) and D.e.shape == (6, 2)
    h = 1e-4

    def cd(f):
        return (-f(2 * h) + 8 * f(h) - 8 * f(-h) + f(-2 * h)) / (12 * h)

    def with_v(k):
        return lambda t: solve_problem(_coupled(v + t * np.eye(6)[k], e, mu),
                                       "stronge").impulse.ravel()

    def with_W(i, j):
        def f(t):
            E = np.zeros((6, 6))
            E[i, j] += t
            E[j, i] += t if i != j else 0.0
            return solve_problem(dataclasses.replace(P, delassus=P.delassus + E),
                                 "stronge").impulse.ravel()
        return f

    def with_c(name, i):
        def f(t):
            val = {"e": [e, e], "mu": [mu, mu]}
            val[name][i] += t
            return solve_problem(_coupled(v, *val.values()), "stronge").impulse.ravel()
        return f

    scale = np.max(np.abs(D.v))
    for k in range(6):
        np.testing.assert_allclose(D.v[:, k], cd(with_v(k)), atol=1e-7 * scale)
    for i, j in ((0, 0), (0, 3), (1, 4), (2, 5), (4, 4)):
        np.testing.assert_allclose(D.W[:, i, j] + (D.W[:, j, i] if i != j else 0),
                                   cd(with_W(i, j)), atol=1e-7 * scale)
    for i in range(2):
        np.testing.assert_allclose(D.e[:, i], cd(with_c("e", i)), atol=1e-7 * scale)
        np.testing.assert_allclose(D.mu[:, i], cd(with_c("mu", i)), atol=1e-7 * scale)


def test_coupled_contacts_scaled_or_recompressed_expansion_is_not_supported():
    """The law scales the expansion down (kappa < 1) where different e per coupled contact
    would gain energy, and compresses again where the expansion drives a contact into
    approach: no derivative is given for those (the guard, on a result whose record says
    so), nor by the one-contact entry for several contacts."""
    import dataclasses
    from types import MappingProxyType
    P = _coupled(np.array([-1.0, 0.2, 0.1, -0.5, 0.3, -0.1]), 0.5, 0.4)
    r = solve_problem(P, "stronge")
    extras = dict(r.diagnostics.extras)
    scaled = dataclasses.replace(r, diagnostics=dataclasses.replace(
        r.diagnostics, extras=MappingProxyType({**extras, "expansion_scale": 0.9})))
    with pytest.raises(NotSupportedError, match="kappa"):
        several_impulse_derivative(P, scaled)
    contacts = [dict(c) for c in extras["contacts"]]
    contacts[1]["recompression_impulse"] = [0.1, 0.0, 0.0]
    again = dataclasses.replace(r, diagnostics=dataclasses.replace(
        r.diagnostics, extras=MappingProxyType({**extras, "contacts": contacts})))
    with pytest.raises(NotSupportedError, match="second plastic compression"):
        several_impulse_derivative(P, again)
    with pytest.raises(NotSupportedError, match="several_impulse_derivative"):
        impulse_derivative(P, r)


def test_one_approaching_contact_among_coupled_ones():
    """Coupled contacts of which one approaches and its exact impulse lifts the other: the
    derivative is that contact's; checked in v- against central differences of the public
    law (dq = Jc^-1 (v- + t e_k), W unchanged)."""
    J = np.zeros((2, 2, 4))
    J[0] = [[1.0, 0.0, 0.3, 0.0], [0.0, 1.0, 0.0, 0.0]]
    J[1] = [[0.2, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]]
    rows = J.reshape(4, 4)
    v = np.array([-1.0, 0.2, 0.5, 0.3])

    def pi(t, k):
        dv = np.zeros(4)
        dv[k] = t
        P = build_problem(np.eye(4), J, np.linalg.solve(rows, v + dv), 0.5, 0.4)
        return solve_problem(P, "stronge").impulse.ravel()

    P = build_problem(np.eye(4), J, np.linalg.solve(rows, v), 0.5, 0.4)
    r = solve_problem(P, "stronge")
    assert r.diagnostics.extras["formulation"].startswith("one approaching contact")
    D = several_impulse_derivative(P, r)
    assert D.regimes == ("slip-stick", "separating") and D.one_sided == ()
    for k in range(4):
        fd = (-pi(2 * H, k) + 8 * pi(H, k) - 8 * pi(-H, k) + pi(-2 * H, k)) / (12 * H)
        np.testing.assert_allclose(D.v[:, k], fd, rtol=1e-8, atol=1e-10)
