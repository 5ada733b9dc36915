"""Housner's rocking block: a slender block released tilted on one corner, rocking to rest.

A uniform rectangular block (width 0.2 m, height 1 m, mass 1 kg, I = m (w^2 + h^2) / 12
about its centre; chosen) on a free planar joint, theta = (x, y, phi): the centre's position
and the angle of the base from +x (counter-clockwise positive). Its bottom corners
``left_corner`` (-w/2, -h/2) and ``right_corner`` (+w/2, -h/2) are point contacts with the
floor y = 0 (n = +y, t = -x), e = 0, mu = 1. It is released from rest tilted by ``tilt`` about
its right corner, the left corner lifted (phi = -tilt), resting on the right corner: placed by
:func:`convimpact.model.place_resting` (phi fixed, the right corner's gap exactly 0).

Housner (1963): while it pivots on one corner without slipping the block is a pendulum about
that corner, I_O theta'' = -m g R sin(alpha - theta) with theta the rotation from the flat
position toward the lifted side (here theta = -phi), alpha = atan(width / height) the
slenderness angle, R = sqrt(w^2 + h^2) / 2 the half diagonal, I_O = 4/3 m R^2 and
p^2 = m g R / I_O = 3 g / (4 R). It lands flat on the other corner; with no bounce (e = 0) and
no slip the impact keeps the angular momentum about the new corner, so the angular velocity
drops by r = 1 - 3/2 sin^2 alpha and the old corner lifts; the rocking amplitudes satisfy
cos(alpha - theta_+) - cos alpha = r^2 [cos(alpha - theta_-) - cos alpha] and the impacts
accumulate in finite time (the block comes to rest, Zeno: after about 8.7 s for the
defaults, so t_end = 3 s covers the first six landings). A tilt above alpha topples it.

Assumptions (Housner's idealisation, chosen parameters): mu = 1 is large enough that the
pivot never slips (the friction needed is far below mu for a slender block); the pivot never
lifts off; the impact is plastic at the new corner and the old corner leaves the floor.

Parameters of :func:`make_scene`: width (0.2 m), height (1 m), mass (1 kg), tilt (0.1 rad),
e (0), mu (1), t_end (3 s). ``parameters`` also holds alpha, R, p^2 = 3 g / (4 R), p, I_O,
the impact ratio r and the linearised first-landing time (1/p) arccosh(1 / (1 - tilt/alpha)).
"""

from __future__ import annotations

import math
from types import MappingProxyType

import numpy as np

from convimpact.model import place_resting
from convimpact.problems._box import G, block_outline, build_block
from convimpact.scenes import Scene
from convimpact.validation import NonNegative, Positive, Real, Unit


#: the parameters of :func:`make_scene` and their ranges, checked by ``load_scene`` before
#: the scene is built (an error names the parameter)
PARAMETERS = {"width": Positive(), "height": Positive(), "mass": Positive(),
              "tilt": Real(0.0, math.pi / 2, low_open=True, high_open=True), "e": Unit(),
              "mu": NonNegative(), "t_end": Positive()}


def make_scene(width: float = 0.2, height: float = 1.0, mass: float = 1.0, tilt: float = 0.1,
               e: float = 0.0, mu: float = 1.0, t_end: float = 3.0) -> Scene:
    """Housner's rocking block (see the module docstring)."""
    mech = build_block(width, height, mass, e, mu)
    guess = np.array([0.0, height, -tilt])  # above the floor, tilted clockwise
    theta0 = place_resting(mech, guess, ["right_corner"], fixed=["phi"])
    alpha = float(np.arctan(width / height))
    R = 0.5 * float(np.hypot(width, height))
    p2 = 3.0 * G / (4.0 * R)
    r = 1.0 - 1.5 * np.sin(alpha) ** 2
    linear_t = (float(np.arccosh(1.0 / (1.0 - tilt / alpha)) / np.sqrt(p2))
                if tilt < alpha else None)
    description = (
        f"Housner's rocking block: a uniform rectangular block (width {width} m, height "
        f"{height} m, m = {mass} kg, I = m (w^2 + h^2)/12; chosen) on a free planar joint "
        "(x, y, phi), its two bottom corners point contacts with the floor y = 0 (n = +y, "
        f"t = -x, e = {e}, mu = {mu}). Released from rest tilted {tilt} rad clockwise "
        "(phi = -tilt) resting on its right corner, the left corner lifted; placed with "
        "place_resting. Assumed (Housner): the pivot neither slips nor lifts; each landing is "
        "plastic on the new corner and the old corner leaves the floor, so the angular velocity "
        "drops by r = 1 - 3/2 sin^2(alpha); the rocking decays to rest in finite time (Zeno). "
        "A tilt above alpha = atan(width/height) topples the block."
    )
    params = dict(
        width=width, height=height, mass=mass, tilt=tilt, e=e, mu=mu, gravity=G,
        alpha=alpha, R=R, p_squared=p2, p=float(np.sqrt(p2)),
        pivot_inertia=4.0 / 3.0 * mass * R ** 2, impact_ratio=float(r),
        topples=bool(tilt >= alpha), first_landing_time_linearized=linear_t,
        pivot="right_corner", lifted="left_corner",
        assumptions=[
            "block dimensions and mass chosen (Housner's example proportions)",
            "no slip at the pivot (mu = 1), no lift-off of the pivot",
            "plastic landing on the new corner, the old corner lifting off",
            "theta (Housner) = -phi: rotation about the pivot toward the lifted side",
        ])
    return Scene(name="rocking_block", description=description, mechanism=mech, theta0=theta0,
                 dtheta0=np.zeros(3), t_end=t_end, parameters=MappingProxyType(params),
                 outlines=block_outline(width, height))
