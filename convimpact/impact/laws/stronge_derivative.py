"""The exact derivative of law ``"stronge"``: d pi / d(W, v-, e, mu) of the impulse-space
integration (:mod:`convimpact.impact.laws.stronge`), in the contract of
:class:`~convimpact.impact.derivatives.contact.ContactDerivative`.

The collision's path is re-traced with the kernel's decisions and every quantity carries its
gradient with respect to ``theta = (W's upper triangle, v-, e, mu)``:

* **Linear phases** (planar slip, stick, reversal, onset; the spatial stick and onset, and the
  straight finish of a spatial slip) have constant rates ``dpi_t/dp = lambda``,
  ``dv_n/dp = a_n = W_nn + W_tn.lambda``, ``dv_t/dp = W_tn + W_tt lambda``, each
  differentiated in closed form: slip ``lambda = -mu s`` (``ds = (I - s s^T) dv_t / |v_t|``
  at a hand-over, 0 in the plane), stick ``dlambda = -W_tt^-1 (dW_tn + dW_tt lambda)``, onset
  ``s = (kappa I + mu W_tt)^-1 W_tn`` with ``|s| = 1`` by the implicit function theorem.
* **Every phase switch** is an event ``g(p, theta) = 0`` whose impulse moves by
  ``dp = -(dg) / (dg/dp)``: the slip stop ``|v_t| + rate dp = 0``, the end of compression
  ``v_n + a_n dp = 0``, the end of restitution ``W_n + v_n dp + a_n dp^2 / 2 =
  (1 - e^2) W_n(p_c)`` (whose sensitivity carries ``d((1 - e^2) W_n(p_c))``).
* **The curved spatial slip** by its variational equations, integrated with the state
  (:mod:`convimpact.impact.laws.stronge_sensitivity`), with the events' sensitivities.

Mode boundaries (a slip that stops exactly at the end of compression or of restitution,
``|W_tt^-1 W_tn| = mu`` between stick and slip at rest, a zero pre-impact slip, e = 0,
mu = 0, v_n- = 0) give one-sided derivatives, named in ``one_sided``; ``other_side=True``
re-traces the path with the decisions at those boundaries reversed.
"""

from __future__ import annotations

import math

import numpy as np

from ..derivatives.contact import ContactDerivative
from ..errors import NotSupportedError, ParameterError
from ..problem.build import ImpactProblem
from ..results import ImpactResult
from .stronge_sensitivity import SlipSystem, integrate_slip
from .stronge_slip import JAM_RTOL, STICK_RTOL, STOP_RTOL, _onset

#: two events closer than this (relative to the impulse) are one boundary: the derivative is
#: one-sided there
BOUNDARY_RTOL = 1e-9
#: a zero pre-impact slip's two directional derivatives in v_t closer than this (relative)
#: are one: the derivative is two-sided there
ZERO_SLIP_RTOL = 1e-9
#: the recomputed impulse must agree with the result's to this (relative), else the result is
#: not this problem's answer of law "stronge"
CONSISTENCY_RTOL = 1e-7


