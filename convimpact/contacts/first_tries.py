"""The contact engine's first tries (:mod:`.engine`, :func:`.engine.solve`), before its
general way: the compiled dense kernels (:mod:`.interior_point`, :mod:`.newton`: the interior
point and Newton finish, up to :data:`COMPILED_MAX_ROWS` rows), the compiled ADMM from zero
(:func:`admm_first`, :data:`ADMM_FIRST_MAX_ROWS` rows at most) and Newton from a warm start
(:func:`warm_newton`, a time-stepping scheme's previous impulses). Each answer is judged on
the natural-map residual of the original data.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from . import cones
from .admm import RELAX
from .admm_kernel import dense_admm, natural_residual
from .ccp_interior import EngineResult, use_sparse
from .finish import newton_finish
from .light_direct import on_cones
from .threads import one_blas_thread

#: rows up to which the compiled dense kernels (:mod:`.interior_point`, :mod:`.natural_map`,
#: :mod:`.newton`: the same interior point and Newton finish) are tried; above, and where
#: their answer is not certified, the vectorized backend of :mod:`.engine` takes the problem
COMPILED_MAX_ROWS = 120
#: the compiled kernels' interior-point tolerance before their Newton finish
HANDOVER_TOL = 1e-9
_KERNELS = None
#: up to this many rows, the compiled ADMM from zero runs first (for Coulomb's law at most
#: :data:`ADMM_FIRST_ITER` iterations, Newton tried on its way: 80-1,900 at 40-300 rows)...
ADMM_FIRST_MAX_ROWS = 300
#: ...before the compiled kernels above this many rows, after them below
ADMM_FIRST_MIN_ROWS = 40
ADMM_FIRST_ITER = 5000
#: ...ending at this many times the iterations to 1e-5 where Newton failed from there (a
#: 100-box stack: certified at 2.8 times with Newton's full weight, at once with the light)...
ADMM_FIRST_PATIENCE = 3.0
#: ...and at once up to :data:`COMPILED_MAX_ROWS` rows, whose compiled kernels are cheap (at
#: 3 the try lost 1,800 iterations, 2-3x the kernels' time, on 24 robot feet)
ADMM_FIRST_PATIENCE_SMALL = 1.0
#: ...or after a batch of 200 iterations that lowered its best less than this (certified tries:
#: 40-500x a batch; 2-5x on 24 robot feet and 40 planar blocks, 600 and 2,000 iterations lost)
ADMM_FIRST_CRAWL = 10.0
#: ...its Newton tries lightly damped (``damping`` of :func:`.finish.newton_finish`), 8 steps;
#: over-relaxed (:data:`RELAX`) where no compiled kernels follow (1.2-2x fewer iterations)
ADMM_FIRST_DAMPING, ADMM_FIRST_POLISH_STEPS = 1e-3, 8
#: ...and for the CCP (from :data:`COMPILED_MAX_ROWS` rows: below, its kernels are sure, fast)
ADMM_FIRST_ITER_CCP = 300


def kernels():
    """The compiled kernels (:mod:`.newton`), imported on first use (compiled then, or loaded
    from numba's on-disk cache, with a message when that takes long)."""
    global _KERNELS
    if _KERNELS is None:
        from . import newton
        from ..compiled import announce

        announce("contact engine kernels", 25, newton.ccp_kernel, newton.coulomb_kernel)
        _KERNELS = newton
    return _KERNELS

def warm_newton(W, b: np.ndarray, mu: np.ndarray, d: int, start: np.ndarray, *,
                coulomb: bool, tol: float = 1e-8, newton_iter: int = 30,
                sparse: bool | None = None, compiled: bool = True, damping: float = 1.0
                ) -> EngineResult:
    """Newton on the law's natural map from ``start`` (n, d) alone: the compiled finish of the
    kernels (on their scaled program) up to :data:`COMPILED_MAX_ROWS` rows, the vectorized
    :func:`.finish.newton_finish` above (its weight times ``damping``). ``converged`` when the
    natural-map residual of the answer, on the original data, is at most ``tol``."""
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
                                          max_iter=newton_iter, sparse=sparse, damping=damping)
            res, u = cones.natural_map_residual(W, bb, mu, r, coulomb)
    ok = bool(res <= tol)
    return EngineResult(r, u, float(res), int(steps), ok,
                        "converged (warm start)" if ok else "warm start not certified")

def admm_first(W, b, mu, d, coulomb, tol, newton_iter, compiled) -> EngineResult:
    """Coulomb's law by the compiled ADMM from zero (Pinocchio's start), at most
    :data:`ADMM_FIRST_ITER` iterations, Newton (:func:`warm_newton`) tried on its way."""
    n = mu.shape[0]
    Wd = W.toarray() if sp.issparse(W) else np.asarray(W, dtype=float)
    bb = np.asarray(b, dtype=float).reshape(n, d)
    steps = [0]

    def polish(r):
        # the compiled finish (complete pivoting, rows^3 loops) on the smallest, LAPACK's above
        R = warm_newton(Wd, bb, mu, d, r, coulomb=coulomb, tol=tol,
                        newton_iter=min(newton_iter, ADMM_FIRST_POLISH_STEPS), sparse=False,
                        compiled=compiled and n * d <= ADMM_FIRST_MIN_ROWS,
                        damping=ADMM_FIRST_DAMPING)
        steps[0] += R.iterations
        return R.impulse, R.residual, R.iterations

    small = n * d <= COMPILED_MAX_ROWS  # (over-relaxed, 24 robot feet lost a Newton try: 2x)
    with one_blas_thread(), np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        r, _, it = dense_admm(Wd, bb, mu, d, np.zeros((n, d)), tol=tol,
                              max_iter=ADMM_FIRST_ITER if coulomb else ADMM_FIRST_ITER_CCP,
                              polish=polish, coulomb=coulomb,
                              patience=ADMM_FIRST_PATIENCE_SMALL if small else ADMM_FIRST_PATIENCE,
                              crawl=ADMM_FIRST_CRAWL if small else None,
                              relax=1.0 if small else RELAX)
        r, res, u = on_cones(Wd, bb, mu, r, coulomb, tol)  # Newton's answer on the cones
    ok = bool(res <= tol)
    return EngineResult(r, u, float(res), it + steps[0], ok, "converged" if ok else "")


def compiled_answer(W, b, mu, d, coulomb, tol, max_iter, newton_iter) -> EngineResult:
    """The compiled kernels' answer (``converged`` when certified at ``tol``)."""
    K = kernels()
    n = mu.shape[0]
    Wd = np.ascontiguousarray(W.toarray() if sp.issparse(W) else W, dtype=float)
    bb = np.ascontiguousarray(b, dtype=float).reshape(-1)
    m = np.ascontiguousarray(mu, dtype=float)
    pi, _, it, steps, _, _ = (K.coulomb_kernel if coulomb else K.ccp_kernel)(
        Wd, bb, m, d, HANDOVER_TOL, max_iter, min(newton_iter, 20))
    # cones.natural_map_residual compiled (in Python as costly as the kernel); u = W r + b
    u, y, p = np.empty(n * d), np.empty(n * d), np.empty(n * d)
    res = float(natural_residual(Wd, bb, m, d, pi, coulomb, u, y, p))
    ok = bool(res <= tol)
    return EngineResult(pi.reshape(n, d), u.reshape(n, d), res, int(it) + int(steps), ok,
                        "converged" if ok else "")
