"""Planar double pendulum striking a horizontal floor: cases (a) and (b) of Section 9.2.

Parameters of :func:`make_scene`
--------------------------------
case : "a" | "b" | "drop"
    "a": rods at -108 and -120 degrees from +x at impact; "b": rod 1 vertical (-90 degrees),
    rod 2 at -102 degrees. In both the floor is placed at the tip's height at impact
    (y = -1.8171 m for (a), -1.9781 m for (b)) so the impact state touches (gap = 0), and
    the simulation starts from rest with both rods at -45 degrees, above that floor, so the
    tip strikes it repeatedly. "drop": floor at y = -1.5 m, release from rest with the rods
    horizontal (no paper impact state).
e, mu : coefficients of restitution and friction of the tip contact (the paper sweeps them;
    defaults 0.5 and 0.3).
mass, length : of each rod (defaults 1 kg and 1 m).

Sign convention: the joint coordinates are relative angles about +z (counter-clockwise
positive). The paper prints theta_dot = (-1, -1) rad/s, but its approach velocities
``-1.309 n - 2.683 t`` (a) and ``-0.416 n - 2.956 t`` (b) with n = +y and t = -x are
obtained with theta_dot = (+1, +1) about +z (the paper's angular rates are measured
clockwise); with (-1, -1) about +z the tip would be separating from the floor. We use
(+1, +1) about +z so the printed digits are reproduced.
"""

from __future__ import annotations

from types import MappingProxyType

import numpy as np

from convimpact.model import impact_arguments as _impact_arguments
from convimpact.scenes import Scene
from convimpact.validation import Choice, NonNegative, Positive, Unit

from ._double_pendulum import CASE_ANGLES, build, relative_coordinates, tip_height

#: the paper's approach velocities (v_n, v_t), n = +y, t = -x

#: the parameters of :func:`make_scene` and their ranges, checked by ``load_scene`` before
#: the scene is built (an error names the parameter)
PARAMETERS = {"case": Choice(("a", "b", "drop")), "e": Unit(), "mu": NonNegative(),
              "mass": Positive(), "length": Positive()}


PAPER_APPROACH = {"a": (-1.309, -2.683), "b": (-0.416, -2.956)}


def make_scene(case: str = "a", e: float = 0.5, mu: float = 0.3, mass: float = 1.0,
               length: float = 1.0) -> Scene:
    """The planar double pendulum of Section 9.2 (see the module docstring)."""
    if case not in ("a", "b", "drop"):
        from convimpact.errors import UnknownOptionError
        raise UnknownOptionError(f"unknown case {case!r}; choose 'a', 'b' or 'drop'")
    if case == "drop":
        floor_y = -1.5 * length
        theta0 = np.zeros(2)
        impact_state = None
    else:
        a1, a2 = CASE_ANGLES[case]
        floor_y = tip_height(a1, a2, length)
        theta0 = relative_coordinates(-45.0, -45.0)
        impact_state = (relative_coordinates(a1, a2), np.array([1.0, 1.0]))
    model = build(True, mass, length, floor_y, e, mu)
    description = (
        f"Planar double pendulum of Pereira & Nikravesh (1996) Section 9.2, case {case!r}: two "
        f"identical uniform slender rods (L = {length} m, m = {mass} kg each; the paper gives no "
        "mass, we chose 1 kg), revolute joints at the support (origin) and between the rods, the "
        f"tip of rod 2 striking a horizontal floor at y = {floor_y:.6f} m (placed so that the "
        "impact state touches). Coordinates: theta1 = rod 1 angle from +x, theta2 = rod 2 angle "
        "relative to rod 1, about +z. Impact rates theta_dot = (+1, +1) rad/s about +z reproduce "
        "the paper's approach velocities (its text prints -1 with clockwise-positive rates). "
        "Contact frame n = +y, t = -x. Gravity 9.81 m/s^2 along -y."
    )
    params = dict(case=case, e=e, mu=mu, mass=mass, length=length, floor_y=floor_y,
                  gravity=9.81, impact_rates=[1.0, 1.0],
                  paper_approach_velocity=list(PAPER_APPROACH.get(case, (None, None))),
                  assumptions=["rod mass 1 kg (not given in the paper)",
                               "rates +1 rad/s counter-clockwise reproduce the printed velocities",
                               "floor height chosen so the impact state touches"])
    return Scene(name="pendulum_planar", description=description, mechanism=model.mechanism(),
                 theta0=theta0, dtheta0=np.zeros(2), t_end=3.0,
                 parameters=MappingProxyType(params), impact_state=impact_state,
                 impact_contact="tip")


def impact_arguments(case: str = "a", e: float = 0.5, mu: float = 0.3) -> dict:
    """Raw ``resolve_impact`` arguments (M, Jc, dq, C, e, mu) of case "a" or "b"."""
    if case not in ("a", "b"):
        from convimpact.errors import UnknownOptionError
        raise UnknownOptionError(f"case {case!r} has no paper impact; choose 'a' or 'b'")
    scene = make_scene(case=case, e=e, mu=mu)
    theta, dtheta = scene.impact_state
    return _impact_arguments(scene.mechanism, theta, dtheta, contacts="tip")