class _Path:
    """One contact's path in impulse space (normalized data) with the gradients of its state
    ``(p, pi_t, W_n)`` with respect to theta = (W upper triangle, v-, e, mu)."""

    def __init__(self, W, v, e, mu, flip=False, zero_sign=None):
        d = W.shape[0]
        self.d, self.dt = d, d - 1
        self.W, self.vm, self.e, self.mu = W, v, e, mu
        iu = list(zip(*np.triu_indices(d)))
        self.iu = iu
        nw = len(iu)
        self.iv = np.arange(nw, nw + d)
        self.ie, self.imu = nw + d, nw + d + 1
        m = self.m = nw + d + 2
        Wg = np.zeros((m, d, d))
        for k, (i, j) in enumerate(iu):
            Wg[k, i, j] = Wg[k, j, i] = 1.0
        self.Wg = Wg
        self.vg = np.zeros((m, d))
        self.vg[self.iv, np.arange(d)] = 1.0
        self.unit_e = np.zeros(m)
        self.unit_e[self.ie] = 1.0
        self.unit_mu = np.zeros(m)
        self.unit_mu[self.imu] = 1.0
        self.A, self.b, self.C = W[0, 0], W[1:, 0], W[1:, 1:]
        self.gA, self.gb, self.gC = Wg[:, 0, 0], Wg[:, 1:, 0].T, Wg[:, 1:, 1:]
        self.tr = float(np.trace(W))
        self.flip = flip
        # zero pre-impact slip: the side (+1: v_t along +t) of the directional derivative
        self.zero_sign = zero_sign if zero_sign is not None else (-1.0 if flip else 1.0)
        self.zero_slip = False
        self.p, self.pt, self.Wn = 0.0, np.zeros(d - 1), 0.0
        self.vn, self.vt = float(v[0]), np.array(v[1:], dtype=float)
        self.gp, self.gpt, self.gWn = np.zeros(m), np.zeros((d - 1, m)), np.zeros(m)
        self.compressing, self.done = True, False
        self.target, self.gtarget = 0.0, np.zeros(m)
        self.phases: list[str] = []
        self.boundaries: list[str] = []

    # -- the state's velocity and the phases' rates, with their gradients

    def gvel(self) -> np.ndarray:
        """dv / dtheta (d, m) at the current state."""
        pi = np.concatenate(([self.p], self.pt))
        gpi = np.vstack((self.gp, self.gpt))
        return self.W @ gpi + (self.Wg @ pi).T + self.vg.T

    def rates(self, lam, glam):
        """(a_n, da_n, a_t, da_t) of a linear phase with dpi_t/dp = lam."""
        an = self.A + self.b @ lam
        gan = self.gA + self.Wg[:, 0, 1:] @ lam + self.b @ glam
        at = self.b + self.C @ lam
        gat = self.gb + (self.gC @ lam).T + self.C @ glam
        return an, gan, at, gat

    def boundary(self, text: str, near: bool) -> bool:
        """Record a boundary statement when ``near``; True when the decision is to be reversed."""
        if near:
            if text not in self.boundaries:
                self.boundaries.append(text)
            return self.flip
        return False

    def _open(self, kind):
        if not self.phases or self.phases[-1] != kind:
            self.phases.append(kind)

    # -- events

    def stage_event(self, an, lam):
        """End of compression (restitution starts; the target (1 - e^2) W_n(p_c)) or of
        restitution (the collision ends). ``an``, ``lam``: the rates active after it."""
        if self.compressing:
            e = self.e
            self.compressing = False
            self.vn = 0.0
            self.target = (1.0 - e * e) * self.Wn
            self.gtarget = (1.0 - e * e) * self.gWn - 2.0 * e * self.Wn * self.unit_e
            if not self.target > self.Wn:  # e = 0: nothing to restitute
                self.done = True
                if e == 0.0:
                    self.boundary("e = 0: d pi / d e is the right derivative (e -> 0+), "
                                  "p_f - p_c = e sqrt(2 |W_n(p_c)| / a_n) + O(e^2)", True)
                    if an > 0.0:
                        k = math.sqrt(2.0 * abs(self.Wn) / an)
                        self.gp = self.gp + k * self.unit_e
                        self.gpt = self.gpt + np.outer(lam, k * self.unit_e)
        else:
            self.Wn = self.target
            self.done = True

    def run_linear(self, kind, lam, glam, stop=math.inf, gstop=None):
        """One linear phase until its slip stops after ``stop`` (inf: never) or the collision
        ends (the kernel's ``_run_linear``), the gradients through the events' sensitivities."""
        self._open(kind)
        an, gan, at, gat = self.rates(lam, glam)
        gstop = np.zeros(self.m) if gstop is None else gstop
        while True:
            gvn = self.gvel()[0]
            if self.compressing:
                if an > JAM_RTOL * self.tr:
                    end = max(-self.vn / an, 0.0)
                    gend = -(gvn + end * gan) / an
                else:
                    end, gend = math.inf, np.zeros(self.m)
            else:
                D = self.target - self.Wn
                vp = max(self.vn, 0.0)
                disc = vp * vp + 2.0 * an * D
                if D <= 0.0:
                    end = 0.0
                else:
                    end = math.inf if disc < 0.0 else 2.0 * D / (vp + math.sqrt(disc))
                den = self.vn + an * end
                gend = (-(self.gWn + end * gvn + 0.5 * end * end * gan - self.gtarget) / den
                        if den > 0.0 else np.zeros(self.m))
            stops = stop <= end
            # a slip stopping exactly at the end of restitution: slip throughout on one side,
            # a vanishing stick (or reversal) on the other, with another d pi_t. (Stopping at
            # the end of compression is no boundary of the impulse: W_n(p_c) = min W_n is
            # stationary in p, so the kink of p_c(theta) does not reach p_f or pi_t.)
            if not self.compressing and math.isfinite(stop) and math.isfinite(end):
                near = abs(stop - end) <= BOUNDARY_RTOL * (self.p + max(stop, end))
                if self.boundary("the slip stops at the end of restitution: one-sided (slip "
                                 "throughout on one side, a vanishing last phase on the "
                                 "other)", near):
                    stops = not stops
            if stops and not math.isfinite(stop):
                raise ParameterError("law 'stronge' derivative: this contact jams (the kernel "
                                     "raises NonPositiveEffectiveMassError for it)")
            dp, gdp = (stop, gstop) if stops else (end, gend)
            self.gWn = self.gWn + gdp * (self.vn + an * dp) + dp * gvn + 0.5 * dp * dp * gan
            self.Wn += dp * (self.vn + 0.5 * an * dp)
            self.vn += an * dp
            self.p += dp
            self.gp = self.gp + gdp
            self.pt = self.pt + lam * dp
            self.gpt = self.gpt + np.outer(lam, gdp) + dp * glam
            self.vt = self.vt + at * dp
            if stops:
                self.vt = np.zeros(self.dt)
                return True
            stop -= end
            gstop = gstop - gend
            self.stage_event(an, lam)
            if self.done:
                return False

    # -- the phases

    def slip(self, s, gs, kind="slip"):
        """A linear slip along s (fixed), stopping where |v_t| + rate dp = 0 if it slows."""
        lam = -self.mu * s
        glam = -np.outer(s, self.unit_mu) - self.mu * gs
        _, _, at, gat = self.rates(lam, glam)
        rate = float(s @ at)
        if rate < 0.0:
            r = float(s @ self.vt)
            if self.dt == 1:
                stop = -self.vt[0] / at[0]  # the kernel's expression
            else:
                stop = r / -rate
            gr = s @ self.gvel()[1:] + self.vt @ gs
            grate = at @ gs + s @ gat
            gstop = -(gr + stop * grate) / rate
            return self.run_linear(kind, lam, glam, stop, gstop)
        return self.run_linear(kind, lam, glam)

    def at_rest(self, s0):
        """Stick, or slip from rest along the selected direction (the kernel's decision)."""
        A, b, C, mu = self.A, self.b, self.C, self.mu
        Ci = np.linalg.inv(C)
        lam_s = -Ci @ b
        x = float(np.linalg.norm(lam_s))
        stick = x <= mu * (1.0 + STICK_RTOL)
        near = abs(x - mu) <= BOUNDARY_RTOL * max(mu, x) and mu > 0.0
        if self.boundary("|W_tt^-1 W_tn| = mu: at rest, between stick and slip (one-sided; "
                         "the other side slips along W_tn's direction)", near):
            stick = not stick
        if stick:
            glam = -Ci @ (self.gb + (self.gC @ lam_s).T)
            return self.run_linear("stick", lam_s, glam)
        kind = "reversal" if s0 and self.dt == 1 else "onset"  # the kernel's names
        if self.dt == 1:
            s = np.array([math.copysign(1.0, b[0])])
            return self.slip(s, np.zeros((1, self.m)), kind)
        if near:
            kappa, s = 0.0, -lam_s / x  # the boundary's limit of the onset direction
        elif mu == 0.0:
            kappa, s = float(np.linalg.norm(b)), b / float(np.linalg.norm(b))
        else:
            kappa, s1, s2 = _onset(b[0], b[1], C[0, 0], C[0, 1], C[1, 1], mu)
            s = np.array([s1, s2])
        # s = (kappa I + mu C)^-1 b, |s| = 1: implicit differentiation
        Mi = np.linalg.inv(kappa * np.eye(2) + mu * C)
        R = self.gb - np.outer(C @ s, self.unit_mu) - mu * (self.gC @ s).T
        q = Mi @ s
        gk = (q @ R) / (s @ q)
        gs = Mi @ (R - np.outer(s, gk))
        return self.slip(s, gs, kind)

    def curved(self):
        """The spatial curved slip by its variational equations, then its straight finish."""
        sys = SlipSystem(self.W, self.vm, self.mu, self.Wg, self.vg, self.unit_mu)
        while True:
            z = np.empty((4, 1 + self.m))
            z[:, 0] = (self.p, self.pt[0], self.pt[1], self.Wn)
            z[0, 1:], z[1:3, 1:], z[3, 1:] = self.gp, self.gpt, self.gWn
            kind, z = integrate_slip(sys, z, self.compressing, self.target, self.gtarget)
            self.p, self.pt, self.Wn = float(z[0, 0]), z[1:3, 0].copy(), float(z[3, 0])
            self.gp, self.gpt, self.gWn = z[0, 1:].copy(), z[1:3, 1:].copy(), z[3, 1:].copy()
            v = self.vm + self.W @ z[:3, 0]
            self.vn, self.vt = float(v[0]), v[1:].copy()
            self._open("slip")
            if kind in ("compression", "restitution"):
                r = float(np.linalg.norm(self.vt))
                s = self.vt / r
                self.stage_event(self.A - self.mu * float(self.b @ s), -self.mu * s)
                if self.done:
                    return
                continue
            if kind == "floor":
                self.vt = np.zeros(2)
                return
            r = float(np.linalg.norm(self.vt))
            s = self.vt / r
            gvt = self.gvel()[1:]
            gs = (gvt - np.outer(s, s @ gvt)) / r
            self.slip(s, gs)
            return

    def run(self):
        """The whole path (the kernel's loop); returns (pi, dpi/dtheta (d, m))."""
        d = self.d
        vscale = float(np.max(np.abs(self.vm)))
        if d == 2:
            rest = self.vt[0] == 0.0
        else:
            rest = float(np.linalg.norm(self.vt)) <= STOP_RTOL * vscale
        s0 = not rest
        if rest and float(np.linalg.norm(self.vt)) == 0.0 and self.mu > 0.0:
            self.boundary("zero pre-impact slip: d pi / d v_t is one-sided, the directional "
                          "derivative along +t (each tangent's +direction in space; the other "
                          "side: along -t)", True)
            self._zero_slip_start()
        elif rest:
            self.vt = np.zeros(self.dt)
        while not self.done:
            if rest:
                self.at_rest(s0)
                rest = True
            elif d == 2:
                s = np.array([math.copysign(1.0, self.vt[0])])
                rest = self.slip(s, np.zeros((1, self.m)))
            else:
                self.curved()
                rest = not self.done
        pi = np.concatenate(([self.p], self.pt))
        return pi, np.vstack((self.gp, self.gpt))

    def _zero_slip_start(self):
        """v_t- = 0: the directional derivative along +-t of each tangent. A slip started at
        eps u (u a tangent's unit vector) stops after eps dp_u of normal impulse (dp_u = 0 when
        it grows: the onset along u), then the path from rest; to first order the state at
        that stop is eps (dp_u, dpi_t_u, v_n- dp_u)."""
        self.zero_slip = True
        sign = self.zero_sign
        for j in range(self.dt):
            u = np.zeros(self.dt)
            u[j] = sign
            dp, dpt = self._stop_from(u)
            col = self.iv[1 + j]
            self.gp[col] = sign * dp
            self.gpt[:, col] = sign * dpt
            self.gWn[col] = sign * self.vm[0] * dp

    def _stop_from(self, u):
        """(dp, dpi_t) until a slip started at v_t = u (with v_n far from its events) stops;
        when it does not stop (it turns toward the onset direction and grows), (0, the
        offset of its tangential impulse from the onset path's, :func:`_turn_offset`)."""
        b, C, mu = self.b, self.C, self.mu
        if self.dt == 1:
            at = b[0] - mu * C[0, 0] * u[0]
            if u[0] * at < 0.0:
                dp = -u[0] / at
                return dp, np.array([-mu * u[0] * dp])
            return 0.0, np.zeros(1)
        W = self.W.copy()
        v = np.concatenate(([-1.0], u))  # v_n plays no part without events
        m0 = np.zeros((0, 3, 3))
        sys = SlipSystem(W, v, mu, m0, np.zeros((0, 3)), np.zeros(0))
        z = np.zeros((4, 1))
        a = b - mu * (C @ u)
        if float(u @ a) >= 0.0 and abs(u[0] * a[1] - u[1] * a[0]) <= 1e-14 * np.abs(a).sum():
            return 0.0, np.zeros(2)
        kind, z = integrate_slip(sys, z, True, 0.0, np.zeros(0), events=False)
        if kind == "diverging":
            return 0.0, _turn_offset(b, C, mu, u)
        vt = u + b * z[0, 0] + C @ z[1:3, 0]
        r = float(np.linalg.norm(vt))
        if kind == "settled" and r > 0.0:
            s = vt / r
            at = b - mu * (C @ s)
            dp = r / -float(s @ at)
            return float(z[0, 0]) + dp, z[1:3, 0] - mu * s * dp
        return float(z[0, 0]), z[1:3, 0].copy()


