"""Compiled stick tier of the ``pereira-nikravesh`` law at several contacts.

:func:`stick_tier` runs, in one compiled call, what
:func:`~convimpact.impact.laws.pn_complementarity.stick_on` and the law's admissibility test
do for each candidate active set (every subset holding an approaching contact, up to
2^8 - 1 of them): the sticking system ``W_SS pi_S = -b_S`` (S: every row of a frictional
contact of A, the normal row of a frictionless one) solved by LU when
``cond_2(W_SS) < STICK_COND_MAX`` (the ratio of its extreme singular values: of its
eigenvalues' magnitudes, W_SS being symmetric), else in the
least-squares sense (the minimum-norm solution with numpy's default cut-off
``eps max(m, m)`` relative to the largest singular value, from the eigenvectors) and kept
only when consistent; then the cones and Newton's law on A and
no penetration off A, contact by contact with the same round-off allowances; then
``T+ - T- = pi.v- + 1/2 pi.W.pi``. The same numbers as numpy's ``cond``, ``solve`` and
``lstsq`` (the first and the last from the symmetric eigendecomposition rather than an SVD:
equal to round-off), so the answers are the Python path's to round-off; the Python path stays the
reference (``tests/impact/test_pn_complementarity_kernels.py`` compares them).
"""

from __future__ import annotations

import numpy as np

from ...compiled import jit as _jit

EPS = float(np.finfo(float).eps)
TINY = 1e-300


@_jit
def stick_tier(W, b, vminus, mu, d, sets, cond_max, cone_rtol, slack_max, tol):
    """Stick every active set of ``sets``; (admissible, energy change, impulses).

    Parameters
    ----------
    W : (N, N) Delassus matrix, ``N = n d``.
    b, vminus : (N,) Newton velocity shift ``v- + e min(v_n-, 0) n`` and ``v-``, flattened.
    mu : (n,) friction coefficients.
    d : contact dimension (2 or 3).
    sets : (n_sets, n) bool, the active sets.
    cond_max, cone_rtol, slack_max, tol : the law's STICK_COND_MAX, CONE_RTOL,
        VELOCITY_SLACK_MAX and the admissibility tolerance.

    Returns
    -------
    ok : (n_sets,) bool, the set's sticking impulse exists and is admissible.
    energy : (n_sets,) ``T+ - T-`` of the admissible ones.
    pis : (n_sets, N) their impulses.
    """
    n = mu.size
    N = n * d
    ns = sets.shape[0]
    ok = np.zeros(ns, dtype=np.bool_)
    energy = np.zeros(ns)
    pis = np.zeros((ns, N))
    absW = np.abs(W)
    rows = np.empty(N, dtype=np.int64)
    for s in range(ns):
        m = 0
        for i in range(n):
            if sets[s, i]:
                rows[m] = i * d
                m += 1
                if mu[i] > 0.0:
                    for k in range(1, d):
                        rows[m] = i * d + k
                        m += 1
        Wss = np.empty((m, m))
        r = np.empty(m)
        for a in range(m):
            r[a] = -b[rows[a]]
            for c in range(m):
                Wss[a, c] = W[rows[a], rows[c]]
        # W_SS is symmetric: its singular values are its eigenvalues' magnitudes, and its
        # minimum-norm least-squares solution is V diag(1/lambda) V^T r over the eigenvalues
        # above the cut-off eps m max|lambda| (gelsd's rule with numpy's default rcond)
        lam, V = np.linalg.eigh(Wss)
        ev = np.abs(lam)
        smin = np.min(ev)
        smax = np.max(ev)
        cond = smax / smin if smin > 0.0 else np.inf
        if cond < cond_max:
            x = np.linalg.solve(Wss, r)
        else:
            y = V.T @ r
            for a in range(m):
                y[a] = y[a] / lam[a] if ev[a] > EPS * m * smax else 0.0
            x = V @ y
            res = 0.0
            rn = 0.0
            for a in range(m):
                acc = -r[a]
                for c in range(m):
                    acc += Wss[a, c] * x[c]
                res += acc * acc
                rn += r[a] * r[a]
            if np.sqrt(res) > 1e-9 * max(np.sqrt(rn), TINY):
                continue
        pi = np.zeros(N)
        for a in range(m):
            pi[rows[a]] = x[a]
        if admissible(W, absW, sets[s], pi, b, mu, d, cone_rtol, slack_max, tol):
            ok[s] = True
            Wpi = W @ pi
            energy[s] = pi @ vminus + 0.5 * (pi @ Wpi)
            pis[s] = pi
    return ok, energy, pis


