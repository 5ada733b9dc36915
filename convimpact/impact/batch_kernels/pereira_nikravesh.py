"""The compiled kernel of the Pereira-Nikravesh law for one contact
(:func:`convimpact.impact.laws.pereira_nikravesh.contact_kernel`, mu > 0).

The stick impulse if it lies in the friction cone; else the planar slide against the slip, or
the spatial slide of maximal dissipation (:mod:`~convimpact.impact.max_dissipation`): Newton's
root certified by the KKT conditions, else the most dissipative candidate direction verified by
probing the cone. Each kernel returns ``(status, regime, p0, p1, p2, effective_mass)``.
"""

from __future__ import annotations

import math

from .algebra import (
    _candidates,
    _det_wq,
    _inverse3,
    _linsolve3,
    _newton_root,
    _refine,
    _rotate,
    _solve2,
    _solve3,
)
from .common import (
    DEFER,
    FAILED,
    JAM,
    OK,
    SINGULAR,
    SLIDE,
    STICK,
    _NAN,
    _in_cone,
    _jit,
    _pmax2,
    _unit_or,
)

# directions probed by the certificate of maximal dissipation (constants as tuples)
_PROBE_X = tuple(math.cos(k * math.pi / 4) for k in range(8))
_PROBE_Y = tuple(math.sin(k * math.pi / 4) for k in range(8))


# --------------------------------------------------------------------------------------------
# max_dissipation


@_jit
def _pn_kkt(w00, w01, w02, w11, w12, w22, v0, v1, v2, c, mu, p, t1, t2):
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
    """max_dissipation._max_dissipation_verified."""
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
def _md_angle(A, B1, B2, C11, C12, C22, v0, v1, v2, c, mu, E0, Ex, Ey, Exx, Eyy, Exy):
    """max_dissipation._dissipation_angle (robust=False): (ok, x, y, T_L, pi_n, D)."""
    has, q4, q3, q2, q1, q0, cp, sp, n, xs, ys, ts, rs = _candidates(E0, Ex, Ey, Exx, Eyy,
                                                                     Exy)
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


# --------------------------------------------------------------------------------------------
# the kernels


@_jit
def _pn_planar(w00, w01, w11, v0, v1, e, mu):
    """laws.pereira_nikravesh.contact_kernel, d = 2, mu > 0."""
    c = -(1.0 + e) * v0
    pn, pt, ok = _solve2(w00, w01, w11, c, -v1)
    if not ok:
        return SINGULAR, FAILED, _NAN, _NAN, _NAN, _NAN
    if _in_cone(pn, abs(pt), mu):
        return OK, STICK, pn, pt, 0.0, _NAN
    if v1 != 0.0:
        s = -math.copysign(1.0, v1)
    else:
        s = math.copysign(1.0, pt) if pt != 0.0 else 1.0
    D = w00 + mu * s * w01
    wm = _pmax2(_pmax2(abs(w00), abs(w01)), abs(w11))
    if not D > 1e-12 * wm:
        return JAM, FAILED, _NAN, _NAN, _NAN, D
    p = c / D
    return OK, SLIDE, p, mu * s * p, 0.0, D


@_jit
def _pn_spatial(w00, w01, w02, w11, w12, w22, v0, v1, v2, e, mu):
    """laws.pereira_nikravesh.contact_kernel, d = 3, mu > 0."""
    c = -(1.0 + e) * v0
    i00, i01, i02, i11, i12, i22, det, ok = _inverse3(w00, w01, w02, w11, w12, w22)
    if not ok:
        return SINGULAR, FAILED, _NAN, _NAN, _NAN, _NAN
    pn, p1, p2 = _linsolve3(w00, w01, w02, w11, w12, w22, i00, i01, i02, i11, i12, i22, det,
                            c, -v1, -v2)
    if _in_cone(pn, math.hypot(p1, p2), mu):
        return OK, STICK, pn, p1, p2, _NAN
    # max_dissipation.max_dissipation_slide(w, v, c, mu, inv, (p1, p2))
    f1, f2 = _unit_or(p1, p2, 1.0, 0.0)
    r1, r2 = _unit_or(-v1, -v2, f1, f2)
    q0, q1, q2 = _solve3(i00, i01, i02, i11, i12, i22, v0, v1, v2)
    lam = (c + v0) / w00
    interior = _in_cone(lam - q0, math.hypot(q1, q2), mu)
    A, B1, B2, C11, C12, C22, R6, R7, R8 = _rotate(w00, w01, w02, w11, w12, w22, v0, v1, v2,
                                                   r1, r2)
    # _dissipation_equation(R, c, mu)
    mB1, mB2 = mu * B1, mu * B2
    cv, cm = c + R6, c * mu
    E0, Ex, Ey, Exx, Eyy, Exy = _det_wq(
        cv * A, cv * mB1, cv * mB2,
        c * B1 + R7 * A, cm * C11 + R7 * mB1, cm * C12 + R7 * mB2,
        c * B2 + R8 * A, cm * C12 + R8 * mB1, cm * C22 + R8 * mB2, A, B1, B2, mu)
    if not interior:
        x, y, converged = _newton_root(E0, Ex, Ey, Exx, Eyy, Exy)
        D = A + mu * (B1 * x + B2 * y)
        if converged and D > 1e-12 * (A + mu * math.hypot(B1, B2)):
            p = c / D
            t1, t2 = x * r1 - y * r2, x * r2 + y * r1
            if _pn_kkt(w00, w01, w02, w11, w12, w22, v0, v1, v2, c, mu, p, t1, t2):
                return OK, SLIDE, p, mu * p * t1, mu * p * t2, D
    ok, x, y, tl, p, D = _md_angle(A, B1, B2, C11, C12, C22, R6, R7, R8, c, mu,
                                   E0, Ex, Ey, Exx, Eyy, Exy)
    if not ok:
        return DEFER, FAILED, _NAN, _NAN, _NAN, _NAN
    t1, t2 = x * r1 - y * r2, x * r2 + y * r1
    if not _md_verified(w00, w01, w02, w11, w12, w22, v0, v1, v2, c, mu, p, t1, t2, tl,
                        interior):
        return DEFER, FAILED, _NAN, _NAN, _NAN, _NAN  # companion-matrix roots: Python
    return OK, SLIDE, p, mu * p * t1, mu * p * t2, D