def _turn_offset(b, C, mu, u):
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
    from scipy.integrate import solve_ivp
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


def _tensor_W(path: _Path, g: np.ndarray) -> np.ndarray:
    """dpi/dW (d, d, d) from the gradient over W's upper triangle: a symmetric pair's weight
    split evenly between its two entries."""
    d = path.d
    out = np.zeros((g.shape[0], d, d))
    for k, (i, j) in enumerate(path.iu):
        if i == j:
            out[:, i, i] = g[:, k]
        else:
            out[:, i, j] = out[:, j, i] = 0.5 * g[:, k]
    return out


def contact_derivative(W, v, e: float, mu: float, other_side: bool = False
                       ) -> tuple[np.ndarray, ContactDerivative]:
    """One contact's impulse and its derivative (contact space, unnormalized data).

    Returns ``(pi, ContactDerivative)``; the derivative is that of the mode the answer is in,
    or with ``other_side`` of the neighbouring mode at the boundaries met (its ``other_side``
    is then None).
    """
    W = np.asarray(W, dtype=float)
    v = np.asarray(v, dtype=float)
    d = W.shape[0]
    vs = float(np.max(np.abs(v)))
    ws = float(np.trace(W))
    if not v[0] < 0.0:
        return np.zeros(d), _separating(W, v, e, mu, vs, ws, other_side)
    Wh, vh = W / ws, v / vs
    path = _Path(Wh, vh, e, mu, flip=other_side)
    pi_h, g = path.run()
    if path.zero_slip:
        # both directional derivatives in v_t agree (a contact that sticks from the start):
        # the derivative is two-sided there
        twin = _Path(Wh, vh, e, mu, flip=other_side, zero_sign=-path.zero_sign)
        _, g2 = twin.run()
        cols = path.iv[1:]
        if np.max(np.abs(g2[:, cols] - g[:, cols])) <= ZERO_SLIP_RTOL * max(
                float(np.max(np.abs(g))), 1e-300):
            path.boundaries = [t for t in path.boundaries if not t.startswith("zero pre")]
    if mu == 0.0:
        path.boundaries.append("mu = 0: d pi / d mu is the right derivative (mu -> 0+)")
        regime = "frictionless"
    else:
        regime = "-".join(path.phases)
    scale = vs / ws
    pi = scale * pi_h
    dW = _tensor_W(path, g) * (scale / ws)
    dv = g[:, path.iv] / ws
    de = (g[:, path.ie] * scale)[:, None]
    dmu = (g[:, path.imu] * scale)[:, None]
    deriv = ContactDerivative(W=dW, v=dv, e=de, mu=dmu, e_t=None, regimes=(regime,),
                              one_sided=tuple(path.boundaries))
    return pi, deriv


