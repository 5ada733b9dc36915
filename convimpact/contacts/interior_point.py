"""Compiled (numba) kernels of the several-contact solver: a primal-dual interior point for the
monotone cone complementarity problem of the maximal-dissipation laws.

The problem (Anitescu's CCP, the plastic phase of the dissipative law) is, in contact space,

    minimize 1/2 pi^T W pi + b^T pi   over   pi_i in K_mu_i = {|pi_t| <= mu_i pi_n},

a convex QP over a product of small cones (W positive *semi*definite: four corners of a box
give a rank-6 W of size 12). Its KKT conditions are the complementarity problem

    K ∋ pi  ⊥  z = W pi + b ∈ K*.

Per contact the impulse is written ``pi = diag(1/mu, 1, 1) y`` so that y lies in the standard
second-order cone ``y_0 >= |y_1|`` (a frictionless contact keeps its normal only: a cone of
dimension one, the half line), every contact is equilibrated by its own effective mass and
the data scaled to unit size (as :func:`convimpact.impact.conic.qp.equilibrated` does).

The iteration is Mehrotra's predictor-corrector on the monotone linear complementarity
problem over self-dual second-order cones with Nesterov-Todd scaling (Vandenberghe, "The
CVXOPT linear and quadratic cone program solvers", 2010, sections 3-4): with the scaling
``T`` of the current pair (``T z = T^-1 x = lambda``) each Newton step solves

    (P + T^-2) dx = r + T^-1 (lambda \\ r_c),   dz = P dx - r,   r = z - P x - q,

one dense Cholesky factorization per iteration, two triangular solves. A singular ``P`` is
no obstacle: ``T^-2`` is positive definite. The iterates stay strictly inside the cones, so
the answer is primal and dual feasible by construction; it stops when the residual and the
complementarity gap reach the hand-over tolerance (or stop decreasing), and a Newton finish
takes the answer to round-off. Whether the answer is the law's is decided by the
certificates of :mod:`convimpact.contacts.newton` on the original data, never by the
iteration's own measures.

The Newton finish and the drivers on contact data are in
:mod:`convimpact.contacts.newton`, the certificates in
:mod:`convimpact.contacts.certificates`. Everything is compiled on first use and cached
per user (:mod:`convimpact.compiled`: an edit of any compiled source retires the cache);
:mod:`convimpact.impact.several.interior` imports these modules lazily.
"""

from __future__ import annotations

import math

import numpy as np
from ..compiled import jit as _jit

#: kernel status codes
CONVERGED = 0
MAX_ITER = 1  # the iteration limit was reached before the gap and residual reached tol
STALLED = 2  # the factorization failed or the iterates diverged (no solution: a rigid pinch)
TRIVIAL = 3  # b = 0: pi = 0

EPS = 2.220446049250313e-16
TINY = 1e-300


@_jit
def _step_to_boundary(x, dx, o, m):
    """Largest alpha with x + alpha dx in the second-order cone of block [o, o + m) (inf if
    the whole ray stays inside)."""
    if m == 1:
        if dx[o] < 0.0:
            return -x[o] / dx[o]
        return np.inf
    a = dx[o] * dx[o]
    bb = x[o] * dx[o]
    c = x[o] * x[o]
    for j in range(o + 1, o + m):
        a -= dx[j] * dx[j]
        bb -= x[j] * dx[j]
        c -= x[j] * x[j]
    bb *= 2.0
    # f(alpha) = a alpha^2 + bb alpha + c, f(0) = c > 0: the first positive root
    if c <= 0.0:
        return 0.0
    disc = bb * bb - 4.0 * a * c
    if a == 0.0:
        return -c / bb if bb < 0.0 else np.inf
    if disc < 0.0:
        return np.inf
    sq = math.sqrt(disc)
    qq = -0.5 * (bb + (sq if bb >= 0.0 else -sq))
    best = np.inf
    if qq != 0.0:
        r1 = qq / a
        r2 = c / qq
        if r1 > 0.0 and r1 < best:
            best = r1
        if r2 > 0.0 and r2 < best:
            best = r2
    return best


