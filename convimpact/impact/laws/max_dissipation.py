"""The direction of the friction impulse that maximizes the energy loss (eq. 60), exactly.

The paper's spatial sliding rule (Section 9.3): ``pi = pi_n (n + mu t)`` with ``pi_n`` from
eq. (38)/(51), ``pi_n = -(1+e) v_n / (W_n . (1, mu t))``, and t the direction, among those with
a positive denominator, that maximizes T_L (eq. 60). This is also the boundary optimum of the
program P_N (minimize T+ subject to v_n+ = -e v_n-, pi in K_mu). Its stationarity condition
``det[c W p + (a.p) v, a, q] = 0`` (a = W e_n, q = (-mu, t)) is a trigonometric quadratic in t,
solved exactly by the boundary algebra of :mod:`convimpact.impact.laws.algebra`. P_N
is convex, so Newton's method from -v_t- is tried first and accepted when P_N's KKT conditions
certify it; otherwise every root is compared, the winner certified (KKT or probe directions),
then retried with companion-matrix roots, then SolverError.

:func:`max_dissipation_slide` is compiled (numba; plain Python under ``NUMBA_DISABLE_JIT=1``):
the spatial kernel of the ``pereira-nikravesh`` law calls it, and so does
:func:`max_dissipation_direction`, the public entry the conic path, the paper's sweep and the
landscapes use.
"""

from __future__ import annotations

import math

import numpy as np

from .algebra import (_candidates, _det_wq, _inverse3, _newton_root, _refine, _rotate, _solve3)
from .codes import NO_SOLUTION, OK, _in_cone, _jit, _pmax2, _unit_or
from ...errors import SingularSystemError, SolverError, real_number
from ..problem.dense import as_lists

# directions probed by the certificate of maximal dissipation (constants as tuples)
_PROBE_X = tuple(math.cos(k * math.pi / 4) for k in range(8))
_PROBE_Y = tuple(math.sin(k * math.pi / 4) for k in range(8))


@_jit
def _pn_kkt(w00, w01, w02, w11, w12, w22, v0, v1, v2, c, mu, p, t1, t2):
    """KKT of P_N at pi = p (1, mu t): y = W pi + v - lam W e_n = sigma (mu, -t), sigma >= 0,
    with lam = pi.(W pi + v) / c (so that y is orthogonal to pi)."""
    A, B1, B2, C11, C12, C22 = w00, w01, w02, w11, w12, w22
    a1, a2 = mu * p * t1, mu * p * t2
    g0 = A * p + B1 * a1 + B2 * a2 + v0
    g1 = B1 * p + C11 * a1 + C12 * a2 + v1
    g2 = B2 * p + C12 * a1 + C22 * a2 + v2
    lam = (p * g0 + a1 * g1 + a2 * g2) / c
    y0, y1, y2 = g0 - lam * A, g1 - lam * B1, g2 - lam * B2
    sigma = -(y1 * t1 + y2 * t2)
    wmax = _pmax2(_pmax2(A, C11), C22)
    tol = 1e-6 * (c + abs(v0) + abs(v1) + abs(v2)
                  + wmax * (p + abs(a1) + abs(a2)) + abs(lam) * A)
    return sigma >= -tol and abs(y1 * t2 - y2 * t1) <= tol and abs(
        y0 - mu * sigma) <= tol * (1.0 + mu)


@_jit
def _md_verified(w00, w01, w02, w11, w12, w22, v0, v1, v2, c, mu, p, t1, t2, tl, interior):
    """Cheap certificate that the boundary direction t maximizes T_L (guards the quartic).

    When P_N's optimum lies on the boundary it is this point (:func:`_pn_kkt`). When it is
    interior, or that test fails to round-off (e.g. mu so small that T_L is flat in t), T_L(t)
    must beat eight probe directions."""
    if not interior and _pn_kkt(w00, w01, w02, w11, w12, w22, v0, v1, v2, c, mu, p, t1, t2):
        return True
    A, B1, B2, C11, C12, C22 = w00, w01, w02, w11, w12, w22
    for k in range(8):
        x, y = _PROBE_X[k], _PROBE_Y[k]
        D = A + mu * (B1 * x + B2 * y)
        if D > 0.0:
            pn = c / D
            pWp = D + mu * (x * (B1 + mu * (C11 * x + C12 * y)) + y * (B2 + mu * (C12 * x
                                                                                  + C22 * y)))
            if -pn * (v0 + mu * (v1 * x + v2 * y)) - 0.5 * pn * pn * pWp > (
                    tl + 1e-9 * (abs(tl) + c * c / A)):
                return False
    return True


