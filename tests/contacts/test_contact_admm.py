"""The compiled ADMM of the contact engine (convimpact.contacts.admm_kernel) and the
engine's Coulomb path through it.

Oracles, none of them the code under test: closed forms derived by hand in the comments (one
planar contact sliding, two decoupled contacts, one sticking and one separating), and the
natural-map residual recomputed here with this file's own projection onto the friction cone.
"""


import numpy as np
import pytest

import convimpact as ci
from convimpact.contacts import admm_kernel, first_tries

from .cone_checks import coulomb_residual


# one planar contact, W = [[2, 1/2], [1/2, 1]], b = (-1, 1/2), mu = 0.3: it slides forward
# (u_t > 0), so r_t = -mu r_n and u_n = 0: (2 - mu/2) r_n = 1, r_n = 1/1.85, and
# u_t = r_n/2 - mu r_n + 1/2 = 0.2/1.85 + 0.5 > 0 (consistent)
W1 = np.array([[2.0, 0.5], [0.5, 1.0]])
B1 = np.array([-1.0, 0.5])
MU1 = np.array([0.3])
R1 = np.array([[1.0 / 1.85, -0.3 / 1.85]])


def test_admm_one_sliding_contact_closed_form():
    r, res, it = admm_kernel.dense_admm(W1, B1, MU1, 2, np.zeros((1, 2)), tol=1e-12,
                                        max_iter=5000)
    assert np.abs(r - R1).max() <= 1e-10
    assert coulomb_residual(W1, B1, MU1, r) <= 1e-12
    assert 0 < it <= 5000


def test_compiled_residual_is_the_natural_map_residual():
    rng = np.random.default_rng(3)
    n, d = 5, 3
    A = rng.standard_normal((n * d, n * d))
    W = A @ A.T
    b = rng.standard_normal(n * d)
    mu = rng.uniform(0.1, 1.0, n)
    r = rng.standard_normal((n, d))
    N = n * d
    got = admm_kernel.natural_residual(W, b, mu, d, r.ravel(), True, np.empty(N),
                                       np.empty(N), np.empty(N))
    assert got == pytest.approx(coulomb_residual(W, b, mu, r), rel=1e-12)


def test_admm_two_decoupled_contacts_stick_and_separate():
    # contact 0 (spatial): W block 2 I, b = (-1, 0.1, 0): sticking needs u = 0, r = (1/2,
    # -0.05, 0), inside the cone |r_t| = 0.05 <= mu r_n = 0.25 (mu = 0.5);
    # contact 1: b = (+1, 0.3, 0.2) already separating, r = 0, u = b
    W = np.zeros((6, 6))
    W[:3, :3] = 2.0 * np.eye(3)
    W[3:, 3:] = np.eye(3)
    b = np.array([-1.0, 0.1, 0.0, 1.0, 0.3, 0.2])
    mu = np.array([0.5, 0.5])
    r, res, it = admm_kernel.dense_admm(W, b, mu, 3, np.zeros((2, 3)), tol=1e-12,
                                        max_iter=5000)
    assert np.abs(r - [[0.5, -0.05, 0.0], [0.0, 0.0, 0.0]]).max() <= 1e-10
    assert coulomb_residual(W, b, mu, r) <= 1e-12


def test_admm_polish_is_called_and_its_answer_kept():
    calls = []

    def polish(r):  # returns the exact answer: the ADMM must stop on it
        calls.append(r.copy())
        return R1.copy(), 0.0, 1

    r, res, it = admm_kernel.dense_admm(W1, B1, MU1, 2, np.zeros((1, 2)), tol=1e-300,
                                        max_iter=5000, polish=polish)
    assert calls and res == 0.0 and np.array_equal(r, R1)