@_jit
def _cholesky(A, L):
    """Lower Cholesky factor of the SPD A into L; False when A is not numerically SPD."""
    n = A.shape[0]
    for j in range(n):
        s = A[j, j]
        for k in range(j):
            s -= L[j, k] * L[j, k]
        if not s > 0.0:
            return False
        d = math.sqrt(s)
        L[j, j] = d
        for i in range(j + 1, n):
            t = A[i, j]
            for k in range(j):
                t -= L[i, k] * L[j, k]
            L[i, j] = t / d
        for i in range(j):
            L[i, j] = 0.0
    return True


@_jit
def _cho_solve(L, rhs, out):
    n = L.shape[0]
    for i in range(n):
        s = rhs[i]
        for k in range(i):
            s -= L[i, k] * out[k]
        out[i] = s / L[i, i]
    for i in range(n - 1, -1, -1):
        s = out[i]
        for k in range(i + 1, n):
            s -= L[k, i] * out[k]
        out[i] = s / L[i, i]


@_jit
def _direction(L, P, r, tmp, rhs, dx, dz):
    """A Newton direction: L L^T dx = r + tmp, then dz = P dx - r."""
    N = r.shape[0]
    for i in range(N):
        rhs[i] = r[i] + tmp[i]
    _cho_solve(L, rhs, dx)
    for i in range(N):
        s = -r[i]
        for j in range(N):
            s += P[i, j] * dx[j]
        dz[i] = s


@_jit
def _max_step(x, dx, z, dz, starts, sizes, amax):
    """The largest step (at most ``amax``) keeping x + a dx and z + a dz in every cone."""
    for c in range(starts.shape[0]):
        a1 = _step_to_boundary(x, dx, starts[c], sizes[c])
        a2 = _step_to_boundary(z, dz, starts[c], sizes[c])
        if a1 < amax:
            amax = a1
        if a2 < amax:
            amax = a2
    return amax


@_jit
def _nt_scaling(x, z, o, m, wbar, beta):
    """Nesterov-Todd scaling of block [o, o + m): v (into wbar[o:o+m]) and beta.

    With x_bar = x / sqrt(x^T J x), z_bar likewise, gamma = sqrt((1 + x_bar^T z_bar) / 2),
    w = (x_bar + J z_bar) / (2 gamma) and v = (w + e) / sqrt(2 (w_0 + 1)):
    T = beta (2 v v^T - J), T^-1 = (2 J v v^T J - J) / beta, T z = T^-1 x = lambda
    (CVXOPT's scaling of a second-order cone).
    """
    xt = 0.0
    zt = 0.0
    for j in range(o + 1, o + m):
        xt += x[j] * x[j]
        zt += z[j] * z[j]
    xt = math.sqrt(xt)
    zt = math.sqrt(zt)
    xj = (x[o] - xt) * (x[o] + xt)
    zj = (z[o] - zt) * (z[o] + zt)
    xn = math.sqrt(max(xj, TINY))
    zn = math.sqrt(max(zj, TINY))
    dot = 0.0
    for j in range(o, o + m):
        dot += x[j] * z[j]
    dot /= xn * zn
    gamma = math.sqrt(max(0.5 * (1.0 + dot), TINY))
    w0 = (x[o] / xn + z[o] / zn) / (2.0 * gamma)
    # the hyperbolic Householder vector v = (w + e) / sqrt(2 (w_0 + 1)) of w_bar
    f = 1.0 / math.sqrt(2.0 * (w0 + 1.0))
    wbar[o] = (w0 + 1.0) * f
    for j in range(o + 1, o + m):
        wbar[j] = (x[j] / xn - z[j] / zn) / (2.0 * gamma) * f
    beta[o] = math.sqrt(xn / zn)


@_jit
def _apply_t(wbar, beta, o, m, v, out, inverse):
    """out[o:o+m] = T v (inverse: T^-1 v) for block [o, o + m)."""
    # J v, and w^T J v (inverse) or w^T v
    if inverse:
        # T^-1 v = (2 (J w)(J w)^T v - J v) / beta
        s = wbar[o] * v[o]
        for j in range(o + 1, o + m):
            s -= wbar[j] * v[j]
        f = 1.0 / beta[o]
        out[o] = f * (2.0 * wbar[o] * s - v[o])
        for j in range(o + 1, o + m):
            out[j] = f * (-2.0 * wbar[j] * s + v[j])
    else:
        s = 0.0
        for j in range(o, o + m):
            s += wbar[j] * v[j]
        f = beta[o]
        out[o] = f * (2.0 * wbar[o] * s - v[o])
        for j in range(o + 1, o + m):
            out[j] = f * (2.0 * wbar[j] * s + v[j])


