"""One contact from (M, Jc, dq), in compiled code: the fast lane of ``resolve_impact``.

:func:`lane_solve` is the whole single-contact solve of
:func:`convimpact.impact.exact.lane.resolve_one` (its steps 1-3 are listed in
:mod:`convimpact.impact.exact.lane`) in one compiled call: :func:`reduce_one` reduces with
:func:`convimpact.impact.problem.compiled_reduction.reduce_rows` (shared with the
several-contact lane) and checks the contact (approaching, a normal that moves mass, near unit
scale); the law's kernel runs through :func:`~convimpact.impact.laws.table.contact_item` (the
batch's own); :func:`finish_one` maps the impulse back (``compiled_reduction.map_back`` and
``velocity_jump``).

Everything is written into one flat workspace (:func:`convimpact.impact.exact.lane.layout`), so the
call from Python passes seven arguments and allocates one array. A case the lane does not take (see
:mod:`convimpact.impact.exact.lane`) returns a code > 0 and the full path takes it.
"""

from __future__ import annotations

import math

from ..problem.compiled_reduction import PLAIN, map_back, reduce_rows, velocity_jump
from ..problem.build import IMMOBILE_RTOL, SAFE_SCALE, TINY_NORMAL
from ..laws.codes import DEFER, OK, _jit
from ...compiled import literally
from ..laws.table import contact_item as _contact_item

#: lane_solve's codes beyond reduce_one's (1-5): the kernel refused (status SINGULAR/JAM),
#: deferred (DEFER: outside the compiled range of scale), or a result outside plain arithmetic
REFUSED, DEFERRED, NOT_PLAIN = 6, 7, 8


@_jit
def reduce_one(M, J, dq, ws):
    """Check and reduce one contact into ``ws`` (:func:`convimpact.impact.exact.lane.layout`).
    Returns 0 when the data are the plain case, else a code > 0: the full path must take
    them."""
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
    # M checked and factored, X = L^-1 J^T, W = X^T X, v = J dq (lane_algebra's codes 1-3)
    code = reduce_rows(M, J, dq, ws[:oX].reshape((k, k)), ws[oX:oW].reshape((k, d)),
                       ws[oW:ov].reshape((d, d)), ws[ov:ov + d])
    if code != 0:
        return code
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
    map_back(ws[:oX].reshape((k, k)), ws[oX:oW].reshape((k, d)), pi, dq, ws[oo:oo + k])
    dT, ps, vs = velocity_jump(ws[oW:ov].reshape((d, d)), ws[ov:oo], pi, ws[oo + k:oo + k + d])
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
def lane_solve(law, dim, M, J, dq, e, mu, et, ws, out):
    """Reduce, solve and map back one contact into ``ws`` (:func:`convimpact.impact.exact.lane.layout`).
    Returns 0 (done), or reduce_one's code (1-5), REFUSED (the kernel's status in ws:
    SINGULAR or JAM), DEFERRED (the kernel is called from Python on W and v-, which are in
    ws) or NOT_PLAIN. ``out`` receives the law's extras (``laws.codes.OUT_SIZE`` floats).
    ``law`` and ``dim`` (= ``J.shape[0]``) are compiled as constants: each law and dimension
    compiles its own lane, with that one kernel."""
    literally(law)
    literally(dim)
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
    if d == 2:  # W's entries (0, 0), (0, 1), (1, 1) and v-; the rest is not read
        w00, w01, w02, w11, w12, w22 = ws[oW], ws[oW + 1], 0.0, ws[oW + 3], 0.0, 0.0
        v0, v1, v2 = ws[ov], ws[ov + 1], 0.0
    else:
        w00, w01, w02, w11, w12, w22 = ws[oW], ws[oW + 1], ws[oW + 2], ws[oW + 4], ws[oW + 5], \
            ws[oW + 8]
        v0, v1, v2 = ws[ov], ws[ov + 1], ws[ov + 2]
    st, rg, p0, p1, p2, em = _contact_item(law, dim, w00, w01, w02, w11, w12, w22, v0, v1, v2,
                                           e, mu, et, out)
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
