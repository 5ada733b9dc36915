"""Newton on Coulomb's natural map with a light Levenberg-Marquardt term, for the tries from
the nonsmooth Gauss-Seidel's iterates on large sparse W (:mod:`.gauss_seidel`).

The map and its generalized Jacobian are the finish's (:mod:`.finish`):
``F(r) = r - P_K(r - rho y(r))``, ``y = u + mu |u_t| e_n``, ``u = W r + b``,
``rho_i = 1 / W_nn,i``, ``J = I - D + D rho B W``. A step solves
``min |J dr + F|^2 + lam |dr|^2`` on W's sparse block pattern
(:class:`.sparse_step.SparseStepSystem`) and is followed by a backtracking line search on ``|F|``. The one difference from the
finish is ``lam = LIGHT_LAM |F| / scale`` instead of ``|F| / scale``: on the sphere piles of
624-897 contacts J is ill-conditioned (a step of 1.4e-4 for a map of 5e-7: singular values
near 1e-3), the finish's lam damped exactly those directions and its steps shrank the map
by 0.6 each (9 steps from a residual of 1e-6, 26 from 1e-5); with lam 1000 times lighter
the same starts certified in 2-3 steps (the Newton step itself unchanged, its linear model
matched to 10%).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from .cones import natural_map_residual, project
from .finish import projection_jacobian
from .sparse_step import SparseStepSystem

#: the Levenberg-Marquardt weight relative to the finish's ``|F| / scale``
LIGHT_LAM = 1e-3


def _map(W, b, mu, rho, r):
    n, d = r.shape
    u = (W @ r.ravel()).reshape(n, d) + b
    ut = np.sqrt(np.einsum("ij,ij->i", u[:, 1:], u[:, 1:]))
    y = u.copy()
    y[:, 0] += mu * ut
    v = r - rho[:, None] * y
    return r - project(v, mu), u, ut, v


def light_newton(W: sp.csr_matrix, b: np.ndarray, mu: np.ndarray, r0: np.ndarray, *,
                 tol: float, max_iter: int, system: SparseStepSystem | None = None,
                 stall_steps: int | None = None,
                 lam_factor: float = LIGHT_LAM) -> tuple[np.ndarray, float, int]:
    """Newton steps on Coulomb's natural map from ``r0`` (n, d) until the relative
    natural-map residual (:func:`~.cones.natural_map_residual`) is at most ``tol``, at most
    ``max_iter``, or (``stall_steps``) where the best residual has not halved in the last
    ``stall_steps`` steps, or where the line search finds no decrease.

    ``system``: the step system of W (built here when not given; the caller keeps one per
    problem). Returns the best ``(r, residual, steps)``.
    """
    n, d = r0.shape
    b = np.asarray(b, dtype=float).reshape(n, d)
    if system is None:
        system = SparseStepSystem(W, d)
    wdiag = np.asarray(W.diagonal())[np.arange(n) * d]
    rho = 1.0 / np.maximum(wdiag, max(float(np.max(wdiag, initial=0.0)), 1e-300) * 1e-12)
    r = np.array(r0, dtype=float)
    best_res, _ = natural_map_residual(W, b, mu, r, True)
    best = r.copy()
    F, u, ut, v = _map(W, b, mu, rho, r)
    fn = float(np.linalg.norm(F))
    history = [best_res]
    steps = 0
    bscale = float(np.linalg.norm(b)) * float(rho.max())
    for _ in range(max_iter):
        if best_res <= tol:
            break
        if stall_steps is not None and steps >= stall_steps and \
                best_res > 0.5 * history[steps - stall_steps]:
            break
        D = projection_jacobian(v, mu)
        scale = max(float(np.linalg.norm(r)), bscale, 1e-300)
        DB = D * rho[:, None, None]
        slide = (ut > 0.0) & (mu > 0.0)
        if np.any(slide):
            th = u[slide, 1:] / ut[slide, None]
            DB[slide, :, 1:] += DB[slide, :, 0:1] * (mu[slide, None, None] * th[:, None, :])
        try:
            dr = system.solve(D, DB, lam_factor * fn / scale, F.ravel())
        except RuntimeError:  # QDLDL: the system is not quasi-definite to round-off
            break
        if not np.all(np.isfinite(dr)):
            break
        dr = dr.reshape(n, d)
        t = 1.0
        for _ in range(30):  # backtracking (Armijo) on |F|
            mapped = _map(W, b, mu, rho, r + t * dr)
            ft = float(np.linalg.norm(mapped[0]))
            if ft <= (1.0 - 1e-4 * t) * fn:
                break
            t *= 0.5
        else:
            break
        steps += 1
        r = r + t * dr
        fn = ft
        F, u, ut, v = mapped
        res, _ = natural_map_residual(W, b, mu, r, True)
        if res < best_res:
            best_res, best = res, r.copy()
        history.append(best_res)
    return best, float(best_res), steps
