"""The Newton finish's step through a low-rank factor of W, for Delassus matrices with more
contact rows than degrees of freedom.

A Delassus matrix ``W = J M^-1 J^T`` of ``N`` contact rows has rank ``r`` at most the number
of generalized coordinates; on piles of capsules and brick walls ``r`` is a fifth to a third
of ``N``. :class:`DelassusFactor` finds ``W = G G^T`` (``G`` N x r) from W alone, by LAPACK's
Cholesky factorization with complete pivoting (``dpstrf``, stopped at its rank tolerance),
once per problem, when the finish's first step finds that it may pay (a count of flops
against those of its own step's factorization); :func:`lowrank_step` then
solves the finish's regularized (Levenberg-Marquardt) step

    ``(J^T J + lam I) dr = -J^T F``,  ``J = A + E W = A + U V^T``

(``A = I - D`` and ``E = D B rho`` block diagonal, ``U = E G``, ``V = G``) exactly, through
the quasi-definite system ``[[lam I, J^T], [J, -I]] [dr; s] = [0; -F]`` augmented with
``t = V^T dr`` and ``p = U^T s``: its contact block (2d x 2d per contact) is eliminated in
closed form, leaving a symmetric indefinite Schur complement of 2r rows (equilibrated, then
LAPACK's Bunch-Kaufman factorization). A step costs three products of r x N by N x r and a
factorization of 2r rows, instead of a factorization of the N x N (dense) or 2N-row (sparse)
system; the same step to round-off (the tests compare it with the dense normal equations).
"""

from __future__ import annotations

import warnings

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
from scipy.linalg import lapack

#: the factor is kept when its rank is at most this fraction of the rows
LOWRANK_MAX_FRACTION = 0.4
#: problems of fewer rows keep the finish's own step (its factorization is cheap there)
LOWRANK_MIN_ROWS = 600
#: W is not factored where even a rank of this fraction of the rows would not pay
MIN_RANK_FRACTION = 0.2
#: a flop of the sparse LDL^T (QDLDL, scalar code) costs about as much time as this many
#: flops of the low-rank step's BLAS products (measured 1.2 and 20 Gflop/s on one core of the
#: bench machine, piles and walls of 400-1,000 contacts)
SPARSE_FLOP_COST = 16.0
#: dpstrf's stop: the largest remaining pivot at most this times the largest diagonal of W
#: (then every entry of W - G G^T is at most that, W being positive semidefinite)
RANK_RTOL = 1e-13


def lowrank_flops(N: int, r: int) -> float:
    """Flops of one :func:`lowrank_step` on N rows and rank r: three r x N x r products and
    the 2r-row symmetric factorization."""
    return 6.0 * N * r * r + (2.0 * r) ** 3 / 3.0


class DelassusFactor:
    """``W = G G^T`` for the Newton finish, found and kept where its step is the cheaper one.

    The finish calls :meth:`decide` on its first step with that step's own cost; the
    decision (deterministic: a count of flops, never a time) holds for the whole solve, and
    :attr:`G` is the factor chosen, or None.

    Parameters
    ----------
    W : (N, N) ndarray or scipy.sparse matrix, symmetric positive semidefinite.
    min_rows : problems of fewer rows get no factor.
    max_fraction : the factor is kept when its rank is at most this fraction of N...
    always : ...whatever the costs (tests), else only where its step costs fewer flops.
    """

    def __init__(self, W, min_rows: int = LOWRANK_MIN_ROWS,
                 max_fraction: float = LOWRANK_MAX_FRACTION, always: bool = False):
        self._W = W
        self._min_rows = min_rows
        self._max_fraction = max_fraction
        self._always = always
        self._G: np.ndarray | None = None
        #: the Newton finish's sparse step system (:mod:`.sparse_step`), set up on its first
        #: sparse step and kept for the problem's later ones
        self.step_system = None
        #: the step through a sparse G (:class:`.lowrank_sparse.SparseLowRankStep`), laid out
        #: on its first step and kept for the problem's later ones
        self.sparse_lowrank = None
        self.decided = False
        self.rank: int | None = None

    @classmethod
    def given(cls, G) -> "DelassusFactor":
        """A factor known beforehand (``G = J L^-T`` of :mod:`.generalized`, sparse), decided
        at once."""
        f = cls(None)
        f._G, f.decided, f.rank = G, True, G.shape[1]
        return f

    @property
    def G(self) -> np.ndarray | None:
        """The factor chosen (None: not chosen, or not decided yet)."""
        return self._G

    def decide(self, step_flops: float) -> np.ndarray | None:
        """Choose once: factor W (``dpstrf``) unless even a rank of :data:`MIN_RANK_FRACTION`
        of the rows would cost more than ``step_flops`` (the finish's own step, in flops of
        dense BLAS), and keep the factor where its rank is small enough and its step cheaper.
        Returns :attr:`G`."""
        if self.decided:
            return self._G
        self.decided = True
        N = self._W.shape[0]
        low = lowrank_flops(N, int(np.ceil(MIN_RANK_FRACTION * N)))
        if N >= self._min_rows and (self._always or step_flops > low):
            G = delassus_factor(self._W)
            self.rank = G.shape[1]
            if G.shape[1] <= self._max_fraction * N and (
                    self._always or lowrank_flops(N, G.shape[1]) < step_flops):
                self._G = G
        self._W = None
        return self._G


