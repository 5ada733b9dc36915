"""Compiled kernels of a Moreau–Jean step's contact problem on the engine (laws ccp and
coulomb, :class:`.moreau_engine.EngineSolver`).

A step of :func:`convimpact.simulation.moreau.simulate_moreau` splits its contact problem
into independent islands (:mod:`.islands`); a scene of separate bodies (boxes side by side)
has many islands of a few contacts each, where calling the engine once per island would
spend more time in Python than in the solves. :func:`solve_small_islands` assembles every
small island's Delassus matrix ``W = J_I G_II J_I^T`` (as :func:`assemble_islands` does) and
runs the engine's compiled kernels (:mod:`convimpact.contacts.newton`: the interior
point and the Newton finish of :func:`convimpact.contacts.engine.solve`) over all of
them in one call, each island warm-started, when asked, by Newton on its law's natural map
from the previous step's impulses (:func:`convimpact.contacts.engine.warm_newton`'s
compiled branch). :func:`apply_impulses` gives ``v_{k+1} = v_free + G J^T r``;
:func:`same_pattern` tells whether a step keeps the previous step's island layout
(:func:`same_pattern_on`: the same answer, reading each row on its contact's support).

Every answer is judged by the relative natural-map residual on the island's original data,
:func:`natural_map_residual` (the formula of
:func:`convimpact.contacts.cones.natural_map_residual`, compiled); an island whose
answer is above ``tol`` is flagged, and the caller hands it to the full engine (its ADMM for
Coulomb's law) or raises.
"""

from __future__ import annotations

import math

import numpy as np

from ..compiled import jit as _jit
from ..contacts.natural_map import natural_map_newton
from ..contacts.newton import ccp_kernel, coulomb_kernel, scaled_program
from .moreau_step_kernels import block_times


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
def island_delassus(J, G, cons, cols, d, W):
    """``W = J_I G_II J_I^T`` (symmetric, into ``W`` (N, N), N = len(cons) d) of the island
    with the contacts ``cons`` (rows of J (n, d, k)) and the coordinates ``cols``."""
    nc, nk = cons.shape[0], cols.shape[0]
    N = nc * d
    JI = np.empty((N, nk))
    X = np.empty((N, nk))
    for c in range(nc):
        for r in range(d):
            for a in range(nk):
                JI[c * d + r, a] = J[cons[c], r, cols[a]]
    for i in range(N):
        for a in range(nk):
            v = 0.0
            for e in range(nk):
                v += JI[i, e] * G[cols[e], cols[a]]
            X[i, a] = v
    for i in range(N):
        for j in range(i + 1):
            v = 0.0
            for a in range(nk):
                v += X[i, a] * JI[j, a]
            W[i, j] = v
            W[j, i] = v


@_jit
def island_velocity(J, v, cons, cols, d, out):
    """``out = J_I v`` (N = len(cons) d): the contact velocities of the island with the
    contacts ``cons`` (rows of J (n, d, k)) from ``v`` on its coordinates ``cols``."""
    nk = cols.shape[0]
    for c in range(cons.shape[0]):
        for a in range(d):
            acc = 0.0
            for e in range(nk):
                acc += J[cons[c], a, cols[e]] * v[cols[e]]
            out[c * d + a] = acc


@_jit
def apply_island_impulse(J, G, cons, cols, d, pi, r, v_new):
    """The island's impulse ``pi`` (N,) into ``r`` (its contacts' rows) and
    ``v_new += G_II J_I^T pi`` on its coordinates ``cols``."""
    nc, nk = cons.shape[0], cols.shape[0]
    for c in range(nc):
        for a in range(d):
            r[cons[c], a] = pi[c * d + a]
    for e in range(nk):
        g = 0.0
        for c in range(nc):
            for a in range(d):
                g += J[cons[c], a, cols[e]] * pi[c * d + a]
        for f in range(nk):
            v_new[cols[f]] += G[cols[f], cols[e]] * g


@_jit
def assemble_islands(J, G, C, K, d, out):
    """``W_b = J_b G_bb J_b^T`` of every island b of one batch (contacts C[b], coordinates
    K[b]) into ``out`` (B * N * N, row-major, N = nc d), symmetrized
    (:func:`island_delassus`)."""
    B, nc = C.shape
    N = nc * d
    for b in range(B):
        island_delassus(J, G, C[b], K[b], d, out[b * N * N:(b + 1) * N * N].reshape(N, N))


