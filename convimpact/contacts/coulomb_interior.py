"""An interior point on Coulomb's law itself (De Saxce's form), one of the engine's ways where
Newton from the CCP answer misses (before its sparse ADMM, after its compiled dense one).

In the standard cones of :mod:`.ccp_interior` (``r = S x``, the velocity ``v = A x + q = S u``),
De Saxce's shifted velocity is ``y = v + |v_1| e_0`` per friction cone (``|v_1| = mu |u_t|``
times the contact's scale), and Coulomb's law reads ``Q ∋ x ⊥ y ∈ Q``. The iteration is the
CCP's (Mehrotra's predictor-corrector, Nesterov-Todd scaling) on the equality
``y = A x + q + phi(A x + q)``, linearized: ``dy = B A dx - r_p`` with
``B = I + e_0 t^T`` per friction cone (``t = v_1 / |v_1|``), so each Newton system
``(B A + H) dx = rhs`` is nonsymmetric and is factorized by LU (SuperLU when W is sparse).

The problem is not monotone and nothing guarantees the path: on stacks of boxes the iteration
converged in about 20 steps (a 400-box stack at 2e-9 in 0.5 s where the ADMM's way took 10 s),
on piles of spheres and capsules and on walls its steps to the cones' boundary shrank to
nothing. The iteration therefore stops as soon as it stalls (:data:`STALL_STEPS`); the engine
keeps its answer only when certified, or as a start for Newton when it came close.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from . import cones
from .ccp_interior import _shift_into, _step, standard_form
from .nt_kernels import (affine_target, announce_compilation, corrector_target, nt_blocks,
                         scaled_rhs)

#: the fraction of the step to the cones' boundary taken
STEP_FRACTION = 0.99
#: the iteration stops when its best natural-map residual has not halved over this many steps
STALL_STEPS = 8
#: ...or when a step shorter than this was taken twice in a row
TINY_STEP = 1e-2
#: the complementarity gap (unit data) at which the iteration stops
GAP_FLOOR = 1e-15


def _shift(blocks, v: np.ndarray) -> tuple[np.ndarray, list]:
    """``phi(v)`` (``|v_1|`` on ``e_0`` of each friction cone) and per friction group the unit
    tangents ``t = v_1 / |v_1|`` (zero where ``v_1 = 0``; None for frictionless groups)."""
    out = np.zeros_like(v)
    ts = []
    for s, m, _ in blocks.groups:
        if m == 1:
            ts.append(None)
            continue
        rows = v[s].reshape(-1, m)
        nt = np.sqrt(np.einsum("ij,ij->i", rows[:, 1:], rows[:, 1:]))
        out[s].reshape(-1, m)[:, 0] = nt
        ts.append(np.divide(rows[:, 1:], nt[:, None], out=np.zeros_like(rows[:, 1:]),
                            where=nt[:, None] > 0.0))
    return out, ts


def _tangent_matrix(blocks, ts) -> sp.csr_matrix:
    """``B = I + e_0 t^T`` per friction cone, sparse."""
    N = blocks.size
    rows, cols, vals = [np.arange(N)], [np.arange(N)], [np.ones(N)]
    for (s, m, _), t in zip(blocks.groups, ts):
        if m == 1:
            continue
        base = s.start + np.arange(t.shape[0]) * m
        for j in range(1, m):
            rows.append(base)
            cols.append(base + j)
            vals.append(t[:, j - 1])
    return sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                         shape=(N, N))


def _block_matrix(blocks, Hs) -> sp.csr_matrix:
    rows, cols, vals = [], [], []
    for (s, m, _), H in zip(blocks.groups, Hs):
        base = s.start + np.arange(H.shape[0])[:, None, None] * m
        rows.append((base + np.arange(m)[None, :, None]).repeat(m, 2).ravel())
        cols.append((base + np.arange(m)[None, None, :]).repeat(m, 1).ravel())
        vals.append(H.ravel())
    return sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                         shape=(blocks.size, blocks.size))


def coulomb_interior(W, b: np.ndarray, mu: np.ndarray, d: int, *, tol: float = 1e-8,
                     max_iter: int = 60, sparse: bool = False
                     ) -> tuple[np.ndarray, float, int]:
    """The interior point on Coulomb's law from the CCP's start (W dense, or sparse CSR when
    ``sparse``), until Coulomb's natural-map residual
    (:func:`~.cones.natural_map_residual`) is at most ``tol``, the gap reaches round-off, the
    iteration stalls, or ``max_iter`` steps are done.

    Returns the best ``(r (n, d), residual, iterations)``.
    """
    n = mu.shape[0]
    bb = np.asarray(b, dtype=float).reshape(n, d)
    blocks, q, qs = standard_form(W, bb, mu, d, sparse)
    A = blocks.A
    N = blocks.size
    if sparse:
        x = spla.spsolve((A + sp.identity(N, format="csc")).tocsc(), -q)
    else:
        x = np.linalg.solve(A + np.eye(N), -q)
    v = A @ x + q
    y = _shift_into(blocks, v + _shift(blocks, v)[0])
    x = _shift_into(blocks, x)
    nu = sum((s.stop - s.start) // m for s, m, _ in blocks.groups)
    best_res, best_x = np.inf, x
    history: list[float] = []
    tiny = 0
    it = 0
    announce_compilation()
    for it in range(1, max_iter + 1):
        v = A @ x + q
        phi, ts = _shift(blocks, v)
        rp = y - v - phi
        gap = float(x @ y) / nu
        # the cones' scalings, group by group (:mod:`.nt_kernels`, compiled)
        scal = [nt_blocks(x[sl], y[sl], m) for sl, m, _ in blocks.groups]
        H = _block_matrix(blocks, [Hg for _, _, _, Hg in scal])
        BA = _tangent_matrix(blocks, ts) @ A
        try:
            if sparse:
                lu = spla.splu(sp.csc_matrix(BA + H), permc_spec="COLAMD")
                solve = lu.solve
            else:
                f = sla.lu_factor(np.asarray(BA + H.toarray()), check_finite=False)

                def solve(rhs, f=f):
                    return sla.lu_solve(f, rhs, check_finite=False)
        except (RuntimeError, np.linalg.LinAlgError, ValueError):
            break  # a singular Newton matrix: the try ends

        def direction(target):
            t = np.concatenate([scaled_rhs(sv, beta, lam, tg, m) for (sv, beta, lam, _), tg,
                                (_, m, _) in zip(scal, target, blocks.groups)])
            dx = solve(t + rp)
            return dx, BA @ dx - rp

        target = [affine_target(lam, m) for (_, _, lam, _), (_, m, _) in
                  zip(scal, blocks.groups)]
        dxa, dya = direction(target)
        alpha = _step(blocks, x, y, dxa, dya)
        gap_aff = float((x + alpha * dxa) @ (y + alpha * dya)) / nu
        sigma = min(1.0, max(0.0, gap_aff / max(gap, 1e-300))) ** 3
        dx, dy = direction([corrector_target(sv, beta, lam, dxa[sl], dya[sl], sigma * gap, m)
                            for (sv, beta, lam, _), (sl, m, _) in zip(scal, blocks.groups)])
        if not (np.all(np.isfinite(dx)) and np.all(np.isfinite(dy))):
            break
        alpha = min(1.0, STEP_FRACTION * _step(blocks, x, y, dx, dy))
        x = x + alpha * dx
        y = y + alpha * dy
        res, _ = cones.natural_map_residual(W, bb, mu, blocks.to_impulse(x * qs), coulomb=True)
        if res < best_res:
            best_res, best_x = res, x
        history.append(best_res)
        tiny = tiny + 1 if alpha < TINY_STEP else 0
        if best_res <= tol or gap < GAP_FLOOR or tiny >= 2:
            break
        if len(history) > STALL_STEPS and best_res > 0.5 * history[-1 - STALL_STEPS]:
            break
    r = blocks.to_impulse(best_x * qs)
    res, _ = cones.natural_map_residual(W, bb, mu, r, coulomb=True)
    return r, float(res), it
