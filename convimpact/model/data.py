"""Per-state workspace of a model (Pinocchio's ``Data``).

A :class:`Data` belongs to one :class:`~convimpact.model.builder.Model`. The evaluation
functions fill it for a state (theta, theta_dot) and reuse what is already there when they are
called again at the same state, so computing M, f and the contact Jacobians at one state walks
the tree once.
"""

from __future__ import annotations

from typing import Any, Optional

import numpy as np


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
