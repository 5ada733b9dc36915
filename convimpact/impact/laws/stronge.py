"""Stronge's energetic restitution by impulse-space integration (Darboux--Keller).

The collision is followed through the normal impulse ``p = p_n`` as a time-like variable
(Keller 1986; Stronge 1990, 2000). With the contact-frame impulse ``pi(p) = (p, pi_t(p))`` the
contact velocity is ``v(p) = v- + W pi(p)`` (W = Jc G Jc^T, normal first, approaching
``v_n- < 0``), and Coulomb friction acts against the *current* slip throughout::

    dpi_t / dp = lambda,   |lambda| <= mu,
    slipping (v_t != 0):   lambda = -mu s,  s = v_t / |v_t|,   so  dv/dp = W (n - mu s),
    sticking (v_t == 0):   lambda = -W_tt^-1 W_tn  (keeps v_t = 0), admissible iff |lambda| <= mu.

Writing ``W = [[A, b^T], [b, C]]`` (A = W_nn, b = W_tn, C = W_tt): while sticking,
``dv_t = b dp + C dpi_t = 0`` gives the *sticking ratio* ``lambda_s = -C^-1 b`` (in the plane
``-W_tn / W_tt``), and ``dv_n / dp = A - b^T C^-1 b = det W / det C > 0``. When the slip
reaches zero and ``|C^-1 b| > mu`` the contact cannot stick; it slips on in the direction
``s`` the dynamics select, the one whose tangential acceleration ``b - mu C s = kappa s`` is
along ``s`` with ``kappa > 0``: ``s = (kappa I + mu C)^-1 b`` with ``kappa > 0`` the unique
root of ``|(kappa I + mu C)^-1 b| = 1`` (``|.|`` decreases from ``|C^-1 b| / mu > 1`` to 0;
solved by safeguarded Newton in C's eigenbasis). That ray is invariant (the acceleration is
constant along it), so the slip then grows linearly in p. In the plane this is the slip
reversal ``s = sgn(W_tn)``, ``kappa = |W_tn| - mu W_tt``.

Compression ends at ``p_c`` where ``v_n(p_c) = 0``; restitution ends at ``p_f`` where the work
of the normal impulse in restitution is ``e^2`` times minus its work in compression::

    W_n(p) = int_0^p v_n dp',     W_n(p_f) - W_n(p_c) = -e^2 W_n(p_c).

The impulse is ``pi = (p_f, pi_t(p_f))``. Energy is never created:
``T+ - T- = W_n(p_f) - mu int |v_t| dp = (1 - e^2) W_n(p_c) - mu int |v_t| dp <= 0``. With
``mu = 0`` or ``W_tn = 0`` the normal impulse is Newton's, ``(1 + e) p_c`` with
``p_c = -v_n- / W_nn``.

One contact, planar -- exact. Every phase is linear in p: slip (``lambda = -mu s``), stick
(``lambda = -W_tn / W_tt`` when ``|W_tn| <= mu W_tt``), reversal (``s = sgn W_tn`` otherwise).
A slip stops at ``p_s = |v_t| / (mu W_tt - s W_tn)`` when that is positive; at most two
phases occur. Compression ends at a root of a linear function, restitution at the smaller
positive root of the quadratic ``W_n(p) = (1 - e^2) W_n(p_c)`` (written cancellation-free):
closed forms, accurate to round-off.

One contact, spatial -- exact in its linear phases (stick, and slip along an invariant ray:
an onset from rest, or a pre-impact slip already on such a ray), integrated in its curved
one. A pre-impact slip off the invariant rays turns as it slows; ``dv_t/dp = b - mu C s`` is
discontinuous at ``v_t = 0``, where the slip stops at a finite ``p`` with a non-analytic
(fractional-power) approach. The slip is therefore integrated in the variable ``sigma``,
``dsigma = dp / |v_t|``, in which ``dv_t/dsigma = |v_t| b - mu C v_t`` is smooth (Lipschitz,
analytic away from 0) and the stop is an exponential decay (reached as ``sigma -> inf``):
the state ``(p, pi_t, W_n)`` obeys ``dp/dsigma = |v_t|``, ``dpi_t/dsigma = -mu v_t``,
``dW_n/dsigma = |v_t| v_n`` with ``v = v- + W pi``. It is integrated by an embedded
Runge--Kutta pair of order 8(5,3) (Dormand--Prince DOP853: the coefficients of
scipy.integrate's DOP853, our own step loop on plain floats).

**Error control.** Each step's local error estimate is kept below ``ODE_RTOL = 1e-13`` times
``|y| + (p_0, p_0, p_0, |v_n-| p_0)``, ``p_0 = |v_n-| / W_nn`` the frictionless compression
impulse (absolute on impulses and work at that scale, relative beyond it). The events
``v_n = 0`` (end of compression) and ``W_n = (1 - e^2) W_n(p_c)`` (end of restitution) are
located inside the accepted step by bracketed Newton iterations on the step length, each
re-taking the step (so to the method's own accuracy; |dsigma| <= 1e-13 h). A decelerating
slip is handed to the exact straight finish of a linear phase (its last ``|v_t| / |h|`` of
impulse, h = s.(b - mu C s) < 0, with the stop and the events in it exact) once its direction
has settled on the one it stops along: the straight finish misses
``|v_t| |dh/dphi| dphi / (|h| (|h| + |dg/dphi|))`` of normal impulse (first order of the
tail in the angle dphi ~ |g / g'| left, g = s_perp.(b - mu C s)), and the hand-over waits
until that is below ``1e-13 p_0`` with dphi <= 1e-3, or until ``|v_t| <= 1e-10 |v-|`` (the
integration's round-off floor). The stick / onset decision is then taken at ``v_t = 0``.
Measured (tests/impact/test_stronge.py and 400 random systems): against the same kernel at
``ODE_RTOL = 1e-15`` the impulses agree to 2e-11 relative (median 3e-15), against an
independent solve_ivp integration in p to 7e-11 (the latter's own error; median 1e-13); the
energetic condition holds to 4e-11 by quadrature of the independent path. We state 1e-10
(:data:`~convimpact.impact.fast.FAST_TOL`). Cost (CPython, measured through
:func:`~convimpact.impact.fast.solve_contact` on random systems): a spatial impact takes
15-30 steps (median 17; up to a few hundred for stiff slips, ``mu |W_tt| >> |h|``), about
0.8 ms (median; 2.6 ms at worst of 40) against 15-30 us for the other laws' kernels; a
planar one about 23 us against 5-11 us.

A collision that cannot end raises :class:`NonPositiveEffectiveMassError` (a Painleve-like
jam): a phase in which ``dv_n/dp = W_nn - mu W_tn . s <= 0`` before compression ends, or in
which the contact re-approaches (``v_n < 0``) during restitution before the energy condition
is met. A singular W where the stick / onset decision needs ``C^-1 b`` or ``det W / det C``
raises :class:`SingularSystemError`.

Several contacts. Impacts whose contacts are dynamically independent (the off-diagonal
blocks of W vanish, |W_ij| <= 1e-12 times the diagonal scale) are resolved exactly, contact by
contact, through the same exact kernel (no cone program is solved; ``extras["formulation"]``
says so). Coupled contacts go to the two-phase formulation of
:mod:`convimpact.impact.laws.stronge_contacts` (compression by a cone program, expansion by
Poisson's normal impulses with maximal-dissipation friction; never creates energy).

``extras`` of the result: ``phases`` (their kinds in order: ``"slip"``, ``"stick"``,
``"reversal"`` (planar slip after a stop), ``"onset"`` (slip from rest, in the selected
direction)), ``phase_impulses`` (the normal impulse at their boundaries, ``0, ..., p_f``),
``compression_impulse`` p_c, ``normal_work_compression``
W_n(p_c), ``normal_work_restitution`` W_n(p_f) - W_n(p_c), ``energetic_restitution``
``sqrt(-(W_n(p_f) - W_n(p_c)) / W_n(p_c))`` (= e), ``friction_work`` ``T+ - T- - W_n(p_f)``
(<= 0), ``slip_direction`` (the onset direction, when one was selected) and
``integration_steps`` (accepted DOP853 steps, spatial curved slip).

Example (a planar contact whose slip stops and sticks):

>>> sol = contact_kernel([[2.0, 0.5], [0.5, 1.0]], [-1.0, 0.2], 2, 0.5, 0.8)
>>> sol.regime, sol.extras["phases"]
('stick', ('slip', 'stick'))
>>> round(sol.extras["energetic_restitution"], 12)
0.5
"""