def delassus_factor(W, rtol: float = RANK_RTOL) -> np.ndarray:
    """``G`` (N, r) with ``W = G G^T`` up to ``rtol`` times W's largest diagonal entry, by the
    pivoted Cholesky factorization (LAPACK ``dpstrf``); r is its numerical rank."""
    Wd = np.array(W.toarray() if sp.issparse(W) else W, dtype=float, order="F")
    N = Wd.shape[0]
    big = float(np.max(np.diag(Wd), initial=0.0))
    if N == 0 or big <= 0.0:
        return np.zeros((N, 0))
    L, piv, rank, info = lapack.dpstrf(Wd, lower=1, tol=rtol * big)
    if info < 0:  # an illegal argument: cannot happen on a square float matrix
        raise ValueError(f"dpstrf failed (info {info})")
    # W[p][:, p] = L L^T with p = piv - 1 (LAPACK's pivots count from 1)
    G = np.empty((N, rank))
    G[piv - 1] = np.tril(L)[:, :rank]
    return G


def _blocks_times(B: np.ndarray, X: np.ndarray) -> np.ndarray:
    """The block-diagonal ``B`` (n, d, d) times ``X`` (n d, m)."""
    n, d, _ = B.shape
    return np.einsum("nij,njm->nim", B, X.reshape(n, d, -1)).reshape(n * d, -1)


def lowrank_step(A: np.ndarray, E: np.ndarray, G: np.ndarray, lam: float,
                 F: np.ndarray) -> np.ndarray:
    """The Levenberg-Marquardt step ``dr = -(J^T J + lam I)^-1 J^T F`` of ``J = A + E G G^T``.

    Parameters
    ----------
    A, E : (n, d, d) the block-diagonal parts of the Jacobian (``I - D`` and ``D B rho``).
    G : (n d, r) with ``W = G G^T``.
    lam : float > 0, the regularization.
    F : (n d,) the natural map.

    Returns
    -------
    dr : (n d,)
    """
    n, d, _ = A.shape
    r = G.shape[1]
    F = F.ravel()
    eye = np.eye(d)
    At = np.transpose(A, (0, 2, 1))
    H0 = At @ A + lam * eye                     # A^T A + lam I
    H0inv = np.linalg.inv(H0)
    R1 = H0inv @ At                             # H0^-1 A^T
    Cq = lam * np.linalg.inv(A @ At + lam * eye)  # I - A H0^-1 A^T, without the cancellation
    U = _blocks_times(E, G)
    S = np.empty((2 * r, 2 * r))
    S[:r, :r] = U.T @ _blocks_times(Cq, U)
    S[:r, r:] = -(U.T @ _blocks_times(np.transpose(R1, (0, 2, 1)), G))
    S[:r, r:][np.diag_indices(r)] -= 1.0
    S[r:, :r] = S[:r, r:].T
    Y3 = _blocks_times(H0inv, G)
    S[r:, r:] = -(G.T @ Y3)
    dr0 = -_blocks_times(R1, F[:, None])[:, 0]
    s0 = _blocks_times(A, dr0[:, None])[:, 0] + F
    rhs = -np.concatenate([U.T @ s0, G.T @ dr0])
    # equilibrated (rows and columns by the square root of their largest entry): the blocks
    # of t are of the order of lam, those of p of 1 / lam
    big = np.max(np.abs(S), axis=1)
    sc = 1.0 / np.sqrt(np.where(big > 0.0, big, 1.0))
    S *= sc[:, None]
    S *= sc[None, :]
    with warnings.catch_warnings():
        # a step only (accepted by the finish on the residual it brings, never on itself)
        warnings.simplefilter("ignore", sla.LinAlgWarning)
        x = sc * sla.solve(S, sc * rhs, assume_a="sym", check_finite=False)
    t, p = x[:r], x[r:]
    return -(Y3 @ p) - _blocks_times(R1, (F + U @ t)[:, None])[:, 0]
