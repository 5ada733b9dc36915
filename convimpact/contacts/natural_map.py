"""The semismooth Newton method on the natural map of a second-order cone complementarity
problem (compiled), which finishes the several-contact solver.

``F(x) = x - Proj_K(x - y(x))`` over the product K of second-order cones, with ``y = P x + q``
(plus, for Coulomb's law, the shift ``|w_t| e`` per contact): Hayashi, Yamashita & Fukushima,
SIAM J. Optim. 15, 2005. The generalized Jacobian is ``I - D (I - dy/dx)`` with D the
Jacobian of the projection (:func:`_project`); a singular system (redundant contacts) is solved
for a basic solution (:func:`_basic_solve`). :mod:`convimpact.contacts.newton` poses
the programs and calls :func:`natural_map_newton`.
"""

from __future__ import annotations

import math

import numpy as np

from .interior_point import EPS, _jit


@_jit
def _project(u, o, m, out, D, jac):
    """out[o:o+m] = the projection of u's block onto the second-order cone; with ``jac``,
    its (generalized) Jacobian into D[o:o+m, o:o+m]."""
    if jac:
        for a in range(o, o + m):
            for c in range(o, o + m):
                D[a, c] = 0.0
    t = 0.0
    for j in range(o + 1, o + m):
        t += u[j] * u[j]
    t = math.sqrt(t)
    u0 = u[o]
    if t <= u0:  # inside the cone
        for j in range(o, o + m):
            out[j] = u[j]
        if jac:
            for j in range(o, o + m):
                D[j, j] = 1.0
    elif t <= -u0:  # inside the polar cone
        for j in range(o, o + m):
            out[j] = 0.0
    else:
        h = 0.5 * (u0 + t)
        out[o] = h
        for j in range(o + 1, o + m):
            out[j] = h * u[j] / t
        if jac:
            D[o, o] = 0.5
            r = u0 / t
            for j in range(o + 1, o + m):
                wj = u[j] / t
                D[o, j] = 0.5 * wj
                D[j, o] = 0.5 * wj
                for k in range(o + 1, o + m):
                    D[j, k] = -0.5 * r * wj * u[k] / t
                D[j, j] += 0.5 * (1.0 + r)


@_jit
def _basic_solve(A, rhs, out, perm):
    """A basic solution of ``A out = rhs`` by Gaussian elimination with complete pivoting,
    in place (A and rhs are overwritten). Pivots below 1e-12 of the largest are treated as
    zero: their unknowns are set to 0 (the Jacobian is singular where contacts are
    redundant, and the system is then consistent on the remaining ones)."""
    n = rhs.shape[0]
    cols = perm
    for i in range(n):
        cols[i] = i
    big = 0.0
    for i in range(n):
        for j in range(n):
            if abs(A[i, j]) > big:
                big = abs(A[i, j])
    rank = n
    for k in range(n):
        # complete pivoting on the remaining block
        pr, pc, pv = k, k, 0.0
        for i in range(k, n):
            for j in range(k, n):
                if abs(A[i, j]) > pv:
                    pv, pr, pc = abs(A[i, j]), i, j
        if not pv > 1e-12 * big:
            rank = k
            break
        if pr != k:
            for j in range(n):
                A[k, j], A[pr, j] = A[pr, j], A[k, j]
            rhs[k], rhs[pr] = rhs[pr], rhs[k]
        if pc != k:
            for i in range(n):
                A[i, k], A[i, pc] = A[i, pc], A[i, k]
            cols[k], cols[pc] = cols[pc], cols[k]
        inv = 1.0 / A[k, k]
        for i in range(k + 1, n):
            f = A[i, k] * inv
            if f != 0.0:
                for j in range(k + 1, n):
                    A[i, j] -= f * A[k, j]
                rhs[i] -= f * rhs[k]
    y = np.zeros(n)
    for k in range(rank - 1, -1, -1):
        s = rhs[k]
        for j in range(k + 1, rank):
            s -= A[k, j] * y[j]
        y[k] = s / A[k, k]
    for k in range(n):
        out[cols[k]] = y[k]


