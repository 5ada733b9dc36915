"""The KKT equations of a cone QP on one active set of its cones, solved by Newton's method in
compiled code: :func:`kkt_newton`, the polish's
:func:`~convimpact.impact.conic.polish._newton_on_active_set` (``near=False``, the cone QP,
not Coulomb's law) for the slide programs of law ``pereira-nikravesh``
(:mod:`.pn_complementarity_slide`).

Each contact of the active set is at zero, pressing (frictionless), inside its cone, or on
its boundary ``x_i = r (1, mu c)`` with the dual ``z_i = kappa (mu, -c)`` (c a unit tangent
at angle a in space); the unknowns are those parameters and the multipliers of ``E x = f``.
The answer is accepted when the scaled residual is at round-off (:data:`POLISH_ACCEPT`) and
the active set is consistent (r > 0, kappa >= 0, interior impulses inside, the duals of zero
contacts in the dual cone): it then *is* the program's minimizer (the KKT conditions of a
convex program are sufficient), however it was reached.
"""

from __future__ import annotations

import numpy as np

from ...compiled import jit as _jit

EPS = float(np.finfo(float).eps)
TINY = 1e-300
# kinds of a contact in an active set of the cones (the polish's "zero", "act", "int", "bnd")
ZERO, ACT, INT, BND = 0, 1, 2, 3
POLISH_MAX_NEWTON = 12
POLISH_ACCEPT = 1e-11
#: iterations of the damped Newton from the guesses farther from the answer
DAMPED_MAX_NEWTON = 30
VELOCITY_RESIDUAL_MAX = 1e-4


@_jit
def _layout(kind, d):
    n = kind.size
    start = np.zeros(n + 1, dtype=np.int64)
    for i in range(n):
        k = kind[i]
        w = 0
        if k == INT:
            w = d
        elif k == ACT:
            w = 1
        elif k == BND:
            w = 3 if d == 3 else 2
        start[i + 1] = start[i] + w
    return start


@_jit
def _unpack(u, kind, tang, mu, d, start):
    """x, z and their Jacobians in the unknowns u (the polish's parametrization)."""
    n = kind.size
    N = n * d
    U = u.size
    x = np.zeros(N)
    z = np.zeros(N)
    Jx = np.zeros((N, U))
    Jz = np.zeros((N, U))
    for i in range(n):
        s = start[i]
        o = i * d
        k = kind[i]
        m_ = mu[i]
        if k == INT:
            for a in range(d):
                x[o + a] = u[s + a]
                Jx[o + a, s + a] = 1.0
        elif k == ACT:
            x[o] = u[s]
            Jx[o, s] = 1.0
        elif k == BND:
            if d == 3:
                r, ang, kap = u[s], u[s + 1], u[s + 2]
                c, sn = np.cos(ang), np.sin(ang)
                x[o] = r
                x[o + 1] = r * m_ * c
                x[o + 2] = r * m_ * sn
                Jx[o, s] = 1.0
                Jx[o + 1, s] = m_ * c
                Jx[o + 2, s] = m_ * sn
                Jx[o + 1, s + 1] = -r * m_ * sn
                Jx[o + 2, s + 1] = r * m_ * c
                z[o] = kap * m_
                z[o + 1] = -kap * c
                z[o + 2] = -kap * sn
                Jz[o + 1, s + 1] = kap * sn
                Jz[o + 2, s + 1] = -kap * c
                Jz[o, s + 2] = m_
                Jz[o + 1, s + 2] = -c
                Jz[o + 2, s + 2] = -sn
            else:
                r, kap = u[s], u[s + 1]
                sg = tang[i, 0]
                x[o] = r
                x[o + 1] = r * m_ * sg
                Jx[o, s] = 1.0
                Jx[o + 1, s] = m_ * sg
                z[o] = kap * m_
                z[o + 1] = -kap * sg
                Jz[o, s + 1] = m_
                Jz[o + 1, s + 1] = -sg
    return x, z, Jx, Jz


