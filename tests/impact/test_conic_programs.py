"""The cone QP of convimpact.impact.conic.qp and its cvxpy path, against independent solutions.

References: a brute-force angle search for one spatial contact (the cone QP minimized over
the boundary ray family by hand), an accelerated projected gradient (FISTA with exact
projections onto the cones) on the same objective for several contacts, and hand-solved
small programs.
"""

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st
from scipy.optimize import minimize_scalar

import convimpact as ci
from convimpact.impact.conic.cvxpy_backend import CvxpyBackend, psd_factor
from convimpact.impact.conic.qp import ConeQP, solve_cone_qp
from convimpact.impact.problem.build import build_problem

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


def project_onto_cones(x, mus, d):
    """Euclidean projection onto the product of the cones K_mu = {|x_t| <= mu x_n} (mu = 0:
    the half-line x_n >= 0, x_t = 0), in closed form: x itself inside; 0 in the polar cone
    (mu |x_t| <= -x_n); else onto the boundary ray through x_t, r (1, mu x_t / |x_t|) with
    r = (x_n + mu |x_t|) / (1 + mu^2)."""
    y = np.asarray(x, dtype=float).reshape(-1, d)
    mus = np.asarray(mus, dtype=float)
    xn, a = y[:, 0], np.linalg.norm(y[:, 1:], axis=1)
    r = (xn + mus * a) / (1.0 + mus * mus)
    ray = np.concatenate([r[:, None], y[:, 1:] * np.where(
        a > 0, mus * r / np.where(a > 0, a, 1.0), 0.0)[:, None]], axis=1)
    out = np.where((a <= mus * xn)[:, None], y, ray)
    out = np.where(((mus * a <= -xn) & ~(a <= mus * xn))[:, None], 0.0, out)
    return out.ravel()


def accelerated_projected_gradient(W, v, mus, d, rtol=1e-12, max_iter=20000):
    """min 1/2 x.W.x + v.x over the cones by FISTA with gradient restart (O'Donoghue and
    Candes 2015), step 1 / lambda_max(W); stops when the natural residual
    lambda_max |x - P(x - (W x + v) / lambda_max)| is below rtol max |v|. Every iterate is
    feasible (a projection), so its objective is an upper bound of the optimum."""
    L = float(np.linalg.eigvalsh(W)[-1])
    x = np.zeros_like(v)
    y = x.copy()
    t = 1.0
    for k in range(max_iter):
        x_new = project_onto_cones(y - (W @ y + v) / L, mus, d)
        if (y - x_new) @ (x_new - x) > 0.0:  # the momentum points uphill: restart
            t = 1.0
        t_new = 0.5 * (1.0 + np.sqrt(1.0 + 4.0 * t * t))
        y = x_new + (t - 1.0) / t_new * (x_new - x)
        x, t = x_new, t_new
        if k % 20 == 0:
            natural = L * np.max(np.abs(x - project_onto_cones(x - (W @ x + v) / L, mus, d)))
            if natural <= rtol * np.max(np.abs(v)):
                return x
    raise AssertionError("the projected-gradient reference did not converge")


def test_projection_onto_the_cone_by_hand():
    """mu = 0.5: (1, 0.2) is inside; (-1, 0.1) is in the polar cone (0.05 <= 1) -> 0;
    (0, 1) -> r (1, 0.5), r = (0 + 0.5) / 1.25 = 0.4; a frictionless (-2, 3) -> (0, 0)."""
    got = project_onto_cones([1, 0.2, -1, 0.1, 0, 1, -2, 3], [0.5, 0.5, 0.5, 0.0], 2)
    np.testing.assert_allclose(got, [1, 0.2, 0, 0, 0.4, 0.2, 0, 0], atol=1e-15)


@pytest.mark.parametrize("d,n,loops", [(d, n, lo) for d in (2, 3) for n in (2, 3)
                                       for lo in (0, 1)])
@settings(max_examples=2, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), mu=st.floats(0.1, 1.0), e=st.floats(0.0, 1.0))
def test_dissipative_multi_contact_matches_accelerated_projected_gradient(d, n, loops, seed,
                                                                          mu, e):
    """The plastic program (min T+ over the cones) against an independent method: FISTA with
    exact projections onto the cones. Every draw is a valid impact (random_system makes
    contact 0 approaching; W is positive definite), so nothing is filtered; the (d, n, loops)
    combinations are enumerated, not drawn. The reference's iterates are feasible, so the
    conic optimum can be no worse; both minimize a strictly convex function, so the impulses
    agree. (This replaces a comparison with SLSQP, which stalls at the cone's apex and had
    to discard most draws.)"""
    M, Jc, dq, C = random_system(seed, d, n, loops)
    W = delassus(M, Jc, C)
    v = np.concatenate([j @ dq for j in Jc])
    r = ci.resolve_impact(M, Jc, dq, e=e, mu=mu, C=C, law="dissipative", method="cvxpy")
    plastic = np.ravel(r.impulse) / (1.0 + e)  # Poisson's scaling of the plastic impulse
    # a contact that is not approaching enters with its normal only (mu = 0 there)
    mus = [mu if v[i * d] < 0 else 0.0 for i in range(n)]
    ref = accelerated_projected_gradient(W, v, mus, d)

    def objective(x):
        return 0.5 * x @ W @ x + v @ x

    scale = max(abs(objective(ref)), 1e-300)
    assert objective(plastic) <= objective(ref) + 1e-10 * scale
    assert np.max(np.abs(plastic - ref)) <= 1e-7 * np.max(np.abs(ref))
    assert np.max(np.abs(W @ (plastic - ref))) <= 1e-9 * np.max(np.abs(v))
    # and the conic answer is a KKT point of min 1/2 x.W.x + v.x over the cones
    assert ccp_residual(W, v, mus, d, plastic) < 1e-9


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
