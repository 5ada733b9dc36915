"""Law ``"stronge"``: the contact's path in impulse space, compiled -- the linear phases (the
plane's and the space's), the slip direction selected at rest (onset) and the curved slip's
integration in ``sigma`` (``dsigma = dp / |v_t|``): its loop (step-size control, the
stage's events, the stop) and its hand-over to an exact straight finish, on the DOP853
step, error norm and event location of :mod:`convimpact.impact.laws.stronge_dop853`;
:func:`_stronge_spatial` is the spatial kernel.

The equations, the error control and the accuracy are stated in
:mod:`convimpact.impact.laws.stronge` (the law's module: the planar kernel, the extras and
the errors). The kernels return ``(status, regime, p0, p1, p2, effective_mass)`` with the
codes of :mod:`convimpact.impact.laws.codes` (OK; SINGULAR where the stick / onset
decision needs a singular W; JAM, a Painleve-like jam; NO_SOLUTION, the step size's underflow)
and write into the float64 scratch ``out``:

====================  =====================================================================
``out[0]``            number of phases (at most two occur)
``out[1:5]``          their kinds (:data:`PHASE_NAMES`: slip, stick, reversal, onset)
``out[5:9]``          the normal impulse where each phase starts (0 first)
``out[9]``, ``[10]``  ``p_c`` and ``W_n(p_c)`` (end of compression)
``out[11]``           ``W_n(p_f)``
``out[12:14]``        the onset's slip direction (spatial), when ``out[14]`` is 1
``out[15]``           accepted DOP853 steps
``out[16:19]``        on JAM: the phase's kind, its ``dv_n/dp``, 1 if still compressing;
                      on SINGULAR: 0 (W) or 1 (W_tt), the determinant (``out[17]``)
====================  =====================================================================

Every function runs unchanged as plain Python (``NUMBA_DISABLE_JIT=1``): no division by zero
is left to IEEE arithmetic, squares are products (Python's ``**`` raises on overflow).
"""

from __future__ import annotations

import math

import numpy as np

from .codes import (FAILED, JAM, NO_SOLUTION, OK, SINGULAR, SLIDE, STICK, _NAN,
                                    _jit, _pmax2)
from .stronge_dop853 import _NE, _error, _event, _event_length, _rhs, _step, _velocity
from .stronge_dop853 import ODE_RTOL  # noqa: F401  (re-exported; _error reads it there)

#: relative round-off allowance of the stick test |C^-1 b| <= mu
STICK_RTOL = 1e-12
#: |dv_n/dp| below this times tr(W) counts as zero (a phase that cannot end compression)
JAM_RTOL = 1e-12
#: det W / tr(W)^d (and det C / tr(C)^2) below which W is singular for the stick decision
SINGULAR_RTOL = 1e-12
#: a slip direction s with |s x (b - mu C s)| <= RAY_RTOL (|b| + mu |C|) is an invariant ray
RAY_RTOL = 1e-14
#: slip speed, relative to max |v-|, below which a pre-impact slip counts as none
STOP_RTOL = 1e-13
#: slip speed, relative to max |v-|, below which a curved slip may be declared stopped (when
#: the first-order tail is accurate), and below which it is (the integration's floor)
TAIL_RTOL = 1e-8
FLOOR_RTOL = 1e-10
#: accepted steps / impulse (in units of |v_n-| / W_nn) beyond which the collision is a jam
MAX_STEPS = 20000
#: a rejected step shorter than this times the first step is an underflow of the step size
H_FLOOR_RTOL = 1e-200
MAX_IMPULSE = 1e12

#: phase kinds (``out[1:5]``), named by :data:`PHASE_NAMES`
PH_SLIP, PH_STICK, PH_REVERSAL, PH_ONSET = 0, 1, 2, 3
PHASE_NAMES = ("slip", "stick", "reversal", "onset")
#: ``out`` layout (see the module docstring)
MAX_PHASES = 4
O_NPHASES, O_KINDS, O_STARTS, O_PC, O_WC, O_WN = 0, 1, 5, 9, 10, 11
O_DIRECTION, O_HAS_DIRECTION, O_STEPS = 12, 14, 15
O_ERR_KIND, O_ERR_VALUE, O_ERR_COMPRESSING = 16, 17, 18

