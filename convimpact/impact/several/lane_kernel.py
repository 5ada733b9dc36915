"""Several open-loop contacts from (M, Jc, dq), in one compiled call: the lane of
``resolve_impact`` for the laws ``ccp`` and ``dissipative`` (:mod:`convimpact.impact.several.lane`).

:func:`lane_solve` does, into one flat workspace (:func:`layout`):

1. M checked (exactly symmetric, finite) and factored, ``M = L L^T``, every pivot above
   ``PIVOT_RTOL`` times its diagonal entry; ``X = L^-1 Jc^T``, ``W = X^T X`` (symmetric by
   construction) and ``v- = Jc dq`` (:func:`convimpact.impact.problem.compiled_reduction.reduce_rows`, shared
   with the one-contact lane);
2. the plain-case contact checks of :func:`convimpact.impact.problem.build.build_problem`
   (:func:`~convimpact.contacts.interior_point.contact_checks`), some contact approaching, and
   the velocities within 1e-100 .. 1e100;
3. the law by :func:`~convimpact.impact.several.law_programs.solve_law` (the public interior
   path's single call, its steps taken into this function's body: one compiled function for
   the three laws) and its certificate accepted by the rule of
   :func:`convimpact.impact.several.interior._solve`;
4. for the dissipative law Poisson's scaling ``pi = plastic (1 + e_i)`` and the plastic and
   predicted energy losses; then ``dq+ = dq + L^-T X pi``, ``v+ = v- + W pi`` and
   ``T+ - T- = pi.v- + 1/2 pi.W.pi``, all finite.

Returns 0 (done) or a code > 0: the full path takes the impact (and raises or notes as
before). Compiled on first use and cached per user (:mod:`convimpact.compiled`).
"""

from __future__ import annotations

import math

import numpy as np

from ..conic.polish import VELOCITY_RESIDUAL_MAX
from ..problem.compiled_reduction import NOT_FINITE, PLAIN, map_back, reduce_rows, velocity_jump
from ..problem.reduction import IMMOBILE_RTOL, TINY_NORMAL
from ...contacts.interior_point import TRIVIAL, _jit, contact_checks
from .law_programs import solve_law

#: figures computed in plain arithmetic (outside, the full path normalizes them)
PLAIN_LO, PLAIN_HI = PLAIN
#: several_contacts' constants (HANDOVER_TOL, CERTIFIED_ACCURACY, the default options)
HANDOVER_TOL = 1e-9
CERTIFIED_ACCURACY = 1e-9
DEFAULT_TOL = 1e-10
MAX_ITER = 100
NEWTON_ITER = 20
#: codes: M not exactly symmetric or not finite, a pivot not safely positive, the contact
#: data not the plain case (non-finite, degenerate or immobile contacts), no contact
#: approaching, velocities outside plain arithmetic, the certificate failed, a result
#: outside plain arithmetic
NOT_PLAIN_CONTACTS, SEPARATING, SCALE, CERTIFICATE, NOT_PLAIN = range(3, 8)
#: scalars slot names (see layout)
N_SCALARS = 8


@_jit
def layout(n, d, k):
    """Offsets into the workspace: W (N*N), v- (N), dq+ (k), v+ (N), pi (N), a private copy
    of pi (N), the plastic impulse (N), per contact (n each) regime code, lift, mu |v_t+|,
    v_n+, then [status, iterations, Newton steps, certificate, floor, T+ - T-, plastic energy
    loss, predicted energy loss], and private copies of M (k*k), Jc (N*k), dq (k); the last
    entry is the size (N = n d)."""
    N = n * d
    ov = N * N
    odq = ov + N
    ovp = odq + k
    opi = ovp + N
    opc = opi + N
    opl = opc + N
    oout = opl + N
    osc = oout + 4 * n
    ocM = osc + N_SCALARS
    ocJ = ocM + k * k
    ocq = ocJ + N * k
    return ov, odq, ovp, opi, opc, opl, oout, osc, ocM, ocJ, ocq, ocq + k


