"""The exact one-contact Coulomb solver (convimpact.contacts.local_coulomb) and the nonsmooth
Gauss-Seidel built on it (convimpact.contacts.gauss_seidel).

Oracles, none of them the code under test: answers built backwards (a chosen impulse and
velocity satisfying the law by construction, q = u - A r), hand derivations in the comments,
the natural-map residual recomputed with this folder's own cone projection, and a brute-force
scan of slip directions written here from the law's conditions.
"""

import math

import numpy as np
import pytest
import scipy.sparse as sp

from convimpact.contacts.gauss_seidel import diagonal_blocks, gauss_seidel
from convimpact.contacts.local_coulomb import solve_local

from .cone_checks import coulomb_residual, project_cone


def local_error(A, q, mu, r):
    """|r - P_K(r - u - mu |u_t| e_n)| with u = A r + q (absolute)."""
    u = A @ r + q
    y = u.copy()
    y[0] += mu * np.linalg.norm(u[1:])
    return float(np.linalg.norm(r - project_cone((r - y)[None, :], mu)[0]))


def spd(rng, d):
    B = rng.normal(size=(d, d))
    return B @ B.T + 0.5 * np.eye(d)


def solve(A, q, mu, hint=np.nan):
    r = np.zeros(q.shape[0])
    kind = solve_local(np.ascontiguousarray(A), np.ascontiguousarray(q), float(mu), r,
                       np.array([hint]))
    return kind, r


@pytest.mark.parametrize("d", [2, 3])
def test_take_off_when_the_free_velocity_separates(d):
    # q_n >= 0: r = 0 gives u = q with u_n >= 0, and y = (u_n + mu|u_t|, u_t) lies in K_mu*
    A = np.diag([2.0, 1.0, 1.0][:d])
    q = np.array([0.3, -5.0, 2.0][:d])
    kind, r = solve(A, q, 0.4)
    assert kind == 0
    np.testing.assert_array_equal(r, 0.0)
    assert local_error(A, q, 0.4, r) == 0.0


