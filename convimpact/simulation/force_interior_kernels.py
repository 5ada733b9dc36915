"""A compiled cold start of the largest-smallest-margin program
(:func:`~.force_distribution.max_margin_distribution`, stage 1): a primal-dual interior-point
method (:func:`primal_dual_max_min`).

The program ``max tau s.t. s = b - G x in K`` (``x = (y, tau)``, ``G = (A, w)``, K a product of
nonnegative half-lines and three-dimensional second-order cones; its dual ``G'z = e_tau``, z
in K) is solved from a strictly feasible primal point and ``z = e`` by the standard method
for symmetric cones (Nesterov-Todd scaling ``W``, ``W z = W^-1 s = lam``; Mehrotra's predictor
and corrector, centring ``sigma = (1 - alpha_affine)^3``; normal equations ``G' W^-2 G``,
n = r + 1 <= 19 unknowns on the box stack), as Clarabel and CVXOPT solve such programs, in
8-11 iterations to a gap ``s'z`` of 1e-11 there. Its point is not an answer by itself: it
is accepted through :func:`~.force_cold_start.cold_max_min`, after Newton's method on the
program's optimality conditions certifies it
(:func:`~.force_distribution_polish._polish_max_min`), or, where that polish does not
converge, on the optimality residuals Clarabel's answer is held to; Clarabel takes over
where neither holds.

The box stack's five first-stage programs per run cost Clarabel 0.5-0.8 ms each with the
conversion of its data and the check of its answer; this method 0.04-0.15 ms.

The cone algebra (the scaling, its products, the Jordan quotient, the step to the cones'
boundary) is the contact engine's (:mod:`convimpact.contacts.interior_point`), cone by cone:
a second-order cone of three rows, or one row of a half-line.
"""

from __future__ import annotations

import numpy as np

from ..compiled import jit, jit_internal
from ..contacts.interior_point import (_apply_t, _jordan_product, _jordan_solve, _max_step,
                                       _nt_scaling)

#: iterations at most
PD_STEPS = 50
#: the dual residual |G'z - e_tau|_inf at which the method may stop (the polish after it
#: solves stationarity to round-off)
DUAL_TOL = 1e-9
#: fraction of the way to the cones' boundary a step goes at most
STEP_FRACTION = 0.99


@jit_internal
def _inside(v, starts, sizes):
    """Whether v is in the interior of every cone (``v0 > |v1|``; a half-line's ``v > 0``)."""
    for c in range(starts.size):
        o, m = starts[c], sizes[c]
        t = 0.0
        for j in range(o + 1, o + m):
            t += v[j] * v[j]
        if not (v[o] > 0.0 and v[o] * v[o] > t):
            return False
    return True


@jit_internal
def _scale(u, wbar, beta, starts, sizes, out, inverse):
    """``out = W u`` (``inverse``: ``W^-1 u``) cone by cone."""
    for c in range(starts.size):
        _apply_t(wbar, beta, starts[c], sizes[c], u, out, inverse)


@jit_internal
def _lam_solve(lam, r, starts, sizes, out):
    """``out = lam^-1 o r``: the solution u of the Jordan product ``lam o u = r`` per cone."""
    for c in range(starts.size):
        _jordan_solve(lam, r, starts[c], sizes[c], out)


@jit_internal
def _jordan(u, v, starts, sizes, out):
    """``out = u o v`` per cone (a half-line's ``u v``)."""
    for c in range(starts.size):
        _jordan_product(u, v, starts[c], sizes[c], out)


@jit
def primal_dual_max_min(G, b, starts, sizes, x, z, gap):
    """A primal-dual interior-point method (Nesterov-Todd scaling, Mehrotra's predictor and
    corrector) on ``max x[-1] s.t. s = b - G x in K`` (dual: ``G'z = e_tau``, z in K; the
    cones at ``starts`` of ``sizes`` 3, second-order, or 1, half-lines), from the strictly
    feasible x and z = e; its last iterate into x and z. Returns the iterations (> 0) where
    ``s'z <= gap`` and ``|G'z - e_tau|_inf <= DUAL_TOL`` were reached, 0 otherwise (an
    iterate left the cones' interior, or the iterations ran out)."""
    m, n = G.shape
    n_tau = n - 1
    theta = float(starts.size)  # the cones' degree
    z[:] = 0.0
    for c in range(starts.size):
        z[starts[c]] = 1.0
    s = b - G @ x
    wbar = np.empty(m)
    beta = np.empty(m)
    lam = np.empty(m)
    M = np.empty((m, n))
    col = np.empty(m)
    v = np.empty(m)
    rc = np.empty(m)
    tmp = np.empty(m)
    tmp2 = np.empty(m)
    for it in range(PD_STEPS):
        rx = G.T @ z
        rx[n_tau] -= 1.0
        if float(s @ z) <= gap and np.max(np.abs(rx)) <= DUAL_TOL:
            return it + 1
        if not (_inside(s, starts, sizes) and _inside(z, starts, sizes)):
            return 0
        for c in range(starts.size):
            _nt_scaling(s, z, starts[c], sizes[c], wbar, beta)
        _scale(z, wbar, beta, starts, sizes, lam, False)  # lam = W z
        for p in range(n):  # M = W^-1 G
            _scale(G[:, p].copy(), wbar, beta, starts, sizes, col, True)
            M[:, p] = col
        H = M.T @ M
        mu = float(lam @ lam) / theta
        # predictor: rc = -lam o lam
        _jordan(lam, lam, starts, sizes, rc)
        rc = -rc
        _lam_solve(lam, rc, starts, sizes, v)
        dx = np.linalg.solve(H, -rx - M.T @ v)
        ds = -(G @ dx)
        _scale(M @ dx + v, wbar, beta, starts, sizes, tmp, True)
        dz = tmp.copy()
        alpha = min(1.0, _max_step(s, ds, z, dz, starts, sizes, np.inf))
        sigma = (1.0 - alpha) ** 3
        # corrector: rc = -lam o lam - (W^-1 ds) o (W dz) + sigma mu e
        _scale(ds, wbar, beta, starts, sizes, tmp, True)  # W^-1 ds
        Wdz = M @ dx + v  # (W dz; W^-1 ds = -M dx)
        _jordan(tmp, Wdz, starts, sizes, tmp2)
        _jordan(lam, lam, starts, sizes, rc)
        rc = -rc - tmp2
        for c in range(starts.size):
            rc[starts[c]] += sigma * mu
        _lam_solve(lam, rc, starts, sizes, v)
        dx = np.linalg.solve(H, -rx - M.T @ v)
        ds = -(G @ dx)
        _scale(M @ dx + v, wbar, beta, starts, sizes, tmp, True)
        dz = tmp.copy()
        alpha = min(1.0, STEP_FRACTION * _max_step(s, ds, z, dz, starts, sizes, np.inf))
        x += alpha * dx
        s = s + alpha * ds
        z += alpha * dz
    return 0
