"""The compiled kernel of Stronge's energetic law for one spatial contact
(:func:`convimpact.impact.laws.stronge.contact_kernel`, ``d = 3``): a line-by-line port of
``laws.stronge._spatial`` -- its impulse-space path (``_Path``: linear phases, the stage
events, the jams), the onset direction (``_onset``) and the curved slip's embedded DOP853
integration in ``sigma`` with its event location and hand-over to a straight finish
(``_curved_slip``) -- on scalars and one small scratch array. Returns
``(status, regime, p0, p1, p2, effective_mass)``.

Branches are taken in the same order and with the same floating-point expressions (sums in
the same order) as the Python kernel, so the answers agree with it to round-off; two
functions are computed as CPython computes them, not as numba does by default, because the
integration's step-size control would otherwise amplify their last-bit differences:

* ``math.hypot`` is CPython's ``vector_norm`` (scaling by a power of two, exact squares,
  compensated sum, a corrected square root), not the C library's ``hypot``;
* ``x ** 2`` (the error estimate) is the C library's ``pow(x, 2.0)``, as CPython's float
  power calls it, which differs from ``x * x`` in the last bit of about one square in a
  thousand: ``x * x`` where the exact square is within 0.35 ulp of it (pow's error is below
  0.54 ulp, so pow returns that double too), else a call of ``powf64`` (glibc's alias of
  ``pow``; LLVM would fold a call named ``pow`` with a constant 2 into ``x * x``). Where the
  C library has no ``powf64`` it is ``x * x``.

Errors: where the Python kernel raises SingularSystemError the kernel returns ``SINGULAR``,
NonPositiveEffectiveMassError (``path.jam``) ``JAM``; the step-size underflow (SolverError)
and the cases where the Python kernel would stop on a Python exception that is not one of the
library's (a zero division or an overflowing ``** 2``, unreachable in practice) return
``DEFER``: :mod:`convimpact.impact.batch` then runs the Python kernel, which raises.
The tolerances and the DOP853 coefficients (scipy's, read at import as ``_tableau()`` does)
mirror :mod:`convimpact.impact.laws.stronge`.
"""

from __future__ import annotations

import ctypes
import math

import numpy as np
from llvmlite import ir
from numba.core import cgutils, types
from numba.extending import intrinsic
from scipy.integrate._ivp import dop853_coefficients as _dop853

from ..batch_kernels.common import (DEFER, FAILED, JAM, OK, SINGULAR, SLIDE, STICK, _NAN, _jit,
                                    _pmax2)

#: laws.stronge's tolerances (see that module)
STICK_RTOL = 1e-12
JAM_RTOL = 1e-12
SINGULAR_RTOL = 1e-12
RAY_RTOL = 1e-14
ODE_RTOL = 1e-13
STOP_RTOL = 1e-13
TAIL_RTOL = 1e-8
FLOOR_RTOL = 1e-10
MAX_STEPS = 20000
MAX_IMPULSE = 1e12

_INF = math.inf
_DBL_MIN = 2.2250738585072014e-308

#: DOP853's tableau (laws.stronge._tableau: A's lower triangle, B, E3, E5), global arrays
#: that numba freezes into the machine code
_NS = int(_dop853.N_STAGES)
_A = np.ascontiguousarray(np.asarray(_dop853.A, dtype=np.float64)[:_NS, :_NS])
_B = np.ascontiguousarray(np.asarray(_dop853.B, dtype=np.float64))
_E3 = np.ascontiguousarray(np.asarray(_dop853.E3, dtype=np.float64))
_E5 = np.ascontiguousarray(np.asarray(_dop853.E5, dtype=np.float64))
_NE = _E5.shape[0]  # = _NS + 1: the stages and the slope at the step's end


def _has_powf64() -> bool:
    try:
        ctypes.CDLL(None).powf64  # noqa: B018  (the process's C library exports it?)
    except (AttributeError, OSError, TypeError):  # not glibc, or no process-wide handle
        return False
    return True


