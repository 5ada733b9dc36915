"""Three-dimensional double pendulum of Section 9.3 striking a horizontal floor.

The rods of the planar case (a) on a support that also turns about the vertical y axis. The
joint coordinates are ``(theta3, theta1, theta2)`` in tree order: theta3 the base rotation
about +y, then theta1 (rod 1 about the carried z axis) and theta2 (rod 2 relative to rod 1),
all counter-clockwise positive. At impact rod 1 is at -108 and rod 2 at -120 degrees from +x
in the x-y plane (theta3 = 0) with theta_dot = (theta3_dot, theta1_dot, theta2_dot) =
(1, 1, 1) rad/s, which gives the paper's approach velocity
``-1.309 n - 2.683 t1 + 0.809 t2`` with n = +y, t1 = -x, t2 = +z (the paper prints
theta1_dot = theta2_dot = -1 with clockwise-positive rates, see ``pendulum_planar``).

Rods are slender: inertia m L^2 / 12 about both transverse axes and zero about the rod axis.
The base is massless, so the mass matrix is positive definite except where both rods are
parallel to the y axis (the base rotation then turns them only about their own axes, which
carry no inertia). The impact state and the simulation start are far from that.

Parameters of :func:`make_scene`: e, mu (defaults 0.5, 0.3), mass (1 kg, not given in the
paper), length (1 m).
"""

from __future__ import annotations

from types import MappingProxyType

import numpy as np

from convimpact.model import impact_arguments as _impact_arguments
from convimpact.scenes import Scene
from convimpact.validation import NonNegative, Positive, Unit

from ._double_pendulum import CASE_ANGLES, build, relative_coordinates, tip_height

#: the paper's approach velocity (v_n, v_t1, v_t2)

#: the parameters of :func:`make_scene` and their ranges, checked by ``load_scene`` before
#: the scene is built (an error names the parameter)
PARAMETERS = {"e": Unit(), "mu": NonNegative(), "mass": Positive(), "length": Positive()}


PAPER_APPROACH = (-1.309, -2.683, 0.809)


def make_scene(e: float = 0.7, mu: float = 0.4, mass: float = 1.0, length: float = 1.0) -> Scene:
    """The 3D double pendulum of Section 9.3 (see the module docstring).

    The defaults e = 0.7, mu = 0.4 are the values the paper's printed answer implies
    (v_n+ / v_n- = 0.916 / 1.309, |pi_t| / pi_n = 0.398); the paper does not state them.
    """
    a1, a2 = CASE_ANGLES["a"]
    floor_y = tip_height(a1, a2, length)
    model = build(False, mass, length, floor_y, e, mu)
    theta_imp = np.concatenate([[0.0], relative_coordinates(a1, a2)])
    theta0 = np.concatenate([[0.0], relative_coordinates(-45.0, -45.0)])
    description = (
        "Spatial double pendulum of Pereira & Nikravesh (1996) Section 9.3: the slender rods of "
        f"Section 9.2 (L = {length} m, m = {mass} kg each; the paper gives no mass, we chose 1 kg; "
        "inertia m L^2/12 about the transverse axes, zero about the rod axis) on a massless base "
        "turning about the vertical y axis. Coordinates (theta3, theta1, theta2): base rotation "
        "about +y, rod 1 about the carried z axis, rod 2 relative to rod 1. Floor at "
        f"y = {floor_y:.6f} m so the impact state (case (a) angles, theta3 = 0, all rates "
        "+1 rad/s) touches; contact frame n = +y, t1 = -x, t2 = +z. Simulation starts from both "
        "rods at -45 degrees with the base spinning at 1 rad/s. Gravity 9.81 m/s^2 along -y."
    )
    params = dict(e=e, mu=mu, mass=mass, length=length, floor_y=floor_y, gravity=9.81,
                  coordinates=["theta3", "theta1", "theta2"], impact_rates=[1.0, 1.0, 1.0],
                  paper_approach_velocity=list(PAPER_APPROACH),
                  assumptions=["rod mass 1 kg (not given in the paper)", "massless base",
                               "rates +1 rad/s counter-clockwise reproduce the printed velocities",
                               "floor height chosen so the impact state touches"])
    return Scene(name="pendulum_3d", description=description, mechanism=model.mechanism(),
                 theta0=theta0, dtheta0=np.array([1.0, 0.0, 0.0]), t_end=3.0,
                 parameters=MappingProxyType(params),
                 impact_state=(theta_imp, np.array([1.0, 1.0, 1.0])), impact_contact="tip")


def impact_arguments(e: float = 0.7, mu: float = 0.4) -> dict:
    """Raw ``resolve_impact`` arguments (M, Jc, dq, C, e, mu) of the Section 9.3 impact."""
    scene = make_scene(e=e, mu=mu)
    theta, dtheta = scene.impact_state
    return _impact_arguments(scene.mechanism, theta, dtheta, contacts="tip")