_INF = math.inf


# --------------------------------------------------------------------------------------------
# the path's record and its linear phases
#
# The path's state travels as (p, pt1, pt2, vn, vt1, vt2, Wn, compressing, target, done); a
# planar path has pt2 = vt2 = 0.


@_jit
def _start(out):
    """An empty record: no phase, no onset direction, no integration step."""
    out[O_NPHASES] = 0.0
    out[O_HAS_DIRECTION] = 0.0
    out[O_STEPS] = 0.0


@_jit
def _open(out, kind, p):
    """A phase of ``kind`` starts at normal impulse p (merged into the last one if alike)."""
    n = int(out[O_NPHASES])
    if n > 0 and out[O_KINDS + n - 1] == kind:
        return
    if n < MAX_PHASES:  # (the law has at most two)
        out[O_KINDS + n] = kind
        out[O_STARTS + n] = p
        out[O_NPHASES] = n + 1


@_jit
def _failed(out, status, kind, value, compressing):
    """``status`` (JAM or SINGULAR) with what its message names: the phase's kind (JAM) or the
    singular matrix (SINGULAR: 0 W, 1 W_tt), its dv_n/dp or determinant, the stage."""
    out[O_ERR_KIND] = kind
    out[O_ERR_VALUE] = value
    out[O_ERR_COMPRESSING] = 1.0 if compressing else 0.0
    return status


@_jit
def _stage_event(out, p, vn, Wn, compressing, target, e):
    """End of compression (v_n = 0: restitution starts, p_c and W_n(p_c) recorded) or of
    restitution (W_n at its target). Returns (vn, Wn, compressing, target, done)."""
    if compressing:
        out[O_PC] = p
        out[O_WC] = Wn
        target = (1.0 - e * e) * Wn
        # nothing to restitute: e = 0, or e^2 W_n below W_n's last bit (a subnormal e)
        return 0.0, Wn, False, target, not target > Wn
    return vn, target, False, target, True


@_jit
def _run_linear(out, kind, p, pt1, pt2, vn, vt1, vt2, Wn, compressing, target, done, e, tr,
                an, l1, l2, at1, at2, dp_stop):
    """One linear phase (dv_n/dp = an, dpi_t/dp = l, dv_t/dp = at) until its slip stops after
    dp_stop (inf: never) or the collision ends; v is linear and W_n quadratic in p, so every
    end is exact. Returns (status, stopped, p, pt1, pt2, vn, vt1, vt2, Wn, compressing,
    target, done); status JAM when the phase can end neither."""
    _open(out, kind, p)
    while True:
        if compressing:  # impulse to the end of the stage
            dp_end = _pmax2(-vn / an, 0.0) if an > JAM_RTOL * tr else _INF
        else:
            D = target - Wn
            if D <= 0.0:
                dp_end = 0.0
            else:
                vp = _pmax2(vn, 0.0)
                disc = vp * vp + 2.0 * an * D
                # an < 0: v_n returns to zero before the energy is restored
                dp_end = _INF if disc < 0.0 else 2.0 * D / (vp + math.sqrt(disc))
        stops = dp_stop <= dp_end
        if stops and dp_stop == _INF:
            return (_failed(out, JAM, kind, an, compressing), False, p, pt1, pt2, vn, vt1, vt2, Wn,
                    compressing, target, done)
        dp = dp_stop if stops else dp_end
        Wn += dp * (vn + 0.5 * an * dp)
        vn += an * dp
        p += dp
        pt1 += l1 * dp
        vt1 += at1 * dp
        pt2 += l2 * dp
        vt2 += at2 * dp
        if stops:
            return (OK, True, p, pt1, pt2, vn, 0.0, 0.0, Wn, compressing, target, done)
        dp_stop -= dp_end
        vn, Wn, compressing, target, done = _stage_event(out, p, vn, Wn, compressing, target,
                                                         e)
        if done:
            return (OK, False, p, pt1, pt2, vn, vt1, vt2, Wn, compressing, target, done)


# --------------------------------------------------------------------------------------------
# the onset direction


