"""The engine's finish: a semismooth Newton method on the natural map of the contact problem,
regularized (Levenberg-Marquardt) so that redundant contacts do not stop it.

``F(r) = r - P_K(r - rho y(r))`` per contact, ``y = u = W r + b`` (CCP) or
``y = u + mu |u_t| e_n`` (Coulomb's law in De Saxce's form), ``rho_i = 1 / W_nn,i`` (the
contact's effective mass: the map is then dimensionally an impulse). Its generalized
Jacobian is ``I - D (I - rho B W)`` with D the projection's Jacobian (:func:`projection_jacobian`)
and ``B = I + e_n mu t^T`` per sliding contact for Coulomb's law (``t = u_t / |u_t|``).

A step solves ``min |J dr + F|^2 + lam |dr|^2`` with ``lam = |F| / scale`` (Yamashita &
Fukushima's choice: quadratic convergence where the solutions are locally an error bound's
set, singular J included), dense by LAPACK or sparse through the quasi-definite system
``[[lam I, J^T], [J, -I]]`` (QDLDL), followed by a backtracking line search on ``|F|``.
"""

from __future__ import annotations

import warnings

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

from .cones import natural_map_residual, project
from .lowrank import SPARSE_FLOP_COST, DelassusFactor, lowrank_step
from .lowrank_sparse import SparseLowRankStep
from .sparse_step import SparseStepSystem


def projection_jacobian(v: np.ndarray, mu: np.ndarray) -> np.ndarray:
    """The Jacobian (n, d, d) of :func:`~.cones.project` at ``v`` (n, d): I inside the cone,
    0 in its polar, and on the boundary ray the derivative of the closed form."""
    n, d = v.shape
    D = np.zeros((n, d, d))
    vn = v[:, 0]
    vt = v[:, 1:]
    t = np.sqrt(np.einsum("ij,ij->i", vt, vt))
    inside = t <= mu * vn
    polar = mu * t <= -vn
    D[inside] = np.eye(d)
    side = ~(inside | polar)
    if np.any(side):
        m, ts = mu[side], t[side]
        th = vt[side] / ts[:, None]
        c = 1.0 / (1.0 + m * m)
        pn = (vn[side] + m * ts) * c
        D[side, 0, 0] = c
        D[side, 0, 1:] = (m * c)[:, None] * th
        D[side, 1:, 0] = (m * c)[:, None] * th
        outer = th[:, :, None] * th[:, None, :]
        eye = np.eye(d - 1)
        D[side, 1:, 1:] = ((m * m * c)[:, None, None] * outer
                           + (m * pn / ts)[:, None, None] * (eye - outer))
    frictionless = mu <= 0.0
    D[frictionless, :, :] = 0.0
    D[frictionless, 0, 0] = (vn[frictionless] > 0.0).astype(float)
    return D


def _block_diag(blocks: np.ndarray, sparse: bool):
    n, d, _ = blocks.shape
    if not sparse:
        out = np.zeros((n, d, n, d))
        idx = np.arange(n)
        out[idx, :, idx, :] = blocks
        return out.reshape(n * d, n * d)
    rows = (np.arange(n)[:, None, None] * d + np.arange(d)[None, :, None]).repeat(d, 2)
    cols = (np.arange(n)[:, None, None] * d + np.arange(d)[None, None, :]).repeat(d, 1)
    return sp.csr_matrix((blocks.ravel(), (rows.ravel(), cols.ravel())), shape=(n * d, n * d))


def _map(W, b, mu, rho, r, coulomb):
    n, d = r.shape
    u = (W @ r.ravel()).reshape(n, d) + b
    y = u.copy()
    ut = np.sqrt(np.einsum("ij,ij->i", u[:, 1:], u[:, 1:]))
    if coulomb:
        y[:, 0] += mu * ut
    v = r - rho[:, None] * y
    return r - project(v, mu), u, ut, v


