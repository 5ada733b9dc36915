"""The small algebra every law's compiled kernel shares.

* small solves: the 2 x 2 solve and the 3 x 3 inverse and solve of a symmetric W (scaled by
  its trace, one refinement step when nearly singular), with a scale-free singularity test
  (det W / tr(W)^d <= :data:`SINGULAR_RTOL`);
* the cone's boundary: real roots of quadratics, cubics and quartics, the safeguarded Newton
  polish, the candidate directions on the cone's boundary of a quadratic equation in
  (cos th, sin th) (the tangent half-angle quartic), W and v rotated to a tangent basis, and
  the determinant equation ``det_wq``.

These are the only implementation of this algebra: the laws' kernels call them compiled, and
the same code runs as plain Python under ``NUMBA_DISABLE_JIT=1``. The candidates' fallback
(``robust=True``) takes the quartic's roots from its companion matrix's eigenvalues
(:func:`_eigen_quartic`), as numpy's ``roots`` does.
"""

from __future__ import annotations

import math

import numpy as np

from .codes import SINGULAR_RTOL, _jit, _pmax2, _tset4, _tset5

# constants as tuples (no arrays, hence no reference counting in the compiled loops)
_ROT_ANGLES = (0.5 * math.pi, 0.25 * math.pi, 0.75 * math.pi, 0.125 * math.pi, 0.375 * math.pi,
               0.625 * math.pi, 0.875 * math.pi)
_ROT_C = tuple(math.cos(a) for a in _ROT_ANGLES)
_ROT_S = tuple(math.sin(a) for a in _ROT_ANGLES)
_ROT_C2 = tuple(math.cos(2 * a) for a in _ROT_ANGLES)
_ROT_S2 = tuple(math.sin(2 * a) for a in _ROT_ANGLES)


# --------------------------------------------------------------------------------------------
# small solves


@_jit
def _solve2(A, B, C, r0, r1):
    """(x0, x1, ok) of the 2 x 2 W x = r (adjugate; one refinement step when ill-conditioned)."""
    tr = A + C
    a, b, c = A / tr, B / tr, C / tr
    det = a * c - b * b
    if not det > SINGULAR_RTOL:
        return 0.0, 0.0, False
    f = 1.0 / (det * tr)
    x0, x1 = (c * r0 - b * r1) * f, (a * r1 - b * r0) * f
    if det < 1e-3:
        d0, d1 = r0 - (A * x0 + B * x1), r1 - (B * x0 + C * x1)
        x0, x1 = x0 + (c * d0 - b * d1) * f, x1 + (a * d1 - b * d0) * f
    return x0, x1, True


@_jit
def _inverse3(w00, w01, w02, w11, w12, w22):
    """(i00, i01, i02, i11, i12, i22, det W / tr^3, ok): the symmetric inverse of W, computed on
    W / tr(W) (no under- or overflow of det for any scale of W)."""
    tr = w00 + w11 + w22
    g = 1.0 / tr
    A, B1, B2 = w00 * g, w01 * g, w02 * g
    C11, C12, C22 = w11 * g, w12 * g, w22 * g
    k00 = C11 * C22 - C12 * C12
    k01 = B2 * C12 - B1 * C22
    k02 = B1 * C12 - B2 * C11
    det = A * k00 + B1 * k01 + B2 * k02
    if not det > SINGULAR_RTOL:
        return 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, det, False
    f = g / det
    return (k00 * f, k01 * f, k02 * f, (A * C22 - B2 * B2) * f, (B1 * B2 - A * C12) * f,
            (A * C11 - B1 * B1) * f, det, True)


@_jit
def _solve3(i00, i01, i02, i11, i12, i22, r0, r1, r2):
    return (i00 * r0 + i01 * r1 + i02 * r2, i01 * r0 + i11 * r1 + i12 * r2,
            i02 * r0 + i12 * r1 + i22 * r2)