@_jit
def _onset(b1, b2, C11, C12, C22, mu):
    """(kappa, s1, s2): the slip direction selected at v_t = 0 when sticking is inadmissible.

    s = (kappa I + mu C)^-1 b with |s| = 1, kappa > 0 (unique: the norm decreases in kappa).
    Safeguarded Newton on psi(kappa) = 1/|s(kappa)| - 1 in C's eigenbasis, bracketed by
    [0, |b|] (psi(0) < 0 because |C^-1 b| > mu; psi(|b|) > 0).
    """
    half = 0.5 * (C11 + C22)
    c1 = half + math.hypot(0.5 * (C11 - C22), C12)
    c2 = (C11 * C22 - C12 * C12) / c1  # the smaller eigenvalue, without cancellation
    th = 0.5 * math.atan2(2.0 * C12, C11 - C22)
    q1 = math.cos(th)  # eigenvector of c1; (-q2, q1) of c2
    q2 = math.sin(th)
    g1 = q1 * b1 + q2 * b2
    g2 = -q2 * b1 + q1 * b2
    m1 = mu * c1
    m2 = mu * c2
    lo = 0.0
    hi = math.hypot(b1, b2)
    k = 0.0
    for _ in range(100):
        x1 = g1 / (k + m1)
        x2 = g2 / (k + m2)
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
    x1 = g1 / (k + m1)
    x2 = g2 / (k + m2)
    nrm = math.hypot(x1, x2)
    x1 = x1 / nrm
    x2 = x2 / nrm
    return k, q1 * x1 - q2 * x2, q2 * x1 + q1 * x2


# --------------------------------------------------------------------------------------------
# the curved slip: DOP853 in sigma, state y = (p, pi_t, W_n) (the integrator's step, error
# norm and event location: :mod:`.stronge_dop853`)


@_jit
def _slip_rates(A, b1, b2, C11, C12, C22, mu, s1, s2):
    """A slip along s: (dv_n/dp, dv_t/dp) = (A - mu b.s, b - mu C s)."""
    return (A - mu * (b1 * s1 + b2 * s2), b1 - mu * (C11 * s1 + C12 * s2),
            b2 - mu * (C12 * s1 + C22 * s2))


@_jit
def _settles(r, s1, s2, a1, a2, C11, C12, C22, mu, tol):
    """Whether a slip of speed r along s (rates a = b - mu C s) decelerates and has settled on
    the direction phi* it stops along, so that an exact straight finish along s misses at most
    ``tol`` of normal impulse. Near phi* (a stable zero of g = s_perp.(b - mu C s), rate
    h = s.(b - mu C s) < 0) the straight finish misses about
    |v_t| |dh/dphi| dphi / (|h| (|h| + |g'|)) of normal impulse, dphi ~ |g / g'|."""
    rate = s1 * a1 + s2 * a2  # d|v_t|/dp
    if not rate < 0.0:
        return False
    g = s1 * a2 - s2 * a1  # |v_t| dphi/dp
    cs = -C11 * s1 * s2 + C12 * (s1 * s1 - s2 * s2) + C22 * s2 * s1  # s.C.s_perp
    cp = C11 * s2 * s2 - 2.0 * C12 * s1 * s2 + C22 * s1 * s1  # s_perp.C.s_perp
    dh = g - mu * cs  # dh/dphi
    dg = -rate - mu * cp  # dg/dphi
    return (dg < 0.0 and abs(g) <= 1e-3 * -dg
            and r * abs(dh * g) <= tol * -rate * (-rate - dg) * -dg)