from __future__ import annotations

import math
from operator import mul

import numpy as np

from ..conic.paths import ProgramOptions, register_programs
from ..conic.qp import Backend
from ..diagnostics import assemble_result
from ..errors import NonPositiveEffectiveMassError, SingularSystemError, SolverError
from ..fast import FAST_TOL, ContactSolution, frictionless, register_kernel, solution, \
    solve_contact
from ..problem import ImpactProblem
from ..resolve import LAWS
from ..results import ImpactResult

LAW = "stronge"
#: relative round-off allowance of the stick test |C^-1 b| <= mu
STICK_RTOL = 1e-12
#: |dv_n/dp| below this times tr(W) counts as zero (a phase that cannot end compression)
JAM_RTOL = 1e-12
#: det W / tr(W)^d (and det C / tr(C)^2) below which W is singular for the stick decision
SINGULAR_RTOL = 1e-12
#: a slip direction s with |s x (b - mu C s)| <= RAY_RTOL (|b| + mu |C|) is an invariant ray
RAY_RTOL = 1e-14
#: local error tolerance of the DOP853 integration of a curved spatial slip (see the docstring)
ODE_RTOL = 1e-13
#: slip speed, relative to max |v-|, below which a pre-impact slip counts as none
STOP_RTOL = 1e-13
#: slip speed, relative to max |v-|, below which a curved slip may be declared stopped (when
#: the first-order tail is accurate), and below which it is (the integration's floor)
TAIL_RTOL = 1e-8
FLOOR_RTOL = 1e-10
#: accepted steps / impulse (in units of |v_n-| / W_nn) beyond which the collision is a jam
MAX_STEPS = 20000
MAX_IMPULSE = 1e12
#: relative coupling |W_ij| between contacts below which several contacts are independent
DECOUPLED_RTOL = 1e-12