@_jit
def _linsolve3(w00, w01, w02, w11, w12, w22, i00, i01, i02, i11, i12, i22, det, r0, r1, r2):
    x0, x1, x2 = _solve3(i00, i01, i02, i11, i12, i22, r0, r1, r2)
    if det >= 1e-3:
        return x0, x1, x2
    A, B1, B2, C11, C12, C22 = w00, w01, w02, w11, w12, w22
    d0, d1, d2 = _solve3(i00, i01, i02, i11, i12, i22, r0 - (A * x0 + B1 * x1 + B2 * x2),
                         r1 - (B1 * x0 + C11 * x1 + C12 * x2),
                         r2 - (B2 * x0 + C12 * x1 + C22 * x2))
    return x0 + d0, x1 + d1, x2 + d2


# --------------------------------------------------------------------------------------------
# boundary: polynomial roots


@_jit
def _quad(b, c):
    """(n, r1, r2): real roots of x^2 + b x + c (stable: no cancellation)."""
    disc = b * b - 4.0 * c
    if disc < 0.0:
        if disc >= -1e-9 * (b * b + abs(c)):
            return 1, -0.5 * b, 0.0
        return 0, 0.0, 0.0
    s = math.sqrt(disc)
    q = -0.5 * (b + math.copysign(s, b))
    if q == 0.0:
        return 1, 0.0, 0.0
    return 2, q, c / q


@_jit
def _cubic_polish(x, a, b, c):
    for _ in range(2):
        f = ((x + a) * x + b) * x + c
        df = (3.0 * x + 2.0 * a) * x + b
        if df == 0.0:
            break
        x -= f / df
    return x


@_jit
def _cubic(a, b, c):
    """(n, r1, r2, r3): real roots of x^3 + a x^2 + b x + c (trigonometric or Cardano, Newton-polished)."""
    p = b - a * a / 3.0
    q = 2.0 * a * a * a / 27.0 - a * b / 3.0 + c
    shift = -a / 3.0
    disc = (q * q) / 4.0 + (p * p * p) / 27.0
    if p < 0.0 and disc <= 0.0:
        m = 2.0 * math.sqrt(-p / 3.0)
        arg = 3.0 * q / (p * m)
        arg = arg if arg < 1.0 else 1.0  # min(1.0, arg)
        arg = arg if arg > -1.0 else -1.0  # max(-1.0, .)
        phi = math.acos(arg) / 3.0
        r1 = m * math.cos(phi - 0 * math.tau / 3.0) + shift
        r2 = m * math.cos(phi - 1 * math.tau / 3.0) + shift
        r3 = m * math.cos(phi - 2 * math.tau / 3.0) + shift
        return (3, _cubic_polish(r1, a, b, c), _cubic_polish(r2, a, b, c),
                _cubic_polish(r3, a, b, c))
    sd = math.sqrt(_pmax2(disc, 0.0))
    u = -0.5 * q + sd if q <= 0.0 else -0.5 * q - sd
    u = math.copysign(abs(u) ** (1.0 / 3.0), u)
    t = u - p / (3.0 * u) if u != 0.0 else 0.0
    return 1, _cubic_polish(t + shift, a, b, c), 0.0, 0.0


