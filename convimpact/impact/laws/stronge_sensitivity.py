"""Law ``"stronge"``: the sensitivities of the curved spatial slip (the derivative of the
impulse-space integration of :mod:`convimpact.impact.laws.stronge_slip`).

The curved slip is integrated in ``sigma`` (``dsigma = dp / |v_t|``), state
``y = (p, pi_t, W_n)``, ``dy/dsigma = f(y, theta) = (|v_t|, -mu v_t, |v_t| v_n)`` with
``v = v- + W pi``; ``theta`` collects the contact-space data (W's upper triangle, v-, e, mu).
Here the state is integrated together with its sensitivity ``S = dy/dtheta``, which obeys
the variational equations ``dS/dsigma = f_y S + f_theta``::

    dv = W dpi + dW pi + dv-,       d|v_t| = s.dv_t,      s = v_t / |v_t|,
    dS_p = s.dv_t,   dS_pi_t = -mu dv_t - v_t dmu,   dS_Wn = v_n s.dv_t + |v_t| dv_n,

by the same embedded Runge--Kutta pair as the law's own integration (DOP853: the tableau of
:mod:`.stronge_dop853`), the error of every component -- state and sensitivities -- kept below
:data:`SENSITIVITY_RTOL` relative to its scale. The stage's events are located inside the
accepted step by the law's own compiled locator (:func:`~.stronge_dop853._event_length`:
the state's slopes do not depend on the sensitivities), and carry their event
sensitivities: where ``g(y, theta) = 0`` (``g = v_n`` at the end of compression,
``g = W_n - (1 - e^2) W_n(p_c)`` at the end of restitution) the event's ``sigma`` moves by
``dsigma = -(g_y S + g_theta) / (g_y f)``, so the state's total derivative there is
``S + f dsigma``. A decelerating slip is handed to the caller's exact straight finish once its
direction has settled (a tighter test than the law's own, :data:`SETTLE_RTOL`); the hand-over
point is a cut that does not depend on the data, so the sensitivities there are ``S`` itself.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.integrate import solve_ivp

from ...errors import SolverError
from .stronge_dop853 import _A, _B, _E3, _E5, _NE, _NS, _error_norm, _event, _event_length
from .stronge_slip import MAX_STEPS, _onset, _settles  # (MAX_STEPS: the law's bound)

#: local error tolerance of the variational integration (state and sensitivities)
SENSITIVITY_RTOL = 1e-13
#: hand-over to the straight finish: its first-order error in the normal impulse below this
#: times the frictionless compression impulse (the law's own test uses 1e-13)
SETTLE_RTOL = 1e-15
#: slip speed (relative to max |v-|) at which the slip counts as stopped whatever its angle
FLOOR_RTOL = 1e-12
#: a vanishing slip's self-similar stop (events off, |u| = 1, tr W = 1): a slip that neither
#: stops nor grows within this many accepted steps or this much normal impulse does not stop
#: (it slows forever: |W_tt^-1 W_tn| = mu)
MAX_STEPS_SELF_SIMILAR = 500
MAX_IMPULSE_SELF_SIMILAR = 1e3


class SlipSystem:
    """The variational system of one contact's curved slip on normalized data.

    Parameters
    ----------
    W : (3, 3) array, v_minus : (3,) array, mu : float
        The contact's Delassus block, pre-impact velocity and friction.
    W_grad : (m, 3, 3) array
        dW / dtheta_k per parameter (zero for parameters other than W's).
    v_grad : (m, 3) array
        dv- / dtheta_k.
    mu_grad : (m,) array
        dmu / dtheta_k.
    """

    def __init__(self, W, v_minus, mu, W_grad, v_grad, mu_grad):
        self.W = np.asarray(W, dtype=float)
        self.vm = np.asarray(v_minus, dtype=float)
        self.mu = float(mu)
        self.Wg = W_grad
        self.WgT = np.ascontiguousarray(np.transpose(W_grad, (1, 0, 2)))  # (3, m, 3)
        self.vg = v_grad.T  # (3, m)
        self.mug = mu_grad
        self.m = W_grad.shape[0]
        W = self.W  # the compiled kernel's scalars (vn0, vt01, vt02, A, b1, b2, C11, C12, C22)
        self.coefficients = (float(self.vm[0]), float(self.vm[1]), float(self.vm[2]),
                             float(W[0, 0]), float(W[1, 0]), float(W[2, 0]), float(W[1, 1]),
                             float(W[1, 2]), float(W[2, 2]))
        self.K = np.empty((4, _NE))  # the compiled step's scratch

    def velocity(self, z):
        """v and dv/dtheta (3, m) at the augmented state z (4, 1 + m)."""
        pi = z[:3, 0]
        v = self.vm + self.W @ pi
        gv = self.W @ z[:3, 1:] + self.WgT @ pi + self.vg
        return v, gv

    def rhs(self, z):
        """The augmented slope (4, 1 + m): (f, f_y S + f_theta)."""
        v, gv = self.velocity(z)
        vt = v[1:]
        r = math.hypot(vt[0], vt[1])
        out = np.empty_like(z)
        out[0, 0] = r
        out[1:3, 0] = -self.mu * vt
        out[3, 0] = r * v[0]
        gr = (vt @ gv[1:]) / r if r > 0.0 else np.zeros(self.m)
        out[0, 1:] = gr
        out[1:3, 1:] = -self.mu * gv[1:] - vt[:, None] * self.mug
        out[3, 1:] = gr * v[0] + r * gv[0]
        return out

    def step(self, z, f0, h):
        """One DOP853 step of length h: (z_new, the stage slopes (13, 4, 1 + m))."""
        shape = z.shape
        K = np.empty((_NS + 1, z.size))
        K[0] = f0.ravel()
        zf = z.ravel()
        for i in range(1, _NS):
            K[i] = self.rhs((zf + h * (_A[i, :i] @ K[:i])).reshape(shape)).ravel()
        z_new = (zf + h * (_B @ K[:_NS])).reshape(shape)
        K[_NS] = self.rhs(z_new).ravel()
        return z_new, K.reshape((_NS + 1,) + shape)


def _error(h, z, z_new, K, scale):
    """DOP853's error norm (the law's :func:`~.stronge_dop853._error_norm`), each component
    against SENSITIVITY_RTOL (scale + |z|); the sensitivities' columns averaged."""
    sc = SENSITIVITY_RTOL * (scale + np.maximum(np.abs(z), np.abs(z_new)))
    e5 = (h * np.tensordot(_E5, K, axes=1) / sc) ** 2
    e3 = (h * np.tensordot(_E3, K, axes=1) / sc) ** 2
    s5 = float(e5[:, 0].sum() + e5[:, 1:].mean(axis=1).sum()) if z.shape[1] > 1 \
        else float(e5.sum())
    s3 = float(e3[:, 0].sum() + e3[:, 1:].mean(axis=1).sum()) if z.shape[1] > 1 \
        else float(e3.sum())
    return _error_norm(s5, s3)


