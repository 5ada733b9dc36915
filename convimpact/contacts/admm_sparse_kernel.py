"""The sparse ADMM of :mod:`.admm` compiled (numba): its iterations on W's sparse
factorization, ten at a time without returning to Python, and the natural-map residual of
the iterate computed in the same call.

The iteration is :func:`.admm.coulomb_admm`'s (the same proximal step, over-relaxation, cone
step, De Saxce shift and balance of rho). Its proximal solve ``(W + c I)^-1`` is either

* through ``W = G G^T`` (G sparse, N x m, from the generalized coordinates) by Woodbury's
  identity ``(G G^T + c I)^-1 v = (v - G (c I + G^T G)^-1 G^T v) / c``, or
* with W's own sparse matrix, ``W + c I`` factored,

both by a QDLDL factorization ``K = P^T L D L^T P`` (refactored in Python, by QDLDL, only
when rho changes: the kernel returns there), its triangular solves compiled here. The
residual uses ``W w = G (G^T w)`` where G is given (17 thousand entries against W's 225
thousand on the brick wall of 976 contacts); the caller certifies any answer on W itself.

On the brick wall of 976 contacts (2,928 rows, m = 798) an iteration cost 93 us in the
Python loop of :func:`.admm.coulomb_admm` (the Woodbury solve 66 us, of it 32 us QDLDL's
solve through its Python binding and 29 us scipy's products with G and G^T), and the
natural-map check every ten iterations 214 us (the product with W 148 us); compiled, 76 us
and 40 us (the ADMM of that wall from 0.68 s to 0.49 s in all: the solves are bound by the
indirect loads of G, G^T and the factor, 86 thousand multiply-adds, not by Python).
"""

from __future__ import annotations

import numpy as np
import qdldl
import scipy.sparse as sp

from ..compiled import announce
from ..compiled import jit as _jit
from .admm_kernel import _desaxce, _project_into, admm_update, residual_of_velocity

#: first compilation of :func:`sparse_admm_steps` and :func:`sparse_residual` on 2 cores (s),
#: announced (2.7 s measured with an empty cache)
COMPILE_SECONDS = 3


@_jit
def _csr_matvec(indptr, indices, data, x, out):
    """out = A x for A in CSR form."""
    for i in range(indptr.shape[0] - 1):
        s = 0.0
        for k in range(indptr[i], indptr[i + 1]):
            s += data[k] * x[indices[k]]
        out[i] = s


@_jit
def _ldl_solve(Lp, Li, Lx, D, P, rhs, out, z):
    """out = K^-1 rhs with ``K = P^T L D L^T P`` (L unit lower triangular, strictly lower
    part in CSC form; ``(P v)_i = v_{P_i}``); z is scratch of rhs's size."""
    n = rhs.shape[0]
    for i in range(n):
        z[i] = rhs[P[i]]
    for j in range(n):  # L z' = z (by columns)
        zj = z[j]
        for k in range(Lp[j], Lp[j + 1]):
            z[Li[k]] -= Lx[k] * zj
    for i in range(n):
        z[i] /= D[i]
    for j in range(n - 1, -1, -1):  # L^T z'' = z'
        s = z[j]
        for k in range(Lp[j], Lp[j + 1]):
            s -= Lx[k] * z[Li[k]]
        z[j] = s
    for i in range(n):
        out[P[i]] = z[i]


@_jit
def _prox_solve(woodbury, Gp, Gi, Gx, Tp, Ti, Tx, Lp, Li, Lx, D, P, shift, rhs, out, t, z, y):
    """out = (W + shift I)^-1 rhs: by Woodbury's identity on G (CSR) and G^T (CSR as T)
    with the factor of ``shift I + G^T G`` (t, z, y: scratch of m rows), else directly
    with the factor of ``W + shift I`` (t, z: scratch of N rows)."""
    if woodbury:
        _csr_matvec(Tp, Ti, Tx, rhs, t)
        _ldl_solve(Lp, Li, Lx, D, P, t, y, z)
        N = rhs.shape[0]
        for i in range(N):
            s = rhs[i]
            for k in range(Gp[i], Gp[i + 1]):
                s -= Gx[k] * y[Gi[k]]
            out[i] = s / shift
    else:
        _ldl_solve(Lp, Li, Lx, D, P, rhs, out, t)


