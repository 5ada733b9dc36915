"""Shared construction of a planar rectangular block with its two bottom corners as contacts.

A uniform rectangle (width w, height h, mass m, I = m (w^2 + h^2) / 12 about its centre) on
a free planar joint: theta = (x, y, phi), the centre's position and the angle of the block's
base from +x (counter-clockwise positive). Its bottom corners, ``left_corner`` at
(-w/2, -h/2) and ``right_corner`` at (+w/2, -h/2) in the block frame, are point contacts
against a plane of the ground (a line in the plane) through ``plane_point`` with unit normal
``normal``; the contact tangent is the normal turned by +90 degrees.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from convimpact.model import Joint, ModelBuilder

CORNERS = ("left_corner", "right_corner")
G = 9.81


def build_block(width: float, height: float, mass: float, e: float, mu: float,
                normal: Sequence[float] = (0.0, 1.0),
                plane_point: Sequence[float] = (0.0, 0.0)):
    """The block's mechanism (see the module docstring); ValueError for bad dimensions."""
    if not (width > 0 and height > 0):
        raise ValueError(f"the block's width and height must be positive, got {width}, {height}")
    b = ModelBuilder(planar=True)
    b.add_body("block", "ground", Joint.free(), mass, (0.0, 0.0),
               mass * (width ** 2 + height ** 2) / 12, joint_name="float",
               coordinate_names=["x", "y", "phi"])
    for name, sx in zip(CORNERS, (-0.5, 0.5)):
        b.add_contact(name, body="block", point=(sx * width, -0.5 * height), normal=normal,
                      plane_point=plane_point, e=e, mu=mu)
    return b.build().mechanism()


def block_outline(width: float, height: float) -> dict[str, np.ndarray]:
    """The block's rectangle in its own frame, for drawing (``Scene.outlines``)."""
    w, h = 0.5 * width, 0.5 * height
    return {"block": np.array([[-w, -h], [w, -h], [w, h], [-w, h]])}


def corner_normal_forces(width: float, height: float, weight_normal: float,
                         friction_total: float) -> dict[str, float]:
    """Normal forces on the corners of a block whose base lies on its plane, not rotating.

    In the block frame (x along the base, y along the plane's normal), with total friction
    ``friction_total`` along +x and total normal force ``weight_normal``, the moments about
    the centre, (w/2)(N_right - N_left) + (h/2) F = 0, split the normal force:
    N_right - N_left = -(h / w) F.
    """
    diff = -height / width * friction_total
    return {"right_corner": float(0.5 * (weight_normal + diff)),
            "left_corner": float(0.5 * (weight_normal - diff))}