@_jit
def _residual(u, W, q, E, f, kind, tang, mu, d, start, eq_rows, n_prim, scales):
    N = W.shape[0]
    m = E.shape[0]
    U = u.size
    x, z, Jx, Jz = _unpack(u, kind, tang, mu, d, start)
    lam = u[n_prim:]
    X = max(np.max(np.abs(x)) if N else 0.0, TINY)
    sG = max(scales[0], scales[1] * X, TINY)
    sE = max(scales[2], scales[3] * X, TINY)
    G = W @ x + q - E.T @ lam - z
    dG = W @ Jx - Jz
    for a in range(N):
        for c in range(m):
            dG[a, n_prim + c] -= E[c, a]
    n_eq = 0
    for a in range(N):
        if eq_rows[a]:
            n_eq += 1
    F = np.empty(n_eq + m)
    J = np.empty((n_eq + m, U))
    row = 0
    for a in range(N):
        if eq_rows[a]:
            F[row] = G[a] / sG
            for c in range(U):
                J[row, c] = dG[a, c] / sG
            row += 1
    Ex = E @ x
    EJ = E @ Jx
    for c in range(m):
        F[row] = (Ex[c] - f[c]) / sE
        for k in range(U):
            J[row, k] = EJ[c, k] / sE
        row += 1
    return F, J, x, G


@_jit
def _minimum_norm_step(J, F):
    """``-J^+ F`` from the eigenvectors of ``J^T J``, its eigenvalues below 1e-15 of the
    largest (singular values of J below 3e-8 of its largest: the redundant directions, which
    round-off leaves at 1e-16) taken as zero. A Newton step only: the answer is accepted on
    its residual and sign conditions, never on how it was reached."""
    lam, V = np.linalg.eigh(J.T @ J)
    g = V.T @ (J.T @ F)
    top = np.max(lam)
    for a in range(lam.size):
        g[a] = -g[a] / lam[a] if lam[a] > 1e-15 * top else 0.0
    return V @ g


@_jit
def _newton_step(J, F):
    """The minimum-norm solution of ``J s = -F`` (the polish's ``lstsq`` with rcond 1e-13).

    J is square here (one equation per unknown of the active set's parametrization): Gaussian
    elimination with complete pivoting answers when every pivot exceeds 1e-10 of the largest
    (J safely nonsingular: its solution is the minimum-norm one to round-off); a smaller
    pivot (redundant contacts, a singular J) takes :func:`_minimum_norm_step`.
    """
    n = F.size
    if J.shape[0] != n or J.shape[1] != n:
        return np.linalg.lstsq(J, -F, 1e-13)[0]
    A = J.copy()
    r = -F
    perm = np.arange(n)
    first = 0.0
    for k in range(n):
        p, c, big = k, k, 0.0
        for i in range(k, n):
            for j in range(k, n):
                if abs(A[i, j]) > big:
                    big, p, c = abs(A[i, j]), i, j
        if k == 0:
            first = big
        if not big > 1e-10 * first or big == 0.0:
            return _minimum_norm_step(J, F)
        if p != k:
            for j in range(n):
                A[k, j], A[p, j] = A[p, j], A[k, j]
            r[k], r[p] = r[p], r[k]
        if c != k:
            for i in range(n):
                A[i, k], A[i, c] = A[i, c], A[i, k]
            perm[k], perm[c] = perm[c], perm[k]
        for i in range(k + 1, n):
            fct = A[i, k] / A[k, k]
            if fct != 0.0:
                for j in range(k + 1, n):
                    A[i, j] -= fct * A[k, j]
                r[i] -= fct * r[k]
    y = np.empty(n)
    for k in range(n - 1, -1, -1):
        acc = r[k]
        for j in range(k + 1, n):
            acc -= A[k, j] * y[j]
        y[k] = acc / A[k, k]
    x = np.empty(n)
    for k in range(n):
        x[perm[k]] = y[k]
    return x


