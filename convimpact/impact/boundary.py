"""Roots of a trigonometric quadratic on the friction cone's boundary (pure Python floats).

On the cone boundary ``pi = pi_n (1, mu t)``, ``t = (cos th, sin th)``, every law's defining
condition is a determinant of three columns affine in ``z = (1, cos th, sin th)``, hence a
trigonometric polynomial of degree 2, ``E(th) = e0 + ex x + ey y + exx x^2 + eyy y^2 + exy x y``
in ``x = cos th, y = sin th``, i.e. a quartic in ``tau = tan(th / 2)``. This module builds such
equations (:func:`det_wq`, :func:`rotate`, :func:`wp`) and finds their roots: Ferrari's closed
form (:func:`quartic_roots`), Newton-polished (:func:`polish`, :func:`refine`) in the chart where
the root is small (tau, or cot(th/2) for |tau| > 1, so nothing is lost at tau -> infinity),
measured from a reference angle where neither end coefficient vanishes (:func:`candidates`);
numpy's companion matrix is the fallback (``robust=True``). The laws in
:mod:`convimpact.impact.laws` call it and certify the root they keep.
"""

from __future__ import annotations

import math

import numpy as np


# --------------------------------------------------------------------------------------------
# polynomial roots


def quadratic_roots(b: float, c: float) -> list[float]:
    """Real roots of x^2 + b x + c (a nearly double complex pair gives its real part)."""
    disc = b * b - 4.0 * c
    if disc < 0.0:
        if disc >= -1e-9 * (b * b + abs(c)):
            return [-0.5 * b]
        return []
    s = math.sqrt(disc)
    q = -0.5 * (b + math.copysign(s, b))
    if q == 0.0:
        return [0.0]
    return [q, c / q]


def cubic_roots(a: float, b: float, c: float) -> list[float]:
    """Real roots of x^3 + a x^2 + b x + c (trigonometric / Cardano, Newton-polished)."""
    p = b - a * a / 3.0
    q = 2.0 * a * a * a / 27.0 - a * b / 3.0 + c
    shift = -a / 3.0
    disc = (q * q) / 4.0 + (p * p * p) / 27.0
    if p < 0.0 and disc <= 0.0:
        m = 2.0 * math.sqrt(-p / 3.0)
        arg = 3.0 * q / (p * m)
        arg = max(-1.0, min(1.0, arg))
        phi = math.acos(arg) / 3.0
        roots = [m * math.cos(phi - k * math.tau / 3.0) + shift for k in range(3)]
    else:
        sd = math.sqrt(max(disc, 0.0))
        u = -0.5 * q + sd if q <= 0.0 else -0.5 * q - sd
        u = math.copysign(abs(u) ** (1.0 / 3.0), u)
        t = u - p / (3.0 * u) if u != 0.0 else 0.0
        roots = [t + shift]
    out = []
    for x in roots:
        for _ in range(2):  # Newton polish on the cubic
            f = ((x + a) * x + b) * x + c
            df = (3.0 * x + 2.0 * a) * x + b
            if df == 0.0:
                break
            x -= f / df
        out.append(x)
    return out