@_jit
def admissible(W, absW, A, pi, b, mu, d, cone_rtol, slack_max, tol):
    """The law's ``_admissible`` (pn_complementarity): cones and pi_n >= 0 on A, u_n >= 0
    off A, each to its own round-off allowance."""
    n = mu.size
    Wpi = W @ pi
    ro = absW @ np.abs(pi)
    for i in range(n):
        size = 0.0
        roundoff = 0.0
        for k in range(d):
            j = i * d + k
            size = max(size, max(abs(b[j]), abs(Wpi[j])))
            roundoff = max(roundoff, 1e2 * EPS * ro[j])
        slack = max(tol * size, min(roundoff, slack_max * size))
        if A[i]:
            pn = pi[i * d]
            pt2 = 0.0
            for k in range(1, d):
                pt2 += pi[i * d + k] ** 2
            pt = np.sqrt(pt2)
            pnorm = np.sqrt(pn * pn + pt2)
            ptol = max(tol * pnorm, slack / W[i * d, i * d])
            if pn < -ptol or pt > mu[i] * pn * (1.0 + cone_rtol) + ptol:
                return False
        elif Wpi[i * d] + b[i * d] < -slack:
            return False
    return True


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


@_jit
def _sliding_guess(q, relaxed, mu, d, zero_mask, r_floor):
    """Kinds and start: frictional contacts on the cone boundary against their slip before
    impact (inside the cone without slip), frictionless ones pressing; ``zero_mask``
    contacts at zero."""
    n = mu.size
    kind = np.zeros(n, dtype=np.int64)
    tang = np.zeros((n, 2))
    x0 = np.zeros(n * d)
    for i in range(n):
        o = i * d
        if zero_mask[i]:
            kind[i] = ZERO
            continue
        r = max(relaxed[o], r_floor)
        s2 = 0.0
        for a in range(1, d):
            s2 += q[o + a] ** 2
        sn = np.sqrt(s2)
        x0[o] = r
        if mu[i] == 0.0:
            kind[i] = ACT
        elif sn > 0.0:
            kind[i] = BND
            for a in range(1, d):
                tang[i, a - 1] = -q[o + a] / sn
                x0[o + a] = r * mu[i] * tang[i, a - 1]
        else:
            kind[i] = INT
            for a in range(1, d):
                x0[o + a] = relaxed[o + a]
    return kind, tang, x0


@_jit
def _relaxed_kinds(x, mu, d):
    """The polish's primary classification of ``x`` (``_contact_kinds``)."""
    n = mu.size
    kind = np.zeros(n, dtype=np.int64)
    tang = np.zeros((n, 2))
    X = max(np.max(np.abs(x)), TINY)
    for i in range(n):
        o = i * d
        xt2 = 0.0
        for a in range(1, d):
            xt2 += x[o + a] ** 2
        xt = np.sqrt(xt2)
        nx = np.sqrt(x[o] ** 2 + xt2)
        if nx <= 1e-4 * X or x[o] <= 0.0:
            kind[i] = ZERO
        elif mu[i] == 0.0:
            kind[i] = ACT
        elif (mu[i] * x[o] - xt) / max(nx, TINY) <= 1e-4:
            kind[i] = BND
            if xt > 0.0:
                for a in range(1, d):
                    tang[i, a - 1] = x[o + a] / xt
            else:
                tang[i, 0] = 1.0
        else:
            kind[i] = INT
    return kind, tang


