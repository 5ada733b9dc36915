"""Forward kinematics, point Jacobians and their time derivatives (eqs. 1, 16-17).

:func:`forward_kinematics` runs the compiled position and velocity passes of
:mod:`convimpact.model.recursive` once per state: body placements and velocities, and for
every joint coordinate j the origin p_j of its moving frame, its world motion subspace
``S_j`` about p_j (linear part first: ``(0, a_j)`` for a revolute axis a_j through p_j,
``(u_j, 0)`` for a prismatic one) and ``S_dot_j``. Any point Jacobian then follows column by
column: coordinate j moves the material point at x with ``S_lin + S_ang x (x - p_j)`` and
turns it with ``S_ang``; along theta_dot that column changes at
``S_dot_lin + S_dot_ang x (x - p_j) + S_ang x x_dot``, so ``J_dot`` is exact (no
differencing).
"""

from __future__ import annotations

import numpy as np

from ..errors import ModelError, NonFiniteError, ShapeError
from .recursive import POS, VEL, point_columns


def check_vector(model, value, name: str) -> np.ndarray:
    """``value`` as a finite float vector of length k (ShapeError / NonFiniteError)."""
    k = model.n_coordinates
    if (type(value) is np.ndarray and value.dtype == np.float64 and value.shape == (k,)
            and value.flags.c_contiguous):
        a = value
    else:
        try:
            a = np.ascontiguousarray(value, dtype=float)
        except (TypeError, ValueError):
            raise ShapeError(f"{name} must be a numeric vector of length {k}") from None
        if a.shape != (k,):
            raise ShapeError(f"{name} must have shape ({k},) for this model "
                             f"(coordinates {', '.join(model.coordinate_names)}), got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise NonFiniteError(f"{name} contains NaN or infinity; pass finite values")
    return a


def ensure_configuration(model, data, theta) -> None:
    """Make ``data`` hold configuration ``theta``, keeping its velocity if theta is unchanged
    (zero velocities otherwise)."""
    data.compute(POS | VEL, theta)


def forward_kinematics(model, data, theta, dtheta=None) -> None:
    """Fill ``data`` with body poses and velocities at (theta, theta_dot).

    ``dtheta`` None means zero velocities. Nothing is recomputed when ``data`` already holds
    this state, and only the velocity pass runs when just theta_dot changed.
    """
    data.compute(POS | VEL, theta, np.zeros(data.k) if dtheta is None else dtheta)


def world_point(data, body: int, local) -> np.ndarray:
    """World position of a point given in body ``body``'s frame."""
    return data.position[body] + data.rotation[body] @ np.asarray(local, dtype=float)


def _point_columns(model, data, body: int, x, rate: bool) -> tuple[np.ndarray, np.ndarray]:
    k, d = model.n_coordinates, model.dim
    node = int(data.layout.node_of_body[body])
    if node < 0:
        return np.zeros((d, k)), np.zeros((model.rot_dim, k))
    J = np.zeros((6, k))
    x = np.asarray(x, dtype=float)
    point_columns(data.work, node, float(x[0]), float(x[1]), 0.0 if model.planar else float(x[2]),
                  rate, J)
    return (J[:2].copy(), J[5:6].copy()) if model.planar else (J[:3].copy(), J[3:].copy())


def point_jacobian(model, data, body: int, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Jacobians ``(Jv, Jw)`` of the material point of ``body`` at world position ``x``.

    ``Jv`` (d, k) maps theta_dot to the point's velocity, ``Jw`` (r, k) to the body's angular
    velocity: the body's block rows of B in eq. (1), at an arbitrary point. ``data`` holds the
    configuration (:func:`ensure_configuration`).
    """
    return _point_columns(model, data, body, x, False)


def point_jacobian_dot(model, data, body: int, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Time derivatives ``(Jv_dot, Jw_dot)`` of :func:`point_jacobian` along theta_dot.

    ``x`` is a material point of ``body`` (it moves with the body); ``data`` holds the state
    (:func:`forward_kinematics`).
    """
    return _point_columns(model, data, body, x, True)


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
