"""The Newton finish's sparse step system (convimpact.contacts.sparse_step) against the
Levenberg-Marquardt step from its dense normal equations, formed here with numpy:
``dr = -(J^T J + lam I)^-1 J^T F``, ``J = I - D + DB W``; with open contacts (their D and DB
zero, the step's pattern reduced) and again after they close (the pattern restored)."""

import numpy as np
import scipy.sparse as sp

from convimpact.contacts.sparse_step import SparseStepSystem


def _dense_step(W, D, DB, lam, F):
    n, d, _ = D.shape
    N = n * d
    J = np.eye(N) - sp.block_diag(list(D)).toarray() + sp.block_diag(list(DB)).toarray() @ W
    return -np.linalg.solve(J.T @ J + lam * np.eye(N), J.T @ F)


def test_sparse_step_is_the_levenberg_marquardt_step():
    rng = np.random.default_rng(5)
    n, d = 12, 3
    # a banded block pattern (a chain of contacts), symmetric positive semidefinite
    B = sp.random(n * d, 8, density=0.4, random_state=1).toarray()
    W = B @ B.T
    mask = np.kron(np.abs(np.subtract.outer(np.arange(n), np.arange(n))) <= 1, np.ones((d, d)))
    W = W * mask
    Ws = sp.csr_matrix(W)
    S = SparseStepSystem(Ws, d)
    for step in range(4):
        D = rng.standard_normal((n, d, d))
        DB = rng.standard_normal((n, d, d))
        if step in (1, 2):  # contacts 2 and 7 open: D = DB = 0 there (the same set twice)
            D[[2, 7]] = 0.0
            DB[[2, 7]] = 0.0
        F = rng.standard_normal(n * d)
        lam = 10.0 ** -step
        want = _dense_step(W, D, DB, lam, F)
        got = S.solve(D, DB, lam, F)
        assert np.abs(got - want).max() <= 1e-8 * max(np.abs(want).max(), 1.0)
