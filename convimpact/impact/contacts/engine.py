"""The contact engine: a primal-dual interior point on the cone complementarity problem
``K ∋ r ⊥ u = W r + b ∈ K*`` (the convex relaxation of Coulomb's law, ``ccp``), finished by
Newton (:mod:`.finish`); Coulomb's law in De Saxce's form by Newton from the CCP's answer, or
where that misses, by an ADMM (:mod:`.admm_kernel` compiled, :mod:`.admm` on large sparse W)
and Newton again. :func:`solve` is the entry; small problems go first to the compiled dense
kernels of the same method, and up to :data:`ADMM_FIRST_MAX_ROWS` rows the compiled ADMM from
zero gets a bounded try first (before the kernels above :data:`ADMM_FIRST_MIN_ROWS` rows).

The problem is the optimality system of the convex program ``min 1/2 r^T W r + b^T r`` over
the product K of friction cones; W is only positive semidefinite (a stack of boxes has more
contact rows than degrees of freedom), and then the impulses are not unique but the velocity
``u`` is. The method (Mehrotra's predictor-corrector with Nesterov-Todd scaling, as in
CVXOPT's ``coneqp``; :mod:`.cones`):

* the cones are made standard (``r = D x``) and each contact is equilibrated by its own
  effective mass ``sqrt(W_nn)``;
* every iteration solves ``(A + H) dx = rhs`` with ``A`` the equilibrated W and ``H`` the
  block-diagonal Nesterov-Todd term, positive definite inside the cones: a singular W needs no
  regularization, and the iterates follow the central path to the analytic centre of the set of
  solutions (a unique, documented choice of the indeterminate impulses);
* dense W: one LAPACK Cholesky per iteration; sparse W: a sparse LDL^T (QDLDL) whose symbolic
  analysis is made once and reused (H keeps W's pattern plus its own diagonal blocks).

The answer is accepted on the natural-map residual in the original data
(:func:`.cones.natural_map_residual`) and never returned above ``tol``: the caller raises.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import qdldl
import scipy.linalg as sla
import scipy.sparse as sp

from . import cones
from .admm import coulomb_admm
from .admm_kernel import dense_admm, natural_residual
from .finish import newton_finish
from .fixed_point import shift_fixed_point
from .threads import one_blas_thread

#: the interior-point path's parameters (Mehrotra): the fraction of the step to the boundary
STEP_FRACTION = 0.99
#: contact rows up to which the compiled dense kernels (:mod:`.interior_point`,
#: :mod:`.natural_map`, :mod:`.newton`: the same interior point and Newton finish, compiled
#: with a dense unblocked factorization) are tried first; above, and where their answer is
#: not certified, the vectorized dense/sparse backend of this module takes the problem
COMPILED_MAX_ROWS = 120
#: the compiled kernels' interior-point tolerance before their Newton finish
HANDOVER_TOL = 1e-9
_KERNELS = None
#: the interior point stops at this gap (unit data): the Newton finish takes over from here
GAP_FLOOR = 1e-14
#: up to this many rows, the compiled ADMM from zero runs first (for Coulomb's law at most
#: :data:`ADMM_FIRST_ITER` iterations, Newton tried on its way; it needed 80-1,900 on the
#: corpus's walls, piles and robots of 40-300 rows, 4,500-10,000 on its stacks)...
ADMM_FIRST_MAX_ROWS = 300
#: ...before the compiled kernels above this many rows, after them below
ADMM_FIRST_MIN_ROWS = 40
ADMM_FIRST_ITER = 5000
#: ...ending at this many times the iterations to 1e-5 where Newton failed from there (the
#: stacks' ADMM crawls from 1e-5 on: 520 iterations to 1e-5, 6,700 to 1e-8 on two humanoids
#: and two quadrupeds)
ADMM_FIRST_PATIENCE = 3.0
#: ...and for the CCP, from :data:`COMPILED_MAX_ROWS` rows (whose interior point is sure and
#: fast: the ADMM gets a short try)
ADMM_FIRST_ITER_CCP = 300
#: Coulomb's law: the ADMM from the CCP answer is the compiled dense one
#: (:mod:`.admm_kernel`) for W dense or up to this many rows; above, :mod:`.admm` on W's
#: sparse factorization (per iteration the dense one was 1.5-1.8x faster than it at 380-400
#: rows on piles, 1.5x slower at 670 on a wall)
DENSE_ADMM_MAX_ROWS = 450
#: Newton steps on Coulomb's natural map straight from the CCP answer, up to
#: :data:`SPARING_NEWTON_MAX_ROWS` rows or on dense W (when it converges from there it does
#: in 1-4; else the ADMM's way is the cheaper one); 10 above, where the ADMM of :mod:`.admm`
#: also tries Newton more often (the sphere piles of 624-897 contacts)
DIRECT_NEWTON_STEPS = 4
SPARING_NEWTON_MAX_ROWS = 900
#: Newton steps of a try from an ADMM iterate (within 1e-5 it converges in 1-4 where it does)
POLISH_STEPS = 4
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
    """Factorizations of ``A + H`` (H block diagonal), dense or sparse."""

    def __init__(self, blocks: _Blocks, sparse: bool):
        self.blocks, self.sparse = blocks, sparse
        self.solver = None
        if sparse:
            # W's pattern and the cones' diagonal blocks (every entry counted positive)
            rows, cols = [], []
            for s, m, _ in blocks.groups:
                k = (s.stop - s.start) // m
                base = s.start + np.arange(k)[:, None, None] * m
                rows.append((base + np.arange(m)[None, :, None]).repeat(m, 2).ravel())
                cols.append((base + np.arange(m)[None, None, :]).repeat(m, 1).ravel())
            rows, cols = np.concatenate(rows), np.concatenate(cols)
            P = abs(blocks.A) + sp.csc_matrix((np.ones(rows.size), (rows, cols)),
                                              shape=(blocks.size, blocks.size))
            self.pattern = sp.triu(P, format="csc")
            self.pattern.sum_duplicates()
            self.pattern.sort_indices()
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

    def _positions(self, rows, cols):
        P = self.pattern
        pos = np.empty(rows.size, dtype=np.int64)
        for j in np.unique(cols):
            sel = cols == j
            start, stop = P.indptr[j], P.indptr[j + 1]
            pos[sel] = start + np.searchsorted(P.indices[start:stop], rows[sel])
        return pos

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
        data = np.zeros(self.pattern.nnz)
        pos, vals = self.A_data
        np.add.at(data, pos, vals)
        for (upper, slots), H in zip(self.H_slots, Hs):
            np.add.at(data, slots, H[upper])
        M = sp.csc_matrix((data, self.pattern.indices, self.pattern.indptr),
                          shape=self.pattern.shape)
        if self.solver is None:
            self.solver = ("qdldl", qdldl.Solver(M))
        else:
            self.solver[1].update(M)

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        kind, f = self.solver
        if kind == "chol":
            return sla.cho_solve(f, rhs, check_finite=False)
        if kind == "lu":
            return sla.lu_solve(f, rhs, check_finite=False)
        return f.solve(rhs)


def kernels():
    """The compiled kernels (:mod:`.newton`), imported on first use (compiled then, or loaded
    from numba's on-disk cache, with a message when that takes long)."""
    global _KERNELS
    if _KERNELS is None:
        from . import newton
        from ...compiled import announce

        announce("several-contact interior kernels", 25, newton.solve_law, newton.ccp_kernel,
                 newton.coulomb_kernel)
        _KERNELS = newton
    return _KERNELS


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
              max_iter: int = 100, sparse: bool | None = None) -> EngineResult:
    """Solve the CCP ``K ∋ r ⊥ W r + b ∈ K*`` by the interior point alone (W dense, or sparse
    CSR when ``sparse``); the residual reported is the CCP's natural-map residual."""
    n = mu.shape[0]
    if sparse is None:
        sparse = use_sparse(W, n * d)
    W = sp.csr_matrix(W) if sparse else (W.toarray() if sp.issparse(W) else W)
    bb = np.asarray(b, dtype=float).reshape(n, d)
    blocks, q, qs = standard_form(W, bb, mu, d, sparse)
    A = blocks.A
    factor = _Factor(blocks, sparse)
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
    for it in range(1, max_iter + 1):
        rp = z - A @ x - q
        mu_c = float(x @ z) / nu
        xs, zs = blocks.cone_rows(x), blocks.cone_rows(z)
        scal = [cones.nt_scaling(xi, zi) for xi, zi in zip(xs, zs)]
        Hs = [np.einsum("nij,njk->nik", Gi, Gi) for _, Gi, _ in scal]
        try:
            factor.factor(Hs)
        except (np.linalg.LinAlgError, ValueError) as exc:
            message = f"factorization failed: {exc}"
            break

        def direction(target):
            # (A + H) dx = G^-1 (lam \ target) + rp;  dz = A dx - rp
            t = np.concatenate([np.einsum("nij,nj->ni", Gi, cones.jsolve(lam, tg)).ravel()
                                for (G, Gi, lam), tg in zip(scal, target)])
            dx = factor.solve(t + rp)
            return dx, A @ dx - rp

        lams = [lam for _, _, lam in scal]
        target = [-cones.jprod(lam, lam) for lam in lams]
        dxa, dza = direction(target)
        alpha = _step(blocks, x, z, dxa, dza)
        mu_aff = float((x + alpha * dxa) @ (z + alpha * dza)) / nu
        sigma = min(1.0, max(0.0, mu_aff / max(mu_c, 1e-300))) ** 3
        target = []
        for (G, Gi, lam), dxi, dzi in zip(scal, blocks.cone_rows(dxa), blocks.cone_rows(dza)):
            e = np.zeros_like(lam)
            e[:, 0] = 1.0
            sx = np.einsum("nij,nj->ni", Gi, dxi)
            sz = np.einsum("nij,nj->ni", G, dzi)
            target.append(sigma * mu_c * e - cones.jprod(lam, lam) - cones.jprod(sx, sz))
        dx, dz = direction(target)
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
    a = 1e30
    for v, dv in ((x, dx), (z, dz)):
        for rows, drows in zip(blocks.cone_rows(v), blocks.cone_rows(dv)):
            a = min(a, cones.max_step(rows, drows))
    return a


