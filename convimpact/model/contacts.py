"""Contacts: signed gap, contact frame and the contact Jacobian ``Jc`` (eqs. 16-19).

A contact joins body i (a point, or a sphere of radius r_i around it) and body j (a plane or
a sphere). The frame is ``n`` (from body j toward body i) and ``t`` = n turned by +90 degrees
(planar) or ``t1``, ``t2 = n x t1`` (spatial). The rows of ``Jc`` are the frame axes applied
to the relative velocity of the two material contact points, ``Jc = [n t1 t2]^T (J_i - J_j)``
= the paper's ``[c_n c_t]^T`` (eq. 19), so ``d(gap)/dt = Jc[0] @ theta_dot``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..impact.errors import SingularSystemError
from .geometry import orthonormal_complement, perp
from .kinematics import ensure_configuration, point_jacobian, world_point


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


def contact_frame(model, data, name: str, theta) -> ContactFrame:
    """Evaluate contact ``name`` at theta (gap, frame and Jacobian)."""
    spec = model.contact(name)
    ensure_configuration(model, data, theta)
    key = "q:contact:" + name
    if key in data.cache:
        return data.cache[key]
    ci = world_point(data, spec.body, spec.point)
    if spec.target == "plane":
        n = data.rotation[spec.other] @ spec.normal
        o = world_point(data, spec.other, spec.other_point)
        gap = float(n @ (ci - o)) - spec.radius
        xi = ci - spec.radius * n
        xj = xi
        if model.planar:
            tangents = perp(n)[None]
        else:
            t1 = data.rotation[spec.other] @ spec.tangent
            tangents = np.stack([t1, np.cross(n, t1)])
    else:
        cj = world_point(data, spec.other, spec.other_point)
        delta = ci - cj
        dist = float(np.linalg.norm(delta))
        if dist < 1e-12:
            raise SingularSystemError(
                f"contact {name!r}: the two sphere centres coincide, so the contact normal is "
                "undefined; move the bodies apart or use a plane contact")
        n = delta / dist
        gap = dist - spec.radius - spec.other_radius
        xi = ci - spec.radius * n
        xj = cj + spec.other_radius * n
        if model.planar:
            tangents = perp(n)[None]
        else:
            tangents = np.stack(orthonormal_complement(n))
    Ji, _ = point_jacobian(model, data, spec.body, xi)
    Jj, _ = point_jacobian(model, data, spec.other, xj)
    basis = np.vstack([n[None], tangents])
    frame = ContactFrame(name, gap, xi, n, tangents, basis @ (Ji - Jj))
    data.cache[key] = frame
    return frame


def contact_gap(model, data, name: str, theta) -> float:
    """Signed gap of contact ``name`` at theta."""
    return contact_frame(model, data, name, theta).gap


def contact_jacobian(model, data, name: str, theta) -> np.ndarray:
    """Contact Jacobian ``Jc`` (rows n, t / n, t1, t2) of contact ``name`` at theta, (d, k)."""
    return contact_frame(model, data, name, theta).jacobian.copy()
