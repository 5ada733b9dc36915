"""The compiled kernel of Coulomb's law for one contact
(:func:`convimpact.impact.laws.coulomb.contact_kernel`, mu > 0).

The stick impulse if it lies in the friction cone; else every slide whose post-impact slip
opposes the friction (the roots of the Coulomb condition on the cone's boundary: a polished
quartic root and its deflated cubic, else every candidate direction), the most dissipative
kept. Each kernel returns ``(status, regime, p0, p1, p2, effective_mass)``.
"""

from __future__ import annotations

import math

from .algebra import (
    _candidates,
    _cubic,
    _inverse3,
    _linsolve3,
    _polish,
    _refine,
    _rotate,
    _solve2,
)
from .common import (
    CONE_RTOL,
    DEFER,
    FAILED,
    JAM,
    OK,
    ROOT_RTOL,
    SINGULAR,
    SLIDE,
    STICK,
    _NAN,
    _in_cone,
    _jit,
    _pmax2,
    _tset5,
    _unit_or,
)


@_jit
def _coulomb_conditions(x, y, rtol, E0, Ex, Ey, Exx, Eyy, Exy, escale, A, B1, B2, C11, C12,
                        C22, v0, v1, v2, c, mu, dmin, vscale, wscale):
    """coulomb.contact_kernel's conditions(): (status, T_L, pi_n, D, sigma); status 0 = a
    Coulomb slide, 1 = rejected, 2 = rejected by a non-positive denominator (a jam)."""
    if abs(E0 + Ex * x + Ey * y + Exx * x * x + Eyy * y * y + Exy * x * y) > rtol * escale:
        return 1, 0.0, 0.0, 0.0, 0.0
    D = A + mu * (B1 * x + B2 * y)
    if not D > dmin:
        return 2, 0.0, 0.0, 0.0, 0.0
    P1 = B1 + mu * (C11 * x + C12 * y)
    P2 = B2 + mu * (C12 * x + C22 * y)
    p = c / D
    u1, u2 = v1 + p * P1, v2 + p * P2
    sigma = -(u1 * x + u2 * y)
    if sigma < -rtol * vscale or abs(u1 * y - u2 * x) > rtol * (vscale + abs(p) * wscale):
        return 1, 0.0, 0.0, 0.0, 0.0
    pWp = D + mu * (x * P1 + y * P2)
    return 0, -p * (v0 + mu * (v1 * x + v2 * y)) - 0.5 * p * p * pWp, p, D, sigma


@_jit
def _coulomb_add(fx, fy, nf, btl, bx, by, bp, bD, tl, x, y, p, D, dedup):
    """coulomb.contact_kernel's add() and max(found): the set of found directions (fx, fy, nf)
    and the best entry, lexicographic on (T_L, x, y) as Python's max over the tuples."""
    if dedup:
        for j in range(nf):
            if abs(x - fx[j]) + abs(y - fy[j]) < 1e-9:
                return fx, fy, nf, btl, bx, by, bp, bD
    if nf < 5:
        fx = _tset5(fx, nf, x)
        fy = _tset5(fy, nf, y)
    if nf == 0 or tl > btl or (tl == btl and (x > bx or (x == bx and y > by))):
        btl, bx, by, bp, bD = tl, x, y, p, D
    return fx, fy, nf + 1, btl, bx, by, bp, bD