_INF = math.inf


# --------------------------------------------------------------------------------------------
# the impulse-space path: state, stage events and linear phases


class _Path:
    """State of the impulse-space integration of one contact (plain floats)."""

    __slots__ = ("e", "v0", "p", "pt", "vn", "vt", "Wn", "compressing", "pc", "Wc", "target",
                 "done", "phases", "tr", "steps", "direction")

    def __init__(self, v: list, e: float, tr: float):
        self.e = e
        self.v0 = v
        self.p = 0.0
        self.pt = [0.0] * (len(v) - 1)
        self.vn = v[0]
        self.vt = list(v[1:])
        self.Wn = 0.0
        self.compressing = True
        self.pc = self.Wc = self.target = None
        self.done = False
        self.phases: list = []
        self.tr = tr
        self.steps = 0
        self.direction = None

    def open(self, kind: str) -> None:
        if self.phases and self.phases[-1][0] == kind:
            return
        self.phases.append([kind, self.p, self.p])

    def close(self) -> None:
        self.phases[-1][2] = self.p

    def stage_dp(self, an: float) -> float:
        """Normal impulse to the end of the current stage at dv_n/dp = an (inf: never)."""
        if self.compressing:
            if an > JAM_RTOL * self.tr:
                return max(-self.vn / an, 0.0)
            return _INF
        D = self.target - self.Wn
        if D <= 0.0:
            return 0.0
        vn = max(self.vn, 0.0)
        disc = vn * vn + 2.0 * an * D
        if disc < 0.0:  # an < 0: v_n returns to zero before the energy is restored
            return _INF
        return 2.0 * D / (vn + math.sqrt(disc))  # smaller positive root, cancellation-free

    def stage_event(self) -> bool:
        """End of compression (then restitution starts) or of restitution; True when done."""
        if self.compressing:
            self.vn = 0.0
            self.compressing = False
            self.pc, self.Wc = self.p, self.Wn
            self.target = (1.0 - self.e * self.e) * self.Wn
            if self.e == 0.0:
                self.done = True
        else:
            self.Wn = self.target
            self.done = True
        return self.done

    def advance(self, dp: float, an: float, lam: tuple, at: tuple) -> None:
        """Move along a linear phase by dp (exact: v linear, W_n quadratic in p)."""
        self.Wn += dp * (self.vn + 0.5 * an * dp)
        self.vn += an * dp
        self.p += dp
        for i in range(len(lam)):
            self.pt[i] += lam[i] * dp
            self.vt[i] += at[i] * dp

    def jam(self, kind: str, an: float) -> NonPositiveEffectiveMassError:
        stage = "compression" if self.compressing else "restitution"
        return NonPositiveEffectiveMassError(
            f"law 'stronge': the {stage} of this contact cannot end -- in its {kind} phase the "
            f"normal velocity changes by dv_n/dp_n = {an:.3e} per unit normal impulse "
            "(W_nn - mu W_tn.s <= 0, a Painleve-like jam), so the contact would absorb an "
            "unbounded impulse or re-approach before restitution ends; lower mu, or use "
            "law='ccp' or 'dissipative', which stay well posed")

    def run_linear(self, kind: str, an: float, lam: tuple, at: tuple, dp_stop: float) -> bool:
        """One linear phase until its slip stops (returns True) or the collision ends."""
        self.open(kind)
        while True:
            dp_end = self.stage_dp(an)
            if dp_stop <= dp_end:
                if dp_stop == _INF:
                    raise self.jam(kind, an)
                self.advance(dp_stop, an, lam, at)
                self.close()
                for i in range(len(self.vt)):
                    self.vt[i] = 0.0
                return True
            self.advance(dp_end, an, lam, at)
            self.close()
            dp_stop -= dp_end
            if self.stage_event():
                return False

    def solution(self, w: list, d: int, regime: str) -> ContactSolution:
        impulse = [self.p, *self.pt]
        dT = 0.0  # T+ - T- = pi.v- + 1/2 pi.W.pi
        for i in range(d):
            row, x = w[i], impulse[i]
            dT += x * (self.v0[i] + 0.5 * sum(map(mul, row, impulse)))
        Wc = self.Wc
        Wr = self.Wn - Wc
        extras = {
            "phases": tuple(k for k, _, _ in self.phases),
            "phase_impulses": (0.0, *(b for _, _, b in self.phases)),
            "compression_impulse": self.pc,
            "normal_work_compression": Wc,
            "normal_work_restitution": Wr,
            "energetic_restitution": math.sqrt(max(-Wr / Wc, 0.0)) if Wc < 0.0 else 0.0,
            "friction_work": dT - self.Wn,
        }
        if self.direction is not None:
            extras["slip_direction"] = self.direction
        if self.steps:
            extras["integration_steps"] = self.steps
        return solution(impulse, regime, extras=extras)