@_jit
def _quartic(c4, c3, c2, c1, c0):
    """(n, r0, r1, r2, r3): the real roots of the quartic, n = -1 if it is zero
    (Ferrari's closed form)."""
    scale = _pmax2(_pmax2(_pmax2(_pmax2(abs(c4), abs(c3)), abs(c2)), abs(c1)), abs(c0))
    if scale == 0.0:
        return -1, 0.0, 0.0, 0.0, 0.0
    eps = 1e-13 * scale
    if abs(c4) <= eps:
        if abs(c3) <= eps:
            if abs(c2) <= eps:
                if abs(c1) > eps:
                    return 1, -c0 / c1, 0.0, 0.0, 0.0
                return 0, 0.0, 0.0, 0.0, 0.0
            n, r1, r2 = _quad(c1 / c2, c0 / c2)
            return n, r1, r2, 0.0, 0.0
        n, r1, r2, r3 = _cubic(c2 / c3, c1 / c3, c0 / c3)
        return n, r1, r2, r3, 0.0
    f = 1.0 / c4
    a, b, c, d = c3 * f, c2 * f, c1 * f, c0 * f
    a2 = a * a
    p = b - 0.375 * a2
    q = c - 0.5 * a * b + 0.125 * a2 * a
    r = d - 0.25 * a * c + 0.0625 * a2 * b - 0.01171875 * a2 * a2
    shift = -0.25 * a
    ap, sr = abs(p), math.sqrt(math.sqrt(abs(r)))
    out = (0.0, 0.0, 0.0, 0.0)
    if abs(q) <= 1e-14 * (ap * math.sqrt(ap) + sr * sr * sr + abs(q)):  # biquadratic
        n = 0
        nz, z1, z2 = _quad(p, r)
        for j in range(nz):
            z = z1 if j == 0 else z2
            if z > 0.0:
                s = math.sqrt(z)
                out = _tset4(out, n, s + shift)
                out = _tset4(out, n + 1, shift - s)
                n += 2
            elif z >= -1e-9 * (abs(p) + math.sqrt(abs(r))):
                out = _tset4(out, n, shift)
                n += 1
        return n, out[0], out[1], out[2], out[3]
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
    dfm = (3.0 * m + 2.0 * ca) * m + cb
    if dfm != 0.0:
        m -= (((m + ca) * m + cb) * m + cc) / dfm
    if m <= 0.0:
        m = 1e-300
    s = math.sqrt(2.0 * m)
    h = q / (2.0 * s)
    k = 0.5 * p + m
    n = 0
    for j in range(2):
        if j == 0:
            bb, cq = -s, k + h
        else:
            bb, cq = s, k - h
        disc = bb * bb - 4.0 * cq
        if disc >= 0.0:
            qr = -0.5 * (bb + math.copysign(math.sqrt(disc), bb))
            if qr != 0.0:
                out = _tset4(out, n, qr + shift)
                out = _tset4(out, n + 1, cq / qr + shift)
                n += 2
            else:
                out = _tset4(out, n, shift)
                n += 1
        elif disc >= -1e-9 * (bb * bb + abs(cq)):
            out = _tset4(out, n, shift - 0.5 * bb)
            n += 1
    return n, out[0], out[1], out[2], out[3]


@_jit
def _eigen_quartic(c4, c3, c2, c1, c0):
    """(n, r0, r1, r2, r3): the real parts of the nearly real roots of the quartic, from the
    eigenvalues of its companion matrix (leading coefficients below 1e-13 of the largest
    dropped); n = -1 if the quartic is zero. The fallback of :func:`_quartic`."""
    scale = _pmax2(_pmax2(_pmax2(_pmax2(abs(c4), abs(c3)), abs(c2)), abs(c1)), abs(c0))
    if scale == 0.0:
        return -1, 0.0, 0.0, 0.0, 0.0
    c = np.array([c4, c3, c2, c1, c0])
    first = 0
    while abs(c[first]) <= 1e-13 * scale:
        first += 1
    deg = 4 - first
    out = (0.0, 0.0, 0.0, 0.0)
    if deg == 0:
        return 0, 0.0, 0.0, 0.0, 0.0
    comp = np.zeros((deg, deg), dtype=np.complex128)  # complex: numba keeps the domain
    for j in range(deg):
        comp[0, j] = -c[first + 1 + j] / c[first]
    for j in range(1, deg):
        comp[j, j - 1] = 1.0
    z = np.linalg.eigvals(comp)
    n = 0
    for j in range(deg):
        zr, zi = z[j].real, z[j].imag
        if abs(zi) <= 1e-6 * (1.0 + math.hypot(zr, zi)):
            out = _tset4(out, n, zr)
            n += 1
    return n, out[0], out[1], out[2], out[3]