@_jit
def _coulomb_planar(w00, w01, w11, v0, v1, e, mu, out):
    """laws.coulomb.contact_kernel, d = 2, mu > 0."""
    c = -(1.0 + e) * v0
    wscale = w00 if w00 > w11 else w11
    dmin = 1e-12 * wscale
    vscale = _pmax2(_pmax2(abs(v0), abs(v1)), abs(v1))
    pn, pt, ok = _solve2(w00, w01, w11, c, -v1)
    if not ok:
        return SINGULAR, FAILED, _NAN, _NAN, _NAN, _NAN
    if _in_cone(pn, abs(pt), mu):
        return OK, STICK, pn, pt, 0.0, _NAN
    A, B, C = w00, w01, w11
    nf = 0
    jam = False
    jmin = 0.0
    btl, bs, bp, bD = 0.0, 0.0, 0.0, 0.0
    for k in range(2):
        s = 1.0 if k == 0 else -1.0
        D = A + mu * s * B
        if not D > dmin:
            if not jam or D < jmin:
                jmin = D
            jam = True
            continue
        p = c / D
        ut = v1 + p * (B + mu * s * C)
        if ut * s <= CONE_RTOL * vscale:
            tl = -p * (v0 + mu * s * v1) - 0.5 * p * p * (D + mu * s * (B + mu * s * C))
            if nf == 0 or tl > btl or (tl == btl and s > bs):
                btl, bs, bp, bD = tl, s, p, D
            nf += 1
    if nf == 0:
        if jam:
            return JAM, FAILED, _NAN, _NAN, _NAN, jmin
        return DEFER, FAILED, _NAN, _NAN, _NAN, _NAN
    return OK, SLIDE, bp, mu * bs * bp, 0.0, bD


