"""The Newton finish's step through a low-rank factor of W (convimpact.contacts.lowrank).

Oracles, none of them the code under test:

* ``W = J M^-1 J^T`` built here from a random full-column-rank J (N x k, N > k): the factor's
  rank is k by construction and ``G G^T`` must give W back to round-off;
* the Levenberg-Marquardt step ``dr = -(J^T J + lam I)^-1 J^T F`` of ``J = A + E W``, formed
  and solved here densely with numpy, on block-diagonal A and E with every kind of block
  (zero: a sticking contact, identity: an open one, random: sliding);
* the natural-map residual recomputed here (``test_contact_problem.my_residual``) on the
  Newton finish's answer with the factor, on a pile of capsules whose W has more rows than
  rank.
"""

import numpy as np
import pytest
import scipy.sparse as sp

from convimpact.contacts.cones import natural_map_residual
from convimpact.contacts.engine import solve as engine_solve
from convimpact.contacts.finish import newton_finish
from convimpact.contacts.lowrank import (DelassusFactor, delassus_factor, lowrank_flops,
                                         lowrank_step)

from .test_contact_problem import my_residual


def random_delassus(seed, n, d, k):
    rng = np.random.default_rng(seed)
    J = rng.normal(size=(n * d, k))
    B = rng.normal(size=(k, k))
    M = B @ B.T + k * np.eye(k)
    W = J @ np.linalg.solve(M, J.T)
    return 0.5 * (W + W.T), rng


@pytest.mark.parametrize("as_sparse", [False, True])
@pytest.mark.parametrize("n,d,k", [(10, 3, 12), (30, 3, 40), (25, 2, 17)])
def test_factor_gives_W_back_with_its_rank(n, d, k, as_sparse):
    W, _ = random_delassus(n + k, n, d, k)
    G = delassus_factor(sp.csr_matrix(W) if as_sparse else W)
    assert G.shape == (n * d, k)
    assert np.abs(G @ G.T - W).max() <= 1e-12 * np.abs(W).max()


def test_factor_of_zero_W_is_empty():
    assert delassus_factor(np.zeros((6, 6))).shape == (6, 0)


def blocks(rng, n, d, kinds):
    """n blocks d x d: 0 (zero), 1 (identity) or 2 (random), cycling through ``kinds``."""
    out = np.empty((n, d, d))
    for i in range(n):
        kind = kinds[i % len(kinds)]
        out[i] = (0.0 if kind == 0 else np.eye(d) if kind == 1
                  else rng.normal(size=(d, d)))
    return out


def dense(bl):
    n, d, _ = bl.shape
    out = np.zeros((n * d, n * d))
    for i in range(n):
        out[i * d:(i + 1) * d, i * d:(i + 1) * d] = bl[i]
    return out


@pytest.mark.parametrize("lam", [1.0, 1e-3, 1e-7])
@pytest.mark.parametrize("n,d,k", [(12, 3, 10), (20, 2, 9)])
def test_step_is_the_dense_levenberg_marquardt_step(n, d, k, lam):
    W, rng = random_delassus(7 * n + k, n, d, k)
    A = blocks(rng, n, d, [0, 1, 2, 0, 2])
    E = blocks(rng, n, d, [2, 0, 2, 2, 1])
    F = rng.normal(size=n * d)
    Jd = dense(A) + dense(E) @ W
    H = Jd.T @ Jd + lam * np.eye(n * d)
    expected = -np.linalg.solve(H, Jd.T @ F)
    got = lowrank_step(A, E, delassus_factor(W), lam, F)
    # round-off: the normal equations' condition number times the unit round-off
    bound = 100 * np.linalg.cond(H) * np.finfo(float).eps
    assert np.linalg.norm(got - expected) <= bound * np.linalg.norm(expected)