HAS_POWF64 = _has_powf64()
_cpow = types.ExternalFunction("powf64" if HAS_POWF64 else "pow",
                               types.float64(types.float64, types.float64))


@intrinsic
def _fma(typingctx, x, y, z):
    """x y + z rounded once (LLVM's fma: one instruction where the CPU has it, else the C
    library's fma); CPython's dl_mul takes the exact error of a product so."""
    def codegen(context, builder, signature, args):
        d = ir.DoubleType()
        fn = cgutils.get_or_insert_function(builder.module, ir.FunctionType(d, [d, d, d]),
                                            "llvm.fma.f64")
        return builder.call(fn, args)
    return types.float64(types.float64, types.float64, types.float64), codegen


#: squares x x below this fraction of x x from the exact square are glibc's pow(x, 2.0) too
#: (pow's error is below 0.54 ulp, glibc e_pow.c: the exact square within 0.35 ulp of the
#: rounded product leaves pow no other double)
_SQ_SAFE = 0.35 * 2.0 ** -53


@_jit
def _sq(x):
    """CPython's ``x ** 2``: the C library's pow(|x|, 2.0) (float_pow takes |x| for an even
    integer power). The product x x is that double whenever the exact square is close to it
    (about three squares in five), which costs no call."""
    hi = x * x
    if 1e-280 < hi < 1e300:
        lo = _fma(x, x, -hi)  # the exact square is hi + lo
        if abs(lo) <= _SQ_SAFE * hi:
            return hi
    if HAS_POWF64:
        return _cpow(abs(x), 2.0)
    return hi  # pragma: no cover - not glibc: the product


# --------------------------------------------------------------------------------------------
# CPython's math.hypot


@_jit
def _hypot(x, y):
    """math.hypot(x, y) as CPython 3.8+ computes it (Modules/mathmodule.c, vector_norm)."""
    x = abs(x)
    y = abs(y)
    mx = 0.0
    if x > mx:
        mx = x
    if y > mx:
        mx = y
    if math.isinf(mx):
        return mx
    if math.isnan(x) or math.isnan(y):
        return _NAN
    if mx == 0.0:
        return mx
    back = 1.0
    E = (np.float64(mx).view(np.int64) >> 52) & 0x7FF  # biased exponent: frexp's is E - 1022
    if 1 <= E <= 2044:
        scale = np.int64((2045 - E) << 52).view(np.float64)  # 2^-max_e, exactly
        unscale = np.int64((E + 1) << 52).view(np.float64)  # 2^max_e: x / scale = x unscale
    else:  # subnormal or near the top: frexp and ldexp as CPython
        _, max_e = math.frexp(mx)
        if max_e < -1023:  # bring subnormals up first
            x /= _DBL_MIN
            y /= _DBL_MIN
            mx /= _DBL_MIN
            back = _DBL_MIN
            _, max_e = math.frexp(mx)
        scale = math.ldexp(1.0, -max_e)
        unscale = 0.0  # (2^max_e may overflow: divide below)
    csum = 1.0
    frac1 = 0.0
    frac2 = 0.0
    t = x * scale
    hi = t * t  # dl_mul: the square and its exact error
    lo = _fma(t, t, -hi)
    s = csum + hi
    frac2 += (csum - s) + hi
    csum = s
    frac1 += lo
    t = y * scale
    hi = t * t
    lo = _fma(t, t, -hi)
    s = csum + hi
    frac2 += (csum - s) + hi
    csum = s
    frac1 += lo
    h = math.sqrt(csum - 1.0 + (frac1 + frac2))
    hi = -h * h
    lo = _fma(-h, h, -hi)
    s = csum + hi
    frac2 += (csum - s) + hi
    csum = s
    frac1 += lo
    t = csum - 1.0 + (frac1 + frac2)
    h += t / (2.0 * h)
    if unscale > 0.0:
        return h * unscale
    return back * (h / scale)