@pytest.mark.parametrize("d", [2, 3])
def test_stick_returns_the_impulse_that_stops_the_contact(d):
    # r* = (1, 0.2, -0.1) lies inside K_0.5 (|r_t| = 0.224 < 0.5); u* = 0; q = -A r*
    rng = np.random.default_rng(1)
    A = spd(rng, d)
    r_star = np.array([1.0, 0.2, -0.1][:d])
    kind, r = solve(A, -A @ r_star, 0.5)
    assert kind == 1
    np.testing.assert_allclose(r, r_star, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(A @ r - A @ r_star, 0.0, atol=1e-12)


def test_slide_hand_derivation():
    # A = diag(2, 1, 1), q = (-1, 0.6, 0.8), mu = 0.5: sticking needs |r_t| = 1 > mu r_n =
    # 0.25, so it slides; u_n = 2 r_n - 1 = 0, r_n = 1/2, r_t = -0.25 (0.6, 0.8) and
    # u_t = r_t + q_t = (0.45, 0.6), along (0.6, 0.8)
    A = np.diag([2.0, 1.0, 1.0])
    kind, r = solve(A, np.array([-1.0, 0.6, 0.8]), 0.5)
    assert kind == 2
    np.testing.assert_allclose(r, [0.5, -0.15, -0.2], atol=1e-13)


@pytest.mark.parametrize("d", [2, 3])
@pytest.mark.parametrize("seed", range(8))
def test_slide_built_backwards(d, seed):
    # r* = rn (1, -mu t) on the cone's boundary and u* = (0, lam t), lam > 0, satisfy the law
    # by construction; q = u* - A r*. A near the identity keeps the answer unique.
    rng = np.random.default_rng(seed)
    mu = rng.uniform(0.1, 1.0)
    A = np.eye(d) + 0.1 * spd(rng, d)
    t = rng.normal(size=d - 1)
    t /= np.linalg.norm(t)
    rn, lam = rng.uniform(0.2, 2.0), rng.uniform(0.05, 1.0)
    r_star = np.concatenate([[rn], -mu * rn * t])
    u_star = np.concatenate([[0.0], lam * t])
    q = u_star - A @ r_star
    assert local_error(A, q, mu, r_star) < 1e-14  # the construction is a solution
    kind, r = solve(A, q, mu)
    assert kind == 2
    np.testing.assert_allclose(r, r_star, rtol=1e-10, atol=1e-10)
    # a slip-direction hint (the Gauss-Seidel's previous angle) gives the same answer
    if d == 3:
        kind, r2 = solve(A, q, mu, hint=math.atan2(t[1], t[0]) + 0.05)
        np.testing.assert_allclose(r2, r_star, rtol=1e-10, atol=1e-10)


def test_frictionless_contact_keeps_its_normal():
    # mu = 0: r = (max(0, -q_n / A_nn), 0, 0) = (1.5 / 3, 0, 0)
    A = np.array([[3.0, 0.5, 0.2], [0.5, 2.0, 0.1], [0.2, 0.1, 1.0]])
    kind, r = solve(A, np.array([-1.5, 0.7, -0.3]), 0.0)
    np.testing.assert_allclose(r, [0.5, 0.0, 0.0], atol=1e-15)
    assert local_error(A, np.array([-1.5, 0.7, -0.3]), 0.0, r) < 1e-15


def brute_force_slide(A, q, mu, m=20000):
    """The slide answers found by scanning m slip angles (here: r_n from u_n = 0, then the
    angle whose u_t is most nearly along t, forward): the best (r, misalignment)."""
    best, arg = np.inf, None
    for th in np.linspace(-np.pi, np.pi, m, endpoint=False):
        t = np.array([math.cos(th), math.sin(th)])
        g = np.concatenate([[1.0], -mu * t])
        an = (A @ g)[0]
        if an <= 0 or -q[0] / an <= 0:
            continue
        r = -q[0] / an * g
        ut = (A @ r + q)[1:]
        if ut @ t <= 0:
            continue
        mis = abs(ut[0] * t[1] - ut[1] * t[0])
        if mis < best:
            best, arg = mis, r
    return arg, best


@pytest.mark.parametrize("seed", range(12))
def test_random_problems_against_the_natural_map_and_a_brute_force_scan(seed):
    rng = np.random.default_rng(100 + seed)
    A = spd(rng, 3)
    q = rng.normal(size=3)
    q[0] = -abs(q[0]) - 0.1  # closing: take-off excluded
    mu = rng.uniform(0.05, 1.2)
    kind, r = solve(A, q, mu)
    assert kind in (1, 2)
    scale = max(np.linalg.norm(q), np.linalg.norm(r))
    assert local_error(A, q, mu, r) <= 1e-12 * scale
    stick = np.linalg.solve(A, -q)
    stick_ok = stick[0] >= 0 and np.linalg.norm(stick[1:]) <= mu * stick[0]
    assert (kind == 1) == stick_ok
    if kind == 2:
        rb, mis = brute_force_slide(A, q, mu)
        assert rb is not None and mis < 1e-2 * scale
        # the scan's angle step is 2 pi / 20000: the answers agree to about that
        np.testing.assert_allclose(r, rb, atol=1e-3 * scale)


def test_gauss_seidel_on_two_decoupled_contacts_matches_their_closed_forms():
    # W block diagonal: contact 1 the hand-derived slide above, contact 2 a stick with
    # r* = (1, 0.1, 0) (W2 = I, q2 = -r*): one sweep solves both exactly
    W = sp.block_diag([np.diag([2.0, 1.0, 1.0]), np.eye(3)], format="csr")
    b = np.array([-1.0, 0.6, 0.8, -1.0, -0.1, 0.0])
    mu = np.array([0.5, 0.5])
    np.testing.assert_array_equal(diagonal_blocks(W, 3)[0], np.diag([2.0, 1.0, 1.0]))
    r = next(gauss_seidel(W, b, mu, 3, np.zeros((2, 3)), sweeps=1))
    np.testing.assert_allclose(r, [[0.5, -0.15, -0.2], [1.0, 0.1, 0.0]], atol=1e-13)


@pytest.mark.parametrize("seed", range(4))
def test_nsgs_certifies_rank_deficient_random_problems(seed):
    # W = J J^T / k with J (18, 12): rank 12 < 18 rows (impulses not unique, as in piles)
    from convimpact.contacts.gauss_seidel import nsgs_newton

    rng = np.random.default_rng(seed)
    n, k = 6, 12
    J = rng.normal(size=(3 * n, k))
    W = J @ J.T / k
    b = rng.normal(size=3 * n)
    b[::3] -= 0.5
    mu = rng.uniform(0.1, 1.0, n)
    assert np.linalg.matrix_rank(W) == k

    def residual(r):
        return coulomb_residual(W, b, mu, r)

    r, res, work = nsgs_newton(sp.csr_matrix(W), b.reshape(n, 3), mu, 3, np.zeros((n, 3)),
                               tol=1e-10, residual=residual)
    assert res == pytest.approx(coulomb_residual(W, b, mu, r), rel=1e-12)
    assert res <= 1e-10
    assert 0 < work <= 20000


def test_singular_block_slides_instead_of_failing():
    # A = diag(2, 1, 0): no stick answer (A not invertible); q = (-1, 0.6, 0.8), mu = 0.5:
    # u_n = 2 r_n - 1 = 0, r_n = 1/2; the slide r_t = -0.25 t, u_t = (q_1 - 0.25 t_1, 0.8)
    # along t: t = (0.6, 0.8) gives u_t = (0.45, 0.8), not along t; solve u_t || t:
    # (0.6 - 0.25 c) s = 0.8 c with c^2 + s^2 = 1. The answer is checked against the
    # natural map (it must be a solution), not against a closed form.
    A = np.diag([2.0, 1.0, 0.0])
    q = np.array([-1.0, 0.6, 0.8])
    kind, r = solve(A, q, 0.5)
    assert kind == 2
    assert local_error(A, q, 0.5, r) <= 1e-12
    assert r[0] == pytest.approx(0.5, abs=1e-13)