# --------------------------------------------------------------------------------------------
# one planar contact: exact


def _planar(w: list, v: list, e: float, mu: float) -> ContactSolution:
    A, B, C = w[0][0], w[0][1], w[1][1]
    path = _Path(v, e, A + C)
    s0 = 0.0 if v[1] == 0.0 else math.copysign(1.0, v[1])
    kind = "slip"
    while not path.done:
        vt = path.vt[0]
        if vt != 0.0:
            s = math.copysign(1.0, vt)
            kind = "slip" if s == s0 else "reversal"
            lam = -mu * s
            at = B + C * lam
            stop = -vt / at if vt * at < 0.0 else _INF
        elif abs(B) <= mu * C * (1.0 + STICK_RTOL):
            det = A * C - B * B
            if not det > SINGULAR_RTOL * (A + C) ** 2:
                raise _singular(det, "W")
            kind = "stick"
            lam, at, stop = -B / C, 0.0, _INF
        else:
            s = math.copysign(1.0, B)
            kind = "reversal" if s0 != 0.0 else "onset"
            lam = -mu * s
            at = B + C * lam
            stop = _INF
        path.run_linear(kind, A + B * lam, (lam,), (at,), stop)
    return path.solution(w, 2, "stick" if kind == "stick" else "slide")


def _singular(det: float, what: str) -> SingularSystemError:
    return SingularSystemError(
        f"law 'stronge': the contact's slip reached zero and {what} is singular "
        f"(det = {det:.3e}), so the sticking ratio -W_tt^-1 W_tn (or the normal compliance "
        "det W / det W_tt while sticking) is not defined; the impulse-space integration "
        "cannot go on. Use law='ccp' or 'dissipative', which accept a singular W")