@_jit
def _jordan_product(u, v, o, m, out):
    """out[o:o+m] = u o v, the Jordan product of block [o, o + m): (u'v, u_0 v_1 + v_0 u_1)."""
    s = 0.0
    for j in range(o, o + m):
        s += u[j] * v[j]
    out[o] = s
    for j in range(o + 1, o + m):
        out[j] = u[o] * v[j] + v[o] * u[j]


@_jit
def _jordan_solve(lam, r, o, m, out):
    """out[o:o+m] = lambda \\ r, the solution v of lambda o v = r (Jordan product)."""
    l0 = lam[o]
    den = l0 * l0
    num = l0 * r[o]
    for j in range(o + 1, o + m):
        den -= lam[j] * lam[j]
        num -= lam[j] * r[j]
    v0 = num / den
    out[o] = v0
    for j in range(o + 1, o + m):
        out[j] = (r[j] - v0 * lam[j]) / l0


@_jit
def cone_lcp(P, q, starts, sizes, tol, max_iter):
    """Solve ``x in K, z = P x + q in K, x^T z = 0`` over a product of second-order cones.

    Parameters
    ----------
    P : (N, N) symmetric positive semidefinite, of unit scale.
    q : (N,) of unit scale.
    starts, sizes : (n_cones,) first index and dimension of each cone (1 = half line).
    tol : stop when the residual |z - P x - q|_inf and the mean complementarity x^T z /
        n_cones are both below tol (relative to the unit data).
    max_iter : iteration limit.

    Returns
    -------
    x, z, status (CONVERGED, MAX_ITER, STALLED), iterations, gap, residual; when not
    converged, the best iterate met (smallest max(residual, mean gap)).
    """
    N = q.shape[0]
    nc = starts.shape[0]
    x = np.zeros(N)
    z = np.zeros(N)
    for c in range(nc):
        x[starts[c]] = 1.0
        z[starts[c]] = 1.0
    wbar = np.empty(N)
    beta = np.empty(N)
    lam = np.empty(N)
    K = np.empty((N, N))
    L = np.empty((N, N))
    r = np.empty(N)
    rc = np.empty(N)
    dc = np.empty(N)
    tmp = np.empty(N)
    rhs = np.empty(N)
    dx = np.empty(N)
    dz = np.empty(N)
    dxa = np.empty(N)
    dza = np.empty(N)
    u = np.empty(N)
    col = np.empty(N)
    e_j = np.empty(N)
    status = MAX_ITER
    gap = np.inf
    res = np.inf
    best = np.inf
    xbest = x.copy()
    zbest = z.copy()
    it = 0
    for it in range(max_iter + 1):
        # residual r = z - P x - q and gap
        res = 0.0
        gap = 0.0
        for i in range(N):
            s = z[i] - q[i]
            for j in range(N):
                s -= P[i, j] * x[j]
            r[i] = s
            if abs(s) > res:
                res = abs(s)
            gap += x[i] * z[i]
        mub = gap / nc
        # NaN compares false: test finiteness first (the gap carries any NaN of x or z)
        if not (math.isfinite(gap) and math.isfinite(res)):
            status = STALLED
            break
        if res <= tol and mub <= tol:
            status = CONVERGED
            break
        merit = max(res, mub)
        if merit > 1e30:
            status = STALLED
            break
        if it == max_iter:
            break
        # a stalled iteration at round-off: accept when within 1e3 tol, else keep going
        if merit >= best and merit <= 1e3 * tol:
            status = CONVERGED
            break
        if merit < best:
            best = merit
            for i in range(N):
                xbest[i] = x[i]
                zbest[i] = z[i]
        # NT scaling and lambda = T z
        for c in range(nc):
            _nt_scaling(x, z, starts[c], sizes[c], wbar, beta)
            _apply_t(wbar, beta, starts[c], sizes[c], z, lam, False)
        # K = P + T^-2 (block diagonal)
        for i in range(N):
            for j in range(N):
                K[i, j] = P[i, j]
        for c in range(nc):
            o, m = starts[c], sizes[c]
            for jj in range(m):
                for i in range(N):
                    e_j[i] = 0.0
                e_j[o + jj] = 1.0
                _apply_t(wbar, beta, o, m, e_j, tmp, True)
                _apply_t(wbar, beta, o, m, tmp, col, True)
                for ii in range(m):
                    K[o + ii, o + jj] += col[o + ii]
        if not _cholesky(K, L):
            status = STALLED
            break
        # predictor: r_c = -lambda o lambda, so lambda \ r_c = -lambda
        for i in range(N):
            dc[i] = -lam[i]
        for c in range(nc):
            _apply_t(wbar, beta, starts[c], sizes[c], dc, tmp, True)
        _direction(L, P, r, tmp, rhs, dxa, dza)
        amax = _max_step(x, dxa, z, dza, starts, sizes, 1.0)
        gap_aff = 0.0
        for i in range(N):
            gap_aff += (x[i] + amax * dxa[i]) * (z[i] + amax * dza[i])
        sigma = gap_aff / gap if gap > 0.0 else 0.0
        sigma = min(max(sigma, 0.0), 1.0) ** 3
        # corrector: r_c = -lambda o lambda - (T^-1 dx_a) o (T dz_a) + sigma mu e
        for c in range(nc):
            o, m = starts[c], sizes[c]
            _apply_t(wbar, beta, o, m, dxa, tmp, True)
            _apply_t(wbar, beta, o, m, dza, u, False)
            s_ll = 0.0
            s_du = 0.0
            for j in range(o, o + m):
                s_ll += lam[j] * lam[j]
                s_du += tmp[j] * u[j]
            rc[o] = -s_ll - s_du + sigma * mub
            for j in range(o + 1, o + m):
                rc[j] = -2.0 * lam[o] * lam[j] - (tmp[o] * u[j] + u[o] * tmp[j])
            _jordan_solve(lam, rc, o, m, dc)
            _apply_t(wbar, beta, o, m, dc, tmp, True)
        _direction(L, P, r, tmp, rhs, dx, dz)
        amax = _max_step(x, dx, z, dz, starts, sizes, np.inf)
        alpha = min(1.0, 0.99 * amax)
        for i in range(N):
            x[i] += alpha * dx[i]
            z[i] += alpha * dz[i]
    if status != CONVERGED:
        # an ill-conditioned P can break the scaling near the answer: hand over the best
        # iterate (smallest max(residual, gap)); the Newton finish and the certificate decide
        return xbest, zbest, status, it, gap, res
    return x, z, status, it, gap, res