def quartic_roots(c4: float, c3: float, c2: float, c1: float, c0: float) -> list[float] | None:
    """Approximate real roots of c4 x^4 + ... + c0 (Ferrari); None if the polynomial is zero.

    Leading coefficients negligible against the largest one are dropped (their roots sit near
    infinity, which the callers cover by trying the angle pi explicitly). Nearly double roots
    that round-off turns into a complex pair are returned as their real part; callers polish.
    """
    scale = max(abs(c4), abs(c3), abs(c2), abs(c1), abs(c0))
    if scale == 0.0:
        return None
    eps = 1e-13 * scale
    if abs(c4) <= eps:
        if abs(c3) <= eps:
            if abs(c2) <= eps:
                return [-c0 / c1] if abs(c1) > eps else []
            return quadratic_roots(c1 / c2, c0 / c2)
        return cubic_roots(c2 / c3, c1 / c3, c0 / c3)
    f = 1.0 / c4
    a, b, c, d = c3 * f, c2 * f, c1 * f, c0 * f
    a2 = a * a
    p = b - 0.375 * a2
    q = c - 0.5 * a * b + 0.125 * a2 * a
    r = d - 0.25 * a * c + 0.0625 * a2 * b - 0.01171875 * a2 * a2
    shift = -0.25 * a
    ap, sr = abs(p), math.sqrt(math.sqrt(abs(r)))
    if abs(q) <= 1e-14 * (ap * math.sqrt(ap) + sr * sr * sr + abs(q)):  # biquadratic
        ys = []
        for z in quadratic_roots(p, r):
            if z > 0.0:
                s = math.sqrt(z)
                ys += [s + shift, shift - s]
            elif z >= -1e-9 * (abs(p) + math.sqrt(abs(r))):
                ys.append(shift)
        return ys
    # resolvent 8 m^3 + 8 p m^2 + (2 p^2 - 8 r) m - q^2 = 0: its largest root m > 0
    ca, cb, cc = p, 0.25 * p * p - r, -0.125 * q * q
    pp = cb - ca * ca / 3.0
    qq = 2.0 * ca * ca * ca / 27.0 - ca * cb / 3.0 + cc
    disc = 0.25 * qq * qq + pp * pp * pp / 27.0
    if pp < 0.0 and disc <= 0.0:
        mm = 2.0 * math.sqrt(-pp / 3.0)
        arg = 3.0 * qq / (pp * mm)
        arg = 1.0 if arg > 1.0 else (-1.0 if arg < -1.0 else arg)
        m = mm * math.cos(math.acos(arg) / 3.0) - ca / 3.0
    else:
        sd = math.sqrt(disc if disc > 0.0 else 0.0)
        u = -0.5 * qq + sd if qq <= 0.0 else -0.5 * qq - sd
        u = math.copysign(abs(u) ** (1.0 / 3.0), u)
        m = (u - pp / (3.0 * u) if u != 0.0 else 0.0) - ca / 3.0
    dfm = (3.0 * m + 2.0 * ca) * m + cb  # one Newton step on the resolvent
    if dfm != 0.0:
        m -= (((m + ca) * m + cb) * m + cc) / dfm
    if m <= 0.0:
        m = 1e-300
    s = math.sqrt(2.0 * m)
    h = q / (2.0 * s)
    k = 0.5 * p + m
    out = []
    # y^2 - s y + (k + h) = 0 and y^2 + s y + (k - h) = 0 (stable forms; a nearly double
    # complex pair gives its real part)
    for b, c in ((-s, k + h), (s, k - h)):
        disc = b * b - 4.0 * c
        if disc >= 0.0:
            qr = -0.5 * (b + math.copysign(math.sqrt(disc), b))
            if qr != 0.0:
                out += [qr + shift, c / qr + shift]
            else:
                out.append(shift)
        elif disc >= -1e-9 * (b * b + abs(c)):
            out.append(shift - 0.5 * b)
    return out


# --------------------------------------------------------------------------------------------
# the boundary quartic: a trigonometric quadratic E(th) solved through tau = tan(th / 2)


def polish(c4: float, c3: float, c2: float, c1: float, c0: float, t: float) -> float:
    """Newton's method on the quartic from t (|t| <= 1 expected), safeguarded: a step is
    taken only if it decreases |f|, and steps are clipped to 0.5."""
    f = (((c4 * t + c3) * t + c2) * t + c1) * t + c0
    df = ((4.0 * c4 * t + 3.0 * c3) * t + 2.0 * c2) * t + c1
    for _ in range(8):
        if df == 0.0:
            break
        step = f / df
        if step > 0.5:
            step = 0.5
        elif step < -0.5:
            step = -0.5
        tn = t - step
        fn = (((c4 * tn + c3) * tn + c2) * tn + c1) * tn + c0
        if abs(fn) >= abs(f):
            break
        t, f = tn, fn
        if abs(step) < 1e-12:
            break
        df = ((4.0 * c4 * t + 3.0 * c3) * t + 2.0 * c2) * t + c1
    return t


#: reference rotations tried when E(0) or E(pi) nearly vanishes (roots near tau = 0 or inf)
_ROTATIONS = tuple((math.cos(a), math.sin(a), math.cos(2 * a), math.sin(2 * a))
                   for a in (0.5 * math.pi, 0.25 * math.pi, 0.75 * math.pi, 0.125 * math.pi,
                             0.375 * math.pi, 0.625 * math.pi, 0.875 * math.pi))


