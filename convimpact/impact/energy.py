"""Energy loss of an impact (eqs. 58-61) and the necessary stiction conditions (eq. 62)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import NonFiniteError, ShapeError, SingularSystemError, as_real_array, real_number
from .problem.build import build_problem, check_friction, check_mass_matrix, check_restitution
from .problem.reduction import _reduce


def _vector(name: str, x, k: int) -> np.ndarray:
    """A finite real (k,) vector, or a typed error naming ``name``."""
    a = as_real_array(name, x)
    if a.shape != (k,):
        raise ShapeError(f"{name} must have length {k} to match M, got shape {a.shape}")
    if not np.isfinite(a).all():
        raise NonFiniteError(f"{name} contains NaN or infinity; pass finite values")
    return a


def _energy(name: str, value: float) -> float:
    """``value``, or NonFiniteError when it leaves double precision's range (kinetic energies
    of 1e200 m/s): never an inf or a NaN (the README's promise)."""
    if not math.isfinite(value):
        raise NonFiniteError(f"{name} = {value} is not finite: the units of M and the "
                             "velocities make kinetic energies exceed 1e308; rescale them")
    return value


def _delassus(M, rows, C=None) -> np.ndarray:
    """``rows G rows^T`` (G = M^-1, or the loop-constrained inverse for closed loops) for
    finite rows of matching length, without the contact checks of build_problem (c_t may be
    zero here)."""
    M, L = check_mass_matrix(M)
    return _reduce(L, np.asarray(rows, dtype=float), np.zeros(M.shape[0]), C)[1]


def energy_loss(M, dq_minus, dq_plus) -> float:
    """T_L = T- - T+ = 1/2 dq-^T M dq- - 1/2 dq+^T M dq+ (eq. 58)."""
    M, _ = check_mass_matrix(M)
    k = M.shape[0]
    a, b = _vector("dq_minus", dq_minus, k), _vector("dq_plus", dq_plus, k)
    with np.errstate(over="ignore", invalid="ignore"):  # an overflow raises just below
        Ta, Tb = 0.5 * float(a @ M @ a), 0.5 * float(b @ M @ b)
    T_minus = _energy("T- = 1/2 dq_minus^T M dq_minus", Ta)
    T_plus = _energy("T+ = 1/2 dq_plus^T M dq_plus", Tb)
    return T_minus - T_plus


def oblique_coefficients(M, c_n, c_t, C=None) -> tuple[float, float, float]:
    """m_nn, m_nt, m_tt = c_n^T G c_n, c_n^T G c_t, c_t^T G c_t (eq. 61).

    G = M^-1 for open loops and the loop-constrained inverse for closed ones (Section 6).
    """
    M, _ = check_mass_matrix(M)
    k = M.shape[0]
    c_n, c_t = _vector("c_n", c_n, k), _vector("c_t", c_t, k)
    W = _delassus(M, np.vstack([c_n, c_t]), C)
    return float(W[0, 0]), float(W[0, 1]), float(W[1, 1])


def central_energy_loss(M, c_n, dq, e: float, C=None) -> float:
    """T_L = (1 - e^2) v_n-^2 / (2 c_n^T M^-1 c_n) for a central/frictionless impact (eq. 59)."""
    e = float(check_restitution(e)[0])
    c_n = _vector("c_n", c_n, check_mass_matrix(M)[0].shape[0])
    m_nn, _, _ = oblique_coefficients(M, c_n, np.zeros_like(c_n), C)
    if not m_nn > 0.0:
        raise SingularSystemError(
            f"c_n^T M^-1 c_n = {m_nn:.3e}: the contact normal moves no mass, eq. (59) is "
            "undefined; check c_n")
    v_n = float(c_n @ _vector("dq", dq, c_n.shape[0]))
    return _energy("the energy loss", (1.0 - e * e) * v_n * v_n / (2.0 * m_nn))


def oblique_energy_loss(M, c_n, c_t, dq, normal_impulse: float, mu: float, C=None) -> float:
    """T_L for a sliding impulse pi = pi_n (c_n + mu c_t) (eqs. 60, 61).

    T_L = -1/2 pi_n^2 (m_nn + 2 mu m_nt + mu^2 m_tt) - pi_n (v_n- + mu v_t-), with
    v_t- = c_t^T dq- measured along the impulse's tangent t.
    """
    mu = real_number("mu", mu)
    pn = real_number("normal_impulse", normal_impulse)
    if not (np.isfinite(mu) and np.isfinite(pn)):
        raise NonFiniteError(f"mu and normal_impulse must be finite, got {mu!r}, {pn!r}")
    m_nn, m_nt, m_tt = oblique_coefficients(M, c_n, c_t, C)
    c_n, c_t = as_real_array("c_n", c_n), as_real_array("c_t", c_t)
    dq = _vector("dq", dq, c_n.shape[0])
    v_n, v_t = float(c_n @ dq), float(c_t @ dq)
    return _energy("the energy loss",
                   -0.5 * pn * pn * (m_nn + 2 * mu * m_nt + mu * mu * m_tt)
                   - pn * (v_n + mu * v_t))


@dataclass(frozen=True)
class StictionInterval:
    """Coefficients of restitution e in [lower, upper] for which sticking is possible.

    ``empty`` is True (and the bounds are NaN) when no e in [0, 1] allows sticking.
    ``conditions`` names the conditions that were imposed.
    """

    lower: float
    upper: float
    conditions: tuple[str, ...]

    @property
    def empty(self) -> bool:
        return not (self.lower <= self.upper)

    def __contains__(self, e: float) -> bool:
        return (not self.empty) and self.lower <= e <= self.upper


def stiction_interval(M, Jc, dq, mu: float | None = None, C=None,
                      opposing: bool = True, tol: float = 1e-12) -> StictionInterval:
    """Interval of e for which the sticking solution of eq. (42)/(52) is admissible.

    The sticking impulse is affine in e: pi(e) = -W^-1 ((1+e) v_n, v_t). Imposed on it:

    * ``"compressive"``: pi_n(e) >= 0 (the paper's D_1/D > 0);
    * ``"opposing"`` (if ``opposing``): the friction impulse opposes the pre-impact slip,
      pi_t(e) . v_t- <= 0 -- with the compressive condition these are the paper's necessary
      conditions (62a, 62b) in the plane. They are Cramer's D_1/D > 0 and D_2/D > 0 of eq. (42);
      (62b) is printed exactly so, while the printed (62a), m_tt v_t - (1+e) m_nt v_n > 0, swaps
      m_tt and m_nt relative to D_1 = m_nt v_t - (1+e) m_tt v_n (t the paper's tangent): we
      follow the derivation (a test pins a case where the two differ in sign);
    * ``"cone"`` (if ``mu`` is given): |pi_t(e)| <= mu pi_n(e), the admissibility test of the
      Section 8 algorithm, which makes the conditions sufficient as well.

    Each condition cuts a convex set of e (linear or second-order-cone in e), so the result
    is one interval, clipped to [0, 1].
    """
    P = build_problem(M, Jc, dq, C=C)
    tol = real_number("tol", tol)
    if P.n_contacts != 1:
        raise ShapeError("stiction_interval takes one contact Jacobian")
    if mu is not None:
        mu = float(check_friction(mu)[0])
    W, v = P.contact_block(0)
    lam = np.linalg.eigvalsh(W)
    if not lam[0] > 1e-12 * lam[-1]:
        raise SingularSystemError(
            "the Delassus matrix W is singular: the sticking impulse of eq. (42)/(52) is not "
            "unique, so no interval of e can be given; check that c_n and c_t are independent "
            "through the mechanism")
    Winv = np.linalg.inv(W)
    base = np.zeros_like(v)
    base[0] = v[0]
    pi0 = -Winv @ v  # pi(e) = pi0 + e pi1
    pi1 = -Winv @ base
    vt = v[1:]
    conditions = ["compressive"]
    linear = [(pi0[0], pi1[0])]  # a + b e >= 0
    if opposing:
        conditions.append("opposing")
        linear.append((-float(pi0[1:] @ vt), -float(pi1[1:] @ vt)))
    if mu is not None:
        conditions.append("cone")

    scale = max(float(np.max(np.abs(pi0))), float(np.max(np.abs(pi1))), 1e-300)

    def feasible(e: float) -> bool:
        if any(a + b * e < -tol * scale for a, b in linear):
            return False
        if mu is not None:
            p = pi0 + e * pi1
            return float(np.linalg.norm(p[1:])) <= mu * p[0] + tol * scale
        return True

    # breakpoints: ends of [0, 1], roots of the linear conditions, roots of the cone quadratic
    points = [0.0, 1.0]
    for a, b in linear:
        if b != 0.0:
            points.append(-a / b)
    if mu is not None:
        # mu^2 (a0 + e a1)^2 - |t0 + e t1|^2 = 0, divided by max(mu, 1)^2 (finite for any
        # finite mu: mu^2 overflows beyond 1e154)
        a0, a1, t0, t1 = pi0[0], pi1[0], pi0[1:], pi1[1:]
        m, r = (1.0, 1.0 / mu) if mu > 1.0 else (mu, 1.0)
        q2 = m * m * a1 * a1 - r * r * float(t1 @ t1)
        q1 = 2 * m * m * a0 * a1 - 2 * r * r * float(t0 @ t1)
        q0 = m * m * a0 * a0 - r * r * float(t0 @ t0)
        roots = np.roots([q2, q1, q0]) if abs(q2) > 0 else (
            np.array([-q0 / q1]) if q1 != 0 else np.array([]))
        points.extend(float(r.real) for r in np.atleast_1d(roots) if abs(r.imag) < 1e-12)
    pts = sorted(p for p in points if 0.0 <= p <= 1.0)
    candidates = pts + [0.5 * (x + y) for x, y in zip(pts, pts[1:])]
    ok = [p for p in candidates if feasible(p)]
    if not ok:
        return StictionInterval(float("nan"), float("nan"), tuple(conditions))
    return StictionInterval(min(ok), max(ok), tuple(conditions))
