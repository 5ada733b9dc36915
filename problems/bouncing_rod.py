"""A slender rod dropped on a floor, bouncing to rest: the Zeno case.

A planar uniform rod (length 1 m, mass 1 kg, I = m L^2 / 12; not from the paper) with a free
planar joint: theta = (x, y, phi), the centre's position and the rod's angle from +x. Both
ends are candidate contacts (``end_a`` at -L/2, ``end_b`` at +L/2 along the rod) against the
floor y = 0 (n = +y, t = -x). Released from rest with its centre 1 m above the floor and
tilted 30 degrees, it strikes with one end, rotates, strikes with the other, and with e < 1
the bounces accumulate to rest in finite time (infinitely many impacts: a Zeno sequence that
an event-driven simulator must detect and terminate).

Parameters of :func:`make_scene`: e (0.5), mu (0.3), mass (1 kg), length (1 m),
height (1 m), tilt (30 degrees), t_end (3 s).
"""

from __future__ import annotations

from types import MappingProxyType

import numpy as np

from convimpact.model import Joint, ModelBuilder
from convimpact.scenes import Scene
from convimpact.validation import NonNegative, Positive, Real, Unit


#: the parameters of :func:`make_scene` and their ranges, checked by ``load_scene`` before
#: the scene is built (an error names the parameter)
PARAMETERS = {"e": Unit(), "mu": NonNegative(), "mass": Positive(), "length": Positive(),
              "height": Positive(), "tilt": Real(-90.0, 90.0), "t_end": Positive()}


def make_scene(e: float = 0.5, mu: float = 0.3, mass: float = 1.0, length: float = 1.0,
               height: float = 1.0, tilt: float = 30.0, t_end: float = 3.0) -> Scene:
    """The bouncing rod (see the module docstring)."""
    b = ModelBuilder(planar=True)
    b.add_body("rod", "ground", Joint.free(), mass, (0.0, 0.0), mass * length ** 2 / 12,
               joint_name="float", coordinate_names=["x", "y", "phi"])
    for name, s in (("end_a", -0.5), ("end_b", 0.5)):
        b.add_contact(name, body="rod", point=(s * length, 0.0), normal=(0.0, 1.0),
                      plane_point=(0.0, 0.0), e=e, mu=mu)
    mech = b.build().mechanism()
    theta0 = np.array([0.0, height, np.radians(tilt)])
    description = (
        f"A uniform slender rod (L = {length} m, m = {mass} kg, I = m L^2/12; chosen, not from the "
        "paper) with a free planar joint (x, y, phi), dropped from rest with its centre "
        f"{height} m above the floor y = 0 and tilted {tilt} degrees. Both ends are candidate "
        f"contacts (n = +y, t = -x, e = {e}, mu = {mu}). With e < 1 it bounces to rest in finite "
        "time through infinitely many impacts (Zeno)."
    )
    params = dict(e=e, mu=mu, mass=mass, length=length, height=height, tilt_deg=tilt,
                  gravity=9.81, assumptions=["rod dimensions and mass chosen (not in the paper)"])
    return Scene(name="bouncing_rod", description=description, mechanism=mech, theta0=theta0,
                 dtheta0=np.zeros(3), t_end=t_end, parameters=MappingProxyType(params))
