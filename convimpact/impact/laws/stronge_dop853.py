"""The DOP853 integrator of law ``"stronge"``'s curved spatial slip, compiled: its mechanics.

A slip off the invariant rays is integrated in ``sigma`` (``dsigma = dp / |v_t|``), state
``y = (p, pi_t, W_n)`` (:mod:`convimpact.impact.laws.stronge` states the equations and the
error control). Here are the integrator's parts, on the tableau of scipy.integrate's DOP853
(Dormand--Prince 8(5,3), Hairer, Norsett & Wanner) frozen into the machine code:
:func:`_rhs` (the slope ``dy/dsigma``), :func:`_step` (one step), :func:`_error` (the error
norm, each component scaled by :data:`ODE_RTOL`), :func:`_event` and :func:`_event_length`
(the stage's event function and its location inside an accepted step; the sensitivities of
the curved slip, :mod:`convimpact.impact.laws.stronge_sensitivity`, step on the same tableau
and locate their events with these two). The loop that drives them -- step-size control,
the stage's events, the stop and the hand-over to an exact straight finish -- is the law's,
``_curved_slip`` in :mod:`convimpact.impact.laws.stronge_slip`.

Every function runs unchanged as plain Python (``NUMBA_DISABLE_JIT=1``), which reads
:data:`ODE_RTOL` from this module at run time.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.integrate._ivp import dop853_coefficients as _dop853

from .codes import _jit, _pmax2

#: local error tolerance of the DOP853 integration of a curved spatial slip
ODE_RTOL = 1e-13

#: DOP853's tableau (Hairer, Norsett & Wanner; scipy.integrate's coefficients): A's lower
#: triangle, B, the error estimators E3 and E5, global arrays frozen into the machine code
_NS = int(_dop853.N_STAGES)
_A = np.ascontiguousarray(np.asarray(_dop853.A, dtype=np.float64)[:_NS, :_NS])
_B = np.ascontiguousarray(np.asarray(_dop853.B, dtype=np.float64))
_E3 = np.ascontiguousarray(np.asarray(_dop853.E3, dtype=np.float64))
_E5 = np.ascontiguousarray(np.asarray(_dop853.E5, dtype=np.float64))
_NE = _E5.shape[0]  # = _NS + 1: the stages and the slope at the step's end


@_jit
def _velocity(y0, y1, y2, vn0, vt01, vt02, A, b1, b2, C11, C12, C22):
    """v = v- + W pi at pi = (y0, y1, y2): (v_n, v_t1, v_t2)."""
    return (vn0 + A * y0 + b1 * y1 + b2 * y2, vt01 + b1 * y0 + C11 * y1 + C12 * y2,
            vt02 + b2 * y0 + C12 * y1 + C22 * y2)


@_jit
def _rhs(y0, y1, y2, vn0, vt01, vt02, A, b1, b2, C11, C12, C22, mu):
    """dy/dsigma = (|v_t|, -mu v_t, |v_t| v_n) with v = v- + W pi."""
    vn, v1, v2 = _velocity(y0, y1, y2, vn0, vt01, vt02, A, b1, b2, C11, C12, C22)
    r = math.hypot(v1, v2)
    return r, -mu * v1, -mu * v2, r * vn


@_jit
def _step(y0, y1, y2, y3, f0, f1, f2, f3, h, K, vn0, vt01, vt02, A, b1, b2, C11, C12, C22,
          mu):
    """One DOP853 step from y (slope f) of length h: y_new and its slope; the stage slopes
    and that one in K. (The stages' W_n components are not formed: the slope does not depend
    on W_n.)"""
    K[0, 0] = f0
    K[1, 0] = f1
    K[2, 0] = f2
    K[3, 0] = f3
    for i in range(1, _NS):
        s0 = 0.0
        s1 = 0.0
        s2 = 0.0
        for m in range(i):
            a = _A[i, m]
            s0 += a * K[0, m]
            s1 += a * K[1, m]
            s2 += a * K[2, m]
        k0, k1, k2, k3 = _rhs(y0 + h * s0, y1 + h * s1, y2 + h * s2, vn0, vt01, vt02, A, b1,
                              b2, C11, C12, C22, mu)
        K[0, i] = k0
        K[1, i] = k1
        K[2, i] = k2
        K[3, i] = k3
    s0 = 0.0
    s1 = 0.0
    s2 = 0.0
    s3 = 0.0
    for m in range(_NS):
        b = _B[m]
        s0 += b * K[0, m]
        s1 += b * K[1, m]
        s2 += b * K[2, m]
        s3 += b * K[3, m]
    z0, z1, z2, z3 = y0 + h * s0, y1 + h * s1, y2 + h * s2, y3 + h * s3
    n0, n1, n2, n3 = _rhs(z0, z1, z2, vn0, vt01, vt02, A, b1, b2, C11, C12, C22, mu)
    K[0, _NS] = n0
    K[1, _NS] = n1
    K[2, _NS] = n2
    K[3, _NS] = n3
    return z0, z1, z2, z3, n0, n1, n2, n3


@_jit
def _error(h, y0, y1, y2, y3, z0, z1, z2, z3, pref, ref3, K):
    """DOP853's error norm of the step y -> z (the 5th- and 3rd-order estimators combined as
    scipy does), each component scaled by ODE_RTOL (|reference| + max |y|)."""
    e5 = 0.0
    e3 = 0.0
    for i in range(4):
        if i == 0:
            sc = pref + _pmax2(abs(y0), abs(z0))
        elif i == 1:
            sc = pref + _pmax2(abs(y1), abs(z1))
        elif i == 2:
            sc = pref + _pmax2(abs(y2), abs(z2))
        else:
            sc = ref3 + _pmax2(abs(y3), abs(z3))
        sc *= ODE_RTOL
        s5 = 0.0
        s3 = 0.0
        for m in range(_NE):
            s5 += _E5[m] * K[i, m]
            s3 += _E3[m] * K[i, m]
        # the step's error estimates h K^T E, not the slopes' K^T E, against the scale: the
        # slopes (|v_t|, mu v_t) can exceed the scale of p by far more than double precision
        # spans when the contact slides much faster than it approaches (h is then as small)
        s5 *= h
        s3 *= h
        e5 += (s5 / sc) * (s5 / sc)
        e3 += (s3 / sc) * (s3 / sc)
    return _error_norm(e5, e3)


@_jit
def _error_norm(e5, e3):
    """scipy's DOP853 error norm |h| |e5|^2 / sqrt(4 (|e5|^2 + |e3|^2 / 100)) from the squared
    norms of the two estimators (h moved into them)."""
    if e5 == 0.0 and e3 == 0.0:
        return 0.0
    return e5 / math.sqrt((e5 + 0.01 * e3) * 4.0)


@_jit
def _event(y0, y1, y2, y3, compressing, target, vn0, A, b1, b2):
    """The stage's event function: v_n while compressing, then W_n - target (rising to 0)."""
    if compressing:
        return vn0 + A * y0 + b1 * y1 + b2 * y2
    return y3 - target


