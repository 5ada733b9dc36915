"""convimpact.solve_contact_problem: the contact problem ``u = W r + b`` on friction cones.

Oracles, none of them the code under test:

* closed forms derived by hand in the comments (one and two contacts: sliding, sticking,
  separating, frictionless; Coulomb against its convex relaxation, the CCP);
* a second method: the CCP is the optimality (KKT) system of ``min 1/2 r^T W r + b^T r`` over
  the product of friction cones, written here for cvxpy and solved by Clarabel;
* the laws' conditions recomputed here from the returned impulse, with this file's own
  projection onto the friction cone (itself checked by Moreau's decomposition);
* momentum balance on a box dropped flat on its four corners (W of rank 6, size 12);
* the scaling law of the problem (W -> alpha W, b -> beta b).
"""

import math

import cvxpy as cp
import numpy as np
import pytest
import scipy.sparse as sp

import convimpact as ci
from convimpact.errors import InputError, NonFiniteError, ParameterError, ShapeError

from .cone_checks import project_cone

solve = ci.solve_contact_problem


# --- this file's own cone algebra (the projection: tests/contacts/cone_checks.py) -----------


def law_y(u, mu, law):
    """y of the law: u + mu |u_t| e_n (Coulomb, De Saxce) or u (CCP)."""
    y = np.array(u, float, copy=True)
    if law == "coulomb":
        y[:, 0] += mu * np.linalg.norm(y[:, 1:], axis=1)
    return y


def my_residual(W, b, mu, r, law):
    """|r - P_K(r - y)| / max(|b|, |r|, |u|) with u = W r + b computed here."""
    n, d = r.shape
    Wd = W.toarray() if sp.issparse(W) else np.asarray(W, float)
    u = (Wd @ r.ravel() + np.ravel(b)).reshape(n, d)
    y = law_y(u, np.broadcast_to(mu, (n,)), law)
    err = np.linalg.norm(r - project_cone(r - y, mu))
    return err / max(np.linalg.norm(b), np.linalg.norm(r), np.linalg.norm(u)), u


def check_laws(W, b, mu, sol, law, tol=1e-8):
    """The law's conditions on the returned impulse, recomputed from it."""
    r = sol.impulse
    n, d = r.shape
    mu = np.broadcast_to(np.asarray(mu, float), (n,))
    Wd = W.toarray() if sp.issparse(W) else np.asarray(W, float)
    u = (Wd @ r.ravel() + np.ravel(b)).reshape(n, d)
    scale = max(np.linalg.norm(b), np.linalg.norm(r), np.linalg.norm(u))
    # the velocity returned is W r + b
    assert np.abs(sol.velocity - u).max() <= 1e-12 * scale
    y = law_y(u, mu, law)
    slack = 10 * tol * scale
    # r in K_mu, y in K_mu* = {y_n >= mu |y_t|}
    assert np.all(mu * r[:, 0] - np.linalg.norm(r[:, 1:], axis=1) >= -slack)
    assert np.all(r[:, 0] >= -slack)
    assert np.all(y[:, 0] - mu * np.linalg.norm(y[:, 1:], axis=1) >= -slack)
    # frictionless contacts: no tangential impulse
    assert np.all(np.abs(r[mu == 0.0, 1:]) <= slack)
    # complementarity, contact by contact
    assert np.all(np.abs(np.einsum("ij,ij->i", r, y)) <= 10 * tol * scale**2)
    res, _ = my_residual(W, b, mu, r, law)
    assert res <= tol
    assert sol.residual <= tol
    assert sol.status == "solved" and sol.law == law and sol.tol == tol
    return u


def test_own_projection_is_the_projection():
    """Moreau: x = P_K x + P_{K°} x with P_K x in K, x - P_K x in the polar -K*, orthogonal."""
    rng = np.random.default_rng(0)
    for d in (2, 3):
        x = rng.normal(size=(400, d)) * rng.uniform(0.01, 10.0, size=(400, 1))
        mu = rng.choice([0.0, 0.2, 1.0, 3.0], size=400)
        p = project_cone(x, mu)
        q = x - p
        tol = 1e-12 * np.linalg.norm(x, axis=1)
        assert np.all(mu * p[:, 0] - np.linalg.norm(p[:, 1:], axis=1) >= -tol)
        assert np.all(-q[:, 0] - mu * np.linalg.norm(q[:, 1:], axis=1) >= -tol)
        assert np.all(np.abs(np.einsum("ij,ij->i", p, q)) <= 1e-12 * np.einsum("ij,ij->i", x, x))
        assert np.all(np.abs(p[mu == 0, 1:]) == 0.0)


# --- 1. one contact, closed forms ---------------------------------------------------------

# A planar contact with W = [[a, c], [c, d]] = [[2, 0.5], [0.5, 1]] (positive definite).
W2 = np.array([[2.0, 0.5], [0.5, 1.0]])


