"""The ADMM of :mod:`.admm` compiled (numba) for a dense W: the same iteration, the same
parameters (Pinocchio's), run in batches of iterations without returning to Python, its
iterate judged by Coulomb's (or the CCP's) natural-map residual on the original data every
:data:`CHECK_EVERY` iterations inside the batch.

One iteration costs two triangular solves with the Cholesky factor of ``W + (rho + eta) I``
(refactored, by LAPACK through numba, only when rho changes) and one product with W every
check; in Python each iteration also cost some ten numpy calls, which dominated up to a few
hundred rows.
"""

from __future__ import annotations

import math

import numpy as np

from .. import compiled
from ..compiled import jit as _jit

#: the triangular solves' options: the project's, and the float reassociation that lets the
#: compiler vectorize their dot products (3-8x faster at 200-300 rows in our measurements;
#: no assumption on NaN or infinity is made, and every answer is certified afterwards by
#: :func:`natural_residual`, compiled without it)
_REASSOCIATE = {"reassoc", "nsz", "contract"}
try:
    from numba import njit as _njit
except ImportError:  # the plain-Python form of compiled.jit
    _jit_reassociating = _jit
else:
    _jit_reassociating = _njit(**compiled.JIT_OPTIONS, fastmath=_REASSOCIATE)
from .cones import project

#: Pinocchio's ADMM parameters (:mod:`.admm` and this module): the proximal weight, the
#: over-relaxation of rho, the power of the condition number in the first rho, the factor
#: rho changes by, and the residual ratio that changes it
ETA = 1e-6
TAU = 0.5
RHO_POWER = 0.2
RHO_STEP = 2.0
BALANCE = 10.0

#: iterations between two natural-map checks inside a batch
CHECK_EVERY = 10


@_jit
def _factor(W, shift):
    K = W.copy()
    for i in range(K.shape[0]):
        K[i, i] += shift
    return np.linalg.cholesky(K)  # lower triangular L, K = L L^T


@_jit_reassociating
def _chol_solve(L, rhs, out, tmp):
    """out = (L L^T)^-1 rhs: both substitutions along the contiguous rows of L."""
    N = rhs.shape[0]
    for i in range(N):  # L tmp = rhs
        s = rhs[i]
        for j in range(i):
            s -= L[i, j] * tmp[j]
        tmp[i] = s / L[i, i]
    for i in range(N - 1, -1, -1):  # L^T out = tmp
        oi = tmp[i] / L[i, i]
        out[i] = oi
        for j in range(i):
            tmp[j] -= L[i, j] * oi


@_jit
def _project_into(v, mu, d, out):
    """out = the projection of v (n d,) onto the product of friction cones K_mu."""
    n = mu.shape[0]
    for c in range(n):
        o = c * d
        rn = v[o]
        t = 0.0
        for j in range(o + 1, o + d):
            t += v[j] * v[j]
        t = math.sqrt(t)
        m = mu[c]
        if t <= m * rn:
            for j in range(o, o + d):
                out[j] = v[j]
        elif m * t <= -rn:
            for j in range(o, o + d):
                out[j] = 0.0
        else:
            pn = (rn + m * t) / (1.0 + m * m)
            out[o] = pn
            s = m * pn / t if t > 0.0 else 0.0
            for j in range(o + 1, o + d):
                out[j] = v[j] * s


@_jit
def _desaxce(v, mu, d, out, add):
    """De Saxce's shift ``mu |v_t|`` of each contact into ``out``'s normal rows (added to
    them with ``add``, else written over them; the tangential rows are left alone)."""
    for c in range(mu.shape[0]):
        o = c * d
        t = 0.0
        for j in range(o + 1, o + d):
            t += v[j] * v[j]
        if add:
            out[o] += mu[c] * math.sqrt(t)
        else:
            out[o] = mu[c] * math.sqrt(t)