def _separating(W, v, e, mu, vs, ws, other_side) -> ContactDerivative:
    """A contact that does not approach takes no impulse: zero derivative; at v_n- = 0 the
    other side is the approaching limit, pi = -v_n (1 + e) (1, lambda) / a_n + o(v_n) with the
    rates of the path's first phase."""
    d = W.shape[0]
    zero = ContactDerivative(W=np.zeros((d, d, d)), v=np.zeros((d, d)), e=np.zeros((d, 1)),
                             mu=np.zeros((d, 1)), e_t=None, regimes=("separating",))
    if v[0] > 0.0 or vs == 0.0:
        return zero
    text = ("v_n- = 0: the contact touches without approaching; d pi / d v_n is one-sided "
            "(the other side: the approaching limit)")
    if not other_side:
        return ContactDerivative(W=zero.W, v=zero.v, e=zero.e, mu=zero.mu, e_t=None,
                                 regimes=("separating",), one_sided=(text,))
    path = _Path(W / ws, np.concatenate(([-1.0], v[1:] / vs)), e, mu)
    vt = path.vt
    if d == 2 and vt[0] != 0.0:
        lam = np.array([-mu * math.copysign(1.0, vt[0])])
    elif d == 3 and float(np.linalg.norm(vt)) > 0.0:
        lam = -mu * vt / float(np.linalg.norm(vt))
    else:
        Ci = np.linalg.inv(path.C)
        lam = -Ci @ path.b
        x = float(np.linalg.norm(lam))
        if x > mu:
            if d == 2:
                lam = np.array([-mu * math.copysign(1.0, path.b[0])])
            else:
                _, s1, s2 = _onset(*path.b, path.C[0, 0], path.C[0, 1], path.C[1, 1], mu)
                lam = -mu * np.array([s1, s2])
    an = path.A + float(path.b @ lam)
    dv = np.zeros((d, d))
    dv[:, 0] = -(1.0 + e) * np.concatenate(([1.0], lam)) / (an * ws)
    return ContactDerivative(W=zero.W, v=dv, e=zero.e, mu=zero.mu, e_t=None,
                             regimes=("approaching limit",), one_sided=(text,))