@pytest.mark.parametrize("coulomb", [True, False])
def test_newton_finish_through_the_factor(coulomb):
    # a pile of 16 capsules on 56 contacts: W has 168 rows and rank 89. From the CCP answer
    # of the engine perturbed by 1e-3, the finish with the factor takes the steps of the
    # finish without it (the same step to round-off) and ends certified, by this file's own
    # residual.
    from convimpact.bench.contact_corpus import corpus

    case, = corpus(names=["capsule-pile-4x4-56"])
    W, b, mu = case.problem()
    n, d = case.n_contacts, case.dim
    b = b.reshape(n, d)
    ccp = engine_solve(W, b, mu, d, coulomb=False, tol=1e-10)
    r0 = ccp.impulse * (1.0 + 1e-3 * np.random.default_rng(1).normal(size=(n, d)))
    factor = DelassusFactor(W, min_rows=0, max_fraction=1.0, always=True)
    factor.decide(0.0)
    # its rank: the SVD's (below the 96 coordinates: a capsule's spin about its own axis
    # moves no contact)
    assert factor.G is not None
    assert factor.rank == np.linalg.matrix_rank(W.toarray(), hermitian=True) < case.k
    with_factor = newton_finish(W, b, mu, r0, coulomb=coulomb, tol=1e-10, max_iter=30,
                                sparse=True, factor=factor)
    without = newton_finish(W, b, mu, r0, coulomb=coulomb, tol=1e-10, max_iter=30,
                            sparse=True)
    r, res, steps = with_factor
    assert steps == without[2]
    assert res <= 1e-10
    mine, _ = my_residual(W, b, mu, r, "coulomb" if coulomb else "ccp")
    assert mine <= 1e-10
    assert np.isclose(mine, natural_map_residual(W, b, mu, r, coulomb)[0], rtol=1e-6,
                      atol=1e-14)


def test_factor_kept_only_where_it_pays():
    W, _ = random_delassus(3, 10, 3, 20)  # 30 rows, rank 20
    huge = 1e30
    assert DelassusFactor(W).decide(huge) is None    # fewer rows than LOWRANK_MIN_ROWS
    f = DelassusFactor(W, min_rows=0, max_fraction=0.5)
    assert f.decide(huge) is None and f.rank == 20   # rank 2/3 of the rows
    f = DelassusFactor(W, min_rows=0, max_fraction=0.7)
    assert f.G is None                               # not decided yet
    assert f.decide(huge).shape == (30, 20) and f.G is not None
    # a step of the finish's own cheaper than a low-rank one at rank 3: W not even factored
    f = DelassusFactor(W, min_rows=0, max_fraction=0.7)
    assert f.decide(lowrank_flops(30, 3) - 1.0) is None and f.rank is None
    # factored, but the rank-20 step costs more than the finish's own
    f = DelassusFactor(W, min_rows=0, max_fraction=0.7)
    assert f.decide(lowrank_flops(30, 20) - 1.0) is None and f.rank == 20
    assert f.decided and f.decide(huge) is None      # decided once


@pytest.mark.parametrize("shift", [1.0, 1e-3, 1e-6])
def test_admm_proximal_solve_through_the_factor(shift):
    # the ADMM's proximal step (W + c I) x = rhs by Woodbury's identity against numpy's dense
    # solve, to the round-off of the system's condition number
    from convimpact.contacts.admm import _Solver

    W, rng = random_delassus(11, 20, 3, 24)
    rhs = rng.normal(size=60)
    solver = _Solver(W, False, delassus_factor(W))
    solver.factor(shift)
    K = W + shift * np.eye(60)
    expected = np.linalg.solve(K, rhs)
    bound = 100 * np.linalg.cond(K) * np.finfo(float).eps
    assert np.linalg.norm(solver.solve(rhs) - expected) <= bound * np.linalg.norm(expected)


def test_dense_finish_chooses_the_factor_and_takes_the_same_steps():
    # the pile of 16 capsules with W dense (168 rows, rank 89): the finish decides on its
    # first step (the dense normal equations cost 2.3 N^3 = 1.1e7 flops, the rank-89 step
    # 1.0e7), then takes the steps of the finish without the factor, to round-off; the answer
    # is certified by this file's own residual
    from convimpact.bench.contact_corpus import corpus

    case, = corpus(names=["capsule-pile-4x4-56"])
    W, b, mu = case.W.toarray(), case.b.reshape(56, 3), case.mu
    ccp = engine_solve(W, b, mu, 3, coulomb=False, tol=1e-10)
    r0 = ccp.impulse * (1.0 + 1e-3 * np.random.default_rng(2).normal(size=(56, 3)))
    factor = DelassusFactor(W, min_rows=0, max_fraction=0.6)
    r, res, steps = newton_finish(W, b, mu, r0, coulomb=True, tol=1e-10, max_iter=30,
                                  factor=factor)
    assert factor.decided and factor.G is not None and factor.rank == 89
    r_ref, res_ref, steps_ref = newton_finish(W, b, mu, r0, coulomb=True, tol=1e-10,
                                              max_iter=30)
    assert steps == steps_ref >= 1
    assert res <= 1e-10 and my_residual(W, b, mu, r, "coulomb")[0] <= 1e-10
    np.testing.assert_allclose(r, r_ref, rtol=0, atol=1e-8 * np.abs(r_ref).max())
