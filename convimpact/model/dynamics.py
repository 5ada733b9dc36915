"""Generalized mass matrix, forces and energies in joint coordinates (eqs. 1-4, 11).

Per body b with centre-of-mass Jacobian ``Jv_b`` and angular Jacobian ``Jw_b`` (its rows of
B, eq. 1), mass ``m_b`` and world inertia ``I_b = R_b I_b' R_b^T``:

* ``M = sum_b m_b Jv_b^T Jv_b + Jw_b^T I_b Jw_b``                                  (eq. 3)
* ``f = sum_b Jv_b^T m_b (g - Jv_dot_b theta_dot)
        + Jw_b^T (-w_b x I_b w_b - I_b Jw_dot_b theta_dot) + Q_applied``             (eq. 4)
* ``M_dot = sum_b m_b (Jv_dot^T Jv + Jv^T Jv_dot) + Jw_dot^T I Jw + Jw^T I Jw_dot
            + Jw^T (w x I - I w x) Jw``                                             (eq. 11)

where g is gravity and ``-w x I w`` the gyroscopic term of the body's generalized force
vector (zero in the plane).
"""

from __future__ import annotations

import numpy as np

from ..impact.errors import NonFiniteError, ShapeError
from .geometry import cross3, skew
from .kinematics import (
    check_vector,
    ensure_configuration,
    forward_kinematics,
    point_jacobian,
    point_jacobian_dot,
)


def _world_inertia(model, data, b: int) -> np.ndarray:
    I = model.bodies[b].inertia
    if model.planar:
        return I
    R = data.rotation[b]
    return R @ I @ R.T


def _com(data, model, b: int) -> np.ndarray:
    return data.position[b] + data.rotation[b] @ model.bodies[b].com


def body_jacobians(model, data) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """``[(c_b, Jv_b, Jw_b)]`` for the moving bodies: centre of mass and its Jacobians."""
    key = "q:body_jacobians"
    if key not in data.cache:
        out = []
        for b in range(1, model.n_bodies):
            c = _com(data, model, b)
            Jv, Jw = point_jacobian(model, data, b, c)
            out.append((c, Jv, Jw))
        data.cache[key] = out
    return data.cache[key]


def _body_jacobians_dot(model, data) -> list[tuple[np.ndarray, np.ndarray]]:
    key = "body_jacobians_dot"
    if key not in data.cache:
        data.cache[key] = [point_jacobian_dot(model, data, b, c)
                           for b, (c, _, _) in enumerate(body_jacobians(model, data), start=1)]
    return data.cache[key]


def velocity_transformation(model, data, theta) -> np.ndarray:
    """B of eq. (1): ``v = B theta_dot`` with v stacking (c_dot_b, w_b) per moving body.

    Shape ``((n_bodies - 1) (d + r), k)``.
    """
    ensure_configuration(model, data, theta)
    return np.vstack([np.vstack([Jv, Jw]) for _, Jv, Jw in body_jacobians(model, data)])


def mass_matrix(model, data, theta) -> np.ndarray:
    """Generalized mass matrix ``M(theta) = B^T M B`` (eq. 3), (k, k) symmetric."""
    ensure_configuration(model, data, theta)
    key = "q:mass_matrix"
    if key not in data.cache:
        k = model.n_coordinates
        M = np.zeros((k, k))
        for b, (_, Jv, Jw) in enumerate(body_jacobians(model, data), start=1):
            M += model.bodies[b].mass * (Jv.T @ Jv) + Jw.T @ _world_inertia(model, data, b) @ Jw
        data.cache[key] = 0.5 * (M + M.T)
    return data.cache[key].copy()


def mass_matrix_dot(model, data, theta, dtheta) -> np.ndarray:
    """``dM/dt`` along theta_dot, (k, k) symmetric (for eq. 11)."""
    forward_kinematics(model, data, theta, dtheta)
    key = "mass_matrix_dot"
    if key not in data.cache:
        k = model.n_coordinates
        Md = np.zeros((k, k))
        for b, ((_, Jv, Jw), (dJv, dJw)) in enumerate(
                zip(body_jacobians(model, data), _body_jacobians_dot(model, data)), start=1):
            m = model.bodies[b].mass
            I = _world_inertia(model, data, b)
            A = m * (dJv.T @ Jv) + dJw.T @ I @ Jw
            Md += A + A.T
            if not model.planar:
                W = skew(data.omega[b])
                Md += Jw.T @ (W @ I - I @ W) @ Jw
        data.cache[key] = Md
    return data.cache[key].copy()


def applied_forces(model, t: float, theta: np.ndarray, dtheta: np.ndarray) -> np.ndarray:
    """The model's applied joint forces at (t, theta, theta_dot), validated; zeros if none."""
    k = model.n_coordinates
    if model.applied_forces is None:
        return np.zeros(k)
    Q = np.asarray(model.applied_forces(t, theta.copy(), dtheta.copy()), dtype=float)
    if Q.shape != (k,):
        raise ShapeError(f"applied forces must return shape ({k},), got {Q.shape}")
    if not np.all(np.isfinite(Q)):
        raise NonFiniteError(f"applied forces returned NaN or infinity at t = {t}")
    return Q


def generalized_forces(model, data, t: float, theta, dtheta) -> np.ndarray:
    """``f = B^T (g - M B_dot theta_dot)`` plus applied joint forces (eq. 4), (k,)."""
    theta = check_vector(model, theta, "theta")
    dtheta = check_vector(model, dtheta, "dtheta")
    forward_kinematics(model, data, theta, dtheta)
    key = "bias_forces"
    if key not in data.cache:
        f = np.zeros(model.n_coordinates)
        for b, ((_, Jv, Jw), (dJv, dJw)) in enumerate(
                zip(body_jacobians(model, data), _body_jacobians_dot(model, data)), start=1):
            m = model.bodies[b].mass
            I = _world_inertia(model, data, b)
            f += Jv.T @ (m * (model.gravity - dJv @ dtheta))
            tau = -I @ (dJw @ dtheta)
            if not model.planar:
                w = data.omega[b]
                tau -= cross3(w, I @ w)
            f += Jw.T @ tau
        data.cache[key] = f
    return data.cache[key] + applied_forces(model, float(t), theta, dtheta)


def kinetic_energy(model, data, theta, dtheta) -> float:
    """``T = 1/2 theta_dot^T M theta_dot``."""
    dtheta = check_vector(model, dtheta, "dtheta")
    return 0.5 * float(dtheta @ mass_matrix(model, data, theta) @ dtheta)


def potential_energy(model, data, theta) -> float:
    """Gravitational potential ``V = -sum_b m_b g . c_b`` (zero at the origin)."""
    ensure_configuration(model, data, theta)
    return -sum(model.bodies[b].mass * float(model.gravity @ c)
                for b, (c, _, _) in enumerate(body_jacobians(model, data), start=1))