@_jit
def kkt_newton(W, q, E, f, mu, d, kind, tang, x0, max_iter, damped):
    """The polish's Newton on the KKT equations of one active set of the cones
    (:func:`convimpact.impact.conic.polish._newton_on_active_set` with ``near=False``, for the
    cone QP): minimum-norm steps, accepted when the residual is at round-off and the active
    set consistent (then x is the program's minimizer). ``damped``: backtracking steps and
    no early stop, up to ``max_iter`` iterations (for starts far from the answer; the
    acceptance is the same). Returns (x, ok)."""
    n = mu.size
    N = n * d
    m = E.shape[0]
    start = _layout(kind, d)
    n_prim = start[n]
    U = n_prim + m
    g0 = W @ x0 + q
    u = np.zeros(U)
    for i in range(n):
        s = start[i]
        o = i * d
        if kind[i] == INT:
            for a in range(d):
                u[s + a] = x0[o + a]
        elif kind[i] == ACT:
            u[s] = max(x0[o], 0.0)
        elif kind[i] == BND:
            nx = 0.0
            for a in range(d):
                nx += x0[o + a] ** 2
            u[s] = max(x0[o], np.sqrt(nx) / (1.0 + mu[i]), 0.0)
            kap = max(g0[o] / mu[i], 0.0)
            if d == 3:
                u[s + 1] = np.arctan2(tang[i, 1], tang[i, 0])
                u[s + 2] = kap
            else:
                u[s + 1] = kap
    if m:
        lam0 = np.linalg.lstsq(np.ascontiguousarray(E.T), g0, EPS * max(N, m))[0]
        for c in range(m):
            u[n_prim + c] = lam0[c]
    eq_rows = np.zeros(N, dtype=np.bool_)
    for i in range(n):
        if kind[i] == INT or kind[i] == BND:
            for a in range(d):
                eq_rows[i * d + a] = True
        elif kind[i] == ACT:
            eq_rows[i * d] = True
    qmax = np.max(np.abs(q)) if N else 0.0
    scales = np.array([qmax, np.max(np.abs(W)) if N else 0.0,
                       np.max(np.abs(f)) if m else 0.0, np.max(np.abs(E)) if m else 0.0])
    best_f = np.inf
    best_u = u.copy()
    f0 = -1.0
    prev = np.inf
    for it in range(max_iter):
        F, J, x, G = _residual(u, W, q, E, f, kind, tang, mu, d, start, eq_rows, n_prim,
                               scales)
        fn = np.max(np.abs(F)) if F.size else 0.0
        if f0 < 0.0:
            f0 = fn
        if fn < best_f:
            best_f = fn
            best_u = u.copy()
        if fn <= 4.0 * EPS or (it >= 4 and best_f > 1e-6 * f0 and not damped):
            break
        if it > 0 and fn <= POLISH_ACCEPT and fn > 0.25 * prev:
            break  # at round-off and no longer falling (a singular J: redundant contacts)
        prev = fn
        if F.size == 0 or U == 0:
            break
        step = _newton_step(J, F)
        if not np.all(np.isfinite(step)):
            break
        if damped:
            # halve the step until the residual falls (a start far from the answer)
            t = 1.0
            for _ in range(10):
                Ft = _residual(u + t * step, W, q, E, f, kind, tang, mu, d, start, eq_rows,
                               n_prim, scales)[0]
                if np.max(np.abs(Ft)) < fn:
                    break
                t *= 0.5
            u = u + t * step
        else:
            u = u + step
    F, J, x, G = _residual(best_u, W, q, E, f, kind, tang, mu, d, start, eq_rows, n_prim,
                           scales)
    u = best_u
    if F.size and np.max(np.abs(F)) > POLISH_ACCEPT:
        return x, False
    Wx = W @ x
    V = max(qmax, np.max(np.abs(Wx)) if N else 0.0, TINY)
    for a in range(N):
        if eq_rows[a] and abs(G[a]) > VELOCITY_RESIDUAL_MAX * V:
            return x, False
    # the active set's sign conditions (polish._consistent, the cone QP's)
    X = max(np.max(np.abs(x)) if N else 0.0, TINY)
    floor = EPS * (np.max(np.abs(W)) if N else 0.0) * X / V
    vtol = V * max(1e-10, min(1e2 * floor, VELOCITY_RESIDUAL_MAX))
    for i in range(n):
        o = i * d
        gt = 0.0
        xt = 0.0
        for a in range(1, d):
            gt += G[o + a] ** 2
            xt += x[o + a] ** 2
        if kind[i] == ZERO:
            if mu[i] == 0.0:
                if G[o] < -vtol:
                    return x, False
            elif mu[i] * np.sqrt(gt) > G[o] + vtol:
                return x, False
        elif kind[i] == ACT:
            if x[o] < -1e-12 * X:
                return x, False
        elif kind[i] == INT:
            if not (x[o] >= 0.0 and np.sqrt(xt) <= mu[i] * x[o] + 1e-12 * X):
                return x, False
        elif kind[i] == BND:
            if not (u[start[i]] > 0.0 and u[start[i + 1] - 1] >= -vtol):
                return x, False
    return x, True
