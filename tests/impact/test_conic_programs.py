"""The cone QP of convimpact.impact.conic.qp and its cvxpy path, against independent solutions.

References: a brute-force angle search for one spatial contact (the cone QP minimized over
the boundary ray family by hand), scipy's SLSQP on the same objective for several contacts,
and hand-solved small programs.
"""

import numpy as np
import pytest
from hypothesis import assume, given, settings, strategies as st
from scipy.optimize import minimize, minimize_scalar

import convimpact as ci
from convimpact.impact.conic.cvxpy_backend import CvxpyBackend, psd_factor
from convimpact.impact.conic.qp import ConeQP, solve_cone_qp
from convimpact.impact.problem import build_problem

from .convex_systems import ccp_residual, delassus, newton_b, random_system


def ccp_single_reference(W, b, mu):
    """min 1/2 x.W.x + b.x over {|x_t| <= mu x_n}, one spatial contact, by hand.

    Interior: the unconstrained minimizer if it lies in the cone. Boundary: x = r g(a),
    g = (1, mu cos a, mu sin a), r = max(0, -g.b / g.W.g), value -(g.b)^2 / (2 g.W.g); the angle
    by a 4001-point grid refined by a bounded scalar search.
    """
    x = np.linalg.solve(W, -b)
    if np.linalg.norm(x[1:]) <= mu * x[0]:
        return x

    def val(a):
        a = np.atleast_1d(a)
        g = np.stack([np.ones_like(a), mu * np.cos(a), mu * np.sin(a)])
        gb = b @ g
        out = np.where(gb < 0, -(gb**2) / (2 * np.einsum("ik,ij,jk->k", g, W, g)), 0.0)
        return out if out.size > 1 else float(out[0])

    grid = np.linspace(-np.pi, np.pi, 4001)
    k = int(np.argmin(val(grid)))
    h = grid[1] - grid[0]
    a = minimize_scalar(val, bounds=(grid[k] - h, grid[k] + h), method="bounded",
                        options={"xatol": 1e-14}).x
    g = np.array([1.0, mu * np.cos(a), mu * np.sin(a)])
    return max(0.0, -(g @ b) / (g @ W @ g)) * g


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), e=st.floats(0, 1), mu=st.floats(0.05, 1.5),
       loops=st.integers(0, 1))
def test_ccp_single_spatial_matches_brute_force(seed, e, mu, loops):
    M, Jc, dq, C = random_system(seed, 3, 1, loops)
    r = ci.resolve_impact(M, Jc, dq, e=e, mu=mu, C=C, law="ccp", method="cvxpy")
    W = delassus(M, Jc, C)
    b = newton_b(Jc @ dq, [e])
    ref = ccp_single_reference(W, b, mu)
    # the reference's angle is flat-bottomed (accurate to ~1e-8 in angle)
    assert np.allclose(r.impulse, ref, rtol=0, atol=1e-6 * np.abs(ref).max())
    # and the cvxpy answer itself is a KKT point to round-off
    assert ccp_residual(W, b, [mu], 3, r.impulse) < 1e-10
    assert r.diagnostics.extras["polished"]


@settings(max_examples=8, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), d=st.sampled_from([2, 3]), n=st.integers(2, 3),
       loops=st.integers(0, 1), mu=st.floats(0.1, 1.0))
def test_dissipative_multi_contact_matches_slsqp(seed, d, n, loops, mu):
    """The plastic program (min T+ over the cones) against scipy's SLSQP on the same objective
    (measured: SLSQP matches to 1e-6 or stalls higher; the conic answer is never worse)."""
    M, Jc, dq, C = random_system(seed, d, n, loops)
    W = delassus(M, Jc, C)
    v = np.concatenate([j @ dq for j in Jc])
    r = ci.resolve_impact(M, Jc, dq, e=0.0, mu=mu, C=C, law="dissipative", method="cvxpy")
    # a contact that is not approaching enters with its normal only (mu = 0 there)
    mus = [mu if v[i * d] < 0 else 0.0 for i in range(n)]
    cons = []
    for i in range(n):
        o = i * d
        cons.append({"type": "ineq",
                     "fun": lambda x, o=o, m=mus[i]: m**2 * x[o]**2 - np.sum(x[o + 1:o + d]**2)})
        cons.append({"type": "ineq", "fun": lambda x, o=o: x[o]})
    x0 = np.ravel(r.impulse) * 0.9 + 0.01
    ref = minimize(lambda x: 0.5 * x @ W @ x + v @ x, x0, jac=lambda x: W @ x + v,
                   constraints=cons, method="SLSQP", options={"ftol": 1e-14, "maxiter": 500})
    f_conic = 0.5 * np.ravel(r.impulse) @ W @ np.ravel(r.impulse) + v @ np.ravel(r.impulse)
    xs = ref.x.reshape(n, d)
    violation = max(0.0, float(np.max(np.linalg.norm(xs[:, 1:], axis=1)
                                      - np.array(mus) * xs[:, 0])))
    # SLSQP may stop early or slightly outside the cones: compare with its feasible answers
    assume(ref.success and violation <= 1e-10)
    scale = max(abs(ref.fun), 1e-12)
    # the conic optimum is at least as good as SLSQP's feasible answer (SLSQP sometimes stalls
    # at a worse point: the squared cone constraint is degenerate at the apex) ...
    assert f_conic <= ref.fun + 1e-9 * scale
    # ... and it is optimal: the KKT conditions of min 1/2 x.W.x + v.x over the cones
    assert ccp_residual(W, v, mus, d, r.impulse) < 1e-9