# --------------------------------------------------------------------------------------------
# one spatial contact


def _onset(b1: float, b2: float, C11: float, C12: float, C22: float,
           mu: float) -> tuple[float, float, float]:
    """(kappa, s1, s2): the slip direction selected at v_t = 0 when sticking is inadmissible.

    s = (kappa I + mu C)^-1 b with |s| = 1, kappa > 0 (unique: the norm decreases in kappa).
    Safeguarded Newton on psi(kappa) = 1/|s(kappa)| - 1 in C's eigenbasis, bracketed by
    [0, |b|] (psi(0) < 0 because |C^-1 b| > mu; psi(|b|) > 0).
    """
    half = 0.5 * (C11 + C22)
    rad = math.hypot(0.5 * (C11 - C22), C12)
    c1 = half + rad
    c2 = (C11 * C22 - C12 * C12) / c1  # the smaller eigenvalue, without cancellation
    th = 0.5 * math.atan2(2.0 * C12, C11 - C22)
    q1, q2 = math.cos(th), math.sin(th)  # eigenvector of c1; (-q2, q1) of c2
    g1, g2 = q1 * b1 + q2 * b2, -q2 * b1 + q1 * b2
    m1, m2 = mu * c1, mu * c2
    lo, hi = 0.0, math.hypot(b1, b2)
    k = 0.0
    for _ in range(100):
        x1, x2 = g1 / (k + m1), g2 / (k + m2)
        nrm = math.hypot(x1, x2)
        psi = 1.0 / nrm - 1.0
        if psi < 0.0:
            lo = k
        else:
            hi = k
        dpsi = (x1 * x1 / (k + m1) + x2 * x2 / (k + m2)) / (nrm * nrm * nrm)
        new = k - psi / dpsi if dpsi > 0.0 else 0.5 * (lo + hi)
        if not lo <= new <= hi:
            new = 0.5 * (lo + hi)
        if abs(new - k) <= 1e-16 * (new + m1):
            k = new
            break
        k = new
    x1, x2 = g1 / (k + m1), g2 / (k + m2)
    nrm = math.hypot(x1, x2)
    x1, x2 = x1 / nrm, x2 / nrm
    return k, q1 * x1 - q2 * x2, q2 * x1 + q1 * x2


_TABLEAU = None


def _tableau():
    """DOP853's coefficients (Hairer, Norsett & Wanner) as plain floats, loaded on first use."""
    global _TABLEAU
    if _TABLEAU is None:
        from scipy.integrate._ivp import dop853_coefficients as c
        n = c.N_STAGES
        A = tuple(tuple(float(x) for x in c.A[i, :i]) for i in range(n))
        _TABLEAU = (A, tuple(float(x) for x in c.B), tuple(float(x) for x in c.E3),
                    tuple(float(x) for x in c.E5), n)
    return _TABLEAU