@_jit
def _md_tl(A, B1, B2, C11, C12, C22, v0, v1, v2, c, mu, x, y):
    """(D, T_L) of the slide along (x, y) (eq. 60 with pi_n from eq. 38)."""
    D = A + mu * (B1 * x + B2 * y)
    pWp = D + mu * (x * (B1 + mu * (C11 * x + C12 * y)) + y * (B2 + mu * (C12 * x + C22 * y)))
    pn = c / D
    return D, -pn * (v0 + mu * (v1 * x + v2 * y)) - 0.5 * pn * pn * pWp


@_jit
def _md_angle(A, B1, B2, C11, C12, C22, v0, v1, v2, c, mu, E0, Ex, Ey, Exx, Eyy, Exy, robust):
    """The direction maximizing T_L (eq. 60) on the cone boundary with D > 0, over every root
    of the stationarity equation E (in R's basis): (ok, x, y, T_L, pi_n, D). The roots are
    stationary, so their unpolished scores are accurate to second order: the winner and any
    runner-up within 1e-6 are polished."""
    has, q4, q3, q2, q1, q0, cp, sp, n, xs, ys, ts, rs = _candidates(E0, Ex, Ey, Exx, Eyy,
                                                                     Exy, robust)
    dmin = 1e-12 * (A + mu * math.hypot(B1, B2))
    ns = 0
    top = 0.0
    for j in range(n):
        D, tl = _md_tl(A, B1, B2, C11, C12, C22, v0, v1, v2, c, mu, xs[j], ys[j])
        if not D > dmin:
            continue
        if ns == 0 or tl > top:
            top = tl
        ns += 1
    if ns == 0:
        return False, 0.0, 0.0, 0.0, 0.0, 0.0
    cut = top - 1e-6 * (abs(top) + 1e-300)
    found = False
    bx, by, btl, bp, bD = 0.0, 0.0, 0.0, 0.0, 0.0
    for j in range(n):
        D, tl0 = _md_tl(A, B1, B2, C11, C12, C22, v0, v1, v2, c, mu, xs[j], ys[j])
        if not D > dmin or tl0 < cut:
            continue
        x, y = _refine(has, q4, q3, q2, q1, q0, cp, sp, xs[j], ys[j], ts[j], rs[j])
        D = A + mu * (B1 * x + B2 * y)
        if D > dmin:
            D, tl = _md_tl(A, B1, B2, C11, C12, C22, v0, v1, v2, c, mu, x, y)
        else:
            x, y, tl = xs[j], ys[j], tl0
            D = A + mu * (B1 * x + B2 * y)
        if not found or tl > btl:
            found = True
            bx, by, btl, bp, bD = x, y, tl, c / D, D
    return True, bx, by, btl, bp, bD



@_jit
def max_dissipation_slide(w00, w01, w02, w11, w12, w22, v0, v1, v2, c, mu, has_inv, i00, i01,
                          i02, i11, i12, i22, f1, f2):
    """The seed's spatial slide maximizing eq. (60), with ``c = -(1 + e) v_n``.

    Reference direction -v_t- (else the unit ``(f1, f2)``, else t1). When ``has_inv`` (the
    symmetric W^-1 given as ``i..``) tells that P_N's optimum lies on the boundary, Newton's
    method from the reference direction is tried first and certified by P_N's KKT conditions;
    otherwise, or if that fails, every root of the boundary quartic is compared, the answer is
    certified (KKT or probe directions), then retried with companion-matrix roots.

    Returns (status, t1, t2, T_L, pi_n, D, interior): status OK, or NO_SOLUTION when no
    direction could be certified; ``interior`` says whether P_N's optimum is interior to the
    cone (unknown, hence True, without W^-1).
    """
    g1, g2 = _unit_or(f1, f2, 1.0, 0.0)
    r1, r2 = _unit_or(-v1, -v2, g1, g2)
    interior = True
    if has_inv:
        # P_N's optimum over the plane a.pi = c: pi* = lam e_n - W^-1 v, lam = (c + v_n) / W_nn
        q0, q1, q2 = _solve3(i00, i01, i02, i11, i12, i22, v0, v1, v2)
        lam = (c + v0) / w00
        interior = _in_cone(lam - q0, math.hypot(q1, q2), mu)
    A, B1, B2, C11, C12, C22, R6, R7, R8 = _rotate(w00, w01, w02, w11, w12, w22, v0, v1, v2,
                                                   r1, r2)
    # the stationarity equation det[c W p + (a.p) v, a, q] = 0
    mB1, mB2 = mu * B1, mu * B2
    cv, cm = c + R6, c * mu
    E0, Ex, Ey, Exx, Eyy, Exy = _det_wq(
        cv * A, cv * mB1, cv * mB2,
        c * B1 + R7 * A, cm * C11 + R7 * mB1, cm * C12 + R7 * mB2,
        c * B2 + R8 * A, cm * C12 + R8 * mB1, cm * C22 + R8 * mB2, A, B1, B2, mu)
    if not interior:
        # fast path: Newton from -v_t; P_N is convex, so its KKT conditions certify the root
        x, y, converged = _newton_root(E0, Ex, Ey, Exx, Eyy, Exy)
        D = A + mu * (B1 * x + B2 * y)
        if converged and D > 1e-12 * (A + mu * math.hypot(B1, B2)):
            p = c / D
            t1, t2 = x * r1 - y * r2, x * r2 + y * r1
            if _pn_kkt(w00, w01, w02, w11, w12, w22, v0, v1, v2, c, mu, p, t1, t2):
                D, tl = _md_tl(A, B1, B2, C11, C12, C22, R6, R7, R8, c, mu, x, y)
                return OK, t1, t2, tl, p, D, interior
    for robust in (False, True):  # Ferrari's roots, then the companion matrix's
        ok, x, y, tl, p, D = _md_angle(A, B1, B2, C11, C12, C22, R6, R7, R8, c, mu,
                                       E0, Ex, Ey, Exx, Eyy, Exy, robust)
        t1, t2 = x * r1 - y * r2, x * r2 + y * r1
        if ok and _md_verified(w00, w01, w02, w11, w12, w22, v0, v1, v2, c, mu, p, t1, t2, tl,
                               interior):
            return OK, t1, t2, tl, p, D, interior
    return NO_SOLUTION, 0.0, 0.0, 0.0, 0.0, 0.0, interior


