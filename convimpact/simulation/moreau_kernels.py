"""One compiled call for the many small contact problems of a Moreau–Jean step.

A step of :func:`convimpact.simulation.moreau.simulate_moreau` splits its contact problem
into independent islands (:mod:`.islands`); a scene of separate bodies (boxes side by side)
has many islands of a few contacts each, where calling the engine once per island would
spend more time in Python than in the solves. :func:`solve_islands` runs the engine's
compiled kernels (:mod:`convimpact.impact.contacts.newton`: the interior point and the Newton
finish of :func:`convimpact.impact.contacts.engine.solve`) over all of them in one call,
each island warm-started, when asked, by Newton on its law's natural map from the previous
step's impulses (:func:`convimpact.impact.contacts.engine.warm_newton`'s compiled branch).

Every answer is judged by the relative natural-map residual on the island's original data,
:func:`natural_map_residual` (the formula of
:func:`convimpact.impact.contacts.cones.natural_map_residual`, compiled); an island whose
answer is above ``tol`` is flagged, and the caller hands it to the full engine (its ADMM for
Coulomb's law) or raises.
"""

from __future__ import annotations

import math

import numpy as np

from ..compiled import jit as _jit
from ..impact.contacts.natural_map import natural_map_newton
from ..impact.contacts.newton import ccp_kernel, coulomb_kernel, scaled_program


@_jit
def _project(rn, rt, mu, out):
    """Projection of (rn, rt) onto the friction cone K_mu into ``out`` (normal first)."""
    d = rt.shape[0] + 1
    t = 0.0
    for j in range(d - 1):
        t += rt[j] * rt[j]
    t = math.sqrt(t)
    if t <= mu * rn:
        out[0] = rn
        for j in range(d - 1):
            out[j + 1] = rt[j]
    elif mu * t <= -rn:
        for j in range(d):
            out[j] = 0.0
    else:
        pn = (rn + mu * t) / (1.0 + mu * mu)
        s = mu * pn / t if t > 0.0 else 0.0
        out[0] = pn
        for j in range(d - 1):
            out[j + 1] = rt[j] * s


@_jit
def natural_map_residual(W, b, mu, d, r, coulomb):
    """``|r - P_K(r - y)| / max(|b|, |r|, |u|)``, ``u = W r + b``, ``y = u (+ mu |u_t| e_n)``
    for Coulomb's law (arrays flat, contact by contact, normal first)."""
    N = b.shape[0]
    n = N // d
    u = W @ r + b
    err = 0.0
    v = np.empty(d)
    p = np.empty(d)
    for i in range(n):
        o = i * d
        ut = 0.0
        for j in range(1, d):
            ut += u[o + j] * u[o + j]
        ut = math.sqrt(ut)
        for j in range(d):
            v[j] = r[o + j] - u[o + j]
        if coulomb:
            v[0] -= mu[i] * ut
        _project(v[0], v[1:], mu[i], p)
        for j in range(d):
            e = r[o + j] - p[j]
            err += e * e
    scale = max(np.linalg.norm(b), np.linalg.norm(r), np.linalg.norm(u), 1e-308)
    return math.sqrt(err) / scale


@_jit
def _warm(W, b, mu, d, start, coulomb, newton_iter):
    N = b.shape[0]
    P, q, idx, scale, starts, sizes, f, trivial = scaled_program(W, b, mu, d)
    r = np.zeros(N)
    if trivial:
        return r, 0
    M = q.shape[0]
    x = np.empty(M)
    for a in range(M):
        x[a] = start[idx[a]] / (scale[a] * f)
    x, _, steps = natural_map_newton(P, q, x, starts, sizes, newton_iter, coulomb)
    for a in range(M):
        r[idx[a]] = scale[a] * f * x[a]
    return r, steps


@_jit
def solve_islands(Wcat, woff, bcat, boff, mucat, moff, d, coulomb, tol, max_iter,
                  newton_iter, start, warm):
    """Solve every island ``i``: ``W_i = Wcat[woff[i]:woff[i+1]]`` (row-major, square),
    ``b_i = bcat[boff[i]:boff[i+1]]``, ``mu_i = mucat[moff[i]:moff[i+1]]``.

    With ``warm[i]``, Newton on the law's natural map from ``start[boff[i]:boff[i+1]]``
    first, kept when its residual is at most ``tol``; otherwise (or without) the engine's
    compiled kernel (the interior point and Newton; Coulomb's law: Newton on its map from
    the CCP answer). Returns ``(impulses, residuals, warm_used, iterations)``; an island
    whose residual is above ``tol`` is left to the caller.
    """
    n_isl = woff.shape[0] - 1
    out = np.zeros(bcat.shape[0])
    res = np.empty(n_isl)
    used = np.zeros(n_isl, dtype=np.bool_)
    iters = np.zeros(n_isl, dtype=np.int64)
    for i in range(n_isl):
        N = boff[i + 1] - boff[i]
        W = Wcat[woff[i]:woff[i + 1]].reshape(N, N)
        b = bcat[boff[i]:boff[i + 1]].copy()
        mu = mucat[moff[i]:moff[i + 1]].copy()
        if warm[i]:
            r, steps = _warm(W, b, mu, d, start[boff[i]:boff[i + 1]].copy(), coulomb,
                             newton_iter)
            iters[i] = steps
            rr = natural_map_residual(W, b, mu, d, r, coulomb)
            if rr <= tol:
                out[boff[i]:boff[i + 1]] = r
                res[i] = rr
                used[i] = True
                continue
        if coulomb:
            r, status, it, steps, g1, g2 = coulomb_kernel(W, b, mu, d, 1e-9, max_iter,
                                                          newton_iter)
        else:
            r, status, it, steps, g1, g2 = ccp_kernel(W, b, mu, d, 1e-9, max_iter,
                                                      newton_iter)
        iters[i] += it + steps
        out[boff[i]:boff[i + 1]] = r
        res[i] = natural_map_residual(W, b, mu, d, r, coulomb)
    return out, res, used, iters


