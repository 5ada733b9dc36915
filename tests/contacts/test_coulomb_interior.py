"""The interior point on Coulomb's law itself (convimpact.contacts.coulomb_interior) and the
engine's Coulomb path through it.

Oracles, none of them the code under test: closed forms derived by hand in the comments (one
spatial contact sliding or sticking, two decoupled contacts), Coulomb's conditions in De
Saxce's form checked contact by contact from the returned impulse, and the natural-map
residual recomputed here with this file's own projection onto the friction cone.
"""


import numpy as np
import pytest
import scipy.sparse as sp

import convimpact as ci
from convimpact.contacts.coulomb_interior import coulomb_interior

from .cone_checks import project_cone


def velocity(W, b, r):
    n, d = r.shape
    Wd = W.toarray() if sp.issparse(W) else np.asarray(W, float)
    return (Wd @ r.ravel() + np.ravel(b)).reshape(n, d)


def coulomb_residual(W, b, mu, r):
    """|r - P_K(r - y)| / max(|b|, |r|, |u|), y = u + mu |u_t| e_n, u = W r + b (here)."""
    u = velocity(W, b, r)
    y = u.copy()
    y[:, 0] += mu * np.linalg.norm(u[:, 1:], axis=1)
    err = np.linalg.norm(r - project_cone(r - y, mu))
    return err / max(np.linalg.norm(b), np.linalg.norm(r), np.linalg.norm(u))


def check_coulomb(W, b, mu, r, tol=1e-8):
    """Coulomb's law in De Saxce's form, contact by contact: r in K_mu, y = u + mu |u_t| e_n
    in K_mu* = {y_n >= mu |y_t|}, r . y = 0; and a sliding contact's friction opposes its
    slip (r_t = -mu r_n u_t / |u_t| where |u_t| > 0 and r_n > 0)."""
    u = velocity(W, b, r)
    scale = max(np.linalg.norm(b), np.linalg.norm(r), np.linalg.norm(u))
    slack = 10 * tol * scale
    ut = np.linalg.norm(u[:, 1:], axis=1)
    y = u.copy()
    y[:, 0] += mu * ut
    assert np.all(mu * r[:, 0] - np.linalg.norm(r[:, 1:], axis=1) >= -slack)
    assert np.all(y[:, 0] - mu * np.linalg.norm(y[:, 1:], axis=1) >= -slack)
    assert np.all(np.abs(np.einsum("ij,ij->i", r, y)) <= 10 * tol * scale ** 2)
    sliding = (ut > 1e-6 * scale) & (r[:, 0] > 1e-6 * scale)
    for i in np.flatnonzero(sliding):
        np.testing.assert_allclose(r[i, 1:], -mu[i] * r[i, 0] * u[i, 1:] / ut[i],
                                   atol=1e-6 * scale)
    assert coulomb_residual(W, b, mu, r) <= tol


# one spatial contact, W = diag(2, 1, 1), b = (-1, 0.6, 0.8), mu = 0.5 (hand derivation):
# sticking would need r = -W^-1 b = (0.5, -0.6, -0.8), |r_t| = 1 > mu r_n = 0.25: it slides.
# W diagonal, so u_n = 2 r_n - 1 = 0 gives r_n = 1/2, r_t = -mu r_n (0.6, 0.8) = (-0.15, -0.2)
# and u_t = r_t + b_t = (0.45, 0.6), along (0.6, 0.8): consistent.
W_SLIDE = np.diag([2.0, 1.0, 1.0])
B_SLIDE = np.array([-1.0, 0.6, 0.8])
MU_SLIDE = np.array([0.5])
R_SLIDE = np.array([[0.5, -0.15, -0.2]])


@pytest.mark.parametrize("sparse", [False, True])
def test_one_sliding_contact_closed_form(sparse):
    W = sp.csr_matrix(W_SLIDE) if sparse else W_SLIDE
    r, res, it = coulomb_interior(W, B_SLIDE, MU_SLIDE, 3, tol=1e-10, sparse=sparse)
    np.testing.assert_allclose(r, R_SLIDE, atol=1e-8)
    assert res <= 1e-10 and 1 <= it <= 60
    assert res == pytest.approx(coulomb_residual(W_SLIDE, B_SLIDE, MU_SLIDE, r),
                                rel=1e-6, abs=1e-15)


def test_two_decoupled_contacts_stick_and_separate():
    """Contact 1: W = diag(1, 1, 1), b = (-1, 0.2, 0), mu = 0.8: r = (1, -0.2, 0) stops it,
    |r_t| = 0.2 <= 0.8 (sticking, u = 0). Contact 2: b = (0.5, 0.3, -0.1), separating: r = 0,
    u = b."""
    W = np.eye(6)
    b = np.array([-1.0, 0.2, 0.0, 0.5, 0.3, -0.1])
    mu = np.array([0.8, 0.4])
    r, res, _ = coulomb_interior(W, b, mu, 3, tol=1e-10)
    np.testing.assert_allclose(r, [[1.0, -0.2, 0.0], [0.0, 0.0, 0.0]], atol=1e-8)
    np.testing.assert_allclose(velocity(W, b, r), [[0, 0, 0], [0.5, 0.3, -0.1]], atol=1e-8)


def test_planar_stack_certified_by_the_interior_point_alone():
    """planar-stack-200 (200 contacts, W singular: 2 corner contacts of 2 rows per rectangle
    of 3 coordinates): the iteration alone meets Coulomb's law at 1e-8, checked contact by
    contact."""
    from convimpact.bench.contact_corpus import corpus

    (case,) = corpus(names=["planar-stack-200"])
    r, res, it = coulomb_interior(case.W.tocsr(), case.b, case.mu, case.dim, sparse=True)
    assert res <= 1e-8 and it <= 60
    check_coulomb(case.W, case.b, case.mu, r)


def test_a_stall_is_reported_not_hidden():
    """capsule-pile-4x4-56: the iteration stalls (its steps to the cones' boundary vanish)
    short of 1e-8; what it returns is its best iterate with that iterate's true residual."""
    from convimpact.bench.contact_corpus import corpus

    (case,) = corpus(names=["capsule-pile-4x4-56"])
    W = case.W.toarray()
    r, res, it = coulomb_interior(W, case.b, case.mu, case.dim, sparse=False)
    assert it < 60  # stopped by the stall test, not the iteration limit
    assert res == pytest.approx(coulomb_residual(W, case.b, case.mu, r), rel=1e-6)
    assert res > 1e-8


def test_engine_certifies_a_box_stack_past_the_compiled_sizes():
    """box-stack-400 (100 boxes, 400 contacts: 1,200 rows, W of rank at most 600): through
    solve_contact_problem (Newton from the CCP answer misses, the interior point on Coulomb's
    law certifies); checked contact by contact."""
    from convimpact.bench.contact_corpus import corpus

    (case,) = corpus(names=["box-stack-400"])
    sol = ci.solve_contact_problem(case.W, case.b, case.mu, law="coulomb", dim=case.dim)
    check_coulomb(case.W, case.b, case.mu, sol.impulse)
    np.testing.assert_allclose(sol.velocity, velocity(case.W, case.b, sol.impulse),
                               atol=1e-12 * np.abs(case.b).max())

