"""Exact impulse derivatives at several simultaneous contacts (``several_impulse_derivative``):
the cone laws ccp, coulomb and dissipative, the closed forms shared with pereira-nikravesh and
chatterjee-ruina, redundant contacts and bad input (P-N's and Chatterjee-Ruina's own modes:
test_derivatives_several_pn.py; the problems and checks: several_derivative_problems.py).

Oracles, each independent of the code under test:

* central finite differences of the impulse of the PUBLIC path (``build_problem`` +
  ``solve_problem`` at tol = 1e-12) along perturbations of dq, Jc, M, e, mu (and e_t), the
  contract's W-derivative contracted with the symmetric ``dW`` those induce
  (``dW = dJ G J^T + J G dJ^T``, ``-J G dM G J^T``). Step: the solvers answer to about 1e-12
  relative, the data are of order one and W's condition number below ~10, so the central
  difference's truncation (h^2 ~ 1e-10) and noise (1e-12 / h ~ 1e-7) both stay below the
  asserted 2e-6 with h = 1e-5;
* closed forms derived by hand: two independent frictionless contacts (W diagonal:
  ``pi_n,i = -(1 + e_i) v_i / W_ii``) and a frictionless coupled pair that both press
  (``pi_n = -(1 + e) W^-1 v_n``, so ``d pi / d v = -(1 + e) W^-1``, ``d pi = -W^-1 dW pi``);
* at a mode boundary the one-sided differences (forward and backward) match the derivative
  and its ``other_side`` (one each).

Problems with a prescribed mode are constructed, not drawn and filtered
(several_derivative_problems.py).
"""

import numpy as np
import pytest

from convimpact.errors import NotSupportedError, ParameterError
from convimpact.impact.laws import law_module
from convimpact.impact.problem.build import build_problem
from convimpact.impact.resolve import solve_problem

from .several_derivative_problems import (CONE_LAWS, H, RTOL, check_fd, construct, flat_box,
                                          mode_lists, one_sided_pair, predicted, solve, split)


@pytest.mark.parametrize("law", CONE_LAWS)
@pytest.mark.parametrize("d", [2, 3])
def test_cone_laws_mixed_modes_match_finite_differences(law, d):
    rng = np.random.default_rng(100 + 10 * d + CONE_LAWS.index(law))
    for modes in mode_lists(d):
        M, Jl, dq, e, mu, pi = construct(rng, law, modes, d)
        P, R = solve(M, Jl, dq, e, mu, law)
        assert np.max(np.abs(R.impulse.ravel() - pi)) <= 1e-9  # the constructed answer
        D = law_module(law).several_impulse_derivative(P, R)
        names = {"sep": "separating", "stick": "stick", "slide": "slide"}
        assert D.regimes == tuple(names[m] for m in modes)
        assert D.one_sided == () and D.other_side is None
        assert law_module(law).several_impulse_derivative(P, R, other_side=True).other_side \
            is None  # no boundary: no other side
        errors = check_fd(rng, law, M, Jl, dq, e, mu, D, 1e-3 * np.max(np.abs(pi)))
        assert max(errors.values()) <= RTOL, (modes, errors)


@pytest.mark.parametrize("law", CONE_LAWS)
def test_cone_laws_derivative_is_the_same_from_every_method(law):
    """The derivative depends on the law's answer and mode, not on the method: from the
    answers of the conic paths (KKT-polished) it equals the interior point's."""
    rng = np.random.default_rng(110 + CONE_LAWS.index(law))
    M, Jl, dq, e, mu, _ = construct(rng, law, ["stick", "slide", "sep", "slide"], 3)
    P = build_problem(M, Jl, dq, e, mu)
    ref = law_module(law).several_impulse_derivative(P, solve_problem(P, law,
                                                                      method="interior"))
    for method in ("clarabel", "cvxpy"):
        D = law_module(law).several_impulse_derivative(P, solve_problem(P, law, method=method))
        assert D.regimes == ref.regimes
        for name in ("W", "v", "e", "mu"):
            a, b = getattr(D, name), getattr(ref, name)
            assert np.max(np.abs(a - b)) <= 1e-7 * max(np.max(np.abs(b)), 1.0), (method, name)


ALL_LAWS = ("pereira-nikravesh", "ccp", "coulomb", "dissipative")