@_jit
def slide_set(Wf, vf, bf, muf, d, A):
    """P_N over the active set ``A`` (contact indices) from guessed active sets of the cones,
    certified by the KKT conditions (:mod:`.pn_complementarity_slide`).

    Returns (status, pi): status 1 certified (pi the minimizer, (n_all d,)), 0 no guess
    consistent (the caller solves by the interior-point method), -1 the program is trivial
    (pi = 0), -2 W is zero (the caller raises through the interior-point path).
    """
    na = A.size
    N = na * d
    idx = np.empty(N, dtype=np.int64)
    for a in range(na):
        for k in range(d):
            idx[a * d + k] = A[a] * d + k
    W = np.empty((N, N))
    q = np.empty(N)
    mu = np.empty(na)
    for a in range(N):
        q[a] = vf[idx[a]]
        for c in range(N):
            W[a, c] = Wf[idx[a], idx[c]]
    f = np.empty(na)
    for a in range(na):
        mu[a] = muf[A[a]]
        f[a] = -bf[A[a] * d]
    pi = np.zeros(Wf.shape[0])
    # equilibration (conic.qp.equilibrated)
    D = np.empty(N)
    for a in range(na):
        dg = 0.0
        for k in range(d):
            dg = max(dg, W[a * d + k, a * d + k])
        c = 1.0 / np.sqrt(dg) if dg > 0.0 else 1.0
        for k in range(d):
            D[a * d + k] = c
    for a in range(N):
        q[a] *= D[a]
        for c in range(N):
            W[a, c] *= D[a] * D[c]
    E = np.empty((na, N))
    for a in range(na):
        for c in range(N):
            E[a, c] = W[a * d, c] / D[a * d]  # rows of the unscaled W, columns scaled
    sW = np.max(np.abs(W))
    sq = max(np.max(np.abs(q)), np.max(np.abs(f)))
    if not sW > 0.0:
        return -2, pi
    if sq == 0.0:
        return -1, pi
    sE = max(np.max(np.abs(E)), TINY)
    W = W / sW
    q = q / sq
    E = E / sE
    f = f * (sW / (sq * sE))
    scale = D * (sq / sW)
    # the program without the cones, for the starts
    K = np.zeros((N + na, N + na))
    rhs = np.zeros(N + na)
    for a in range(N):
        rhs[a] = -q[a]
        for c in range(N):
            K[a, c] = W[a, c]
        for c in range(na):
            K[a, N + c] = E[c, a]
            K[N + c, a] = E[c, a]
    for c in range(na):
        rhs[N + c] = f[c]
    relaxed = np.linalg.lstsq(K, rhs, EPS * (N + na))[0][:N]
    if not np.all(np.isfinite(relaxed)):
        return 0, pi
    r_floor = 0.0
    for a in range(na):
        r_floor = max(r_floor, relaxed[a * d])
    r_floor = max(r_floor, 1.0) * 1e-2
    zero_mask = np.zeros(na, dtype=np.bool_)
    # 1. everything sliding against its slip
    kind, tang, x0 = _sliding_guess(q, relaxed, mu, d, zero_mask, r_floor)
    x, ok = kkt_newton(W, q, E, f, mu, d, kind, tang, x0, POLISH_MAX_NEWTON, False)
    if not ok:
        # 2. the classification of the impulse without the cones
        kind, tang = _relaxed_kinds(relaxed, mu, d)
        x, ok = kkt_newton(W, q, E, f, mu, d, kind, tang, relaxed, POLISH_MAX_NEWTON, False)
    n_pulled = 0
    if not ok:
        # 3. as 1, with the contacts the cone-free impulse pulls at zero (damped)
        for a in range(na):
            zero_mask[a] = relaxed[a * d] <= 0.0
            n_pulled += zero_mask[a]
        if 0 < n_pulled < na:
            kind, tang, x0 = _sliding_guess(q, relaxed, mu, d, zero_mask, r_floor)
            x, ok = kkt_newton(W, q, E, f, mu, d, kind, tang, x0, DAMPED_MAX_NEWTON, True)
    if not ok and na > 2:
        # 4. as 1, with one contact at zero (damped), the one the cone-free impulse presses
        # least first (3. tried it when it was the only one pulled)
        for z in np.argsort(relaxed[::d]):
            if n_pulled == 1 and relaxed[z * d] <= 0.0:
                continue
            for a in range(na):
                zero_mask[a] = a == z
            kind, tang, x0 = _sliding_guess(q, relaxed, mu, d, zero_mask, r_floor)
            x, ok = kkt_newton(W, q, E, f, mu, d, kind, tang, x0, DAMPED_MAX_NEWTON, True)
            if ok:
                break
    if not ok:
        return 0, pi
    for a in range(N):
        pi[idx[a]] = x[a] * scale[a]
    return 1, pi