def _check(problem: ImpactProblem, result: ImpactResult, pi: np.ndarray, i: int) -> None:
    if getattr(result, "law", "stronge") != "stronge":
        raise ParameterError(f"law 'stronge' derivative: the result is of law {result.law!r}")
    got = np.asarray(result.impulse, dtype=float).reshape(problem.n_contacts, problem.dim)[i]
    scale = max(float(np.max(np.abs(got))), float(np.max(np.abs(pi))), 1e-300)
    if float(np.max(np.abs(got - pi))) > CONSISTENCY_RTOL * scale:
        raise ParameterError(
            f"law 'stronge' derivative: the result's impulse {got.tolist()} is not this "
            f"problem's answer {pi.tolist()} (pass the result of solving this problem)")


def _with_other(problem, i, other_side):
    W, v = (np.array(x, dtype=float) for x in problem.contact_lists(i))
    e, mu = float(problem.restitution[i]), float(problem.friction[i])
    pi, deriv = contact_derivative(W, v, e, mu)
    if other_side and deriv.one_sided:
        _, other = contact_derivative(W, v, e, mu, other_side=True)
        deriv = ContactDerivative(W=deriv.W, v=deriv.v, e=deriv.e, mu=deriv.mu, e_t=None,
                                  regimes=deriv.regimes, one_sided=deriv.one_sided,
                                  other_side=other)
    return pi, deriv


