"""The mechanisms of the bench section ``model``: random chains and trees, and a chain
dropped on the floor, with their Pinocchio twins
(:func:`~convimpact.model.pinocchio_adapter.to_pinocchio`).

* :func:`random_mechanism`: ``n`` bodies on revolute joints (planar: about z; spatial: random
  axes), a serial chain or a random tree (:func:`convimpact.model.random.random_model`), and
  one point contact on the last body against a plane fixed in the world;
* :func:`dropped_chain`: ``n`` equal links (1 m, 1 kg in all; slender links, I_xx = I_yy /
  100 in space) hanging from a pivot (planar: revolute joints; spatial: a universal joint at
  the pivot, then revolute joints alternately about z and y), released from rest at 0.3 rad
  (and 0.2 rad about y in space) below the horizontal; the tip, a point contact with e = 0.5
  and mu = 0.3, strikes the floor 0.6 m below the pivot (several impacts in the first second);
* :func:`swinging_tree`: a random revolute tree released from rest, with a contact plane
  below it; :func:`without_contacts`: a model's bodies alone (free motion);
* :func:`pinocchio_twin`: the Pinocchio model of one of ours with a frame at each contact
  point (a material point of the contact's body), and a
  :class:`~convimpact.model.pinocchio_mechanism.PinocchioMechanism` with the same contacts,
  so the same event-driven simulator runs on either backend.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..model import Joint, ModelBuilder
from ..model.random import random_model

#: the floor's height below the dropped chain's pivot (m)
FLOOR = -0.6
#: initial angles of the dropped chain's first joint(s) (rad)
RELEASE = (0.3, 0.2)


def random_mechanism(n: int, planar: bool, chain: bool, seed: int):
    """(model, theta, theta_dot) of a random revolute chain or tree of ``n`` bodies with one
    point contact ("tip") on the last body against a world plane."""
    rng = np.random.default_rng(seed + 1000 * n + 17 * planar + 3 * chain)
    model, theta = random_model(rng, planar, n_bodies=n, joint_kinds=("revolute",),
                                n_contacts=0, chain=chain)
    d = model.dim
    b = _rebuild(model)
    b.add_contact("tip", model.bodies[-1].name, rng.normal(size=d) * 0.3,
                  normal=np.eye(d)[1], plane_point=-np.eye(d)[1] * 3.0)
    model = b.build()
    return model, theta, rng.normal(size=model.n_coordinates)


def _rebuild(model) -> ModelBuilder:
    """A builder holding ``model``'s bodies (to add contacts to)."""
    b = ModelBuilder(planar=model.planar, gravity=model.gravity)
    for body in model.bodies[1:]:
        inertia = body.inertia[0, 0] if model.planar else body.inertia
        b.add_body(body.name, model.bodies[body.parent].name, body.joint, body.mass, body.com,
                   inertia, joint_origin=body.placement_origin,
                   joint_rotation=body.placement_angle if model.planar else body.placement_rotation,
                   joint_name=body.joint_name, allow_singular_inertia=True)
    return b


def dropped_chain(n: int, planar: bool, e: float = 0.5, mu: float = 0.3):
    """(model, theta0, theta_dot0) of the chain of the module docstring."""
    length, mass = 1.0, 1.0
    ln, m = length / n, mass / n
    d = 2 if planar else 3
    b = ModelBuilder(planar=planar)
    parent = "ground"
    for i in range(n):
        if planar:
            joint, inertia = Joint.revolute(), m * ln * ln / 12
        else:
            joint = (Joint.universal((0, 0, 1), (0, 1, 0)) if i == 0 else
                     Joint.revolute((0, 0, 1) if i % 2 == 0 else (0, 1, 0)))
            inertia = (m * ln * ln / 1200, m * ln * ln / 12, m * ln * ln / 12)
        origin = np.zeros(d) if i == 0 else np.eye(d)[0] * ln
        b.add_body(f"link{i}", parent, joint, m, np.eye(d)[0] * ln / 2, inertia,
                   joint_origin=origin)
        parent = f"link{i}"
    b.add_contact("tip", parent, np.eye(d)[0] * ln, normal=np.eye(d)[1],
                  plane_point=np.eye(d)[1] * FLOOR, e=e, mu=mu)
    model = b.build()
    theta = np.zeros(model.n_coordinates)
    theta[0] = -RELEASE[0]
    if not planar:
        theta[1] = RELEASE[1]
    return model, theta, np.zeros(model.n_coordinates)


def swinging_tree(n: int, planar: bool, seed: int):
    """(model, theta0, theta_dot0) of a random revolute tree of ``n`` bodies
    (:func:`random_mechanism`) released from rest under gravity; its contact ("tip", e = 0.5,
    mu = 0.3) is a plane 3 m below the root, which some trees reach."""
    model, theta, _ = random_mechanism(n, planar, False, seed)
    b = _rebuild(model)
    spec = model.contacts[0]
    b.add_contact(spec.name, model.bodies[spec.body].name, spec.point, normal=spec.normal,
                  plane_point=spec.other_point, e=0.5, mu=0.3)
    model = b.build()
    return model, np.asarray(theta, dtype=float), np.zeros(model.n_coordinates)


def without_contacts(model):
    """``model`` with its contacts removed (the free motion of the same bodies)."""
    return _rebuild(model).build()


def pinocchio_twin(model) -> dict[str, Any]:
    """Pinocchio's model of ``model`` with a frame "x:<contact>" at each contact point of
    body i (at theta = 0), the coordinate permutation (``q = theta[permutation]``), and,
    when every contact is a point against a plane fixed in the world, the
    :class:`~convimpact.model.pinocchio_mechanism.PinocchioMechanism` with the same contacts
    over Pinocchio's coordinates (``mechanism``; None otherwise)."""
    import pinocchio as pin

    from ..model import pinocchio_adapter as pa
    from ..model.pinocchio_mechanism import PinocchioMechanism

    pm, perm = pa.to_pinocchio(model)
    lift = ((lambda v: np.array([v[0], v[1], 0.0])) if model.planar
            else (lambda v: np.asarray(v, dtype=float)))
    frames = {}
    for spec in model.contacts:
        body = model.bodies[spec.body]
        f0 = pm.frames[pm.getFrameId(body.name)]
        local = pin.SE3(np.eye(3), lift(spec.point))
        frames[spec.name] = pm.addFrame(pin.Frame("x:" + spec.name, f0.parentJoint,
                                                  f0.placement * local, pin.FrameType.OP_FRAME))
    mech = None
    if all(s.other == 0 and s.target == "plane" and s.radius == 0.0 for s in model.contacts):
        contacts = [pa.PinocchioContact(s.name, "x:" + s.name, normal=s.normal,
                                        plane_point=s.other_point, tangent=s.tangent,
                                        e=s.restitution, mu=s.friction)
                    for s in model.contacts]
        mech = PinocchioMechanism(pm, contacts=contacts, planar=model.planar)
    return {"model": pm, "data": pm.createData(), "permutation": np.asarray(perm),
            "frames": frames, "mechanism": mech}
