"""The Newton finish's Levenberg-Marquardt step through a sparse ``G`` (``W = G G^T``, G from
the generalized coordinates, :mod:`.generalized`), with what does not change from step to step
kept: :class:`SparseLowRankStep`.

The step is :func:`.lowrank.lowrank_step`'s: ``dr = -(J^T J + lam I)^-1 J^T F`` of
``J = A + E G G^T`` (``A = I - D``, ``E = D B rho`` block diagonal), its contact blocks
eliminated in closed form, leaving the symmetric indefinite system of 2m rows (m the columns
of G) in ``t = G^T dr`` and ``p = U^T s`` (``U = E G``)

    S = [[G^T B11 G, -G^T B12 G - I], [-G^T B12^T G - I, -G^T B22 G]],

``B11 = E^T Cq E``, ``B12 = E^T R1^T``, ``B22 = H0^-1`` block diagonal (one d x d block per
contact), equilibrated by the square roots of its rows' largest entries. Each contact adds to
S a small dense block on the columns of G its rows touch (two bodies: at most 12), so S's
pattern is that of G's columns' co-occurrence, whatever the values: it is laid out once per
solve (:class:`SparseLowRankStep`), and a step is four batched products of those blocks and
one scatter into its entries. S is then factored by an LDL^T without pivoting
(:class:`.supernodal.SupernodalLDL`: QDLDL's ordering and symbolic factorization kept from
the first step, the supernodes where S fills in) with a static regularization
of :data:`REGULARIZATION` (+ on the t block, - on the p block: quasi-definite) removed by
iterative refinement on S itself; where the refinement does not reach
:data:`REFINED_RTOL`, or the first factorization meets a zero pivot, SuperLU factors S (its
symmetric mode).

Measured on the corpus's largest problems (one core, S of 1,200 and 1,596 rows): SuperLU's
factorization 14 and 16 ms a step, QDLDL's numeric one 6 and 2.5 ms (fill 144k and 96k against
330k and 531k), three refinements to the SuperLU answer's accuracy (2e-14 and 3e-12).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from .supernodal import SupernodalLDL

#: the static regularization of the equilibrated S (whose rows' largest entries are 1)
REGULARIZATION = 1e-9
#: the refinement is accepted at this relative residual of the equilibrated system (SuperLU's
#: own answer: 4e-14 on a capsule pile of 920 contacts, 1.6e-11 on a brick wall of 976)...
REFINED_RTOL = 1e-10
#: ...within this many refinements (the wall: 2e-4, 4.5e-7, 1.1e-9, 3e-12)
MAX_REFINEMENTS = 8


class SparseLowRankStep:
    """The Levenberg-Marquardt step of the Newton finish through a sparse ``G`` (module
    docstring), for one G (the steps of one solve).

    Parameters
    ----------
    G : (n d, m) sparse, ``W = G G^T``.
    d : 2 or 3, the rows per contact.
    """

    def __init__(self, G, d: int):
        self.G_given = G  # (the caller's object: its steps reuse this layout)
        G = sp.csr_matrix(G)
        G.sum_duplicates()
        G.sort_indices()
        N, m = G.shape
        n = N // d
        self.G, self.Gt, self.m = G, sp.csr_matrix(G.T), m
        # each contact's columns (the union of its d rows'), padded to k: G_c (n, d, k)
        row = np.repeat(np.arange(N), np.diff(G.indptr))
        contact = row // d
        key = contact * m + G.indices
        ukey, where = np.unique(key, return_inverse=True)
        ucontact = ukey // m
        first = np.searchsorted(ucontact, np.arange(n))
        local = np.arange(ukey.size) - first[ucontact]
        k = int(local.max(initial=-1)) + 1
        Gc = np.zeros((n, d, max(k, 1)))
        Gc[contact, row % d, local[where]] = G.data
        cols = np.full((n, max(k, 1)), -1, dtype=np.int64)
        cols[ucontact, local] = ukey % m
        self._Gc = Gc
        self._GcT = np.ascontiguousarray(np.transpose(Gc, (0, 2, 1)))
        # S's pattern: P, the co-occurrence of G's columns in a contact (and the diagonal), in
        # each of the four quadrants; column j of S holds P's column j at rows i and m + i
        valid = (cols >= 0)[:, :, None] & (cols >= 0)[:, None, :]
        ri = np.broadcast_to(cols[:, :, None], valid.shape)[valid]
        ci = np.broadcast_to(cols[:, None, :], valid.shape)[valid]
        eye = np.arange(m)
        pkeys, inverse = np.unique(np.concatenate([ci * m + ri, eye * m + eye]),
                                   return_inverse=True)
        prow, pcol = pkeys % m, pkeys // m
        pptr = np.searchsorted(pcol, np.arange(m + 1))
        nnz_p = pkeys.size
        length = np.diff(pptr)
        offset = np.arange(nnz_p) - pptr[pcol]
        # each P entry's position in S's CSC data, per quadrant (row block a, column block b)
        quad = np.empty((2, 2, nnz_p), dtype=np.int64)
        for b in (0, 1):
            for a in (0, 1):
                quad[a, b] = b * 2 * nnz_p + 2 * pptr[pcol] + a * length[pcol] + offset
        self._nnz = size = 4 * nnz_p
        where_p = np.full(valid.shape, -1, dtype=np.int64)
        where_p[valid] = inverse[:ri.size]
        # the contributions' positions (padding: one past the end)
        self._block_pos = np.where(where_p >= 0, quad[:, :, where_p], size)
        diag_p = inverse[ri.size:]
        self._eye_pos = np.concatenate([quad[0, 1, diag_p], quad[1, 0, diag_p]])
        indices = np.empty(size, dtype=np.int64)
        col = np.empty(size, dtype=np.int64)
        for b in (0, 1):
            for a in (0, 1):
                indices[quad[a, b]] = prow + a * m
                col[quad[a, b]] = pcol + b * m
        self._indices = indices.astype(np.int32)
        self._col = col
        self._indptr = np.concatenate([2 * pptr, 2 * nnz_p + 2 * pptr[1:]]).astype(np.int32)
        size = 2 * m
        # the upper triangle (QDLDL's input) and the regularization's signs on its diagonal
        upper = self._indices <= self._col
        self._upper = np.flatnonzero(upper)
        ucol = self._col[upper]
        self._uindices = self._indices[upper]
        self._uindptr = np.searchsorted(ucol, np.arange(size + 1)).astype(np.int32)
        udiag = np.flatnonzero(self._uindices == ucol)
        self._udiag = udiag
        self._sign = np.where(ucol[udiag] < m, 1.0, -1.0)
        self._solver = None
        self.fallbacks = 0  # (the steps SuperLU took: for the tests)

    def _assemble(self, B11, B12, B22) -> np.ndarray:
        """S's CSC data from the contact blocks (module docstring)."""
        Gc, GcT = self._Gc, self._GcT
        P11 = GcT @ B11 @ Gc
        P12 = -(GcT @ B12 @ Gc)
        P21 = np.transpose(P12, (0, 2, 1))
        P22 = -(GcT @ B22 @ Gc)
        pos = self._block_pos
        data = np.bincount(np.concatenate([pos[0, 0].ravel(), pos[0, 1].ravel(),
                                           pos[1, 0].ravel(), pos[1, 1].ravel(),
                                           self._eye_pos]),
                           weights=np.concatenate([P11.ravel(), P12.ravel(), P21.ravel(),
                                                   P22.ravel(),
                                                   np.full(2 * self.m, -1.0)]),
                           minlength=self._nnz + 1)
        return data[:self._nnz]

    def _solve_system(self, S: sp.csc_matrix, rhs: np.ndarray) -> np.ndarray:
        """``S x = rhs`` (S equilibrated): QDLDL with the static regularization and iterative
        refinement, else SuperLU."""
        K = sp.csc_matrix((S.data[self._upper], self._uindices, self._uindptr), shape=S.shape)
        K.data[self._udiag] += REGULARIZATION * self._sign
        scale = max(float(np.max(np.abs(rhs))), 1e-300)
        try:
            if self._solver is None:
                self._solver = SupernodalLDL(K, upper=True)
            else:
                self._solver.update(K, upper=True)
            x = self._solver.solve(rhs)
            best = np.inf
            for _ in range(MAX_REFINEMENTS + 1):
                res = rhs - S @ x
                err = float(np.max(np.abs(res))) / scale
                if not np.isfinite(err) or err >= 0.5 * best:
                    break
                best = err
                if err <= REFINED_RTOL:
                    return x
                x = x + self._solver.solve(res)
        except (RuntimeError, ValueError):  # a zero pivot
            self._solver = None
        self.fallbacks += 1
        lu = spla.splu(S, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.1,
                       options={"SymmetricMode": True})
        return lu.solve(rhs)

    def solve(self, A: np.ndarray, E: np.ndarray, lam: float, F: np.ndarray) -> np.ndarray:
        """The step ``dr`` (n d,) for the block-diagonal parts ``A = I - D``, ``E = D B rho``
        (n, d, d), the weight ``lam > 0`` and the natural map ``F`` (n d,). Raises
        RuntimeError where SuperLU finds S exactly singular."""
        n, d, _ = A.shape
        G, Gt, m = self.G, self.Gt, self.m
        F = F.ravel()
        eye = np.eye(d)
        At = np.transpose(A, (0, 2, 1))
        H0inv = np.linalg.inv(At @ A + lam * eye)
        R1 = H0inv @ At
        Cq = lam * np.linalg.inv(A @ At + lam * eye)
        Et = np.transpose(E, (0, 2, 1))
        data = self._assemble(Et @ Cq @ E, Et @ np.transpose(R1, (0, 2, 1)), H0inv)
        dr0 = -np.einsum("nij,nj->ni", R1, F.reshape(n, d)).ravel()
        s0 = np.einsum("nij,nj->ni", A, dr0.reshape(n, d)).ravel() + F
        rhs = -np.concatenate([Gt @ np.einsum("nji,nj->ni", E, s0.reshape(n, d)).ravel(),
                               Gt @ dr0])
        # equilibrated: rows and columns by the square root of their largest entry
        # (S is symmetric: its columns' largest entries are its rows'; every column holds
        # its diagonal entry, so none is empty)
        big = np.maximum.reduceat(np.abs(data), self._indptr[:-1])
        sc = 1.0 / np.sqrt(np.where(big > 0.0, big, 1.0))
        S = sp.csc_matrix((data * sc[self._indices] * sc[self._col], self._indices,
                           self._indptr), shape=(2 * m, 2 * m))
        x = sc * self._solve_system(S, sc * rhs)
        t, p = x[:m], x[m:]
        Y3p = np.einsum("nij,nj->ni", H0inv, (G @ p).reshape(n, d)).ravel()
        Ut = np.einsum("nij,nj->ni", E, (G @ t).reshape(n, d)).ravel()
        return -Y3p - np.einsum("nij,nj->ni", R1, (F + Ut).reshape(n, d)).ravel()


def sparse_lowrank_step(A: np.ndarray, E: np.ndarray, G, lam: float,
                        F: np.ndarray) -> np.ndarray:
    """One step of :class:`SparseLowRankStep` (laid out for this call alone)."""
    return SparseLowRankStep(G, A.shape[1]).solve(A, E, lam, F)
