"""The compiled lanes' shared algebra: the reduction of an impact to contact space and the map
back (eqs. 29, 58), on validated float64 arrays, in numba.

Both lanes of :func:`~convimpact.impact.resolve.resolve_impact` -- one contact
(:mod:`convimpact.impact.exact.lane_kernel`) and several
(:mod:`convimpact.impact.several.lane_kernel`) -- call these from their compiled code:

* :func:`reduce_rows`: M exactly symmetric and finite, ``M = L L^T`` with every pivot above
  :data:`PIVOT_RTOL` times its diagonal entry, ``X = L^-1 R^T``, ``W = X^T X`` (symmetric by
  construction) and ``v- = R dq`` for the stacked contact rows R, all finite;
* :func:`map_back`: ``dq+ = dq + L^-T X pi``;
* :func:`velocity_jump`: ``v+ = v- + W pi`` and ``T+ - T- = pi.v- + 1/2 pi.W.pi``.

The full path (:func:`~convimpact.impact.problem.build.build_problem`, LAPACK) decides the cases
these refuse: an M symmetric only to round-off, a pivot at the edge of definiteness.
"""

from __future__ import annotations

import math

from ...compiled import jit as _jit, jit_internal

#: a Cholesky pivot at or below this fraction of its diagonal entry sends M to the full
#: path (whose LAPACK factorization decides positive definiteness at the edge)
PIVOT_RTOL = 1e-12
#: figures the lanes compute in plain arithmetic (outside, the full path normalizes them)
PLAIN = (1e-100, 1e100)
#: reduce_rows' codes: M not exactly symmetric or not finite; a pivot not safely positive;
#: a contact row, W or v- not finite
BAD_M, BAD_PIVOT, NOT_FINITE = 1, 2, 3


@jit_internal
def cholesky_into(M, L, k, rtol):
    """Lower Cholesky factor of M[:k, :k] into L (upper triangle untouched); False at a pivot
    not above ``rtol`` times its diagonal entry or not finite (also model.compiled_algebra's)."""
    for j in range(k):
        s = M[j, j]
        for p in range(j):
            s -= L[j, p] * L[j, p]
        if not s > rtol * M[j, j] or not math.isfinite(s):
            return False
        d = math.sqrt(s)
        L[j, j] = d
        for i in range(j + 1, k):
            s = M[i, j]
            for p in range(j):
                s -= L[i, p] * L[j, p]
            L[i, j] = s / d
    return True


@jit_internal
def back_substitute(L, x):
    """x = L^-T x in place, L lower triangular."""
    n = L.shape[0]
    for i in range(n - 1, -1, -1):
        s = x[i]
        for p in range(i + 1, n):
            s -= L[p, i] * x[p]
        x[i] = s / L[i, i]


@_jit
def reduce_rows(M, R, dq, L, X, W, v):
    """Factor M into L (k, k) and reduce the contact rows R (r, k) into X = L^-1 R^T (k, r),
    W = X^T X (r, r) and v = R dq (r). Returns 0, or BAD_M, BAD_PIVOT or NOT_FINITE."""
    k = M.shape[0]
    r = R.shape[0]
    for i in range(k):
        if not math.isfinite(M[i, i]):
            return BAD_M
        for j in range(i):
            if M[i, j] != M[j, i] or not math.isfinite(M[i, j]):
                return BAD_M
    for i in range(k):
        for j in range(k):
            L[i, j] = 0.0
    if not cholesky_into(M, L, k, PIVOT_RTOL):
        return BAD_PIVOT
    # X = L^-1 R^T (forward substitution, column by column)
    for c in range(r):
        for i in range(k):
            s = R[c, i]
            for p in range(i):
                s -= L[i, p] * X[p, c]
            X[i, c] = s / L[i, i]
    total = 0.0
    for a in range(r):
        for b in range(a + 1):
            s = 0.0
            for i in range(k):
                s += X[i, a] * X[i, b]
            W[a, b] = s
            W[b, a] = s
            total += s
        s = 0.0
        for i in range(k):
            if not math.isfinite(R[a, i]):
                return NOT_FINITE
            s += R[a, i] * dq[i]
        v[a] = s
        total += s
    if not math.isfinite(total):
        return NOT_FINITE
    return 0


@_jit
def map_back(L, X, pi, dq, dq_plus):
    """dq+ = dq + L^-T (X pi) into ``dq_plus`` (eq. 29)."""
    k = X.shape[0]
    r = X.shape[1]
    for i in range(k):
        s = 0.0
        for c in range(r):
            s += X[i, c] * pi[c]
        dq_plus[i] = s
    back_substitute(L, dq_plus)
    for i in range(k):
        dq_plus[i] += dq[i]


@_jit
def velocity_jump(W, v, pi, v_plus):
    """v+ = v- + W pi into ``v_plus``; returns (T+ - T- = pi.v- + 1/2 pi.W.pi (eq. 58),
    max |pi|, max |v-|)."""
    dT = 0.0
    ps = 0.0
    vs = 0.0
    for a in range(v.shape[0]):
        s = v[a]
        q = 0.0
        for b in range(v.shape[0]):
            q += W[a, b] * pi[b]
        v_plus[a] = s + q
        dT += pi[a] * s + 0.5 * pi[a] * q
        ps = max(ps, abs(pi[a]))
        vs = max(vs, abs(s))
    return dT, ps, vs