@pytest.mark.parametrize("law", ["coulomb", "ccp"])
def test_planar_sticking(law):
    # b = (-1, 0.1), mu = 1. Guess stick: u = 0 -> r = -W^-1 b;
    # W^-1 = [[1, -0.5], [-0.5, 2]] / 1.75, so r = -(-1.05, 0.7) / 1.75 = (0.6, -0.4);
    # |r_t| = 0.4 <= mu r_n = 0.6: inside the cone. u = 0 lies in K* and y = 0 for both laws.
    b = np.array([-1.0, 0.1])
    sol = solve(W2, b, 1.0, law=law)
    assert sol.impulse.shape == (1, 2) and sol.velocity.shape == (1, 2)
    np.testing.assert_allclose(sol.impulse, [[0.6, -0.4]], rtol=0, atol=1e-7)
    np.testing.assert_allclose(sol.velocity, [[0.0, 0.0]], rtol=0, atol=1e-7)
    check_laws(W2, b, 1.0, sol, law)


def test_planar_sliding_coulomb():
    # b = (-1, 0.8), mu = 0.3. Guess slide with u_t > 0: r_t = -mu r_n, u_n = 0:
    #   u_n = a r_n + c r_t + b_n = (2 - 0.5 * 0.3) r_n - 1 = 1.85 r_n - 1 = 0 -> r_n = 1/1.85,
    #   r_t = -0.3 / 1.85,
    #   u_t = c r_n + d r_t + b_t = (0.5 - 0.3) / 1.85 + 0.8 = 0.2/1.85 + 0.8 > 0: consistent.
    b = np.array([-1.0, 0.8])
    sol = solve(W2, b, 0.3, law="coulomb")
    rn = 1 / 1.85
    np.testing.assert_allclose(sol.impulse, [[rn, -0.3 * rn]], rtol=1e-7)
    np.testing.assert_allclose(sol.velocity[0, 1], 0.2 * rn + 0.8, rtol=1e-7)
    assert abs(sol.velocity[0, 0]) <= 1e-7
    check_laws(W2, b, 0.3, sol, "coulomb")


def test_planar_sliding_ccp_gap_against_coulomb():
    # Same data as above for the CCP: r on the cone's boundary, r = r_n (1, -mu s), and
    # u ⊥ r in K* with u on the boundary of K*: u = (mu |u_t|, u_t), s = sign(u_t) = +1
    # (r . u = r_n mu |u_t| - mu s r_n u_t = 0). With r_t = -mu r_n:
    #   u_n = (a - c mu) r_n + b_n,   u_t = (c - d mu) r_n + b_t,   u_n = mu u_t
    #   -> r_n (a - 2 c mu + d mu^2) = mu b_t - b_n
    #   -> r_n = (0.24 + 1) / (2 - 0.3 + 0.09) = 1.24 / 1.79,
    #   u_t = 0.2 r_n + 0.8 > 0 (consistent), and the CCP's "gap" u_n = mu u_t > 0 where
    #   Coulomb's u_n = 0. The CCP's normal impulse exceeds Coulomb's by
    #   1.24/1.79 - 1/1.85.
    b = np.array([-1.0, 0.8])
    mu = 0.3
    ccp = solve(W2, b, mu, law="ccp")
    cou = solve(W2, b, mu, law="coulomb")
    rn = 1.24 / 1.79
    ut = 0.2 * rn + 0.8
    np.testing.assert_allclose(ccp.impulse, [[rn, -mu * rn]], rtol=1e-7)
    np.testing.assert_allclose(ccp.velocity, [[mu * ut, ut]], rtol=1e-7)
    np.testing.assert_allclose(ccp.impulse[0, 0] - cou.impulse[0, 0], 1.24 / 1.79 - 1 / 1.85,
                               rtol=1e-6)
    np.testing.assert_allclose(ccp.velocity[0, 0] - cou.velocity[0, 0], mu * ut, rtol=1e-6)
    check_laws(W2, b, mu, ccp, "ccp")


@pytest.mark.parametrize("law", ["coulomb", "ccp"])
def test_planar_separating(law):
    # b_n > 0: r = 0 gives u = b with b_n = 0.5 >= mu |b_t| = 0.15 (CCP) and y_n = b_n + mu|b_t|
    # >= mu |b_t| (Coulomb): r = 0, u = b.
    b = np.array([0.5, -0.5])
    sol = solve(W2, b, 0.3, law=law)
    np.testing.assert_allclose(sol.impulse, 0.0, atol=1e-7)
    np.testing.assert_allclose(sol.velocity, [b], rtol=1e-9, atol=1e-7)
    check_laws(W2, b, 0.3, sol, law)