def candidates(e0: float, ex: float, ey: float, exx: float, eyy: float,
               exy: float, robust: bool = False) -> tuple[tuple | None, list]:
    """Unpolished points (x, y, chart value, reversed) where E(th) vanishes.

    E is first written in harmonics, a0 + a1 cos th + b1 sin th + a2 cos 2th + b2 sin 2th,
    and measured from a reference angle phi at which neither E(phi) nor E(phi + pi) nearly
    vanishes: those are the constant and leading coefficients of the quartic in
    tau = tan((th - phi)/2), so its roots stay bounded away from 0 and infinity and Ferrari's
    closed form stays accurate (phi = 0 unless min(|E(0)|, |E(pi)|) < 1e-2 max |c|). Each
    root is kept in the chart where it is small: tau itself for |tau| <= 1, s = 1/tau (the
    reversed quartic) otherwise; th = phi + pi is added when the leading coefficient is still
    small or no root was found. Returns the quartic's data (None if E vanishes identically:
    every direction is then stationary and the single candidate th = 0 is exact) and the
    points, (x, y) = (cos th, sin th) in the caller's basis; :func:`refine` polishes one.
    ``robust=True`` takes the roots from the companion matrix's eigenvalues (numpy) instead
    of Ferrari and always adds th = phi + pi: the callers' fallback when a check fails.
    """
    a0 = e0 + 0.5 * (exx + eyy)
    a1, b1, a2, b2 = ex, ey, 0.5 * (exx - eyy), 0.5 * exy
    cp, sp = 1.0, 0.0
    c4, c0 = a0 - a1 + a2, a0 + a1 + a2  # E(pi), E(0)
    big = max(abs(a0), abs(a1), abs(b1), abs(a2), abs(b2))
    if big == 0.0:
        return None, [(1.0, 0.0, 0.0, False)]
    if min(abs(c4), abs(c0)) < 1e-2 * big:
        best = min(abs(c4), abs(c0))
        for c, s, c2, s2 in _ROTATIONS:
            r1, r2 = a1 * c + b1 * s, a2 * c2 + b2 * s2
            q = min(abs(a0 - r1 + r2), abs(a0 + r1 + r2))
            if q > best:
                best, cp, sp, cp2, sp2 = q, c, s, c2, s2
                if q >= 1e-2 * big:
                    break
        if sp != 0.0 or cp != 1.0:
            a1, b1 = a1 * cp + b1 * sp, b1 * cp - a1 * sp
            a2, b2 = a2 * cp2 + b2 * sp2, b2 * cp2 - a2 * sp2
            c4, c0 = a0 - a1 + a2, a0 + a1 + a2
    c3 = 2.0 * (b1 - 2.0 * b2)
    c2 = 2.0 * a0 - 6.0 * a2
    c1 = 2.0 * (b1 + 2.0 * b2)
    roots = quartic_roots(c4, c3, c2, c1, c0) if not robust else eigen_roots(
        c4, c3, c2, c1, c0)
    if roots is None:
        return None, [(1.0, 0.0, 0.0, False)]
    pts = []
    for t in roots:
        if -1.0 <= t <= 1.0:
            t2 = t * t
            x, y = (1.0 - t2) / (1.0 + t2), 2.0 * t / (1.0 + t2)
            rev = False
        else:
            t = 1.0 / t
            t2 = t * t
            x, y = (t2 - 1.0) / (t2 + 1.0), 2.0 * t / (t2 + 1.0)
            rev = True
        pts.append((x * cp - y * sp, x * sp + y * cp, t, rev))
    if robust or not pts or abs(c4) <= 1e-6 * max(abs(c3), abs(c2), abs(c1), abs(c0)):
        pts.append((-cp, -sp, 0.0, True))  # th = phi + pi: a root near tau = infinity
    return (c4, c3, c2, c1, c0, cp, sp), pts


def eigen_roots(c4: float, c3: float, c2: float, c1: float, c0: float) -> list[float] | None:
    """Real parts of the nearly real roots of the quartic, from numpy's companion matrix."""
    c = np.array([c4, c3, c2, c1, c0])
    scale = float(np.max(np.abs(c)))
    if scale == 0.0:
        return None
    nz = np.flatnonzero(np.abs(c) > 1e-13 * scale)
    z = np.roots(c[nz[0]:])
    return [float(r.real) for r in z if abs(r.imag) <= 1e-6 * (1.0 + abs(r))]


