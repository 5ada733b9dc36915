"""Compiled right-hand side of the canonical equations for a fixed set of held contacts.

The two passes of :meth:`~convimpact.simulation.canonical.CanonicalEquations.__call__` on a
:class:`~convimpact.model.ModelMechanism` without loops, between the model's own compiled
passes (positions: M's factor and the contact Jacobians; velocities: f, p_dot and the
Jacobians' rates):

* :func:`held_velocities`: eqs. (7), (10), (13) with the held rows ``C``: ``A = M^-1 C^T``,
  ``S = C A`` and its Cholesky factor, ``theta_dot = M^-1 p + A sigma`` with
  ``sigma = -S^-1 C M^-1 p``;
* :func:`held_rates`: eq. (14), ``p_dot - C_dot^T sigma``, and for sliding contacts their
  Coulomb friction ``D nu`` with ``C M^-1 (C^T + D) nu = -(C M^-1 f + C_dot theta_dot)``
  (eqs. 8, 9), D's columns ``-mu c_t^T s`` (s the slip velocity's direction, kept through a
  reversal; the stored one below the slip floor) -- the numbers of the general path, summed
  in another order.

The general path (numpy, :mod:`~convimpact.simulation.canonical`) stays the reference and
the fallback: where a kernel reports a failure (S or K singular, a non-finite value) the
caller evaluates the state there, which raises the documented error.
"""

from __future__ import annotations

import math

import numpy as np

from ..compiled import jit, jit_internal
from ..impact.problem.compiled_reduction import cholesky_into
from ..model.compiled_algebra import cho_solve_mat, cho_solve_vec

OK, SINGULAR_S, SINGULAR_K, NOT_FINITE = 0, 1, 2, 3


@jit
def held_velocities(Lm, CJ, rc, rr, p, L, C, A, S, SL, dtheta, sigma):
    """theta_dot and sigma of ``M theta_dot - C^T sigma = p``, ``C theta_dot = 0``.

    ``Lm`` M's lower Cholesky factor (copied into ``L``), ``CJ`` (n_contacts, 3, k) the
    contact Jacobians, the held rows ``C[i] = CJ[rc[i], rr[i]]``. Fills L, C, A (k, m),
    S (m, m), SL (its factor), dtheta (k,), sigma (m,). Returns OK or SINGULAR_S.
    """
    k = Lm.shape[0]
    m = rc.shape[0]
    for i in range(k):
        for j in range(k):
            L[i, j] = Lm[i, j] if j <= i else 0.0
    for i in range(m):
        for j in range(k):
            C[i, j] = CJ[rc[i], rr[i], j]
    for i in range(k):  # A = M^-1 C^T
        for c in range(m):
            A[i, c] = C[c, i]
    cho_solve_mat(L, A, A)
    for i in range(m):
        for j in range(m):
            s = 0.0
            for q in range(k):
                s += C[i, q] * A[q, j]
            S[i, j] = s
    if not cholesky_into(S, SL, m, 0.0):
        return SINGULAR_S
    cho_solve_vec(L, p, dtheta)
    # sigma = -(S^-1) C dtheta0
    for i in range(m):
        s = 0.0
        for q in range(k):
            s += C[i, q] * dtheta[q]
        sigma[i] = s
    cho_solve_vec(SL, sigma, sigma)
    for i in range(m):
        sigma[i] = -sigma[i]
    for i in range(k):
        s = dtheta[i]
        for q in range(m):
            s += A[i, q] * sigma[q]
        dtheta[i] = s
    return OK


@jit_internal
def _constraint_rhs(L, C, CJD, rc, rr, f, dtheta):
    """``C M^-1 f + C_dot theta_dot`` (m,): the held rows' acceleration terms (eq. 8)."""
    k, m = L.shape[0], C.shape[0]
    Mf = np.empty(k)
    cho_solve_vec(L, f, Mf)
    rhs = np.empty(m)
    for i in range(m):
        s = 0.0
        for q in range(k):
            s += C[i, q] * Mf[q] + CJD[rc[i], rr[i], q] * dtheta[q]
        rhs[i] = s
    return rhs