@_jit
def _polish(c4, c3, c2, c1, c0, t):
    """Newton's method on the quartic from t, safeguarded: a step is taken only if it decreases
    |f|, and steps are clipped to 0.5."""
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


# --------------------------------------------------------------------------------------------
# boundary: directions on the cone's boundary


@_jit
def _candidates(e0, ex, ey, exx, eyy, exy, robust=False):
    """Unpolished points (x, y, chart value, reversed) where E(th) vanishes, as 5-tuples.

    E is first written in harmonics, a0 + a1 cos th + b1 sin th + a2 cos 2th + b2 sin 2th,
    and measured from a reference angle phi at which neither E(phi) nor E(phi + pi) nearly
    vanishes: those are the constant and leading coefficients of the quartic in
    tau = tan((th - phi)/2), so its roots stay bounded away from 0 and infinity and Ferrari's
    closed form stays accurate (phi = 0 unless min(|E(0)|, |E(pi)|) < 1e-2 max |c|). Each
    root is kept in the chart where it is small: tau itself for |tau| <= 1, s = 1/tau (the
    reversed quartic) otherwise; th = phi + pi is added when the leading coefficient is still
    small or no root was found. ``robust=True`` takes the roots from the companion matrix
    (:func:`_eigen_quartic`) instead of Ferrari and always adds th = phi + pi: the callers'
    fallback when a check fails. :func:`_refine` polishes a point.

    Returns (has_coeffs, c4, c3, c2, c1, c0, cp, sp, n, xs, ys, ts, revs); has_coeffs is False
    when E vanishes identically (every direction is then stationary and the single candidate
    th = 0 is exact).
    """
    z5 = (0.0, 0.0, 0.0, 0.0, 0.0)
    a0 = e0 + 0.5 * (exx + eyy)
    a1, b1, a2, b2 = ex, ey, 0.5 * (exx - eyy), 0.5 * exy
    cp, sp = 1.0, 0.0
    cp2, sp2 = 1.0, 0.0
    c4, c0 = a0 - a1 + a2, a0 + a1 + a2
    big = _pmax2(_pmax2(_pmax2(_pmax2(abs(a0), abs(a1)), abs(b1)), abs(a2)), abs(b2))
    if big == 0.0:
        return (False, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 1, _tset5(z5, 0, 1.0), z5, z5, z5)
    if abs(c0) < abs(c4):  # min(|c4|, |c0|)
        lo = abs(c0)
    else:
        lo = abs(c4)
    if lo < 1e-2 * big:
        best = lo
        for j in range(7):
            c, s, c2, s2 = _ROT_C[j], _ROT_S[j], _ROT_C2[j], _ROT_S2[j]
            r1, r2 = a1 * c + b1 * s, a2 * c2 + b2 * s2
            qa, qb = abs(a0 - r1 + r2), abs(a0 + r1 + r2)
            q = qb if qb < qa else qa
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
    if robust:
        nr, q0, q1, q2, q3 = _eigen_quartic(c4, c3, c2, c1, c0)
    else:
        nr, q0, q1, q2, q3 = _quartic(c4, c3, c2, c1, c0)
    if nr < 0:
        return (False, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 1, _tset5(z5, 0, 1.0), z5, z5, z5)
    xs, ys, ts, rs = z5, z5, z5, z5
    n = 0
    for j in range(nr):
        t = q0 if j == 0 else (q1 if j == 1 else (q2 if j == 2 else q3))
        if -1.0 <= t <= 1.0:
            t2 = t * t
            x, y = (1.0 - t2) / (1.0 + t2), 2.0 * t / (1.0 + t2)
            rev = 0.0
        else:
            t = 1.0 / t
            t2 = t * t
            x, y = (t2 - 1.0) / (t2 + 1.0), 2.0 * t / (t2 + 1.0)
            rev = 1.0
        xs = _tset5(xs, n, x * cp - y * sp)
        ys = _tset5(ys, n, x * sp + y * cp)
        ts = _tset5(ts, n, t)
        rs = _tset5(rs, n, rev)
        n += 1
    top = _pmax2(_pmax2(_pmax2(abs(c3), abs(c2)), abs(c1)), abs(c0))
    if robust or n == 0 or abs(c4) <= 1e-6 * top:
        xs = _tset5(xs, n, -cp)
        ys = _tset5(ys, n, -sp)
        ts = _tset5(ts, n, 0.0)
        rs = _tset5(rs, n, 1.0)
        n += 1
    return True, c4, c3, c2, c1, c0, cp, sp, n, xs, ys, ts, rs