def test_spatial_separating_ccp_not_in_dual_cone():
    # b_n > 0 but mu |b_t| > b_n: for the CCP r = 0 is not the answer (u = b is outside K*);
    # for Coulomb it is (y_n = b_n + mu|b_t| >= mu |b_t|). Coulomb: r = 0, u = b.
    W = np.diag([2.0, 1.0, 1.0])
    b = np.array([0.1, 1.2, -1.6])      # |b_t| = 2, mu |b_t| = 1 > 0.1
    cou = solve(W, b, 0.5)
    np.testing.assert_allclose(cou.impulse, 0.0, atol=1e-7)
    np.testing.assert_allclose(cou.velocity, [b], atol=1e-7)
    # CCP on this diagonal W: the slip direction is -b_t/|b_t| and, as in the planar case with
    # c = 0, r_n (a + d mu^2) = mu |b_t| - b_n -> r_n = (1 - 0.1) / (2 + 0.25) = 0.4.
    ccp = solve(W, b, 0.5, law="ccp")
    np.testing.assert_allclose(ccp.impulse, [[0.4, *(-0.5 * 0.4 * b[1:] / 2.0)]], rtol=1e-7)
    check_laws(W, b, 0.5, ccp, "ccp")


def test_spatial_sliding_known_direction():
    # W = diag(a, d, d) = diag(2, 1.5, 1.5), b = (-1, 1.2, 1.6), |b_t| = 2, mu = 0.5.
    # Isotropic tangential block: u_t = b_t + d r_t stays parallel to b_t when r_t is, so the
    # slip direction is t = b_t / |b_t| = (0.6, 0.8) and r_t = -mu r_n t.
    # u_n = 0: r_n = -b_n / a = 0.5; r_t = -0.25 (0.6, 0.8);
    # u_t = (|b_t| - d mu r_n) t = (2 - 0.375) t = 1.625 t (positive: it slides).
    W = np.diag([2.0, 1.5, 1.5])
    b = np.array([-1.0, 1.2, 1.6])
    sol = solve(W, b, 0.5)
    t = np.array([0.6, 0.8])
    np.testing.assert_allclose(sol.impulse, [[0.5, *(-0.25 * t)]], rtol=1e-7)
    np.testing.assert_allclose(sol.velocity[0, 1:], 1.625 * t, rtol=1e-7)
    assert abs(sol.velocity[0, 0]) <= 1e-7
    check_laws(W, b, 0.5, sol, "coulomb")


@pytest.mark.parametrize("law", ["coulomb", "ccp"])
def test_spatial_sliding_with_normal_tangent_coupling(law):
    # W = [[a, c t^T], [c t, d I]] with t = b_t/|b_t| = (0.6, 0.8): a = 2, c = 0.4, d = 1.5,
    # b = (-1, 1.2, 1.6), mu = 0.5. Everything stays in the plane (e_n, t): r_t = -mu r_n t and
    # the problem is the planar one with W = [[a, c], [c, d]], b = (b_n, |b_t|) = (-1, 2):
    #   Coulomb: (a - c mu) r_n = -b_n -> r_n = 1/1.8; u_t = |b_t| + (c - d mu) r_n
    #            = 2 - 0.35/1.8 > 0;
    #   CCP:     r_n (a - 2 c mu + d mu^2) = mu |b_t| - b_n -> r_n = 2 / (2 - 0.4 + 0.375)
    #            = 2 / 1.975; u_t = 2 - 0.35 r_n > 0, u_n = mu u_t.
    t = np.array([0.6, 0.8])
    a, c, d, mu = 2.0, 0.4, 1.5, 0.5
    W = np.block([[np.array([[a]]), c * t[None, :]], [c * t[:, None], d * np.eye(2)]])
    b = np.array([-1.0, 1.2, 1.6])
    sol = solve(W, b, mu, law=law)
    rn = 1 / 1.8 if law == "coulomb" else 2 / 1.975
    ut = 2 - 0.35 * rn
    un = 0.0 if law == "coulomb" else mu * ut
    np.testing.assert_allclose(sol.impulse, [[rn, *(-mu * rn * t)]], rtol=1e-7)
    np.testing.assert_allclose(sol.velocity, [[un, *(ut * t)]], rtol=1e-7, atol=1e-8)
    check_laws(W, b, mu, sol, law)


@pytest.mark.parametrize("law", ["coulomb", "ccp"])
@pytest.mark.parametrize("d", [2, 3])
def test_frictionless(law, d):
    # mu = 0: K = the normal half-line, K* = {u_n >= 0}, and both laws coincide:
    # r_t = 0, r_n = max(0, -b_n / W_nn), u = b + r_n W[:, n].
    rng = np.random.default_rng(d)
    A = rng.normal(size=(d, d))
    W = A @ A.T + 0.5 * np.eye(d)
    for bn in (-0.7, 0.3):
        b = np.concatenate([[bn], rng.normal(size=d - 1)])
        sol = solve(W, b, 0.0, law=law)
        rn = max(0.0, -bn / W[0, 0])
        r = np.zeros(d)
        r[0] = rn
        np.testing.assert_allclose(sol.impulse[0], r, rtol=1e-8, atol=1e-7)
        np.testing.assert_allclose(sol.velocity[0], W @ r + b, rtol=1e-8, atol=1e-7)
        check_laws(W, b, 0.0, sol, law)


