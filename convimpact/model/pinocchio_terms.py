"""What a Pinocchio model gives at a state: M, the contact and loop Jacobians, and its frames.

From a Pinocchio ``model``, ``data``, configuration ``q`` (and velocity ``v``):

* :func:`mass_matrix`: M(q) by CRBA, symmetrized;
* :func:`contact_basis` and :func:`contact_jacobian`: the rows (n, t1, t2), or (n, t) planar,
  of a frame point's world velocity, minus that of a second frame for body-body contacts;
* :func:`point_loop_jacobian` and :func:`point_loop_jacobian_dot`: C and C_dot of a
  point-coincidence loop closure between two frames;
* :class:`PinocchioContact`: a point of a frame against a plane fixed in the world.

These are the pieces that :mod:`convimpact.model.pinocchio_adapter` (single impacts, export of
our models) and :class:`~convimpact.model.pinocchio_mechanism.PinocchioMechanism`
(simulation) share; both modules hand the public names on. Pinocchio (PyPI package ``pin``)
is an optional extra, imported on first use by :func:`_pin`, which raises
:class:`PinocchioUnavailableError` (a :class:`~convimpact.errors.NotSupportedError`
and an ``ImportError``) when it is missing.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Optional, Sequence, Union

import numpy as np

from ..errors import ModelError, NotSupportedError, ShapeError
from .geometry import orthonormal_complement

FrameRef = Union[str, int]


class PinocchioUnavailableError(NotSupportedError, ImportError):
    """Pinocchio is not installed."""


def _pin():
    try:
        import pinocchio
    except ImportError as exc:
        raise PinocchioUnavailableError(
            "the Pinocchio adapter needs Pinocchio: install it with "
            "`pip install convimpact[pinocchio]` (PyPI package 'pin')") from exc
    return pinocchio


def _frame_id(model, frame: FrameRef) -> int:
    if isinstance(frame, (int, np.integer)):
        if not 0 <= int(frame) < model.nframes:
            raise ModelError(f"frame index {frame} out of range 0..{model.nframes - 1}")
        return int(frame)
    if not model.existFrame(frame):
        raise ModelError(f"the Pinocchio model has no frame {frame!r}; add it with model.addFrame")
    return int(model.getFrameId(frame))


def _vec(model, a, n: int, name: str) -> np.ndarray:
    a = np.asarray(a, dtype=float)
    if a.shape != (n,):
        raise ShapeError(f"{name} must have shape ({n},) for this Pinocchio model, got {a.shape}")
    return a


def mass_matrix(model, data, q) -> np.ndarray:
    """Joint-space mass matrix M(q) by CRBA (Pinocchio fills one triangle; we symmetrize)."""
    pin = _pin()
    M = np.array(pin.crba(model, data, _vec(model, q, model.nq, "q"))).reshape(model.nv, model.nv)
    return np.triu(M) + np.triu(M, 1).T


def _frame_point_jacobian(pin, model, data, fid: int, local_point) -> tuple[np.ndarray, np.ndarray]:
    """World position and linear world-aligned Jacobian of a point fixed in frame ``fid``."""
    frame = model.frames[fid]
    placement = frame.placement
    if local_point is not None:
        placement = placement * pin.SE3(np.eye(3), np.asarray(local_point, dtype=float))
    J = pin.getFrameJacobian(model, data, frame.parentJoint, placement, pin.LOCAL_WORLD_ALIGNED)
    x = (data.oMi[frame.parentJoint] * placement).translation
    return np.array(x), np.asarray(J).reshape(6, model.nv)[:3].copy()


def contact_basis(normal, tangent=None, planar: bool = False) -> np.ndarray:
    """Rows (n, t1, t2) - or (n, t) when ``planar`` - of a contact frame in world coordinates.

    ``t1`` defaults to a deterministic completion; ``t2 = n x t1``. A planar basis in the x-y
    plane uses ``t = n`` turned by +90 degrees about z, as the planar models do.
    """
    n = np.asarray(normal, dtype=float)
    if n.shape != (3,) or np.linalg.norm(n) < 1e-12:
        raise ShapeError(f"normal must be a non-zero 3-vector, got {normal!r}")
    n = n / np.linalg.norm(n)
    if planar:
        if abs(n[2]) > 1e-12:
            raise ShapeError("a planar contact normal must lie in the x-y plane")
        return np.array([n, [-n[1], n[0], 0.0]])
    if tangent is None:
        t1, t2 = orthonormal_complement(n)
    else:
        t1 = np.asarray(tangent, dtype=float)
        t1 = t1 - (t1 @ n) * n
        if np.linalg.norm(t1) < 1e-9:
            raise ShapeError("tangent is parallel to the normal")
        t1 = t1 / np.linalg.norm(t1)
        t2 = np.cross(n, t1)
    return np.array([n, t1, t2])


def contact_jacobian(model, data, q, frame: FrameRef, normal, tangent=None,
                     other_frame: Optional[FrameRef] = None, local_point=None,
                     planar: bool = False) -> np.ndarray:
    """Contact Jacobian ``Jc`` (rows n, t1, t2 or n, t) of a point of ``frame``.

    Parameters
    ----------
    model, data, q : Pinocchio model, data and configuration.
    frame : frame (name or id) carrying the contact point (its origin, shifted by
        ``local_point`` in the frame's axes when given): body i.
    normal : world normal pointing toward body i; ``tangent`` optional t1.
    other_frame : body j's frame for body-body contacts (its material point coincident with
        the contact point is used); None for a contact against the fixed world.
    planar : return the 2-row planar Jacobian (n, t) of an x-y plane mechanism.
    """
    pin = _pin()
    q = _vec(model, q, model.nq, "q")
    pin.computeJointJacobians(model, data, q)
    pin.updateFramePlacements(model, data)
    x, J = _frame_point_jacobian(pin, model, data, _frame_id(model, frame), local_point)
    if other_frame is not None:
        fj = _frame_id(model, other_frame)
        oMf = data.oMf[fj]
        local = oMf.rotation.T @ (x - oMf.translation)
        _, Jj = _frame_point_jacobian(pin, model, data, fj, local)
        J = J - Jj
    return contact_basis(normal, tangent, planar) @ J


def point_loop_jacobian(model, data, q, frame_a: FrameRef, frame_b: FrameRef) -> np.ndarray:
    """C (3, nv) of the loop closure ``Psi = p_a - p_b = 0`` between two frame origins."""
    pin = _pin()
    q = _vec(model, q, model.nq, "q")
    pin.computeJointJacobians(model, data, q)
    pin.updateFramePlacements(model, data)
    _, Ja = _frame_point_jacobian(pin, model, data, _frame_id(model, frame_a), None)
    _, Jb = _frame_point_jacobian(pin, model, data, _frame_id(model, frame_b), None)
    return Ja - Jb


def _point_jacobian_dot(pin, model, data, fid: int) -> np.ndarray:
    # point Jacobian J_p = J_lin - [p]x J_ang from the WORLD (spatial) Jacobian; differentiate
    Jw = pin.getFrameJacobian(model, data, fid, pin.WORLD)
    dJw = pin.getFrameJacobianTimeVariation(model, data, fid, pin.WORLD)
    p = data.oMf[fid].translation
    v = data.v_for_dot
    pdot = (Jw[:3] - _skew(p) @ Jw[3:]) @ v
    return dJw[:3] - _skew(pdot) @ Jw[3:] - _skew(p) @ dJw[3:]


def _skew(w) -> np.ndarray:
    return np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])


def point_loop_jacobian_dot(model, data, q, v, frame_a: FrameRef, frame_b: FrameRef) -> np.ndarray:
    """C_dot (3, nv) of :func:`point_loop_jacobian` along the velocity v."""
    pin = _pin()
    q = _vec(model, q, model.nq, "q")
    v = _vec(model, v, model.nv, "v")
    pin.computeJointJacobiansTimeVariation(model, data, q, v)
    pin.updateFramePlacements(model, data)
    data.v_for_dot = v
    return (_point_jacobian_dot(pin, model, data, _frame_id(model, frame_a))
            - _point_jacobian_dot(pin, model, data, _frame_id(model, frame_b)))


@dataclass(frozen=True)
class PinocchioContact:
    """A point of a Pinocchio frame against a plane fixed in the world.

    ``normal`` (world, toward the robot's body) and ``plane_point`` define the plane; the gap
    is ``n . (p - plane_point)`` with p the frame's origin, shifted by ``local_point`` (in the
    frame's axes) when given; ``tangent`` is the optional t1; e and mu the coefficients.
    """

    name: str
    frame: FrameRef
    normal: Sequence[float]
    plane_point: Sequence[float] = (0.0, 0.0, 0.0)
    tangent: Optional[Sequence[float]] = None
    e: float = 0.0
    mu: float = 0.0
    local_point: Optional[Sequence[float]] = None


__all__ = [
    "FrameRef", "PinocchioUnavailableError", "PinocchioContact", "mass_matrix", "contact_basis",
    "contact_jacobian", "point_loop_jacobian", "point_loop_jacobian_dot",
]
