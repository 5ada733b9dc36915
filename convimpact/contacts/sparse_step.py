"""The Newton finish's sparse step system on a pattern fixed once per problem.

The finish's step on sparse W solves the quasi-definite system
``[[lam I, J^T], [J, -I]] [dr; s] = [0; -F]`` with ``J = I - D + (D B rho) W``, D and
``D B rho`` block diagonal (one d x d block per contact). Its pattern is W's, blocked by
contacts: :class:`SparseStepSystem` computes that pattern, the layout of the system's upper
triangle (CSC) and W's values on it once; each step then only fills the values, ``J``'s
blocks by one batched product of d x d blocks, drops the off-diagonal blocks of the contacts
whose ``D B`` vanishes (open contacts), and refactors numerically while that pattern holds
(QDLDL ``update``: the AMD ordering and the elimination tree computed again only when the
open contacts change), instead of assembling the system anew through scipy's sparse
constructors and factoring it from scratch at every step.
"""

from __future__ import annotations

import numpy as np
import qdldl
import scipy.sparse as sp


class SparseStepSystem:
    """The step system of W (sparse, N = n d rows) on W's contact-block pattern.

    Parameters
    ----------
    W : (N, N) sparse.
    d : the contact dimension.
    """

    def __init__(self, W, d: int):
        W = sp.csr_matrix(W)
        N = W.shape[0]
        n = N // d
        self.N, self.n, self.d = N, n, d
        # the block pattern of W, the diagonal blocks included
        Wc = W.tocoo()
        Wc.sum_duplicates()
        Bp = sp.coo_matrix((np.ones(Wc.nnz + n), (np.concatenate([Wc.row // d, np.arange(n)]),
                                                  np.concatenate([Wc.col // d, np.arange(n)]))),
                           shape=(n, n)).tocsr()
        Bp.sum_duplicates()
        Bp.sort_indices()
        nb = Bp.nnz
        self.block_row = np.repeat(np.arange(n), np.diff(Bp.indptr))  # (nb,)
        self.diag_block = Bp.indptr[:-1] + np.array(
            [np.searchsorted(Bp.indices[Bp.indptr[i]:Bp.indptr[i + 1]], i) for i in range(n)])
        # W's values on the blocks (zeros where the block pattern has no entry of W)
        keys = self.block_row * n + Bp.indices          # ascending
        at = np.searchsorted(keys, (Wc.row // d) * n + Wc.col // d)
        self.W_data = np.zeros((nb, d, d))
        np.add.at(self.W_data, (at, Wc.row % d, Wc.col % d), Wc.data)
        # the CSR order of J's entries: a BSR of entry numbers (from 1) converted
        numbered = sp.bsr_matrix((np.arange(1, nb * d * d + 1, dtype=float).reshape(nb, d, d),
                                  Bp.indices, Bp.indptr), shape=(N, N)).tocsr()
        numbered.sort_indices()
        if numbered.nnz != nb * d * d:  # cannot happen: no entry is zero
            raise ValueError("the step's pattern lost entries")
        self.to_csr = numbered.data.astype(np.int64) - 1
        row_nnz = np.diff(numbered.indptr)
        # the system's upper triangle in CSC: column j < N holds lam at (j, j); column N + k
        # holds row k of J (rows 0..N-1) and -1 at (N + k, N + k)
        counts = np.concatenate([np.ones(N, dtype=np.int64), row_nnz + 1])
        indptr = np.concatenate([[0], np.cumsum(counts)])
        indices = np.empty(indptr[-1], dtype=np.int64)
        indices[indptr[:N]] = np.arange(N)
        self.lam_pos = indptr[:N]
        neg = indptr[N + 1:] - 1
        indices[neg] = N + np.arange(N)
        self.neg_pos = neg
        J_pos = np.ones(indptr[-1], dtype=bool)
        J_pos[self.lam_pos] = False
        J_pos[neg] = False
        self.J_pos = np.flatnonzero(J_pos)
        indices[self.J_pos] = numbered.indices
        self.K = sp.csc_matrix((np.zeros(indptr[-1]), indices, indptr), shape=(2 * N, 2 * N))
        self.K.data[self.neg_pos] = -1.0
        self.keep_all = np.ones(indptr[-1], dtype=bool)
        self.solver = None
        self.kept = None
        self.step_K = None

    def solve(self, D: np.ndarray, DB: np.ndarray, lam: float, F: np.ndarray) -> np.ndarray:
        """The step ``dr`` (N,) of ``J = I - D + DB W`` (D, DB: (n, d, d)), regularization
        ``lam``, natural map ``F`` (N,)."""
        Jb = np.einsum("kab,kbc->kac", DB[self.block_row], self.W_data)
        Jb[self.diag_block] += np.eye(self.d) - D
        K = self.K
        K.data[self.lam_pos] = lam
        K.data[self.J_pos] = Jb.ravel()[self.to_csr]
        # the rows of contacts whose D B vanishes (open contacts) keep their diagonal block
        # only: the pattern of this step, its symbolic factorization reused while it holds
        live = np.any(DB != 0.0, axis=(1, 2))[self.block_row]
        live[self.diag_block] = True
        keep = self.keep_all.copy()
        keep[self.J_pos] = np.repeat(live, self.d * self.d)[self.to_csr]
        if self.solver is None or not np.array_equal(keep, self.kept):
            counts = np.add.reduceat(keep.astype(np.int64), K.indptr[:-1])
            self.step_K = sp.csc_matrix(
                (K.data[keep], K.indices[keep], np.concatenate([[0], np.cumsum(counts)])),
                shape=K.shape)
            self.solver = qdldl.Solver(self.step_K)
            self.kept = keep
        else:
            self.step_K.data[:] = K.data[keep]
            self.solver.update(self.step_K)
        return self.solver.solve(np.concatenate([np.zeros(self.N), -F]))[:self.N]