@jit
def held_rates(L, C, A, S, SL, CJ, CJD, rc, rr, si, cols, stored, mu, xc, xr, w, x0,
               floors, f, pdot, dtheta, sigma, out, aux, want_nu):
    """y_dot = [theta_dot, p_dot - C_dot^T sigma + D nu] into ``out`` (2k,).

    ``CJD`` the Jacobians' rates (C_dot's rows as C's), ``si`` the sliding contacts'
    indices into CJ, ``cols`` their normal rows among C's, ``stored`` (n_s, d - 1) their
    stored slip directions, ``mu`` their friction coefficients, ``floors`` (n_s,) the slip
    speeds below which their stored directions are kept (inf: a frozen direction). In a sliding group the dropped (redundant)
    rows ``CJ[xc[j], xr[j]]`` (r,) are unknowns past the multipliers (a sliding one's
    normal row: among the sliding contacts, last, ``cols`` >= m), and ``w`` (m + r,) the
    unknowns' weights (``1 + mu^2`` for a sliding normal force, else 1): nu is the
    least-norm solution ``W^-1 E^T (E W^-1 E^T)^-1 rhs`` of ``E nu = rhs``, E = C M^-1
    [C^T + D | J_r^T + D_r] (m, m + r); ``xc`` empty without them; ``x0`` (m + r,) the segment's offset z0
    (``z0 + W^-1 E^T (E W^-1 E^T)^-1 (rhs - E z0)``; zeros: the least-norm one). ``aux`` (m + r + 2 + n_s (d - 1),): the
    multipliers nu (eq. 9; without sliding contacts only with ``want_nu``, else zeros), the
    sliding contacts' friction power ``sum lambda_t . v_t``, the Painleve indicator
    ``det(C M^-1 (C^T + D)) / det(C M^-1 C^T)`` (1 without sliding contacts) and the
    sliding contacts' slip directions s. Returns OK, SINGULAR_K (Painleve: the sliding
    contacts' force system singular) or NOT_FINITE.
    """
    k = L.shape[0]
    m = C.shape[0]
    ns = si.shape[0]
    nx = xc.shape[0]
    mu_ = m + nx  # the unknowns
    for i in range(aux.shape[0]):
        aux[i] = 0.0
    aux[mu_ + 1] = 1.0
    for i in range(k):
        out[i] = dtheta[i]
        s = pdot[i]
        for r in range(m):
            s -= CJD[rc[r], rr[r], i] * sigma[r]
        out[k + i] = s
    if ns > 0:
        dt = stored.shape[1]
        # D's columns of the sliding contacts (k, ns) and M^-1 of them
        D = np.empty((k, ns))
        vs = np.empty(ns)  # s . v_t of each sliding contact
        for c in range(ns):
            sdir = np.empty(dt)
            for j in range(dt):
                sdir[j] = stored[c, j]
            vt = np.empty(dt)
            for j in range(dt):
                v = 0.0
                for q in range(k):
                    v += CJ[si[c], 1 + j, q] * dtheta[q]
                vt[j] = v
            if dt > 1:  # in space: the slip velocity's direction
                nn = 0.0
                dot = 0.0
                for j in range(dt):
                    nn += vt[j] * vt[j]
                    dot += vt[j] * stored[c, j]
                norm = math.sqrt(nn)
                if norm > floors[c] and norm > 0.0:
                    sg = norm if dot >= 0.0 else -norm
                    for j in range(dt):
                        sdir[j] = vt[j] / sg
            v = 0.0
            for j in range(dt):
                v += sdir[j] * vt[j]
                aux[mu_ + 2 + c * dt + j] = sdir[j]
            vs[c] = v
            for q in range(k):
                s = 0.0
                for j in range(dt):
                    s += CJ[si[c], 1 + j, q] * sdir[j]
                D[q, c] = -mu[c] * s
        X = np.empty((k, ns))
        cho_solve_mat(L, D, X)  # M^-1 D
        K = np.zeros((m, mu_))
        for i in range(m):
            for j in range(m):
                K[i, j] = S[i, j]
            for c in range(ns):
                s = 0.0
                for q in range(k):
                    s += C[i, q] * X[q, c]
                K[i, cols[c]] += s
        if nx > 0:  # the redundant rows' columns C M^-1 J_r^T
            Y = np.empty((k, nx))
            for j in range(nx):
                for q in range(k):
                    Y[q, j] = CJ[xc[j], xr[j], q]
            cho_solve_mat(L, Y, Y)
            for i in range(m):
                for j in range(nx):
                    s = 0.0
                    for q in range(k):
                        s += C[i, q] * Y[q, j]
                    K[i, m + j] += s
        rhs = _constraint_rhs(L, C, CJD, rc, rr, f, dtheta)
        for i in range(m):
            rhs[i] = -rhs[i]
        sol = np.empty(mu_)
        if nx > 0:  # the least-norm solution: G = E W^-1 E^T, nu = W^-1 E^T G^-1 rhs
            G = np.empty((m, m))
            for i in range(m):
                for j in range(m):
                    s = 0.0
                    for q in range(mu_):
                        s += K[i, q] * K[j, q] / w[q]
                    G[i, j] = s
            GL = np.zeros((m, m))
            if not cholesky_into(G, GL, m, 0.0):
                return SINGULAR_K
            r2 = np.empty(m)
            for i in range(m):
                s = rhs[i]
                for q in range(mu_):
                    s -= K[i, q] * x0[q]
                r2[i] = s
            cho_solve_vec(GL, r2, r2)
            for q in range(mu_):
                s = 0.0
                for i in range(m):
                    s += K[i, q] * r2[i]
                sol[q] = x0[q] + s / w[q]
        # det K / det S, pivot by pivot (K's first m columns), and with nx = 0 nu = K^-1
        # rhs: LU with partial pivoting (singular only at a zero pivot, as LAPACK)
        ratio = 1.0
        for j in range(m):
            best = j
            for i in range(j + 1, m):
                if abs(K[i, j]) > abs(K[best, j]):
                    best = i
            if K[best, j] == 0.0:
                if nx > 0:
                    ratio = 0.0
                    break
                return SINGULAR_K
            if best != j:
                for q in range(m):
                    K[j, q], K[best, q] = K[best, q], K[j, q]
                rhs[j], rhs[best] = rhs[best], rhs[j]
                ratio = -ratio
            ratio *= K[j, j] / (SL[j, j] * SL[j, j])
            for i in range(j + 1, m):
                g = K[i, j] / K[j, j]
                if g != 0.0:
                    for q in range(j + 1, m):
                        K[i, q] -= g * K[j, q]
                    rhs[i] -= g * rhs[j]
        if nx == 0:
            for i in range(m - 1, -1, -1):
                s = rhs[i]
                for q in range(i + 1, m):
                    s -= K[i, q] * rhs[q]
                rhs[i] = s / K[i, i]
            for i in range(m):
                sol[i] = rhs[i]
        for i in range(k):
            s = out[k + i]
            for c in range(ns):
                s += D[i, c] * sol[cols[c]]
            out[k + i] = s
        for i in range(mu_):
            aux[i] = sol[i]
        power = 0.0
        for c in range(ns):  # lambda_t = -mu nu_n s
            power -= mu[c] * sol[cols[c]] * vs[c]
        aux[mu_] = power
        aux[mu_ + 1] = ratio
    elif want_nu:  # nu = -(C M^-1 C^T)^-1 (C M^-1 f + C_dot theta_dot)
        rhs = _constraint_rhs(L, C, CJD, rc, rr, f, dtheta)
        cho_solve_vec(SL, rhs, rhs)
        for i in range(m):
            aux[i] = -rhs[i]
    for i in range(2 * k):
        if not math.isfinite(out[i]):
            return NOT_FINITE
    return OK
