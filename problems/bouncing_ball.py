"""A ball (point mass) dropped on a floor, bouncing to rest: the simplest Zeno case.

A point mass of 1 kg with radius 0.1 m and a translation joint, theta = (x, y) the centre's
position (the ball cannot rotate, so its spin is not modelled; the solid-sphere inertia
2 m r^2 / 5 is recorded but never enters M). Floor y = 0 (n = +y, t = -x). Released at
height h with horizontal speed u, it bounces with heights e^(2i) h; the impacts accumulate
at ``t_Z = sqrt(2 h' / g) (1 + 2 e / (1 - e))`` with ``h' = h - r`` (closed form for the
simulator's tests). With friction the first impact also removes horizontal speed.

Parameters of :func:`make_scene`: e (0.5), mu (0.0), mass (1 kg), radius (0.1 m),
height (1 m, of the centre), speed (0 m/s horizontal), t_end (2 s).
"""

from __future__ import annotations

from types import MappingProxyType

import numpy as np

from convimpact.model import Joint, ModelBuilder
from convimpact.scenes import Scene
from convimpact.validation import NonNegative, Positive, Real, Unit


#: the parameters of :func:`make_scene` and their ranges, checked by ``load_scene`` before
#: the scene is built (an error names the parameter)
PARAMETERS = {"e": Unit(), "mu": NonNegative(), "mass": Positive(), "radius": Positive(),
              "height": Positive(), "speed": Real(), "t_end": Positive()}


def zeno_time(e: float, height: float, radius: float, g: float = 9.81) -> float:
    """Accumulation time of the bounces of a ball dropped from rest (frictionless, e < 1)."""
    t1 = np.sqrt(2.0 * (height - radius) / g)
    return float(t1 * (1.0 + 2.0 * e / (1.0 - e)))


def make_scene(e: float = 0.5, mu: float = 0.0, mass: float = 1.0, radius: float = 0.1,
               height: float = 1.0, speed: float = 0.0, t_end: float = 2.0) -> Scene:
    """The bouncing ball (see the module docstring)."""
    b = ModelBuilder(planar=True)
    b.add_body("ball", "ground", Joint.translation(), mass, (0.0, 0.0), 0.4 * mass * radius ** 2,
               joint_name="float", coordinate_names=["x", "y"])
    b.add_contact("floor", body="ball", point=(0.0, 0.0), radius=radius, normal=(0.0, 1.0),
                  plane_point=(0.0, 0.0), e=e, mu=mu)
    mech = b.build().mechanism()
    description = (
        f"A ball (point mass m = {mass} kg, radius {radius} m; chosen) with a translation joint "
        f"(x, y), released with its centre {height} m above the floor y = 0 at horizontal speed "
        f"{speed} m/s; contact n = +y, t = -x, e = {e}, mu = {mu}. Bounces to rest in finite time "
        "(Zeno); the accumulation time is known in closed form (see zeno_time)."
    )
    params = dict(e=e, mu=mu, mass=mass, radius=radius, height=height, speed=speed, gravity=9.81,
                  zeno_time=zeno_time(e, height, radius) if e < 1 else None,
                  assumptions=["point mass: rotation not modelled"])
    return Scene(name="bouncing_ball", description=description, mechanism=mech,
                 theta0=np.array([0.0, height]), dtheta0=np.array([speed, 0.0]), t_end=t_end,
                 parameters=MappingProxyType(params))
