"""Trajectory sensitivities of the event-driven scheme: the variational equations between events.

Between two events the modes are fixed and the canonical equations ``y_dot = f(y)``
(:class:`~convimpact.simulation.canonical.CanonicalEquations`, ``y = [theta, p]``) are smooth;
a perturbation of the state then obeys the variational equations

    Phi_dot = A(t) Phi,        A = df/dy (y(t)),        Phi(t_a) = I,
    s_dot = A(t) s + df/dmu,                            s(t_a) = 0,

the second for the friction coefficients, which enter the flow through the sliding contacts'
friction force ``-mu lambda_n c_t^T s`` (the restitution coefficients enter at impacts only).
They are integrated over each event-free interval along the run's own trajectory (the
accepted steps' dense output, the same polynomial the events were located on): with the
explicit integrators (DOP853, RK45, RK23) on the run's own accepted steps, one 8th-order
Dormand-Prince step each, so alongside the state and at the state's accuracy; with the
implicit ones (Radau, BDF, LSODA) by ``solve_ivp`` with the run's class (see
:func:`interval_flow`).

Coordinates. The run integrates ``y = [theta, p]``, ``p = M theta_dot - C^T sigma``; the
sensitivities are reported in the physical state ``x = (theta, theta_dot)``:
``T(y) = dx/dy`` (theta_dot from eqs. 7 + 13 of the modes in force) maps a variation of y
to one of x, and ``L = d[theta, M theta_dot - C^T sigma]/dx`` (sigma of the interval's start
held fixed; sigma = 0 at the run's start, as :func:`~convimpact.simulation.simulate` builds
y0 from a tuple) lifts a variation of x to one of y with ``T L = I``. A variation of p along
``C^T dsigma`` changes no velocity and stays such under the flow, so the interval's map
``T(y_b) Phi L(y_a)`` does not depend on the lift chosen, and the maps of the intervals
and the events' saltation matrices (:mod:`convimpact.simulation.saltation`) multiply to the
derivative of the final x with respect to the initial one.

Accuracy. ``A``, ``df/dmu``, ``T`` and ``L`` are central differences of the smooth model
functions (the mode's right-hand side, the velocities, M theta_dot) with steps
``eps^(1/3) max(|v|, 1)`` (about 6e-6 relative), so truncation (h^2) and round-off
(eps / h) errors are both about 1e-10 relative to the functions' scale: the derivatives are
accurate to ~1e-9 relative, well below the integration's own error at the usual rtol. On
the run's steps the variational equations are as accurate as the state (measured on the
double pendulum striking the floor, relative error of dx(t_f)/dx(t_0) against a run at
rtol 1e-12: 1e-6, 5e-8, 7e-10 at rtol 1e-6, 1e-8, 1e-10). With an implicit integrator they
are integrated to ``max(rtol, VAR_RTOL)``: below :data:`VAR_RTOL` (1e-9) an adaptive
solver's steps would only chase the differences' noise.
"""

from __future__ import annotations

import copy
from dataclasses import replace
from typing import Callable, Sequence

import numpy as np
from scipy.integrate import solve_ivp
from scipy.integrate._ivp import dop853_coefficients as _DOP

from .canonical import CanonicalEquations
from .result import PiecewiseSolution

#: relative central-difference step: eps^(1/3) balances truncation (h^2) and round-off (eps/h)
FD_STEP = float(np.finfo(float).eps ** (1.0 / 3.0))
#: tightest relative tolerance of the variational equations: their differenced A carries
#: ~1e-10 relative noise, which a tighter tolerance would only chase with tiny steps
VAR_RTOL = 1e-9
#: the integrators whose accepted steps the variational equations follow (explicit RK)
EXPLICIT = ("DOP853", "RK45", "RK23")


def central_jacobian(fun: Callable[[np.ndarray], np.ndarray], v: np.ndarray) -> np.ndarray:
    """``d fun / d v`` by central differences, step ``FD_STEP max(|v_j|, 1)`` per entry
    (about 1e-10 relative error for a smooth function of unit scale)."""
    v = np.asarray(v, dtype=float)
    cols = []
    for j in range(v.size):
        h = FD_STEP * max(abs(float(v[j])), 1.0)
        vp, vm = v.copy(), v.copy()
        vp[j] += h
        vm[j] -= h
        cols.append((np.asarray(fun(vp), float) - np.asarray(fun(vm), float)) / (vp[j] - vm[j]))
    return np.array(cols).T if cols else np.zeros((0, 0))


