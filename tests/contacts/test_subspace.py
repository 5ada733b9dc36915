"""The firmly sticking contacts' subspace step (convimpact.contacts.subspace.stick_step).

Oracles, none of them the code under test: problems built backwards (sticking impulses and
b = -W r*, so that u* = 0), the minimum-norm step of a singular W by numpy's least squares,
the velocities and the natural-map residual recomputed here (tests/contacts/cone_checks).
"""

import numpy as np
import scipy.sparse as sp

from convimpact.contacts.subspace import stick_step

from .cone_checks import coulomb_residual


def _spd(n, seed, floor=0.5):
    rng = np.random.default_rng(seed)
    B = rng.normal(size=(n, n))
    return floor * np.eye(n) + 0.2 * (B @ B.T)


def test_two_coupled_sticking_contacts_are_solved_in_one_step():
    # r* inside both cones (|r_t| = 0.2 mu r_n), b = -W r*: u* = 0, r* sticks, a solution of
    # Coulomb's law by construction; from r* moved by 1e-2 (still firmly inside) the step
    # returns r*
    W = _spd(6, 0)
    mu = np.array([0.5, 0.8])
    r_star = np.array([[1.0, 0.06, -0.08], [2.0, 0.0, 0.32]])
    b = -(W @ r_star.ravel()).reshape(2, 3)
    assert coulomb_residual(W, b, mu, r_star) < 1e-15
    r0 = r_star + 1e-2 * np.array([[1.0, -0.5, 0.3], [-0.4, 0.2, 0.1]])
    r = stick_step(sp.csr_matrix(W), b, mu, r0)
    np.testing.assert_allclose(r, r_star, atol=1e-12)
    assert coulomb_residual(W, b, mu, r) < 1e-12


def test_open_sliding_and_frictionless_contacts_are_held():
    # contact 0 sticks firmly (|r_t| = 0.25 mu r_n), 1 is open (r = 0), 2 slides (on its
    # cone's boundary), 3 is frictionless: 1-3 keep their impulses exactly, and contact 0's
    # velocity, recomputed here, is zero (b: every velocity 1e-3 from zero at r0)
    W = _spd(12, 1)
    mu = np.array([0.4, 0.6, 0.5, 0.0])
    r0 = np.array([[1.0, 0.1, 0.0], [0.0, 0.0, 0.0], [0.8, 0.24, 0.32], [0.5, 0.0, 0.0]])
    b = -(W @ r0.ravel()).reshape(4, 3) + 1e-3 * np.random.default_rng(2).normal(size=(4, 3))
    r = stick_step(sp.csr_matrix(W), b, mu, r0)
    np.testing.assert_array_equal(r[1:], r0[1:])
    u = (W @ r.ravel() + b.ravel()).reshape(4, 3)
    np.testing.assert_allclose(u[0], 0.0, atol=1e-12)


def test_a_singular_W_takes_the_minimum_norm_step():
    # W = G G^T of rank 3 for two contacts (6 rows: a pile's redundancy), b = -W r_t for r_t
    # inside the cones: u = W (r0 - r_t), and the step of least norm zeroing it is
    # -P (r0 - r_t), P the projection onto range(G) (numpy's least squares); the null-space
    # part of r0 is kept
    rng = np.random.default_rng(3)
    G = rng.normal(size=(6, 3))
    W = G @ G.T
    mu = np.array([0.7, 0.7])
    r_t = np.array([[1.0, 0.1, 0.05], [1.5, -0.1, 0.2]])
    b = -(W @ r_t.ravel()).reshape(2, 3)
    r0 = r_t + 1e-2 * rng.normal(size=(2, 3))
    expected = r0.ravel() - G @ np.linalg.lstsq(G, (r0 - r_t).ravel(), rcond=None)[0]
    r = stick_step(sp.csr_matrix(W), b, mu, r0)
    np.testing.assert_allclose(r.ravel(), expected, atol=1e-10)
    assert coulomb_residual(W, b, mu, r) < 1e-10


def test_no_step_without_firm_contacts_or_where_it_is_too_long():
    W = sp.csr_matrix(_spd(3, 4))
    mu = np.array([0.5])
    # on the cone's boundary (sliding): no unknown
    assert stick_step(W, np.ones((1, 3)), mu, np.array([[1.0, 0.3, 0.4]])) is None
    # firmly inside, but u = W r + b of 1e3 against |r| of 1: a step of about 1e3 |r|
    assert stick_step(W, np.full((1, 3), 1e3), mu, np.array([[1.0, 0.1, 0.0]])) is None
