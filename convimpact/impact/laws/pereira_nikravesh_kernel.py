"""The exact single-contact kernel of law ``pereira-nikravesh`` (:mod:`.pereira_nikravesh`,
Section 8 of the paper), compiled: ``method="fast"``, the batch, the compiled lane and the
law's several-contact search (:mod:`.pn_complementarity_prune`) all run this code. In the
plane: the stick test (eq. 42, admissible by eq. 53), else the slide against the slip
(eq. 55) with pi_n from eq. (38); in space: the stick test (eq. 52/53), else the slide of
maximal dissipation (eq. 60).
"""

from __future__ import annotations

import math

from .algebra import _inverse3, _linsolve3, _solve2
from .codes import FAILED, JAM, OK, SINGULAR, SLIDE, STICK, _NAN, _in_cone, _jit, _pmax2
from .max_dissipation import max_dissipation_slide


@_jit
def _pn_planar(w00, w01, w11, v0, v1, e, mu, out):
    """One planar contact, mu > 0: the stick test (eq. 42, admissible by eq. 53), else the slide
    against the slip (eq. 55) with pi_n from eq. (38)."""
    c = -(1.0 + e) * v0
    pn, pt, ok = _solve2(w00, w01, w11, c, -v1)  # eq. (42)
    if not ok:
        return SINGULAR, FAILED, _NAN, _NAN, _NAN, _NAN
    if _in_cone(pn, abs(pt), mu):
        return OK, STICK, pn, pt, 0.0, _NAN
    if v1 != 0.0:
        s = -math.copysign(1.0, v1)
    else:  # no pre-impact slip: friction saturates the way the stick impulse needed
        s = math.copysign(1.0, pt) if pt != 0.0 else 1.0
    D = w00 + mu * s * w01  # eq. (55) direction, eq. (38) denominator
    wm = _pmax2(_pmax2(abs(w00), abs(w01)), abs(w11))
    if not D > 1e-12 * wm:
        return JAM, FAILED, _NAN, _NAN, _NAN, D
    p = c / D
    return OK, SLIDE, p, mu * s * p, 0.0, D


#: ``out`` of the spatial kernel: [P_N's optimum interior?, T_L max, t1, t2]
_OUT_INTERIOR, _OUT_TL, _OUT_T1, _OUT_T2 = 0, 1, 2, 3


@_jit
def _pn_spatial(w00, w01, w02, w11, w12, w22, v0, v1, v2, e, mu, out):
    """One spatial contact, mu > 0: the stick test (eq. 52/53), else the slide of maximal
    dissipation (eq. 60, :func:`~convimpact.impact.laws.max_dissipation.max_dissipation_slide`)."""
    c = -(1.0 + e) * v0
    i00, i01, i02, i11, i12, i22, det, ok = _inverse3(w00, w01, w02, w11, w12, w22)
    if not ok:
        return SINGULAR, FAILED, _NAN, _NAN, _NAN, _NAN
    pn, p1, p2 = _linsolve3(w00, w01, w02, w11, w12, w22, i00, i01, i02, i11, i12, i22, det,
                            c, -v1, -v2)  # eq. (42) in space
    if _in_cone(pn, math.hypot(p1, p2), mu):
        return OK, STICK, pn, p1, p2, _NAN
    st, t1, t2, tl, p, D, interior = max_dissipation_slide(
        w00, w01, w02, w11, w12, w22, v0, v1, v2, c, mu, True, i00, i01, i02, i11, i12, i22,
        p1, p2)
    if st != OK:
        return st, FAILED, _NAN, _NAN, _NAN, _NAN
    out[_OUT_INTERIOR] = 1.0 if interior else 0.0
    out[_OUT_TL] = tl
    out[_OUT_T1] = t1
    out[_OUT_T2] = t2
    return OK, SLIDE, p, mu * p * t1, mu * p * t2, D