# --- 2. two contacts ----------------------------------------------------------------------


@pytest.mark.parametrize("law", ["coulomb", "ccp"])
def test_two_independent_planar_contacts(law):
    # W = blockdiag(W2, W2): the contacts do not interact, each is its own one-contact
    # problem. Contact 0: the sticking case above (mu 1, r = (0.6, -0.4)); contact 1: the
    # sliding case above (mu 0.3): Coulomb r_n = 1/1.85, CCP r_n = 1.24/1.79, r_t = -0.3 r_n.
    W = np.kron(np.eye(2), W2)
    b = np.array([[-1.0, 0.1], [-1.0, 0.8]])
    mu = np.array([1.0, 0.3])
    sol = solve(W, b, mu, law=law)
    rn = 1 / 1.85 if law == "coulomb" else 1.24 / 1.79
    np.testing.assert_allclose(sol.impulse, [[0.6, -0.4], [rn, -0.3 * rn]], rtol=1e-7)
    np.testing.assert_allclose(sol.velocity[0], 0.0, atol=1e-7)
    check_laws(W, b, mu, sol, law)


def test_two_independent_spatial_contacts_one_separating():
    # blockdiag(diag(2, 1.5, 1.5), diag(1, 1, 1)); contact 0 slides as in
    # test_spatial_sliding_known_direction, contact 1 has b = (0.4, 0.1, -0.2), separating
    # (r = 0, u = b; b_n = 0.4 >= mu |b_t| for the CCP too).
    W = np.diag([2.0, 1.5, 1.5, 1.0, 1.0, 1.0])
    b = np.array([-1.0, 1.2, 1.6, 0.4, 0.1, -0.2])
    sol = solve(W, b, [0.5, 0.5])
    t = np.array([0.6, 0.8])
    np.testing.assert_allclose(sol.impulse[0], [0.5, *(-0.25 * t)], rtol=1e-7)
    np.testing.assert_allclose(sol.impulse[1], 0.0, atol=1e-7)
    np.testing.assert_allclose(sol.velocity[1], b[3:], atol=1e-7)
    check_laws(W, b, 0.5, sol, "coulomb")


def _coupled_W():
    A = np.array([[1.0, 0.2, -0.1, 0.3],
                  [0.1, 0.8, 0.2, 0.0],
                  [-0.2, 0.1, 1.1, 0.1],
                  [0.3, 0.0, 0.1, 0.9]])
    return A @ A.T + 0.1 * np.eye(4)


@pytest.mark.parametrize("law", ["coulomb", "ccp"])
def test_two_coupled_planar_contacts_both_sticking(law):
    # Full coupling. Choose b = -W r* with r* = ((1, 0.2), (0.5, -0.1)) strictly inside the
    # cones (mu = 0.5: 0.2 < 0.5, 0.1 < 0.25). Then r = r*, u = 0 satisfies both laws
    # (y = 0), and it is the only CCP solution since W is positive definite; equivalently
    # r = -W^-1 b with W^-1 b computed here by a linear solve.
    W = _coupled_W()
    rstar = np.array([1.0, 0.2, 0.5, -0.1])
    b = -W @ rstar
    sol = solve(W, b, 0.5, law=law)
    np.testing.assert_allclose(sol.impulse.ravel(), -np.linalg.solve(W, b), rtol=1e-7)
    assert np.all(0.5 * sol.impulse[:, 0] > np.abs(sol.impulse[:, 1]))
    np.testing.assert_allclose(sol.velocity, 0.0, atol=1e-7)
    check_laws(W, b, 0.5, sol, law)


@pytest.mark.parametrize("law", ["coulomb", "ccp"])
def test_two_coupled_planar_contacts_slide_and_separate(law):
    # Built from the answer: contact 0 slides with u_0 = (g, 0.7) (g = 0 Coulomb, g = mu 0.7
    # CCP) and r_0 = 0.8 (1, -mu) on the cone's boundary opposite to the slip; contact 1
    # separates with r_1 = 0, u_1 = (0.6, -0.2) (0.6 >= mu 0.2). b = u - W r. Both r . y = 0
    # per contact and the cone conditions hold by construction; the CCP solution is unique
    # (W positive definite), and so is Coulomb's here (mu = 0.3 small against W's coupling;
    # the test would show a second solution as a mismatch).
    W = _coupled_W()
    mu = 0.3
    r = np.array([0.8, -0.8 * mu, 0.0, 0.0])
    u = np.array([0.0 if law == "coulomb" else mu * 0.7, 0.7, 0.6, -0.2])
    b = u - W @ r
    sol = solve(W, b, mu, law=law)
    np.testing.assert_allclose(sol.impulse.ravel(), r, rtol=1e-7, atol=1e-8)
    np.testing.assert_allclose(sol.velocity.ravel(), u, rtol=1e-7, atol=1e-8)
    check_laws(W, b, mu, sol, law)


# --- 3. a second method on random problems ------------------------------------------------


