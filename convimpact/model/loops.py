"""Loop closure by cut joints: Psi(theta) (eq. 6), C(theta) (eq. 7), C_dot (eqs. 8, 14).

Each cut joint's constraint rows are built from points and body-fixed directions, every one
carried with its value, Jacobian and Jacobian time derivative; the product rule then gives
exact rows of C and C_dot (see :class:`~convimpact.model.specs.LoopSpec` for the rows).
:func:`assemble` and :func:`consistent_velocity` bring an inconsistent state onto
``Psi = 0`` and ``C theta_dot = 0`` for any :class:`~convimpact.mechanism.Mechanism`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from ..errors import AssemblyError, ModelError
from .geometry import cross
from .kinematics import (
    ensure_configuration,
    forward_kinematics,
    point_jacobian,
    point_jacobian_dot,
    world_point,
)


@dataclass(frozen=True)
class _Quantity:
    """A world vector with its Jacobian and the Jacobian's time derivative."""

    value: np.ndarray
    jac: np.ndarray
    jac_dot: np.ndarray

    def __sub__(self, other: "_Quantity") -> "_Quantity":
        return _Quantity(self.value - other.value, self.jac - other.jac, self.jac_dot - other.jac_dot)


def _point(model, data, body: int, local) -> _Quantity:
    x = world_point(data, body, local)
    Jv, _ = point_jacobian(model, data, body, x)
    dJv, _ = point_jacobian_dot(model, data, body, x)
    return _Quantity(x, Jv, dJv)


def _direction(model, data, body: int, local) -> _Quantity:
    """A unit vector fixed in ``body``: d/dt u = w x u, so J_u = Jw x u column-wise."""
    u = data.rotation[body] @ local
    x = data.position[body]
    _, Jw = point_jacobian(model, data, body, x)
    _, dJw = point_jacobian_dot(model, data, body, x)
    udot = cross(model.planar, data.omega[body], u)
    J = cross(model.planar, Jw, u[:, None] * np.ones_like(Jw[:1]))
    Jd = cross(model.planar, dJw, u[:, None] * np.ones_like(Jw[:1])) \
        + cross(model.planar, Jw, udot[:, None] * np.ones_like(Jw[:1]))
    return _Quantity(u, J, Jd)


