"""Coulomb's law at one contact, solved exactly: ``u = A r + q`` with ``A`` (d, d) symmetric
positive definite, ``K_mu ∋ r ⊥ u + mu |u_t| e_n ∈ K_mu*`` (De Saxce's form; d = 2 or 3,
normal first).

The one-contact problem has three kinds of answers, tried in this order (the enumerative
local solver of Bertails-Descoubes et al. 2011, "A nonsmooth Newton solver for capturing
exact Coulomb friction in fiber assemblies", and of Siconos' and So-bogus' local solvers):

* **take-off**: ``r = 0``, valid when ``q_n >= 0`` (then ``u = q`` and ``u_n >= 0``);
* **stick**: ``r = -A^-1 q``, valid when it lies in ``K_mu`` (then ``u = 0``; not tried where
  ``A`` is singular);
* **slide**: ``r = r_n (1, -mu t)`` with ``t`` the unit slip direction, ``u_n = 0`` and
  ``u_t = lambda t``, ``lambda > 0``. For a direction ``t(theta) = (cos theta, sin theta)``
  (``t = ±1`` in the plane) ``u_n = 0`` fixes ``r_n = -q_n / (A g)_n`` with
  ``g = (1, -mu t)``, and the slip condition is the scalar equation
  ``f(theta) = u_t x t = 0`` with ``u_t . t > 0`` and ``r_n > 0``. Its roots are bracketed on
  a grid of :data:`SCAN` angles and refined by bisection to round-off (after a Newton try
  from the previous slip direction, which the Gauss-Seidel sweeps of
  :mod:`.gauss_seidel` supply).

A frictionless contact (``mu = 0``) keeps its normal only: ``r = (max(0, -q_n / A_nn), 0)``.
Every returned answer satisfies the law to round-off; the tests check each kind against the
natural-map residual and against a brute-force search.
"""

from __future__ import annotations

import math

import numpy as np

from ..compiled import jit as _jit

#: angles of the slip-direction scan (the roots of f are bracketed between neighbours)
SCAN = 48
#: bisection steps refining a bracketed root (the bracket shrinks to 2 pi / SCAN / 2^60)
BISECTIONS = 60


@_jit
def _slide_at(A, q, mu, c, s, out):
    """The slide candidate for the slip direction (c, s): fills ``out`` (r) and returns
    ``(f, valid, forward)`` with f = u_t x t (d = 3; ``s`` unused and f = 0 for d = 2),
    ``valid`` when r_n > 0, ``forward`` when also u_t . t > 0."""
    d = q.shape[0]
    g0 = 1.0
    g1 = -mu * c
    g2 = -mu * s if d == 3 else 0.0
    an = A[0, 0] * g0 + A[0, 1] * g1 + (A[0, 2] * g2 if d == 3 else 0.0)
    if an <= 0.0:
        return 0.0, False, False
    rn = -q[0] / an
    if not rn > 0.0:
        return 0.0, False, False
    out[0] = rn
    out[1] = rn * g1
    if d == 3:
        out[2] = rn * g2
    u1 = q[1] + A[1, 0] * out[0] + A[1, 1] * out[1] + (A[1, 2] * out[2] if d == 3 else 0.0)
    if d == 2:
        return 0.0, True, u1 * c > 0.0
    u2 = q[2] + A[2, 0] * out[0] + A[2, 1] * out[1] + A[2, 2] * out[2]
    return u1 * s - u2 * c, True, u1 * c + u2 * s >= 0.0


@_jit
def local_residual(A, q, mu, r):
    """The one-contact natural-map error ``|r - P_K(r - u - mu |u_t| e_n)|`` (absolute),
    in scalars (d = 2 or 3: no array allocated)."""
    d = q.shape[0]
    u0 = q[0]
    u1 = q[1]
    u2 = q[2] if d == 3 else 0.0
    for j in range(d):
        u0 += A[0, j] * r[j]
        u1 += A[1, j] * r[j]
        if d == 3:
            u2 += A[2, j] * r[j]
    r2 = r[2] if d == 3 else 0.0
    v0 = r[0] - u0 - mu * math.sqrt(u1 * u1 + u2 * u2)
    v1 = r[1] - u1
    v2 = r2 - u2
    t = math.sqrt(v1 * v1 + v2 * v2)
    if t <= mu * v0:
        p0, p1, p2 = v0, v1, v2
    elif mu * t <= -v0:
        p0, p1, p2 = 0.0, 0.0, 0.0
    else:
        p0 = (v0 + mu * t) / (1.0 + mu * mu)
        sc = mu * p0 / t if t > 0.0 else 0.0
        p1, p2 = v1 * sc, v2 * sc
    return math.sqrt((r[0] - p0) ** 2 + (r[1] - p1) ** 2 + (r2 - p2) ** 2)