def _curved_slip(path: _Path, A: float, b1: float, b2: float, C11: float, C12: float,
                 C22: float, mu: float, vscale: float) -> None:
    """Integrate a curved slip in sigma (dsigma = dp / |v_t|) until it stops (v_t set to 0)
    or the collision ends; see the module docstring for the error control."""
    TA, TB, TE3, TE5, ns = _tableau()
    vn0, vt01, vt02 = path.v0
    pref = -vn0 / A  # frictionless compression impulse
    ref = (pref, pref, pref, -vn0 * pref)

    def rhs(y):
        p, q1, q2 = y[0], y[1], y[2]
        v1 = vt01 + b1 * p + C11 * q1 + C12 * q2
        v2 = vt02 + b2 * p + C12 * q1 + C22 * q2
        r = math.hypot(v1, v2)
        return (r, -mu * v1, -mu * v2, r * (vn0 + A * p + b1 * q1 + b2 * q2))

    def vnormal(y):
        return vn0 + A * y[0] + b1 * y[1] + b2 * y[2]

    def step(y, f, h):
        """One DOP853 step from y (slope f) of length h: (y_new, stage slopes per component)."""
        y0, y1, y2, y3 = y
        K0, K1, K2, K3 = [f[0]], [f[1]], [f[2]], [f[3]]
        for a in TA[1:]:
            k = rhs((y0 + h * sum(map(mul, a, K0)), y1 + h * sum(map(mul, a, K1)),
                     y2 + h * sum(map(mul, a, K2)), y3 + h * sum(map(mul, a, K3))))
            K0.append(k[0])
            K1.append(k[1])
            K2.append(k[2])
            K3.append(k[3])
        return (y0 + h * sum(map(mul, TB, K0)), y1 + h * sum(map(mul, TB, K1)),
                y2 + h * sum(map(mul, TB, K2)), y3 + h * sum(map(mul, TB, K3))), \
            (K0, K1, K2, K3)

    def event(y):
        return vnormal(y) if path.compressing else y[3] - path.target

    def event_rate(y, f):
        return A * f[0] + b1 * f[1] + b2 * f[2] if path.compressing else f[3]

    def locate(y, f, h, g0, g1):
        """The event inside the accepted step [0, h]: Newton on the step length, bracketed."""
        lo, hi = 0.0, h
        tau = h * g0 / (g0 - g1)
        yt = None
        for _ in range(60):
            yt, _K = step(y, f, tau)
            g = event(yt)
            if g == 0.0:
                break
            if g < 0.0:
                lo = tau
            else:
                hi = tau
            rate = event_rate(yt, rhs(yt))
            new = tau - g / rate if rate > 0.0 else 0.5 * (lo + hi)
            if not lo <= new <= hi:
                new = 0.5 * (lo + hi)
            if abs(new - tau) <= 1e-13 * h:
                yt, _K = step(y, f, new)
                break
            tau = new
        return yt

    def set_state(y):
        path.p, path.pt[0], path.pt[1], path.Wn = y
        path.vn = vnormal(y)
        path.vt[0] = vt01 + b1 * y[0] + C11 * y[1] + C12 * y[2]
        path.vt[1] = vt02 + b2 * y[0] + C12 * y[1] + C22 * y[2]

    def settle(y, r, stalled):
        """Hand the rest of a decelerating slip to an exact linear phase along its current
        direction once that is accurate (returns True; the curved phase is over).

        Near the direction phi* the slip stops along (a stable zero of
        g = s_perp.(b - mu C s), with the slip's rate h = s.(b - mu C s) < 0), the direction
        converges like dphi ~ |g / g'| (in sigma at the rate |g'|) and a straight finish
        misses about ``|v_t| |dh/dphi| dphi / (|h| (|h| + |g'|))`` of normal impulse (the
        first-order term of the tail's expansion in dphi); the hand-over waits until that is
        below 1e-13 |v_n-| / W_nn (and dphi <= 1e-3), or until |v_t| <= 1e-10 |v-| (the
        integration's round-off floor; also when |v_t| stalls below 1e-8 |v-|).
        """
        p, q1, q2 = y[0], y[1], y[2]
        v1 = vt01 + b1 * p + C11 * q1 + C12 * q2
        v2 = vt02 + b2 * p + C12 * q1 + C22 * q2
        s1, s2 = v1 / r, v2 / r
        a1 = b1 - mu * (C11 * s1 + C12 * s2)
        a2 = b2 - mu * (C12 * s1 + C22 * s2)
        rate = s1 * a1 + s2 * a2  # d|v_t|/dp
        floor = r <= FLOOR_RTOL * vscale or (stalled and r <= TAIL_RTOL * vscale)
        if not floor:
            if not rate < 0.0:
                return False
            g = s1 * a2 - s2 * a1  # |v_t| dphi/dp
            cs = -C11 * s1 * s2 + C12 * (s1 * s1 - s2 * s2) + C22 * s2 * s1  # s.C.s_perp
            cp = C11 * s2 * s2 - 2.0 * C12 * s1 * s2 + C22 * s1 * s1  # s_perp.C.s_perp
            dh, dg = g - mu * cs, -rate - mu * cp  # dh/dphi, dg/dphi
            if not (dg < 0.0 and abs(g) <= 1e-3 * -dg
                    and r * abs(dh * g) <= 1e-13 * pref * -rate * (-rate - dg) * -dg):
                return False
        set_state(y)
        path.close()
        if rate < 0.0:
            path.vt[0], path.vt[1] = r * s1, r * s2
            path.run_linear("slip", A - mu * (b1 * s1 + b2 * s2), (-mu * s1, -mu * s2),
                            (rate * s1, rate * s2), r / -rate)
        else:  # |v_t| at the round-off floor, not decreasing: it has stopped
            path.vt[0] = path.vt[1] = 0.0
        return True

    y = (path.p, path.pt[0], path.pt[1], path.Wn)
    f = rhs(y)
    nb = math.hypot(b1, b2)
    nc = 0.5 * (C11 + C22) + math.hypot(0.5 * (C11 - C22), C12)
    h = 0.05 / (nb + mu * nc + A * f[0] / -vn0)
    path.open("slip")
    g_old = event(y)
    steps = since = 0
    r_min = f[0]
    n = 4.0
    while True:
        y_new, K = step(y, f, h)
        f_new = rhs(y_new)
        e5 = e3 = 0.0
        for i in range(4):
            Ki = K[i]
            Ki.append(f_new[i])
            sc = ODE_RTOL * (ref[i] + max(abs(y[i]), abs(y_new[i])))
            e5 += (sum(map(mul, TE5, Ki)) / sc) ** 2
            e3 += (sum(map(mul, TE3, Ki)) / sc) ** 2
        err = 0.0 if e5 == 0.0 and e3 == 0.0 else abs(h) * e5 / math.sqrt((e5 + 0.01 * e3) * n)
        if not err <= 1.0:
            if not math.isfinite(err):
                err = 1e10
            h *= max(0.2, 0.9 * err ** -0.125)
            if h <= 1e-300:
                raise SolverError("law 'stronge': the spatial slip integration could not meet "
                                  "its error tolerance (step size underflow)")
            continue
        steps += 1
        g_new = event(y_new)
        if g_new >= 0.0 and g_old < 0.0:
            y_ev = locate(y, f, h, g_old, g_new)
            set_state(y_ev)
            path.close()
            if path.stage_event():
                path.steps += steps
                return
            y = y_ev
            f = rhs(y)
            g_old = event(y)
            continue
        y, f, g_old = y_new, f_new, g_new
        if not path.compressing and vnormal(y) < 1e-9 * vn0:  # re-approaching: a jam
            set_state(y)
            raise path.jam("slip", A - mu * (b1 * path.vt[0] + b2 * path.vt[1]) / f[0])
        r = f[0]
        if r < r_min:
            r_min, since = r, 0
        else:
            since += 1
        if settle(y, r, since > 20):
            path.steps += steps
            return
        if steps > MAX_STEPS or y[0] > MAX_IMPULSE * pref:
            set_state(y)
            s1, s2 = path.vt[0] / f[0], path.vt[1] / f[0]
            raise path.jam("slip", A - mu * (b1 * s1 + b2 * s2))
        h *= min(10.0, 0.9 * err ** -0.125) if err > 0.0 else 10.0