@_jit
def contact_checks(W, v, d, immobile_rtol, tiny_normal):
    """The contact-space checks of :func:`convimpact.impact.problem.build.build_problem` for several
    contacts, in one compiled call.

    Makes W exactly symmetric in place (``W_ij = W_ji = (W_ij + W_ji) / 2`` where they differ,
    bit for bit as :func:`~convimpact.impact.problem.reduction._symmetrize`), then returns 0 when the
    problem is the plain case -- the entries of W and v sum to a finite number, every
    contact's normal moves mass (``W_nn >= tiny_normal``) and every contact's tangents do
    (largest tangent diagonal entry above ``immobile_rtol`` times W's largest diagonal
    entry) -- else 1: the Python checks then decide (and raise or note, as before).
    """
    r = W.shape[0]
    for i in range(r):
        for j in range(i):
            a = W[i, j]
            b = W[j, i]
            if a != b:
                s = (a + b) * 0.5
                W[i, j] = s
                W[j, i] = s
    total = 0.0
    for i in range(r):
        for j in range(r):
            total += W[i, j]
        total += v[i]
    if not math.isfinite(total):
        return 1
    big = W[0, 0]
    for i in range(1, r):
        big = max(big, W[i, i])
    for o in range(0, r, d):
        if not W[o, o] >= tiny_normal:
            return 1
        wt = W[o + 1, o + 1]
        for j in range(o + 2, o + d):
            wt = max(wt, W[j, j])
        if wt <= immobile_rtol * big:
            return 1
    return 0
