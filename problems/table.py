"""A rigid table on ``legs`` legs, resting on the floor or launched to slide to rest.

A rigid table (mass m, principal inertia m diag(0.05, 0.08, 0.05) m^2 about its centre of
mass; chosen) on a free spatial joint (translations, then Cardan X-Y-Z angles), its centre of
mass ``height`` above the floor y = 0, with ``legs`` point feet evenly spaced on a circle of
``radius`` (the first at 0.3 rad), e = 0, one mu. From three legs on the supports are
redundant (three equations, vertical force and two tilting moments, for ``legs`` normal
forces): the forces are statically indeterminate, the motion is not.

The table starts at rest on all its legs and, with ``v0 > 0``, sliding at ``v0`` along the
direction at ``direction_deg`` from +x in the floor plane. Closed forms (the rigid body,
Coulomb friction at every leg, no tipping while mu height < radius cos(pi / legs)):
it decelerates at mu g, stops after t_stop = v0 / (mu g) at the distance v0^2 / (2 mu g)
along its launch direction, and stays; the normal forces total m g, at rest m g / legs each
(the force problem's documented distribution: the largest smallest margin, then the least
norm).

Parameters of :func:`make_scene`: legs (5), v0 (0.6 m/s; 0: at rest), direction_deg (23),
mu (0.3), mass (2 kg), radius (0.3 m), height (0.2 m), t_end (0.3 s). ``parameters`` holds
stop_time, stop_distance and normal_force_at_rest.
"""

from __future__ import annotations

from types import MappingProxyType

import numpy as np

from convimpact.model import Joint, ModelBuilder
from convimpact.scenes import Scene
from convimpact.validation import Integer, NonNegative, Positive, Real

PARAMETERS = {"legs": Integer(1, 10000), "v0": NonNegative(), "direction_deg": Real(),
              "mu": NonNegative(), "mass": Positive(), "radius": Positive(),
              "height": Positive(), "t_end": Positive()}

G = 9.81


def build_table(legs: int, mu: float, mass: float, radius: float, height: float):
    """The table's mechanism (see the module docstring)."""
    b = ModelBuilder(planar=False)
    b.add_body("table", "ground", Joint.free(), mass, (0.0, 0.0, 0.0),
               mass * np.diag([0.05, 0.08, 0.05]), joint_name="float")
    for i in range(legs):
        a = 2.0 * np.pi * i / legs + 0.3
        b.add_contact(f"leg{i}", body="table",
                      point=(radius * np.cos(a), -height, radius * np.sin(a)),
                      normal=(0.0, 1.0, 0.0), plane_point=(0.0, 0.0, 0.0), e=0.0, mu=mu)
    return b.build().mechanism()


def table_outline(legs: int, radius: float, height: float) -> np.ndarray:
    """The top's rim and the feet, for drawing."""
    a = 2.0 * np.pi * np.arange(legs) / legs + 0.3
    rim = np.stack([radius * np.cos(a), np.full(legs, 0.05), radius * np.sin(a)], axis=1)
    feet = np.stack([radius * np.cos(a), np.full(legs, -height), radius * np.sin(a)], axis=1)
    return np.vstack([rim, feet])


def make_scene(legs: int = 5, v0: float = 0.6, direction_deg: float = 23.0, mu: float = 0.3,
               mass: float = 2.0, radius: float = 0.3, height: float = 0.2,
               t_end: float = 0.3) -> Scene:
    """The table (see the module docstring)."""
    legs = int(legs)
    mech = build_table(legs, mu, mass, radius, height)
    theta0 = np.zeros(6)
    theta0[1] = height  # every foot exactly on the floor
    psi = np.radians(direction_deg)
    dtheta0 = np.zeros(6)
    dtheta0[[0, 2]] = v0 * np.cos(psi), v0 * np.sin(psi)
    stop_time = v0 / (mu * G) if mu > 0 else float("inf")
    description = (
        f"A rigid table ({mass} kg, legs on a circle of radius {radius} m, centre of mass "
        f"{height} m above the feet; chosen) on {legs} point legs on the floor y = 0 (e = 0, "
        f"mu = {mu}), free in space, launched at {v0} m/s at {direction_deg} deg from +x: it "
        f"slides to rest after v0/(mu g) = {stop_time:.6g} s at v0^2/(2 mu g) = "
        f"{v0 ** 2 / (2 * mu * G) if mu > 0 else float('inf'):.6g} m. The legs' forces are "
        "statically indeterminate from three legs on; the motion is not.")
    params = dict(legs=legs, v0=v0, direction_deg=direction_deg, mu=mu, mass=mass,
                  radius=radius, height=height, gravity=G, stop_time=stop_time,
                  stop_distance=v0 ** 2 / (2 * mu * G) if mu > 0 else float("inf"),
                  normal_force_at_rest=mass * G / legs,
                  tips=bool(mu * height > radius * np.cos(np.pi / legs)),
                  assumptions=["table dimensions, mass and inertia chosen",
                               "point legs evenly spaced on a circle",
                               "Coulomb friction at every leg; no tipping (mu h < R cos(pi/n))"])
    return Scene(name="table", description=description, mechanism=mech, theta0=theta0,
                 dtheta0=dtheta0, t_end=t_end, parameters=MappingProxyType(params),
                 outlines={"table": table_outline(legs, radius, height)})
