"""Exact single-contact impact solvers for every law (``method="fast"``).

One contact's impact reduces to its Delassus block ``W`` (d x d, d = 2 planar or 3 spatial;
closed loops are already folded in by :mod:`convimpact.impact.problem`) and its pre-impact velocity
``v = (v_n, v_t...)``. Every law is then a small problem over the friction cone
``K_mu = {|pi_t| <= mu pi_n}`` with an interior (stick / unconstrained) branch that is a linear
solve and a boundary (slide) branch ``pi = pi_n (1, mu t)``, ``t = (cos th, sin th)``.

On the boundary every law's defining condition is a determinant of three columns that are
affine in ``z = (1, cos th, sin th)``, hence a trigonometric polynomial of degree 2, i.e. a
quartic in ``tau = tan(th / 2)``:

* maximal dissipation (the seed's spatial law, eq. 60, and the boundary optimum of P_N):
  ``det[W pi + v, a, q] = 0`` with ``a = W e_n`` (normal row, the restitution constraint of
  eq. 38) and ``q = (-mu, t)`` (the cone's normal), ``pi_n = c / (a . p)``;
* Coulomb with Newton restitution (friction opposing the post-impact slip):
  ``b + pi_n W p = (0, -sigma t)`` so ``det[W p, (0, t), b] = 0``;
* CCP (Anitescu): ``W pi + b = s (mu, -t)`` so ``det[W p, b, q] = 0``,

with ``p = (1, mu t)``, ``c = -(1 + e) v_n`` and ``b = v + e v_n e_n``. The quartic is solved
in closed form (Ferrari); the roots are compared on the law's objective and conditions, and
the winner is polished by Newton's method on the quartic in tan(th/2) or, for |tau| > 1, on
the reversed quartic in cot(th/2) (no loss at ``tau -> infinity``; the angle opposite to the
reference direction is tried whenever the leading coefficient nearly vanishes; the quartic is
measured from a reference angle where neither end coefficient vanishes). The root that
satisfies all of the law's conditions (and is best for its objective) is kept.

For the two convex programs (P_N behind the seed's spatial law, and CCP) Newton's method from
the reference direction is tried first and accepted only when the program's KKT conditions
certify it (convexity makes that certificate global); otherwise the quartic's roots are
enumerated. Coulomb's law is not a convex program and may have several sliding solutions: its
Newton root (from the stick impulse's tangent) is completed by the roots of the deflated
cubic, so every solution is still found and counted. Every boundary answer is certified (P_N's KKT sign or probe directions, CCP's KKT
sign, Coulomb's conditions); a failed certificate retries with numpy's companion-matrix roots
and then raises SolverError, never returning a wrong root silently.

The interior branches solve W x = r by the adjugate with one step of iterative refinement.
Every kernel works on plain Python floats (numpy's per-call overhead would dominate): a spatial
solve takes some 10-20 microseconds, a planar one a few.

Degenerate cases are explicit: mu = 0 is the frictionless impulse of eq. (38); v_t- = 0
needs no special branch (the reference direction falls back to the stick impulse's tangent,
then to t1); a (numerically) singular W raises SingularSystemError naming the conic paths;
a law whose every sliding root has a non-positive denominator raises
NonPositiveEffectiveMassError (Newton laws) -- never a NaN.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any, Mapping, Sequence

import numpy as np

from .diagnostics import assemble_result
from .errors import (
    NonFiniteError,
    NonPositiveEffectiveMassError,
    NotSupportedError,
    ParameterError,
    ShapeError,
    SingularSystemError,
    SolverError,
    UnknownOptionError,
)
from .resolve import register_solver
from .problem import ImpactProblem
from .results import ImpactResult

#: laws treated by :func:`solve_contact`
FAST_LAWS = ("pereira-nikravesh", "coulomb", "ccp", "dissipative")
#: relative determinant below which W is treated as singular: det W <= tol * trace(W)^d
#: (in the plane det/trace^2 ~ 1/cond(W), matching the closed form's cond(W) >= 1e12)
SINGULAR_RTOL = 1e-12
#: relative tolerance of the cone / sign tests (round-off allowance)
CONE_RTOL = 1e-12
#: relative tolerance on a boundary root's residual for it to count as a solution
ROOT_RTOL = 1e-8
#: accuracy stated for the fast path (passed to assemble_result)
FAST_TOL = 1e-10

_TWO_PI = 2.0 * math.pi


@dataclass(frozen=True, slots=True)
class ContactSolution:
    """Impulse of one contact under one law, as found by :func:`solve_contact`.

    Attributes
    ----------
    impulse : (d,) contact-frame impulse, normal first (pi_n, pi_t) or (pi_n, pi_t1, pi_t2).
    regime : "separating", "frictionless", "stick" or "slide".
    effective_mass : the sliding denominator c_n^T G (c_n + mu c_t) of eq. (38)/(51) when the
        law slid with Newton's restitution, else None.
    extras : law-specific figures (sliding angle, energy loss, CCP lift, solution counts).
    warnings : statements about the solve (e.g. P_N's interior optimum disagreeing).
    """

    impulse: np.ndarray
    regime: str
    effective_mass: float | None = None
    extras: Mapping[str, Any] = field(default_factory=lambda: MappingProxyType({}))
    warnings: tuple[str, ...] = ()


# --------------------------------------------------------------------------------------------
# polynomial roots (pure Python floats)


def _quadratic_roots(b: float, c: float) -> list[float]:
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


def _cubic_roots(a: float, b: float, c: float) -> list[float]:
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
        roots = [m * math.cos(phi - k * _TWO_PI / 3.0) + shift for k in range(3)]
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


def _quartic_roots(c4: float, c3: float, c2: float, c1: float, c0: float) -> list[float] | None:
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
            return _quadratic_roots(c1 / c2, c0 / c2)
        return _cubic_roots(c2 / c3, c1 / c3, c0 / c3)
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
        for z in _quadratic_roots(p, r):
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
# the boundary quartic: a trigonometric quadratic E(th) = e0 + ex x + ey y + exx x^2 + eyy y^2
# + exy x y in x = cos th, y = sin th, solved through tau = tan(th / 2)


def _polish(c4: float, c3: float, c2: float, c1: float, c0: float, t: float) -> float:
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


def _candidates(e0: float, ex: float, ey: float, exx: float, eyy: float,
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
    points, (x, y) = (cos th, sin th) in the caller's basis; :func:`_refine` polishes one.
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
    roots = _quartic_roots(c4, c3, c2, c1, c0) if not robust else _eigen_roots(
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


def _eigen_roots(c4: float, c3: float, c2: float, c1: float, c0: float) -> list[float] | None:
    """Real parts of the nearly real roots of the quartic, from numpy's companion matrix."""
    c = np.array([c4, c3, c2, c1, c0])
    scale = float(np.max(np.abs(c)))
    if scale == 0.0:
        return None
    nz = np.flatnonzero(np.abs(c) > 1e-13 * scale)
    z = np.roots(c[nz[0]:])
    return [float(r.real) for r in z if abs(r.imag) <= 1e-6 * (1.0 + abs(r))]


def _refine(coeffs: tuple | None, point: tuple) -> tuple[float, float]:
    """Newton-polished (x, y) = (cos th, sin th) of a candidate of :func:`_candidates`."""
    x, y, t, rev = point
    if coeffs is None:
        return x, y
    c4, c3, c2, c1, c0, cp, sp = coeffs
    if rev:
        s = _polish(c0, c1, c2, c3, c4, t)
        s2 = s * s
        x, y = (s2 - 1.0) / (s2 + 1.0), 2.0 * s / (s2 + 1.0)
    else:
        t = _polish(c4, c3, c2, c1, c0, t)
        t2 = t * t
        x, y = (1.0 - t2) / (1.0 + t2), 2.0 * t / (1.0 + t2)
    return x * cp - y * sp, x * sp + y * cp


def _det_wq(u: tuple, k0: float, k1: float, k2: float, mu: float) -> tuple:
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


def _rotate(w: list, v: list, r1: float, r2: float) -> tuple:
    """(A, B1, B2, C11, C12, C22, v0, v1, v2): W and v in the tangent basis (r, r_perp)."""
    A, B1, B2 = w[0]
    C11, C12, C22 = w[1][1], w[1][2], w[2][2]
    rr = r1 * r2
    return (A, B1 * r1 + B2 * r2, B2 * r1 - B1 * r2,
            C11 * r1 * r1 + 2.0 * C12 * rr + C22 * r2 * r2,
            (C22 - C11) * rr + C12 * (r1 * r1 - r2 * r2),
            C11 * r2 * r2 - 2.0 * C12 * rr + C22 * r1 * r1,
            v[0], v[1] * r1 + v[2] * r2, v[2] * r1 - v[1] * r2)


def _wp(R: tuple, mu: float) -> tuple:
    """W p, p = (1, mu x, mu y), as three affine forms (9 floats) in the rotated basis."""
    A, B1, B2, C11, C12, C22 = R[:6]
    return (A, mu * B1, mu * B2, B1, mu * C11, mu * C12, B2, mu * C12, mu * C22)


def _dissipation_equation(R: tuple, c: float, mu: float) -> tuple:
    """Stationarity of T_L on the boundary as a trigonometric quadratic E(th).

    c det[W p, a, q] + (a.p) det[v, a, q] = det[c W p + (a.p) v, a, q] = 0 with a = W e_n and
    a.p = A + mu (B1 x + B2 y), the denominator D of eq. (38); ``R`` from :func:`_rotate`.
    """
    A, B1, B2, C11, C12, C22, v0, v1, v2 = R
    mB1, mB2 = mu * B1, mu * B2
    cv, cm = c + v0, c * mu
    U = (cv * A, cv * mB1, cv * mB2,
         c * B1 + v1 * A, cm * C11 + v1 * mB1, cm * C12 + v1 * mB2,
         c * B2 + v2 * A, cm * C12 + v2 * mB1, cm * C22 + v2 * mB2)
    return _det_wq(U, A, B1, B2, mu)


def _newton_root(E: tuple) -> tuple[float, float, bool]:
    """Root of E(th) by Newton's method from th = 0, on the quartic in tan(th/2).

    Returns (x, y, converged): a fast path whose answer the callers certify (KKT of a convex
    program), falling back to :func:`_candidates` when it is not certified.
    """
    e0, ex, ey, exx, eyy, exy = E
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


def _dissipation_angle(R: tuple, c: float, mu: float, robust: bool = False,
                       E: tuple | None = None) -> tuple[float, float, float, float, float]:
    """Direction maximizing T_L (eq. 60) on the cone boundary with D > 0, over every root of
    :func:`_dissipation_equation`. Returns (x, y, T_L, pi_n, D) in R's basis."""
    A, B1, B2, C11, C12, C22, v0, v1, v2 = R
    coeffs, cands = _candidates(*(E or _dissipation_equation(R, c, mu)), robust=robust)
    dmin = 1e-12 * (A + mu * math.hypot(B1, B2))
    scored = []
    top = None
    for pt in cands:
        x, y = pt[0], pt[1]
        D = A + mu * (B1 * x + B2 * y)
        if not D > dmin:
            continue
        pWp = D + mu * (x * (B1 + mu * (C11 * x + C12 * y)) + y * (B2 + mu * (C12 * x + C22 * y)))
        pn = c / D
        tl = -pn * (v0 + mu * (v1 * x + v2 * y)) - 0.5 * pn * pn * pWp  # eq. (60)
        scored.append((tl, pt))
        if top is None or tl > top:
            top = tl
    if top is None:  # unreachable for W_nn > 0: D averages W_nn over the circle
        raise SolverError("no admissible sliding direction found (every D <= 0)")
    # the roots are stationary, so their unpolished scores are accurate to second order:
    # polish the winner and any runner-up within 1e-6
    cut = top - 1e-6 * (abs(top) + 1e-300)
    best = None
    for tl0, pt in scored:
        if tl0 < cut:
            continue
        x, y = _refine(coeffs, pt)
        D = A + mu * (B1 * x + B2 * y)
        if D > dmin:
            pWp = D + mu * (x * (B1 + mu * (C11 * x + C12 * y))
                            + y * (B2 + mu * (C12 * x + C22 * y)))
            pn = c / D
            tl = -pn * (v0 + mu * (v1 * x + v2 * y)) - 0.5 * pn * pn * pWp
        else:  # polishing left the admissible set: keep the raw candidate
            x, y, tl = pt[0], pt[1], tl0
            D = A + mu * (B1 * x + B2 * y)
        if best is None or tl > best[2]:
            best = (x, y, tl, c / D, D)
    return best


def _unit_or(x1: float, x2: float, fallback: tuple[float, float]) -> tuple[float, float]:
    n = math.hypot(x1, x2)
    if n > 0.0:
        return x1 / n, x2 / n
    return fallback


def _as_lists(W, v) -> tuple[list, list, int]:
    if type(W) is np.ndarray and type(v) is np.ndarray:
        d = v.shape[0] if v.ndim == 1 else 0
        if d in (2, 3) and W.shape == (d, d):
            return W.tolist(), v.tolist(), d
    else:
        try:
            w = [[float(x) for x in row] for row in W]
            vv = [float(x) for x in v]
        except (TypeError, ValueError):
            w, vv = [], []
        d = len(vv)
        if d in (2, 3) and len(w) == d and all(len(r) == d for r in w):
            return w, vv, d
    raise ShapeError(
        f"a single contact needs W of shape (d, d) and v of length d with d = 2 (n, t) or "
        f"3 (n, t1, t2); got W {np.shape(W)} and v {np.shape(v)}")


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
    SingularSystemError if W_nn <= 0; ShapeError for bad shapes.
    """
    w, vv, d = _as_lists(W, v)
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
    try:
        inv = _inverse3(w, "pereira-nikravesh")
    except SingularSystemError:
        inv = None
    t1, t2 = _max_dissipation3(w, vv, c, mu, inv, (1.0, 0.0))[:2]
    return np.array((t1, t2))


# --------------------------------------------------------------------------------------------
# linear solves (interior branches)


def _singular(law: str, det: float) -> SingularSystemError:
    return SingularSystemError(
        f"the Delassus matrix W = Jc M^-1 Jc^T of this contact is singular (det W = {det:.3e}): "
        "its normal and tangential motions are dependent here, so the exact fast solve of law "
        f"{law!r} (which inverts W on its interior branch) has no unique answer; use "
        "method='clarabel' or method='cvxpy' (law='dissipative' or 'ccp' accept a singular W)")


def _inverse3(w: list, law: str) -> tuple:
    """Symmetric inverse of the 3 x 3 W as (i00, i01, i02, i11, i12, i22, det W / tr(W)^3)."""
    tr = w[0][0] + w[1][1] + w[2][2]
    g = 1.0 / tr  # work on W / tr(W): no under- or overflow of det for any scale of W
    A, B1, B2 = w[0][0] * g, w[0][1] * g, w[0][2] * g
    C11, C12, C22 = w[1][1] * g, w[1][2] * g, w[2][2] * g
    k00 = C11 * C22 - C12 * C12
    k01 = B2 * C12 - B1 * C22
    k02 = B1 * C12 - B2 * C11
    det = A * k00 + B1 * k01 + B2 * k02  # det W / tr(W)^3
    if not det > SINGULAR_RTOL:
        raise _singular(law, det * tr * tr * tr)
    f = g / det  # inv(W) = inv(W / tr) / tr
    return (k00 * f, k01 * f, k02 * f, (A * C22 - B2 * B2) * f, (B1 * B2 - A * C12) * f,
            (A * C11 - B1 * B1) * f, det)


def _solve3(inv: tuple, r0: float, r1: float, r2: float) -> tuple[float, float, float]:
    i00, i01, i02, i11, i12, i22 = inv[:6]
    return (i00 * r0 + i01 * r1 + i02 * r2, i01 * r0 + i11 * r1 + i12 * r2,
            i02 * r0 + i12 * r1 + i22 * r2)


def _linsolve3(w: list, inv: tuple, r0: float, r1: float, r2: float) -> tuple[float, float, float]:
    """W x = r by the adjugate inverse, plus one step of iterative refinement when W is
    ill-conditioned (det W / tr(W)^3 < 1e-3)."""
    x0, x1, x2 = _solve3(inv, r0, r1, r2)
    if inv[6] >= 1e-3:
        return x0, x1, x2
    (A, B1, B2), (_, C11, C12), (_, _, C22) = w
    d0, d1, d2 = _solve3(inv, r0 - (A * x0 + B1 * x1 + B2 * x2),
                         r1 - (B1 * x0 + C11 * x1 + C12 * x2),
                         r2 - (B2 * x0 + C12 * x1 + C22 * x2))
    return x0 + d0, x1 + d1, x2 + d2


def _stick2(w: list, r0: float, r1: float, law: str) -> tuple[float, float]:
    """Solve the 2 x 2 W x = r (adjugate; one refinement step when ill-conditioned)."""
    A, B, C = w[0][0], w[0][1], w[1][1]
    tr = A + C
    a, b, c = A / tr, B / tr, C / tr  # W / tr(W): scale-free determinant test
    det = a * c - b * b  # det W / tr(W)^2
    if not det > SINGULAR_RTOL:
        raise _singular(law, det * tr * tr)
    f = 1.0 / (det * tr)  # 1 / det W, as (1 / det(W / tr)) / tr^2 times tr
    x0, x1 = (c * r0 - b * r1) * f, (a * r1 - b * r0) * f
    if det < 1e-3:
        d0, d1 = r0 - (A * x0 + B * x1), r1 - (B * x0 + C * x1)
        x0, x1 = x0 + (c * d0 - b * d1) * f, x1 + (a * d1 - b * d0) * f
    return x0, x1


def _in_cone(pn: float, ptn: float, mu: float) -> bool:
    """|pi_t| <= mu pi_n (eq. 53), with the closed form's round-off allowance."""
    return pn >= 0.0 and ptn <= mu * pn * (1.0 + CONE_RTOL)


def _jam(mu: float, D: float, law: str) -> NonPositiveEffectiveMassError:
    return NonPositiveEffectiveMassError(
        f"sliding denominator c_n^T M^-1 (c_n + mu c_t) = {D:.3e} <= 0 at mu = {mu:g} for every "
        f"sliding solution of law {law!r} (Painleve-like jam: eq. (38) would divide by it); use "
        "law='ccp' or 'dissipative', which stay well posed, or lower mu")


def _sol(impulse: Sequence[float], regime: str, effective_mass: float | None = None,
         extras: dict | None = None, warnings: tuple[str, ...] = ()) -> ContactSolution:
    return ContactSolution(np.array(impulse), regime, effective_mass,
                           MappingProxyType(extras or {}), warnings)


#: extras of a ContactSolution that are impulses or energies (they scale like pi)
_IMPULSE_EXTRAS = ("plastic_impulse", "normal_impulse", "energy_loss_max")


def _rescaled(sol: ContactSolution, g: float) -> ContactSolution:
    """A solution computed with W / tr(W), brought back to W (``g = 1 / tr``): impulses,
    impulse-like extras and energies times ``g``, the sliding denominator over ``g``."""
    extras = dict(sol.extras)
    for key in _IMPULSE_EXTRAS:
        if key in extras and extras[key] is not None:
            extras[key] = (tuple(g * x for x in extras[key]) if isinstance(extras[key], tuple)
                           else g * extras[key])
    mass = None if sol.effective_mass is None else sol.effective_mass / g
    return ContactSolution(sol.impulse * g, sol.regime, mass, MappingProxyType(extras),
                           sol.warnings)


def _angle_from_slip(v1: float, v2: float, t1: float, t2: float) -> float:
    """Angle in [0, 2 pi) of t measured counter-clockwise from v_t- (from t1 if v_t- = 0)."""
    if v1 == 0.0 and v2 == 0.0:
        a = math.atan2(t2, t1)
    else:
        a = math.atan2(v1 * t2 - v2 * t1, v1 * t1 + v2 * t2)
    return a % _TWO_PI


# --------------------------------------------------------------------------------------------
# the seed's law (Section 8): stick test, else slide with maximal dissipation


def _max_dissipation_verified(w: list, v: list, c: float, mu: float, p: float, t1: float,
                              t2: float, tl: float, interior: bool) -> bool:
    """Cheap certificate that the boundary direction t maximizes T_L (guards the quartic).

    When P_N's optimum lies on the boundary it is this point, so y = W pi + v - lam W e_n with
    lam = pi.(W pi + v) / c must be sigma (mu, -t) with sigma >= 0 (KKT of P_N). When it is
    interior, or that test fails to round-off, T_L(t) must beat eight probe directions.
    """
    if not interior and _pn_kkt(w, v, c, mu, p, t1, t2):
        return True
    # interior, or no KKT certificate (e.g. mu so small that T_L is flat in t to round-off)
    (A, B1, B2), (_, C11, C12), (_, _, C22) = w
    for k in range(8):
        x, y = _PROBES[k]
        D = A + mu * (B1 * x + B2 * y)
        if D > 0.0:
            pn = c / D
            pWp = D + mu * (x * (B1 + mu * (C11 * x + C12 * y)) + y * (B2 + mu * (C12 * x
                                                                                 + C22 * y)))
            if -pn * (v[0] + mu * (v[1] * x + v[2] * y)) - 0.5 * pn * pn * pWp > (
                    tl + 1e-9 * (abs(tl) + c * c / A)):
                return False
    return True


def _pn_kkt(w: list, v: list, c: float, mu: float, p: float, t1: float, t2: float) -> bool:
    """KKT of P_N at pi = p (1, mu t): y = W pi + v - lam W e_n = sigma (mu, -t), sigma >= 0,
    with lam = pi.(W pi + v) / c (so that y is orthogonal to pi)."""
    (A, B1, B2), (_, C11, C12), (_, _, C22) = w
    a1, a2 = mu * p * t1, mu * p * t2
    g0 = A * p + B1 * a1 + B2 * a2 + v[0]
    g1 = B1 * p + C11 * a1 + C12 * a2 + v[1]
    g2 = B2 * p + C12 * a1 + C22 * a2 + v[2]
    lam = (p * g0 + a1 * g1 + a2 * g2) / c
    y0, y1, y2 = g0 - lam * A, g1 - lam * B1, g2 - lam * B2
    sigma = -(y1 * t1 + y2 * t2)
    tol = 1e-6 * (c + abs(v[0]) + abs(v[1]) + abs(v[2])
                  + max(A, C11, C22) * (p + abs(a1) + abs(a2)) + abs(lam) * A)
    return sigma >= -tol and abs(y1 * t2 - y2 * t1) <= tol and abs(
        y0 - mu * sigma) <= tol * (1.0 + mu)


_PROBES = tuple((math.cos(k * math.pi / 4), math.sin(k * math.pi / 4)) for k in range(8))


def _max_dissipation3(w: list, v: list, c: float, mu: float, inv: tuple | None,
                      fallback: tuple[float, float]) -> tuple:
    """The seed's spatial slide: (t1, t2, T_L, pi_n, D, P_N interior?) maximizing eq. (60).

    Reference direction -v_t- (else ``fallback``, else t1). When P_N's optimum lies on the
    boundary (``inv`` = W^-1 tells), Newton's method from the reference direction is tried
    first and certified by P_N's KKT conditions (P_N is convex); otherwise, or if that fails,
    every root of the boundary quartic is compared, the answer is certified (KKT or probe
    directions), then retried with companion-matrix roots, then SolverError.
    """
    r1, r2 = _unit_or(-v[1], -v[2], _unit_or(fallback[0], fallback[1], (1.0, 0.0)))
    if inv is not None:
        # P_N's optimum over the plane a.pi = c: pi* = lam e_n - W^-1 v, lam = (c + v_n) / W_nn
        q0, q1, q2 = _solve3(inv, v[0], v[1], v[2])
        lam = (c + v[0]) / w[0][0]
        interior = _in_cone(lam - q0, math.hypot(q1, q2), mu)
    else:
        interior = True  # unknown: no KKT shortcut, the probes certify
    R = _rotate(w, v, r1, r2)
    E = _dissipation_equation(R, c, mu)
    if not interior:
        # fast path: Newton from -v_t; P_N is convex, so its KKT conditions certify the root
        x, y, converged = _newton_root(E)
        A, B1, B2, C11, C12, C22, v0, v1, v2 = R
        D = A + mu * (B1 * x + B2 * y)
        if converged and D > 1e-12 * (A + mu * math.hypot(B1, B2)):
            p = c / D
            t1, t2 = x * r1 - y * r2, x * r2 + y * r1
            if _pn_kkt(w, v, c, mu, p, t1, t2):
                pWp = D + mu * (x * (B1 + mu * (C11 * x + C12 * y))
                                + y * (B2 + mu * (C12 * x + C22 * y)))
                tl = -p * (v0 + mu * (v1 * x + v2 * y)) - 0.5 * p * p * pWp  # eq. (60)
                return t1, t2, tl, p, D, interior
    x, y, tl, p, D = _dissipation_angle(R, c, mu, E=E)
    t1, t2 = x * r1 - y * r2, x * r2 + y * r1
    if not _max_dissipation_verified(w, v, c, mu, p, t1, t2, tl, interior):
        x, y, tl, p, D = _dissipation_angle(R, c, mu, robust=True)  # companion-matrix roots
        t1, t2 = x * r1 - y * r2, x * r2 + y * r1
        if not _max_dissipation_verified(w, v, c, mu, p, t1, t2, tl, interior):
            raise SolverError("the maximal-dissipation direction could not be certified (KKT "
                              "of P_N or probe directions); use method='sweep' or 'clarabel'")
    return t1, t2, tl, p, D, interior


def _pereira_nikravesh(w: list, v: list, d: int, e: float, mu: float) -> ContactSolution:
    c = -(1.0 + e) * v[0]
    if d == 2:
        pn, pt = _stick2(w, c, -v[1], "pereira-nikravesh")  # eq. (42)
        if _in_cone(pn, abs(pt), mu):
            return _sol((pn, pt), "stick")
        s = -math.copysign(1.0, v[1]) if v[1] != 0.0 else (math.copysign(1.0, pt) if pt else 1.0)
        D = w[0][0] + mu * s * w[0][1]  # eq. (55) direction, eq. (38) denominator
        if not D > 1e-12 * max(abs(w[0][0]), abs(w[0][1]), abs(w[1][1])):
            raise _jam(mu, D, "pereira-nikravesh")
        p = c / D
        return _sol((p, mu * s * p), "slide", D)
    inv = _inverse3(w, "pereira-nikravesh")
    pn, p1, p2 = _linsolve3(w, inv, c, -v[1], -v[2])  # eq. (42) in space
    ptn = math.hypot(p1, p2)
    if _in_cone(pn, ptn, mu):
        return _sol((pn, p1, p2), "stick")
    t1, t2, tl, p, D, interior = _max_dissipation3(w, v, c, mu, inv, (p1, p2))
    extras = {"alpha_m": _angle_from_slip(v[1], v[2], t1, t2), "energy_loss_max": tl,
              "normal_impulse": p, "direction": (t1, t2), "pn_optimum_interior": interior}
    warns = ()
    if interior:
        warns = ("P_N's optimum is interior to the cone (with e > 0 its slip is not zero) while "
                 "the stick test failed: the seed's boundary maximal-dissipation direction is "
                 "used",)
    return _sol((p, mu * p * t1, mu * p * t2), "slide", D, extras, warns)


# --------------------------------------------------------------------------------------------
# Coulomb friction opposing the post-impact slip, Newton restitution


def _coulomb(w: list, v: list, d: int, e: float, mu: float) -> ContactSolution:
    c = -(1.0 + e) * v[0]
    b0 = -c  # b = v + e v_n e_n; u = b + W pi
    wscale = w[0][0] if w[0][0] > w[1][1] else w[1][1]  # max |W_ij| for a PSD W
    if d == 3 and w[2][2] > wscale:
        wscale = w[2][2]
    dmin = 1e-12 * wscale
    vscale = max(abs(v[0]), abs(v[1]), abs(v[-1]))
    if d == 2:
        pn, pt = _stick2(w, c, -v[1], "coulomb")
        if _in_cone(pn, abs(pt), mu):
            return _sol((pn, pt), "stick")
        A, B, C = w[0][0], w[0][1], w[1][1]
        found, jams = [], []
        for s in (1.0, -1.0):
            D = A + mu * s * B
            if not D > dmin:
                jams.append(D)
                continue
            p = c / D
            ut = v[1] + p * (B + mu * s * C)  # post-impact slip
            if ut * s <= CONE_RTOL * vscale:  # anti-parallel to pi_t (or zero)
                tl = -p * (v[0] + mu * s * v[1]) - 0.5 * p * p * (D + mu * s * (B + mu * s * C))
                found.append((tl, s, p, D, ut))
        if not found:
            if jams:
                raise _jam(mu, min(jams), "coulomb")
            raise SolverError("no Coulomb sliding solution exists for this planar contact "
                              "although the stick impulse leaves the cone; use method='clarabel'")
        tl, s, p, D, ut = max(found)
        extras = {"n_slide_solutions": len(found), "post_slip": (ut,)}
        warns = (("the Coulomb law has several sliding solutions here; the most dissipative "
                  "one is returned",) if len(found) > 1 else ())
        return _sol((p, mu * s * p), "slide", D, extras, warns)
    inv = _inverse3(w, "coulomb")
    pn, p1, p2 = _linsolve3(w, inv, c, -v[1], -v[2])
    if _in_cone(pn, math.hypot(p1, p2), mu):
        return _sol((pn, p1, p2), "stick")
    r1, r2 = _unit_or(p1, p2, _unit_or(-v[1], -v[2], (1.0, 0.0)))
    R = _rotate(w, v, r1, r2)
    A, B1, B2, C11, C12, C22, v0, v1, v2 = R
    u00, u0x, u0y, u10, u1x, u1y, u20, u2x, u2y = (A, mu * B1, mu * B2, B1, mu * C11, mu * C12,
                                                   B2, mu * C12, mu * C22)  # W p
    # det[W p, (0, t), b] = sum_i (W p)_i (m x b)_i = 0, m = (0, x, y), b = (b0, v1, v2):
    # m x b = (x v2 - y v1, y b0, -x b0)
    e0 = 0.0
    ex = u00 * v2 - u20 * b0
    ey = -u00 * v1 + u10 * b0
    exx = u0x * v2 - u2x * b0
    eyy = -u0y * v1 + u1y * b0
    exy = -u0x * v1 + u0y * v2 + u1x * b0 - u2y * b0
    escale = (abs(ex) + abs(ey) + abs(exx) + abs(eyy) + abs(exy)) or 1.0
    found: list = []
    jams: list = []

    def conditions(x: float, y: float, rtol: float) -> tuple | None:
        """(T_L, x, y, pi_n, D, sigma) if t = (x, y) is a Coulomb slide to tolerance rtol."""
        if abs(e0 + ex * x + ey * y + exx * x * x + eyy * y * y + exy * x * y) > rtol * escale:
            return None
        D = A + mu * (B1 * x + B2 * y)
        if not D > dmin:
            jams.append(D)
            return None
        P1 = B1 + mu * (C11 * x + C12 * y)
        P2 = B2 + mu * (C12 * x + C22 * y)
        p = c / D  # eq. (38): u_n = 0
        u1, u2 = v1 + p * P1, v2 + p * P2  # post-impact slip, rotated basis
        sigma = -(u1 * x + u2 * y)  # u_t = -sigma t, sigma >= 0: friction opposes the slip
        if sigma < -rtol * vscale or abs(u1 * y - u2 * x) > rtol * (vscale + abs(p) * wscale):
            return None
        pWp = D + mu * (x * P1 + y * P2)
        return -p * (v0 + mu * (v1 * x + v2 * y)) - 0.5 * p * p * pWp, x, y, p, D, sigma

    def add(got: tuple) -> None:
        for f in found:
            if abs(got[1] - f[1]) + abs(got[2] - f[2]) < 1e-9:
                return  # the same root reached twice
        found.append(got)

    # fast path: Newton from the stick impulse's tangent (tau = 0), then the other roots from
    # the deflated cubic, so that every sliding solution is still enumerated
    c4, c3, c2, c1, c0 = (e0 - ex + exx, 2.0 * (ey - exy), 2.0 * (e0 - exx) + 4.0 * eyy,
                          2.0 * (ey + exy), e0 + ex + exx)
    big = max(abs(c4), abs(c3), abs(c2), abs(c1), abs(c0))
    fast_done = False
    if abs(c4) >= 1e-2 * big:  # all roots bounded: |tau| <= 101
        t0 = _polish(c4, c3, c2, c1, c0, 0.0)
        t2 = t0 * t0
        got = conditions((1.0 - t2) / (1.0 + t2), 2.0 * t0 / (1.0 + t2), ROOT_RTOL)
        if got is not None:
            fast_done = True
            found.append(got)
            b2 = c3 + t0 * c4
            b1 = c2 + t0 * b2
            b0 = c1 + t0 * b1
            for t in _cubic_roots(b2 / c4, b1 / c4, b0 / c4):
                t2 = t * t
                x, y = (1.0 - t2) / (1.0 + t2), 2.0 * t / (1.0 + t2)
                if conditions(x, y, 1e-6) is None:  # cheap screening of the raw root
                    continue
                t = _polish(c4, c3, c2, c1, c0, t)
                t2 = t * t
                got = conditions((1.0 - t2) / (1.0 + t2), 2.0 * t / (1.0 + t2), ROOT_RTOL)
                if got is not None:
                    add(got)
    if not fast_done:
        for robust in (False, True):  # Ferrari's roots, then the companion matrix's
            coeffs, cands = _candidates(e0, ex, ey, exx, eyy, exy, robust=robust)
            for pt in cands:
                if not robust and conditions(pt[0], pt[1], 1e-6) is None:
                    continue  # cheap screening of the raw root
                got = conditions(*_refine(coeffs, pt), ROOT_RTOL)
                if got is not None:
                    add(got)
            if found:
                break
    if not found:
        if jams:
            raise _jam(mu, min(jams), "coulomb")
        raise SolverError("no Coulomb sliding solution found for this spatial contact although "
                          "the stick impulse leaves the cone; use method='clarabel'")
    tl, x, y, p, D, sigma = max(found)  # the most dissipative if several
    t1, t2 = x * r1 - y * r2, x * r2 + y * r1
    extras = {"n_slide_solutions": len(found), "direction": (t1, t2),
              "alpha": _angle_from_slip(v[1], v[2], t1, t2), "post_slip_speed": sigma}
    warns = (("the Coulomb law has several sliding solutions here; the most dissipative one "
              "is returned",) if len(found) > 1 else ())
    return _sol((p, mu * p * t1, mu * p * t2), "slide", D, extras, warns)


# --------------------------------------------------------------------------------------------
# CCP (Anitescu): min 1/2 pi.W.pi + pi.b over K_mu


def _ccp_sol(poisson: float | None, impulse: tuple, regime: str,
             extras: dict | None = None) -> ContactSolution:
    if poisson is None:
        return _sol(impulse, regime, extras=extras)
    k = 1.0 + poisson  # Poisson's hypothesis on the plastic impulse
    return _sol([k * x for x in impulse], regime, extras={"plastic_impulse": impulse})


def _ccp(w: list, v: list, d: int, e: float, mu: float, law: str,
         poisson: float | None = None) -> ContactSolution:
    """CCP impulse; with ``poisson = e`` (the dissipative law, called with e = 0) the plastic
    impulse is returned times (1 + e), and reported in the extras."""
    b = list(v)
    b[0] = (1.0 + e) * v[0]
    if d == 2:
        bt = abs(b[1])
        if b[0] >= mu * bt:  # b in the dual cone K*: pi = 0 is optimal
            return _ccp_sol(poisson, (0.0, 0.0), "separating")
        pn, pt = _stick2(w, -b[0], -b[1], law)
        if _in_cone(pn, abs(pt), mu):
            return _ccp_sol(poisson, (pn, pt), "stick", extras={"normal_velocity_lift": 0.0})
        best = None
        for s in (1.0, -1.0):
            pb = b[0] + mu * s * b[1]
            pWp = w[0][0] + 2.0 * mu * s * w[0][1] + mu * mu * w[1][1]
            if pb < 0.0 and pWp > 0.0:
                obj = -0.5 * pb * pb / pWp
                if best is None or obj < best[0]:
                    best = (obj, s, -pb / pWp)
        if best is None:
            raise SolverError("CCP boundary search found no descent direction; use "
                              "method='clarabel'")
        _, s, r = best
        un = b[0] + r * (w[0][0] + mu * s * w[0][1])
        ut = b[1] + r * (w[0][1] + mu * s * w[1][1])
        return _ccp_sol(poisson, (r, mu * s * r), "slide",
                    extras={"normal_velocity_lift": un, "post_slip": (ut,)})
    if b[0] >= mu * math.hypot(b[1], b[2]):
        return _ccp_sol(poisson, (0.0, 0.0, 0.0), "separating")
    inv = _inverse3(w, law)
    pn, p1, p2 = _linsolve3(w, inv, -b[0], -b[1], -b[2])
    if _in_cone(pn, math.hypot(p1, p2), mu):
        return _ccp_sol(poisson, (pn, p1, p2), "stick", extras={"normal_velocity_lift": 0.0})
    r1, r2 = _unit_or(p1, p2, _unit_or(-v[1], -v[2], (1.0, 0.0)))
    R = _rotate(w, b, r1, r2)  # R[6:] hold b in the rotated basis
    scale = abs(b[0]) + abs(b[1]) + abs(b[2])
    E = _det_wq(_wp(R, mu), R[6], R[7], R[8], mu)  # det[W p, b, q] = 0
    got = _ccp_ray(R, mu, *_newton_root(E))  # fast path: Newton from the unconstrained pi_t
    if got is None or got[3] < -1e-6 * scale:  # KKT: y_n = u_n = mu |u_t| >= 0 certifies
        got = _ccp_boundary(R, mu, False, E)
    if got is None or got[3] < -1e-6 * scale:
        got = _ccp_boundary(R, mu, True)  # companion-matrix roots
        if got is None or got[3] < -1e-6 * scale:
            raise SolverError("the CCP boundary solve found no KKT point; use "
                              "method='clarabel'")
    x, y, r, un, slip = got
    t1, t2 = x * r1 - y * r2, x * r2 + y * r1
    return _ccp_sol(poisson, (r, mu * r * t1, mu * r * t2), "slide",
                    extras={"normal_velocity_lift": un, "post_slip_speed": slip,
                            "direction": (t1, t2)})


def _ccp_ray(R: tuple, mu: float, x: float, y: float, converged: bool) -> tuple | None:
    """(x, y, r, u_n, |u_t|) of the optimal ray pi = r p along t = (x, y), or None."""
    if not converged:
        return None
    A, B1, B2, C11, C12, C22, b0, b1, b2 = R
    pb = b0 + mu * (b1 * x + b2 * y)
    pWp = A + mu * (2.0 * (B1 * x + B2 * y) + mu * (C11 * x * x + 2.0 * C12 * x * y
                                                    + C22 * y * y))
    if not (pb < 0.0 and pWp > 0.0):
        return None
    r = -pb / pWp
    un = b0 + r * (A + mu * (B1 * x + B2 * y))
    slip = math.hypot(b1 + r * (B1 + mu * (C11 * x + C12 * y)),
                      b2 + r * (B2 + mu * (C12 * x + C22 * y)))
    return x, y, r, un, slip


def _ccp_boundary(R: tuple, mu: float, robust: bool, E: tuple | None = None) -> tuple | None:
    """Best boundary ray of the CCP program: (x, y, r, u_n, |u_t|) in R's basis, or None.

    Along the ray pi = r p the optimum is r = -p.b / p.W.p (if p.b < 0), with objective
    -1/2 (p.b)^2 / p.W.p; the winner maximizes g = (p.b)^2 / (2 p.W.p) over the roots of
    det[W p, b, q] = 0.
    """
    A, B1, B2, C11, C12, C22, b0, b1, b2 = R
    coeffs, cands = _candidates(*(E or _det_wq(_wp(R, mu), b0, b1, b2, mu)), robust=robust)
    scored = []
    top = None
    for pt in cands:
        x, y = pt[0], pt[1]
        pb = b0 + mu * (b1 * x + b2 * y)
        pWp = A + mu * (2.0 * (B1 * x + B2 * y) + mu * (C11 * x * x + 2.0 * C12 * x * y
                                                        + C22 * y * y))
        if pb < 0.0 and pWp > 0.0:
            g = 0.5 * pb * pb / pWp
            scored.append((g, pt))
            if top is None or g > top:
                top = g
    if top is None:
        return None
    cut = top - 1e-6 * top
    best = None
    for g0, pt in scored:
        if g0 < cut:
            continue
        x, y = _refine(coeffs, pt)
        pb = b0 + mu * (b1 * x + b2 * y)
        pWp = A + mu * (2.0 * (B1 * x + B2 * y) + mu * (C11 * x * x + 2.0 * C12 * x * y
                                                        + C22 * y * y))
        if not (pb < 0.0 and pWp > 0.0):
            x, y = pt[0], pt[1]
            pb = b0 + mu * (b1 * x + b2 * y)
            pWp = A + mu * (2.0 * (B1 * x + B2 * y) + mu * (C11 * x * x + 2.0 * C12 * x * y
                                                            + C22 * y * y))
        g = 0.5 * pb * pb / pWp
        if best is None or g > best[0]:
            best = (g, x, y, pb, pWp)
    _, x, y, pb, pWp = best
    r = -pb / pWp
    un = b0 + r * (A + mu * (B1 * x + B2 * y))
    slip = math.hypot(b1 + r * (B1 + mu * (C11 * x + C12 * y)),
                      b2 + r * (B2 + mu * (C12 * x + C22 * y)))
    return x, y, r, un, slip


# --------------------------------------------------------------------------------------------
# public kernel


def solve_contact(W, v, e: float, mu: float, law: str) -> ContactSolution:
    """Exact impulse of one contact under ``law`` (the kernel of ``method="fast"``).

    Parameters
    ----------
    W : (d, d) array_like
        The contact's Delassus block (loops already folded in), d = 2 (n, t) or 3 (n, t1, t2).
    v : (d,) array_like
        Pre-impact contact velocity; ``v[0] = v_n < 0`` when approaching.
    e : float
        Restitution in [0, 1].
    mu : float
        Friction coefficient >= 0.
    law : {"pereira-nikravesh", "coulomb", "ccp", "dissipative"}
        ``"pereira-nikravesh"``: stick test (eq. 42), else slide on the cone boundary along
        eq. (55) in the plane and along the maximal-dissipation direction in space (eq. 60).
        ``"coulomb"``: Newton restitution on u = v+ + e v_n- n and friction opposing the
        post-impact slip (stick if the stick impulse is in the cone, else u_n = 0 and
        pi_t = -mu pi_n u_t/|u_t|; the most dissipative solution if several).
        ``"ccp"``: min 1/2 pi.W.pi + pi.b over K_mu, b = v + e v_n n.
        ``"dissipative"``: ccp with e = 0, the impulse times (1 + e).

    Returns
    -------
    ContactSolution

    Raises
    ------
    ShapeError, UnknownOptionError, NonFiniteError, ParameterError
        bad shapes, law, non-finite data, e outside [0, 1] or mu < 0.
    SingularSystemError
        W_nn <= 0, or W singular where the law inverts it.
    NonPositiveEffectiveMassError
        Newton laws whose every slide has a non-positive denominator (Painleve-like).
    SolverError
        no solution of the law's conditions exists (Coulomb) or was found.
    """
    w, vv, d = _as_lists(W, v)
    e = float(e)
    mu = float(mu)
    if law not in FAST_LAWS:
        raise UnknownOptionError(f"unknown law {law!r}; choose one of {', '.join(FAST_LAWS)}")
    if not math.isfinite(sum(map(sum, w)) + sum(vv) + e + mu):
        raise NonFiniteError("W, v, e and mu must be finite; got NaN or infinity")
    if not (0.0 <= e <= 1.0 and mu >= 0.0):
        raise ParameterError(f"need e in [0, 1] and mu >= 0, got e = {e:g}, mu = {mu:g}")
    if not vv[0] < 0.0:
        return _sol([0.0] * d, "separating")
    A = w[0][0]
    if not A > 0.0:
        raise SingularSystemError(
            f"W_nn = c_n^T M^-1 c_n = {A:.3e}: the contact normal moves no mass in this "
            "configuration; no impulse can act there")
    tr = sum(w[i][i] for i in range(d))
    if not 1e-100 < tr < 1e100:
        # products of W's entries (quartic coefficients, determinants) would under- or
        # overflow: solve with W / tr(W); every law is homogeneous, pi scales by 1 / tr
        scaled = solve_contact([[x / tr for x in row] for row in w], vv, e, mu, law)
        return _rescaled(scaled, 1.0 / tr)
    if mu == 0.0:
        pi = [0.0] * d
        pi[0] = -(1.0 + e) * vv[0] / A  # eq. (38) with mu = 0 (every law agrees)
        if law == "dissipative":
            plastic = [0.0] * d
            plastic[0] = -vv[0] / A
            return _sol(pi, "frictionless", extras={"plastic_impulse": tuple(plastic)})
        return _sol(pi, "frictionless")
    if law == "pereira-nikravesh":
        return _pereira_nikravesh(w, vv, d, e, mu)
    if law == "coulomb":
        return _coulomb(w, vv, d, e, mu)
    if law == "ccp":
        return _ccp(w, vv, d, e, mu, law)
    return _ccp(w, vv, d, 0.0, mu, law, poisson=e)  # plastic maximal dissipation x (1 + e)


# --------------------------------------------------------------------------------------------
# registered solvers


def _fast_solver(law: str):
    def solver(problem: ImpactProblem, **options) -> ImpactResult:
        if options:
            raise UnknownOptionError(
                f"method 'fast' takes no options, got {', '.join(sorted(options))}")
        if problem.n_contacts != 1:
            raise NotSupportedError(
                f"method='fast' is exact for one contact only; for {problem.n_contacts} "
                "simultaneous contacts use method='clarabel' or method='cvxpy'")
        W, v = problem.contact_block(0)
        sol = solve_contact(W, v, float(problem.restitution[0]), float(problem.friction[0]), law)
        return assemble_result(problem, sol.impulse[None], [sol.regime], law, "fast",
                               effective_mass=sol.effective_mass, tol=FAST_TOL,
                               extras=sol.extras, warnings=sol.warnings)

    solver.__name__ = f"fast_{law.replace('-', '_')}"
    solver.__doc__ = f"Exact single-contact solver of law {law!r} (see solve_contact)."
    return register_solver(law, "fast")(solver)


for _law in FAST_LAWS:
    _fast_solver(_law)
del _law

__all__ = ["ContactSolution", "solve_contact", "max_dissipation_direction", "FAST_LAWS"]
