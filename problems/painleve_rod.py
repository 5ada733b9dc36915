"""Painleve's rod: a rod sliding on one end where Coulomb friction has no consistent solution.

A uniform rod (length 2 l = 1 m, mass 1 kg, I = m (2 l)^2 / 12 = m l^2 / 3 about its centre;
chosen) on a free planar joint, theta = (x, y, phi): the centre's position and the angle of
the rod from +x. Its ``foot`` (the body-frame point (-l, 0)) is a point contact with the floor
y = 0 (n = +y, t = -x), e = 0, mu = 1.5; the other end is not a contact. The rod is inclined at
theta_r = ``angle_deg`` = 60 degrees to the floor and LEANS TOWARD -x: phi = 180 - angle_deg
degrees, so the foot is below and to the right of the centre. The foot rests on the floor
(placed by :func:`convimpact.model.place_resting`, gap exactly 0) and the rod translates at
v0 = 1 m/s along +x, the foot sliding AWAY from the lean: dtheta0 = (v0, 0, 0) (zero normal
velocity, no rotation).

Effective normal (inverse) mass of the sliding foot (derived here). Let u = (cos th, sin th)
point from the foot to the centre in the plane spanned by the lean (th = theta_r measured
from the direction of the lean). With the contact force N (normal) and F = -mu s N (friction,
s = the sign of the foot's slip velocity along the lean direction), the centre moves by
m a_G = (F, N - m g) and the rod turns by I th'' = l (F sin th - N cos th) (the foot is at
-l u from the centre). The foot's height is y - l sin th, so its normal acceleration is
y'' - l cos th th'' + l sin th th'^2 = b + A N with b = -g + l sin th th'^2 and

    A(th) = 1/m + l^2 cos th (cos th + mu s sin th) / I
          = (1/m) (1 + 3 cos^2 th + 3 mu s sin th cos th)      (I = m l^2 / 3).

A < 0 needs s = -1 (the foot sliding away from the side the rod leans over, as here) and
mu > (1 + 3 cos^2 th) / (3 sin th cos th), whose minimum over th is 4/3 at tan th = 2. At the
defaults (th = 60 degrees, mu = 1.5 > 1.363) A = (1.75 - 1.949) / m = -0.199 / m < 0, and the
rod starts without rotation, so b = -g < 0: the complementarity problem b + A N >= 0, N >= 0,
N (b + A N) = 0 has no solution (inconsistent); with b > 0 it would have two (indeterminate).
In ``parameters``: the A above (painleve_A), b, the critical mu at this angle, 4/3, and the
regime ('inconsistent', 'indeterminate' or 'consistent').

Parameters of :func:`make_scene`: angle_deg (60), v0 (1 m/s, the foot's x velocity; > 0
slides away from the lean), mu (1.5), length (1 m, = 2 l), mass (1 kg), e (0), t_end (2 s).
"""

from __future__ import annotations

from types import MappingProxyType

import numpy as np

from convimpact.model import Joint, ModelBuilder, place_resting, rest_velocity
from convimpact.scenes import Scene
from convimpact.validation import NonNegative, Positive, Real, Unit


#: the parameters of :func:`make_scene` and their ranges, checked by ``load_scene`` before
#: the scene is built (an error names the parameter)
PARAMETERS = {"angle_deg": Real(0.0, 90.0, low_open=True, high_open=True), "v0": Real(),
              "mu": NonNegative(), "length": Positive(), "mass": Positive(), "e": Unit(),
              "t_end": Positive()}


G = 9.81


def make_scene(angle_deg: float = 60.0, v0: float = 1.0, mu: float = 1.5, length: float = 1.0,
               mass: float = 1.0, e: float = 0.0, t_end: float = 2.0) -> Scene:
    """Painleve's rod (see the module docstring)."""
    half = 0.5 * length
    th = float(np.radians(angle_deg))
    b = ModelBuilder(planar=True)
    b.add_body("rod", "ground", Joint.free(), mass, (0.0, 0.0), mass * length ** 2 / 12,
               joint_name="float", coordinate_names=["x", "y", "phi"])
    b.add_contact("foot", body="rod", point=(-half, 0.0), normal=(0.0, 1.0),
                  plane_point=(0.0, 0.0), e=e, mu=mu)
    mech = b.build().mechanism()
    theta0 = place_resting(mech, np.array([0.0, length, np.pi - th]), ["foot"],
                           fixed=["x", "phi"])
    dtheta0 = rest_velocity(mech, theta0, np.array([v0, 0.0, 0.0]), ["foot"])
    s = -float(np.sign(v0))  # slip along the lean direction (-x)
    c, sn = np.cos(th), np.sin(th)
    A = (1.0 + 3.0 * c * c + 3.0 * mu * s * sn * c) / mass
    b_acc = -G + half * sn * dtheta0[2] ** 2
    mu_crit = (1.0 + 3.0 * c * c) / (3.0 * sn * c)
    if A >= 0:
        regime = "consistent"
    else:
        regime = "inconsistent" if b_acc < 0 else "indeterminate"
    description = (
        f"Painleve's rod: a uniform rod (2l = {length} m, m = {mass} kg, I = m l^2/3; chosen) "
        "on a free planar joint (x, y, phi), one end (the foot) a point contact with the floor "
        f"y = 0 (n = +y, t = -x, e = {e}, mu = {mu}). Inclined {angle_deg} degrees, leaning "
        f"toward -x, the foot on the floor (placed with place_resting), translating at {v0} "
        "m/s along +x (the foot slides away from the lean). The foot's effective normal "
        f"inverse mass is A = (1 + 3 cos^2 - 3 mu sin cos)/m = {A:.4g} and b = -g: with "
        "A < 0 Coulomb friction has no consistent contact force (Painleve's paradox), the "
        "case a simulator must detect (e.g. by an impact without collision)."
    )
    params = dict(
        angle_deg=angle_deg, angle=th, v0=v0, mu=mu, length=length, half_length=half, mass=mass,
        inertia=mass * length ** 2 / 12, e=e, gravity=G, slip_sign_along_lean=s,
        painleve_A=float(A), normal_free_acceleration=float(b_acc),
        mu_critical_at_angle=float(mu_crit), mu_critical_min=4.0 / 3.0,
        angle_of_min_critical_mu=float(np.arctan(2.0)), regime=regime,
        lean_direction=[-1.0, 0.0],
        assumptions=["rod dimensions and mass chosen", "only the lower end is a contact",
                     "the rod leans toward -x; v0 > 0 slides the foot away from the lean",
                     "Coulomb friction; A derived for I = m l^2 / 3"])
    return Scene(name="painleve_rod", description=description, mechanism=mech, theta0=theta0,
                 dtheta0=dtheta0, t_end=t_end, parameters=MappingProxyType(params))