def solve(W, b: np.ndarray, mu: np.ndarray, d: int, *, coulomb: bool, tol: float = 1e-8,
          max_iter: int = 100, newton_iter: int = 30, admm_iter: int = 20000,
          sparse: bool | None = None, compiled: bool = True,
          start: np.ndarray | None = None) -> EngineResult:
    """The engine.

    With ``compiled``: from :data:`ADMM_FIRST_MIN_ROWS` to :data:`ADMM_FIRST_MAX_ROWS` rows the
    compiled ADMM from zero (:func:`.admm_kernel.dense_admm`, at most
    :data:`ADMM_FIRST_ITER` iterations for Coulomb's law, :data:`ADMM_FIRST_ITER_CCP` for the
    CCP, Newton tried from its iterate within 1e-5); then up to :data:`COMPILED_MAX_ROWS` rows
    the compiled dense kernels (interior point and Newton), and below
    :data:`ADMM_FIRST_MIN_ROWS` rows the ADMM's try after them. Each answer is kept when its
    natural-map residual is at most ``tol``. Then the CCP: the interior point, and the Newton
    finish where it stops short of ``tol`` (skipped when the compiled CCP kernel's answer is
    certified). Coulomb's law: Newton on its natural map from the CCP's answer
    (:data:`DIRECT_NEWTON_STEPS`); where that does not reach ``tol``, the ADMM from there
    (compiled on dense W and up to :data:`DENSE_ADMM_MAX_ROWS` rows, else :mod:`.admm` on the
    sparse factorization), Newton tried as it comes within 1e-5 (1e-4 in :mod:`.admm`), then
    the fixed point on De Saxce's shift (:mod:`.fixed_point`).

    ``start`` (n, d), optional, is a warm start (a time-stepping scheme's impulses of the
    previous step): the law's Newton finish (:func:`warm_newton`) runs from it first, and its
    answer is returned when its natural-map residual is at most ``tol``; otherwise the cold
    path above runs as without it (the warm attempt's steps are counted in ``iterations``).
    The interior point itself is not warm-started: its iterates must stay central, and a
    start on the cones' boundary (where impulses of sliding or open contacts lie) slows it.
    """
    n = mu.shape[0]
    warm_steps = 0
    if start is not None:
        R = warm_newton(W, b, mu, d, start, coulomb=coulomb, tol=tol, newton_iter=newton_iter,
                        sparse=sparse, compiled=compiled)
        if R.converged:
            return R
        warm_steps = R.iterations
    R = _cold(W, b, mu, d, coulomb, tol, max_iter, newton_iter, admm_iter, sparse, compiled)
    if warm_steps:
        R = EngineResult(R.impulse, R.velocity, R.residual, R.iterations + warm_steps,
                         R.converged, R.message)
    return R