def _spatial(w: list, v: list, e: float, mu: float) -> ContactSolution:
    A = w[0][0]
    b1, b2 = w[0][1], w[0][2]
    C11, C12, C22 = w[1][1], w[1][2], w[2][2]
    tr = A + C11 + C22
    path = _Path(v, e, tr)
    vscale = max(abs(v[0]), abs(v[1]), abs(v[2]))
    r_stop = STOP_RTOL * vscale
    ray_tol = RAY_RTOL * (math.hypot(b1, b2) + mu * (C11 + C22))
    stopped = math.hypot(v[1], v[2]) <= r_stop
    kind = "slip"
    while not path.done:
        if stopped:
            detC = C11 * C22 - C12 * C12
            if not detC > SINGULAR_RTOL * (C11 + C22) ** 2:
                raise _singular(detC, "W_tt")
            l1 = -(C22 * b1 - C12 * b2) / detC  # sticking ratio -C^-1 b
            l2 = -(C11 * b2 - C12 * b1) / detC
            if math.hypot(l1, l2) <= mu * (1.0 + STICK_RTOL):
                an = A + b1 * l1 + b2 * l2  # det W / det C
                if not an > SINGULAR_RTOL * tr:
                    raise _singular(an * detC, "W")
                kind = "stick"
                path.run_linear(kind, an, (l1, l2), (0.0, 0.0), _INF)
            else:
                _, s1, s2 = _onset(b1, b2, C11, C12, C22, mu)
                path.direction = (s1, s2)
                kind = "onset"
                a1 = b1 - mu * (C11 * s1 + C12 * s2)
                a2 = b2 - mu * (C12 * s1 + C22 * s2)
                path.run_linear(kind, A - mu * (b1 * s1 + b2 * s2), (-mu * s1, -mu * s2),
                                (a1, a2), _INF)
            continue
        v1, v2 = path.vt
        r = math.hypot(v1, v2)
        s1, s2 = v1 / r, v2 / r
        a1 = b1 - mu * (C11 * s1 + C12 * s2)
        a2 = b2 - mu * (C12 * s1 + C22 * s2)
        if abs(s1 * a2 - s2 * a1) <= ray_tol:  # on an invariant ray: a linear phase
            rate = s1 * a1 + s2 * a2
            stopped = path.run_linear(kind, A - mu * (b1 * s1 + b2 * s2), (-mu * s1, -mu * s2),
                                      (rate * s1, rate * s2), r / -rate if rate < 0.0 else _INF)
        else:
            _curved_slip(path, A, b1, b2, C11, C12, C22, mu, vscale)
            stopped = not path.done
    return path.solution(w, 3, "stick" if kind == "stick" else "slide")