def _event_value(sys: SlipSystem, z, compressing, target):
    """The law's event function (:func:`~.stronge_dop853._event`) at the state of z."""
    vn0, _, _, A, b1, b2 = sys.coefficients[:6]
    return _event(float(z[0, 0]), float(z[1, 0]), float(z[2, 0]), float(z[3, 0]), compressing,
                  target, vn0, A, b1, b2)


def integrate_slip(sys: SlipSystem, z, compressing: bool, target: float,
                   target_grad: np.ndarray, events: bool = True):
    """Integrate the curved slip with its sensitivities from z (4, 1 + m).

    Returns ``(kind, z)``: ``kind`` "compression" or "restitution" (an event, z its state with
    the event's sensitivity folded in), "settled" (the direction has settled on the one the
    slip stops along: hand over to the straight finish), "floor" (the slip speed reached the
    round-off floor without decreasing: stopped) or, without ``events``, "diverging" (the
    slip grows past 1e3 max |v-|: it does not stop) or "undecided" (neither stops nor grows
    within :data:`MAX_STEPS_SELF_SIMILAR` steps or :data:`MAX_IMPULSE_SELF_SIMILAR`).

    Raises
    ------
    SolverError
        when the slip neither ends nor stops within :data:`MAX_STEPS` steps, or the step size
        underflows.
    """
    W, mu = sys.W, sys.mu
    A = W[0, 0]
    b = W[1:, 0]
    C = W[1:, 1:]
    vm = sys.vm
    pref = -vm[0] / A if vm[0] < 0.0 else 1.0 / A
    vscale = float(np.max(np.abs(vm)))
    scale = np.empty(z.shape)
    scale[:3] = pref
    scale[3] = pref * max(-vm[0], 1e-300)
    f = sys.rhs(z)
    nb = math.hypot(b[0], b[1])
    nc = float(np.linalg.eigvalsh(C)[-1])
    h = 0.05 / (nb + mu * nc + A * f[0, 0] / max(-vm[0], 1e-300 + abs(vm[0])))
    h_floor = 1e-200 * h
    g_old = _event_value(sys, z, compressing, target) if events else -1.0
    steps = 0
    while True:
        z_new, K = sys.step(z, f, h)
        err = _error(h, z, z_new, K, scale)
        if not err <= 1.0:
            if not math.isfinite(err):
                err = 1e10
            h *= max(0.2, 0.9 * err ** -0.125)
            if h <= h_floor:
                raise SolverError("law 'stronge' derivative: the curved slip's sensitivity "
                                  "integration could not meet its tolerance (step size "
                                  "underflow)")
            continue
        steps += 1
        if steps > MAX_STEPS:
            raise SolverError("law 'stronge' derivative: the curved slip did not end or stop "
                              f"within {MAX_STEPS} integration steps")
        if events:
            g_new = _event_value(sys, z_new, compressing, target)
            if g_new >= 0.0 and g_old < 0.0:
                # its length located by the law's own compiled locator on the state's columns
                # (their slopes do not depend on the sensitivities), then the augmented step
                tau = _event_length(*(float(x) for x in z[:, 0]), *(float(x) for x in f[:, 0]),
                                    float(h), float(g_old), float(g_new), bool(compressing),
                                    float(target), sys.K, *sys.coefficients, sys.mu)
                ze, Ke = sys.step(z, f, tau)
                fe = Ke[_NS]
                # the event's sensitivity: dsigma = -(g_y S + g_theta) / (g_y f)
                if compressing:
                    dg = sys.velocity(ze)[1][0]
                    rate = float(W[0, :3] @ fe[:3, 0])
                else:
                    dg = ze[3, 1:] - target_grad
                    rate = float(fe[3, 0])
                ze[:, 1:] -= np.outer(fe[:, 0], dg / rate)
                return ("compression" if compressing else "restitution"), ze
            g_old = g_new
        z, f = z_new, K[_NS]
        v, _ = sys.velocity(z)
        vt = v[1:]
        r = math.hypot(vt[0], vt[1])
        if r == 0.0:
            return "floor", z
        s = vt / r
        a = b - mu * (C @ s)
        rate = float(s @ a)
        settled = _settles(r, s[0], s[1], a[0], a[1], C[0, 0], C[0, 1], C[1, 1], mu,
                           SETTLE_RTOL * pref)
        if not events and rate > 0.0 and r > 1e3 * vscale:
            return "diverging", z
        if not events and rate <= 0.0 and (steps > MAX_STEPS_SELF_SIMILAR
                                           or z[0, 0] > MAX_IMPULSE_SELF_SIMILAR):
            return "undecided", z
        if settled or r <= FLOOR_RTOL * vscale:
            return ("settled" if rate < 0.0 else "floor"), z
        h *= min(10.0, 0.9 * err ** -0.125) if err > 0.0 else 10.0