@_jit
def admm_update(x_new, x, w, lam, s, mu, d, rho, eta, coulomb, v, wn):
    """The part of an ADMM iteration after its proximal solve ``x_new``, in place: ``w`` the
    projection of ``x_new + lam / rho`` onto the cones, ``lam += rho (x_new - w)``, ``s`` De
    Saxce's shift of ``-lam`` in its normal rows (with ``coulomb``; its tangential rows stay
    zero), ``x = x_new``; ``v`` and ``wn`` are scratch of x's size. Returns the primal and dual
    residuals (max norms) that balance rho."""
    N = x.shape[0]
    for i in range(N):
        v[i] = x_new[i] + lam[i] / rho
    _project_into(v, mu, d, wn)
    primal = 0.0
    dual = 0.0
    for i in range(N):
        dx = x_new[i] - wn[i]
        lam[i] += rho * dx
        if abs(dx) > primal:
            primal = abs(dx)
        dd = rho * abs(wn[i] - w[i]) + eta * abs(x_new[i] - x[i])
        if dd > dual:
            dual = dd
        x[i] = x_new[i]
        w[i] = wn[i]
    if coulomb:  # -lam tends to the shifted velocity u + s; |(-lam)_t| = |lam_t|
        _desaxce(lam, mu, d, s, False)
    return primal, dual


@_jit
def largest_eigenvalue(W, v):
    """W's largest eigenvalue (W symmetric positive semidefinite) by 30 power iterations from
    v (overwritten): :func:`.admm._largest_eigenvalue` compiled (its Python loop cost more
    than the whole ADMM on problems of a few contacts)."""
    N = v.shape[0]
    w = np.empty(N)
    lam = 0.0
    for _ in range(30):
        nw = 0.0
        vw = 0.0
        vv = 0.0
        for i in range(N):
            s = 0.0
            for j in range(N):
                s += W[i, j] * v[j]
            w[i] = s
            nw += s * s
            vw += v[i] * s
            vv += v[i] * v[i]
        if nw == 0.0:
            return 0.0
        lam = vw / vv
        nw = math.sqrt(nw)
        for i in range(N):
            v[i] = w[i] / nw
    return max(lam, 0.0)


@_jit
def natural_residual(W, b, mu, d, r, coulomb, u, y, p):
    """The relative natural-map residual of r (as :func:`.cones.natural_map_residual`);
    u, y, p are work arrays (u holds W r + b on return)."""
    N = b.shape[0]
    for i in range(N):
        s = b[i]
        for j in range(N):
            s += W[i, j] * r[j]
        u[i] = s
    return residual_of_velocity(b, mu, d, r, coulomb, u, y, p)


@_jit
def residual_of_velocity(b, mu, d, r, coulomb, u, y, p):
    """The relative natural-map residual of r given its velocity ``u = W r + b`` (u kept;
    y, p work arrays): ``|r - P_K(r - y)| / max(|b|, |r|, |u|)``, ``y = u`` (CCP) or De
    Saxce's ``u + mu |u_t| e_n`` (Coulomb)."""
    N = b.shape[0]
    nb = 0.0
    nr = 0.0
    nu = 0.0
    for i in range(N):
        y[i] = u[i]
        nb += b[i] * b[i]
        nr += r[i] * r[i]
        nu += u[i] * u[i]
    if coulomb:
        _desaxce(u, mu, d, y, True)
    for i in range(N):
        y[i] = r[i] - y[i]
    _project_into(y, mu, d, p)
    err = 0.0
    for i in range(N):
        e = r[i] - p[i]
        err += e * e
    scale = max(math.sqrt(nb), math.sqrt(nr), math.sqrt(nu), 1e-300)
    return math.sqrt(err) / scale