def impulse_derivative(problem: ImpactProblem, result: ImpactResult,
                       other_side: bool = False) -> ContactDerivative:
    """The derivative of Stronge's impulse of one contact with respect to ``(W, v-, e, mu)``.

    Parameters
    ----------
    problem : ImpactProblem
        The impact (one contact, planar or spatial).
    result : ImpactResult
        Its answer under law ``"stronge"`` (any method).
    other_side : bool
        At a mode boundary, also give the neighbouring mode's derivative
        (``.other_side``).

    Returns
    -------
    ContactDerivative
        ``regimes`` names the path's phases (e.g. ``"slip-stick"``); ``one_sided`` the
        boundaries met.

    Raises
    ------
    NotSupportedError
        for several contacts (see :func:`several_impulse_derivative`).
    ParameterError
        when ``result`` is not this problem's answer of law ``"stronge"``.
    """
    if problem.n_contacts != 1:
        raise NotSupportedError("impulse_derivative treats one contact; for "
                                f"{problem.n_contacts} use several_impulse_derivative")
    pi, deriv = _with_other(problem, 0, other_side)
    _check(problem, result, pi, 0)
    return deriv


def several_impulse_derivative(problem: ImpactProblem, result: ImpactResult,
                               other_side: bool = False) -> ContactDerivative:
    """The derivative of Stronge's impulses at several contacts.

    Exact where the law is: dynamically independent contacts (block-diagonal W, each contact's
    derivative by :func:`impulse_derivative`'s path, the off-diagonal blocks' derivative that
    of the independent answer) and one approaching contact whose impulse lifts the others.

    Raises
    ------
    NotSupportedError
        for coupled contacts resolved by the two-phase formulation
        (:mod:`convimpact.impact.laws.stronge_contacts`), whose derivative is not provided.
    """
    from ..exact.dispatch import coupled
    n, d = problem.n_contacts, problem.dim
    extras = getattr(result.diagnostics, "extras", None) or {}
    formulation = str(extras.get("formulation", ""))
    if coupled(problem) and not formulation.startswith("one approaching contact"):
        raise NotSupportedError(
            "law 'stronge' on coupled contacts (the two-phase compression / expansion "
            "formulation of stronge_contacts) has no derivative; use law 'ccp' or "
            "'dissipative' for derivatives of several coupled contacts")
    N = n * d
    out = {k: np.zeros(s) for k, s in (("W", (N, N, N)), ("v", (N, N)), ("e", (N, n)),
                                       ("mu", (N, n)))}
    other = {k: v.copy() for k, v in out.items()}
    regimes, sided, any_other = [], [], False
    for i in range(n):
        sl = slice(i * d, (i + 1) * d)
        pi, dc = _with_other(problem, i, other_side)
        if formulation.startswith("one approaching contact") and not problem.approaching[i]:
            pi, dc = np.zeros(d), _separating(*(np.array(x, dtype=float) for x in
                                               problem.contact_lists(i)), 0.0, 0.0, 1.0,
                                             1.0, False)
        _check(problem, result, pi, i)
        regimes.append(dc.regimes[0])
        sided.extend(f"contact {i}: {t}" for t in dc.one_sided)
        for tgt, src in ((out, dc), (other, dc.other_side or dc)):
            tgt["W"][sl, sl, sl] = src.W
            tgt["v"][sl, sl] = src.v
            tgt["e"][sl, i] = src.e[:, 0]
            tgt["mu"][sl, i] = src.mu[:, 0]
        any_other = any_other or dc.other_side is not None
    if formulation.startswith("one approaching contact"):
        vp = np.asarray(result.v_plus, dtype=float).reshape(n, d)[:, 0]
        vscale = float(np.max(np.abs(problem.v_minus)))
        for j in range(n):
            if not problem.approaching[j] and abs(vp[j]) <= BOUNDARY_RTOL * vscale:
                sided.append(
                    f"contact {j} lifts with v_n+ = 0: one-sided (driven any further, it "
                    "would approach and the coupled two-phase formulation, which has no "
                    "derivative, would take over)")
    side = (ContactDerivative(e_t=None, regimes=tuple(regimes), **other)
            if other_side and any_other else None)
    return ContactDerivative(e_t=None, regimes=tuple(regimes), one_sided=tuple(sided),
                             other_side=side, **out)