@_jit
def _curved_slip(out, p, pt1, pt2, vn, vt1, vt2, Wn, compressing, target, done, e, tr, vn0,
                 vt01, vt02, A, b1, b2, C11, C12, C22, mu, vscale):
    """Integrate a curved slip in sigma until it stops (v_t set to 0) or the collision ends
    (the error control of :mod:`convimpact.impact.laws.stronge`). Returns (status, p, pt1,
    pt2, vn, vt1, vt2, Wn, compressing, target, done); status OK, JAM, or NO_SOLUTION (the
    step size underflowed)."""
    K = np.empty((4, _NE))
    pref = -vn0 / A  # frictionless compression impulse
    ref3 = -vn0 * pref
    y0, y1, y2, y3 = p, pt1, pt2, Wn
    f0, f1, f2, f3 = _rhs(y0, y1, y2, vn0, vt01, vt02, A, b1, b2, C11, C12, C22, mu)
    nb = math.hypot(b1, b2)
    nc = 0.5 * (C11 + C22) + math.hypot(0.5 * (C11 - C22), C12)
    h = 0.05 / (nb + mu * nc + A * f0 / -vn0)
    # the step's floor, relative to the first step: sigma's scale is p / |v_t| ~ |v_n-| /
    # (W_nn |v_t|), far below one when the contact slides much faster than it approaches
    h_floor = H_FLOOR_RTOL * h
    _open(out, PH_SLIP, p)
    g_old = _event(y0, y1, y2, y3, compressing, target, vn0, A, b1, b2)
    steps = 0
    since = 0
    r_min = f0
    while True:
        z0, z1, z2, z3, n0, n1, n2, n3 = _step(y0, y1, y2, y3, f0, f1, f2, f3, h, K, vn0,
                                               vt01, vt02, A, b1, b2, C11, C12, C22, mu)
        err = _error(h, y0, y1, y2, y3, z0, z1, z2, z3, pref, ref3, K)
        if not err <= 1.0:  # rejected (NaN and inf too)
            if not math.isfinite(err):
                err = 1e10
            h *= _pmax2(0.2, 0.9 * err ** -0.125)
            if h <= h_floor:
                st = NO_SOLUTION
                break
            continue
        steps += 1
        g_new = _event(z0, z1, z2, z3, compressing, target, vn0, A, b1, b2)
        if g_new >= 0.0 and g_old < 0.0:  # the stage ends inside the step
            tau = _event_length(y0, y1, y2, y3, f0, f1, f2, f3, h, g_old, g_new, compressing,
                                target, K, vn0, vt01, vt02, A, b1, b2, C11, C12, C22, mu)
            y0, y1, y2, y3, f0, f1, f2, f3 = _step(y0, y1, y2, y3, f0, f1, f2, f3, tau, K, vn0,
                                                   vt01, vt02, A, b1, b2, C11, C12, C22, mu)
            p, pt1, pt2, Wn = y0, y1, y2, y3
            vn, vt1, vt2 = _velocity(y0, y1, y2, vn0, vt01, vt02, A, b1, b2, C11, C12, C22)
            vn, Wn, compressing, target, done = _stage_event(out, p, vn, Wn, compressing,
                                                             target, e)
            st = OK
            if done:
                break
            g_old = _event(y0, y1, y2, y3, compressing, target, vn0, A, b1, b2)
            continue
        y0, y1, y2, y3 = z0, z1, z2, z3
        f0, f1, f2, f3 = n0, n1, n2, n3
        g_old = g_new
        r = f0
        wn, v1, v2 = _velocity(y0, y1, y2, vn0, vt01, vt02, A, b1, b2, C11, C12, C22)
        if not compressing and wn < 1e-9 * vn0:  # re-approaching during restitution: a jam
            an = A - mu * (b1 * v1 + b2 * v2) / r if r > 0.0 else A
            st = _failed(out, JAM, PH_SLIP, an, compressing)
            break
        if r < r_min:
            r_min = r
            since = 0
        else:
            since += 1
        if r == 0.0:  # the slip has stopped exactly
            p, pt1, pt2, Wn, vn, vt1, vt2, st = y0, y1, y2, y3, wn, 0.0, 0.0, OK
            break
        # settle: hand a decelerating slip to an exact straight finish once that is accurate
        s1 = v1 / r
        s2 = v2 / r
        an, a1, a2 = _slip_rates(A, b1, b2, C11, C12, C22, mu, s1, s2)
        rate = s1 * a1 + s2 * a2  # d|v_t|/dp
        if (r <= FLOOR_RTOL * vscale or (since > 20 and r <= TAIL_RTOL * vscale)
                or _settles(r, s1, s2, a1, a2, C11, C12, C22, mu, 1e-13 * pref)):
            p, pt1, pt2, Wn, vn, vt1, vt2, st = y0, y1, y2, y3, wn, 0.0, 0.0, OK
            if rate < 0.0:  # the exact straight finish along s
                st, _, p, pt1, pt2, vn, vt1, vt2, Wn, compressing, target, done = _run_linear(
                    out, PH_SLIP, p, pt1, pt2, vn, r * s1, r * s2, Wn, compressing, target,
                    done, e, tr, an, -mu * s1, -mu * s2, rate * s1, rate * s2, r / -rate)
            break  # (else |v_t| at the round-off floor, not decreasing: it has stopped)
        if steps > MAX_STEPS or y0 > MAX_IMPULSE * pref:
            st = _failed(out, JAM, PH_SLIP, an, compressing)
            break
        h *= min(10.0, 0.9 * err ** -0.125) if err > 0.0 else 10.0
    out[O_STEPS] += steps
    return (st, p, pt1, pt2, vn, vt1, vt2, Wn, compressing, target, done)


