"""A box resting on an incline: it holds when mu >= tan(slope), else slides down.

A uniform rectangular box (width 0.4 m, height 0.2 m, mass 1 kg, I = m (w^2 + h^2) / 12;
chosen) on a free planar joint, theta = (x, y, phi): the centre's position and the angle of
the base from +x. The incline is the plane through the origin with unit normal
(-sin a, cos a), a = ``slope_deg``: the line y = x tan a, RISING TO THE RIGHT, so down the
slope is d = (-cos a, -sin a) (toward -x). The box's bottom corners ``left_corner``
(-w/2, -h/2, downhill) and ``right_corner`` (+w/2, -h/2, uphill) are point contacts with it
(t = n turned +90 degrees = (-cos a, -sin a) = d, e = 0, mu = 0.7), the box lying flat on
them (phi = a; placed by :func:`convimpact.model.place_resting`, both gaps exactly 0).
It starts at rest, or with the speed ``v0`` along the incline, positive DOWN the slope:
dtheta0 = v0 (d, 0).

Closed forms (Coulomb friction at both corners, the box translating without rotating):

* at rest it holds iff mu >= tan a (static friction m g sin a, normal force m g cos a);
  otherwise it slides down with the acceleration g (sin a - mu cos a) along d;
* sliding down (v0 > 0) it accelerates at g (sin a - mu cos a) (a deceleration when
  mu > tan a: it then stops after v0 / (g (mu cos a - sin a)) and holds);
* sliding up (v0 < 0) it decelerates at g (sin a + mu cos a), stops after
  |v0| / (g (sin a + mu cos a)), then holds or slides down as from rest.

The corner normal forces follow from the moments about the centre (box frame x up the
slope): N_right - N_left = -(h / w) F with F the total friction up the slope; the box tips
over its downhill corner if that makes N_right < 0 (not for the defaults).

Parameters of :func:`make_scene`: slope_deg (30), mu (0.7), v0 (0 m/s, down the slope),
width (0.4 m), height (0.2 m), mass (1 kg), e (0), t_end (2 s). In ``parameters`` every
acceleration is the component along d (down the slope): acceleration_from_rest (0 when it
holds), acceleration_while_sliding_down / _up; stop_time and stop_distance_down (signed along
d) of the first stop of the slip, None when it never stops.
"""

from __future__ import annotations

from types import MappingProxyType

import numpy as np

from convimpact.model import place_resting, rest_velocity
from convimpact.problems._box import CORNERS, G, block_outline, build_block, corner_normal_forces
from convimpact.scenes import Scene
from convimpact.validation import NonNegative, Positive, Real, Unit


#: the parameters of :func:`make_scene` and their ranges, checked by ``load_scene`` before
#: the scene is built (an error names the parameter)
PARAMETERS = {"slope_deg": Real(0.0, 90.0, high_open=True), "mu": NonNegative(), "v0": Real(),
              "width": Positive(), "height": Positive(), "mass": Positive(), "e": Unit(),
              "t_end": Positive()}


def _stop(v0: float, mu: float, a: float) -> tuple[float | None, float | None]:
    """(time, distance down the slope) at which the slip first stops, or (None, None).

    At rest (v0 = 0): (0, 0) when the box holds, (None, None) when it slides from the start.
    """
    if v0 > 0:
        dec = G * (mu * np.cos(a) - np.sin(a))
        if dec <= 0:
            return None, None
        return v0 / dec, v0 ** 2 / (2 * dec)
    if v0 < 0:
        dec = G * (np.sin(a) + mu * np.cos(a))
        return -v0 / dec, -v0 ** 2 / (2 * dec)
    return (0.0, 0.0) if mu >= np.tan(a) else (None, None)


def make_scene(slope_deg: float = 30.0, mu: float = 0.7, v0: float = 0.0, width: float = 0.4,
               height: float = 0.2, mass: float = 1.0, e: float = 0.0,
               t_end: float = 2.0) -> Scene:
    """The box on an incline (see the module docstring)."""
    a = float(np.radians(slope_deg))
    n = (-np.sin(a), np.cos(a))
    down = np.array([-np.cos(a), -np.sin(a)])
    mech = build_block(width, height, mass, e, mu, normal=n)
    theta0 = place_resting(mech, np.array([0.0, height, a]), list(CORNERS))
    dtheta0 = rest_velocity(mech, theta0, np.concatenate([v0 * down, [0.0]]), list(CORNERS))
    holds = bool(mu >= np.tan(a))
    acc_rest = 0.0 if holds else G * (np.sin(a) - mu * np.cos(a))
    t_stop, s_stop = _stop(v0, mu, a)
    W_n = mass * G * np.cos(a)
    if v0 > 0:
        friction_up = mu * W_n
    elif v0 < 0:
        friction_up = -mu * W_n
    else:
        friction_up = mass * G * np.sin(a) if holds else mu * W_n
    description = (
        f"A uniform box (width {width} m, height {height} m, m = {mass} kg; chosen) on a free "
        f"planar joint (x, y, phi), lying on an incline of {slope_deg} degrees (the line "
        "y = x tan a through the origin, rising to the right, normal (-sin a, cos a)) on its two "
        f"bottom corners (point contacts, e = {e}, mu = {mu}; placed with place_resting), "
        f"starting with speed {v0} m/s down the slope. Assumed: Coulomb friction at both "
        "corners, the box translates without rotating or tipping. It holds at rest iff "
        "mu >= tan a, else slides down at g (sin a - mu cos a)."
    )
    params = dict(
        slope_deg=slope_deg, slope=a, mu=mu, v0=v0, width=width, height=height, mass=mass, e=e,
        gravity=G, tan_slope=float(np.tan(a)), holds=holds,
        acceleration_from_rest=float(acc_rest),
        acceleration_while_sliding_down=float(G * (np.sin(a) - mu * np.cos(a))),
        acceleration_while_sliding_up=float(G * (np.sin(a) + mu * np.cos(a))),
        stop_time=None if t_stop is None else float(t_stop),
        stop_distance_down=None if s_stop is None else float(s_stop),
        down_direction=down.tolist(), normal=list(map(float, n)),
        normal_forces_initial=corner_normal_forces(width, height, W_n, float(friction_up)),
        assumptions=["box dimensions and mass chosen", "incline rises to the right (+x)",
                     "v0 > 0 means down the slope (toward -x)",
                     "Coulomb friction at both corners; translation without rotation"])
    return Scene(name="incline_box", description=description, mechanism=mech, theta0=theta0,
                 dtheta0=dtheta0, t_end=t_end, parameters=MappingProxyType(params),
                 outlines=block_outline(width, height))
