"""The model's evaluations as they were before the recursive algorithms (a frozen reference).

A verbatim copy of the per-body, column-by-column implementation of M (eq. 3), f (eq. 4),
M_dot, the contact gaps, frames and Jacobians (eqs. 16-19), kept so the compiled recursive
algorithms can be checked against the old definitions. Use :class:`ReferenceModel`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Optional

import numpy as np

from convimpact.errors import ModelError, NonFiniteError, ShapeError, SingularSystemError
from convimpact.model.geometry import cross, cross3, cross_ww, orthonormal_complement, perp, rot2, rot3, skew


# ---- old convimpact/model/data.py ----------------------------------------





class Data:
    """Kinematic quantities of every body and joint axis at the last evaluated state.

    Attributes (after :func:`~convimpact.model.kinematics.forward_kinematics`)
    --------------------------------------------------------------------------
    theta, dtheta : the state the arrays below belong to (copies).
    rotation : (n_bodies, d, d) body orientations; ``angle`` (n_bodies,) planar absolute angles.
    position : (n_bodies, d) body-frame origins; ``velocity`` their velocities.
    omega : (n_bodies, r) body angular velocities.
    axis_rev : (r, k) world axis of each revolute coordinate (0 for prismatic ones).
    axis_pri : (d, k) world axis of each prismatic coordinate (0 for revolute ones).
    axis_origin : (d, k) a world point on each coordinate's axis; ``axis_origin_vel`` its
        velocity as a point of the frame that carries the axis.
    axis_omega : (r, k) angular velocity of the frame that carries each axis.
    cache : derived quantities (mass matrix, Jacobians) at this state, cleared when it changes.
    """

    def __init__(self, model):
        self.model = model
        nb, k, d, r = model.n_bodies, model.n_coordinates, model.dim, model.rot_dim
        self.theta: Optional[np.ndarray] = None
        self.dtheta: Optional[np.ndarray] = None
        self.rotation = np.tile(np.eye(d), (nb, 1, 1))
        self.angle = np.zeros(nb)
        self.position = np.zeros((nb, d))
        self.offset = np.zeros((nb, d))  # parent-frame joint offset in world axes
        self.velocity = np.zeros((nb, d))
        self.omega = np.zeros((nb, r))
        self.axis_rev = np.zeros((r, k))
        self.axis_pri = np.zeros((d, k))
        self.axis_origin = np.zeros((d, k))
        self.axis_origin_vel = np.zeros((d, k))
        self.axis_omega = np.zeros((r, k))
        self.cache: dict[str, Any] = {}


# ---- old convimpact/model/kinematics.py ----------------------------------------





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


# ---- old convimpact/model/dynamics.py ----------------------------------------





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


# ---- old convimpact/model/contacts.py ----------------------------------------






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



class ReferenceModel:
    """The old evaluations of ``model`` (fresh workspace per instance)."""

    def __init__(self, model):
        self.model = model
        self.data = Data(model)

    def mass_matrix(self, theta):
        return mass_matrix(self.model, self.data, theta)

    def mass_matrix_dot(self, theta, dtheta):
        return mass_matrix_dot(self.model, self.data, theta, dtheta)

    def generalized_forces(self, t, theta, dtheta):
        return generalized_forces(self.model, self.data, t, theta, dtheta)

    def contact_frame(self, name, theta):
        return contact_frame(self.model, self.data, name, theta)

    def contact_jacobian(self, name, theta):
        return contact_jacobian(self.model, self.data, name, theta)

    def contact_gap(self, name, theta):
        return contact_gap(self.model, self.data, name, theta)

    def kinetic_energy(self, theta, dtheta):
        return kinetic_energy(self.model, self.data, theta, dtheta)

    def potential_energy(self, theta):
        return potential_energy(self.model, self.data, theta)

    def velocity_transformation(self, theta):
        return velocity_transformation(self.model, self.data, theta)
