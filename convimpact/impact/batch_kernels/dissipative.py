"""The compiled kernel of the dissipative law for one contact
(:func:`convimpact.impact.laws.dissipative.contact_kernel`): the plastic (e = 0) impulse -- the
frictionless one if mu = 0, else the CCP law's -- times (1 + e) (Poisson's hypothesis). Each
kernel returns ``(status, regime, p0, p1, p2, effective_mass)``.
"""

from __future__ import annotations

from .ccp import _ccp_planar, _ccp_spatial
from .common import FRICTIONLESS, OK, _NAN, _jit


@_jit
def _dissipative_planar(w00, w01, w11, v0, v1, e, mu, out):
    """laws.dissipative.contact_kernel, d = 2."""
    if mu == 0.0:
        st, rg, p0, p1, p2, em = OK, FRICTIONLESS, -(1.0 + 0.0) * v0 / w00, 0.0, 0.0, _NAN
    else:
        st, rg, p0, p1, p2, em = _ccp_planar(w00, w01, w11, v0, v1, 0.0, mu, out)
    if st != OK:
        return st, rg, p0, p1, p2, em
    k = 1.0 + e
    return OK, rg, k * p0, k * p1, k * p2, _NAN


@_jit
def _dissipative_spatial(w00, w01, w02, w11, w12, w22, v0, v1, v2, e, mu, out):
    """laws.dissipative.contact_kernel, d = 3."""
    if mu == 0.0:
        st, rg, p0, p1, p2, em = OK, FRICTIONLESS, -(1.0 + 0.0) * v0 / w00, 0.0, 0.0, _NAN
    else:
        st, rg, p0, p1, p2, em = _ccp_spatial(w00, w01, w02, w11, w12, w22, v0, v1, v2,
                                              0.0, mu, out)
    if st != OK:
        return st, rg, p0, p1, p2, em
    k = 1.0 + e
    return OK, rg, k * p0, k * p1, k * p2, _NAN
