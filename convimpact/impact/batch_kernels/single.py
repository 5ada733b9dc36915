"""One contact from (M, Jc, dq), in compiled code: the fast lane of ``resolve_impact``.

:func:`lane_solve` is the whole single-contact solve of
:func:`convimpact.impact.lane.resolve_one` in one compiled call:

1. :func:`reduce_one` checks M (exactly symmetric, finite) and factors it, ``M = L L^T``;
   then ``X = L^-1 Jc^T``, ``W = X^T X`` (eq. 29's Delassus block) and ``v- = Jc dq``;
2. the law's exact kernel -- the compiled port of ``contact_kernel`` of each law module
   (:func:`.loop._planar_item`, :func:`.loop._spatial_item`, the batch's own) -- gives the
   contact impulse ``pi`` from ``(W, v-, e, mu)``;
3. :func:`finish_one` maps it back: ``dq+ = dq + L^-T X pi`` (eq. 29), ``v+ = v- + W pi`` and
   ``T+ - T- = pi.v- + 1/2 pi.W.pi`` (eq. 58).

Everything is written into one flat workspace (:func:`layout`), so the call from Python
passes seven arguments and allocates one array. A case the lane does not take (see
:mod:`convimpact.impact.lane`) returns a code > 0 and the full path takes it.
"""

from __future__ import annotations

import math

from ..lane import layout  # noqa: F401  (the workspace's offsets, for callers of this module)
from ..problem import IMMOBILE_RTOL, SAFE_SCALE, TINY_NORMAL
from .common import DEFER, OK, _jit
from .loop import _planar_item, _spatial_item

#: a Cholesky pivot at or below this fraction of its diagonal entry sends M to the full
#: path (whose LAPACK factorization decides positive definiteness at the edge)
PIVOT_RTOL = 1e-12
#: figures the lane computes in plain arithmetic (outside, the full path normalizes them)
PLAIN = (1e-100, 1e100)
#: lane_solve's codes beyond reduce_one's (1-5): the kernel refused (status SINGULAR/JAM),
#: deferred to the Python kernel (DEFER), or a result outside plain arithmetic
REFUSED, DEFERRED, NOT_PLAIN = 6, 7, 8


@_jit
def reduce_one(M, J, dq, ws):
    """Check and reduce one contact into ``ws`` (layout: :func:`layout`). Returns 0 when the
    data are the plain case, else a code > 0: the full path must take them."""
    k = M.shape[0]
    d = J.shape[0]
    oX = k * k
    oW = oX + k * d
    ov = oW + d * d
    oc = ov + d + k + d + 3
    # private copies of the data (the diagnostics measure them on first access)
    for i in range(k):
        for j in range(k):
            ws[oc + i * k + j] = M[i, j]
        ws[oc + k * k + d * k + i] = dq[i]
    for c in range(d):
        for i in range(k):
            ws[oc + k * k + c * k + i] = J[c, i]
    # M exactly symmetric and finite (the full path symmetrizes or rejects the others)
    for i in range(k):
        if not math.isfinite(M[i, i]):
            return 1
        for j in range(i):
            if M[i, j] != M[j, i] or not math.isfinite(M[i, j]):
                return 1
    # Cholesky M = L L^T, every pivot safely positive
    for i in range(k * k):
        ws[i] = 0.0
    for j in range(k):
        s = M[j, j]
        for p in range(j):
            s -= ws[j * k + p] * ws[j * k + p]
        if not s > PIVOT_RTOL * M[j, j]:
            return 2
        r = math.sqrt(s)
        ws[j * k + j] = r
        for i in range(j + 1, k):
            s = M[i, j]
            for p in range(j):
                s -= ws[i * k + p] * ws[j * k + p]
            ws[i * k + j] = s / r
    # X = L^-1 J^T (forward substitution, column by column), W = X^T X, v = J dq
    for c in range(d):
        for i in range(k):
            s = J[c, i]
            for p in range(i):
                s -= ws[i * k + p] * ws[oX + p * d + c]
            ws[oX + i * d + c] = s / ws[i * k + i]
    total = 0.0
    for a in range(d):
        for b in range(a + 1):
            s = 0.0
            for i in range(k):
                s += ws[oX + i * d + a] * ws[oX + i * d + b]
            ws[oW + a * d + b] = s
            ws[oW + b * d + a] = s
            total += s
        s = 0.0
        for i in range(k):
            if not math.isfinite(J[a, i]):
                return 3
            s += J[a, i] * dq[i]
        ws[ov + a] = s
        total += s
    if not math.isfinite(total):
        return 3
    vs = 0.0
    tr = 0.0
    for a in range(d):
        vs = max(vs, abs(ws[ov + a]))
        tr += ws[oW + a * d + a]
    if not (ws[oW] >= TINY_NORMAL and ws[ov] < 0.0):
        return 4  # a degenerate normal, or a contact that does not approach
    if not (SAFE_SCALE[0] <= tr <= SAFE_SCALE[1] and SAFE_SCALE[0] <= vs <= SAFE_SCALE[1]):
        return 5  # far from unit scale: the full path rescales
    wt = ws[oW + d + 1]
    if d == 3 and ws[oW + 8] > wt:
        wt = ws[oW + 8]
    if wt <= IMMOBILE_RTOL * ws[oW]:
        return -1  # tangents that move no mass: plain, but frictionless (as build_problem)
    return 0


