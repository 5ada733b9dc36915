"""The direction of the friction impulse that maximizes the energy loss (eq. 60), exactly.

The paper's spatial sliding rule (Section 9.3): ``pi = pi_n (n + mu t)`` with ``pi_n`` from
eq. (38)/(51), ``pi_n = -(1+e) v_n / (W_n . (1, mu t))``, and t the direction, among those with
a positive denominator, that maximizes T_L (eq. 60). This is also the boundary optimum of the
program P_N (minimize T+ subject to v_n+ = -e v_n-, pi in K_mu). Its stationarity condition
``det[c W p + (a.p) v, a, q] = 0`` (a = W e_n, q = (-mu, t)) is a trigonometric quadratic in t,
solved exactly by :mod:`convimpact.impact.boundary`. P_N is convex, so Newton's method from
-v_t- is tried first and accepted when P_N's KKT conditions certify it; otherwise every root
is compared, the winner certified (KKT or probe directions), then retried with companion-
matrix roots, then SolverError.
"""

from __future__ import annotations

import math

import numpy as np

from .boundary import candidates, det_wq, newton_root, refine, rotate
from .errors import SingularSystemError, SolverError, real_number
from .fast import in_cone
from .small_linalg import as_lists, inverse3, solve3, unit_or


def _dissipation_equation(R: tuple, c: float, mu: float) -> tuple:
    """Stationarity of T_L on the boundary as a trigonometric quadratic E(th).

    c det[W p, a, q] + (a.p) det[v, a, q] = det[c W p + (a.p) v, a, q] = 0 with a = W e_n and
    a.p = A + mu (B1 x + B2 y), the denominator D of eq. (38); ``R`` from :func:`rotate`.
    """
    A, B1, B2, C11, C12, C22, v0, v1, v2 = R
    mB1, mB2 = mu * B1, mu * B2
    cv, cm = c + v0, c * mu
    U = (cv * A, cv * mB1, cv * mB2,
         c * B1 + v1 * A, cm * C11 + v1 * mB1, cm * C12 + v1 * mB2,
         c * B2 + v2 * A, cm * C12 + v2 * mB1, cm * C22 + v2 * mB2)
    return det_wq(U, A, B1, B2, mu)


def _dissipation_angle(R: tuple, c: float, mu: float, robust: bool = False,
                       E: tuple | None = None) -> tuple[float, float, float, float, float]:
    """Direction maximizing T_L (eq. 60) on the cone boundary with D > 0, over every root of
    :func:`_dissipation_equation`. Returns (x, y, T_L, pi_n, D) in R's basis."""
    A, B1, B2, C11, C12, C22, v0, v1, v2 = R
    coeffs, cands = candidates(*(E or _dissipation_equation(R, c, mu)), robust=robust)
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
        x, y = refine(coeffs, pt)
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
    try:
        inv = inverse3(w, "pereira-nikravesh")
    except SingularSystemError:
        inv = None
    t1, t2 = max_dissipation_slide(w, vv, c, mu, inv, (1.0, 0.0))[:2]
    return np.array((t1, t2))


# --------------------------------------------------------------------------------------------
# certified spatial slide (the kernel of the seed's law in space)


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


def max_dissipation_slide(w: list, v: list, c: float, mu: float, inv: tuple | None,
                          fallback: tuple[float, float]) -> tuple:
    """The seed's spatial slide: (t1, t2, T_L, pi_n, D, P_N interior?) maximizing eq. (60).

    Reference direction -v_t- (else ``fallback``, else t1). When P_N's optimum lies on the
    boundary (``inv`` = W^-1 tells), Newton's method from the reference direction is tried
    first and certified by P_N's KKT conditions (P_N is convex); otherwise, or if that fails,
    every root of the boundary quartic is compared, the answer is certified (KKT or probe
    directions), then retried with companion-matrix roots, then SolverError.
    """
    r1, r2 = unit_or(-v[1], -v[2], unit_or(fallback[0], fallback[1], (1.0, 0.0)))
    if inv is not None:
        # P_N's optimum over the plane a.pi = c: pi* = lam e_n - W^-1 v, lam = (c + v_n) / W_nn
        q0, q1, q2 = solve3(inv, v[0], v[1], v[2])
        lam = (c + v[0]) / w[0][0]
        interior = in_cone(lam - q0, math.hypot(q1, q2), mu)
    else:
        interior = True  # unknown: no KKT shortcut, the probes certify
    R = rotate(w, v, r1, r2)
    E = _dissipation_equation(R, c, mu)
    if not interior:
        # fast path: Newton from -v_t; P_N is convex, so its KKT conditions certify the root
        x, y, converged = newton_root(E)
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
