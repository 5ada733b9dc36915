"""The sparse ADMM compiled (convimpact.contacts.admm_sparse_kernel): its proximal solve, the
residual it reports, and Coulomb's law solved on a small brick wall, through ``W = G G^T``
(Woodbury's identity) and on W's own factorization.

Oracles, none of them the code under test: numpy's dense solve of ``(W + c I) x = v``, and
Coulomb's natural-map residual recomputed here with this folder's own projection onto the
friction cone (``cone_checks.coulomb_residual``).
"""

import numpy as np
import pytest

from convimpact.contacts import admm, admm_sparse_kernel as K

from .cone_checks import best_coulomb_residual



@pytest.mark.parametrize("woodbury", [True, False])
def test_proximal_solve_matches_a_dense_solve(brick_wall_44, woodbury):
    W, b, mu, d, G = brick_wall_44
    N = W.shape[0]
    c = 0.37
    fac = K._Factor(W, G if woodbury else None)
    Lp, Li, Lx, D, P = fac.factor(c)
    Gc, T = (K._csr(G), K._csr(G.T)) if woodbury else ((np.zeros(1, np.int64),) * 2 +
                                                        (np.zeros(0),),) * 2
    v = np.random.default_rng(3).standard_normal(N)
    m = G.shape[1] if woodbury else N
    out = np.empty(N)
    K._prox_solve(woodbury, *Gc, *T, Lp, Li, Lx, D, P, c, v, out, np.empty(m), np.empty(m),
                  np.empty(m))
    expected = np.linalg.solve(W.toarray() + c * np.eye(N), v)
    assert np.abs(out - expected).max() <= 1e-9 * np.abs(expected).max()


@pytest.mark.parametrize("with_g", [True, False])
def test_compiled_run_solves_coulombs_law_and_reports_its_residual(brick_wall_44, with_g):
    # from zero, over-relaxed as the engine's: every reported residual is the one recomputed
    # here (to 1e-6 relative), and the best reaches 1e-8 within 3,000 iterations
    W, b, mu, d, G = brick_wall_44
    n = mu.shape[0]
    factor = type("F", (), {"G": G})() if with_g else None
    run = admm.coulomb_admm(W, b, mu, np.zeros((n, d)), True, factor=factor, relax=admm.RELAX)
    assert isinstance(run, K.SparseAdmmRun)
    best = best_coulomb_residual(run, W, b, mu)
    assert best <= 1e-8