def warm_newton(W, b: np.ndarray, mu: np.ndarray, d: int, start: np.ndarray, *,
                coulomb: bool, tol: float = 1e-8, newton_iter: int = 30,
                sparse: bool | None = None, compiled: bool = True) -> EngineResult:
    """Newton on the law's natural map from ``start`` (n, d) alone: the compiled finish of the
    kernels (on their scaled program) up to :data:`COMPILED_MAX_ROWS` rows, the vectorized
    :func:`.finish.newton_finish` above. ``converged`` when the natural-map residual of the
    answer, on the original data, is at most ``tol``."""
    n = mu.shape[0]
    start = np.asarray(start, dtype=float).reshape(n, d)
    bb = np.asarray(b, dtype=float).reshape(n, d)
    if compiled and n * d <= COMPILED_MAX_ROWS:
        K = kernels()
        Wd = np.ascontiguousarray(W.toarray() if sp.issparse(W) else W, dtype=float)
        m = np.ascontiguousarray(mu, dtype=float)
        P, q, idx, scale, starts, sizes, f, trivial = K.scaled_program(Wd, bb.ravel().copy(),
                                                                        m, d)
        if trivial:
            r, steps = np.zeros((n, d)), 0
        else:
            x = start.ravel()[idx[:q.shape[0]]] / (scale[:q.shape[0]] * f)
            x, _, steps = K.natural_map_newton(P, q, np.ascontiguousarray(x), starts, sizes,
                                               min(newton_iter, 20), coulomb)
            r = np.zeros(n * d)
            r[idx[:q.shape[0]]] = scale[:q.shape[0]] * f * x
            r = r.reshape(n, d)
        res, u = cones.natural_map_residual(Wd, bb, m, r, coulomb)
    else:
        if sparse is None:
            sparse = use_sparse(W, n * d)
        W = sp.csr_matrix(W) if sparse else (W.toarray() if sp.issparse(W) else W)
        with one_blas_thread(), np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            r, res, steps = newton_finish(W, bb, mu, start, coulomb=coulomb, tol=tol,
                                          max_iter=newton_iter, sparse=sparse)
            res, u = cones.natural_map_residual(W, bb, mu, r, coulomb)
    ok = bool(res <= tol)
    return EngineResult(r, u, float(res), int(steps), ok,
                        "converged (warm start)" if ok else "warm start not certified")