@_jit
def _event_length(y0, y1, y2, y3, f0, f1, f2, f3, h, g0, g1, compressing, target, K, vn0,
                  vt01, vt02, A, b1, b2, C11, C12, C22, mu):
    """The length of the step from y to the event inside the accepted step [0, h]: Newton on
    the step length, bracketed, each iterate re-taking the step (to |dsigma| <= 1e-13 h; at
    most 60 iterations). The law's curved slip and its sensitivities
    (:mod:`convimpact.impact.laws.stronge_sensitivity`) both use it."""
    lo = 0.0
    hi = h
    tau = h * g0 / (g0 - g1)
    for it in range(60):
        t0, t1, t2, t3, r0, r1, r2, r3 = _step(y0, y1, y2, y3, f0, f1, f2, f3, tau, K, vn0,
                                               vt01, vt02, A, b1, b2, C11, C12, C22, mu)
        g = _event(t0, t1, t2, t3, compressing, target, vn0, A, b1, b2)
        if g == 0.0:
            return tau
        if g < 0.0:
            lo = tau
        else:
            hi = tau
        rate = A * r0 + b1 * r1 + b2 * r2 if compressing else r3
        new = tau - g / rate if rate > 0.0 else 0.5 * (lo + hi)
        if not lo <= new <= hi:
            new = 0.5 * (lo + hi)
        if abs(new - tau) <= 1e-13 * h:
            return new
        if it == 59:
            break
        tau = new
    return tau