# --------------------------------------------------------------------------------------------
# the law's entry points


def contact_kernel(w: list, v: list, d: int, e: float, mu: float) -> ContactSolution:
    """Stronge's law for one approaching contact on plain floats (the ``fast`` kernel)."""
    if mu == 0.0:
        return frictionless(w, v, d, e)  # p_f = (1 + e) p_c: Newton's impulse
    return _planar(w, v, e, mu) if d == 2 else _spatial(w, v, e, mu)


def program_result(P: ImpactProblem, backend: Backend, method: str,
                   opts: ProgramOptions) -> ImpactResult:
    """Several contacts: exact, contact by contact, when they are dynamically independent;
    coupled contacts by the two-phase formulation of
    :mod:`convimpact.impact.laws.stronge_contacts` (on the conic path ``method``).

    ``backend`` and ``opts`` serve the coupled formulation's compression program only.
    """
    n, d = P.n_contacts, P.dim
    W = P.delassus
    diag = np.sqrt(np.maximum(np.diag(W), 0.0))
    for i in range(n):
        for j in range(i + 1, n):
            block = W[i * d:(i + 1) * d, j * d:(j + 1) * d]
            bound = DECOUPLED_RTOL * max(float(np.max(diag[i * d:(i + 1) * d])), 1e-300) * \
                max(float(np.max(diag[j * d:(j + 1) * d])), 1e-300)
            if np.max(np.abs(block)) > bound:
                from .stronge_contacts import coupled_result
                return coupled_result(P, backend, method, opts)
    pi = np.zeros((n, d))
    regimes = []
    per_contact = []
    for i in range(n):
        Wi, vi = P.contact_block(i)
        sol = solve_contact(Wi, vi, float(P.restitution[i]), float(P.friction[i]), LAW)
        pi[i] = sol.impulse
        regimes.append(sol.regime)
        per_contact.append(dict(sol.extras))
    extras = {"formulation": "independent contacts (block-diagonal W): the exact "
                             "single-contact impulse-space integration per contact; no cone "
                             "program is solved",
              "contacts": per_contact}
    return assemble_result(P, pi, regimes, LAW, method, tol=FAST_TOL, extras=extras)


def register() -> None:
    """Register the kernel (``method="fast"``) and the several-contact entry (``"clarabel"``,
    ``"cvxpy"``); done on import once :data:`~convimpact.impact.laws.LAW_MODULES` lists the
    law."""
    register_kernel(LAW, contact_kernel)
    register_programs(LAW, program_result)


if LAW in LAWS:
    register()
