"""Optional Pinocchio adapter: impacts of Pinocchio models, and our models exported to it.

Research users often already have a Pinocchio model of their robot. This module gives, from a
Pinocchio ``model``, ``data``, configuration ``q`` and velocity ``v``:

* :func:`mass_matrix` (CRBA, symmetrized) and :func:`contact_jacobian` (rows n, t1, t2 of the
  frame point's world velocity, minus that of a second frame for body-body contacts);
* :func:`point_loop_jacobian`: C of a point-coincidence loop closure between two frames (the
  position part of a revolute or spherical cut joint), with :func:`point_loop_jacobian_dot`;
  these, :func:`contact_basis` and :class:`PinocchioContact` are defined in
  :mod:`convimpact.model.pinocchio_terms` and importable from here;
* :func:`impact_arguments`: the keyword arguments of :func:`convimpact.resolve_impact`;
* :class:`PinocchioMechanism` (defined in :mod:`convimpact.model.pinocchio_mechanism`,
  importable from here): a :class:`~convimpact.mechanism.Mechanism` for simulation, with
  loaders for URDF and MJCF files, plane contacts on frames and point loop closures;
* :func:`to_pinocchio`: our :class:`~convimpact.model.builder.Model` as a Pinocchio model
  (planar models embedded in the x-y plane), used by the tests as an independent check.

Pinocchio (PyPI package ``pin``) is an optional extra: ``pip install convimpact[pinocchio]``.
It is imported on first use; when it is missing every function raises
:class:`PinocchioUnavailableError`, which is both a
:class:`~convimpact.errors.NotSupportedError` and an ``ImportError``.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from ..errors import ModelError
from .pinocchio_mechanism import PinocchioMechanism
from .pinocchio_terms import (FrameRef, PinocchioContact, PinocchioUnavailableError, _pin, _vec,
                              contact_basis, contact_jacobian, mass_matrix, point_loop_jacobian,
                              point_loop_jacobian_dot)


def impact_arguments(model, data, q, v, contacts: Sequence[PinocchioContact],
                     loops: Sequence[tuple[FrameRef, FrameRef]] = ()) -> dict:
    """Keyword arguments of :func:`convimpact.resolve_impact` for a Pinocchio robot.

    ``contacts`` are the contacts taking part in the impact; ``loops`` optional pairs of
    frames whose origins must coincide (point loop closures, C of eq. 7).
    """
    if not contacts:
        raise ModelError("name at least one PinocchioContact")
    q = _vec(model, q, model.nq, "q")
    v = _vec(model, v, model.nv, "v")
    data_M = mass_matrix(model, data, q)
    Jc = [contact_jacobian(model, data, q, c.frame, c.normal, c.tangent,
                           local_point=c.local_point) for c in contacts]
    C = None
    if loops:
        C = np.vstack([point_loop_jacobian(model, data, q, a, b) for a, b in loops])
    return dict(M=data_M, Jc=Jc, dq=v.copy(), C=C, e=[c.e for c in contacts],
                mu=[c.mu for c in contacts])


def to_pinocchio(model):
    """Our :class:`Model` as an equivalent Pinocchio model, with q = theta and v = theta_dot.

    Each elementary motion becomes a ``RevoluteUnaligned`` or ``PrismaticUnaligned`` joint
    (composite joints through massless intermediate frames), fixed joints are merged into the
    parent joint. Planar models are embedded in the x-y plane (revolute joints about z).
    Every body's frame is added as an ``OP_FRAME`` named after the body. Pinocchio needs the
    joints in depth-first order, so its coordinates are ours permuted.

    Returns
    -------
    (pinocchio.Model, permutation)
        ``q = theta[permutation]`` and ``v = theta_dot[permutation]``; a Pinocchio matrix
        ``X`` over v maps back as ``X[np.ix_(inv, inv)]`` with ``inv = np.argsort(permutation)``.
    """
    pin = _pin()

    def lift(v):
        return np.array([v[0], v[1], 0.0]) if model.planar else np.asarray(v, dtype=float)

    def lift_rot(R):
        if not model.planar:
            return np.asarray(R, dtype=float)
        R3 = np.eye(3)
        R3[:2, :2] = R
        return R3

    pm = pin.Model()
    pm.gravity = pin.Motion(np.concatenate([lift(model.gravity), np.zeros(3)]))
    # where each of our bodies' frames sits: (pinocchio joint id, placement in that joint)
    where = {0: (0, pin.SE3.Identity())}
    children: dict[int, list[int]] = {}
    for b in model.bodies[1:]:
        children.setdefault(b.parent, []).append(b.index)
    order: list[int] = []
    stack = [0]
    while stack:  # depth-first, children in declaration order
        i = stack.pop()
        if i:
            order.append(i)
        stack.extend(reversed(children.get(i, [])))
    permutation = [c for i in order for c in model.bodies[i].coordinates]
    for b in (model.bodies[i] for i in order):
        pj, off = where[b.parent]
        placement = off * pin.SE3(lift_rot(b.placement_rotation), lift(b.placement_origin))
        jid = pj
        for i, mo in enumerate(b.motions):
            if mo.kind == "revolute":
                axis = np.array([0.0, 0.0, mo.axis[0]]) if model.planar else mo.axis
                jm = pin.JointModelRevoluteUnaligned(axis)
            else:
                jm = pin.JointModelPrismaticUnaligned(lift(mo.axis))
            jid = pm.addJoint(jid, jm, placement if i == 0 else pin.SE3.Identity(),
                              f"{b.joint_name}:{i}")
        body_off = pin.SE3.Identity() if b.motions else placement
        where[b.index] = (jid, body_off)
        if model.planar:
            izz = float(b.inertia[0, 0])
            I3 = np.diag([izz, izz, izz])
        else:
            I3 = b.inertia
        pm.appendBodyToJoint(jid, pin.Inertia(b.mass, lift(b.com), I3), body_off)
        pm.addFrame(pin.Frame(b.name, jid, body_off, pin.FrameType.OP_FRAME))
    return pm, np.array(permutation, dtype=int)


__all__ = [
    "PinocchioUnavailableError", "PinocchioContact", "PinocchioMechanism", "mass_matrix",
    "contact_basis", "contact_jacobian", "point_loop_jacobian", "point_loop_jacobian_dot",
    "impact_arguments", "to_pinocchio",
]