def _cold(W, b, mu, d, coulomb, tol, max_iter, newton_iter, admm_iter, sparse, compiled):
    n = mu.shape[0]
    ccp = None
    admm_first = compiled and n * d <= ADMM_FIRST_MAX_ROWS
    # the CCP's compiled kernels are fast and sure on their rows: its ADMM try comes above
    if admm_first and n * d > (ADMM_FIRST_MIN_ROWS if coulomb else COMPILED_MAX_ROWS):
        # the compiled interior point's dense Newton grows as rows^3: the ADMM first
        R = _admm_first(W, b, mu, d, coulomb, tol, newton_iter, compiled)
        if R.converged:
            return R
        admm_first = False
    if compiled and n * d <= COMPILED_MAX_ROWS:
        R = _compiled(W, b, mu, d, coulomb, tol, max_iter, newton_iter)
        if R is not None and R.converged:
            return R
    if admm_first and coulomb:
        R = _admm_first(W, b, mu, d, coulomb, tol, newton_iter, compiled)
        if R.converged:
            return R
    if compiled and n * d <= COMPILED_MAX_ROWS:
        if coulomb:  # the compiled CCP answer, Coulomb's start below
            ccp = _compiled(W, b, mu, d, False, tol, max_iter, newton_iter)
            ccp = ccp if ccp is not None and ccp.converged else None
    with one_blas_thread(), np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        return _solve(W, b, mu, d, coulomb, tol, max_iter, newton_iter, admm_iter, sparse,
                      ccp)