@_jit
def _pmin2(a, b):
    """Python's min(a, b): the first argument wins unless beaten."""
    return b if b < a else a


# --------------------------------------------------------------------------------------------
# the path's linear phases (laws.stronge._Path.run_linear, stage_dp, advance, stage_event)
#
# The path's state travels as the tuple (p, pt1, pt2, vn, vt1, vt2, Wn, compressing, target,
# done); Wc and pc are extras of the Python kernel only.


@_jit
def _run_linear(p, pt1, pt2, vn, vt1, vt2, Wn, compressing, target, done, e, tr, an, l1, l2,
                at1, at2, dp_stop):
    """_Path.run_linear: one linear phase until its slip stops or the collision ends.
    Returns (status, stopped, p, pt1, pt2, vn, vt1, vt2, Wn, compressing, target, done)."""
    while True:
        if compressing:  # stage_dp
            dp_end = _pmax2(-vn / an, 0.0) if an > JAM_RTOL * tr else _INF
        else:
            D = target - Wn
            if D <= 0.0:
                dp_end = 0.0
            else:
                vp = _pmax2(vn, 0.0)
                disc = vp * vp + 2.0 * an * D
                dp_end = _INF if disc < 0.0 else 2.0 * D / (vp + math.sqrt(disc))
        if dp_stop <= dp_end:
            if dp_stop == _INF:
                return (JAM, False, p, pt1, pt2, vn, vt1, vt2, Wn, compressing, target, done)
            dp = dp_stop  # advance
            Wn += dp * (vn + 0.5 * an * dp)
            vn += an * dp
            p += dp
            pt1 += l1 * dp
            vt1 += at1 * dp
            pt2 += l2 * dp
            vt2 += at2 * dp
            return (OK, True, p, pt1, pt2, vn, 0.0, 0.0, Wn, compressing, target, done)
        dp = dp_end
        Wn += dp * (vn + 0.5 * an * dp)
        vn += an * dp
        p += dp
        pt1 += l1 * dp
        vt1 += at1 * dp
        pt2 += l2 * dp
        vt2 += at2 * dp
        dp_stop -= dp_end
        if compressing:  # stage_event
            vn = 0.0
            compressing = False
            target = (1.0 - e * e) * Wn
            if e == 0.0:
                done = True
        else:
            Wn = target
            done = True
        if done:
            return (OK, False, p, pt1, pt2, vn, vt1, vt2, Wn, compressing, target, done)


# --------------------------------------------------------------------------------------------
# the onset direction (laws.stronge._onset)


@_jit
def _onset(b1, b2, C11, C12, C22, mu):
    """(kappa, s1, s2): the slip direction selected at v_t = 0 when sticking is inadmissible
    (safeguarded Newton in C's eigenbasis, as laws.stronge._onset)."""
    half = 0.5 * (C11 + C22)
    rad = _hypot(0.5 * (C11 - C22), C12)
    c1 = half + rad
    c2 = (C11 * C22 - C12 * C12) / c1
    th = 0.5 * math.atan2(2.0 * C12, C11 - C22)
    q1 = math.cos(th)
    q2 = math.sin(th)
    g1 = q1 * b1 + q2 * b2
    g2 = -q2 * b1 + q1 * b2
    m1 = mu * c1
    m2 = mu * c2
    lo = 0.0
    hi = _hypot(b1, b2)
    k = 0.0
    for _ in range(100):
        x1 = g1 / (k + m1)
        x2 = g2 / (k + m2)
        nrm = _hypot(x1, x2)
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
    nrm = _hypot(x1, x2)
    x1 = x1 / nrm
    x2 = x2 / nrm
    return k, q1 * x1 - q2 * x2, q2 * x1 + q1 * x2


