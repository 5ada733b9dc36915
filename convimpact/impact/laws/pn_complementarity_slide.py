"""P-N's slide program over one active set solved exactly in compiled code from guessed active
sets of its cones, certified by its KKT conditions, before any interior-point solve.

The slide tier of :mod:`~convimpact.impact.laws.pn_complementarity` solves, for each
candidate active set A with several contacts,

    P_N(A):  minimize 1/2 pi.W.pi + v-.pi   subject to   u_n = 0 on A,   pi_i in K_mu_i,

a convex cone QP. :func:`slide_set` equilibrates it as
:func:`~convimpact.impact.conic.qp.solve_cone_qp` does and solves the KKT equations of
guessed active sets (the polish's Newton, :func:`~convimpact.impact.conic.polish_newton.
active_set_newton`, with pivoted steps), from the impulse of the same program without the
cones:

1. every frictional contact on its cone boundary against its slip before impact (inside its
   cone without slip), every frictionless one pressing;
2. the polish's classification of the cone-free impulse;
3. as 1, the contacts the cone-free impulse pulls at zero (damped Newton);
4. as 1, one contact at zero, the least pressed first (damped; three contacts or more).

The first consistent one is the minimizer: the polished answer of the interior-point path
to round-off where P_N(A) has one minimizer; where redundant contacts leave a family of
minimizers (a box's four corners) one of them, with the same velocities and energy (measured
1e-8 apart on the sliding box). When no guess is consistent the caller solves by the
interior-point method. :func:`slide_many` does it for every active set of the tier at once,
with the law's admissibility test and ``T+ - T-``.
"""

from __future__ import annotations

import numpy as np

from ...compiled import jit as _jit
from ..problem.compiled_reduction import back_substitute
from .pn_complementarity_kernels import admissible
from ..conic.polish_newton import (ACT, BND, DAMPED_MAX_NEWTON, INT, POLISH_MAX_NEWTON, ZERO,
                                   active_set_newton, primary_kinds)

EPS = float(np.finfo(float).eps)
TINY = 1e-300
#: :func:`warm_kkt_point`: the residuals of the KKT conditions accepted, relative to
#: ``max(|v-|, |b|, |W| |pi|)`` (the polish's POLISH_ACCEPT), and a contact read as on its
#: cone's boundary within this of ``mu pn`` (relative)
KKT_RTOL = 1e-11
BOUNDARY_RTOL = 1e-10


@_jit
def _kkt(W, q, E, f, mu, d, kind, tang, x0, max_iter, damped):
    """The cone QP's KKT equations on one active set (not Coulomb's, no closeness test),
    pivoted Newton steps: (x, accepted)."""
    return active_set_newton(W, q, E, f, mu, d, kind, tang, x0, False, False, max_iter, damped,
                             True)


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
def slide_set(Wf, vf, bf, muf, d, A):
    """P_N over the active set ``A`` (contact indices) from guessed active sets of the cones,
    certified by the KKT conditions (:mod:`.pn_complementarity_slide`).

    Returns (status, pi): status 1 certified (pi the minimizer, (n_all d,)), 0 no guess
    consistent (the caller solves by the interior-point method), -1 the program is trivial
    (pi = 0), -2 W is zero (the caller raises through the interior-point path).
    """
    n = muf.size
    st, pi, _, _ = slide_set_warm(Wf, vf, bf, muf, d, A, np.zeros(n, dtype=np.int64),
                                  np.zeros((n, 2)), np.zeros(Wf.shape[0]), False)
    return st, pi