@_jit
def _times_w(woodbury, Gp, Gi, Gx, Tp, Ti, Tx, Wp, Wi, Wx, v, out, t):
    """out = W v: ``G (G^T v)`` (t: scratch of m rows) or W's own CSR product."""
    if woodbury:
        _csr_matvec(Tp, Ti, Tx, v, t)
        _csr_matvec(Gp, Gi, Gx, t, out)
    else:
        _csr_matvec(Wp, Wi, Wx, v, out)


@_jit
def sparse_admm_steps(woodbury, Gp, Gi, Gx, Tp, Ti, Tx, Wp, Wi, Wx, Lp, Li, Lx, D, P,
                      b, mu, d, x, w, lam, s, rho, eta, Lmax, relax, coulomb, count,
                      balance, step):
    """Up to ``count`` ADMM iterations from the state ``(x, w, lam, s)`` (updated in place)
    with the factor ``(Lp, Li, Lx, D, P)`` of the proximal system for ``rho + eta``.

    Stops after an iteration whose primal and dual residuals differ by more than
    ``balance`` (rho is then to be multiplied by ``step`` or divided by it: the caller
    refactors). Returns ``(iterations done, new rho)`` (new rho equal to rho: no change)."""
    N = b.shape[0]
    M = Tp.shape[0] - 1 if woodbury else N
    rhs = np.empty(N)
    xn = np.empty(N)
    rel = np.empty(N)
    v = np.empty(N)
    wn = np.empty(N)
    t = np.empty(M)
    z = np.empty(M)
    y = np.empty(M)
    shift = rho + eta
    it = 0
    while it < count:
        it += 1
        for i in range(N):
            rhs[i] = eta * x[i] - b[i] - s[i] + rho * w[i] - lam[i]
        _prox_solve(woodbury, Gp, Gi, Gx, Tp, Ti, Tx, Lp, Li, Lx, D, P, shift, rhs, xn,
                    t, z, y)
        for i in range(N):
            rel[i] = relax * xn[i] + (1.0 - relax) * w[i]
        primal, dual = admm_update(rel, x, w, lam, s, mu, d, rho, eta, coulomb, v, wn)
        for i in range(N):  # the proximal centre: the solve's own answer
            x[i] = xn[i]
        if primal > balance * dual and rho < 1e8 * Lmax:
            return it, rho * step
        if dual > balance * primal and rho > 1e-8 * Lmax:
            return it, rho / step
    return it, rho


@_jit
def sparse_residual(woodbury, Gp, Gi, Gx, Tp, Ti, Tx, Wp, Wi, Wx, b, mu, d, r, coulomb):
    """The relative natural-map residual of r (as :func:`.cones.natural_map_residual`), W's
    product as in :func:`_times_w`."""
    N = b.shape[0]
    M = Tp.shape[0] - 1 if woodbury else N
    u = np.empty(N)
    y = np.empty(N)
    p = np.empty(N)
    t = np.empty(M)
    _times_w(woodbury, Gp, Gi, Gx, Tp, Ti, Tx, Wp, Wi, Wx, r, u, t)
    for i in range(N):
        u[i] += b[i]
    return residual_of_velocity(b, mu, d, r, coulomb, u, y, p)


class _Factor:
    """QDLDL's factorization of the proximal system for a shift c: ``c I + G^T G`` (m x m)
    with G, else ``W + c I``; its pattern set once, refactored numerically per shift."""

    def __init__(self, W, G):
        if G is not None:
            A = sp.csc_matrix(G.T @ G)
        else:
            A = sp.csc_matrix(W)
        n = A.shape[0]
        K = sp.triu(A + sp.identity(n, format="csc"), format="csc")
        K.sort_indices()
        diag = np.empty(n, dtype=np.int64)
        for j in range(n):
            lo, hi = K.indptr[j], K.indptr[j + 1]
            diag[j] = lo + np.searchsorted(K.indices[lo:hi], j)
        self.K, self.diag = K, diag
        self.base = K.data.copy()
        self.base[diag] -= 1.0
        self.solver = None

    def twin(self) -> "_Factor":
        """Another factorization of the same pattern (for another run's shifts)."""
        other = object.__new__(_Factor)
        other.K, other.diag, other.base = self.K.copy(), self.diag, self.base
        other.solver = None
        return other

    def factor(self, shift: float) -> tuple:
        """``(Lp, Li, Lx, D, P)`` for ``shift``."""
        K = self.K
        K.data[:] = self.base
        K.data[self.diag] += shift
        if self.solver is None:
            self.solver = qdldl.Solver(K)
        else:
            self.solver.update(K)
        L, D, P = self.solver.factors()
        L = sp.csc_matrix(L)
        return (L.indptr.astype(np.int64), L.indices.astype(np.int64),
                np.ascontiguousarray(L.data, dtype=float), np.ascontiguousarray(D, dtype=float),
                np.ascontiguousarray(P, dtype=np.int64))