@_jit
def block_inverses(Mflat, flat, s, out):
    """Invert the SPD blocks ``Mflat[flat]`` (n_blocks of s x s, row-major) into
    ``out[flat]`` by Cholesky; returns False (out undefined) when a block is not positive
    definite or not finite."""
    nb = flat.shape[0] // (s * s)
    L = np.empty((s, s))
    Li = np.empty((s, s))
    for b in range(nb):
        o = b * s * s
        for i in range(s):
            for j in range(i + 1):
                v = Mflat[flat[o + i * s + j]]
                for p in range(j):
                    v -= L[i, p] * L[j, p]
                if i == j:
                    if not (v > 0.0) or not math.isfinite(v):
                        return False
                    L[i, i] = math.sqrt(v)
                else:
                    L[i, j] = v / L[j, j]
        # Li = L^-1 (lower)
        for j in range(s):
            for i in range(s):
                Li[i, j] = 0.0
            Li[j, j] = 1.0 / L[j, j]
            for i in range(j + 1, s):
                v = 0.0
                for p in range(j, i):
                    v -= L[i, p] * Li[p, j]
                Li[i, j] = v / L[i, i]
        # M^-1 = Li^T Li
        for i in range(s):
            for j in range(s):
                v = 0.0
                for p in range(max(i, j), s):
                    v += Li[p, i] * Li[p, j]
                out[flat[o + i * s + j]] = v
    return True


@_jit
def assemble_islands(J, G, C, K, d, out):
    """``W_b = J_b G_bb J_b^T`` of every island b of one batch (contacts C[b], coordinates
    K[b]) into ``out`` (B * N * N, row-major, N = nc d), symmetrized."""
    B, nc = C.shape
    nk = K.shape[1]
    N = nc * d
    JI = np.empty((N, nk))
    X = np.empty((N, nk))
    for b in range(B):
        for c in range(nc):
            for r in range(d):
                for a in range(nk):
                    JI[c * d + r, a] = J[C[b, c], r, K[b, a]]
        for i in range(N):
            for a in range(nk):
                v = 0.0
                for e in range(nk):
                    v += JI[i, e] * G[K[b, e], K[b, a]]
                X[i, a] = v
        o = b * N * N
        for i in range(N):
            for j in range(i + 1):
                v = 0.0
                for a in range(nk):
                    v += X[i, a] * JI[j, a]
                out[o + i * N + j] = v
                out[o + j * N + i] = v


@_jit
def contact_rows(gaps, J, v, v_free, e, h_theta, limit, rest_velocity):
    """The step's active contacts and their data, in one pass.

    A contact is active when ``gaps[c] + h_theta J_n v_free <= limit``. Returns
    ``(active, Ja, b, vn_k)``: their indices, Jacobian rows (na, d, k), ``b = J v_free``
    with Newton's restitution ``e_eff min(v_n,free, 0)`` added to the normal
    (``e_eff = min(e v_n,k / v_n,free, 1)`` on contacts approaching at the step's start,
    ``v_n,k < -rest_velocity`` and ``v_n,free < 0``; 0 otherwise) and the normal velocities
    at the start ``vn_k``.
    """
    nc, d, k = J.shape
    vnf = np.empty(nc)
    count = 0
    for c in range(nc):
        s = 0.0
        for a in range(k):
            s += J[c, 0, a] * v_free[a]
        vnf[c] = s
        if gaps[c] + h_theta * s <= limit:
            count += 1
    active = np.empty(count, dtype=np.int64)
    Ja = np.empty((count, d, k))
    b = np.empty((count, d))
    vn_k = np.empty(count)
    i = 0
    for c in range(nc):
        if not (gaps[c] + h_theta * vnf[c] <= limit):
            continue
        active[i] = c
        for r in range(d):
            s = 0.0
            for a in range(k):
                Ja[i, r, a] = J[c, r, a]
                s += J[c, r, a] * v_free[a]
            b[i, r] = s
        s = 0.0
        for a in range(k):
            s += J[c, 0, a] * v[a]
        vn_k[i] = s
        if s < -rest_velocity and vnf[c] < 0.0:
            b[i, 0] += min(e[c] * s / vnf[c], 1.0) * vnf[c]
        i += 1
    return active, Ja, b, vn_k
