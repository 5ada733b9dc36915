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
    """The one-contact natural-map error ``|r - P_K(r - u - mu |u_t| e_n)|`` (absolute)."""
    d = q.shape[0]
    u = np.empty(d)
    for i in range(d):
        s = q[i]
        for j in range(d):
            s += A[i, j] * r[j]
        u[i] = s
    ut = 0.0
    for i in range(1, d):
        ut += u[i] * u[i]
    ut = math.sqrt(ut)
    v = np.empty(d)
    v[0] = r[0] - u[0] - mu * ut
    for i in range(1, d):
        v[i] = r[i] - u[i]
    t = 0.0
    for i in range(1, d):
        t += v[i] * v[i]
    t = math.sqrt(t)
    p = np.zeros(d)
    if t <= mu * v[0]:
        for i in range(d):
            p[i] = v[i]
    elif mu * t <= -v[0]:
        pass
    else:
        pn = (v[0] + mu * t) / (1.0 + mu * mu)
        p[0] = pn
        sc = mu * pn / t if t > 0.0 else 0.0
        for i in range(1, d):
            p[i] = v[i] * sc
    e = 0.0
    for i in range(d):
        e += (r[i] - p[i]) ** 2
    return math.sqrt(e)


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
    # stick needs A invertible (a singular diagonal block of W: no stick answer is tried)
    if d == 2:
        det = A[0, 0] * A[1, 1] - A[0, 1] * A[1, 0]
    else:
        det = (A[0, 0] * (A[1, 1] * A[2, 2] - A[1, 2] * A[2, 1])
               - A[0, 1] * (A[1, 0] * A[2, 2] - A[1, 2] * A[2, 0])
               + A[0, 2] * (A[1, 0] * A[2, 1] - A[1, 1] * A[2, 0]))
    big = 0.0
    for i in range(d):
        big = max(big, abs(A[i, i]))
    if abs(det) > 1e-13 * big ** d:
        x = np.linalg.solve(A, -q)
    else:
        x = np.full(d, -1.0)
    t = 0.0
    for i in range(1, d):
        t += x[i] * x[i]
    if x[0] >= 0.0 and math.sqrt(t) <= mu * x[0]:
        for i in range(d):
            r[i] = x[i]
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
            th = th - f * h / (f2 - f)
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