def _csr(A) -> tuple:
    A = sp.csr_matrix(A)
    A.sort_indices()
    return (A.indptr.astype(np.int64), A.indices.astype(np.int64),
            np.ascontiguousarray(A.data, dtype=float))


class SparseAdmmRun:
    """The ADMM of :func:`.admm.coulomb_admm` from ``r0`` (n, d) on sparse W, compiled:
    :meth:`next` runs ten iterations and returns the cone copy w (n, d); :attr:`residual` is
    then its natural-map residual (W's product through G where G is given).

    Parameters as :func:`.admm.coulomb_admm`'s: ``G`` sparse (N x m) with ``W = G G^T`` or
    None; ``L`` W's largest eigenvalue; ``rho`` the first rho; ``eta``, ``relax``,
    ``balance`` and ``step`` the iteration's constants. ``like``, optional: a run on the same
    W and G whose set-up (G, G^T and W in CSR form, the pattern of the proximal system) this
    one shares (the engine's second start: 14 ms a set-up on the wall of 976 contacts).
    """

    def __init__(self, W, b, mu, r0, G, *, L: float, rho: float, eta: float, relax: float,
                 balance: float, step: float, coulomb: bool = True,
                 like: "SparseAdmmRun | None" = None):
        announce("sparse ADMM's kernels", COMPILE_SECONDS, sparse_admm_steps, sparse_residual)
        n, d = r0.shape
        self.shape = n, d
        self.woodbury = G is not None
        if like is not None:
            self.G, self.T, self.W, self.fac = like.G, like.T, like.W, like.fac.twin()
        else:
            empty = (np.zeros(1, dtype=np.int64), np.zeros(0, dtype=np.int64), np.zeros(0))
            self.G = _csr(G) if G is not None else empty
            self.T = _csr(G.T) if G is not None else empty
            self.W = empty if G is not None else _csr(W)
            self.fac = _Factor(W, G)
        self.q = np.ascontiguousarray(b, dtype=float).ravel()
        self.mu = np.ascontiguousarray(mu, dtype=float)
        self.d, self.coulomb = d, bool(coulomb)
        self.L, self.rho, self.eta, self.relax = L, rho, eta, relax
        self.balance, self.step = balance, step
        self.F = self.fac.factor(rho + eta)
        x = np.asarray(r0, dtype=float).ravel().copy()
        w = _project(x, self.mu, d)
        u = np.empty(x.size)
        _times_w(self.woodbury, *self.G, *self.T, *self.W, w, u, np.empty(self._m()))
        lam = -(u + self.q)
        s = np.zeros(x.size)
        if coulomb:
            _desaxce(lam, self.mu, d, s, False)
        self.x, self.w, self.lam, self.s = x, w, lam, s
        self.residual = np.inf

    def _m(self) -> int:
        return self.T[0].shape[0] - 1 if self.woodbury else self.q.size

    def _steps(self, left: int) -> tuple[int, float]:
        """Up to ``left`` iterations in the compiled kernel: ``(iterations, new rho)``."""
        return sparse_admm_steps(
            self.woodbury, *self.G, *self.T, *self.W, *self.F, self.q, self.mu, self.d,
            self.x, self.w, self.lam, self.s, self.rho, self.eta, self.L, self.relax,
            self.coulomb, left, self.balance, self.step)

    def _given(self) -> np.ndarray:
        """The iterate :meth:`next` gives (flat): the cone copy w."""
        return self.w

    def next(self) -> np.ndarray:
        left = 10
        while left:
            done, rho = self._steps(left)
            left -= done
            if rho != self.rho:
                self.rho = rho
                self.F = self.fac.factor(rho + self.eta)
        w = self._given()
        self.residual = sparse_residual(self.woodbury, *self.G, *self.T, *self.W, self.q,
                                        self.mu, self.d, w, self.coulomb)
        return w.reshape(self.shape).copy()

    __next__ = next

    def __iter__(self):
        return self


def _project(x: np.ndarray, mu: np.ndarray, d: int) -> np.ndarray:
    out = np.empty_like(x)
    _project_into(x, mu, d, out)
    return out
