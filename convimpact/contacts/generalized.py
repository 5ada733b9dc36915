"""A contact problem's Delassus matrix from its generalized coordinates: ``W = J M^-1 J^T =
G G^T`` with the sparse ``G = J L^-T`` (``M = L L^T``), and the engine's linear algebra
through G where W has more contact rows than the system has degrees of freedom.

Given the mass matrix ``M`` (m x m, symmetric positive definite, sparse: one block per body or
per articulated robot) and the contact Jacobian ``J`` (N x m), :class:`GeneralizedFactor`
factors M block by block (the connected components of its pattern, a dense Cholesky each: the
symbolic work once per problem) and keeps ``G = J L^-T`` sparse (G has J's row pattern within
each block). Then

* the ADMM's proximal solves ``(W + c I)^-1`` go through Woodbury's identity,
  ``(G G^T + c I)^-1 = (I - G (c I + G^T G)^-1 G^T) / c``: a sparse LDL^T (QDLDL) of the
  m x m matrix ``c I + G^T G``, whose pattern does not change with c (its symbolic
  factorization is reused at every change of the ADMM's rho: :class:`WoodburySolver`);
* the Newton finish's Levenberg-Marquardt step is the one of :func:`.lowrank.lowrank_step`
  with its 2m-row Schur complement assembled sparse and factored by a sparse LDL^T
  (:mod:`.lowrank_sparse`), instead of dense products of N x m matrices.

Nothing changes in the problem: the certificate stays the natural-map residual on ``W`` and
``b`` as given.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from ..errors import MassMatrixError, NonFiniteError, ShapeError, as_real_array
from .lowrank import LOWRANK_MAX_FRACTION, DelassusFactor
from .supernodal import SupernodalLDL

#: a coupled block of M of more rows than this is not factored dense: the entry raises
#: MassMatrixError and says to pass W alone (a sparse factorization of such blocks is not built)
MAX_BLOCK_ROWS = 2000
#: the Newton steps and the interior point go through G where m is at most this fraction of
#: the contact rows
NEWTON_MAX_FRACTION = LOWRANK_MAX_FRACTION
#: W given with M and J must equal J M^-1 J^T to this fraction of the scale of a probe
CONSISTENCY_RTOL = 1e-9


def inverse_cholesky_transpose(M) -> sp.csr_matrix:
    """``L^-T`` (sparse, block diagonal) with ``M = L L^T``, block by block over the connected
    components of M's pattern (blocks of one size factored together, batched). Raises
    :class:`~convimpact.errors.MassMatrixError` where a block is not positive definite or
    larger than :data:`MAX_BLOCK_ROWS` rows."""
    M = sp.coo_matrix(M)
    m = M.shape[0]
    count, labels = connected_components(M, directed=False)
    order = np.argsort(labels, kind="stable")
    sizes = np.bincount(labels, minlength=count)
    if sizes.max(initial=0) > MAX_BLOCK_ROWS:
        raise MassMatrixError(f"a coupled block of M has {sizes.max()} rows: more than "
                              f"{MAX_BLOCK_ROWS}, not factored dense; pass the Delassus "
                              "matrix W alone (without mass_matrix and jacobian)")
    first = np.concatenate([[0], np.cumsum(sizes)[:-1]])
    local = np.empty(m, dtype=np.int64)
    local[order] = np.arange(m) - first[labels[order]]   # a coordinate's place in its block
    rows, cols, vals = [], [], []
    for k in np.unique(sizes):
        which = np.flatnonzero(sizes == k)              # the blocks of k rows
        slot = np.full(count, -1)
        slot[which] = np.arange(which.size)
        B = np.zeros((which.size, k, k))
        sel = slot[labels[M.row]] >= 0
        np.add.at(B, (slot[labels[M.row[sel]]], local[M.row[sel]], local[M.col[sel]]),
                  M.data[sel])
        try:
            L = np.linalg.cholesky(0.5 * (B + np.transpose(B, (0, 2, 1))))
        except np.linalg.LinAlgError as exc:
            raise MassMatrixError("M is not positive definite") from exc
        Li = np.transpose(np.linalg.inv(L), (0, 2, 1))  # L^-T, block by block
        coords = order[first[which][:, None] + np.arange(k)[None, :]]   # (blocks, k)
        nz = np.nonzero(Li)
        rows.append(coords[nz[0], nz[1]])
        cols.append(coords[nz[0], nz[2]])
        vals.append(Li[nz])
    return sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                         shape=(m, m))


class GeneralizedFactor:
    """``W = G G^T`` with ``G = J L^-T`` sparse (N x m), from the mass matrix and the contact
    Jacobian (checked by :func:`generalized_inputs` at the public entry).

    Parameters
    ----------
    M : (m, m) sparse or dense, symmetric positive definite.
    J : (N, m) sparse or dense.

    Attributes
    ----------
    G : (N, m) CSR matrix.
    """

    def __init__(self, M, J):
        Lt = inverse_cholesky_transpose(M)
        G = sp.csr_matrix(sp.csr_matrix(J, dtype=float) @ Lt)
        G.eliminate_zeros()
        G.sort_indices()
        self.G = G

    def delassus(self) -> sp.csr_matrix:
        """``W = G G^T`` (CSR, symmetrized)."""
        W = sp.csr_matrix(self.G @ self.G.T)
        W = sp.csr_matrix(0.5 * (W + W.T))
        W.sort_indices()
        return W

    def times(self, x: np.ndarray) -> np.ndarray:
        """``W x = G (G^T x)``."""
        return self.G @ (self.G.T @ x)


def _real_matrix(name: str, A, shape_hint: str):
    if sp.issparse(A):
        A = sp.csr_matrix(A)
        if A.dtype.kind not in "fiu":
            raise ShapeError(f"{name} must be a real matrix, got dtype {A.dtype}")
        A = A.astype(float)
        if not np.all(np.isfinite(A.data)):
            raise NonFiniteError(f"{name} has a non-finite entry (nan or inf)")
    else:
        A = as_real_array(name, A)
        if A.ndim != 2:
            raise ShapeError(f"{name} must be a matrix {shape_hint}, got shape {A.shape}")
        if not np.all(np.isfinite(A)):
            raise NonFiniteError(f"{name} has a non-finite entry (nan or inf)")
        A = sp.csr_matrix(A)
    return A


def generalized_inputs(M, J, N: int, W=None) -> GeneralizedFactor:
    """Checks the generalized coordinates of a contact problem of N rows and returns their
    factor: ``M`` (m, m) symmetric positive definite (:class:`~convimpact.errors.MassMatrixError`
    otherwise), ``J`` (N, m), both real and finite (ShapeError, NonFiniteError); where ``W``
    is given too, ``J M^-1 J^T`` must equal it (on two probe vectors, to
    :data:`CONSISTENCY_RTOL` of their scale: ShapeError otherwise)."""
    M = _real_matrix("mass_matrix", M, "(m, m)")
    J = _real_matrix("jacobian", J, "(n*d, m)")
    m = M.shape[0]
    if M.shape != (m, m):
        raise ShapeError(f"mass_matrix must be square, got shape {M.shape}")
    if J.shape != (N, m):
        raise ShapeError(f"jacobian must be (n*d, m) = ({N}, {m}) for the {N} rows of b and "
                         f"the {m} coordinates of mass_matrix, got shape {J.shape}")
    big = abs(M).max() if M.nnz else 0.0
    if M.nnz and abs(M - M.T).max() > 1e-10 * big:
        raise MassMatrixError("mass_matrix must be symmetric")
    factor = GeneralizedFactor(M, J)
    if W is not None:
        rng = np.random.default_rng(0)
        for _ in range(2):
            x = rng.standard_normal(N)
            a, g = W @ x, factor.times(x)
            scale = (abs(W).max() if sp.issparse(W) else np.abs(W).max()) * np.abs(x).sum()
            if np.abs(a - g).max() > CONSISTENCY_RTOL * max(scale, 1e-300):
                raise ShapeError("W is not J M^-1 J^T for the given mass_matrix and jacobian "
                                 f"(a probe differs by {np.abs(a - g).max():.3g})")
    return factor


def engine_factors(W, generalized: GeneralizedFactor | None, sparse: bool
                   ) -> tuple[DelassusFactor, DelassusFactor]:
    """The engine's factors of W for its Newton steps and its sparse ADMM's solves: with the
    generalized coordinates on the sparse path, G for the ADMM always (its m x m Woodbury
    factorization was 3-8x cheaper per solve than W's own on piles and walls of 400-1,000
    contacts), and for the Newton steps where m is at most
    :data:`~.lowrank.LOWRANK_MAX_FRACTION` of the rows (the 2m-row sparse step was 3x
    cheaper than W's on brick walls and log piles, m/N = 0.27; 20x costlier on sphere piles,
    m/N = 0.65-0.8, where its factorization fills in), the first factor serving the CCP's
    interior point too (through G 5-20x faster on log piles; as fast on sphere piles, where
    its different answer, the start of Coulomb's ADMM, left a pile of 624 spheres
    uncertified); else W's own (:class:`~.lowrank.DelassusFactor`) for both."""
    own = DelassusFactor(W)
    if generalized is None or not sparse:
        return own, own
    given = DelassusFactor.given(generalized.G)
    G = generalized.G
    return (given if G.shape[1] <= NEWTON_MAX_FRACTION * G.shape[0] else own), given