@_jit
def relaxed_bounds(W, b, vminus, mu, d, sets):
    """The law's ``relaxed_bound`` of every active set of ``sets``: min of T+ - T- over the
    impulses on A with ``u_n = 0`` there, without the cones (the KKT system of the
    equality-constrained QP, least squares with numpy's default cut-off), +inf where the
    equalities cannot hold (a residual above 1e-8 of the right-hand side)."""
    n = mu.size
    N = n * d
    ns = sets.shape[0]
    out = np.empty(ns)
    rows = np.empty(N, dtype=np.int64)
    normals = np.empty(n, dtype=np.int64)
    for s in range(ns):
        m = 0
        k = 0
        for i in range(n):
            if sets[s, i]:
                normals[k] = i * d
                k += 1
                rows[m] = i * d
                m += 1
                if mu[i] > 0.0:
                    for a in range(1, d):
                        rows[m] = i * d + a
                        m += 1
        size = m + k
        K = np.zeros((size, size))
        rhs = np.empty(size)
        for a in range(m):
            rhs[a] = -vminus[rows[a]]
            for c in range(m):
                K[a, c] = W[rows[a], rows[c]]
        for a in range(k):
            rhs[m + a] = -b[normals[a]]
            for c in range(m):
                K[m + a, c] = W[normals[a], rows[c]]
                K[c, m + a] = W[normals[a], rows[c]]
        sol = np.linalg.lstsq(K, rhs, EPS * size)[0]
        res = 0.0
        rn = 0.0
        for a in range(size):
            acc = -rhs[a]
            for c in range(size):
                acc += K[a, c] * sol[c]
            res += acc * acc
            rn += rhs[a] * rhs[a]
        if np.sqrt(res) > 1e-8 * max(np.sqrt(rn), TINY):
            out[s] = np.inf
            continue
        pi = np.zeros(N)
        for a in range(m):
            pi[rows[a]] = sol[a]
        out[s] = pi @ vminus + 0.5 * (pi @ (W @ pi))
    return out


@_jit
def slide_many(W, b, vminus, mu, d, sets, cone_rtol, slack_max, tol):
    """:func:`slide_set` on every active set of ``sets`` with several contacts, then the law's
    admissibility test (tolerance ``tol``) and ``T+ - T-`` of each certified or trivial one.

    Returns
    -------
    status : (n_sets,) slide_set's status (one-contact sets: -3, not solved).
    pis : (n_sets, N) the impulses of status 1 and -1.
    ok : (n_sets,) bool, admissible.
    energy : (n_sets,) their ``T+ - T-``.
    """
    ns = sets.shape[0]
    N = W.shape[0]
    status = np.full(ns, -3, dtype=np.int64)
    pis = np.zeros((ns, N))
    ok = np.zeros(ns, dtype=np.bool_)
    energy = np.zeros(ns)
    absW = np.abs(W)
    for s in range(ns):
        A = np.flatnonzero(sets[s])
        if A.size < 2:
            continue
        st, pi = slide_set(W, vminus, b, mu, d, A)
        status[s] = st
        if st == 1 or st == -1:
            pis[s] = pi
            ok[s] = admissible(W, absW, sets[s], pi, b, mu, d, cone_rtol, slack_max, tol)
            energy[s] = pi @ vminus + 0.5 * (pi @ (W @ pi))
    return status, pis, ok, energy