@_jit
def slide_set_warm(Wf, vf, bf, muf, d, A, wkind, wtang, wpi, warm):
    """:func:`slide_set`, first trying (with ``warm``) the active set of the cones ``wkind``,
    ``wtang`` (per contact of A) from the impulse ``wpi`` (n_all d,) -- a previous time step's
    answer to the same set: an accepted Newton answer is a KKT point of the convex program,
    so a minimizer whatever its start (where redundant contacts leave a family of
    minimizers, possibly another member, with the same velocities and energy). Returns
    (status, pi, kind, tang): the active set of the certified answer, for the next step."""
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
    no_kind = np.zeros(na, dtype=np.int64)
    no_tang = np.zeros((na, 2))
    if not sW > 0.0:
        return -2, pi, no_kind, no_tang
    if sq == 0.0:
        return -1, pi, no_kind, no_tang
    sE = max(np.max(np.abs(E)), TINY)
    W = W / sW
    q = q / sq
    E = E / sE
    f = f * (sW / (sq * sE))
    scale = D * (sq / sW)
    if warm:
        kind = wkind[:na].copy()
        tang = wtang[:na].copy()
        x0 = np.empty(N)
        for a in range(N):
            x0[a] = wpi[idx[a]] / scale[a]
        x, ok = _kkt(W, q, E, f, mu, d, kind, tang, x0, POLISH_MAX_NEWTON, False)
        if ok:
            for a in range(N):
                pi[idx[a]] = x[a] * scale[a]
            return 1, pi, kind, tang
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
        return 0, pi, no_kind, no_tang
    r_floor = 0.0
    for a in range(na):
        r_floor = max(r_floor, relaxed[a * d])
    r_floor = max(r_floor, 1.0) * 1e-2
    zero_mask = np.zeros(na, dtype=np.bool_)
    # 1. everything sliding against its slip
    kind, tang, x0 = _sliding_guess(q, relaxed, mu, d, zero_mask, r_floor)
    x, ok = _kkt(W, q, E, f, mu, d, kind, tang, x0, POLISH_MAX_NEWTON, False)
    if not ok:
        # 2. the classification of the impulse without the cones
        kind, tang = primary_kinds(relaxed, mu, d)
        x, ok = _kkt(W, q, E, f, mu, d, kind, tang, relaxed, POLISH_MAX_NEWTON, False)
    n_pulled = 0
    if not ok:
        # 3. as 1, with the contacts the cone-free impulse pulls at zero (damped)
        for a in range(na):
            zero_mask[a] = relaxed[a * d] <= 0.0
            n_pulled += zero_mask[a]
        if 0 < n_pulled < na:
            kind, tang, x0 = _sliding_guess(q, relaxed, mu, d, zero_mask, r_floor)
            x, ok = _kkt(W, q, E, f, mu, d, kind, tang, x0, DAMPED_MAX_NEWTON, True)
    if not ok and na > 2:
        # 4. as 1, with one contact at zero (damped), the one the cone-free impulse presses
        # least first (3. tried it when it was the only one pulled)
        for z in np.argsort(relaxed[::d]):
            if n_pulled == 1 and relaxed[z * d] <= 0.0:
                continue
            for a in range(na):
                zero_mask[a] = a == z
            kind, tang, x0 = _sliding_guess(q, relaxed, mu, d, zero_mask, r_floor)
            x, ok = _kkt(W, q, E, f, mu, d, kind, tang, x0, DAMPED_MAX_NEWTON, True)
            if ok:
                break
    if not ok:
        return 0, pi, no_kind, no_tang
    for a in range(N):
        pi[idx[a]] = x[a] * scale[a]
    return 1, pi, kind, tang


@_jit
def _project_out(Q, m, r, coef):
    """r minus its projection on the orthonormal rows ``Q[:m]``, in place (classical
    Gram-Schmidt, twice), the coefficients taken out into ``coef[:m]``."""
    N = r.shape[0]
    for t in range(m):
        coef[t] = 0.0
    for _ in range(2):
        for t in range(m):
            h = 0.0
            for a in range(N):
                h += Q[t, a] * r[a]
            coef[t] += h
            for a in range(N):
                r[a] -= h * Q[t, a]


