"""Generalized mass matrix, forces and energies in joint coordinates (eqs. 1-4, 11).

Per body b with centre-of-mass Jacobian ``Jv_b`` and angular Jacobian ``Jw_b`` (its rows of
B, eq. 1), mass ``m_b`` and world inertia ``I_b = R_b I_b' R_b^T``:

* ``M = sum_b m_b Jv_b^T Jv_b + Jw_b^T I_b Jw_b``                                  (eq. 3)
* ``f = sum_b Jv_b^T m_b (g - Jv_dot_b theta_dot)
        + Jw_b^T (-w_b x I_b w_b - I_b Jw_dot_b theta_dot) + Q_applied``             (eq. 4)
* ``M_dot = sum_b m_b (Jv_dot^T Jv + Jv^T Jv_dot) + Jw_dot^T I Jw + Jw^T I Jw_dot
            + Jw^T (w x I - I w x) Jw``                                             (eq. 11)

where g is gravity and ``-w x I w`` the gyroscopic term of the body's generalized force
vector (zero in the plane). They are evaluated by the recursive algorithms of
:mod:`convimpact.model.recursive` (composite rigid bodies for M, Newton-Euler for f, the
differentiated CRBA for M_dot), not by the sums above, which define them: f is
``-(C(theta, theta_dot) theta_dot + g(theta))`` in Pinocchio's terms, ``-rnea(q, v, 0)``.
:func:`momentum_rate` gives ``p_dot = f + M_dot theta_dot`` of eq. (11) in one pass.
"""

from __future__ import annotations

import numpy as np

from ..errors import NonFiniteError, ShapeError
from .kinematics import check_vector, ensure_configuration, point_jacobian
from .recursive import BIAS, MASS, MDOT, POS


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


def velocity_transformation(model, data, theta) -> np.ndarray:
    """B of eq. (1): ``v = B theta_dot`` with v stacking (c_dot_b, w_b) per moving body.

    Shape ``((n_bodies - 1) (d + r), k)``.
    """
    ensure_configuration(model, data, theta)
    return np.vstack([np.vstack([Jv, Jw]) for _, Jv, Jw in body_jacobians(model, data)])


def mass_matrix(model, data, theta) -> np.ndarray:
    """Generalized mass matrix ``M(theta) = B^T M B`` (eq. 3), (k, k) symmetric (CRBA)."""
    data.compute(MASS, theta)
    return data.M.copy()


def mass_matrix_dot(model, data, theta, dtheta) -> np.ndarray:
    """``dM/dt`` along theta_dot, (k, k) symmetric (for eq. 11)."""
    data.compute(MDOT, theta, dtheta)
    return data.M_dot.copy()


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
    """``f = B^T (g - M B_dot theta_dot)`` plus applied joint forces (eq. 4), (k,) (RNEA)."""
    data.compute(BIAS, theta, dtheta)
    f = data.bias.copy()
    if model.applied_forces is not None:
        f += applied_forces(model, float(t), data.theta, data.dtheta)
    return f


def momentum_rate(model, data, t: float, theta, dtheta) -> np.ndarray:
    """``p_dot = f + M_dot theta_dot`` (eq. 11) with the applied forces, (k,), in one pass:
    ``dT/dtheta - dV/dtheta + Q`` by Lagrange's equations."""
    data.compute(BIAS, theta, dtheta)
    p = data.momentum_rate.copy()
    if model.applied_forces is not None:
        p += applied_forces(model, float(t), data.theta, data.dtheta)
    return p


def kinetic_energy(model, data, theta, dtheta) -> float:
    """``T = 1/2 theta_dot^T M theta_dot``."""
    dtheta = check_vector(model, dtheta, "dtheta")
    data.compute(MASS, theta)
    return 0.5 * float(dtheta @ data.M @ dtheta)


def potential_energy(model, data, theta) -> float:
    """Gravitational potential ``V = -sum_b m_b dot(g, c_b)`` (zero at the origin)."""
    data.compute(POS, theta)
    key = "q:potential"
    if key not in data.cache:
        lay = data.layout
        c = data.position3 + np.einsum("bij,bj->bi", data.rotation3, lay.body_com)
        data.cache[key] = -float(lay.body_mass @ (c @ lay.gravity))
    return data.cache[key]