def _admm_first(W, b, mu, d, coulomb, tol, newton_iter, compiled) -> EngineResult:
    """Coulomb's law by the compiled ADMM from zero (Pinocchio's start), at most
    :data:`ADMM_FIRST_ITER` iterations, Newton (:func:`warm_newton`) tried on its way."""
    n = mu.shape[0]
    Wd = W.toarray() if sp.issparse(W) else np.asarray(W, dtype=float)
    bb = np.asarray(b, dtype=float).reshape(n, d)
    steps = [0]

    def polish(r):
        # the compiled finish (complete pivoting, rows^3 per step in loops) on the smallest
        # problems, LAPACK's above
        R = warm_newton(Wd, bb, mu, d, r, coulomb=coulomb, tol=tol,
                        newton_iter=min(newton_iter, POLISH_STEPS), sparse=False,
                        compiled=compiled and n * d <= ADMM_FIRST_MIN_ROWS)
        steps[0] += R.iterations
        return R.impulse, R.residual, R.iterations

    with one_blas_thread(), np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        r, _, it = dense_admm(Wd, bb, mu, d, np.zeros((n, d)), tol=tol,
                              max_iter=ADMM_FIRST_ITER if coulomb else ADMM_FIRST_ITER_CCP,
                              polish=polish, coulomb=coulomb, patience=ADMM_FIRST_PATIENCE)
        res, u = cones.natural_map_residual(Wd, bb, mu, r, coulomb=coulomb)
    ok = bool(res <= tol)
    return EngineResult(r, u, float(res), it + steps[0], ok, "converged" if ok else "")


def _compiled(W, b, mu, d, coulomb, tol, max_iter, newton_iter) -> EngineResult:
    """The compiled kernels' answer (``converged`` when certified at ``tol``)."""
    K = kernels()
    n = mu.shape[0]
    Wd = np.ascontiguousarray(W.toarray() if sp.issparse(W) else W, dtype=float)
    bb = np.ascontiguousarray(b, dtype=float).reshape(-1)
    m = np.ascontiguousarray(mu, dtype=float)
    kernel = K.coulomb_kernel if coulomb else K.ccp_kernel
    pi, status, it, steps, _, _ = kernel(Wd, bb, m, d, HANDOVER_TOL, max_iter,
                                         min(newton_iter, 20))
    r = pi.reshape(n, d)
    # the natural-map residual of cones.natural_map_residual, compiled (its Python form
    # cost as much as the kernel on the smallest problems); u = W r + b comes with it
    u, y, p = np.empty(n * d), np.empty(n * d), np.empty(n * d)
    res = float(natural_residual(Wd, bb, m, d, pi, coulomb, u, y, p))
    ok = bool(res <= tol)
    return EngineResult(r, u.reshape(n, d), res, int(it) + int(steps), ok,
                        "converged" if ok else "")