# --------------------------------------------------------------------------------------------
# the curved slip (laws.stronge._curved_slip): DOP853 in sigma, state y = (p, pi_t, W_n)


@_jit
def _rhs(y0, y1, y2, vn0, vt01, vt02, A, b1, b2, C11, C12, C22, mu):
    v1 = vt01 + b1 * y0 + C11 * y1 + C12 * y2
    v2 = vt02 + b2 * y0 + C12 * y1 + C22 * y2
    r = _hypot(v1, v2)
    return r, -mu * v1, -mu * v2, r * (vn0 + A * y0 + b1 * y1 + b2 * y2)


@_jit
def _step(y0, y1, y2, y3, f0, f1, f2, f3, h, K, vn0, vt01, vt02, A, b1, b2, C11, C12, C22,
          mu):
    """One DOP853 step from y (slope f) of length h: y_new; the stage slopes in K[:, :12].
    (The stages' W_n components are not formed: the slope does not depend on W_n.)"""
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
    return y0 + h * s0, y1 + h * s1, y2 + h * s2, y3 + h * s3


@_jit
def _err_terms(i, yi, yni, refi, K):
    """(sum E5 K_i / sc)^2 and (sum E3 K_i / sc)^2 of component i; ok False where CPython's
    ``** 2`` would raise OverflowError."""
    sc = ODE_RTOL * (refi + _pmax2(abs(yi), abs(yni)))
    s5 = 0.0
    s3 = 0.0
    for m in range(_NE):
        s5 += _E5[m] * K[i, m]
    for m in range(_NE):
        s3 += _E3[m] * K[i, m]
    x5 = s5 / sc
    x3 = s3 / sc
    t5 = _sq(x5)
    t3 = _sq(x3)
    ok = not ((math.isinf(t5) and math.isfinite(x5)) or (math.isinf(t3) and math.isfinite(x3)))
    return t5, t3, ok


@_jit
def _event(y0, y1, y2, y3, compressing, target, vn0, A, b1, b2):
    if compressing:
        return vn0 + A * y0 + b1 * y1 + b2 * y2
    return y3 - target


@_jit
def _locate(y0, y1, y2, y3, f0, f1, f2, f3, h, g0, g1, compressing, target, K, vn0, vt01,
            vt02, A, b1, b2, C11, C12, C22, mu):
    """The event inside the accepted step [0, h]: Newton on the step length, bracketed."""
    lo = 0.0
    hi = h
    tau = h * g0 / (g0 - g1)
    t0, t1, t2, t3 = y0, y1, y2, y3
    final = False  # the last step, to the converged length (one call site of _step)
    for it in range(61):
        t0, t1, t2, t3 = _step(y0, y1, y2, y3, f0, f1, f2, f3, tau, K, vn0, vt01, vt02, A,
                               b1, b2, C11, C12, C22, mu)
        if final:
            break
        g = _event(t0, t1, t2, t3, compressing, target, vn0, A, b1, b2)
        if g == 0.0:
            break
        if g < 0.0:
            lo = tau
        else:
            hi = tau
        r0, r1, r2, r3 = _rhs(t0, t1, t2, vn0, vt01, vt02, A, b1, b2, C11, C12, C22, mu)
        rate = A * r0 + b1 * r1 + b2 * r2 if compressing else r3
        new = tau - g / rate if rate > 0.0 else 0.5 * (lo + hi)
        if not lo <= new <= hi:
            new = 0.5 * (lo + hi)
        final = abs(new - tau) <= 1e-13 * h
        if it == 59 and not final:  # the Python kernel's 60 iterations
            break
        tau = new
    return t0, t1, t2, t3


