"""Random mechanisms for property tests and cross-checks.

:func:`random_model` draws a kinematic tree with physically valid bodies (inertias of random
boxes, so the triangle inequality holds), random joint axes and placements, contacts against
the floor or between bodies, and optionally a loop closed by a cut joint that is exactly
assembled at a known configuration.
"""

from __future__ import annotations

from typing import Optional, Sequence

import numpy as np

from .builder import Model, ModelBuilder
from .data import Data
from .joints import Joint
from .kinematics import forward_kinematics


def random_rotation(rng: np.random.Generator) -> np.ndarray:
    """A uniformly random 3 x 3 rotation matrix."""
    Q, R = np.linalg.qr(rng.normal(size=(3, 3)))
    Q = Q * np.sign(np.diag(R))
    if np.linalg.det(Q) < 0:
        Q[:, 0] = -Q[:, 0]
    return Q


def _box_inertia(rng, mass: float, planar: bool, R: Optional[np.ndarray]):
    a, b, c = rng.uniform(0.05, 0.6, size=3)
    if planar:
        return mass * (a * a + b * b) / 12
    moments = mass / 12 * np.array([b * b + c * c, a * a + c * c, a * a + b * b])
    return R @ np.diag(moments) @ R.T


def _joint(rng, kind: str, planar: bool) -> Joint:
    d = 2 if planar else 3
    if kind == "revolute":
        return Joint.revolute(None if planar else rng.normal(size=3))
    if kind == "prismatic":
        return Joint.prismatic(rng.normal(size=d))
    if kind == "universal":
        return Joint.universal(rng.normal(size=3), rng.normal(size=3))
    return {"free": Joint.free, "translation": Joint.translation, "fixed": Joint.fixed}[kind]()


def random_model(rng: np.random.Generator, planar: bool, n_bodies: int = 4,
                 joint_kinds: Sequence[str] = ("revolute", "prismatic"),
                 n_contacts: int = 2, loop: Optional[str] = None,
                 chain: bool = False) -> tuple[Model, np.ndarray]:
    """A random model and a configuration theta* (where the loop, if any, is assembled).

    Parameters
    ----------
    rng : numpy random generator.
    planar : planar or spatial kinematics.
    n_bodies : number of moving bodies.
    joint_kinds : joint kinds to draw from (the first body's is never "fixed", so the model
        always has coordinates).
    n_contacts : contacts: alternately a point/sphere against the floor and a sphere on one
        body against a sphere on another.
    loop : None or a cut-joint kind; the loop joins the last body to the ground with the two
        cut-joint frames coincident at theta*.
    chain : attach every body to the previous one (a serial chain) instead of a random parent.
    """
    d = 2 if planar else 3
    b = ModelBuilder(planar=planar, gravity=rng.normal(size=d) * 5)
    names = ["ground"]
    for i in range(n_bodies):
        parent = names[-1] if chain else names[int(rng.integers(0, len(names)))]
        kind = joint_kinds[int(rng.integers(0, len(joint_kinds)))]
        if i == 0 and kind == "fixed":  # at least one coordinate
            kind = "revolute"
        mass = float(rng.uniform(0.3, 3.0))
        R = None if planar else random_rotation(rng)
        b.add_body(f"b{i}", parent, _joint(rng, kind, planar), mass, rng.normal(size=d) * 0.3,
                   _box_inertia(rng, mass, planar, R), joint_origin=rng.normal(size=d) * 0.5,
                   joint_rotation=float(rng.uniform(-np.pi, np.pi)) if planar else random_rotation(rng))
        names.append(f"b{i}")
    for c in range(n_contacts):
        body = names[1 + int(rng.integers(0, n_bodies))]
        if c % 2 == 0 or n_bodies < 2:
            b.add_contact(f"c{c}", body, rng.normal(size=d) * 0.3, radius=float(rng.uniform(0, 0.1)),
                          normal=rng.normal(size=d), plane_point=rng.normal(size=d),
                          e=float(rng.uniform()), mu=float(rng.uniform()))
        else:
            other = names[1 + (names.index(body) % n_bodies)]
            b.add_contact(f"c{c}", body, rng.normal(size=d) * 0.3, radius=0.05, against=other,
                          sphere_center=rng.normal(size=d) * 0.3, sphere_radius=0.05,
                          e=float(rng.uniform()), mu=float(rng.uniform()))
    model = b.build()
    theta = rng.uniform(-1.0, 1.0, size=model.n_coordinates)
    if loop is None:
        return model, theta
    data = Data(model)
    forward_kinematics(model, data, theta)
    last = n_bodies
    origin_b = rng.normal(size=d) * 0.3
    if planar:
        angle_b = float(rng.uniform(-np.pi, np.pi))
        p = data.position[last] + data.rotation[last] @ origin_b
        b.add_loop("cut", loop, f"b{n_bodies - 1}", "ground", origin_a=origin_b, rotation_a=angle_b,
                   origin_b=p, rotation_b=data.angle[last] + angle_b)
    else:
        Rb = random_rotation(rng)
        p = data.position[last] + data.rotation[last] @ origin_b
        b.add_loop("cut", loop, f"b{n_bodies - 1}", "ground", origin_a=origin_b, rotation_a=Rb,
                   origin_b=p, rotation_b=data.rotation[last] @ Rb)
    return b.build(), theta


__all__ = ["random_model", "random_rotation"]