def _solve(W, b, mu, d, coulomb, tol, max_iter, newton_iter, admm_iter, sparse, ccp=None):
    n = mu.shape[0]
    if sparse is None:
        sparse = use_sparse(W, n * d)
    W = sp.csr_matrix(W) if sparse else (W.toarray() if sp.issparse(W) else W)
    b = np.asarray(b, dtype=float).reshape(n, d)
    R = ccp if ccp is not None else solve_ccp(W, b, mu, d, tol=tol, max_iter=max_iter,
                                              sparse=sparse)
    iterations = R.iterations
    if R.residual > tol:
        r, res, k = newton_finish(W, b, mu, R.impulse, coulomb=False, tol=tol,
                                  max_iter=newton_iter, sparse=sparse)
        iterations += k
        if res < R.residual:
            res, u = cones.natural_map_residual(W, b, mu, r, coulomb=False)
            R = EngineResult(r, u, res, iterations, res <= tol,
                             "converged" if res <= tol else R.message)
    if not coulomb:
        return R
    dense_admm_here = not sparse or n * d <= DENSE_ADMM_MAX_ROWS
    sparing = dense_admm_here or n * d <= SPARING_NEWTON_MAX_ROWS
    r, res, k = newton_finish(W, b, mu, R.impulse, coulomb=True, tol=tol,
                              max_iter=min(newton_iter, DIRECT_NEWTON_STEPS if sparing
                                            else 10), sparse=sparse)
    iterations += k
    best = [res, r, "converged"]
    if res > tol:
        tried = [np.inf]

        def check(r):
            nonlocal iterations
            res, _ = cones.natural_map_residual(W, b, mu, r, coulomb=True)
            if res < best[0]:
                best[:2] = res, r
            if best[0] <= tol:
                return True
            # sparing: Newton tried from within 1e-5, then after each drop by 1000 (as the
            # compiled ADMM's polish); else on each drop by 100 below 1e-4, and every 20
            # checks below 1e-2 (on the largest sparse problems those tries took the sphere
            # pile of 624 contacts to 8e-7, a geometric spacing to 8e-4 only)
            if (res < min(1e-5, 1e-3 * tried[0]) if sparing else
                    res < min(1e-4, 1e-2 * tried[0]) or (res < 1e-2 and len(tried) % 20 == 0)):
                tried[0] = res
                rn, resn, k = newton_finish(W, b, mu, r, coulomb=True, tol=tol,
                                            max_iter=min(newton_iter, POLISH_STEPS if sparing
                                                         else 10), sparse=sparse)
                iterations += k
                if resn < best[0]:
                    best[:2] = resn, rn
            tried.append(res)
            return best[0] <= tol

        # the ADMM from the CCP answer (from zero, Pinocchio's start, was 4x faster on a
        # brick wall but 1.2-3x slower on most of the corpus, and running both cost that)
        done = 0
        if dense_admm_here:  # compiled, dense

            def polish(r):
                nonlocal iterations
                rn, resn, k = newton_finish(W, b, mu, r, coulomb=True, tol=tol,
                                            max_iter=min(newton_iter, POLISH_STEPS),
                                            sparse=sparse)
                iterations += k
                return rn, resn, k

            Wd = W.toarray() if sp.issparse(W) else W
            r, _, done = dense_admm(Wd, b, mu, d, R.impulse, tol=tol, max_iter=admm_iter,
                                    polish=polish)
            res, _ = cones.natural_map_residual(W, b, mu, r, coulomb=True)
            if res < best[0]:
                best[:2] = res, r
        else:
            run = coulomb_admm(W, b, mu, R.impulse, sparse)
            while done < admm_iter:
                done += 10
                if check(next(run)):
                    break
        iterations += done
        iterations += k
        best[2] = "the ADMM's iteration limit" if best[0] > tol else "converged"
        if best[0] > tol:  # the fixed point on the De Saxce shift, CCP by CCP
            for r in shift_fixed_point(W, b, mu, d, best[1], tol, max_iter, sparse, solve_ccp):
                iterations += 1
                if check(r):
                    best[2] = "converged"
                    break
            else:
                best[2] = "the ADMM's and the fixed point's iteration limits"
    res, u = cones.natural_map_residual(W, b, mu, best[1], coulomb=True)
    return EngineResult(best[1], u, res, iterations, res <= tol,
                        "converged" if res <= tol else f"Coulomb's law not solved ({best[2]})")

