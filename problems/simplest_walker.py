"""The simplest walking model of Garcia, Chatterjee, Ruina & Coleman (1998).

Two rigid massless legs of length l = 1 hinged at the hip, a point mass M = 1 at the hip and
point masses m = beta M at the feet, with beta -> 0 in the paper ("infinitesimal"); here
beta = 1e-5 by default (a mass matrix needs the feet's masses; the gait's variables move by
O(beta): 1.5e-6 in the stance angle, 1.5e-4 in the multipliers at beta = 1e-5; a smaller
beta makes the mass matrix's condition number 1/beta amplify round-off into the
differenced stride map: at 1e-6 its multipliers scatter by 5e-4). Units: l = 1, g = 1, time in
sqrt(l/g). The slope ``slope`` = gamma (radians; default 0.009, the paper's example)
descends toward +x. Heel strike is a plastic sticking impact of the swing foot (e = 0,
mu = 1), the stance foot lifting off (its contact is released when it would pull). Foot
scuffing at mid-stance is ignored as in the paper: the swing foot's contact is inactive until
the swing leg has passed the stance leg by ``activation`` (:mod:`convimpact.problems._walker`).

In the paper's variables (theta the stance leg's angle from the slope's normal, positive
with the hip behind the foot; phi the angle between the legs) the stable gait at
gamma = 0.009 starts just after heel strike at theta* = 0.20031090049483, theta_dot* =
-0.19983247291764 (the numbers of Garcia's own simulation code, which also lists that
gait's eigenvalues as -0.19120868949940 +/- 0.55633363687106i, and 4.000, 0.459 for the
unstable short-period gait); its stance angle scales as gamma^(1/3) for small slopes. The
scene starts there (interleg angle -2 theta*, the swing leg's rate from the beta -> 0 heel
strike, theta_dot* (1 - cos 2 theta*) in the paper's phi) and simulates ONE stride (t_end =
4.0: a stride takes 3.8825): the legs keep their labels in a simulation; the stride map's
``reduce`` (:func:`reduce`) switches them.

Parameters of :func:`make_scene`: slope (0.009 rad), beta (1e-5, foot mass / hip mass),
mu (1), activation (None: the guessed stance angle, half the interleg angle at heel strike),
t_end (4.0).
"""

from __future__ import annotations

from types import MappingProxyType

import numpy as np

from convimpact.scenes import Scene
from convimpact.validation import NonNegative, OrNone, Positive, Real

from ._walker import build_walker, find_gait, gait_parameters, stance_state, swap_legs

#: the parameters of :func:`make_scene` and their ranges, checked by ``load_scene``
PARAMETERS = {"slope": Real(0.0, 0.05, low_open=True), "beta": Real(0.0, 0.1, low_open=True),
              "mu": NonNegative(), "activation": OrNone(Positive()), "t_end": Positive()}

REFERENCE_SLOPE = 0.009
#: Garcia et al.'s stable gait at gamma = 0.009 (their simulation code's numbers)
GARCIA_THETA = 0.20031090049483
GARCIA_THETA_DOT = -0.19983247291764


def _guess(slope: float) -> tuple[float, float, float, float]:
    s = (slope / REFERENCE_SLOPE) ** (1.0 / 3.0)
    th, thd = GARCIA_THETA * s, GARCIA_THETA_DOT * s
    return th, thd, -2.0 * th, -thd * (1.0 - np.cos(2.0 * th))


def make_scene(slope: float = REFERENCE_SLOPE, beta: float = 1e-5, mu: float = 1.0,
               activation: float | None = None, t_end: float = 4.0) -> Scene:
    """The simplest walking model (see the module docstring)."""
    slope = float(slope)
    guess = _guess(slope)
    if activation is None:
        activation = guess[0]
    mech = build_walker(1.0, beta, 0.0, 1.0, slope, 1.0, mu, activation)
    theta0, dtheta0 = stance_state(*guess, slope, 1.0)
    params = dict(
        slope=slope, beta=beta, hip_mass=1.0, foot_mass=beta, leg_length=1.0, gravity=1.0,
        mu=mu, e=0.0, activation=float(activation),
        initial_gait=dict(zip(("stance_angle", "stance_rate", "interleg_angle",
                               "interleg_rate"), map(float, guess))),
        reference="Garcia, Chatterjee, Ruina & Coleman (1998)",
        assumptions=["massless legs, point-mass hip, feet of mass beta (paper: beta -> 0)",
                     "l = g = 1: time in sqrt(l/g)",
                     "plastic sticking heel strike, the old stance foot lifting off",
                     "foot scuffing ignored: the swing foot's contact is inactive until the "
                     "swing leg has passed the stance leg by `activation`",
                     "one stride per simulation: the leg switch is the stride map's reduce"])
    description = (
        "The simplest walking model (Garcia, Chatterjee, Ruina & Coleman 1998): massless legs "
        f"of length 1, hip mass 1, foot masses {beta:g} (the paper's limit beta -> 0), g = 1, "
        f"on a slope of {slope:g} rad descending toward +x. Plastic sticking heel strike, the "
        "old stance foot lifting off; foot scuffing ignored as in the paper. Starts just "
        "after heel strike on the stable gait (the paper's numbers at gamma = 0.009, scaled "
        "as gamma^(1/3) elsewhere); one stride.")
    return Scene(name="simplest_walker", description=description, mechanism=mech,
                 theta0=theta0, dtheta0=dtheta0, t_end=t_end,
                 parameters=MappingProxyType(params))


def reduce(theta: np.ndarray, dtheta: np.ndarray):
    """The stride map's reduce: the leg switch and the new stance foot put at the origin."""
    return swap_legs(theta, dtheta, 1.0)


def periodic_gait(**parameters):
    """The stable period-one gait (Newton shooting from the paper's gait, scaled as
    gamma^(1/3) for another slope).

    Returns
    -------
    PeriodicOrbit (``theta``/``dtheta`` just after heel strike; :func:`gait` gives the
    paper's variables).
    """
    from convimpact.scenes import load_scene

    scene = load_scene("simplest_walker", **parameters)
    return find_gait(scene, _guess(float(scene.parameters["slope"])))


def gait(orbit, slope: float = REFERENCE_SLOPE) -> dict:
    """The paper's variables of a fixed point: theta (stance angle from the normal), its
    rate, the interleg angle (minus the paper's phi) and its rate."""
    return gait_parameters(orbit.theta, orbit.dtheta, slope)
