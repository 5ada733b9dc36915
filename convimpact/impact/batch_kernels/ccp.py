"""The compiled kernel of the CCP law for one contact
(:func:`convimpact.impact.laws.ccp.ccp_impulse`, mu > 0): the convex program's answer in closed
form. Separating if the restituted velocity lies in the dual cone, the stick impulse if it lies
in the cone, else the optimal ray on the cone's boundary (Newton's root certified by u_n >= 0,
else the best candidate direction). Each kernel returns
``(status, regime, p0, p1, p2, effective_mass)``.
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
)
from .common import (
    DEFER,
    FAILED,
    OK,
    SEPARATING,
    SINGULAR,
    SLIDE,
    STICK,
    _NAN,
    _in_cone,
    _jit,
    _unit_or,
)


@_jit
def _ccp_ray(A, B1, B2, C11, C12, C22, b0, b1, b2, mu, x, y):
    pb = b0 + mu * (b1 * x + b2 * y)
    pWp = A + mu * (2.0 * (B1 * x + B2 * y) + mu * (C11 * x * x + 2.0 * C12 * x * y
                                                    + C22 * y * y))
    return pb, pWp


@_jit
def _ccp_un(A, B1, B2, b0, mu, x, y, pb, pWp):
    """(r, u_n) of the optimal point of the ray along t = (x, y) (ccp._ray_answer)."""
    r = -pb / pWp
    return r, b0 + r * (A + mu * (B1 * x + B2 * y))


@_jit
def _ccp_planar(w00, w01, w11, v0, v1, e, mu, out):
    """laws.ccp.ccp_impulse, d = 2, mu > 0."""
    b0 = (1.0 + e) * v0
    b1 = v1
    bt = abs(b1)
    if b0 >= mu * bt:
        return OK, SEPARATING, 0.0, 0.0, 0.0, _NAN
    pn, pt, ok = _solve2(w00, w01, w11, -b0, -b1)
    if not ok:
        return SINGULAR, FAILED, _NAN, _NAN, _NAN, _NAN
    if _in_cone(pn, abs(pt), mu):
        return OK, STICK, pn, pt, 0.0, _NAN
    found = False
    bobj, bs, br = 0.0, 0.0, 0.0
    for k in range(2):
        s = 1.0 if k == 0 else -1.0
        pb = b0 + mu * s * b1
        pWp = w00 + 2.0 * mu * s * w01 + mu * mu * w11
        if pb < 0.0 and pWp > 0.0:
            obj = -0.5 * pb * pb / pWp
            if not found or obj < bobj:
                found = True
                bobj, bs, br = obj, s, -pb / pWp
    if not found:
        return DEFER, FAILED, _NAN, _NAN, _NAN, _NAN
    return OK, SLIDE, br, mu * bs * br, 0.0, _NAN


@_jit
def _ccp_spatial(w00, w01, w02, w11, w12, w22, v0, v1, v2, e, mu, out):
    """laws.ccp.ccp_impulse, d = 3, mu > 0."""
    b0 = (1.0 + e) * v0
    b1 = v1
    b2 = v2
    if b0 >= mu * math.hypot(b1, b2):
        return OK, SEPARATING, 0.0, 0.0, 0.0, _NAN
    i00, i01, i02, i11, i12, i22, det, ok = _inverse3(w00, w01, w02, w11, w12, w22)
    if not ok:
        return SINGULAR, FAILED, _NAN, _NAN, _NAN, _NAN
    pn, p1, p2 = _linsolve3(w00, w01, w02, w11, w12, w22, i00, i01, i02, i11, i12, i22, det,
                            -b0, -b1, -b2)
    if _in_cone(pn, math.hypot(p1, p2), mu):
        return OK, STICK, pn, p1, p2, _NAN
    f1, f2 = _unit_or(-v1, -v2, 1.0, 0.0)
    r1, r2 = _unit_or(p1, p2, f1, f2)
    A, B1, B2, C11, C12, C22, R6, R7, R8 = _rotate(w00, w01, w02, w11, w12, w22, b0, b1, b2,
                                                   r1, r2)
    scale = abs(b0) + abs(b1) + abs(b2)
    E0, Ex, Ey, Exx, Eyy, Exy = _det_wq(A, mu * B1, mu * B2, B1, mu * C11, mu * C12,
                                        B2, mu * C12, mu * C22, R6, R7, R8, mu)
    # fast path: Newton from the unconstrained tangent, certified by u_n >= 0 (KKT)
    x, y, converged = _newton_root(E0, Ex, Ey, Exx, Eyy, Exy)
    good = False
    r = 0.0
    if converged:
        pb, pWp = _ccp_ray(A, B1, B2, C11, C12, C22, R6, R7, R8, mu, x, y)
        if pb < 0.0 and pWp > 0.0:
            r, un = _ccp_un(A, B1, B2, R6, mu, x, y, pb, pWp)
            good = not (un < -1e-6 * scale)
    if not good:
        # ccp._ccp_boundary(R, mu, False, E)
        has, q4, q3, q2, q1, q0, cp, sp, n, xs, ys, ts, rs = _candidates(E0, Ex, Ey, Exx, Eyy,
                                                                         Exy)
        ns = 0
        top = 0.0
        for j in range(n):
            pb, pWp = _ccp_ray(A, B1, B2, C11, C12, C22, R6, R7, R8, mu, xs[j], ys[j])
            if pb < 0.0 and pWp > 0.0:
                g = 0.5 * pb * pb / pWp
                if ns == 0 or g > top:
                    top = g
                ns += 1
        if ns == 0:
            return DEFER, FAILED, _NAN, _NAN, _NAN, _NAN
        cut = top - 1e-6 * top
        found = False
        bg, bx, by, bpb, bpWp = 0.0, 0.0, 0.0, 0.0, 0.0
        for j in range(n):
            pb, pWp = _ccp_ray(A, B1, B2, C11, C12, C22, R6, R7, R8, mu, xs[j], ys[j])
            if not (pb < 0.0 and pWp > 0.0) or 0.5 * pb * pb / pWp < cut:
                continue
            x, y = _refine(has, q4, q3, q2, q1, q0, cp, sp, xs[j], ys[j], ts[j], rs[j])
            pb, pWp = _ccp_ray(A, B1, B2, C11, C12, C22, R6, R7, R8, mu, x, y)
            if not (pb < 0.0 and pWp > 0.0):
                x, y = xs[j], ys[j]
                pb, pWp = _ccp_ray(A, B1, B2, C11, C12, C22, R6, R7, R8, mu, x, y)
            g = 0.5 * pb * pb / pWp
            if not found or g > bg:
                found = True
                bg, bx, by, bpb, bpWp = g, x, y, pb, pWp
        x, y = bx, by
        r, un = _ccp_un(A, B1, B2, R6, mu, x, y, bpb, bpWp)
        if un < -1e-6 * scale:
            return DEFER, FAILED, _NAN, _NAN, _NAN, _NAN  # companion-matrix roots: Python
    t1, t2 = x * r1 - y * r2, x * r2 + y * r1
    return OK, SLIDE, r, mu * r * t1, mu * r * t2, _NAN