def random_problem(seed, n, d, deficit=0):
    """W = J M^-1 J^T with M = Q diag(1..4) Q^T and J (n d x k) Gaussian, k = n d + 2 - deficit
    (deficit > 2: W singular); b = J v (a velocity of the system, as in an impact; v Gaussian,
    shifted so that the contacts approach on average), mu ~ U(0.1, 1)."""
    rng = np.random.default_rng([seed, n, d, deficit])
    k = n * d + 2 - deficit
    Q, _ = np.linalg.qr(rng.normal(size=(k, k)))
    lam = rng.uniform(1.0, 4.0, size=k)
    J = rng.normal(size=(n * d, k)) / math.sqrt(k)
    L = J @ Q / np.sqrt(lam)                 # W = L L^T = J M^-1 J^T
    W = L @ L.T
    W = 0.5 * (W + W.T)
    v = rng.normal(size=k)
    v -= 0.5 * np.linalg.lstsq(J, np.kron(np.ones(n), np.eye(d)[0]), rcond=None)[0]
    b = (J @ v).reshape(n, d)
    mu = rng.uniform(0.1, 1.0, size=n)
    return W, L, b, mu


def cvxpy_ccp(L, b, mu):
    """min 1/2 |L^T r|^2 + b . r, |r_t| <= mu r_n per contact, by Clarabel."""
    n, d = b.shape
    r = cp.Variable(n * d)
    cons = [cp.SOC(mu[i] * r[i * d], r[i * d + 1:(i + 1) * d]) for i in range(n)]
    prob = cp.Problem(cp.Minimize(0.5 * cp.sum_squares(L.T @ r) + b.ravel() @ r), cons)
    prob.solve(solver=cp.CLARABEL, tol_gap_abs=1e-10, tol_gap_rel=1e-10, tol_feas=1e-10,
               max_iter=200)
    assert prob.status == "optimal"
    return r.value.reshape(n, d), prob.value


CASES = [(s, n, d, deficit) for d in (2, 3) for s, n, deficit in
         ((0, 2, 0), (1, 3, 0), (2, 4, 0), (3, 6, 0), (4, 5, 4), (5, 6, 6))]


@pytest.mark.parametrize("seed,n,d,deficit", CASES)
def test_ccp_matches_cvxpy_clarabel(seed, n, d, deficit):
    W, L, b, mu = random_problem(seed, n, d, deficit)
    sol = solve(W, b, mu, law="ccp")
    check_laws(W, b, mu, sol, "ccp")
    r_ref, f_ref = cvxpy_ccp(L, b, mu)
    u_ref = (W @ r_ref.ravel()).reshape(n, d) + b
    # u is unique (the objective is strictly convex in L^T r, and u = L L^T r + b)
    assert np.linalg.norm(sol.velocity - u_ref) <= 1e-6 * np.linalg.norm(b)
    r = sol.impulse.ravel()
    f = 0.5 * r @ W @ r + b.ravel() @ r
    assert abs(f - f_ref) <= 1e-7 * max(abs(f_ref), 1e-3 * np.linalg.norm(b) ** 2)
    # at the optimum r . u = 0, so f = 1/2 b . r (a closed form of the optimal value)
    assert abs(f - 0.5 * b.ravel() @ r) <= 1e-7 * max(abs(f), 1e-12)


@pytest.mark.parametrize("seed,n,d,deficit", CASES)
def test_coulomb_random_invariants(seed, n, d, deficit):
    W, L, b, mu = random_problem(seed, n, d, deficit)
    mu = 0.5 * mu  # friction up to 0.5
    sol = solve(W, b, mu, law="coulomb")
    check_laws(W, b, mu, sol, "coulomb")
    # Coulomb's answer minimizes the CCP's objective over the cones shifted by the slip
    # velocity: with s = mu |u_t| fixed at the answer, r solves the CCP of b + s e_n
    # (De Saxce's bipotential form); the second method confirms it.
    s = np.zeros_like(b)
    s[:, 0] = mu * np.linalg.norm(sol.velocity[:, 1:], axis=1)
    r_ref, _ = cvxpy_ccp(L, b + s, mu)
    u_ref = (W @ r_ref.ravel()).reshape(b.shape) + b
    assert np.linalg.norm(sol.velocity - u_ref) <= 1e-6 * np.linalg.norm(b)


# --- 5. rank-deficient W: a box on its four bottom corners ---------------------------------


def box(half=(0.2, 0.15, 0.1), mass=1.0):
    """(M, J) of a box with half sizes (a, b, c) on its corners (+-a, +-b, -c), contact frames
    (z, x, y): rows (axis, p x axis) on the velocity (v, omega)."""
    a, bb, c = half
    I = mass / 3.0 * np.array([bb * bb + c * c, a * a + c * c, a * a + bb * bb])
    M = np.diag([mass] * 3 + list(I))
    axes = (np.array([0.0, 0, 1]), np.array([1.0, 0, 0]), np.array([0.0, 1, 0]))
    rows = []
    for sx in (-1, 1):
        for sy in (-1, 1):
            p = np.array([sx * a, sy * bb, -c])
            rows += [np.concatenate([ax, np.cross(p, ax)]) for ax in axes]
    return M, np.array(rows)