def newton_finish(W, b: np.ndarray, mu: np.ndarray, r0: np.ndarray, *, coulomb: bool,
                  tol: float, max_iter: int = 30, sparse: bool = False,
                  factor: DelassusFactor | None = None,
                  stall_steps: int | None = None,
                  first: tuple[int, float] | None = None, damping: float = 1.0,
                  step_system: SparseStepSystem | None = None
                  ) -> tuple[np.ndarray, float, int]:
    """Newton steps on the natural map from ``r0`` (n, d) until the relative natural-map
    residual (:func:`~.cones.natural_map_residual`) is at most ``tol``.

    ``factor``, optional: W's low-rank factor (:class:`~.lowrank.DelassusFactor`), decided
    on the first step (from that step's cost); where it is chosen, the steps are solved
    through it (:func:`~.lowrank.lowrank_step`, the same step to round-off).

    ``stall_steps``, optional: stop where the best residual has not halved in the last
    ``stall_steps`` steps (Newton converging drops it faster; a try far from its region of
    fast convergence crawls).

    ``first = (k, drop)``, optional: stop after ``k`` steps where the best residual is above
    ``drop`` times the start's (a try judged on its first steps' contraction).

    ``damping``: the Levenberg-Marquardt weight is ``damping |F| / scale`` (1: Yamashita and
    Fukushima's choice above; the NSGS's tries on the sphere piles take 1e-3:
    :data:`.gauss_seidel.NSGS_NEWTON_DAMPING`). ``step_system``, optional: the sparse step
    system of W (:class:`~.sparse_step.SparseStepSystem`) for ``sparse`` without ``factor``,
    kept by a caller that runs many tries on one W. Where the sparse system is not
    quasi-definite to round-off (a tiny weight near the answer), the steps stop there.

    Returns the best ``(r, residual, steps)`` reached.
    """
    n, d = r0.shape
    b = np.asarray(b, dtype=float).reshape(n, d)
    wdiag = np.asarray(W.diagonal() if sp.issparse(W) else np.diag(W))[np.arange(n) * d]
    rho = 1.0 / np.maximum(wdiag, max(float(np.max(wdiag, initial=0.0)), 1e-300) * 1e-12)
    r = r0.copy()
    best_res, _ = natural_map_residual(W, b, mu, r, coulomb)
    best = r.copy()
    F, u, ut, v = _map(W, b, mu, rho, r, coulomb)
    fn = np.linalg.norm(F)
    steps = 0
    history = [best_res]  # the best residual after each step
    for _ in range(max_iter):
        if best_res <= tol:
            break
        if stall_steps is not None and steps >= stall_steps and \
                best_res > 0.5 * history[steps - stall_steps]:
            break
        if first is not None and steps == first[0] and best_res > first[1] * history[0]:
            break
        D = projection_jacobian(v, mu)
        scale = max(np.linalg.norm(r), np.linalg.norm(b) * float(rho.max()), 1e-300)
        lam = damping * fn / scale
        # J = I - D + D rho B W
        DB = D * rho[:, None, None]
        if coulomb:
            slide = (ut > 0.0) & (mu > 0.0)
            if np.any(slide):
                th = u[slide, 1:] / ut[slide, None]
                # D B = D + D[:, :, 0] (mu t^T) on the tangential columns
                DB[slide, :, 1:] += (DB[slide, :, 0:1] * (mu[slide, None, None]
                                                          * th[:, None, :]))
        G = factor.G if factor is not None else None
        if factor is not None and not factor.decided and not sparse:
            # the dense step: J^T J and its Cholesky
            G = factor.decide(2.0 * (n * d) ** 3 + (n * d) ** 3 / 3.0)
        if G is not None and sp.issparse(G):
            # the system's layout and symbolic factorization kept on the factor
            if factor.sparse_lowrank is None or factor.sparse_lowrank.G_given is not G:
                factor.sparse_lowrank = SparseLowRankStep(G, d)
            try:
                dr = factor.sparse_lowrank.solve(np.eye(d) - D, DB, lam, F.ravel())
            except RuntimeError:  # SuperLU: an exactly singular system
                break
        elif G is not None:
            dr = lowrank_step(np.eye(d) - D, DB, G, lam, F.ravel())
        elif sparse:
            # the system on W's block pattern, set up once per problem (kept on the factor)
            system = factor.step_system if factor is not None else step_system
            if system is None:
                system = step_system = SparseStepSystem(W, d)
                if factor is not None:
                    factor.step_system = system
            try:
                dr = system.solve(D, DB, lam, F.ravel())
            except RuntimeError:  # QDLDL: not quasi-definite to round-off
                break
            if factor is not None and not factor.decided:
                # the LDL^T's flops: the sum of its columns' squared counts
                counts = np.diff(system.solver.factors()[0].indptr).astype(float)
                factor.decide(SPARSE_FLOP_COST * float(counts @ counts))
        else:
            # the block rows of D B W, contact by contact (D B is block diagonal)
            J = np.einsum("nij,njk->nik", DB, W.reshape(n, d, n * d)).reshape(n * d, n * d)
            J -= _block_diag(D, False)
            J[np.diag_indices_from(J)] += 1.0
            A = J.T @ J
            A[np.diag_indices_from(A)] += lam
            try:
                # a step only: redundant contacts make J^T J nearly singular (lam keeps it
                # definite), and the answer is accepted on its residual, never on the step,
                # so scipy's ill-conditioning warning would say nothing to the user
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore", sla.LinAlgWarning)
                    dr = sla.solve(A, -J.T @ F.ravel(), assume_a="pos", check_finite=False)
            except (np.linalg.LinAlgError, ValueError):
                break
        if not np.all(np.isfinite(dr)):
            break
        dr = dr.reshape(n, d)
        t = 1.0
        improved = False
        for _ in range(30):  # backtracking (Armijo) on |F|
            trial = r + t * dr
            mapped = _map(W, b, mu, rho, trial, coulomb)
            ft = np.linalg.norm(mapped[0])
            if ft <= (1.0 - 1e-4 * t) * fn:
                improved = True
                break
            t *= 0.5
        if not improved:
            break
        steps += 1
        r, fn = trial, ft
        F, u, ut, v = mapped
        res, _ = natural_map_residual(W, b, mu, r, coulomb)
        if res < best_res:
            best_res, best = res, r.copy()
        history.append(best_res)
    return best, best_res, steps