def central_derivative(fun: Callable[[float], np.ndarray], value: float) -> np.ndarray:
    """``d fun / d value`` of a scalar argument by a central difference (same step rule)."""
    h = FD_STEP * max(abs(float(value)), 1.0)
    up, down = value + h, value - h
    return (np.asarray(fun(up), float) - np.asarray(fun(down), float)) / (up - down)


def quiet_rhs(eq: CanonicalEquations, t: float, y: np.ndarray) -> np.ndarray:
    """``f(y)`` of the modes in force, not counted in the run's ``nfev``."""
    n = eq.nfev
    try:
        return eq(t, np.asarray(y, float))
    finally:
        eq.nfev = n


def with_friction(eq: CanonicalEquations, contact: str, mu: float) -> CanonicalEquations:
    """A copy of ``eq`` whose held ``contact`` has the friction coefficient ``mu``."""
    other = copy.copy(eq)
    other.modes = dict(eq.modes)
    other.modes[contact] = replace(eq.modes[contact], mu=float(mu))
    other._memo = {}
    other.nfev = 0
    return other


def physical(eq: CanonicalEquations, y: np.ndarray) -> np.ndarray:
    """``x = (theta, theta_dot)`` of ``y = [theta, p]`` under the modes of ``eq``."""
    k = eq.k
    dth, _, _ = eq.velocities(np.asarray(y[:k], float), np.asarray(y[k:], float))
    return np.concatenate([y[:k], dth])


def to_physical(eq: CanonicalEquations, y: np.ndarray) -> np.ndarray:
    """``T(y) = dx/dy`` (2k x 2k): theta's rows the identity, theta_dot's differenced."""
    return central_jacobian(lambda v: physical(eq, v), y)


def lift(eq: CanonicalEquations, y: np.ndarray) -> np.ndarray:
    """``L = d[theta, M(theta) theta_dot - C(theta)^T sigma]/dx`` at x = T(y) with the
    multipliers sigma of ``y`` held fixed (2k x 2k): a variation dx of the physical state
    lifted to one of y, so that ``T(y + L dx) = x + dx`` to first order (with sigma = 0,
    as at the start, ``d[theta, M theta_dot]/dx``)."""
    k = eq.k
    th, p = np.asarray(y[:k], float), np.asarray(y[k:], float)
    dth, sigma, _ = eq.velocities(th, p)

    def momentum(v):
        return eq.momentum(v[:k], v[k:], sigma)

    L = np.zeros((2 * k, 2 * k))
    L[:k, :k] = np.eye(k)
    L[k:] = central_jacobian(momentum, np.concatenate([th, dth]))
    return L


def physical_rate(eq: CanonicalEquations, t: float, y: np.ndarray) -> np.ndarray:
    """``x_dot = T(y) f(y)``: (theta_dot, theta_ddot) under the modes of ``eq``."""
    return to_physical(eq, y) @ quiet_rhs(eq, t, y)


def friction_rate(eq: CanonicalEquations, t: float, y: np.ndarray,
                  contacts: Sequence[str]) -> np.ndarray:
    """``df/dmu`` (2k, n_contacts): nonzero in the columns of the sliding contacts only."""
    out = np.zeros((2 * eq.k, len(contacts)))
    for c, _ in eq.slipping:
        j = contacts.index(c)
        out[:, j] = central_derivative(
            lambda m, c=c: quiet_rhs(with_friction(eq, c, m), t, y), eq.modes[c].mu)
    return out


def _variational_rate(eq: CanonicalEquations, contacts: Sequence[str], n2: int, nc: int):
    """``(t, y, Z) -> dZ/dt`` of ``Z = [Phi, S_mu]`` along the state y."""
    sliding = bool(eq.slipping)

    def rate(t: float, y: np.ndarray, Z: np.ndarray) -> np.ndarray:
        A = central_jacobian(lambda v: quiet_rhs(eq, t, v), y)
        out = A @ Z
        if sliding:
            out[:, n2:] += friction_rate(eq, t, y, contacts)
        return out
    return rate