@pytest.mark.parametrize("law", ["coulomb", "ccp"])
@pytest.mark.parametrize("mu", [0.0, 0.3, 1.0])
def test_box_dropped_flat(law, mu):
    # Dropped straight down at speed vz = 2, no spin, e = 0: b = J v, v = (0, 0, -2, 0, 0, 0).
    # r_i = (m vz / 4, 0, 0) at each corner gives J^T r = (0, 0, m vz, sum p_i x e_z m vz/4)
    # = (0, 0, m vz, 0) (the corners' (p_y, -p_x, 0) cancel), so v+ = v + M^-1 J^T r = 0 and
    # u = 0: a solution of both laws. u is unique for the CCP and J has rank 6, so v+ = 0 and
    # the total impulse is unique: total normal impulse = m |v_z| = 2 (the impulses per
    # corner are not: W = J M^-1 J^T is 12 x 12 of rank 6). Coulomb's law has no uniqueness
    # theorem here; this same u = 0 solves it (y = u = 0) and is the answer required.
    M, J = box(mass=1.0)
    W = J @ np.linalg.solve(M, J.T)
    W = 0.5 * (W + W.T)
    assert np.linalg.matrix_rank(W) == 6
    v = np.array([0.0, 0, -2.0, 0, 0, 0])
    b = (J @ v).reshape(4, 3)
    sol = solve(W, b, mu, law=law)
    check_laws(W, b, mu, sol, law)
    np.testing.assert_allclose(sol.impulse[:, 0].sum(), 2.0, rtol=1e-7)
    np.testing.assert_allclose(sol.velocity, 0.0, atol=1e-7)
    wrench = J.T @ sol.impulse.ravel()
    np.testing.assert_allclose(wrench, [0, 0, 2.0, 0, 0, 0], atol=1e-7)


@pytest.mark.parametrize("law", ["coulomb", "ccp"])
def test_box_landing_with_spin(law):
    # The box landing with the velocity and spin of the bench (e = 0): the law's conditions,
    # and momentum: v+ = v + M^-1 J^T r must reproduce the returned u = J v+.
    M, J = box()
    W = J @ np.linalg.solve(M, J.T)
    W = 0.5 * (W + W.T)
    v = np.array([0.8, 0.3, -1.0, 0.3, -0.2, 0.5])
    b = (J @ v).reshape(4, 3)
    sol = solve(W, b, 0.3, law=law)
    check_laws(W, b, 0.3, sol, law)
    vplus = v + np.linalg.solve(M, J.T @ sol.impulse.ravel())
    np.testing.assert_allclose(sol.velocity.ravel(), J @ vplus, atol=1e-12)
    assert np.all(sol.velocity[:, 0] >= -1e-7)
    # the same W given as scipy.sparse.csr_matrix: the same answer (u is unique)
    ssp = solve(sp.csr_matrix(W), b, 0.3, law=law)
    check_laws(sp.csr_matrix(W), b, 0.3, ssp, law)
    assert np.abs(ssp.velocity - sol.velocity).max() <= 1e-9 * np.abs(sol.velocity).max()


def many_boxes(count, seed=3):
    """count independent boxes (block-diagonal W, 12 count rows), each with its own landing
    velocity; the first box is dropped flat at vz = -1.5 (no spin)."""
    rng = np.random.default_rng(seed)
    blocks, bs, data = [], [], []
    for k in range(count):
        M, J = box(half=rng.uniform(0.1, 0.3, size=3), mass=rng.uniform(0.5, 2.0))
        Wk = J @ np.linalg.solve(M, J.T)
        v = np.concatenate([rng.normal(size=2) * 0.5, [-rng.uniform(0.5, 2)],
                            rng.normal(size=3)])
        if k == 0:
            v = np.array([0.0, 0, -1.5, 0, 0, 0])
        blocks.append(0.5 * (Wk + Wk.T))
        bs.append(J @ v)
        data.append((M, J, v))
    return sp.block_diag(blocks, format="csr"), np.concatenate(bs).reshape(-1, 3), data