def _dot(model, p: _Quantity, q: _Quantity, dtheta: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """Row of Psi = p . q with its C and C_dot rows (product rule)."""
    pdot, qdot = p.jac @ dtheta, q.jac @ dtheta
    return (float(p.value @ q.value), p.value @ q.jac + q.value @ p.jac,
            pdot @ q.jac + p.value @ q.jac_dot + qdot @ p.jac + q.value @ p.jac_dot)


def _rows(model, data, lp) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    dtheta = data.dtheta
    oa = _point(model, data, lp.body_a, lp.origin_a)
    ob = _point(model, data, lp.body_b, lp.origin_b)
    if lp.kind in ("revolute", "spherical"):
        diff = oa - ob
        psi, C, Cd = [diff.value], [diff.jac], [diff.jac_dot]
        if lp.kind == "revolute" and not model.planar:
            za = _direction(model, data, lp.body_a, lp.rotation_a[:, 2])
            for col in (0, 1):
                xb = _direction(model, data, lp.body_b, lp.rotation_b[:, col])
                r = _dot(model, za, xb, dtheta)
                psi.append([r[0]]), C.append(r[1][None]), Cd.append(r[2][None])
        return np.concatenate(psi), np.vstack(C), np.vstack(Cd)
    # prismatic
    d = ob - oa
    psi, C, Cd = [], [], []
    if model.planar:
        ya = _direction(model, data, lp.body_a, lp.rotation_a[:, 1])
        r = _dot(model, d, ya, dtheta)
        psi.append(r[0]), C.append(r[1]), Cd.append(r[2])
        _, Jwa = point_jacobian(model, data, lp.body_a, data.position[lp.body_a])
        _, Jwb = point_jacobian(model, data, lp.body_b, data.position[lp.body_b])
        psi.append((data.angle[lp.body_b] + lp.angle_b) - (data.angle[lp.body_a] + lp.angle_a))
        C.append((Jwb - Jwa)[0])
        Cd.append(np.zeros(model.n_coordinates))  # planar angular Jacobians are constant
        return np.array(psi), np.vstack(C), np.vstack(Cd)
    xa = _direction(model, data, lp.body_a, lp.rotation_a[:, 0])
    ya = _direction(model, data, lp.body_a, lp.rotation_a[:, 1])
    za = _direction(model, data, lp.body_a, lp.rotation_a[:, 2])
    xb = _direction(model, data, lp.body_b, lp.rotation_b[:, 0])
    yb = _direction(model, data, lp.body_b, lp.rotation_b[:, 1])
    for p, q in ((d, xa), (d, ya), (za, xb), (za, yb), (xa, yb)):
        r = _dot(model, p, q, dtheta)
        psi.append(r[0]), C.append(r[1]), Cd.append(r[2])
    return np.array(psi), np.vstack(C), np.vstack(Cd)


def _all_rows(model, data, theta, dtheta=None):
    if dtheta is None:
        ensure_configuration(model, data, theta)
    else:
        forward_kinematics(model, data, theta, dtheta)
    key = "loop_rows"
    if key not in data.cache:
        k = model.n_coordinates
        if not model.loops:
            data.cache[key] = (np.zeros(0), np.zeros((0, k)), np.zeros((0, k)))
        else:
            rows = [_rows(model, data, lp) for lp in model.loops]
            data.cache[key] = tuple(np.concatenate([r[i] for r in rows]) if i == 0
                                    else np.vstack([r[i] for r in rows]) for i in range(3))
    return data.cache[key]


def loop_residual(model, data, theta) -> np.ndarray:
    """Psi(theta), (m,) (eq. 6)."""
    return _all_rows(model, data, theta)[0].copy()


def loop_jacobian(model, data, theta) -> np.ndarray:
    """C(theta) = dPsi/dtheta, (m, k) (eq. 7)."""
    return _all_rows(model, data, theta)[1].copy()


def loop_jacobian_dot(model, data, theta, dtheta) -> np.ndarray:
    """C_dot(theta, theta_dot), (m, k) (eqs. 8, 14)."""
    return _all_rows(model, data, theta, dtheta)[2].copy()


def _fixed_indices(mechanism, fixed: Sequence) -> np.ndarray:
    k = mechanism.n_coordinates
    idx = []
    for f in fixed:
        if isinstance(f, (int, np.integer)):
            if not 0 <= int(f) < k:
                raise ModelError(f"fixed coordinate index {f} out of range 0..{k - 1}")
            idx.append(int(f))
        elif hasattr(mechanism, "coordinate_index"):
            idx.append(mechanism.coordinate_index(f))
        else:
            raise ModelError(f"this mechanism has no coordinate names; fix coordinates by index, got {f!r}")
    return np.array(sorted(set(idx)), dtype=int)


def assemble(mechanism, theta, fixed: Sequence = (), tol: float = 1e-12,
             max_iter: int = 50) -> np.ndarray:
    """Bring theta onto the loop constraints ``Psi(theta) = 0`` by Newton's method.

    Each step is the least-norm correction of the free coordinates,
    ``delta = -C_free^+ Psi``, halved while it does not reduce ``|Psi|``.

    Parameters
    ----------
    mechanism : any :class:`~convimpact.mechanism.Mechanism`.
    theta : (k,) initial guess.
    fixed : coordinates (indices, or names when the mechanism has ``coordinate_index``)
        kept at their given values, e.g. the crank angle of a slider-crank.
    tol : convergence tolerance on ``max |Psi|``.
    max_iter : Newton iterations allowed.

    Returns
    -------
    theta : (k,) assembled coordinates.

    Raises
    ------
    AssemblyError
        When the iteration does not reach ``tol``; the message reports the residual.
    """
    theta = np.array(theta, dtype=float)
    if mechanism.n_loop_constraints == 0:
        return theta
    k = mechanism.n_coordinates
    fix = _fixed_indices(mechanism, fixed)
    free = np.setdiff1d(np.arange(k), fix)
    psi = np.asarray(mechanism.loop_residual(theta), dtype=float)
    res = float(np.max(np.abs(psi)))
    for _ in range(max_iter):
        if res <= tol:
            return theta
        C = np.asarray(mechanism.loop_jacobian(theta), dtype=float)[:, free]
        step = -np.linalg.lstsq(C, psi, rcond=None)[0]
        lam = 1.0
        for _ in range(30):
            trial = theta.copy()
            trial[free] += lam * step
            psi_t = np.asarray(mechanism.loop_residual(trial), dtype=float)
            res_t = float(np.max(np.abs(psi_t)))
            if res_t < res:
                break
            lam *= 0.5
        else:
            break
        theta, psi, res = trial, psi_t, res_t
    if res <= tol:
        return theta
    raise AssemblyError(
        f"the loop closure cannot be assembled: max |Psi| = {res:.3e} after Newton's method "
        f"(tolerance {tol:.1e}); check the link lengths and the cut-joint frames, or start "
        "from a better guess of theta")


def consistent_velocity(mechanism, theta, dtheta, fixed: Sequence = (), tol: float = 1e-10) -> np.ndarray:
    """Correct theta_dot so that ``C theta_dot = 0`` (eq. 7), keeping ``fixed`` coordinates.

    The free coordinates receive the least-norm correction ``-C_free^+ C theta_dot``.

    Raises
    ------
    AssemblyError
        When the fixed velocities cannot be completed consistently (C_free rank deficient).
    """
    dtheta = np.array(dtheta, dtype=float)
    if mechanism.n_loop_constraints == 0:
        return dtheta
    k = mechanism.n_coordinates
    fix = _fixed_indices(mechanism, fixed)
    free = np.setdiff1d(np.arange(k), fix)
    C = np.asarray(mechanism.loop_jacobian(theta), dtype=float)
    dtheta[free] -= np.linalg.lstsq(C[:, free], C @ dtheta, rcond=None)[0]
    res = float(np.max(np.abs(C @ dtheta)))
    scale = max(float(np.max(np.abs(C))) * float(np.max(np.abs(dtheta))), 1.0)
    if res > tol * scale:
        raise AssemblyError(f"the velocities cannot satisfy C theta_dot = 0 with these fixed "
                            f"coordinates: max |C theta_dot| = {res:.3e}; fix fewer coordinates")
    return dtheta
