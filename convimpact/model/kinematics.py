"""Forward kinematics, point Jacobians and their time derivatives (eqs. 1, 16-17).

:func:`forward_kinematics` walks the tree once per state and records, for every joint
coordinate, its world axis, a point on it and the motion of the frame that carries it. Any
point Jacobian then follows column by column: a revolute coordinate j with world axis a_j
through o_j moves a point x with ``a_j x (x - o_j)`` and turns it with ``a_j``; a prismatic
one moves it with its axis ``u_j``. Their time derivatives use ``d a_j/dt = w_j x a_j`` and
``d o_j/dt`` of the carrying frame, so ``J_dot`` is exact (no differencing).
"""

from __future__ import annotations

import numpy as np

from ..impact.errors import ModelError, NonFiniteError, ShapeError
from .geometry import cross, cross_ww, rot2, rot3


def check_vector(model, value, name: str) -> np.ndarray:
    """``value`` as a finite float vector of length k (ShapeError / NonFiniteError)."""
    k = model.n_coordinates
    try:
        a = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ShapeError(f"{name} must be a numeric vector of length {k}") from None
    if a.shape != (k,):
        raise ShapeError(f"{name} must have shape ({k},) for this model "
                         f"(coordinates {', '.join(model.coordinate_names)}), got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise NonFiniteError(f"{name} contains NaN or infinity; pass finite values")
    return a


def same_configuration(data, theta) -> bool:
    """True when ``data`` already holds configuration ``theta``."""
    return data.theta is not None and np.array_equal(np.asarray(theta, dtype=float), data.theta)


def ensure_configuration(model, data, theta) -> None:
    """Make ``data`` hold configuration ``theta``, keeping its velocity if theta is unchanged."""
    forward_kinematics(model, data, theta, data.dtheta if same_configuration(data, theta) else None)


def forward_kinematics(model, data, theta, dtheta=None) -> None:
    """Fill ``data`` with body poses and velocities at (theta, theta_dot).

    ``dtheta`` None means zero velocities. Nothing is recomputed when ``data`` already holds
    this state, and only the velocity pass runs when just theta_dot changed.
    """
    theta = check_vector(model, theta, "theta")
    dtheta = np.zeros_like(theta) if dtheta is None else check_vector(model, dtheta, "dtheta")
    same_q = data.theta is not None and np.array_equal(theta, data.theta)
    if same_q and np.array_equal(dtheta, data.dtheta):
        return
    if same_q:  # new velocity only: keep configuration-only entries
        data.cache = {key: val for key, val in data.cache.items() if key.startswith("q:")}
    else:
        data.cache.clear()
        _positions(model, data, theta)
        data.theta = theta.copy()
    _velocities(model, data, theta, dtheta)
    data.dtheta = dtheta.copy()


def _positions(model, data, theta: np.ndarray) -> None:
    planar = model.planar
    for b in model.bodies[1:]:
        a = b.parent
        Ra = data.rotation[a]
        offset = Ra @ b.placement_origin
        data.offset[b.index] = offset
        R = Ra @ b.placement_rotation
        p = data.position[a] + offset
        ang = data.angle[a] + b.placement_angle
        for j, mo in zip(b.coordinates, b.motions):
            data.axis_origin[:, j] = p
            q = theta[j]
            if mo.kind == "revolute":
                if planar:
                    aw = mo.axis
                    R = R @ rot2(aw[0] * q)
                    ang += aw[0] * q
                else:
                    aw = R @ mo.axis
                    R = R @ rot3(mo.axis, q)
                data.axis_rev[:, j] = aw
                data.axis_pri[:, j] = 0.0
            else:
                uw = R @ mo.axis
                data.axis_pri[:, j] = uw
                data.axis_rev[:, j] = 0.0
                p = p + uw * q
        data.rotation[b.index] = R
        data.position[b.index] = p
        data.angle[b.index] = ang


def _velocities(model, data, theta: np.ndarray, dtheta: np.ndarray) -> None:
    planar = model.planar
    for b in model.bodies[1:]:
        a = b.parent
        w = data.omega[a].copy()
        v = data.velocity[a] + cross(planar, w, data.offset[b.index])
        for j, mo in zip(b.coordinates, b.motions):
            data.axis_omega[:, j] = w
            data.axis_origin_vel[:, j] = v
            if mo.kind == "revolute":
                w = w + data.axis_rev[:, j] * dtheta[j]
            else:
                uw = data.axis_pri[:, j]
                v = v + cross(planar, w, uw * theta[j]) + uw * dtheta[j]
        data.omega[b.index] = w
        data.velocity[b.index] = v


def world_point(data, body: int, local) -> np.ndarray:
    """World position of a point given in body ``body``'s frame."""
    return data.position[body] + data.rotation[body] @ np.asarray(local, dtype=float)


def world_vector(data, body: int, local) -> np.ndarray:
    """World components of a vector fixed in body ``body``."""
    return data.rotation[body] @ np.asarray(local, dtype=float)


def point_velocity(model, data, body: int, x: np.ndarray) -> np.ndarray:
    """Velocity of the material point of ``body`` that is at world position ``x``."""
    return data.velocity[body] + cross(model.planar, data.omega[body], x - data.position[body])


def point_jacobian(model, data, body: int, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Jacobians ``(Jv, Jw)`` of the material point of ``body`` at world position ``x``.

    ``Jv`` (d, k) maps theta_dot to the point's velocity, ``Jw`` (r, k) to the body's angular
    velocity: the body's block rows of B in eq. (1), at an arbitrary point.
    """
    k, d, r = model.n_coordinates, model.dim, model.rot_dim
    Jv = np.zeros((d, k))
    Jw = np.zeros((r, k))
    if body == 0:
        return Jv, Jw
    s = model.support[body]
    rel = x[:, None] - data.axis_origin[:, s]
    Jv[:, s] = cross(model.planar, data.axis_rev[:, s], rel) + data.axis_pri[:, s]
    Jw[:, s] = data.axis_rev[:, s]
    return Jv, Jw


def point_jacobian_dot(model, data, body: int, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Time derivatives ``(Jv_dot, Jw_dot)`` of :func:`point_jacobian` along theta_dot.

    ``x`` is a material point of ``body`` (it moves with the body).
    """
    k, d, r = model.n_coordinates, model.dim, model.rot_dim
    dJv = np.zeros((d, k))
    dJw = np.zeros((r, k))
    if body == 0:
        return dJv, dJw
    planar = model.planar
    s = model.support[body]
    xdot = point_velocity(model, data, body, x)
    a = data.axis_rev[:, s]
    u = data.axis_pri[:, s]
    w = data.axis_omega[:, s]
    adot = cross_ww(planar, w, a)
    rel = x[:, None] - data.axis_origin[:, s]
    reldot = xdot[:, None] - data.axis_origin_vel[:, s]
    dJv[:, s] = cross(planar, adot, rel) + cross(planar, a, reldot) + cross(planar, w, u)
    dJw[:, s] = adot
    return dJv, dJw


def body_index(model, body) -> int:
    """Index of ``body`` given by name or index (ModelError when unknown)."""
    if isinstance(body, (int, np.integer)):
        if not 0 <= int(body) < model.n_bodies:
            raise ModelError(f"body index {body} out of range 0..{model.n_bodies - 1}")
        return int(body)
    return model.body_index(body)


def frame_placement(model, data, body, local_point=None) -> tuple[np.ndarray, np.ndarray]:
    """World ``(rotation, position)`` of body ``body`` (name or index) or of a point on it."""
    b = body_index(model, body)
    if local_point is None:
        return data.rotation[b].copy(), data.position[b].copy()
    return data.rotation[b].copy(), world_point(data, b, local_point)
