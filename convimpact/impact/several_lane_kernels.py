"""Several open-loop contacts from (M, Jc, dq), in one compiled call: the lane of
``resolve_impact`` for the laws ``ccp`` and ``dissipative`` (:mod:`convimpact.impact.several_lane`).

:func:`lane_solve` does, into one flat workspace (:func:`layout`):

1. M checked (exactly symmetric, finite) and factored, ``M = L L^T``, every pivot above
   ``PIVOT_RTOL`` times its diagonal entry; ``X = L^-1 Jc^T``, ``W = X^T X`` (the upper
   triangle computed, the lower mirrored: symmetric by construction) and ``v- = Jc dq``;
2. the plain-case contact checks of :func:`convimpact.impact.problem.build_problem`
   (:func:`~convimpact.impact.several_kernels.contact_checks`), some contact approaching, and
   the velocities within 1e-100 .. 1e100;
3. the law by :func:`~convimpact.impact.several_newton.solve_law` (the public interior path's
   single call) and its certificate accepted by the rule of
   :func:`convimpact.impact.several_contacts._solve`;
4. for the dissipative law Poisson's scaling ``pi = plastic (1 + e_i)`` and the plastic and
   predicted energy losses; then ``dq+ = dq + L^-T X pi``, ``v+ = v- + W pi`` and
   ``T+ - T- = pi.v- + 1/2 pi.W.pi``, all finite.

Returns 0 (done) or a code > 0: the full path takes the impact (and raises or notes as
before). Compiled on first use (numba, ``cache=True``: the machine code is kept beside this
module; after editing it delete ``__pycache__/several_lane_kernels*.nb[ic]``).
"""

from __future__ import annotations

import math

import numpy as np

from .conic.polish import VELOCITY_RESIDUAL_MAX
from .reduction import IMMOBILE_RTOL, TINY_NORMAL
from .several_kernels import TRIVIAL, _jit, contact_checks
from .several_newton import solve_law

#: a Cholesky pivot at or below this fraction of its diagonal entry sends M to the full path
PIVOT_RTOL = 1e-12
#: figures computed in plain arithmetic (outside, the full path normalizes them)
PLAIN_LO, PLAIN_HI = 1e-100, 1e100
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
BAD_M, BAD_PIVOT, NOT_PLAIN_CONTACTS, SEPARATING, SCALE, CERTIFICATE, NOT_PLAIN = range(1, 8)
#: scalars slot names (see layout)
N_SCALARS = 8


def layout(n: int, d: int, k: int) -> tuple[int, ...]:
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
    """Reduce, solve (``mode`` 0: ccp, 1: dissipative), certify and map back several contacts
    into ``ws`` (:func:`layout`). ``J`` is (n, d, k), ``e`` and ``friction`` (n,)."""
    n = J.shape[0]
    d = J.shape[1]
    k = J.shape[2]
    N = n * d
    ov = N * N
    odq = ov + N
    ovp = odq + k
    opi = ovp + N
    opc = opi + N
    opl = opc + N
    oout = opl + N
    osc = oout + 4 * n
    ocM = osc + 8
    ocJ = ocM + k * k
    ocq = ocJ + N * k
    # private copies of the data (the diagnostics measure them on first access)
    for i in range(k):
        for j in range(k):
            ws[ocM + i * k + j] = M[i, j]
        ws[ocq + i] = dq[i]
    for a in range(n):
        for b in range(d):
            for i in range(k):
                ws[ocJ + (a * d + b) * k + i] = J[a, b, i]
    # M exactly symmetric and finite (the full path symmetrizes or rejects the others)
    for i in range(k):
        if not math.isfinite(M[i, i]):
            return BAD_M
        for j in range(i):
            if M[i, j] != M[j, i] or not math.isfinite(M[i, j]):
                return BAD_M
    # Cholesky M = L L^T, every pivot safely positive
    L = np.zeros((k, k))
    for j in range(k):
        s = M[j, j]
        for p in range(j):
            s -= L[j, p] * L[j, p]
        if not s > PIVOT_RTOL * M[j, j]:
            return BAD_PIVOT
        r = math.sqrt(s)
        L[j, j] = r
        for i in range(j + 1, k):
            s = M[i, j]
            for p in range(j):
                s -= L[i, p] * L[j, p]
            L[i, j] = s / r
    # X = L^-1 Jc^T (forward substitution), W = X^T X (upper triangle, mirrored), v = Jc dq
    X = np.empty((k, N))
    v = np.empty(N)
    for a in range(n):
        for b in range(d):
            c = a * d + b
            s = 0.0
            for i in range(k):
                s += J[a, b, i] * dq[i]
            v[c] = s
            for i in range(k):
                s = J[a, b, i]
                for p in range(i):
                    s -= L[i, p] * X[p, c]
                X[i, c] = s / L[i, i]
    W = np.empty((N, N))
    for a in range(N):
        for b in range(a, N):
            s = 0.0
            for i in range(k):
                s += X[i, a] * X[i, b]
            W[a, b] = s
            W[b, a] = s
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
    # dq+ = dq + L^-T X pi (y = X pi, back substitution)
    y = np.empty(k)
    for i in range(k):
        s = 0.0
        for c in range(N):
            s += X[i, c] * pi[c]
        y[i] = s
    for i in range(k - 1, -1, -1):
        s = y[i]
        for p in range(i + 1, k):
            s -= L[p, i] * y[p]
        y[i] = s / L[i, i]
    total = 0.0
    for i in range(k):
        ws[odq + i] = dq[i] + y[i]
        total += ws[odq + i]
    # v+ = v- + W pi, T+ - T- = pi.v- + 1/2 pi.W.pi
    dT = 0.0
    ps = 0.0
    for a in range(N):
        q = 0.0
        for b in range(N):
            q += W[a, b] * pi[b]
        ws[ovp + a] = v[a] + q
        total += ws[ovp + a]
        dT += pi[a] * v[a] + 0.5 * pi[a] * q
        ps = max(ps, abs(pi[a]))
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