# --------------------------------------------------------------------------------------------
# one spatial contact


#: max |v-| after the approach speed is scaled to order one stays below 2^SCALED_SPEED_EXP, so
#: that the integration's products (|v_t| v_n, |v_t| p) stay finite when |v_t| >> |v_n-|
SCALED_SPEED_EXP = 600


@_jit
def _stronge_spatial(A, b1, b2, C11, C12, C22, v0, v1, v2, e, mu, out):
    """One spatial contact (:func:`_stronge_spatial_scaled`) in velocity units where the
    approach speed -v0 is of order one.

    The law is positively homogeneous of degree one in v- (impulses scale with v-, the works
    W_n with its square), and the curved slip's integration measures its error against the
    frictionless compression impulse -v0 / A and work v0^2 / A: with -v0 ~ 1e-300 next to a
    tangential speed of order one, that work underflows to zero (the error norm divides by
    it) and the first step underflows, so the integration failed. Here v- is scaled by the
    power of two 2^k with -v0 2^k in [1/2, 1) (bounded so that max |v-| 2^k < 2^600), which
    is exact, and the impulses (out's phase starts, p_c) and works (W_c, W_n) are scaled back
    by 2^-k and 2^-2k; the errors' values (dv_n/dp, det W) do not depend on it."""
    k = _speed_exponent(v0, v1, v2)
    st, regime, p0, p1, p2, mass = _stronge_spatial_scaled(
        A, b1, b2, C11, C12, C22, math.ldexp(v0, k), math.ldexp(v1, k), math.ldexp(v2, k), e,
        mu, out)
    return _scaled_back(out, k, st, regime, p0, p1, p2, mass)


@_jit
def _speed_exponent(v0, v1, v2):
    """k with -v0 2^k in [1/2, 1), lowered so that max |v| 2^k < 2^:data:`SCALED_SPEED_EXP`."""
    vmax = _pmax2(_pmax2(abs(v0), abs(v1)), abs(v2))
    k = -math.frexp(abs(v0))[1]
    top = SCALED_SPEED_EXP - math.frexp(vmax)[1]
    return top if k > top else k


@_jit
def _scaled_back(out, k, st, regime, p0, p1, p2, mass):
    """A kernel's answer and record computed with v- 2^k, brought back to v-: impulses (the
    answer, the phases' starts, p_c) times 2^-k, the works W_c, W_n times 2^-2k (exact)."""
    if st == OK:
        p0 = math.ldexp(p0, -k)
        p1 = math.ldexp(p1, -k)
        p2 = math.ldexp(p2, -k)
    for i in range(O_STARTS, O_STARTS + int(out[O_NPHASES])):
        out[i] = math.ldexp(out[i], -k)
    out[O_PC] = math.ldexp(out[O_PC], -k)
    out[O_WC] = math.ldexp(out[O_WC], -2 * k)
    out[O_WN] = math.ldexp(out[O_WN], -2 * k)
    return st, regime, p0, p1, p2, mass


