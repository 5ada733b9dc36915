"""Contacts: signed gap, contact frame and the contact Jacobian ``Jc`` (eqs. 16-19).

A contact joins body i (a point, or a sphere of radius r_i around it) and body j (a plane or
a sphere). The frame is ``n`` (from body j toward body i) and ``t`` = n turned by +90 degrees
(planar) or ``t1``, ``t2 = n x t1`` (spatial). The rows of ``Jc`` are the frame axes applied
to the relative velocity of the two material contact points, ``Jc = [n t1 t2]^T (J_i - J_j)``
= the paper's ``[c_n c_t]^T`` (eq. 19), so ``d(gap)/dt = Jc[0] @ theta_dot``.
``Jc_dot`` (:func:`contact_jacobian_dot`) is its exact time derivative along theta_dot, the
contact points and the frame moving with the bodies.

Every contact of the model is evaluated in one compiled pass
(:mod:`convimpact.model.recursive`): ``Jc[r, s] = S_s . (e_r, x x e_r)`` over the joint
coordinates s that move the contact point x.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import SingularSystemError
from .recursive import CDOT, CONTACT


@dataclass(frozen=True, eq=False)
class ContactFrame:
    """A contact evaluated at a configuration.

    Attributes
    ----------
    name : the contact's name.
    gap : signed distance (> 0 separated, 0 touching, < 0 penetrating).
    point : (d,) world position of the contact point on body i.
    normal : (d,) unit normal pointing toward body i.
    tangents : (d - 1, d) unit tangent(s): ``t`` (planar) or ``t1, t2`` (spatial).
    jacobian : (d, k) rows n, t or n, t1, t2 of the relative contact-point velocity.
    """

    name: str
    gap: float
    point: np.ndarray
    normal: np.ndarray
    tangents: np.ndarray
    jacobian: np.ndarray


def _index(model, name: str) -> int:
    try:
        return model._contact_index[name]
    except (KeyError, TypeError):
        model.contact(name)  # raises ModelError naming the contacts
        raise


def _checked(model, data, c: int, name: str) -> None:
    if not data.contact_ok[c]:
        raise SingularSystemError(
            f"contact {name!r}: the two sphere centres coincide, so the contact normal is "
            "undefined; move the bodies apart or use a plane contact")


def contact_frame(model, data, name: str, theta) -> ContactFrame:
    """Evaluate contact ``name`` at theta (gap, frame and Jacobian)."""
    c = _index(model, name)
    data.compute(CONTACT, theta)
    key = "q:contact:" + name
    hit = data.cache.get(key)
    if hit is not None:
        return hit
    _checked(model, data, c, name)
    d = model.dim
    E = data.contact_basis[c]
    frame = ContactFrame(name, float(data.gap[c]), data.contact_point[c, 0, :d].copy(),
                         E[0, :d].copy(), E[1:d, :d].copy(), data.contact_jacobian[c, :d].copy())
    data.cache[key] = frame
    return frame


def contact_gap(model, data, name: str, theta) -> float:
    """Signed gap of contact ``name`` at theta."""
    c = _index(model, name)
    data.compute(CONTACT, theta)
    _checked(model, data, c, name)
    return float(data.gap[c])


def contact_jacobian(model, data, name: str, theta) -> np.ndarray:
    """Contact Jacobian ``Jc`` (rows n, t / n, t1, t2) of contact ``name`` at theta, (d, k)."""
    c = _index(model, name)
    data.compute(CONTACT, theta)
    if not data.contact_ok[c]:
        _checked(model, data, c, name)
    return data.jacobian_rows[c].copy()


def contact_jacobian_dot(model, data, name: str, theta, dtheta) -> np.ndarray:
    """``d Jc / dt`` along theta_dot (rows n, t / n, t1, t2) of contact ``name``, (d, k)."""
    c = _index(model, name)
    data.compute(CDOT, theta, dtheta)
    if not data.contact_ok[c]:
        _checked(model, data, c, name)
    return data.jacobian_rate_rows[c].copy()