@_jit
def _curved_slip(p, pt1, pt2, vn, vt1, vt2, Wn, compressing, target, done, e, tr, vn0, vt01,
                 vt02, A, b1, b2, C11, C12, C22, mu, vscale):
    """laws.stronge._curved_slip: integrate a curved slip in sigma until it stops (v_t set to
    0) or the collision ends. Returns (status, p, pt1, pt2, vn, vt1, vt2, Wn, compressing,
    target, done); status OK, JAM or DEFER (step-size underflow: the Python kernel's
    SolverError)."""
    K = np.empty((4, _NE))
    pref = -vn0 / A  # frictionless compression impulse
    ref3 = -vn0 * pref
    y0, y1, y2, y3 = p, pt1, pt2, Wn
    f0, f1, f2, f3 = _rhs(y0, y1, y2, vn0, vt01, vt02, A, b1, b2, C11, C12, C22, mu)
    nb = _hypot(b1, b2)
    nc = 0.5 * (C11 + C22) + _hypot(0.5 * (C11 - C22), C12)
    h = 0.05 / (nb + mu * nc + A * f0 / -vn0)
    g_old = _event(y0, y1, y2, y3, compressing, target, vn0, A, b1, b2)
    steps = 0
    since = 0
    r_min = f0
    n = 4.0
    while True:
        z0, z1, z2, z3 = _step(y0, y1, y2, y3, f0, f1, f2, f3, h, K, vn0, vt01, vt02, A, b1,
                               b2, C11, C12, C22, mu)
        n0, n1, n2, n3 = _rhs(z0, z1, z2, vn0, vt01, vt02, A, b1, b2, C11, C12, C22, mu)
        K[0, _NS] = n0
        K[1, _NS] = n1
        K[2, _NS] = n2
        K[3, _NS] = n3
        e5 = 0.0
        e3 = 0.0
        ok = True
        for i in range(4):  # (a loop: a literal i would compile _err_terms four times)
            if i == 0:
                t5, t3, oki = _err_terms(i, y0, z0, pref, K)
            elif i == 1:
                t5, t3, oki = _err_terms(i, y1, z1, pref, K)
            elif i == 2:
                t5, t3, oki = _err_terms(i, y2, z2, pref, K)
            else:
                t5, t3, oki = _err_terms(i, y3, z3, ref3, K)
            e5 += t5
            e3 += t3
            ok = ok and oki
        if not ok:  # the Python kernel: OverflowError
            return (DEFER, p, pt1, pt2, vn, vt1, vt2, Wn, compressing, target, done)
        err = 0.0 if e5 == 0.0 and e3 == 0.0 else abs(h) * e5 / math.sqrt((e5 + 0.01 * e3) * n)
        if not err <= 1.0:
            if not math.isfinite(err):
                err = 1e10
            h *= _pmax2(0.2, 0.9 * err ** -0.125)
            if h <= 1e-300:  # SolverError: the Python kernel raises it
                return (DEFER, p, pt1, pt2, vn, vt1, vt2, Wn, compressing, target, done)
            continue
        steps += 1
        g_new = _event(z0, z1, z2, z3, compressing, target, vn0, A, b1, b2)
        if g_new >= 0.0 and g_old < 0.0:
            y0, y1, y2, y3 = _locate(y0, y1, y2, y3, f0, f1, f2, f3, h, g_old, g_new,
                                     compressing, target, K, vn0, vt01, vt02, A, b1, b2, C11,
                                     C12, C22, mu)
            # set_state
            p, pt1, pt2, Wn = y0, y1, y2, y3
            vn = vn0 + A * y0 + b1 * y1 + b2 * y2
            vt1 = vt01 + b1 * y0 + C11 * y1 + C12 * y2
            vt2 = vt02 + b2 * y0 + C12 * y1 + C22 * y2
            if compressing:  # stage_event
                vn = 0.0
                compressing = False
                target = (1.0 - e * e) * Wn
                if e == 0.0:
                    done = True
            else:
                Wn = target
                done = True
            if done:
                return (OK, p, pt1, pt2, vn, vt1, vt2, Wn, compressing, target, done)
            f0, f1, f2, f3 = _rhs(y0, y1, y2, vn0, vt01, vt02, A, b1, b2, C11, C12, C22, mu)
            g_old = _event(y0, y1, y2, y3, compressing, target, vn0, A, b1, b2)
            continue
        y0, y1, y2, y3 = z0, z1, z2, z3
        f0, f1, f2, f3 = n0, n1, n2, n3
        g_old = g_new
        if not compressing and vn0 + A * y0 + b1 * y1 + b2 * y2 < 1e-9 * vn0:  # re-approach
            return (JAM, p, pt1, pt2, vn, vt1, vt2, Wn, compressing, target, done)
        r = f0
        if r < r_min:
            r_min = r
            since = 0
        else:
            since += 1
        # settle: hand a decelerating slip to an exact straight finish once accurate
        stalled = since > 20
        if r == 0.0:  # the Python kernel: ZeroDivisionError
            return (DEFER, p, pt1, pt2, vn, vt1, vt2, Wn, compressing, target, done)
        v1 = vt01 + b1 * y0 + C11 * y1 + C12 * y2
        v2 = vt02 + b2 * y0 + C12 * y1 + C22 * y2
        s1 = v1 / r
        s2 = v2 / r
        a1 = b1 - mu * (C11 * s1 + C12 * s2)
        a2 = b2 - mu * (C12 * s1 + C22 * s2)
        rate = s1 * a1 + s2 * a2  # d|v_t|/dp
        floor = r <= FLOOR_RTOL * vscale or (stalled and r <= TAIL_RTOL * vscale)
        settled = True
        if not floor:
            if not rate < 0.0:
                settled = False
            else:
                g = s1 * a2 - s2 * a1  # |v_t| dphi/dp
                cs = -C11 * s1 * s2 + C12 * (s1 * s1 - s2 * s2) + C22 * s2 * s1
                cp = C11 * s2 * s2 - 2.0 * C12 * s1 * s2 + C22 * s1 * s1
                dh = g - mu * cs
                dg = -rate - mu * cp
                if not (dg < 0.0 and abs(g) <= 1e-3 * -dg
                        and r * abs(dh * g) <= 1e-13 * pref * -rate * (-rate - dg) * -dg):
                    settled = False
        if settled:
            p, pt1, pt2, Wn = y0, y1, y2, y3  # set_state
            vn = vn0 + A * y0 + b1 * y1 + b2 * y2
            vt1 = vt01 + b1 * y0 + C11 * y1 + C12 * y2
            vt2 = vt02 + b2 * y0 + C12 * y1 + C22 * y2
            if rate < 0.0:
                vt1 = r * s1
                vt2 = r * s2
                st, _, p, pt1, pt2, vn, vt1, vt2, Wn, compressing, target, done = _run_linear(
                    p, pt1, pt2, vn, vt1, vt2, Wn, compressing, target, done, e, tr,
                    A - mu * (b1 * s1 + b2 * s2), -mu * s1, -mu * s2, rate * s1, rate * s2,
                    r / -rate)
                return (st, p, pt1, pt2, vn, vt1, vt2, Wn, compressing, target, done)
            # |v_t| at the round-off floor, not decreasing: it has stopped
            return (OK, p, pt1, pt2, vn, 0.0, 0.0, Wn, compressing, target, done)
        if steps > MAX_STEPS or y0 > MAX_IMPULSE * pref:
            return (JAM, p, pt1, pt2, vn, vt1, vt2, Wn, compressing, target, done)
        h *= _pmin2(10.0, 0.9 * err ** -0.125) if err > 0.0 else 10.0


