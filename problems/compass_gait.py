"""The compass-gait walker of Goswami, Thuilot & Espiau (1998) walking down a slope.

Two straight legs of length L = a + b hinged at the hip, point feet; the hip mass m_H = 10 kg
at the hip, each leg's mass m = 5 kg at the distance b from the hip (a from the foot), no
leg inertia about it: their nominal walker, m_H / m = 2, a = b = 0.5 m (g = 9.81 m/s^2). The
slope ``slope`` (radians; default 3 degrees) descends toward +x. Heel strike is a plastic
impact of the swing foot (e = 0, mu = 1: it sticks), the stance foot lifting off (the impact
law releases its contact when it would pull); foot scuffing at mid-stance is ignored as the
papers ignore it (the swing foot's contact is inactive until the swing leg has passed the
stance leg by ``activation``, see :mod:`convimpact.problems._walker`). Coordinates (x, y,
phi_st, phi_sw): the hip's position, the stance leg's angle from hanging down
(counter-clockwise), the interleg angle (positive with the swing foot ahead).

The scene starts just after a heel strike on the period-one gait of the 3-degree slope
(stance leg 0.27103 rad behind the slope's normal turning at -1.09238 rad/s, interleg angle
-0.54206 rad opening at 0.71501 rad/s; computed here with :func:`periodic_gait`, stride 0.7343
s, multipliers -0.200 +/- 0.545i and 0.132: stable) and simulates ONE stride (t_end = 0.8 s):
the legs keep their labels in a simulation, so the next stride's leg switch is the stride
map's ``reduce`` (:func:`reduce`); :func:`periodic_gait` chains strides that way.

Goswami et al. report a stable symmetric period-one gait at small slopes that period-doubles
as the slope grows, then a cascade of doublings to chaos; here the period-one gait's
multiplier crosses -1 between 4.35 and 4.40 degrees, the period-two gait's between 4.90 and
4.95, the period-four gait's between 5.00 and 5.05
(:func:`convimpact.studies.gaits.compass_gait_bifurcation`, docs/figures/
compass_gait_bifurcation.png).

Parameters of :func:`make_scene`: slope (0.05236 rad = 3 degrees), hip_mass (10 kg), leg_mass
(5 kg), a (0.5 m), b (0.5 m), mu (1), activation (None: 0.3 rad scaled with the slope as the
gait's interleg angle, slope^(1/3)), t_end (0.8 s).
"""

from __future__ import annotations

from types import MappingProxyType

import numpy as np

from convimpact.scenes import Scene
from convimpact.validation import NonNegative, OrNone, Positive, Real

from ._walker import build_walker, continue_gait, gait_parameters, stance_state, swap_legs

#: the parameters of :func:`make_scene` and their ranges, checked by ``load_scene``
PARAMETERS = {"slope": Real(0.0, 0.35, low_open=True), "hip_mass": Positive(),
              "leg_mass": Positive(), "a": Positive(), "b": Positive(), "mu": NonNegative(),
              "activation": OrNone(Positive()), "t_end": Positive()}

G = 9.81
REFERENCE_SLOPE = float(np.radians(3.0))
#: the period-one gait on the reference slope just after heel strike (nominal walker):
#: stance angle from the normal, its rate, interleg angle, its rate
REFERENCE_GAIT = (0.27103, -1.09238, -0.54206, 0.71501)


def _guess(slope: float) -> tuple[float, float, float, float]:
    s = (slope / REFERENCE_SLOPE) ** (1.0 / 3.0)
    return tuple(v * s for v in REFERENCE_GAIT)


def make_scene(slope: float = REFERENCE_SLOPE, hip_mass: float = 10.0, leg_mass: float = 5.0,
               a: float = 0.5, b: float = 0.5, mu: float = 1.0, activation: float | None = None,
               t_end: float = 0.8) -> Scene:
    """The compass-gait walker (see the module docstring)."""
    slope = float(slope)
    L = float(a) + float(b)
    guess = _guess(slope)
    if activation is None:
        activation = 0.3 * (slope / REFERENCE_SLOPE) ** (1.0 / 3.0)
    mech = build_walker(hip_mass, leg_mass, a, b, slope, G, mu, activation)
    theta0, dtheta0 = stance_state(*guess, slope, L)
    params = dict(
        slope=slope, slope_deg=float(np.degrees(slope)), hip_mass=hip_mass, leg_mass=leg_mass,
        a=a, b=b, leg_length=L, mu=mu, e=0.0, gravity=G, activation=float(activation),
        initial_gait=dict(zip(("stance_angle", "stance_rate", "interleg_angle",
                               "interleg_rate"), guess)),
        reference="Goswami, Thuilot & Espiau (1998), the nominal walker m_H/m = 2, a = b",
        assumptions=["point feet, point-mass legs, no leg inertia about the leg's mass",
                     "plastic sticking heel strike, the old stance foot lifting off",
                     "foot scuffing ignored: the swing foot's contact is inactive until the "
                     "swing leg has passed the stance leg by `activation`",
                     "one stride per simulation: the leg switch is the stride map's reduce"])
    description = (
        f"Compass-gait walker (Goswami, Thuilot & Espiau 1998): hip mass {hip_mass} kg, legs "
        f"of {L} m with {leg_mass} kg at {b} m from the hip, point feet, on a slope of "
        f"{np.degrees(slope):.3g} degrees descending toward +x. Plastic sticking heel strike "
        "(e = 0), the old stance foot lifting off; foot scuffing ignored as in the paper. "
        "Starts just after heel strike near the period-one gait; one stride.")
    return Scene(name="compass_gait", description=description, mechanism=mech, theta0=theta0,
                 dtheta0=dtheta0, t_end=t_end, parameters=MappingProxyType(params))


def reduce(theta: np.ndarray, dtheta: np.ndarray, leg_length: float = 1.0):
    """The stride map's reduce: the leg switch and the new stance foot put at the origin."""
    return swap_legs(theta, dtheta, leg_length)


def periodic_gait(**parameters):
    """The stable period-one gait of the walker with these scene parameters.

    Newton shooting (:func:`convimpact.simulation.find_periodic_orbit`) from the reference
    gait, continued in slope steps of at most 0.25 degrees from 3 degrees when ``slope``
    is another (the gait the papers chart is the branch through the small-slope stable one).

    Returns
    -------
    PeriodicOrbit (its ``theta``/``dtheta`` just after heel strike; :func:`gait` gives the
    papers' variables).
    """
    from convimpact.scenes import load_scene

    target = load_scene("compass_gait", **parameters)
    return continue_gait(lambda s: load_scene("compass_gait", **{**parameters, "slope": s}),
                         REFERENCE_SLOPE, REFERENCE_GAIT, float(target.parameters["slope"]),
                         max_step=float(np.radians(0.25)))


def gait(orbit, slope: float = REFERENCE_SLOPE) -> dict:
    """The papers' variables of a fixed point: stance angle from the normal, its rate,
    interleg angle, its rate."""
    return gait_parameters(orbit.theta, orbit.dtheta, slope)