@_jit
def solve_local(A, q, mu, r, hint):
    """Solve the one-contact Coulomb problem into ``r`` (d,). ``hint`` (1,) holds the slip
    angle (d = 3) of the previous slide, or NaN; it is updated on a slide. Returns the kind
    of answer: 0 take-off, 1 stick, 2 slide, -1 none found (``r`` left unchanged)."""
    d = q.shape[0]
    if q[0] >= 0.0:
        for i in range(d):
            r[i] = 0.0
        return 0
    if mu <= 0.0:
        r[0] = -q[0] / A[0, 0]
        for i in range(1, d):
            r[i] = 0.0
        return 1
    # stick needs A invertible (a singular diagonal block of W: no stick answer is tried);
    # x = -A^-1 q by the adjugate (Cramer's rule: no LAPACK call and no array allocated, the
    # sweeps' cost was 70% local solves, most of it there)
    big = 0.0
    for i in range(d):
        big = max(big, abs(A[i, i]))
    x0 = -1.0
    x1 = 0.0
    x2 = 0.0
    if d == 2:
        det = A[0, 0] * A[1, 1] - A[0, 1] * A[1, 0]
        if abs(det) > 1e-13 * big ** d:
            x0 = -(A[1, 1] * q[0] - A[0, 1] * q[1]) / det
            x1 = -(A[0, 0] * q[1] - A[1, 0] * q[0]) / det
    else:
        c00 = A[1, 1] * A[2, 2] - A[1, 2] * A[2, 1]
        c01 = A[0, 2] * A[2, 1] - A[0, 1] * A[2, 2]
        c02 = A[0, 1] * A[1, 2] - A[0, 2] * A[1, 1]
        det = A[0, 0] * c00 + A[1, 0] * c01 + A[2, 0] * c02
        if abs(det) > 1e-13 * big ** d:
            c10 = A[1, 2] * A[2, 0] - A[1, 0] * A[2, 2]
            c11 = A[0, 0] * A[2, 2] - A[0, 2] * A[2, 0]
            c12 = A[0, 2] * A[1, 0] - A[0, 0] * A[1, 2]
            c20 = A[1, 0] * A[2, 1] - A[1, 1] * A[2, 0]
            c21 = A[0, 1] * A[2, 0] - A[0, 0] * A[2, 1]
            c22 = A[0, 0] * A[1, 1] - A[0, 1] * A[1, 0]
            x0 = -(c00 * q[0] + c01 * q[1] + c02 * q[2]) / det
            x1 = -(c10 * q[0] + c11 * q[1] + c12 * q[2]) / det
            x2 = -(c20 * q[0] + c21 * q[1] + c22 * q[2]) / det
    if x0 >= 0.0 and math.sqrt(x1 * x1 + x2 * x2) <= mu * x0:
        r[0] = x0
        r[1] = x1
        if d == 3:
            r[2] = x2
        return 1
    cand = np.empty(d)
    if d == 2:
        for c in (1.0, -1.0):
            f, ok, fwd = _slide_at(A, q, mu, c, 0.0, cand)
            if fwd:
                r[0] = cand[0]
                r[1] = cand[1]
                return 2
        return -1
    # d = 3: Newton on f(theta) from the hint, then the scan
    th = hint[0]
    if not math.isnan(th):
        for _ in range(8):
            f, ok, fwd = _slide_at(A, q, mu, math.cos(th), math.sin(th), cand)
            if not ok:
                break
            h = 1e-7
            f2, ok2, fwd2 = _slide_at(A, q, mu, math.cos(th + h), math.sin(th + h), cand)
            if not ok2 or f2 == f:
                break
            step = f * h / (f2 - f)
            th = th - step
            if abs(step) <= 1e-15:  # converged (it ran all 8 before: 2x the slides' cost)
                break
        f, ok, fwd = _slide_at(A, q, mu, math.cos(th), math.sin(th), cand)
        if fwd and local_residual(A, q, mu, cand) <= 1e-14 * (abs(q[0]) + abs(q[1]) + abs(q[2])):
            for i in range(3):
                r[i] = cand[i]
            hint[0] = math.atan2(math.sin(th), math.cos(th))
            return 2
    best = np.inf
    bth = 0.0
    found = False
    step = 2.0 * math.pi / SCAN
    a = -math.pi
    fa, oka, fwa = _slide_at(A, q, mu, math.cos(a), math.sin(a), cand)
    for k in range(1, SCAN + 1):
        bb = -math.pi + k * step
        fb, okb, fwb = _slide_at(A, q, mu, math.cos(bb), math.sin(bb), cand)
        if oka and okb and (fa == 0.0 or fa * fb < 0.0):
            lo, hi, flo = a, bb, fa
            for _ in range(BISECTIONS):
                mid = 0.5 * (lo + hi)
                fm, okm, fwm = _slide_at(A, q, mu, math.cos(mid), math.sin(mid), cand)
                if not okm:
                    break
                if fm == 0.0:
                    lo = hi = mid
                    break
                if (fm < 0.0) == (flo < 0.0):
                    lo, flo = mid, fm
                else:
                    hi = mid
            mid = 0.5 * (lo + hi)
            fm, okm, fwm = _slide_at(A, q, mu, math.cos(mid), math.sin(mid), cand)
            if okm:
                e = local_residual(A, q, mu, cand)
                if e < best:
                    best, bth, found = e, mid, True
        a, fa, oka = bb, fb, okb
    if not found:
        return -1
    _slide_at(A, q, mu, math.cos(bth), math.sin(bth), cand)
    for i in range(3):
        r[i] = cand[i]
    hint[0] = bth
    return 2