@_jit
def lane_solve(mode, M, J, dq, e, friction, ws):
    """Reduce, solve (``mode`` 0: ccp, 1: dissipative, 2: coulomb), certify and map back
    several contacts into ``ws`` (:func:`layout`). ``J`` is (n, d, k), ``e`` and ``friction``
    (n,). One compiled specialization serves the three laws (``mode`` is read at run time):
    compiling it once costs less than two law-specific ones, each of which would optimize
    and emit the interior point and the Newton finish again."""
    n = J.shape[0]
    d = J.shape[1]
    k = J.shape[2]
    N = n * d
    ov, odq, ovp, opi, opc, opl, oout, osc, ocM, ocJ, ocq, _ = layout(n, d, k)
    # private copies of the data (the diagnostics measure them on first access)
    for i in range(k):
        for j in range(k):
            ws[ocM + i * k + j] = M[i, j]
        ws[ocq + i] = dq[i]
    Jr = np.empty((N, k))
    for a in range(n):
        for b in range(d):
            for i in range(k):
                Jr[a * d + b, i] = J[a, b, i]
                ws[ocJ + (a * d + b) * k + i] = J[a, b, i]
    # M checked and factored, X = L^-1 Jc^T, W = X^T X, v = Jc dq (problem.compiled_reduction)
    L = np.empty((k, k))
    X = np.empty((k, N))
    W = np.empty((N, N))
    v = np.empty(N)
    code = reduce_rows(M, Jr, dq, L, X, W, v)
    if code == NOT_FINITE:
        return NOT_PLAIN_CONTACTS  # a contact row, W or v- not finite
    if code != 0:
        return code  # compiled_reduction.BAD_M or BAD_PIVOT (1, 2)
    # the plain case of build_problem's contact checks (finite, normals and tangents moving)
    if contact_checks(W, v, d, IMMOBILE_RTOL, TINY_NORMAL) != 0:
        return NOT_PLAIN_CONTACTS
    approaching = False
    vs = 0.0
    for i in range(N):
        vs = max(vs, abs(v[i]))
    for a in range(n):
        if v[a * d] < 0.0:
            approaching = True
    if not approaching:
        return SEPARATING
    if not (PLAIN_LO <= vs <= PLAIN_HI):
        return SCALE
    status, it, steps, residual, floor, out = solve_law(
        W, v, e, friction, d, mode, HANDOVER_TOL, MAX_ITER, NEWTON_ITER, CERTIFIED_ACCURACY)
    if status != TRIVIAL:
        if not residual <= max(DEFAULT_TOL, min(1e3 * floor, VELOCITY_RESIDUAL_MAX)):
            return CERTIFICATE
    else:
        residual = 0.0
    # the law's impulse (Poisson's scaling of the plastic impulse for the dissipative law)
    pi = np.empty(N)
    ep = 0.0
    pred = 0.0
    if mode == 1:
        Ep = np.empty(N)
        for a in range(n):
            for b in range(d):
                c = a * d + b
                pl = out[c]
                ws[opl + c] = pl
                pi[c] = pl * (1.0 + e[a])
                Ep[c] = pl * e[a]
        q1 = 0.0
        q2 = 0.0
        for a in range(N):
            s1 = 0.0
            s2 = 0.0
            for b in range(N):
                s1 += W[a, b] * out[b]
                s2 += W[a, b] * Ep[b]
            q1 += out[a] * s1
            q2 += Ep[a] * s2
        ep = 0.5 * q1
        pred = 0.5 * q1 - 0.5 * q2
    else:
        for c in range(N):
            pi[c] = out[c]
    # dq+ = dq + L^-T X pi, v+ = v- + W pi, T+ - T- = pi.v- + 1/2 pi.W.pi (problem.compiled_reduction)
    map_back(L, X, pi, dq, ws[odq:ovp])
    dT, ps, _ = velocity_jump(W, v, pi, ws[ovp:opi])
    total = 0.0
    for i in range(k):
        total += ws[odq + i]
    for a in range(N):
        total += ws[ovp + a]
        ws[opi + a] = pi[a]
        ws[opc + a] = pi[a]
        ws[ov + a] = v[a]
    total += dT + ep + pred
    if not math.isfinite(total) or not (ps == 0.0 or PLAIN_LO <= ps <= PLAIN_HI):
        return NOT_PLAIN
    for a in range(N):
        for b in range(N):
            ws[a * N + b] = W[a, b]
    for i in range(4 * n):
        ws[oout + i] = out[N + i]
    ws[osc] = status
    ws[osc + 1] = it
    ws[osc + 2] = steps
    ws[osc + 3] = residual
    ws[osc + 4] = floor
    ws[osc + 5] = dT
    ws[osc + 6] = ep
    ws[osc + 7] = pred
    return 0