@pytest.mark.parametrize("law", ["coulomb", "ccp"])
def test_sparse_W_agrees_with_dense(law):
    # 20 boxes: 240 rows of density 1/20, large and sparse enough for the sparse
    # factorization. The velocity and each box's total impulse J^T r are unique (above);
    # the two runs must agree on them to 1e-9 relative (tol 1e-12 on both).
    Ws, b, data = many_boxes(20)
    Wd = Ws.toarray()
    mu = 0.4
    ss = solve(Ws, b, mu, law=law, tol=1e-12)
    sd = solve(Wd, b, mu, law=law, tol=1e-12)
    for sol, W in ((ss, Ws), (sd, Wd)):
        check_laws(W, b, mu, sol, law, tol=1e-12)
    assert np.abs(ss.velocity - sd.velocity).max() <= 1e-9 * np.abs(sd.velocity).max()
    for k, (M, J, v) in enumerate(data):
        ws = J.T @ ss.impulse[4 * k:4 * k + 4].ravel()
        wd = J.T @ sd.impulse[4 * k:4 * k + 4].ravel()
        assert np.abs(ws - wd).max() <= 1e-9 * max(np.abs(wd).max(), 1e-300)
    # the first box was dropped flat: total normal impulse m |v_z|
    M0 = data[0][0][0, 0]
    np.testing.assert_allclose(ss.impulse[:4, 0].sum(), 1.5 * M0, rtol=1e-9)


# --- 6. scaling -----------------------------------------------------------------------------


@pytest.mark.parametrize("law", ["coulomb", "ccp"])
@pytest.mark.parametrize("alpha,beta", [(1e3, 1e-2), (1e-4, 10.0), (7.0, 7.0)])
def test_scaling(law, alpha, beta):
    # If r solves (W, b): r' = (beta/alpha) r gives W' r' + b' = alpha W (beta/alpha) r + beta b
    # = beta u; the cones are invariant under positive scaling and r' . y' = (beta^2/alpha)
    # r . y = 0 (y is positively homogeneous in u). W positive definite: r is unique.
    W, _, b, mu = random_problem(7, 4, 3)
    mu = 0.5 * mu
    # tol 1e-12: the natural-map residual is relative to max(|b|, |r|, |u|), and with
    # alpha = 1e-4 the impulses are 1e5 times the velocities, so tol bounds u's error only
    # to ~ tol |r| / |b|; at 1e-12 both answers are accurate well below the 1e-6 compared.
    s0 = solve(W, b, mu, law=law, tol=1e-12)
    s1 = solve(alpha * W, beta * b, mu, law=law, tol=1e-12)
    rs = np.linalg.norm(s0.impulse)
    assert np.linalg.norm(s1.impulse * alpha / beta - s0.impulse) <= 1e-6 * rs
    assert np.linalg.norm(s1.velocity / beta - s0.velocity) <= 1e-6 * np.linalg.norm(b)
    check_laws(alpha * W, beta * b, mu, s1, law, tol=1e-12)


# --- 7. bad input ---------------------------------------------------------------------------

GOOD_W = np.eye(4)
GOOD_b = np.array([-1.0, 0.2, -0.5, 0.1])


def _raises(exc, word, *args, **kw):
    with pytest.raises(exc) as info:
        solve(*args, **kw)
    assert isinstance(info.value, InputError) and isinstance(info.value, ValueError)
    assert word in str(info.value), str(info.value)
    return info.value


def test_good_input_reference():
    # the baseline the bad inputs below perturb: W = I, two independent contacts, each
    # sticking (|b_t| <= mu |b_n|, b_n < 0): r = -b, u = 0
    sol = solve(GOOD_W, GOOD_b, 0.5)
    np.testing.assert_allclose(sol.impulse, [[1.0, -0.2], [0.5, -0.1]], rtol=1e-7)


@pytest.mark.parametrize("where", ["W", "b"])
@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_non_finite(where, bad):
    W, b = GOOD_W.copy(), GOOD_b.copy()
    if where == "W":
        W[1, 1] = bad
    else:
        b[2] = bad
    _raises(NonFiniteError, where, W, b, 0.5)


def test_non_finite_sparse_W():
    W = sp.csr_matrix(GOOD_W)
    W.data[0] = np.nan
    _raises(NonFiniteError, "W", W, GOOD_b, 0.5)


def test_non_square_and_mismatched_W():
    _raises(ShapeError, "W", np.ones((4, 3)), GOOD_b, 0.5)
    _raises(ShapeError, "W", np.eye(6), GOOD_b, 0.5)
    _raises(ShapeError, "W", sp.eye(6, format="csr"), GOOD_b, 0.5)
    _raises(ShapeError, "W", np.ones(4), GOOD_b, 0.5)


def test_asymmetric_W():
    W = GOOD_W.copy()
    W[0, 1] = 0.3
    _raises(ShapeError, "W", W, GOOD_b, 0.5)
    _raises(ShapeError, "W", sp.csr_matrix(W), GOOD_b, 0.5)


def test_negative_diagonal():
    W = GOOD_W.copy()
    W[2, 2] = -1.0
    _raises(ShapeError, "W", W, GOOD_b, 0.5)


@pytest.mark.parametrize("mu", [-0.1, [0.5, -0.5], np.nan, np.inf])
def test_bad_mu_values(mu):
    _raises(ParameterError, "mu", GOOD_W, GOOD_b, mu)