@pytest.mark.parametrize("law", ALL_LAWS + ("chatterjee-ruina",))
def test_two_independent_frictionless_contacts_closed_form(law):
    """Two particles (masses 2 and 5) falling on the ground, mu = 0: W = diag(1/m), and
    pi_n,i = -(1 + e_i) v_i / W_ii, so d pi_n,i / d v_n,i = -(1 + e_i) / W_ii,
    d / d e_i = -v_i / W_ii, d / d W_ii = (1 + e_i) v_i / W_ii^2 (dissipative: the same, its
    plastic impulse being -v_i / W_ii)."""
    m = np.array([2.0, 5.0])
    M = np.diag([m[0], m[0], m[1], m[1]])
    Jl = [np.array([[0.0, 1, 0, 0], [1, 0, 0, 0]]), np.array([[0.0, 0, 0, 1], [0, 0, 1, 0]])]
    dq = np.array([0.0, -1.5, 0.0, -0.7])
    e = np.array([0.3, 0.8])
    P, R = solve(M, Jl, dq, e, 0.0, law, e_t=0.0 if law == "chatterjee-ruina" else None)
    D = law_module(law).several_impulse_derivative(P, R)
    w, vn = 1.0 / m, dq[[1, 3]]
    for i in range(2):
        r = 2 * i
        assert D.v[r, r] == pytest.approx(-(1 + e[i]) / w[i], rel=1e-12)
        assert D.e[r, i] == pytest.approx(-vn[i] / w[i], rel=1e-12)
        assert D.W[r, r, r] == pytest.approx((1 + e[i]) * vn[i] / w[i] ** 2, rel=1e-12)
        assert D.v[r, 2 - r] == 0.0 and D.e[r, 1 - i] == 0.0
    assert np.all(D.v[1::2] == 0.0) and np.all(D.W[1::2] == 0.0)  # no tangential impulse


@pytest.mark.parametrize("law", ALL_LAWS)
def test_frictionless_coupled_pair_closed_form(law):
    """A uniform bar (mass 3, length 2, I = m L^2 / 12) falls nearly flat on both ends, mu = 0:
    W_nn = [[1/m + 3/m, 1/m - 3/m], ...] couples the ends and both press, so
    pi_n = -(1 + e) W_nn^-1 v_n: d pi_n / d v_n = -(1 + e) W_nn^-1 and d pi_n = -W_nn^-1 dW pi_n;
    d pi_n / d e_i = -W_nn^-1[:, i] v_n,i (dissipative: pi_i = (1 + e) pi_p,i, so
    d pi_n,i / d e_i = pi_p,i = -(W_nn^-1 v_n)_i and zero across contacts)."""
    m, L = 3.0, 2.0
    M = np.diag([m, m, m * L * L / 12])
    Jl = [np.array([[0.0, 1, -L / 2], [1, 0, 0]]), np.array([[0.0, 1, L / 2], [1, 0, 0]])]
    dq = np.array([0.2, -1.0, 0.1])
    e = 0.6
    P, R = solve(M, Jl, dq, e, 0.0, law)
    D = law_module(law).several_impulse_derivative(P, R)
    Wn = np.array([[4.0, -2.0], [-2.0, 4.0]]) / m
    vn = np.array([dq[1] - L / 2 * dq[2], dq[1] + L / 2 * dq[2]])
    Winv = np.linalg.inv(Wn)
    pn = -(1 + e) * Winv @ vn
    assert np.all(pn > 0) and np.allclose(R.impulse[:, 0], pn, rtol=1e-9)
    nr = [0, 2]
    assert np.allclose(D.v[np.ix_(nr, nr)], -(1 + e) * Winv, rtol=1e-10, atol=1e-12)
    dW = np.array([[0.3, -0.1], [-0.1, 0.7]])
    full = np.zeros((4, 4))
    full[np.ix_(nr, nr)] = dW
    assert np.allclose(np.einsum("aij,ij->a", D.W, full)[nr], -Winv @ dW @ pn, rtol=1e-10)
    if law == "dissipative":
        expected = np.diag(-Winv @ vn)
    else:
        expected = -Winv * vn[None, :]
    assert np.allclose(D.e[nr], expected, rtol=1e-10, atol=1e-12)


@pytest.mark.parametrize("law", CONE_LAWS)
@pytest.mark.parametrize("boundary", ["touch", "limit"])
def test_cone_laws_at_a_mode_boundary_are_one_sided(law, boundary):
    """A contact about to separate (pi = 0 with u on the dual cone's boundary), or at the stick
    limit (pi on the cone's boundary, no slip): the derivative is one-sided, stated, and the
    other side is the neighbouring mode's; each matches one of the one-sided differences."""
    rng = np.random.default_rng(50 + (boundary == "limit") + 2 * CONE_LAWS.index(law))
    modes = ["stick", "slide", boundary]
    M, Jl, dq, e, mu, _ = construct(rng, law, modes, 3)
    P, R = solve(M, Jl, dq, e, mu, law)
    D = law_module(law).several_impulse_derivative(P, R, other_side=True)
    assert len(D.one_sided) == 1 and "contact 2" in D.one_sided[0]
    assert D.other_side is not None and D.other_side.regimes[:2] == D.regimes[:2]
    assert {D.regimes[2], D.other_side.regimes[2]} == (
        {"separating", "slide"} if boundary == "touch" else {"stick", "slide"})
    assert law_module(law).several_impulse_derivative(P, R).other_side is None
    for _ in range(3):
        direction = rng.standard_normal(dq.size)
        fwd, bwd, one, two = one_sided_pair(law, M, Jl, dq, e, mu, D, direction)
        scale = max(np.max(np.abs(one)), np.max(np.abs(two)))
        tol = 1e-4 * scale
        straight = max(np.max(np.abs(fwd - one)), np.max(np.abs(bwd - two)))
        crossed = max(np.max(np.abs(fwd - two)), np.max(np.abs(bwd - one)))
        assert min(straight, crossed) <= tol
        assert np.max(np.abs(one - two)) > 1e2 * tol  # the two sides differ


