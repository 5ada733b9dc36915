"""Law ``"stronge"``: one contact's path in impulse space re-traced with the gradients of its
state -- the differentiated counterpart of the kernels of :mod:`.stronge` and
:mod:`.stronge_slip` (the same decisions, the same phases), used by
:mod:`convimpact.impact.laws.stronge_derivative` (which states the method)."""

from __future__ import annotations

import math

import numpy as np

from ...errors import ParameterError
from .stronge_sensitivity import SlipSystem, integrate_slip, turn_offset
from .stronge_slip import JAM_RTOL, STICK_RTOL, STOP_RTOL, _onset

#: the statement of a zero pre-impact slip (dropped when both sides agree)
ZERO_SLIP = ("zero pre-impact slip (within round-off): d pi / d v_t is one-sided, the "
             "directional derivative along +t (each tangent's +direction in space; in the "
             "plane, along a round-off slip's sign), the other side along the opposite")
#: two events closer than this (relative to the impulse) are one boundary: the derivative is
#: one-sided there
BOUNDARY_RTOL = 1e-9


def symmetric_tensor(G: np.ndarray, N: int) -> np.ndarray:
    """dpi/dW (rows, N, N) from G's first columns, the gradient over W's upper triangle
    (``np.triu_indices`` order): a symmetric pair's weight split evenly between its entries."""
    out = np.zeros((G.shape[0], N, N))
    for k, (i, j) in enumerate(zip(*np.triu_indices(N))):
        if i == j:
            out[:, i, i] = G[:, k]
        else:
            out[:, i, j] = out[:, j, i] = 0.5 * G[:, k]
    return out


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
        eye = np.eye(m)
        self.vg = eye[:, self.iv]
        self.unit_e, self.unit_mu = eye[self.ie], eye[self.imu]
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
        self.sided: set[str] = set()  # the boundaries that have another side

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

    def boundary(self, text: str, near: bool, sided: bool = True) -> bool:
        """Record a boundary statement when ``near``; True when the decision is to be reversed.
        ``sided``: the boundary has a neighbouring mode (not e = 0, nor an undefined one)."""
        if near:
            if text not in self.boundaries:
                self.boundaries.append(text)
            if sided:
                self.sided.add(text)
            return self.flip and sided
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
                                  "p_f - p_c = e sqrt(2 |W_n(p_c)| / a_n) + O(e^2)", True,
                                  sided=False)
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

    def slip(self, s, gs, kind="slip", from_rest=False):
        """A linear slip along s (fixed), stopping where |v_t| + rate dp = 0 if it slows (not
        one from rest: it grows along s, the kernel's onset and reversal)."""
        lam = -self.mu * s
        glam = -np.outer(s, self.unit_mu) - self.mu * gs
        _, _, at, gat = self.rates(lam, glam)
        rate = float(s @ at)
        if rate < 0.0 and not from_rest:
            # (in the plane, the kernel's expression)
            stop = -self.vt[0] / at[0] if self.dt == 1 else float(s @ self.vt) / -rate
            gr = s @ self.gvel()[1:] + self.vt @ gs
            grate = at @ gs + s @ gat
            gstop = -(gr + stop * grate) / rate
            return self.run_linear(kind, lam, glam, stop, gstop)
        return self.run_linear(kind, lam, glam)

    def at_rest(self, s0):
        """Stick, or slip from rest along the selected direction (the kernel's decision)."""
        b, C, mu = self.b, self.C, self.mu
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
            return self.slip(s, np.zeros((1, self.m)), kind, from_rest=True)
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
        return self.slip(s, gs, kind, from_rest=True)

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
            if kind == "floor":
                self.vt = np.zeros(2)
                return
            r = float(np.linalg.norm(self.vt))
            s = self.vt / r
            if kind == "settled":
                gvt = self.gvel()[1:]
                self.slip(s, (gvt - np.outer(s, s @ gvt)) / r)
                return
            self.stage_event(self.A - self.mu * float(self.b @ s), -self.mu * s)  # an event
            if self.done:
                return

    def run(self):
        """The whole path (the kernel's loop); returns (pi, dpi/dtheta (d, m))."""
        d = self.d
        tiny = float(np.linalg.norm(self.vt)) <= STOP_RTOL * float(np.max(np.abs(self.vm)))
        rest = self.vt[0] == 0.0 if d == 2 else tiny
        s0 = not rest
        if rest and self.mu > 0.0:
            self.boundary(ZERO_SLIP, True)
            self._zero_slip_start()
        elif tiny and self.mu > 0.0:
            # a planar slip within round-off of zero: the kernel's path (a vanishing slip) is
            # the directional derivative along its sign; the mirrored slip's the other side
            self.boundary(ZERO_SLIP, True)
            self.zero_slip = True
            if self.zero_sign < 0.0:
                self.vt = -self.vt
        if rest:
            self.vt = np.zeros(self.dt)
        while not self.done:
            if rest:
                self.at_rest(s0)
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
            return 0.0, turn_offset(b, C, mu, u)
        if kind == "undecided":
            self.boundary(
                "zero pre-impact slip with |W_tt^-1 W_tn| = mu: a slip started along a "
                "tangent slows without stopping, so the impulse has no directional derivative "
                "in v_t here; the v_t columns are those of the path held at rest", True,
                sided=False)
            return 0.0, np.zeros(2)
        vt = u + b * z[0, 0] + C @ z[1:3, 0]
        r = float(np.linalg.norm(vt))
        if kind == "settled" and r > 0.0:
            s = vt / r
            at = b - mu * (C @ s)
            dp = r / -float(s @ at)
            return float(z[0, 0]) + dp, z[1:3, 0] - mu * s * dp
        return float(z[0, 0]), z[1:3, 0].copy()