def refine(coeffs: tuple | None, point: tuple) -> tuple[float, float]:
    """Newton-polished (x, y) = (cos th, sin th) of a candidate of :func:`candidates`."""
    x, y, t, rev = point
    if coeffs is None:
        return x, y
    c4, c3, c2, c1, c0, cp, sp = coeffs
    if rev:
        s = polish(c0, c1, c2, c3, c4, t)
        s2 = s * s
        x, y = (s2 - 1.0) / (s2 + 1.0), 2.0 * s / (s2 + 1.0)
    else:
        t = polish(c4, c3, c2, c1, c0, t)
        t2 = t * t
        x, y = (1.0 - t2) / (1.0 + t2), 2.0 * t / (1.0 + t2)
    return x * cp - y * sp, x * sp + y * cp


def newton_root(E: tuple) -> tuple[float, float, bool]:
    """Root of E(th) by Newton's method from th = 0, on the quartic in tan(th/2).

    Returns (x, y, converged): a fast path whose answer the callers certify (KKT of a convex
    program), falling back to :func:`candidates` when it is not certified.
    """
    e0, ex, ey, exx, eyy, exy = E
    c4 = e0 - ex + exx
    c3 = 2.0 * (ey - exy)
    c2 = 2.0 * (e0 - exx) + 4.0 * eyy
    c1 = 2.0 * (ey + exy)
    c0 = e0 + ex + exx
    t = polish(c4, c3, c2, c1, c0, 0.0)
    t2 = t * t
    x, y = (1.0 - t2) / (1.0 + t2), 2.0 * t / (1.0 + t2)
    res = e0 + ex * x + ey * y + exx * x * x + eyy * y * y + exy * x * y
    scale = abs(e0) + abs(ex) + abs(ey) + abs(exx) + abs(eyy) + abs(exy)
    return x, y, abs(res) <= 1e-12 * scale


# --------------------------------------------------------------------------------------------
# building E(th): W and v in a rotated tangent basis, W p, and det[., ., q]


def rotate(w: list, v: list, r1: float, r2: float) -> tuple:
    """(A, B1, B2, C11, C12, C22, v0, v1, v2): W and v in the tangent basis (r, r_perp)."""
    A, B1, B2 = w[0]
    C11, C12, C22 = w[1][1], w[1][2], w[2][2]
    rr = r1 * r2
    return (A, B1 * r1 + B2 * r2, B2 * r1 - B1 * r2,
            C11 * r1 * r1 + 2.0 * C12 * rr + C22 * r2 * r2,
            (C22 - C11) * rr + C12 * (r1 * r1 - r2 * r2),
            C11 * r2 * r2 - 2.0 * C12 * rr + C22 * r1 * r1,
            v[0], v[1] * r1 + v[2] * r2, v[2] * r1 - v[1] * r2)


def wp(R: tuple, mu: float) -> tuple:
    """W p, p = (1, mu x, mu y), as three affine forms (9 floats) in the rotated basis."""
    A, B1, B2, C11, C12, C22 = R[:6]
    return (A, mu * B1, mu * B2, B1, mu * C11, mu * C12, B2, mu * C12, mu * C22)


def det_wq(u: tuple, k0: float, k1: float, k2: float, mu: float) -> tuple:
    """E = sum_i U_i (k x q)_i with q = (-mu, x, y): U = (u00, u0x, u0y, u10, ..., u2y) are
    three affine forms, k a constant vector; returns (e0, ex, ey, exx, eyy, exy)."""
    u00, u0x, u0y, u10, u1x, u1y, u20, u2x, u2y = u
    mk1, mk2 = mu * k1, mu * k2
    # k x q = (k1 y - k2 x, -mu k2 - k0 y, k0 x + mu k1)
    return (-u10 * mk2 + u20 * mk1,
            -u00 * k2 - u1x * mk2 + u20 * k0 + u2x * mk1,
            u00 * k1 - u10 * k0 - u1y * mk2 + u2y * mk1,
            -u0x * k2 + u2x * k0,
            u0y * k1 - u1y * k0,
            u0x * k1 - u0y * k2 - u1x * k0 + u2y * k0)
