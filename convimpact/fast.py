"""Exact single-contact impact solvers for every law (``method="fast"``).

One contact's impact reduces to its Delassus block ``W`` (d x d, d = 2 planar or 3 spatial;
closed loops are already folded in by :mod:`convimpact.problem`) and its pre-impact velocity
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
in closed form (Ferrari), every real root is polished by Newton's method on the trigonometric
form (no loss at ``tau -> infinity``; the angle opposite to the reference direction is always
tried as well, which covers a vanishing leading coefficient), and the root that satisfies all
of the law's conditions (and is best for its objective) is kept. The kernels work on plain
Python floats: a spatial solve takes a few microseconds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any, Mapping, Sequence

import numpy as np

from .diagnostics import assemble_result
from .errors import (
    NonPositiveEffectiveMassError,
    NotSupportedError,
    ShapeError,
    SingularSystemError,
    SolverError,
    UnknownOptionError,
)
from .impact import register_solver
from .problem import ImpactProblem

#: laws treated by :func:`solve_contact`
FAST_LAWS = ("pereira-nikravesh", "coulomb", "ccp", "dissipative")
#: relative determinant below which W is treated as singular (det W <= tol * trace(W)^d)
SINGULAR_RTOL = 1e-13
#: relative tolerance of the cone / sign tests (round-off allowance)
CONE_RTOL = 1e-12
#: relative tolerance on a boundary root's residual for it to count as a solution
ROOT_RTOL = 1e-8
#: accuracy stated for the fast path (passed to assemble_result)
FAST_TOL = 1e-10

_TWO_PI = 2.0 * math.pi


@dataclass(frozen=True)
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
    coeffs = [c4, c3, c2, c1, c0]
    scale = max(abs(x) for x in coeffs)
    if scale == 0.0:
        return None
    while coeffs and abs(coeffs[0]) <= 1e-13 * scale:
        coeffs.pop(0)
    deg = len(coeffs) - 1
    if deg <= 0:
        return []
    lead = coeffs[0]
    k = [x / lead for x in coeffs[1:]]
    if deg == 1:
        return [-k[0]]
    if deg == 2:
        return _quadratic_roots(k[0], k[1])
    if deg == 3:
        return _cubic_roots(k[0], k[1], k[2])
    a, b, c, d = k
    a2 = a * a
    p = b - 3.0 * a2 / 8.0
    q = c - a * b / 2.0 + a2 * a / 8.0
    r = d - a * c / 4.0 + a2 * b / 16.0 - 3.0 * a2 * a2 / 256.0
    shift = -a / 4.0
    ys: list[float] = []
    qscale = abs(p) ** 1.5 + abs(r) ** 0.75 + abs(q)
    if abs(q) <= 1e-14 * qscale:  # biquadratic y^4 + p y^2 + r
        for z in _quadratic_roots(p, r):
            if z > 0.0:
                s = math.sqrt(z)
                ys += [s, -s]
            elif z >= -1e-9 * (abs(p) + math.sqrt(abs(r))):
                ys.append(0.0)
    else:
        # resolvent 8 m^3 + 8 p m^2 + (2 p^2 - 8 r) m - q^2 = 0, largest root m > 0
        m = max(_cubic_roots(p, p * p / 4.0 - r, -q * q / 8.0))
        if m <= 0.0:
            m = 1e-300
        s = math.sqrt(2.0 * m)
        h = q / (2.0 * s)
        ys += _quadratic_roots(-s, 0.5 * p + m + h)
        ys += _quadratic_roots(s, 0.5 * p + m - h)
    return [y + shift for y in ys]


# --------------------------------------------------------------------------------------------
# trigonometric quadratics: coefficients (c0, cx, cy, cxx, cyy, cxy) of a form in x = cos th,
# y = sin th; affine forms are (k0, kx, ky)


def _mul(f: tuple, g: tuple) -> tuple:
    return (f[0] * g[0], f[0] * g[1] + f[1] * g[0], f[0] * g[2] + f[2] * g[0],
            f[1] * g[1], f[2] * g[2], f[1] * g[2] + f[2] * g[1])


def _add(*qs: tuple) -> tuple:
    return tuple(sum(col) for col in zip(*qs))


def _stationary_angles(E: tuple) -> list[float]:
    """All angles th in (-pi, pi] where the trigonometric quadratic E vanishes (polished).

    ``pi`` (tau = infinity) is always included as a candidate; if E vanishes identically the
    only candidate returned is 0 (every direction is then stationary).
    """
    c0, cx, cy, cxx, cyy, cxy = E
    roots = _quartic_roots(c0 - cx + cxx, 2.0 * (cy - cxy), 2.0 * (c0 - cxx) + 4.0 * cyy,
                           2.0 * (cy + cxy), c0 + cx + cxx)
    if roots is None:
        return [0.0]
    thetas = [2.0 * math.atan(t) for t in roots]
    thetas.append(math.pi)
    out = []
    for th in thetas:
        x, y = math.cos(th), math.sin(th)
        f = c0 + cx * x + cy * y + cxx * x * x + cyy * y * y + cxy * x * y
        for _ in range(8):  # Newton on E(th)
            df = -cx * y + cy * x + 2.0 * (cyy - cxx) * x * y + cxy * (x * x - y * y)
            if df == 0.0:
                break
            step = f / df
            if step > 0.5:
                step = 0.5
            elif step < -0.5:
                step = -0.5
            th_new = th - step
            xn, yn = math.cos(th_new), math.sin(th_new)
            fn = c0 + cx * xn + cy * yn + cxx * xn * xn + cyy * yn * yn + cxy * xn * yn
            if abs(fn) >= abs(f):
                break
            th, x, y, f = th_new, xn, yn, fn
            if abs(step) < 1e-15:
                break
        out.append(th)
    return out


# --------------------------------------------------------------------------------------------
# spatial contact data in a rotated tangent basis (r, r_perp)


class _Spatial:
    """W and v of one spatial contact expressed in the tangent basis (r, r_perp)."""

    __slots__ = ("A", "B1", "B2", "C11", "C12", "C22", "v0", "v1", "v2", "r1", "r2")

    def __init__(self, w: Sequence[Sequence[float]], v: Sequence[float], r1: float, r2: float):
        A, B1, B2 = w[0]
        C11, C12, C22 = w[1][1], w[1][2], w[2][2]
        self.A = A
        self.B1 = B1 * r1 + B2 * r2
        self.B2 = -B1 * r2 + B2 * r1
        self.C11 = C11 * r1 * r1 + 2.0 * C12 * r1 * r2 + C22 * r2 * r2
        self.C22 = C11 * r2 * r2 - 2.0 * C12 * r1 * r2 + C22 * r1 * r1
        self.C12 = (C22 - C11) * r1 * r2 + C12 * (r1 * r1 - r2 * r2)
        self.v0 = v[0]
        self.v1 = v[1] * r1 + v[2] * r2
        self.v2 = -v[1] * r2 + v[2] * r1
        self.r1, self.r2 = r1, r2

    def direction(self, th: float) -> tuple[float, float]:
        """Unit tangent t(th) = cos th r + sin th r_perp in the contact frame (t1, t2)."""
        x, y = math.cos(th), math.sin(th)
        return x * self.r1 - y * self.r2, x * self.r2 + y * self.r1

    def wp_forms(self, mu: float) -> tuple[tuple, tuple, tuple]:
        """W p with p = (1, mu x, mu y), as three affine forms."""
        return ((self.A, mu * self.B1, mu * self.B2),
                (self.B1, mu * self.C11, mu * self.C12),
                (self.B2, mu * self.C12, mu * self.C22))


def _cross_q(k0: float, k1: float, k2: float, mu: float) -> tuple[tuple, tuple, tuple]:
    """k x q with q = (-mu, x, y), as three affine forms."""
    return (0.0, -k2, k1), (-mu * k2, 0.0, -k0), (mu * k1, k0, 0.0)


def _det_affine(U: tuple, X: tuple) -> tuple:
    """U . X for affine-form triples U and X: a trigonometric quadratic."""
    return _add(_mul(U[0], X[0]), _mul(U[1], X[1]), _mul(U[2], X[2]))


def _eval_p(S: _Spatial, mu: float, th: float) -> tuple[float, float, float, float, float]:
    """(x, y, D = a.p, p.W.p, W p tangential components) at th."""
    x, y = math.cos(th), math.sin(th)
    P0 = S.A + mu * (S.B1 * x + S.B2 * y)
    P1 = S.B1 + mu * (S.C11 * x + S.C12 * y)
    P2 = S.B2 + mu * (S.C12 * x + S.C22 * y)
    return x, y, P0, P0 + mu * (x * P1 + y * P2), (P1, P2)


def _dissipation_angle(S: _Spatial, c: float, mu: float) -> tuple[float, float, float, float]:
    """Angle th in S's basis maximizing T_L (eq. 60) on the cone boundary with D > 0.

    Returns (th, T_L, pi_n, D).
    """
    Wp = S.wp_forms(mu)
    X = _cross_q(S.A, S.B1, S.B2, mu)  # a x q, a = W e_n
    vX = _add(_scale_aff(X[0], S.v0), _scale_aff(X[1], S.v1), _scale_aff(X[2], S.v2))
    # c det[W p, a, q] + (a.p) det[v, a, q] = 0: stationarity of T_L on the boundary
    E = _add(tuple(c * t for t in _det_affine(Wp, X)), _mul(Wp[0], vX))
    best = None
    dmin = 1e-12 * (abs(S.A) + mu * math.hypot(S.B1, S.B2))
    for th in _stationary_angles(E):
        x, y, D, pWp, _ = _eval_p(S, mu, th)
        if not D > dmin:
            continue
        pn = c / D
        tl = -pn * (S.v0 + mu * (S.v1 * x + S.v2 * y)) - 0.5 * pn * pn * pWp
        if best is None or tl > best[1]:
            best = (th, tl, pn, D)
    if best is None:  # unreachable for A > 0: D averages A over the circle
        raise SolverError("no admissible sliding direction found (every D <= 0)")
    return best


def _scale_aff(X: tuple, s: float) -> tuple:
    return (X[0] * s, X[1] * s, X[2] * s)


def _unit_or(x1: float, x2: float, fallback: tuple[float, float]) -> tuple[float, float]:
    n = math.hypot(x1, x2)
    if n > 0.0:
        return x1 / n, x2 / n
    return fallback


def _as_lists(W, v) -> tuple[list, list, int]:
    w = W.tolist() if isinstance(W, np.ndarray) else [list(map(float, r)) for r in W]
    vv = v.tolist() if isinstance(v, np.ndarray) else [float(x) for x in v]
    d = len(vv)
    if d not in (2, 3) or len(w) != d or any(len(r) != d for r in w):
        raise ShapeError(
            f"a single contact needs W of shape (d, d) and v of length d with d = 2 (n, t) or "
            f"3 (n, t1, t2); got W {np.shape(W)} and v {np.shape(v)}")
    return w, vv, d


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
    r1, r2 = _unit_or(-vv[1], -vv[2], (1.0, 0.0))
    S = _Spatial(w, vv, r1, r2)
    th = _dissipation_angle(S, c, mu)[0]
    return np.array(S.direction(th))


__all__ = ["ContactSolution", "max_dissipation_direction", "FAST_LAWS"]