@_jit
def _stronge_spatial_scaled(A, b1, b2, C11, C12, C22, v0, v1, v2, e, mu, out):
    """One spatial contact (W = [[A, b^T], [b, C]]), mu > 0, approaching, W in the safe range:
    stick or onset from rest, else slip -- along an invariant ray (a linear phase) or curved
    (integrated) -- until it stops, then stick or onset; the phases, works and jams into
    ``out``."""
    tr = A + C11 + C22
    _start(out)
    p, pt1, pt2, Wn, target = 0.0, 0.0, 0.0, 0.0, 0.0
    vn, vt1, vt2 = v0, v1, v2
    # True and False (the caller passes an approaching contact, v0 < 0), typed as plain bools:
    # literal ones would compile a second specialization of every helper taking them
    compressing = v0 < 0.0
    done = not compressing
    vscale = _pmax2(_pmax2(abs(v0), abs(v1)), abs(v2))
    ray_tol = RAY_RTOL * (math.hypot(b1, b2) + mu * (C11 + C22))
    stopped = math.hypot(v1, v2) <= STOP_RTOL * vscale
    stick = False
    while not done:
        if stopped:
            detC = C11 * C22 - C12 * C12
            if not detC > SINGULAR_RTOL * (C11 + C22) * (C11 + C22):
                st = _failed(out, SINGULAR, 1, detC, compressing)
                return st, FAILED, _NAN, _NAN, _NAN, _NAN
            l1 = -(C22 * b1 - C12 * b2) / detC  # sticking ratio -C^-1 b
            l2 = -(C11 * b2 - C12 * b1) / detC
            if math.hypot(l1, l2) <= mu * (1.0 + STICK_RTOL):
                an = A + b1 * l1 + b2 * l2  # det W / det C
                if not an > SINGULAR_RTOL * tr:
                    st = _failed(out, SINGULAR, 0, an * detC, compressing)
                    return st, FAILED, _NAN, _NAN, _NAN, _NAN
                stick = True
                st, _, p, pt1, pt2, vn, vt1, vt2, Wn, compressing, target, done = _run_linear(
                    out, PH_STICK, p, pt1, pt2, vn, vt1, vt2, Wn, compressing, target, done, e,
                    tr, an, l1, l2, 0.0, 0.0, _INF)
            else:
                _, s1, s2 = _onset(b1, b2, C11, C12, C22, mu)
                out[O_DIRECTION] = s1
                out[O_DIRECTION + 1] = s2
                out[O_HAS_DIRECTION] = 1.0
                an, a1, a2 = _slip_rates(A, b1, b2, C11, C12, C22, mu, s1, s2)
                st, _, p, pt1, pt2, vn, vt1, vt2, Wn, compressing, target, done = _run_linear(
                    out, PH_ONSET, p, pt1, pt2, vn, vt1, vt2, Wn, compressing, target, done, e,
                    tr, an, -mu * s1, -mu * s2, a1, a2, _INF)
            if st != OK:
                return st, FAILED, _NAN, _NAN, _NAN, _NAN
            continue
        r = math.hypot(vt1, vt2)
        s1 = vt1 / r
        s2 = vt2 / r
        an, a1, a2 = _slip_rates(A, b1, b2, C11, C12, C22, mu, s1, s2)
        if abs(s1 * a2 - s2 * a1) <= ray_tol:  # on an invariant ray: a linear phase
            rate = s1 * a1 + s2 * a2
            st, stopped, p, pt1, pt2, vn, vt1, vt2, Wn, compressing, target, done = \
                _run_linear(out, PH_SLIP, p, pt1, pt2, vn, vt1, vt2, Wn, compressing, target,
                            done, e, tr, an, -mu * s1, -mu * s2, rate * s1, rate * s2,
                            r / -rate if rate < 0.0 else _INF)
        else:
            st, p, pt1, pt2, vn, vt1, vt2, Wn, compressing, target, done = _curved_slip(
                out, p, pt1, pt2, vn, vt1, vt2, Wn, compressing, target, done, e, tr, v0, v1,
                v2, A, b1, b2, C11, C12, C22, mu, vscale)
            stopped = not done
        if st != OK:
            return st, FAILED, _NAN, _NAN, _NAN, _NAN
    out[O_WN] = Wn
    return OK, STICK if stick else SLIDE, p, pt1, pt2, _NAN