@_jit
def solve_small_islands(Ja, b, mu_all, active, G, icon, icoff, icol, icoloff, d, coulomb,
                        tol, max_iter, newton_iter, last, use_start, r, res, used):
    """Solve the small islands of a step: island i has the active contacts
    ``icon[icoff[i]:icoff[i + 1]]`` (indices into ``Ja``, ``b``, ``active``) and the
    coordinates ``icol[icoloff[i]:icoloff[i + 1]]``; its W by :func:`island_delassus`.
    With ``use_start`` and a nonzero previous impulse (``last[active[c]]``) on the island,
    Newton on the law's natural map from there first, kept when certified; else the
    engine's compiled kernel. Writes the impulses into
    ``r`` (n_active, d), the residuals into ``res`` and the warm starts kept into ``used``;
    returns ``(iterations, warm starts kept, whether an island's residual is above tol or
    not a number)``."""
    n_isl = icoff.shape[0] - 1
    total = 0
    kept = 0
    bad = False
    for i in range(n_isl):
        c0, c1 = icoff[i], icoff[i + 1]
        k0, k1 = icoloff[i], icoloff[i + 1]
        nc = c1 - c0
        N = nc * d
        W = np.empty((N, N))
        island_delassus(Ja, G, icon[c0:c1], icol[k0:k1], d, W)
        bi = np.empty(N)
        mi = np.empty(nc)
        start = np.empty(N)
        warm = False
        for c in range(nc):
            ca = icon[c0 + c]
            mi[c] = mu_all[active[ca]]
            for rr in range(d):
                bi[c * d + rr] = b[ca, rr]
                s0 = last[active[ca], rr] if use_start else 0.0
                start[c * d + rr] = s0
                if s0 != 0.0:
                    warm = True
        used[i] = False
        done = False
        x = start
        if warm:
            x, steps = _warm(W, bi, mi, d, start, coulomb, newton_iter)
            total += steps
            rr_ = natural_map_residual(W, bi, mi, d, x, coulomb)
            if rr_ <= tol:
                used[i] = True
                kept += 1
                res[i] = rr_
                done = True
        if not done:
            if coulomb:
                x, status, it, steps, g1, g2 = coulomb_kernel(W, bi, mi, d, 1e-9, max_iter,
                                                              newton_iter)
            else:
                x, status, it, steps, g1, g2 = ccp_kernel(W, bi, mi, d, 1e-9, max_iter,
                                                          newton_iter)
            total += it + steps
            res[i] = natural_map_residual(W, bi, mi, d, x, coulomb)
        if not (res[i] <= tol):
            bad = True
        for c in range(nc):
            for rr in range(d):
                r[icon[c0 + c], rr] = x[c * d + rr]
    return total, kept, bad


@_jit
def apply_impulses(Ja, r, G, gflat, gsize, goff, v_free, v_new, gen, last, active, vn_k,
                   rest_velocity):
    """``gen = J^T r``, ``v_new = v_free + G gen`` (G block diagonal over the coordinate
    groups: flat indices ``gflat`` as in :func:`.moreau_step_kernels.block_times`), ``last``
    the impulses of every contact (zero where inactive); returns the number of contacts
    approaching at the step's start (``v_n,k < -rest_velocity``) that received a normal
    impulse."""
    na, d, k = Ja.shape
    for a in range(k):
        gen[a] = 0.0
    for c in range(na):
        for rr in range(d):
            x = r[c, rr]
            for a in range(k):
                gen[a] += Ja[c, rr, a] * x
    block_times(G, gflat, gsize, goff, gen, v_new)
    for i in range(k):
        v_new[i] = v_free[i] + v_new[i]
    last[:, :] = 0.0
    hits = 0
    for c in range(na):
        for rr in range(d):
            last[active[c], rr] = r[c, rr]
        if vn_k[c] < -rest_velocity and r[c, 0] > 0.0:
            hits += 1
    return hits


@_jit
def _same_active(active, key_active, na):
    if key_active.shape[0] != na:
        return False
    for c in range(na):
        if active[c] != key_active[c]:
            return False
    return True


@_jit
def _moves_as_key(Ja, c, a, key_moves):
    """Whether row block c of ``Ja`` moves column a (a nonzero entry) exactly where the key
    does."""
    moves = False
    for r in range(Ja.shape[1]):
        if Ja[c, r, a] != 0.0:
            moves = True
            break
    return moves == key_moves[c, a]


@_jit
def same_pattern(Ja, active, key_active, key_moves):
    """True when the active contacts are ``key_active`` and the columns their rows move
    (nonzero entries, ``key_moves`` (n_active, k)) are those of the key."""
    na, d, k = Ja.shape
    if not _same_active(active, key_active, na):
        return False
    for c in range(na):
        for a in range(k):
            if not _moves_as_key(Ja, c, a, key_moves):
                return False
    return True


@_jit
def same_pattern_on(Ja, active, key_active, key_moves, jcol, joff):
    """:func:`same_pattern` where contact c's rows are zero outside the columns
    ``jcol[joff[c]:joff[c + 1]]`` (:mod:`.moreau_step_kernels`): once the active contacts
    are the key's, each row is compared on its contact's columns only (``key_moves``, made
    from rows of the same contacts, is False outside them)."""
    na = Ja.shape[0]
    if not _same_active(active, key_active, na):
        return False
    for c in range(na):
        for t in range(joff[active[c]], joff[active[c] + 1]):
            if not _moves_as_key(Ja, c, jcol[t], key_moves):
                return False
    return True