@_jit
def _natural_map(P, q, x, starts, sizes, F, D, G, jac, coulomb, u, proj):
    """F = x - Proj_K(x - y), y = P x + q (+ |w_t| e per cone for Coulomb's law); with
    ``jac``, D = the projection's Jacobian and G = dy/dx."""
    N = q.shape[0]
    for i in range(N):
        s = q[i]
        for j in range(N):
            s += P[i, j] * x[j]
        u[i] = s  # y, shifted below
    if jac:
        for i in range(N):
            for j in range(N):
                G[i, j] = P[i, j]
    if coulomb:
        for c in range(starts.shape[0]):
            o, m = starts[c], sizes[c]
            if m == 1:
                continue
            t = 0.0
            for j in range(o + 1, o + m):
                t += u[j] * u[j]
            t = math.sqrt(t)
            if jac and t > 0.0:
                for j in range(o + 1, o + m):
                    f = u[j] / t
                    for k in range(N):
                        G[o, k] += f * P[j, k]
            u[o] += t
    for i in range(N):
        u[i] = x[i] - u[i]
    for c in range(starts.shape[0]):
        _project(u, starts[c], sizes[c], proj, D, jac)
    fmax = 0.0
    for i in range(N):
        F[i] = x[i] - proj[i]
        if abs(F[i]) > fmax:
            fmax = abs(F[i])
    return fmax


@_jit
def natural_map_newton(P, q, x, starts, sizes, max_iter, coulomb):
    """Semismooth Newton on the natural map ``F(x) = x - Proj_K(x - y(x))`` from ``x``.

    Steps are basic solutions of ``(I - D (I - G)) dx = -F`` (G = dy/dx may be singular:
    redundant contacts), damped by halving until |F| drops. Returns ``(x, |F|_inf, steps)``
    with x replaced by ``Proj_K(x - y)``, which lies in K exactly.
    """
    N = q.shape[0]
    F = np.empty(N)
    Fn = np.empty(N)
    D = np.zeros((N, N))
    G = np.empty((N, N))
    J = np.empty((N, N))
    u = np.empty(N)
    proj = np.empty(N)
    xn = np.empty(N)
    rhs = np.empty(N)
    dx = np.empty(N)
    perm = np.empty(N, dtype=np.int64)
    # the flags as run-time booleans: one compiled _natural_map serves the four calls (a
    # constant argument compiles a specialization per value)
    jac, nojac, coulomb = bool(True), bool(False), bool(coulomb)
    fmax = _natural_map(P, q, x, starts, sizes, F, D, G, jac, coulomb, u, proj)
    steps = 0
    for steps in range(max_iter):
        if fmax <= 4.0 * EPS:
            break
        # J = I - D (I - G), D block diagonal: row i sums over its own cone's block only
        # (the same sums as over all k, whose other terms are exact zeros; N^2 m flops,
        # not N^3)
        for c in range(starts.shape[0]):
            o, m = starts[c], sizes[c]
            for i in range(o, o + m):
                for j in range(N):
                    s = 0.0
                    for k in range(o, o + m):
                        s += D[i, k] * ((1.0 if k == j else 0.0) - G[k, j])
                    J[i, j] = (1.0 if i == j else 0.0) - s
                rhs[i] = -F[i]
        _basic_solve(J, rhs, dx, perm)
        t = 1.0
        accepted = False
        for _ in range(12):
            for i in range(N):
                xn[i] = x[i] + t * dx[i]
            fn = _natural_map(P, q, xn, starts, sizes, Fn, D, G, nojac, coulomb, u, proj)
            if fn < fmax:
                accepted = True
                break
            t *= 0.5
        if not accepted:
            # proj holds the last trial's projection: take it again at x
            fmax = _natural_map(P, q, x, starts, sizes, F, D, G, nojac, coulomb, u, proj)
            break
        for i in range(N):
            x[i] = xn[i]
        fmax = _natural_map(P, q, x, starts, sizes, F, D, G, jac, coulomb, u, proj)
    for i in range(N):
        x[i] = proj[i]
    return x, fmax, steps