# --------------------------------------------------------------------------------------------
# one spatial contact (laws.stronge._spatial)


@_jit
def _stronge_spatial(w00, w01, w02, w11, w12, w22, v0, v1, v2, e, mu, out):
    """laws.stronge._spatial (mu > 0, approaching contact, W in the safe range)."""
    A = w00
    b1 = w01
    b2 = w02
    C11 = w11
    C12 = w12
    C22 = w22
    tr = A + C11 + C22
    p = 0.0  # the path (laws.stronge._Path)
    pt1 = 0.0
    pt2 = 0.0
    vn = v0
    vt1 = v1
    vt2 = v2
    Wn = 0.0
    # True and False (the caller passes an approaching contact, v0 < 0), typed as plain bools:
    # literal ones would compile a second specialization of every helper taking them
    compressing = v0 < 0.0
    target = 0.0
    done = not compressing
    vscale = _pmax2(_pmax2(abs(v0), abs(v1)), abs(v2))
    r_stop = STOP_RTOL * vscale
    ray_tol = RAY_RTOL * (_hypot(b1, b2) + mu * (C11 + C22))
    stopped = _hypot(v1, v2) <= r_stop
    stick = False
    while not done:
        if stopped:
            detC = C11 * C22 - C12 * C12
            if not detC > SINGULAR_RTOL * _sq(C11 + C22):
                return SINGULAR, FAILED, _NAN, _NAN, _NAN, _NAN
            l1 = -(C22 * b1 - C12 * b2) / detC  # sticking ratio -C^-1 b
            l2 = -(C11 * b2 - C12 * b1) / detC
            if _hypot(l1, l2) <= mu * (1.0 + STICK_RTOL):
                an = A + b1 * l1 + b2 * l2  # det W / det C
                if not an > SINGULAR_RTOL * tr:
                    return SINGULAR, FAILED, _NAN, _NAN, _NAN, _NAN
                stick = True
                st, _, p, pt1, pt2, vn, vt1, vt2, Wn, compressing, target, done = _run_linear(
                    p, pt1, pt2, vn, vt1, vt2, Wn, compressing, target, done, e, tr, an, l1,
                    l2, 0.0, 0.0, _INF)
            else:
                _, s1, s2 = _onset(b1, b2, C11, C12, C22, mu)
                stick = False
                a1 = b1 - mu * (C11 * s1 + C12 * s2)
                a2 = b2 - mu * (C12 * s1 + C22 * s2)
                st, _, p, pt1, pt2, vn, vt1, vt2, Wn, compressing, target, done = _run_linear(
                    p, pt1, pt2, vn, vt1, vt2, Wn, compressing, target, done, e, tr,
                    A - mu * (b1 * s1 + b2 * s2), -mu * s1, -mu * s2, a1, a2, _INF)
            if st != OK:
                return st, FAILED, _NAN, _NAN, _NAN, _NAN
            continue
        r = _hypot(vt1, vt2)
        s1 = vt1 / r
        s2 = vt2 / r
        a1 = b1 - mu * (C11 * s1 + C12 * s2)
        a2 = b2 - mu * (C12 * s1 + C22 * s2)
        if abs(s1 * a2 - s2 * a1) <= ray_tol:  # on an invariant ray: a linear phase
            rate = s1 * a1 + s2 * a2
            st, stopped, p, pt1, pt2, vn, vt1, vt2, Wn, compressing, target, done = \
                _run_linear(p, pt1, pt2, vn, vt1, vt2, Wn, compressing, target, done, e, tr,
                            A - mu * (b1 * s1 + b2 * s2), -mu * s1, -mu * s2, rate * s1,
                            rate * s2, r / -rate if rate < 0.0 else _INF)
        else:
            st, p, pt1, pt2, vn, vt1, vt2, Wn, compressing, target, done = _curved_slip(
                p, pt1, pt2, vn, vt1, vt2, Wn, compressing, target, done, e, tr, v0, v1, v2,
                A, b1, b2, C11, C12, C22, mu, vscale)
            stopped = not done
        if st != OK:
            return st, FAILED, _NAN, _NAN, _NAN, _NAN
    return OK, STICK if stick else SLIDE, p, pt1, pt2, _NAN