def test_engine_coulomb_through_the_admm_on_a_brick_wall():
    """box-wall-2x2-16 (16 contacts): the compiled interior point and Newton miss Coulomb's
    law here (Newton from the CCP answer stalls at 1e-2); the ADMM and Newton certify it."""
    from convimpact.bench.contact_corpus import corpus

    (case,) = corpus(names=["box-wall-2x2-16"])
    W = case.W.toarray()
    d = case.dim
    compiled = first_tries.compiled_answer(W, case.b, case.mu, d, True, 1e-8, 100, 30)
    assert not compiled.converged  # the path this test is about
    sol = ci.solve_contact_problem(case.W, case.b, case.mu, law="coulomb", dim=d)
    assert sol.status == "solved"
    assert coulomb_residual(W, case.b, case.mu, sol.impulse) <= 1e-8
    np.testing.assert_allclose(sol.velocity.ravel(), W @ sol.impulse.ravel() + case.b,
                               atol=1e-12 * np.abs(case.b).max())


def test_ccp_admm_and_engine_agree_with_clarabel():
    """box-wall-3x3-44 (44 contacts, W singular) under the CCP: the compiled ADMM alone (the
    CCP mode of the kernel) and the engine; the velocity u = W r + b (unique, though r is not)
    of both agrees with the convex program ``min 1/2 |F^T r|^2 + b^T r`` over the friction
    cones (W = F F^T) solved here by cvxpy and Clarabel."""
    import cvxpy as cp
    from convimpact.bench.contact_corpus import corpus

    (case,) = corpus(names=["box-wall-3x3-44"])
    W = case.W.toarray()
    n, d = case.n_contacts, case.dim
    r_admm, res, it = admm_kernel.dense_admm(W, case.b, case.mu, d, np.zeros((n, d)),
                                             tol=1e-6, max_iter=20000, coulomb=False)
    assert res <= 1e-6 and it < 20000  # alone, the ADMM is slow past 1e-7 here
    sol = ci.solve_contact_problem(case.W, case.b, case.mu, law="ccp", dim=d)
    lam, V = np.linalg.eigh(W)
    keep = lam > 1e-12 * lam.max()
    F = V[:, keep] * np.sqrt(lam[keep])
    r = cp.Variable(n * d)
    cons = [cp.SOC(case.mu[i] * r[i * d], r[i * d + 1:(i + 1) * d]) for i in range(n)]
    cp.Problem(cp.Minimize(0.5 * cp.sum_squares(F.T @ r) + case.b @ r), cons).solve(
        solver=cp.CLARABEL, tol_gap_abs=1e-12, tol_gap_rel=1e-12, tol_feas=1e-12)
    u_ref = W @ r.value + case.b
    scale = np.linalg.norm(case.b)
    assert np.linalg.norm(sol.velocity.ravel() - u_ref) <= 1e-5 * scale
    assert np.linalg.norm(W @ r_admm.ravel() + case.b - u_ref) <= 1e-4 * scale


def test_admm_patience_ends_a_try_whose_newton_fails():
    """A polish that never succeeds: without patience the run goes to its iteration limit
    (tol 0 is never met), with patience 3 it ends within 3x (plus a batch) of the iterations
    at which the polish was first called, here counted by the polish itself through the
    residual of what it receives (first within 1e-5)."""
    seen = []

    def failing(r):
        seen.append(coulomb_residual(W1, B1, MU1, r))
        return r, np.inf, 1

    r, res, it = admm_kernel.dense_admm(W1, B1, MU1, 2, np.zeros((1, 2)), tol=0.0,
                                        max_iter=100_000, polish=failing, patience=3.0)
    assert it < 100_000 and seen and seen[0] <= 1e-5
    assert res == pytest.approx(coulomb_residual(W1, B1, MU1, r), rel=1e-9, abs=1e-15)
    _, _, it_plain = admm_kernel.dense_admm(W1, B1, MU1, 2, np.zeros((1, 2)), tol=0.0,
                                            max_iter=3000, polish=failing)
    assert it_plain == 3000


def test_largest_eigenvalue_against_lapack():
    rng = np.random.default_rng(7)
    A = rng.standard_normal((12, 5))
    W = A @ A.T  # rank 5, positive semidefinite
    got = admm_kernel.largest_eigenvalue(W, rng.standard_normal(12))
    assert got == pytest.approx(np.linalg.eigvalsh(W)[-1], rel=1e-6)