def turn_offset(b, C, mu, u):
    """A slip started at v_t = u (self-similar: the data's other velocities far away) that
    turns toward the onset direction s* and grows: the offset D = lim (pi_t - pi_t^onset).

    With w = v_t - kappa s* p (kappa s* = b - mu C s*), ``dw/dp = -mu C (s - s*)``; in sigma
    (dp = |v_t| dsigma) ``dw/dsigma = -mu C (w_perp - |w_perp|^2 / (r + a) s*)``,
    a = kappa p + s*.w, r = |v_t| (cancellation-free). For large p this is linear,
    ``dw/dln p = -(mu / kappa) C P_perp w``, whose solutions tend to the component of w
    along s* in the basis (s*, C s*_perp) (the other mode decays like p^-m,
    m = (mu / kappa) s*_perp.C.s*_perp > 0). Integrated until p >= 1e14 (the linearization's
    error ~ 1/p), then projected: w_inf = alpha s*, and D = C^-1 (w_inf - u).
    """
    kappa, s1, s2 = _onset(b[0], b[1], C[0, 0], C[0, 1], C[1, 1], mu)
    s = np.array([s1, s2])
    sp = np.array([-s2, s1])

    def rhs(_, y):
        p, w = y[0], y[1:]
        a = kappa * p + s @ w
        wp = w - (s @ w) * s
        r = math.hypot(a, float(np.linalg.norm(wp)))
        return np.concatenate(([r], -mu * (C @ (wp - (wp @ wp) / (r + a) * s))))

    def big(_, y):
        return y[0] - 1e14
    big.terminal = True
    y = np.concatenate(([0.0], u))
    sigma = 0.0
    for _ in range(100):
        sol = solve_ivp(rhs, (sigma, sigma + 50.0 / kappa), y, method="DOP853", rtol=1e-13,
                        atol=1e-15, events=big)
        y, sigma = sol.y[:, -1], float(sol.t[-1])
        if sol.status == 1:
            break
    alpha = np.linalg.solve(np.column_stack((s, C @ sp)), y[1:])[0]
    return np.linalg.solve(C, alpha * s - u)