@_jit
def warm_kkt_point(W, vminus, b, mu, d, pi, cone_rtol):
    """Whether ``pi`` (a previous time step's answer) is a minimizer of the full set's slide
    program P_N (every contact, all frictional) on this problem, by its KKT conditions: ``pi``
    in the cones (``pn > 0``, ``|pt| <= mu pn (1 + cone_rtol)``), ``u_n = (W pi + b)_n = 0``,
    and multipliers ``lambda`` (free) and ``gamma >= 0`` with ``W pi + v- - W_n^T lambda``
    equal to ``gamma_i (mu_i, -t_i)`` on every contact on its cone's boundary (``t_i`` its
    friction's direction, ``pt_i = mu_i pn_i t_i``) and zero on every other (``y`` in the
    dual cone, orthogonal to ``pi``), found by least squares (Gram-Schmidt, dependent columns
    dropped: the twist of redundant contacts), every residual within :data:`KKT_RTOL`. A KKT
    point of the convex program is a minimizer: the one :func:`slide_set_warm`'s Newton
    accepts from this start, to round-off, without its iterations. On a box sliding
    straight the previous step's impulse is this step's (the normal impulses and the
    friction's direction do not depend on the speed)."""
    n = mu.size
    N = n * d
    X = 0.0
    for a in range(N):
        X = max(X, abs(pi[a]))
    wmax = 0.0
    for a in range(N):
        for c in range(N):
            wmax = max(wmax, abs(W[a, c]))
    bmax = 0.0
    for a in range(N):
        bmax = max(bmax, max(abs(b[a]), abs(vminus[a])))
    tolr = KKT_RTOL * max(bmax, wmax * X, TINY)
    u = np.empty(N)
    for a in range(N):
        acc = 0.0
        for c in range(N):
            acc += W[a, c] * pi[c]
        u[a] = acc
    bnd = np.zeros(n, dtype=np.bool_)
    nb = 0
    for i in range(n):
        o = i * d
        pn = pi[o]
        if not (mu[i] > 0.0 and pn > 0.0):
            return False
        if not abs(u[o] + b[o]) <= tolr:
            return False
        pt2 = 0.0
        for k in range(1, d):
            pt2 += pi[o + k] ** 2
        pt = np.sqrt(pt2)
        if not pt <= mu[i] * pn * (1.0 + cone_rtol):
            return False
        if pt >= mu[i] * pn * (1.0 - BOUNDARY_RTOL):
            bnd[i] = True
            nb += 1
    for a in range(N):
        u[a] += vminus[a]
    # the columns: gamma's (disjoint supports: independent, kept), then lambda's
    ncol = nb + n
    C = np.zeros((ncol, N))
    k = 0
    for i in range(n):
        if bnd[i]:
            o = i * d
            pt2 = 0.0
            for c in range(1, d):
                pt2 += pi[o + c] ** 2
            pt = np.sqrt(pt2)
            C[k, o] = mu[i]
            for c in range(1, d):
                C[k, o + c] = -pi[o + c] / pt
            k += 1
    for i in range(n):
        for a in range(N):
            C[k, a] = W[a, i * d]
        k += 1
    cscale = 0.0
    for j in range(ncol):
        acc = 0.0
        for a in range(N):
            acc += C[j, a] * C[j, a]
        cscale = max(cscale, np.sqrt(acc))
    cut = 1e-11 * max(cscale, TINY)
    Q = np.zeros((ncol, N))
    R = np.zeros((ncol, ncol))
    coef = np.empty(ncol)
    m = 0
    for j in range(ncol):
        r = C[j]  # (in place: C's row j is not read again)
        _project_out(Q, m, r, coef)
        nr = 0.0
        for a in range(N):
            nr += r[a] * r[a]
        nr = np.sqrt(nr)
        if nr > cut:
            for t in range(m):
                R[t, m] = coef[t]
            R[m, m] = nr
            for a in range(N):
                Q[m, a] = r[a] / nr
            m += 1
        elif j < nb:
            return False
    y = np.zeros(m)
    res = u
    _project_out(Q, m, res, y)
    for a in range(N):
        if not abs(res[a]) <= tolr:
            return False
    # the gammas: the first nb coefficients of R c = y
    x = y.copy()
    back_substitute(np.ascontiguousarray(R[:m, :m].T), x)  # R x = y, R = (R^T)^T
    for t in range(nb):
        if not x[t] >= 0.0:
            return False
    return True


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
    n = mu.size
    return slide_many_warm(W, b, vminus, mu, d, sets, cone_rtol, slack_max, tol,
                           np.zeros((ns, n), dtype=np.int64), np.zeros((ns, n, 2)),
                           np.zeros((ns, W.shape[0])), np.zeros(ns, dtype=np.bool_))


@_jit
def slide_many_warm(W, b, vminus, mu, d, sets, cone_rtol, slack_max, tol, wkind, wtang, wpi,
                    wvalid):
    """:func:`slide_many` with warm starts (:func:`slide_set_warm`): set s is first tried
    from ``wkind[s]``, ``wtang[s]``, ``wpi[s]`` where ``wvalid[s]``; the arrays are then
    updated with this call's certified answers (``wvalid[s]`` False where none)."""
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
        st, pi, kind, tang = slide_set_warm(W, vminus, b, mu, d, A, wkind[s], wtang[s],
                                            wpi[s], wvalid[s])
        status[s] = st
        wvalid[s] = st == 1
        if st == 1:
            wkind[s, :A.size] = kind
            wtang[s, :A.size] = tang
            wpi[s] = pi
        if st == 1 or st == -1:
            pis[s] = pi
            ok[s] = admissible(W, absW, sets[s], pi, b, mu, d, cone_rtol, slack_max, tol)
            energy[s] = pi @ vminus + 0.5 * (pi @ (W @ pi))
    return status, pis, ok, energy