@_jit
def _refine(has, c4, c3, c2, c1, c0, cp, sp, x, y, t, rev):
    """The Newton-polished (cos th, sin th) of a candidate of :func:`_candidates`."""
    if not has:
        return x, y
    if rev != 0.0:
        s = _polish(c0, c1, c2, c3, c4, t)
        s2 = s * s
        x, y = (s2 - 1.0) / (s2 + 1.0), 2.0 * s / (s2 + 1.0)
    else:
        t = _polish(c4, c3, c2, c1, c0, t)
        t2 = t * t
        x, y = (1.0 - t2) / (1.0 + t2), 2.0 * t / (1.0 + t2)
    return x * cp - y * sp, x * sp + y * cp


@_jit
def _newton_root(e0, ex, ey, exx, eyy, exy):
    """Root of E(th) by Newton's method from th = 0, on the quartic in tan(th/2): (x, y,
    converged) -- a fast path whose answer the callers certify."""
    c4 = e0 - ex + exx
    c3 = 2.0 * (ey - exy)
    c2 = 2.0 * (e0 - exx) + 4.0 * eyy
    c1 = 2.0 * (ey + exy)
    c0 = e0 + ex + exx
    t = _polish(c4, c3, c2, c1, c0, 0.0)
    t2 = t * t
    x, y = (1.0 - t2) / (1.0 + t2), 2.0 * t / (1.0 + t2)
    res = e0 + ex * x + ey * y + exx * x * x + eyy * y * y + exy * x * y
    scale = abs(e0) + abs(ex) + abs(ey) + abs(exx) + abs(eyy) + abs(exy)
    return x, y, abs(res) <= 1e-12 * scale


@_jit
def _rotate(w00, w01, w02, w11, w12, w22, v0, v1, v2, r1, r2):
    """W and v in the tangent basis (r, r_perp)."""
    A, B1, B2 = w00, w01, w02
    C11, C12, C22 = w11, w12, w22
    rr = r1 * r2
    return (A, B1 * r1 + B2 * r2, B2 * r1 - B1 * r2,
            C11 * r1 * r1 + 2.0 * C12 * rr + C22 * r2 * r2,
            (C22 - C11) * rr + C12 * (r1 * r1 - r2 * r2),
            C11 * r2 * r2 - 2.0 * C12 * rr + C22 * r1 * r1,
            v0, v1 * r1 + v2 * r2, v2 * r1 - v1 * r2)


@_jit
def _det_wq(u00, u0x, u0y, u10, u1x, u1y, u20, u2x, u2y, k0, k1, k2, mu):
    """E = sum_i U_i (k x q)_i with q = (-mu, x, y), U three affine forms in (x, y) and k a
    constant vector: (e0, ex, ey, exx, eyy, exy)."""
    mk1, mk2 = mu * k1, mu * k2
    return (-u10 * mk2 + u20 * mk1,
            -u00 * k2 - u1x * mk2 + u20 * k0 + u2x * mk1,
            u00 * k1 - u10 * k0 - u1y * mk2 + u2y * mk1,
            -u0x * k2 + u2x * k0,
            u0y * k1 - u1y * k0,
            u0x * k1 - u0y * k2 - u1x * k0 + u2y * k0)