@_jit
def admm_batch(W, b, mu, d, L, x, w, lam, rho, eta, Lmax, iterations, target, coulomb,
               relax=1.0):
    """Up to ``iterations`` ADMM iterations from the state ``(x, w, lam)`` (updated in place)
    with the factor L of ``W + (rho + eta) I``.

    Every :data:`CHECK_EVERY` iterations the natural-map residual of the cone copy w is
    computed; the batch stops when it is at most ``target``. rho is doubled or halved when the
    primal and dual residuals differ by more than a factor 10 (L refactored); the proximal
    step is over-relaxed by ``relax`` (as in :func:`.admm.coulomb_admm`). Returns
    ``(L, rho, iterations done, last residual, best residual, best w)``.
    """
    N = b.shape[0]
    rhs = np.empty(N)
    tmp = np.empty(N)
    xn = np.empty(N)
    v = np.empty(N)
    wn = np.empty(N)
    u = np.empty(N)
    y = np.empty(N)
    p = np.empty(N)
    s = np.zeros(N)
    best = np.inf
    best_w = w.copy()
    res = np.inf
    if coulomb:
        _desaxce(lam, mu, d, s, False)
    it = 0
    while it < iterations:
        it += 1
        for i in range(N):
            rhs[i] = eta * x[i] - b[i] - s[i] + rho * w[i] - lam[i]
        _chol_solve(L, rhs, xn, tmp)
        for i in range(N):  # the over-relaxed step, in tmp (free after the solve)
            tmp[i] = relax * xn[i] + (1.0 - relax) * w[i]
        primal, dual = admm_update(tmp, x, w, lam, s, mu, d, rho, eta, coulomb, v, wn)
        for i in range(N):  # the proximal centre: the solve's own answer
            x[i] = xn[i]
        if it % CHECK_EVERY == 0:
            res = natural_residual(W, b, mu, d, w, coulomb, u, y, p)
            if res < best:
                best = res
                best_w[:] = w
            if res <= target:
                break
        if primal > 10.0 * dual and rho < 1e8 * Lmax:
            rho *= 2.0
            L = _factor(W, rho + eta)
        elif dual > 10.0 * primal and rho > 1e-8 * Lmax:
            rho *= 0.5
            L = _factor(W, rho + eta)
    return L, rho, it, res, best, best_w


def dense_admm(W: np.ndarray, b: np.ndarray, mu: np.ndarray, d: int, r0: np.ndarray, *,
               tol: float, max_iter: int, polish=None, coulomb: bool = True,
               batch: int = 200, patience: float | None = None, relax: float = 1.0,
               crawl: float | None = None) -> tuple[np.ndarray, float, int]:
    """The compiled ADMM on dense W from ``r0`` (n, d), batch by batch, until its natural-map
    residual is at most ``tol`` or ``max_iter`` iterations are done.

    ``polish(r) -> (r, residual, steps)`` (a Newton finish) is tried on the best iterate when
    the ADMM first comes within 1e-5, and again after each further drop by 1000 (Newton from
    there usually certifies in one to three steps; where the solutions are not isolated, as in
    stacks, it fails again and again, and the ADMM goes on). With ``patience``, the run also
    ends once it has gone ``patience`` times as many iterations as it took to come within
    1e-5 with Newton failing there (a try that the caller backs up with another method).
    With ``crawl``, it ends after a batch (the first excepted) that did not lower the best
    residual by that factor (another such try: the ADMM crawls).
    Returns the best ``(r, residual, iterations)``; the residual is the one of
    :func:`natural_residual` (the engine certifies again on its own).
    """
    n = mu.shape[0]
    N = n * d
    W = np.ascontiguousarray(W, dtype=float)
    q = np.ascontiguousarray(b, dtype=float).reshape(N)
    m = np.ascontiguousarray(mu, dtype=float)
    Lmax = largest_eigenvalue(W, np.random.default_rng(0).standard_normal(N)) or 1.0
    rho = TAU * math.sqrt(Lmax * ETA) * (Lmax / ETA) ** RHO_POWER
    F = _factor(W, rho + ETA)
    x = np.array(r0, dtype=float).reshape(N)
    w = project(x.reshape(n, d), m).ravel()
    lam = -(W @ w + q)
    best_res, best_r = np.inf, w.reshape(n, d).copy()
    tried = np.inf
    done = 0
    first_miss = 0
    while done < max_iter:
        if first_miss and patience is not None and done >= patience * first_miss:
            break
        F, rho, it, res, bres, bw = admm_batch(W, q, m, d, F, x, w, lam, rho, ETA, Lmax,
                                               min(batch, max_iter - done), tol, coulomb,
                                               relax)
        done += it
        before = best_res
        if bres < best_res:
            best_res, best_r = bres, bw.reshape(n, d).copy()
        if best_res <= tol:
            break
        crawled = crawl is not None and done > it and best_res > before / crawl
        if polish is not None and bres < min(1e-5, 1e-3 * tried):
            tried = bres
            rn, resn, _ = polish(bw.reshape(n, d).copy())
            if resn < best_res:
                best_res, best_r = resn, rn
            if best_res <= tol:
                break
            first_miss = first_miss or done
        if crawled:
            break
    return best_r, float(best_res), done