def test_hand_solved_frictionless_pair():
    """Two frictionless normals coupled by W_nn = [[2, 1], [1, 2]]; v_n = (-1, 1) -> only the
    first contact acts: pi_1 = 1/2 (plastic), v_n2+ = 1 + 1/2 > 0, complementarity by hand."""
    W = np.zeros((4, 4))
    W[np.ix_([0, 2], [0, 2])] = [[2.0, 1.0], [1.0, 2.0]]
    W[1, 1] = W[3, 3] = 1.0
    qp = ConeQP(W, np.array([-1.0, 0.3, 1.0, 0.0]), np.zeros(2), 2, np.zeros((0, 4)),
                   np.zeros(0))
    sol = solve_cone_qp(CvxpyBackend(), qp)
    assert np.allclose(sol.x, [0.5, 0.0, 0.0, 0.0], atol=1e-12)
    assert sol.polished and sol.kkt_residual < 1e-14


def test_psd_factor_of_singular_matrix():
    """Two coincident contacts: W = [[A, A], [A, A]] is singular; F^T F = W still holds."""
    A = np.array([[2.0, 0.3, 0.1], [0.3, 1.0, 0.2], [0.1, 0.2, 0.7]])
    W = np.block([[A, A], [A, A]])
    F = psd_factor(W - 1e-17 * np.eye(6))  # round-off may make eigenvalues negative
    assert np.allclose(F.T @ F, W, atol=1e-14)
    assert np.all(np.isfinite(F))


def test_redundant_contacts_give_the_single_contact_velocities():
    """Two identical contacts (W singular): their impulses add up to the single contact's
    (the sum of two copies of K_mu is K_mu), so dq+ is the one-contact answer."""
    M, Jc, dq, C = random_system(11, 3, 1, 0)
    for law in ("ccp", "dissipative", "coulomb"):
        one = ci.resolve_impact(M, Jc, dq, e=0.4, mu=0.5, law=law, method="clarabel")
        two = ci.resolve_impact(M, [Jc, Jc.copy()], dq, e=0.4, mu=0.5, law=law,
                                method="cvxpy")
        assert np.allclose(two.dq_plus, one.dq_plus, atol=1e-8 * np.abs(dq).max()), law
        assert np.allclose(two.impulse.sum(axis=0), one.impulse, atol=1e-7 * np.abs(
            one.impulse).max()), law


def test_dpp_program_compiled_once_per_structure():
    backend = CvxpyBackend()
    rng = np.random.default_rng(0)
    for _ in range(5):
        A = rng.normal(size=(3, 3))
        W = A @ A.T + np.eye(3)
        v = rng.normal(size=3)
        v[0] = -1.0
        qp = ConeQP(W, v, np.array([rng.uniform(0.1, 1)]), 3, np.zeros((0, 3)), np.zeros(0))
        solve_cone_qp(backend, qp)
    assert len(backend._programs) == 1
    problem = backend._programs[next(iter(backend._programs))][0]
    assert problem.is_dpp()


def test_options_are_validated():
    M, Jc, dq, C = random_system(1, 3, 1, 0)
    with pytest.raises(ci.UnknownOptionError, match="tolerance"):
        ci.resolve_impact(M, Jc, dq, e=0.5, mu=0.3, law="ccp", method="cvxpy", tolerance=1e-9)
    with pytest.raises(ci.ParameterError):
        ci.resolve_impact(M, Jc, dq, e=0.5, mu=0.3, law="ccp", method="cvxpy", tol=0.0)
    with pytest.raises(ci.ParameterError):
        ci.resolve_impact(M, Jc, dq, e=0.5, mu=0.3, law="coulomb", method="cvxpy",
                          max_fixed_point_iter=0)


def test_problem_scaling_is_invisible():
    """Scaling M by 1e6 and dq by 1e-3 scales impulses by 1e3 exactly (the solver works on
    unit-size data)."""
    M, Jc, dq, C = random_system(5, 3, 2, 1)
    a = ci.resolve_impact(M, Jc, dq, e=0.3, mu=0.4, C=C, law="ccp", method="cvxpy")
    b = ci.resolve_impact(1e6 * M, Jc, 1e-3 * dq, e=0.3, mu=0.4, C=C, law="ccp", method="cvxpy")
    assert np.allclose(b.impulse, 1e3 * a.impulse, rtol=1e-8, atol=1e-9 * np.abs(
        1e3 * a.impulse).max())


def test_build_problem_w_matches_null_space_formula():
    """Sanity of the test helper itself against problem.py (two independent formulas)."""
    M, Jc, dq, C = random_system(3, 3, 2, 1)
    P = build_problem(M, Jc, dq, 0.0, 0.0, C)
    assert np.allclose(P.delassus, delassus(M, Jc, C), atol=1e-12)
