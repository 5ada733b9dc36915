"""Chatterjee & Ruina's algebraic law (J. Appl. Mech. 65, 939-951, 1998): the plastic
impulses, scaled by two restitution coefficients, then brought back into the friction cone.

With the contact's Delassus block W and pre-impact velocity v (normal first, approaching
``v_n < 0``), two plastic impulses bound the collision:

* the frictionless plastic impulse ``J_I = -(v_n / W_nn) n``, which stops the normal motion;
* the sticking plastic impulse ``J_II = -W^-1 v``, which stops the contact point altogether.

The law's candidate scales the first by Newton's ``1 + e`` and the difference by ``1 + e_t``
(the tangential restitution):

    J^ = (1 + e) J_I + (1 + e_t) (J_II - J_I).

If J^ lies in the friction cone, ``J = J^`` (regime "stick": friction below its bound);
otherwise J is the point where the segment from ``(1 + e) J_I`` along ``J_II - J_I`` leaves
the cone (regime "slide": friction saturated),

    J = (1 + e) J_I + kappa (J_II - J_I),
    kappa = mu (1 + e) (n.J_I) / (|J_II,t| - mu n.(J_II - J_I))  in (0, 1 + e_t).

Properties (each checked by the tests against this derivation). ``J_I`` and ``b = J_II - J_I``
are W-orthogonal (``J_I.W b = 0``), so with ``J = s J_I + k b`` (s = 1 + e):

* Newton's restitution holds exactly whatever k: ``v_n+ = -e v_n-``;
* ``T+ - T- = 1/2 s (s - 2) |J_I|_W^2 + 1/2 k (k - 2) |b|_W^2`` (|x|_W^2 = x.W.x), so the
  energy never rises for ``0 <= e <= 1`` and ``-1 <= e_t <= 1`` (k in [0, 2]); outside that
  range of e_t the law creates energy (k > 2 or k < 0 gives a positive second term), which is
  why ``e_t`` is refused there;
* with W diagonal in the contact frame (a sphere or a disk on a plane) the post-impact slip is
  ``v_t+ = -e_t v_t-`` while J^ stays in the cone: e_t is the tangential coefficient of
  restitution of the rough-ball law it generalizes.

The law is defined per contact: at several contacts it applies contact by contact when they
are dynamically independent (W block-diagonal), and refuses coupled contacts.

Extras: ``sticking_weight`` (k: 1 + e_t, or kappa when brought back into the cone) and
``tangential_restitution`` (e_t).
"""

from __future__ import annotations

import math

from .algebra import _inverse3, _linsolve3, _solve2
from .codes import FAILED, OK, SINGULAR, SLIDE, STICK, _NAN, _in_cone, _jit
from ...errors import NotSupportedError
from ..exact.dispatch import compiled_kernel, independent_contacts_result
from .chatterjee_ruina_derivative import (impulse_derivative,  # noqa: F401
                                          several_impulse_derivative)

LAW = "chatterjee-ruina"
#: the tangential restitution's admissible range (the law creates energy outside it)
E_T_RANGE = (-1.0, 1.0)
#: the extras scratch: [sticking weight]
_OUT_WEIGHT = 0


@_jit
def _cr_answer(s, k, a0, b0, b1, b2, mu, out):
    """J = s J_I + k b, brought back into the cone along b if needed."""
    hn = s * a0 + k * b0
    if _in_cone(hn, k * math.hypot(b1, b2), mu):
        out[_OUT_WEIGHT] = k
        return OK, STICK, hn, k * b1, k * b2, _NAN
    kappa = mu * s * a0 / (math.hypot(b1, b2) - mu * b0)
    out[_OUT_WEIGHT] = kappa
    return OK, SLIDE, s * a0 + kappa * b0, kappa * b1, kappa * b2, _NAN


@_jit
def _cr_planar(w00, w01, w11, v0, v1, e, mu, et, out):
    """One planar contact: J_II from the 2 x 2 solve, then :func:`_cr_answer`."""
    x0, x1, ok = _solve2(w00, w01, w11, -v0, -v1)  # J_II = -W^-1 v
    if not ok:
        return SINGULAR, FAILED, _NAN, _NAN, _NAN, _NAN
    a0 = -v0 / w00  # J_I
    return _cr_answer(1.0 + e, 1.0 + et, a0, x0 - a0, x1, 0.0, mu, out)


@_jit
def _cr_spatial(w00, w01, w02, w11, w12, w22, v0, v1, v2, e, mu, et, out):
    """One spatial contact: J_II from the 3 x 3 solve, then :func:`_cr_answer`."""
    i00, i01, i02, i11, i12, i22, det, ok = _inverse3(w00, w01, w02, w11, w12, w22)
    if not ok:
        return SINGULAR, FAILED, _NAN, _NAN, _NAN, _NAN
    x0, x1, x2 = _linsolve3(w00, w01, w02, w11, w12, w22, i00, i01, i02, i11, i12, i22, det,
                            -v0, -v1, -v2)
    a0 = -v0 / w00
    return _cr_answer(1.0 + e, 1.0 + et, a0, x0 - a0, x1, x2, mu, out)


def _extras(out, regime, impulse, w, v, d, e, mu, et) -> tuple:
    return {"sticking_weight": float(out[_OUT_WEIGHT]), "tangential_restitution": et}, ()


contact_kernel = compiled_kernel(LAW, _cr_planar, _cr_spatial, _extras, tangential=True)


def program_result(P, backend, method: str, opts):
    """Several contacts: the law contact by contact when they are dynamically independent (W
    block-diagonal), or when one contact approaches and its impulse leaves the others lifting
    (no cone program is solved); coupled simultaneous impacts raise NotSupportedError (the law
    is defined per contact)."""
    result = independent_contacts_result(P, LAW, method, one_approaching=True)
    if result is None:
        raise NotSupportedError(
            "law 'chatterjee-ruina' is defined per contact: these contacts strike together "
            "and are dynamically coupled (W is not block-diagonal); use law='ccp', "
            "'dissipative' or 'coulomb' (method='interior'), or 'stronge' (its two-phase "
            "coupled formulation)")
    return result