def _rk_step(rate, interp, t: float, h: float, Z: np.ndarray) -> np.ndarray:
    """One step of the 12-stage, 8th-order Dormand-Prince formulas (scipy's DOP853
    coefficients) for the linear equations ``Z' = rate(t, y(t), Z)``, y from ``interp``."""
    a, b, c = _DOP.A, _DOP.B, _DOP.C
    K = []
    for i in range(_DOP.N_STAGES):
        Zi = Z + h * sum((a[i, j] * K[j] for j in range(i) if a[i, j] != 0.0), np.zeros_like(Z))
        ti = t + c[i] * h
        K.append(rate(ti, np.asarray(interp(ti), float), Zi))
    return Z + h * sum(b[i] * K[i] for i in range(_DOP.N_STAGES))


def interval_flow(eq: CanonicalEquations, segments: Sequence, t_a: float, t_b: float,
                  contacts: Sequence[str], solver_cls, rtol: float, atol: float,
                  times: np.ndarray | None = None):
    """The variational equations over one event-free interval [t_a, t_b].

    ``segments`` are the run's accepted steps ``(t_old, t_new, interpolant)`` inside the
    interval. With an explicit Runge-Kutta run (DOP853, RK45, RK23) the equations are
    integrated on the run's own steps, one 8th-order Dormand-Prince step per accepted step
    of the state (the steps that resolve the state resolve its linearization: the cost is
    bounded by the run's, and a stretch where the run crawls does not make the
    variational equations crawl more); with an implicit one (Radau, BDF, LSODA: stiff
    motion, where an explicit step of the run's length would be unstable) by
    ``solve_ivp`` with the run's class to ``max(rtol, VAR_RTOL)``.

    Returns ``(Phi, S_mu, at)``: ``dy(t_b)/dy(t_a)`` (2k x 2k), the response of y(t_b) to
    the friction coefficients from a zero start (2k x n_contacts), and the same pair at each
    of ``times`` (within [t_a, t_b]) as a list.
    """
    n2, nc = 2 * eq.k, len(contacts)
    times = np.zeros(0) if times is None else np.asarray(times, float)
    if t_b <= t_a or not segments:
        same = (np.eye(n2), np.zeros((n2, nc)))
        return same[0], same[1], [same] * len(times)
    rate = _variational_rate(eq, contacts, n2, nc)
    Z0 = np.hstack([np.eye(n2), np.zeros((n2, nc))])
    if solver_cls.__name__ in EXPLICIT:
        Z, at = Z0, []
        pending = list(times)
        for t_old, t_new, interp in sorted(segments, key=lambda seg: seg[0]):
            while pending and pending[0] < t_new:  # samples inside this step
                ts = pending.pop(0)
                Zs = _rk_step(rate, interp, t_old, ts - t_old, Z) if ts > t_old else Z
                at.append((Zs[:, :n2], Zs[:, n2:]))
            Z = _rk_step(rate, interp, t_old, t_new - t_old, Z)
        at += [(Z[:, :n2], Z[:, n2:])] * len(pending)  # at t_b itself
        return Z[:, :n2], Z[:, n2:], at
    sol = PiecewiseSolution(segments)
    r = solve_ivp(lambda t, z: rate(t, sol(t), z.reshape(n2, n2 + nc)).ravel(), (t_a, t_b),
                  Z0.ravel(), method=solver_cls, rtol=max(rtol, VAR_RTOL),
                  atol=max(atol, VAR_RTOL), dense_output=bool(len(times)))
    if not r.success:
        from ..errors import SimulationError
        raise SimulationError(f"the variational equations failed on [{t_a:.9g}, {t_b:.9g}]: "
                              f"{r.message}")
    Z = r.y[:, -1].reshape(n2, n2 + nc)
    at = []
    for t in times:
        Zt = r.sol(float(t)).reshape(n2, n2 + nc) if t < t_b else Z
        at.append((Zt[:, :n2], Zt[:, n2:]))
    return Z[:, :n2], Z[:, n2:], at


__all__ = ["FD_STEP", "central_jacobian", "central_derivative", "quiet_rhs", "with_friction",
           "physical", "to_physical", "lift", "physical_rate", "friction_rate", "interval_flow"]
