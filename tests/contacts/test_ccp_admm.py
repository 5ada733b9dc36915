"""The CCP's ADMM (:func:`convimpact.contacts.admm.ccp_admm`): the engine's way where the
interior point stalls short of tol and the Newton finish crawls (engine.CCP_ADMM_ITER).

Oracles, none of them the code under test: the CCP's natural-map residual recomputed here with
this folder's own projection onto the friction cone (``test_admm_restart.ccp_residual``), and
the velocity ``u = W r + b`` (unique for the CCP, a convex program) of a second method, the
interior point (dense, on its own).
"""

import numpy as np
import pytest
import scipy.sparse as sp

import convimpact
from convimpact.bench.contact_corpus import corpus
from convimpact.contacts import engine
from convimpact.contacts.admm import ccp_admm
from convimpact.contacts.ccp_interior import solve_ccp

from .test_admm_restart import ccp_residual


@pytest.fixture(scope="module")
def pile():
    (case,) = corpus(names=["capsule-pile-4x4-56"])
    n, d = case.mu.shape[0], case.dim
    return (sp.csr_matrix(case.W), np.asarray(case.b, float).reshape(n, d),
            np.asarray(case.mu, float), d)


@pytest.mark.parametrize("dense", [False, True])
def test_ccp_admm_from_zero_solves_the_ccp(pile, dense):
    W, b, mu, d = pile
    n = mu.shape[0]
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        r, res, its = ccp_admm(W, b, mu, np.zeros((n, d)), True, tol=1e-9, max_iter=20000,
                               dense=dense)
        ref = solve_ccp(W.toarray(), b, mu, d, tol=1e-10, sparse=False)
    assert its <= 20000
    mine = ccp_residual(W, b, mu, r)
    assert mine <= 1e-9
    assert res == pytest.approx(mine, rel=1e-6, abs=1e-15)
    assert ccp_residual(W, b, mu, ref.impulse) <= 1e-8  # the second method is a solution
    u = W @ r.ravel() + b.ravel()
    u_ref = W @ ref.impulse.ravel() + b.ravel()
    assert np.linalg.norm(u - u_ref) <= 1e-6 * max(np.linalg.norm(b), np.linalg.norm(u_ref))


def test_engine_hands_a_short_interior_point_to_the_admm(monkeypatch, pile):
    # the interior point cut at 6 iterations and the Newton finish made idle (it answers its
    # start): only the ADMM can certify, and does, from the interior point's answer; with
    # newton_iter 0 (every finish off) it does not run
    W, b, mu, d = pile
    calls = []
    real = engine.ccp_admm

    def recording(*a, **k):
        calls.append(np.array(a[3], dtype=float))
        return real(*a, **k)

    monkeypatch.setattr(engine, "ccp_admm", recording)
    monkeypatch.setattr(engine, "newton_finish", lambda W, b, mu, r0, **k: (r0, np.inf, 0))
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        R0 = engine._solve(W, b, mu, d, False, 1e-8, 6, 0, 20000, True)
        assert not calls and not R0.converged
        R = engine._solve(W, b, mu, d, False, 1e-8, 6, 30, 20000, True)
    assert len(calls) == 1
    assert ccp_residual(W, b, mu, calls[0]) > 1e-8          # the start was not a solution
    assert R.converged
    assert ccp_residual(W, b, mu, R.impulse) <= 1e-8


@pytest.fixture(scope="module")
def big_wall():
    (case,) = corpus(names=["box-wall-10x14-976"])
    return case


@pytest.mark.parametrize("seed", [None, 1, 2])
def test_brick_wall_of_976_contacts_is_certified_under_round_off(big_wall, seed):
    # its complementarity is not strict: the interior point stalls near 2e-7 and Newton
    # crawls; b perturbed by 1e-14 (relative, seeded) must not change the verdict
    case = big_wall
    b = np.asarray(case.b, float)
    if seed is not None:
        b = b * (1.0 + 1e-14 * np.random.default_rng(seed).standard_normal(b.shape))
    s = convimpact.solve_contact_problem(case.W, b, case.mu, law="ccp", tol=1e-8,
                                         dim=case.dim, mass_matrix=case.M, jacobian=case.J)
    n = case.mu.shape[0]
    r = np.asarray(s.impulse).reshape(n, case.dim)
    assert ccp_residual(sp.csr_matrix(case.W), b.reshape(n, case.dim), case.mu, r) <= 1e-8


@pytest.mark.parametrize("relax", [1.0, 1.6])
def test_over_relaxed_sparse_admm_solves_coulombs_law(relax):
    # the sparse ADMM (admm.coulomb_admm) over-relaxed or not, from zero, on a small brick
    # wall: Coulomb's natural-map residual, recomputed here, reaches 1e-8
    from convimpact.contacts.admm import coulomb_admm

    from .cone_checks import coulomb_residual

    (case,) = corpus(names=["box-wall-3x3-44"])
    n, d = case.mu.shape[0], case.dim
    W, b, mu = sp.csr_matrix(case.W), np.asarray(case.b, float).reshape(n, d), case.mu
    run = coulomb_admm(W, b, mu, np.zeros((n, d)), True, relax=relax)
    Wd = W.toarray()
    best = np.inf
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        for _ in range(3000):
            best = min(best, coulomb_residual(Wd, b, mu, next(run)))
            if best <= 1e-8:
                break
    assert best <= 1e-8


@pytest.mark.parametrize("relax", [1.0, 1.6])
def test_over_relaxed_compiled_admm_solves_coulombs_law(relax):
    # the compiled dense ADMM (admm_kernel.dense_admm) over-relaxed or not, from zero, on a
    # small log pile: Coulomb's natural-map residual, recomputed here, at most 1e-8
    from convimpact.contacts.admm_kernel import dense_admm

    from .cone_checks import coulomb_residual

    (case,) = corpus(names=["capsule-pile-4x4-56"])
    n, d = case.mu.shape[0], case.dim
    Wd, b, mu = case.W.toarray(), np.asarray(case.b, float).reshape(n, d), case.mu
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        r, res, its = dense_admm(Wd, b, mu, d, np.zeros((n, d)), tol=1e-8, max_iter=20000,
                                 relax=relax)
    assert its < 20000
    assert coulomb_residual(Wd, b, mu, r) <= 1e-8
