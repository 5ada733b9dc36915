"""Shared construction of the paper's double pendulum (Sections 9.2 and 9.3).

Two identical uniform slender rods of length L and mass m; rod 1 hinged to the support at
the origin, rod 2 hinged to the end of rod 1; each rod's frame has its x axis along the rod
from its hinge, so the rod's centre of mass is at (L/2, 0). The joint coordinates are
relative: theta1 is rod 1's angle from +x, theta2 rod 2's angle relative to rod 1, both about
+z (counter-clockwise positive). The floor is horizontal (normal +y) with t = -x (planar) or
t1 = -x, t2 = +z (spatial), as in the paper's Figs. 4 and 8.
"""

from __future__ import annotations

import numpy as np

from convimpact.model import Joint, ModelBuilder

#: rod angles from +x (degrees) at the paper's impact instants
CASE_ANGLES = {"a": (-108.0, -120.0), "b": (-90.0, -102.0)}


def relative_coordinates(angle1_deg: float, angle2_deg: float) -> np.ndarray:
    """Joint coordinates (theta1, theta2) of rods at absolute angles (degrees from +x)."""
    return np.radians([angle1_deg, angle2_deg - angle1_deg])


def tip_height(angle1_deg: float, angle2_deg: float, length: float) -> float:
    """y of rod 2's free end for rods at the given absolute angles."""
    return length * (np.sin(np.radians(angle1_deg)) + np.sin(np.radians(angle2_deg)))


def build(planar: bool, mass: float, length: float, floor_y: float, e: float, mu: float):
    """The double pendulum model; spatial adds the base rotation about the vertical y axis.

    Spatial coordinates are ``(theta3, theta1, theta2)``: a universal joint at the support
    turns first about the world y axis (theta3, the paper's base rotation) and then about
    the carried z axis (theta1); the base itself is massless.
    """
    b = ModelBuilder(planar=planar)
    I_t = mass * length ** 2 / 12.0
    if planar:
        com, inertia, singular = (length / 2, 0.0), I_t, False
        joint1 = Joint.revolute()
        names1 = ["theta1"]
        joint2 = Joint.revolute()
    else:
        # slender rod along its x axis: m L^2 / 12 about both transverse axes, 0 about the axis
        com, inertia, singular = (length / 2, 0.0, 0.0), (0.0, I_t, I_t), True
        joint1 = Joint.universal((0.0, 1.0, 0.0), (0.0, 0.0, 1.0))
        names1 = ["theta3", "theta1"]
        joint2 = Joint.revolute((0.0, 0.0, 1.0))
    b.add_body("rod1", "ground", joint1, mass, com, inertia, joint_name="support",
               coordinate_names=names1, allow_singular_inertia=singular)
    b.add_body("rod2", "rod1", joint2, mass, com, inertia,
               joint_origin=(length, 0.0) if planar else (length, 0.0, 0.0),
               joint_name="elbow", coordinate_names=["theta2"], allow_singular_inertia=singular)
    if planar:
        b.add_contact("tip", body="rod2", point=(length, 0.0), normal=(0.0, 1.0),
                      plane_point=(0.0, floor_y), e=e, mu=mu)
    else:
        b.add_contact("tip", body="rod2", point=(length, 0.0, 0.0), normal=(0.0, 1.0, 0.0),
                      plane_point=(0.0, floor_y, 0.0), tangent=(-1.0, 0.0, 0.0), e=e, mu=mu)
    return b.build()