@_jit
def finish_one(ws, k, d, pi, dq):
    """Map the impulse back into ``ws``: dq+ (k), v+ (d), T+ - T-, max |pi|, max |v-|.
    Returns T+ - T-, or NaN when a figure is not finite or |pi| is outside 1e-100 .. 1e100
    (the full path normalizes or raises)."""
    oX = k * k
    oW = oX + k * d
    ov = oW + d * d
    oo = ov + d
    # y = X pi, then dq+ = dq + L^-T y (back substitution)
    for i in range(k):
        s = 0.0
        for c in range(d):
            s += ws[oX + i * d + c] * pi[c]
        ws[oo + i] = s
    for i in range(k - 1, -1, -1):
        s = ws[oo + i]
        for p in range(i + 1, k):
            s -= ws[p * k + i] * ws[oo + p]
        ws[oo + i] = s / ws[i * k + i]
    for i in range(k):
        ws[oo + i] += dq[i]
    dT = 0.0
    ps = 0.0
    vs = 0.0
    for a in range(d):
        s = ws[ov + a]
        q = 0.0
        for b in range(d):
            q += ws[oW + a * d + b] * pi[b]
        ws[oo + k + a] = s + q
        dT += pi[a] * s + 0.5 * pi[a] * q
        ps = max(ps, abs(pi[a]))
        vs = max(vs, abs(s))
    ws[oo + k + d] = dT
    ws[oo + k + d + 1] = ps
    ws[oo + k + d + 2] = vs
    total = dT
    for i in range(k + d):
        total += ws[oo + i]
    if not math.isfinite(total) or not (ps == 0.0 or PLAIN[0] <= ps <= PLAIN[1]):
        return math.nan
    return dT


@_jit
def lane_solve(law, M, J, dq, e, mu, ws):
    """Reduce, solve and map back one contact into ``ws`` (:func:`layout`). Returns 0 (done),
    or reduce_one's code (1-5), REFUSED (the kernel's status in ws: SINGULAR or JAM), DEFERRED
    (a rare branch the Python kernel solves: W and v- are in ws) or NOT_PLAIN."""
    k = M.shape[0]
    d = J.shape[0]
    code = reduce_one(M, J, dq, ws)
    if code > 0:
        return code
    if code < 0:
        mu = 0.0  # tangents that move no mass: frictionless (build_problem's rule)
    oW = k * k + k * d
    ov = oW + d * d
    op = ov + d + k + d + 3 + k * k + d * k + k
    if d == 2:
        st, rg, p0, p1, p2, em = _planar_item(law, ws[oW], ws[oW + 1], ws[oW + 3], ws[ov],
                                              ws[ov + 1], e, mu)
    else:
        st, rg, p0, p1, p2, em = _spatial_item(law, ws[oW], ws[oW + 1], ws[oW + 2], ws[oW + 4],
                                               ws[oW + 5], ws[oW + 8], ws[ov], ws[ov + 1],
                                               ws[ov + 2], e, mu)
    ws[op + 3] = st
    ws[op + 4] = rg
    ws[op + 5] = em
    ws[op + 6] = mu
    if st == DEFER:
        return DEFERRED
    if st != OK:
        return REFUSED
    ws[op] = p0
    ws[op + 1] = p1
    ws[op + 2] = p2
    dT = finish_one(ws, k, d, ws[op:op + d], dq)
    if dT != dT:
        return NOT_PLAIN
    return 0