def test_mu_of_wrong_length():
    # b given as (n, d) = (2, 2): 3 coefficients for 2 contacts
    _raises(ShapeError, "mu", GOOD_W, GOOD_b.reshape(2, 2), [0.5, 0.5, 0.5])
    # b flat with 4 entries: not a multiple of 3 contacts
    _raises(ShapeError, "mu", GOOD_W, GOOD_b, [0.5, 0.5, 0.5])
    _raises(ShapeError, "mu", GOOD_W, GOOD_b, [[0.5, 0.5]])


@pytest.mark.parametrize("where,value", [("W", "1.0"), ("W", True), ("b", "1.0"),
                                         ("b", True)])
def test_string_and_bool_entries(where, value):
    if where == "W":
        W = GOOD_W.tolist()
        W[0][0] = value
        _raises(ShapeError, "W", W, GOOD_b, 0.5)
    else:
        b = GOOD_b.tolist()
        b[0] = value
        _raises(ShapeError, "b", GOOD_W, b, 0.5)


@pytest.mark.parametrize("mu", ["0.5", True, ["0.5", 0.5], [True, 0.5]])
def test_string_and_bool_mu(mu):
    _raises(ParameterError, "mu", GOOD_W, GOOD_b, mu)


@pytest.mark.parametrize("law", ["foo", "Coulomb", None, 1])
def test_bad_law(law):
    _raises(ParameterError, "law", GOOD_W, GOOD_b, 0.5, law=law)


@pytest.mark.parametrize("tol", [0, 0.0, -1.0, np.nan, np.inf, "1e-8", True, None])
def test_bad_tol(tol):
    _raises(ParameterError, "tol", GOOD_W, GOOD_b, 0.5, tol=tol)


@pytest.mark.parametrize("name", ["max_iter", "newton_iter"])
@pytest.mark.parametrize("value", [0, -3, 2.5, True, "10"])
def test_bad_iteration_counts(name, value):
    _raises(ParameterError, name, GOOD_W, GOOD_b, 0.5, **{name: value})


def test_ambiguous_dimension():
    # 6 entries and a scalar mu: 3 planar or 2 spatial contacts. W = I: each contact is its
    # own problem with W = I: r = -b inside the cone when |b_t| <= mu |b_n| (b_n < 0).
    W = np.eye(6)
    b = np.array([-1.0, 0.2, -2.0, 0.1, -0.5, 0.05])
    _raises(ShapeError, "dim", W, b, 0.5)
    s2 = solve(W, b, 0.5, dim=2)
    assert s2.impulse.shape == (3, 2)
    np.testing.assert_allclose(s2.impulse.ravel(), -b, rtol=1e-7)
    # d = 3: contact 0 = (-1, 0.2, -2): |b_t| = 2.01 > 0.5 -> slides; W = I, the planar
    # formula with c = 0 along t = b_t/|b_t|: r_n = 1, r_t = -0.5 t.
    s3 = solve(W, b, 0.5, dim=3)
    assert s3.impulse.shape == (2, 3)
    bt = b[1:3]
    np.testing.assert_allclose(s3.impulse[0], [1.0, *(-0.5 * bt / np.linalg.norm(bt))],
                               rtol=1e-7)
    # contact 1 = (0.1, -0.5, 0.05): b_n > 0, Coulomb: separates
    np.testing.assert_allclose(s3.impulse[1], 0.0, atol=1e-7)


@pytest.mark.parametrize("dim", [4, 1, True, "3"])
def test_bad_dim(dim):
    _raises(ParameterError, "dim", np.eye(8), np.zeros(8) - 1, 0.5, dim=dim)


def test_b_shape_and_dim_disagree():
    _raises(ShapeError, "b", np.eye(6), np.zeros((2, 3)) - 1, 0.5, dim=2)


def test_errors_are_the_public_hierarchy():
    assert issubclass(ShapeError, InputError) and issubclass(NonFiniteError, InputError)
    assert issubclass(ParameterError, InputError) and issubclass(InputError, ValueError)


# --- 8. uncertified -------------------------------------------------------------------------


@pytest.mark.parametrize("law", ["coulomb", "ccp"])
def test_uncertified_raises_with_best_answer(law):
    W, _, b, mu = random_problem(11, 3, 3)
    with pytest.raises(ci.UncertifiedSolutionError) as info:
        solve(W, b, mu, law=law, tol=1e-300)
    err = info.value
    assert isinstance(err, ci.errors.SolverError)
    assert err.residual > 1e-300
    s = err.solution
    assert isinstance(s, ci.ContactSolution)
    assert s.impulse.shape == (3, 3) and s.velocity.shape == (3, 3)
    assert s.status != "solved" and s.law == law and s.tol == 1e-300
    assert s.residual == err.residual
    # the residual it reports is the one this file computes from its impulse
    mine, u = my_residual(W, b, mu, s.impulse, law)
    np.testing.assert_allclose(s.velocity, u, rtol=0, atol=1e-12 * np.linalg.norm(b))
    assert abs(mine - err.residual) <= 1e-3 * err.residual + 1e-15
    # and it is still a good answer, only not at 1e-300
    assert err.residual <= 1e-8