class WoodburySolver:
    """Solves with ``G G^T + c I`` (G sparse N x m) by Woodbury's identity and a QDLDL
    factorization of ``c I + G^T G`` (m x m), refactored numerically only when c changes."""

    def __init__(self, G: sp.csr_matrix):
        self.G = sp.csr_matrix(G)
        self.Gt = sp.csr_matrix(self.G.T)
        m = self.G.shape[1]
        GtG = sp.csc_matrix(self.Gt @ self.G)
        self._GtG = sp.triu(GtG + sp.identity(m, format="csc"), format="csc")
        self._GtG.sort_indices()
        self._diag = self._diagonal_positions(self._GtG)
        self._base = self._GtG.data.copy()
        self._base[self._diag] -= 1.0
        self._f = None
        self._shift = None

    @staticmethod
    def _diagonal_positions(A: sp.csc_matrix) -> np.ndarray:
        pos = np.empty(A.shape[0], dtype=np.int64)
        for j in range(A.shape[0]):
            lo, hi = A.indptr[j], A.indptr[j + 1]
            k = np.searchsorted(A.indices[lo:hi], j)
            pos[j] = lo + k
        return pos

    def factor(self, shift: float) -> None:
        K = self._GtG
        K.data[:] = self._base
        K.data[self._diag] += shift
        if self._f is None:
            self._f = SupernodalLDL(K, upper=True)
        else:
            self._f.update(K, upper=True)
        self._shift = shift

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        return (rhs - self.G @ self._f.solve(self.Gt @ rhs)) / self._shift