def test_redundant_contacts_cone_laws():
    """The same box: sticking, the engine's impulse is one of many (its velocity is unique):
    NotSupportedError says so; sliding, the slide equations fix the impulse (two normal
    impulses for the vertical and rotational motion) and the derivative matches."""
    rng = np.random.default_rng(61)
    M, Jl, dq, e, mu = flat_box(0.1, 0.8)
    P, R = solve(M, Jl, dq, e, mu, "ccp")
    assert R.regime == ("stick", "stick")
    with pytest.raises(NotSupportedError, match="non-unique"):
        law_module("ccp").several_impulse_derivative(P, R)
    M, Jl, dq, e, mu = flat_box(3.0, 0.3)
    P, R = solve(M, Jl, dq, e, mu, "ccp")
    assert R.regime == ("slide", "slide")
    D = law_module("ccp").several_impulse_derivative(P, R)
    errors = check_fd(rng, "ccp", M, Jl, dq, e, mu, D, 1e-3 * np.max(np.abs(R.impulse)))
    assert max(errors.values()) <= RTOL, errors


@pytest.mark.parametrize("law", CONE_LAWS)
def test_redundant_contacts_velocity_derivative(law):
    """The sticking box under the cone laws with ``redundant="velocity"``: the impulse
    derivative given is one of many, but the velocities' derivatives it implies,
    ``d v+ = dv + dW pi + W dpi`` and ``d theta_dot+ = d dq + d(G Jc^T) pi + G Jc^T dpi``, match
    central differences of the public result's v_plus and dq_plus (unique although the impulse
    is not) along perturbations that keep the contacts redundant: dq, e, M, and the box's
    geometry (its half-width and height)."""
    rng = np.random.default_rng(62)
    M, Jl, dq, e, mu = flat_box(0.1, 0.8)
    P, R = solve(M, Jl, dq, e, mu, law)
    assert R.regime == ("stick", "stick")
    D = law_module(law).several_impulse_derivative(P, R, redundant="velocity")
    assert any("minimum-norm" in s for s in D.one_sided)
    J = np.vstack(Jl)
    G = np.linalg.inv(M)
    pi = R.impulse.ravel()
    dJ = np.zeros_like(J)
    dJ[0, 2], dJ[2, 2], dJ[1, 2], dJ[3, 2] = -0.7, 0.7, 0.4, 0.4  # da = 0.7, dh = 0.4
    A = rng.standard_normal((3, 3))
    dM = A + A.T
    ddq = rng.standard_normal(3)
    zero = np.zeros(2)
    cases = (  # (arguments at step s, dJ, dM, ddq, de)
        (lambda s: (M, split(J + s * dJ, 2, 2), dq, e, mu), dJ, 0 * dM, 0 * ddq, zero),
        (lambda s: (M + s * dM, Jl, dq, e, mu), 0 * dJ, dM, 0 * ddq, zero),
        (lambda s: (M, Jl, dq + s * ddq, e, mu), 0 * dJ, 0 * dM, ddq, zero),
        (lambda s: (M, Jl, dq, e + s, mu), 0 * dJ, 0 * dM, 0 * ddq, np.ones(2)))
    for at, dJc, dMc, dqc, dec in cases:
        hi, lo = solve(*at(H), law)[1], solve(*at(-H), law)[1]
        dG = -G @ dMc @ G
        dW = dJc @ G @ J.T + J @ G @ dJc.T + J @ dG @ J.T
        dv = dJc @ dq + J @ dqc
        dpi = predicted(D, dW, dv, dec)
        fd_vplus = (hi.v_plus.ravel() - lo.v_plus.ravel()) / (2 * H)
        assert np.max(np.abs(fd_vplus - (dv + dW @ pi + P.delassus @ dpi))) <= \
            RTOL * max(np.max(np.abs(fd_vplus)), 1.0)
        fd_dq = (hi.dq_plus - lo.dq_plus) / (2 * H)
        pred = dqc + (dG @ J.T + G @ dJc.T) @ pi + G @ J.T @ dpi
        assert np.max(np.abs(fd_dq - pred)) <= RTOL * max(np.max(np.abs(fd_dq)), 1.0)


def test_bad_input_is_refused():
    M, Jl, dq, e, mu = flat_box(3.0, 0.3)
    P, R = solve(M, Jl, dq, e, mu, "ccp")
    with pytest.raises(ParameterError, match="law 'ccp'"):
        law_module("coulomb").several_impulse_derivative(P, R)
    for law in ("ccp", "pereira-nikravesh"):
        with pytest.raises(ParameterError, match="redundant"):
            law_module(law).several_impulse_derivative(P, R, redundant="min-norm")
    P1 = build_problem(M, Jl[0], dq, e, mu)
    R1 = solve_problem(P1, "pereira-nikravesh")
    with pytest.raises(NotSupportedError, match="one contact"):
        law_module("pereira-nikravesh").several_impulse_derivative(P1, R1)
