"""The compiled kernel of Stronge's energetic law for one planar contact
(:func:`convimpact.impact.laws.stronge.contact_kernel`, ``d = 2``), a line-by-line port of its
exact piecewise-linear impulse-space path: phases of slip (friction ``-mu s``), stick (the
sticking ratio ``-W_tn / W_tt`` when ``|W_tn| <= mu W_tt``) and slip reversal / onset
(``s = sgn W_tn``), each linear in the normal impulse, ended by the slip's stop, the end of
compression (``v_n = 0``) or of restitution (the normal impulse's work in restitution equal to
``-e^2`` times its work in compression: the smaller positive root of a quadratic, written
cancellation-free). Returns ``(status, regime, p0, p1, p2, effective_mass)``.

A spatial contact (its slip curves and is integrated in impulse space) is
:mod:`.stronge_spatial`'s. The tolerances mirror :mod:`convimpact.impact.laws.stronge`.
"""

from __future__ import annotations

import math

from .common import JAM, OK, SINGULAR, SLIDE, STICK, FAILED, _NAN, _jit

#: law code (the order of batch.LAW_CODES)
STRONGE = 4
#: laws.stronge.STICK_RTOL, JAM_RTOL, SINGULAR_RTOL
STICK_RTOL = 1e-12
JAM_RTOL = 1e-12
SINGULAR_RTOL = 1e-12

_INF = math.inf


@_jit
def _stronge_planar(A, B, C, v0, v1, e, mu, out):
    """laws.stronge._planar (mu > 0, approaching contact, W in the safe range)."""
    tr = A + C
    p = 0.0
    pt = 0.0
    vn = v0
    vt = v1
    Wn = 0.0
    compressing = True
    target = 0.0
    done = False
    stick = False
    while not done:
        if vt != 0.0:
            s = math.copysign(1.0, vt)
            lam = -mu * s
            at = B + C * lam
            stop = -vt / at if vt * at < 0.0 else _INF
            stick = False
        elif abs(B) <= mu * C * (1.0 + STICK_RTOL):
            det = A * C - B * B
            if not det > SINGULAR_RTOL * (A + C) ** 2:
                return SINGULAR, FAILED, _NAN, _NAN, _NAN, _NAN
            stick = True
            lam = -B / C
            at = 0.0
            stop = _INF
        else:
            s = math.copysign(1.0, B)
            lam = -mu * s
            at = B + C * lam
            stop = _INF
            stick = False
        an = A + B * lam
        while True:  # one linear phase until its slip stops or the collision ends
            if compressing:
                dp_end = max(-vn / an, 0.0) if an > JAM_RTOL * tr else _INF
            else:
                D = target - Wn
                if D <= 0.0:
                    dp_end = 0.0
                else:
                    vp = max(vn, 0.0)
                    disc = vp * vp + 2.0 * an * D
                    dp_end = _INF if disc < 0.0 else 2.0 * D / (vp + math.sqrt(disc))
            if stop <= dp_end:
                if stop == _INF:
                    return JAM, FAILED, _NAN, _NAN, _NAN, _NAN
                dp = stop
                Wn += dp * (vn + 0.5 * an * dp)
                vn += an * dp
                p += dp
                pt += lam * dp
                vt = 0.0
                break
            dp = dp_end
            Wn += dp * (vn + 0.5 * an * dp)
            vn += an * dp
            p += dp
            pt += lam * dp
            vt += at * dp
            stop -= dp_end
            if compressing:  # end of compression: restitution starts
                vn = 0.0
                compressing = False
                target = (1.0 - e * e) * Wn
                if e == 0.0:
                    done = True
            else:
                Wn = target
                done = True
            if done:
                break
    return OK, STICK if stick else SLIDE, p, pt, 0.0, _NAN