@_jit
def _coulomb_spatial(w00, w01, w02, w11, w12, w22, v0, v1, v2, e, mu, out):
    """laws.coulomb.contact_kernel, d = 3, mu > 0."""
    c = -(1.0 + e) * v0
    b0 = -c
    wscale = w00 if w00 > w11 else w11
    if w22 > wscale:
        wscale = w22
    dmin = 1e-12 * wscale
    vscale = _pmax2(_pmax2(abs(v0), abs(v1)), abs(v2))
    i00, i01, i02, i11, i12, i22, det, ok = _inverse3(w00, w01, w02, w11, w12, w22)
    if not ok:
        return SINGULAR, FAILED, _NAN, _NAN, _NAN, _NAN
    pn, p1, p2 = _linsolve3(w00, w01, w02, w11, w12, w22, i00, i01, i02, i11, i12, i22, det,
                            c, -v1, -v2)
    if _in_cone(pn, math.hypot(p1, p2), mu):
        return OK, STICK, pn, p1, p2, _NAN
    f1, f2 = _unit_or(-v1, -v2, 1.0, 0.0)
    r1, r2 = _unit_or(p1, p2, f1, f2)
    A, B1, B2, C11, C12, C22, R6, R7, R8 = _rotate(w00, w01, w02, w11, w12, w22, v0, v1, v2,
                                                   r1, r2)
    u00, u0x, u0y, u10, u1x, u1y, u20, u2x, u2y = (A, mu * B1, mu * B2, B1, mu * C11, mu * C12,
                                                   B2, mu * C12, mu * C22)
    E0 = 0.0
    Ex = u00 * R8 - u20 * b0
    Ey = -u00 * R7 + u10 * b0
    Exx = u0x * R8 - u2x * b0
    Eyy = -u0y * R7 + u1y * b0
    Exy = -u0x * R7 + u0y * R8 + u1x * b0 - u2y * b0
    escale = abs(Ex) + abs(Ey) + abs(Exx) + abs(Eyy) + abs(Exy)
    if escale == 0.0:
        escale = 1.0
    nf = 0
    fx = fy = (0.0, 0.0, 0.0, 0.0, 0.0)
    btl, bx, by, bp, bD = 0.0, 0.0, 0.0, 0.0, 0.0
    jam = False
    c4, c3, c2, c1, c0 = (E0 - Ex + Exx, 2.0 * (Ey - Exy), 2.0 * (E0 - Exx) + 4.0 * Eyy,
                          2.0 * (Ey + Exy), E0 + Ex + Exx)
    big = _pmax2(_pmax2(_pmax2(_pmax2(abs(c4), abs(c3)), abs(c2)), abs(c1)), abs(c0))
    fast_done = False
    if abs(c4) >= 1e-2 * big:
        t0 = _polish(c4, c3, c2, c1, c0, 0.0)
        t2 = t0 * t0
        st, tl, p, D, sig = _coulomb_conditions(
            (1.0 - t2) / (1.0 + t2), 2.0 * t0 / (1.0 + t2), ROOT_RTOL, E0, Ex, Ey, Exx, Eyy,
            Exy, escale, A, B1, B2, C11, C12, C22, R6, R7, R8, c, mu, dmin, vscale, wscale)
        if st == 2:
            jam = True
        if st == 0:
            fast_done = True
            fx, fy, nf, btl, bx, by, bp, bD = _coulomb_add(
                fx, fy, nf, btl, bx, by, bp, bD, tl, (1.0 - t2) / (1.0 + t2),
                2.0 * t0 / (1.0 + t2), p, D, False)
            q2 = c3 + t0 * c4
            q1 = c2 + t0 * q2
            q0 = c1 + t0 * q1
            ncub, ra, rb, rc = _cubic(q2 / c4, q1 / c4, q0 / c4)
            for j in range(ncub):
                t = ra if j == 0 else (rb if j == 1 else rc)
                t2 = t * t
                x, y = (1.0 - t2) / (1.0 + t2), 2.0 * t / (1.0 + t2)
                st, tl, p, D, sig = _coulomb_conditions(
                    x, y, 1e-6, E0, Ex, Ey, Exx, Eyy, Exy, escale, A, B1, B2, C11, C12, C22,
                    R6, R7, R8, c, mu, dmin, vscale, wscale)
                if st == 2:
                    jam = True
                if st != 0:
                    continue
                t = _polish(c4, c3, c2, c1, c0, t)
                t2 = t * t
                x, y = (1.0 - t2) / (1.0 + t2), 2.0 * t / (1.0 + t2)
                st, tl, p, D, sig = _coulomb_conditions(
                    x, y, ROOT_RTOL, E0, Ex, Ey, Exx, Eyy, Exy, escale, A, B1, B2, C11, C12,
                    C22, R6, R7, R8, c, mu, dmin, vscale, wscale)
                if st == 2:
                    jam = True
                if st == 0:
                    fx, fy, nf, btl, bx, by, bp, bD = _coulomb_add(
                        fx, fy, nf, btl, bx, by, bp, bD, tl, x, y, p, D, True)
    if not fast_done:
        has, q4, q3, q2, q1, q0, cp, sp, n, xs, ys, ts, rs = _candidates(E0, Ex, Ey, Exx, Eyy,
                                                                         Exy)
        for j in range(n):
            st, tl, p, D, sig = _coulomb_conditions(
                xs[j], ys[j], 1e-6, E0, Ex, Ey, Exx, Eyy, Exy, escale, A, B1, B2, C11,
                C12, C22, R6, R7, R8, c, mu, dmin, vscale, wscale)
            if st == 2:
                jam = True
            if st != 0:
                continue
            x, y = _refine(has, q4, q3, q2, q1, q0, cp, sp, xs[j], ys[j], ts[j], rs[j])
            st, tl, p, D, sig = _coulomb_conditions(
                x, y, ROOT_RTOL, E0, Ex, Ey, Exx, Eyy, Exy, escale, A, B1, B2, C11, C12, C22,
                R6, R7, R8, c, mu, dmin, vscale, wscale)
            if st == 2:
                jam = True
            if st == 0:
                fx, fy, nf, btl, bx, by, bp, bD = _coulomb_add(
                    fx, fy, nf, btl, bx, by, bp, bD, tl, x, y, p, D, True)
        if nf == 0:
            # the Python kernel retries with companion-matrix roots, then raises
            if jam:
                return DEFER, FAILED, _NAN, _NAN, _NAN, _NAN
            return DEFER, FAILED, _NAN, _NAN, _NAN, _NAN
    if nf == 0:  # pragma: no cover - fast_done implies a solution
        return DEFER, FAILED, _NAN, _NAN, _NAN, _NAN
    x, y, p, D = bx, by, bp, bD  # max(found)
    t1, t2 = x * r1 - y * r2, x * r2 + y * r1
    return OK, SLIDE, p, mu * p * t1, mu * p * t2, D
