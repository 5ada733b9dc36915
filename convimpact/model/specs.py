"""The frozen entries of a :class:`~convimpact.model.builder.Model`: bodies, contacts, loops.

:class:`~convimpact.model.builder.ModelBuilder` validates each entry as it is added and
stores it as one of these records (see :mod:`convimpact.model.builder` for the conventions).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import numpy as np

from .joints import Joint, Motion


@dataclass(frozen=True, eq=False)
class BodyInfo:
    """A body of the tree and the joint attaching it to its parent."""

    name: str
    index: int
    parent: int
    joint: Joint
    joint_name: str
    motions: tuple[Motion, ...]
    coordinates: tuple[int, ...]
    placement_rotation: np.ndarray  # (d, d)
    placement_origin: np.ndarray  # (d,)
    placement_angle: float  # planar only (0 in space)
    mass: float
    com: np.ndarray  # (d,) in the body frame
    inertia: np.ndarray  # (r, r) about the centre of mass, body frame


@dataclass(frozen=True, eq=False)
class ContactSpec:
    """A candidate contact: a point (or sphere) on body i against a plane or sphere on body j.

    The normal ``n`` points from body j toward body i; for a plane it is the plane's normal,
    for two spheres the unit vector from the centre on j to the centre on i. The gap is
    ``n . (c_i - o_j) - r_i`` for a plane and ``|c_i - c_j| - r_i - r_j`` for two spheres.
    """

    name: str
    body: int
    point: np.ndarray
    radius: float
    target: str  # "plane" or "sphere"
    other: int
    other_point: np.ndarray
    normal: Optional[np.ndarray]  # plane normal in body j's frame
    tangent: Optional[np.ndarray]  # spatial plane t1 in body j's frame
    other_radius: float
    restitution: float
    friction: float


@dataclass(frozen=True, eq=False)
class LoopSpec:
    """A cut joint closing a loop between a frame on body a and a frame on body b.

    Constraint rows (``Psi = 0`` when assembled):

    * planar ``revolute``: ``o_a - o_b`` (2);
    * planar ``prismatic`` (slide along the x axis of frame a): ``(o_b - o_a) . y_a`` and
      ``phi_b - phi_a`` (absolute frame angles) (2);
    * spatial ``spherical``: ``o_a - o_b`` (3);
    * spatial ``revolute`` (about the z axes): ``o_a - o_b``, ``z_a . x_b``, ``z_a . y_b`` (5);
    * spatial ``prismatic`` (along the z axes): ``(o_b - o_a) . x_a``, ``(o_b - o_a) . y_a``,
      ``z_a . x_b``, ``z_a . y_b``, ``x_a . y_b`` (5).
    """

    name: str
    kind: str
    body_a: int
    origin_a: np.ndarray
    rotation_a: np.ndarray
    angle_a: float
    body_b: int
    origin_b: np.ndarray
    rotation_b: np.ndarray
    angle_b: float

    @property
    def n_rows(self) -> int:
        if self.rotation_a.shape[0] == 2:  # planar: revolute and prismatic both remove 2
            return 2
        return 3 if self.kind == "spherical" else 5
