"""The vectorized interior point on the cone complementarity problem
``K ∋ r ⊥ u = W r + b ∈ K*`` (the CCP, the convex relaxation of Coulomb's law): the contact
engine's (:mod:`.engine`) backend for problems past its compiled kernels' size, dense or sparse.

The problem is the optimality system of the convex program ``min 1/2 r^T W r + b^T r`` over
the product K of friction cones; W is only positive semidefinite (a stack of boxes has more
contact rows than degrees of freedom), and then the impulses are not unique but the velocity
``u`` is. The method (Mehrotra's predictor-corrector with Nesterov-Todd scaling, as in
CVXOPT's ``coneqp``; :mod:`.cones`):

* the cones are made standard (``r = D x``) and each contact is equilibrated by its own
  effective mass ``sqrt(W_nn)``;
* every iteration solves ``(A + H) dx = rhs`` with ``A`` the equilibrated W and ``H`` the
  block-diagonal Nesterov-Todd term, positive definite inside the cones: a singular W needs no
  regularization, and the iterates follow the central path toward the analytic centre of the
  set of solutions; where W is singular the velocity is unique but the impulses are not, and
  the answer is the iterate (after the Newton finish) whose residual reaches ``tol``: near the
  analytic centre, not at it (on a stack of 48 boxes its impulses lie 1.3e-2, relative, from
  those of the same path run to 1e-11; the velocities agree);
* dense W: one LAPACK Cholesky per iteration; sparse W: a sparse LDL^T (QDLDL) whose symbolic
  analysis is made once and reused (H keeps W's pattern plus its own diagonal blocks).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

from . import cones
from .nt_kernels import (affine_target, announce_compilation, corrector_target, max_step,
                         nt_blocks, scaled_rhs)
from .supernodal import SupernodalLDL

#: the interior-point path's parameters (Mehrotra): the fraction of the step to the boundary
STEP_FRACTION = 0.99
#: the interior point stops at this gap (unit data): the Newton finish takes over from here
GAP_FLOOR = 1e-14
#: refinement steps of a solve through W = G G^T (:class:`_Factor`'s quasi-definite system)
AUGMENTED_REFINEMENTS = 2
#: sparse factorization is used for W given sparse with more than this many rows...
SPARSE_MIN_ROWS = 200
#: ...and at most this density
SPARSE_MAX_DENSITY = 0.15


@dataclass(frozen=True)
class EngineResult:
    """What one engine solve reached (the caller certifies and raises)."""

    impulse: np.ndarray       # (n, d)
    velocity: np.ndarray      # (n, d) = W r + b
    residual: float           # the natural-map residual of the law solved
    iterations: int           # interior-point, Newton and ADMM iterations, summed
    converged: bool
    message: str


class _Blocks:
    """The standard-cone form of a contact problem: ``r = D x``, groups of cones of equal
    dimension (spatial or planar friction cones, frictionless normals), equilibrated."""

    def __init__(self, W, mu: np.ndarray, d: int, sparse: bool):
        n = mu.shape[0]
        self.n, self.d = n, d
        fric = np.flatnonzero(mu > 0.0)
        free = np.flatnonzero(mu <= 0.0)
        # kept components of r (frictionless contacts keep the normal only), grouped
        cols = [(fric[:, None] * d + np.arange(d)).ravel(), free * d]
        self.cols = np.concatenate(cols)
        self.groups = []  # (slice of x, cone dimension, contact indices)
        o = 0
        for idx, m in ((fric, d), (free, 1)):
            if idx.size:
                self.groups.append((slice(o, o + idx.size * m), m, idx))
                o += idx.size * m
        self.size = o
        dscale = np.ones(n * d)
        tang = (fric[:, None] * d + np.arange(1, d)).ravel()
        dscale[tang] = np.repeat(mu[fric], d - 1)
        Wk = W[self.cols][:, self.cols] if not sparse else W.tocsr()[self.cols][:, self.cols]
        Wdiag = Wk.diagonal() if sparse else np.diag(Wk)
        scale = dscale[self.cols]
        # equilibrate each contact by its normal effective mass (one scalar per cone)
        contact_of = self.cols // d
        wnn = np.asarray(W.diagonal() if sparse else np.diag(W))[np.arange(n) * d]
        eq = 1.0 / np.sqrt(np.maximum(wnn, np.finfo(float).tiny))
        if not np.all(np.isfinite(eq)) or np.all(wnn <= 0):
            eq = np.ones(n)
        bad = wnn <= 1e-300
        eq[bad] = 1.0 / np.sqrt(max(float(np.max(np.abs(Wdiag), initial=1.0)), 1e-300))
        self.scale = scale * eq[contact_of]           # r_cols = scale * x
        S = self.scale
        if sparse:
            Sd = sp.diags(S)
            self.A = (Sd @ Wk @ Sd).tocsc()
        else:
            self.A = Wk * S[:, None] * S[None, :]

    def to_impulse(self, x: np.ndarray) -> np.ndarray:
        r = np.zeros(self.n * self.d)
        r[self.cols] = self.scale * x
        return r.reshape(self.n, self.d)

    def cone_rows(self, v: np.ndarray):
        """Views of ``v`` as (cones, m) arrays, one per group."""
        return [v[s].reshape(-1, m) for s, m, _ in self.groups]


def _identity(blocks: _Blocks) -> np.ndarray:
    e = np.zeros(blocks.size)
    for s, m, _ in blocks.groups:
        e[s][::m] = 1.0
    return e


def _shift_into(blocks: _Blocks, v: np.ndarray) -> np.ndarray:
    """``v + a e`` with the smallest ``a`` putting v strictly inside every cone (>= 1)."""
    low = np.inf
    for rows in blocks.cone_rows(v):
        t = rows[:, 0] - np.sqrt(np.einsum("ij,ij->i", rows[:, 1:], rows[:, 1:]))
        low = min(low, float(t.min(initial=np.inf)))
    a = max(0.0, -low) + 1.0
    return v + a * _identity(blocks)


class _Factor:
    """Factorizations of ``A + H`` (H block diagonal), dense or sparse; given ``Gk`` with
    ``A = Gk Gk^T`` (sparse, N x m), the quasi-definite system ``[[H, Gk], [Gk^T, -I]]``
    (N + m rows, QDLDL, its symbolic analysis made once) in place of ``A + H``."""

    def __init__(self, blocks: _Blocks, sparse: bool, Gk: sp.spmatrix | None = None):
        self.blocks, self.sparse = blocks, sparse
        self.solver = None
        self.aug_rows = 0
        if sparse:
            # W's pattern and the cones' diagonal blocks (every entry counted positive)
            rows, cols = [], []
            for s, m, _ in blocks.groups:
                k = (s.stop - s.start) // m
                base = s.start + np.arange(k)[:, None, None] * m
                rows.append((base + np.arange(m)[None, :, None]).repeat(m, 2).ravel())
                cols.append((base + np.arange(m)[None, None, :]).repeat(m, 1).ravel())
            rows, cols = np.concatenate(rows), np.concatenate(cols)
            Hpat = sp.csc_matrix((np.ones(rows.size), (rows, cols)),
                                 shape=(blocks.size, blocks.size))
            P = abs(blocks.A) + Hpat
            self.pattern = sp.triu(P, format="csc")
            self.pattern.sum_duplicates()
            self.pattern.sort_indices()
            if Gk is not None:  # H's blocks, Gk beside them, -I below
                Nk, self.aug_rows = Gk.shape
                self.Gk, self.GkT = sp.csr_matrix(Gk), sp.csr_matrix(Gk.T)
                P = sp.bmat([[Hpat, abs(Gk)], [None, sp.identity(self.aug_rows)]],
                            format="csc")
                self.pattern = sp.triu(P, format="csc")
                self.pattern.sum_duplicates()
                self.pattern.sort_indices()
                Gc = sp.coo_matrix(Gk)
                rows_b = np.concatenate([Gc.row, Nk + np.arange(self.aug_rows)])
                cols_b = np.concatenate([Nk + Gc.col, Nk + np.arange(self.aug_rows)])
                self.A_data = (self._positions(rows_b, cols_b),
                               np.concatenate([Gc.data, -np.ones(self.aug_rows)]))
            else:
                # where each block of H and each entry of A lands in the pattern's data
                self.A_data = self._gather(sp.triu(blocks.A, format="csc"))
            self.H_slots = []
            for s, m, _ in blocks.groups:
                k = (s.stop - s.start) // m
                rows = s.start + np.arange(k)[:, None, None] * m + np.arange(m)[None, :, None]
                colsb = s.start + np.arange(k)[:, None, None] * m + np.arange(m)[None, None, :]
                rows, colsb = np.broadcast_arrays(rows, colsb)
                upper = rows <= colsb
                self.H_slots.append((upper, self._positions(rows[upper], colsb[upper])))

    def _times(self, x: np.ndarray) -> np.ndarray:
        """``(A + H) x`` with ``A = Gk Gk^T``."""
        out = self.Gk @ (self.GkT @ x)
        for (s, m, _), H in zip(self.blocks.groups, self.Hs):
            out[s] += np.einsum("nij,nj->ni", H, x[s].reshape(-1, m)).ravel()
        return out

    def _positions(self, rows, cols):
        # the pattern's entries keyed (column, row), ascending in CSC with sorted indices
        P = self.pattern
        size = np.int64(P.shape[0])
        col_of = np.repeat(np.arange(P.shape[1], dtype=np.int64), np.diff(P.indptr))
        keys = col_of * size + P.indices
        return np.searchsorted(keys, np.asarray(cols, dtype=np.int64) * size
                               + np.asarray(rows, dtype=np.int64))

    def _gather(self, Au):
        Au = Au.tocoo()
        return self._positions(Au.row, Au.col), Au.data

    def factor(self, Hs: list[np.ndarray]) -> None:
        b = self.blocks
        if not self.sparse:
            K = b.A.copy()
            for (s, m, _), H in zip(b.groups, Hs):
                k = (s.stop - s.start) // m
                if m == 1:
                    idx = np.arange(s.start, s.stop)
                    K[idx, idx] += H[:, 0, 0]
                else:
                    base = s.start + np.arange(k) * m
                    for i in range(m):
                        for j in range(m):
                            K[base + i, base + j] += H[:, i, j]
            try:
                self.solver = ("chol", sla.cho_factor(K, lower=False, check_finite=False))
            except np.linalg.LinAlgError:
                self.solver = ("lu", sla.lu_factor(K, check_finite=False))
            return
        self.Hs = Hs
        data = np.zeros(self.pattern.nnz)
        pos, vals = self.A_data
        np.add.at(data, pos, vals)
        for (upper, slots), H in zip(self.H_slots, Hs):
            np.add.at(data, slots, H[upper])
        M = sp.csc_matrix((data, self.pattern.indices, self.pattern.indptr),
                          shape=self.pattern.shape)
        if self.solver is None:
            self.solver = ("augmented" if self.aug_rows else "qdldl",
                           SupernodalLDL(M, upper=True))
        else:
            self.solver[1].update(M, upper=True)

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        kind, f = self.solver
        if kind == "augmented":
            # refined on A + H itself (A x = Gk Gk^T x): the quasi-definite system's answer
            # alone lost digits where H spans many orders near the cones' boundary
            pad = np.zeros(self.aug_rows)
            x = f.solve(np.concatenate([rhs, pad]))[:rhs.shape[0]]
            for _ in range(AUGMENTED_REFINEMENTS):
                x += f.solve(np.concatenate([rhs - self._times(x), pad]))[:rhs.shape[0]]
            return x
        if kind == "chol":
            return sla.cho_solve(f, rhs, check_finite=False)
        if kind == "lu":
            return sla.lu_solve(f, rhs, check_finite=False)
        return f.solve(rhs)


def use_sparse(W, N: int) -> bool:
    """Whether the sparse factorizations serve W (sparse, large and thin enough)."""
    return bool(sp.issparse(W) and N >= SPARSE_MIN_ROWS
                and W.nnz <= SPARSE_MAX_DENSITY * N * N)


def standard_form(W, b: np.ndarray, mu: np.ndarray, d: int, sparse: bool):
    """``(blocks, q, qs)``: the cones made standard and equilibrated, ``q`` the unit-norm
    linear term and ``qs`` its scale (``r = blocks.to_impulse(qs x)``)."""
    blocks = _Blocks(W, mu, d, sparse)
    q = np.asarray(b, dtype=float).ravel()[blocks.cols] * blocks.scale
    qs = max(float(np.linalg.norm(q)), np.finfo(float).tiny)
    return blocks, q / qs, qs


def solve_ccp(W, b: np.ndarray, mu: np.ndarray, d: int, *, tol: float = 1e-8,
              max_iter: int = 100, sparse: bool | None = None,
              G: sp.spmatrix | None = None) -> EngineResult:
    """Solve the CCP ``K ∋ r ⊥ W r + b ∈ K*`` by the interior point alone (W dense, or sparse
    CSR when ``sparse``); the residual reported is the CCP's natural-map residual.

    ``G``, optional (sparse path only): ``W = G G^T`` (N x m, :mod:`.generalized`); each
    iteration's system is then the quasi-definite ``[[H, S G], [(S G)^T, -I]]`` (S the
    equilibration), the same directions to round-off."""
    n = mu.shape[0]
    if sparse is None:
        sparse = use_sparse(W, n * d)
    W = sp.csr_matrix(W) if sparse else (W.toarray() if sp.issparse(W) else W)
    bb = np.asarray(b, dtype=float).reshape(n, d)
    blocks, q, qs = standard_form(W, bb, mu, d, sparse)
    A = blocks.A
    Gk = (sp.diags(blocks.scale) @ sp.csr_matrix(G)[blocks.cols]).tocsc() \
        if sparse and G is not None else None
    factor = _Factor(blocks, sparse, Gk)
    # start (CVXOPT's coneqp): x from (A + I) x = -q, shifted into the cones
    Hs = [np.broadcast_to(np.eye(m), ((s.stop - s.start) // m, m, m)).copy()
          for s, m, _ in blocks.groups]
    factor.factor(Hs)
    x = factor.solve(-q)
    z = _shift_into(blocks, A @ x + q)
    x = _shift_into(blocks, x)
    nu = sum((s.stop - s.start) // m for s, m, _ in blocks.groups)
    best = (np.inf, x, 0)
    message = "iteration limit"
    it = 0
    announce_compilation()
    for it in range(1, max_iter + 1):
        rp = z - A @ x - q
        mu_c = float(x @ z) / nu
        # the cones' scalings, group by group (:mod:`.nt_kernels`, compiled)
        scal = [nt_blocks(x[sl], z[sl], m) for sl, m, _ in blocks.groups]
        Hs = [H for _, _, _, H in scal]
        try:
            factor.factor(Hs)
        except (np.linalg.LinAlgError, ValueError) as exc:
            message = f"factorization failed: {exc}"
            break

        def direction(target):
            # (A + H) dx = T^-1 (lam \ target) + rp;  dz = A dx - rp
            t = np.concatenate([scaled_rhs(v, beta, lam, tg, m) for (v, beta, lam, _), tg,
                                (_, m, _) in zip(scal, target, blocks.groups)])
            dx = factor.solve(t + rp)
            return dx, A @ dx - rp

        target = [affine_target(lam, m) for (_, _, lam, _), (_, m, _) in
                  zip(scal, blocks.groups)]
        dxa, dza = direction(target)
        alpha = _step(blocks, x, z, dxa, dza)
        mu_aff = float((x + alpha * dxa) @ (z + alpha * dza)) / nu
        sigma = min(1.0, max(0.0, mu_aff / max(mu_c, 1e-300))) ** 3
        dx, dz = direction([corrector_target(v, beta, lam, dxa[sl], dza[sl], sigma * mu_c, m)
                            for (v, beta, lam, _), (sl, m, _) in zip(scal, blocks.groups)])
        alpha = min(1.0, STEP_FRACTION * _step(blocks, x, z, dx, dz))
        if not (np.all(np.isfinite(dx)) and np.all(np.isfinite(dz))) or alpha < 1e-8:
            message = "stalled (the step to the cones' boundary vanished)"
            break
        x = x + alpha * dx
        z = z + alpha * dz
        r = blocks.to_impulse(x * qs)
        res, u = cones.natural_map_residual(W, bb, mu, r, coulomb=False)
        if res < best[0]:
            best = (res, x, it)
        if res <= tol:
            message = "converged"
            break
        if mu_c < GAP_FLOOR:
            message = "the complementarity gap reached round-off"
            break
    res, x, _ = best
    r = blocks.to_impulse(x * qs)
    res, u = cones.natural_map_residual(W, bb, mu, r, coulomb=False)
    return EngineResult(r, u, res, it, res <= tol, message if res > tol else "converged")


def _step(blocks: _Blocks, x, z, dx, dz) -> float:
    """The largest step (at most 1e30) keeping x and z in their cones."""
    return min((max_step(x[sl], dx[sl], z[sl], dz[sl], m) for sl, m, _ in blocks.groups),
               default=1e30)