def max_dissipation_direction(W, v, e: float, mu: float, tol: float = 1e-10) -> np.ndarray:
    """Tangent direction of the friction impulse maximizing the energy loss T_L (eq. 60).

    The seed's spatial sliding rule (Section 9.3): ``pi = pi_n (n + mu t)`` with ``pi_n`` from
    eq. (38)/(51), ``pi_n = -(1+e) v_n / (W_n . (1, mu t))``, over the directions with a
    positive denominator. This is also the boundary optimum of P_N (minimize T+ subject to
    v_n+ = -e v_n-, pi in K_mu). Found exactly: the stationarity condition is a quartic in
    tan(alpha/2) solved in closed form and Newton-polished to machine precision.

    Parameters
    ----------
    W : (d, d) Delassus block of the contact (d = 2 planar, 3 spatial).
    v : (d,) pre-impact contact velocity, v[0] = v_n < 0.
    e, mu : restitution in [0, 1] and friction > 0.
    tol : accepted for interface compatibility with iterative searches; the answer is exact
        to round-off (about 1e-15 in angle at simple roots) whatever its value.

    Returns
    -------
    (d-1,) unit vector t in the frame's tangent axes.

    Raises
    ------
    SingularSystemError if W_nn <= 0; ShapeError for bad shapes; SolverError if no direction
    could be certified.
    """
    e = real_number("e", e)
    mu = real_number("mu", mu)
    w, vv, d = as_lists(W, v)
    if not w[0][0] > 0.0:
        raise SingularSystemError(
            f"W_nn = {w[0][0]:.3e}: the contact normal moves no mass; no impulse can act")
    c = -(1.0 + e) * vv[0]
    if d == 2:
        best, bt = None, None
        for s in (-1.0, 1.0) if vv[1] >= 0.0 else (1.0, -1.0):
            D = w[0][0] + mu * s * w[0][1]
            if not D > 0.0:
                continue
            pn = c / D
            tl = -pn * (vv[0] + mu * s * vv[1]) - 0.5 * pn * pn * (
                w[0][0] + 2.0 * mu * s * w[0][1] + mu * mu * w[1][1])
            if best is None or tl > best:
                best, bt = tl, s
        return np.array([bt if bt is not None else 1.0])
    (w00, w01, w02), (_, w11, w12), (_, _, w22) = w
    i00, i01, i02, i11, i12, i22, _, has_inv = _inverse3(w00, w01, w02, w11, w12, w22)
    st, t1, t2 = max_dissipation_slide(w00, w01, w02, w11, w12, w22, vv[0], vv[1], vv[2], c,
                                       mu, has_inv, i00, i01, i02, i11, i12, i22, 1.0, 0.0)[:3]
    if st != OK:
        raise SolverError("the maximal-dissipation direction could not be certified (KKT of "
                          "P_N or probe directions); use method='sweep' or 'clarabel'")
    return np.array((t1, t2))
