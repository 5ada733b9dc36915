"""A box launched along the floor, sliding on its two bottom corners until friction stops it.

A uniform rectangular box (width 0.4 m, height 0.2 m, mass 1 kg, I = m (w^2 + h^2) / 12;
chosen) on a free planar joint, theta = (x, y, phi): the centre's position and the angle of
the base from +x. Its bottom corners ``left_corner`` (-w/2, -h/2) and ``right_corner``
(+w/2, -h/2) are point contacts with the floor y = 0 (n = +y, t = -x), e = 0, mu = 0.3. It
rests flat on both corners (placed by :func:`convimpact.model.place_resting`, both gaps
exactly 0) and is launched at v0 = 3 m/s along +x: dtheta0 = (v0, 0, 0).

Closed forms (Coulomb friction on both corners, the box translating without rotation): the
friction totals mu m g against the motion, so the box decelerates at mu g and stops after
t_stop = |v0| / (mu g) at the distance v0^2 / (2 mu g), then stays (static friction). The
friction moment loads the leading corner more: N_lead - N_trail = mu (h / w) m g, N_lead +
N_trail = m g; the trailing corner would lift (the box tips) if mu h > w, which the defaults
are far from (0.06 < 0.4).

Parameters of :func:`make_scene`: width (0.4 m), height (0.2 m), mass (1 kg), v0 (3 m/s
along +x), mu (0.3), e (0), t_end (2 s). ``parameters`` holds stop_time, stop_distance,
deceleration and the corner normal forces while sliding.
"""

from __future__ import annotations

from types import MappingProxyType

import numpy as np

from convimpact.model import place_resting, rest_velocity
from convimpact.problems._box import CORNERS, G, block_outline, build_block, corner_normal_forces
from convimpact.scenes import Scene
from convimpact.validation import Positive, Real, Unit


#: the parameters of :func:`make_scene` and their ranges, checked by ``load_scene`` before
#: the scene is built (an error names the parameter)
PARAMETERS = {"width": Positive(), "height": Positive(), "mass": Positive(), "v0": Real(),
              "mu": Real(0.0, low_open=True), "e": Unit(), "t_end": Positive()}


def make_scene(width: float = 0.4, height: float = 0.2, mass: float = 1.0, v0: float = 3.0,
               mu: float = 0.3, e: float = 0.0, t_end: float = 2.0) -> Scene:
    """The sliding box (see the module docstring)."""
    mech = build_block(width, height, mass, e, mu)
    theta0 = place_resting(mech, np.array([0.0, height, 0.0]), list(CORNERS))
    dtheta0 = rest_velocity(mech, theta0, np.array([v0, 0.0, 0.0]), list(CORNERS))
    friction = -np.sign(v0) * mu * mass * G  # along +x while sliding
    forces = corner_normal_forces(width, height, mass * G, friction)
    description = (
        f"A uniform box (width {width} m, height {height} m, m = {mass} kg, I = m (w^2 + "
        "h^2)/12; chosen) on a free planar joint (x, y, phi), resting flat on its two bottom "
        f"corners (point contacts with the floor y = 0, n = +y, t = -x, e = {e}, mu = {mu}; "
        f"placed with place_resting) and launched at {v0} m/s along +x. Assumed: Coulomb "
        "friction at both corners, the box translates without rotating or tipping "
        f"(mu h < w), so it stops after |v0|/(mu g) = {abs(v0) / (mu * G):.6g} s at the distance "
        f"v0^2/(2 mu g) = {v0 ** 2 / (2 * mu * G):.6g} m and then stays."
    )
    params = dict(
        width=width, height=height, mass=mass, v0=v0, mu=mu, e=e, gravity=G,
        deceleration=mu * G, stop_time=abs(v0) / (mu * G),
        stop_distance=v0 ** 2 / (2 * mu * G), stop_x=float(theta0[0] + np.sign(v0) * v0 ** 2
                                                           / (2 * mu * G)),
        normal_forces_sliding=forces, tips=bool(mu * height > width),
        assumptions=["box dimensions and mass chosen", "Coulomb friction at both corners",
                     "translation without rotation while sliding (no tipping: mu h < w)"])
    return Scene(name="sliding_box", description=description, mechanism=mech, theta0=theta0,
                 dtheta0=dtheta0, t_end=t_end, parameters=MappingProxyType(params),
                 outlines=block_outline(width, height))
