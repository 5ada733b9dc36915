"""McGeer's rimless wheel walking down a slope: foot strikes settle into a steady gait.

A hub of mass m = 1 kg with n_spokes = 8 massless spokes of length l = 1 m (chosen), on a free
planar joint: theta = (x, y, phi), the hub's position and the wheel's angle (counter-clockwise
positive). The hub has the inertia I = m (rho l)^2 about its centre (rho = 0.1: a free body
needs I > 0 for M to be regular). The spoke ends ``foot0`` ... ``foot{n-1}``, at the body
angles -90 + 360 i / n degrees, are point contacts with the slope, e = 0, mu = 1. The slope
is the plane through the origin with normal (-sin g, cos g), g = ``slope_deg`` = 5 degrees:
the line y = x tan g, RISING TO THE RIGHT, so the wheel walks downhill toward -x, turning
counter-clockwise: phi_dot > 0. It starts standing on ``foot0`` with that leg vertical
(phi = 0; placed by :func:`convimpact.model.place_resting`, gap exactly 0) and the angular
velocity phi_dot = omega0 = 0.7 rad/s about the foot (the hub velocity omega0 l along -x).
The next feet to strike are foot{n-1}, foot{n-2}, ...

Step map (derived here; alpha = pi / n half the inter-leg angle, J = m l^2 (1 + rho^2) the
inertia about a foot). A step starts with the new stance leg leaning back (uphill) by
alpha - g from the vertical and ends when it leans forward by alpha + g, the next foot then
touching; the hub drops l [cos(alpha - g) - cos(alpha + g)] = 2 l sin(alpha) sin(g) per step.
At a foot strike, if the new foot sticks without bouncing and the old foot lifts off (no
impulse on it), the angular momentum about the new foot is conserved (the strike impulse
passes through it, gravity is finite):
I w- + m (G - P') x v_G = J w+ with v_G = w- z x (G - P) and (G - P') . (G - P) = l^2 cos(2 alpha),
so w+ = eta w-, eta = (cos(2 pi / n) + rho^2) / (1 + rho^2). Energy over a step gives
w-_next^2 = eta^2 w-^2 + 4 g_0 sin(alpha) sin(g) / (l (1 + rho^2)), whose fixed point is
w-* = sqrt(4 g_0 sin(alpha) sin(g) / (l (1 + rho^2) (1 - eta^2))), w+* = eta w-*; the gait
exists if w+* carries the hub over the vertical:
w+*^2 > 2 g_0 (1 - cos(alpha - g)) / (l (1 + rho^2)).
(g_0 = 9.81 m/s^2.) Deviations of w-^2 from the fixed point shrink by eta^2 per step
(0.504 for the defaults); from omega0 = 0.7 the first strike's w-^2 is 2.7 % above it, so
the gait is steady after two or three steps (a step takes about 0.8 s).

Stride map and its multiplier (derived here). On the Poincare section just after a foot
strike the state is one number, w+ (the stance foot sticks, the trailing foot has just left,
the angle is alpha - g behind the vertical). Energy over the step gives
w-^2 = w+^2 + c, c = 4 g_0 sin(alpha) sin(g) / (l (1 + rho^2)), and the strike
w+_next = eta w-, so P(w) = eta sqrt(w^2 + c) and P'(w) = eta w / sqrt(w^2 + c) =
eta^2 w / P(w). At the fixed point P(w*) = w*, hence the multiplier is exactly
P'(w*) = eta^2 = ((cos(2 pi / n) + rho^2) / (1 + rho^2))^2 (0.50411 for the defaults), the
same on any section (a multiplier is invariant under a change of coordinates; on the
pre-strike section w- the map is w -> sqrt(eta^2 w^2 + c), derivative eta^2 w / w_next, again
eta^2 at the fixed point). :func:`periodic_gait` finds it by Newton shooting on the full
state (x, y, phi, velocities): the held foot's three constraints and the trailing foot's gap
define the section, the translation along the slope is removed by :func:`reduce` (named in
``trivial_multipliers``), and the one multiplier left is eta^2.

Assumptions: massless spokes, the hub's mass at its centre; feet stick (mu = 1 exceeds the
ratio of the strike impulses, (1 - eta) cot(alpha) / (1 + eta) = 0.41 here, and of the stance
forces, about tan(alpha) = 0.41); a plastic strike with the old foot lifting off; no scuffing
of the swing feet (spokes are rigid and the slope is flat).

:func:`reduce` (the stride map's reduction: phi less one spoke angle, the stance foot put at
the origin) and :func:`periodic_gait` (the gait by Newton shooting) take the scene's
parameters; the slope stays ``slope_deg`` in degrees (the scene's parameter since its
first version; ``parameters["slope"]`` has it in radians).

Parameters of :func:`make_scene`: slope_deg (5), n_spokes (8), leg_length (1 m), mass (1 kg),
rho (0.1, radius of gyration / l), omega0 (0.7 rad/s), e (0), mu (1), t_end (3 s).
``parameters`` holds eta, the fixed point, the first strike's w- from omega0, and the steady
gait's angular velocity with the stance leg vertical (omega_vertical_steady: pass it as
omega0 to start on the limit cycle).
"""

from __future__ import annotations

from types import MappingProxyType

import numpy as np

from convimpact.model import Joint, ModelBuilder, place_resting, rest_velocity
from convimpact.scenes import Scene
from convimpact.validation import Integer, NonNegative, Positive, Real, Unit


#: the parameters of :func:`make_scene` and their ranges, checked by ``load_scene`` before
#: the scene is built (an error names the parameter)
PARAMETERS = {"slope_deg": Real(0.0, 60.0, high_open=True), "n_spokes": Integer(3, 1000),
              "leg_length": Positive(), "mass": Positive(), "rho": Positive(),
              "omega0": Real(), "e": Unit(), "mu": NonNegative(), "t_end": Positive()}


G = 9.81


def make_scene(slope_deg: float = 5.0, n_spokes: int = 8, leg_length: float = 1.0,
               mass: float = 1.0, rho: float = 0.1, omega0: float = 0.7, e: float = 0.0,
               mu: float = 1.0, t_end: float = 3.0) -> Scene:
    """The rimless wheel (see the module docstring)."""
    n = int(n_spokes)
    if not 0.0 <= slope_deg < 180.0 / n:
        raise ValueError(f"slope_deg must lie in [0, 180/n_spokes) = [0, {180 / n:g}), "
                         f"got {slope_deg}")
    gam = float(np.radians(slope_deg))
    leg = float(leg_length)
    b = ModelBuilder(planar=True)
    b.add_body("hub", "ground", Joint.free(), mass, (0.0, 0.0), mass * (rho * leg) ** 2,
               joint_name="float", coordinate_names=["x", "y", "phi"])
    for i in range(n):
        ang = -0.5 * np.pi + 2.0 * np.pi * i / n
        b.add_contact(f"foot{i}", body="hub", point=(leg * np.cos(ang), leg * np.sin(ang)),
                      normal=(-np.sin(gam), np.cos(gam)), plane_point=(0.0, 0.0), e=e, mu=mu)
    mech = b.build().mechanism()
    theta0 = place_resting(mech, np.array([0.0, 1.5 * leg, 0.0]), ["foot0"], fixed=["x", "phi"])
    # rotation about the stance foot: hub velocity omega0 z x (hub - foot) = omega0 l (-1, 0)
    dtheta0 = rest_velocity(mech, theta0, np.array([-omega0 * leg, 0.0, omega0]), ["foot0"],
                            fixed=["phi"])

    alpha = np.pi / n
    eta = (np.cos(2 * alpha) + rho ** 2) / (1 + rho ** 2)
    k = G / (leg * (1 + rho ** 2))  # g / (J / (m leg))
    gain = 4 * k * np.sin(alpha) * np.sin(gam)  # w^2 gained per step
    w_minus = np.sqrt(gain / (1 - eta ** 2))
    w_plus = eta * w_minus
    barrier = 2 * k * (1 - np.cos(alpha - gam))
    w_vert2 = w_plus ** 2 - barrier
    first2 = omega0 ** 2 + 2 * k * (1 - np.cos(alpha + gam))
    description = (
        f"McGeer's rimless wheel: a hub (m = {mass} kg, I = m (rho l)^2, rho = {rho}) with "
        f"{n} massless spokes of length {leg} m (chosen) on a free planar joint (x, y, phi), the "
        f"spoke ends point contacts (e = {e}, mu = {mu}) with a slope of {slope_deg} degrees "
        "rising to the right (y = x tan g). Starts standing on foot0 with the leg vertical "
        f"(placed with place_resting) turning at {omega0} rad/s counter-clockwise, walking "
        "downhill toward -x. Assumed: feet stick, strikes are plastic with the old foot lifting "
        "off, so w+ = w- (cos(2 pi/n) + rho^2)/(1 + rho^2) at each strike and the gait "
        "converges to McGeer's fixed point."
    )
    params = dict(
        slope_deg=slope_deg, slope=gam, n_spokes=n, leg_length=leg, mass=mass, rho=rho,
        hub_inertia=mass * (rho * leg) ** 2, omega0=omega0, e=e, mu=mu, gravity=G,
        half_interleg_angle=alpha, eta=float(eta),
        hub_drop_per_step=float(2 * leg * np.sin(alpha) * np.sin(gam)),
        omega_minus_steady=float(w_minus), omega_plus_steady=float(w_plus),
        omega_vertical_steady=float(np.sqrt(w_vert2)) if w_vert2 > 0 else None,
        steady_gait_exists=bool(w_vert2 > 0),
        omega_minus_first=float(np.sqrt(first2)),
        stance_angle_at_strike=float(alpha + gam),
        next_feet=[f"foot{(n - j) % n}" for j in range(1, n + 1)],
        assumptions=["massless spokes, all mass in the hub", "hub inertia m (rho l)^2",
                     "slope rises to the right; the wheel walks toward -x",
                     "feet stick; plastic strikes, the old foot lifting off"])
    return Scene(name="rimless_wheel", description=description, mechanism=mech, theta0=theta0,
                 dtheta0=dtheta0, t_end=t_end, parameters=MappingProxyType(params))


def reduce(theta: np.ndarray, dtheta: np.ndarray, n_spokes: int = 8, leg_length: float = 1.0):
    """The stride map's reduce: phi less one spoke angle (foot{n-1}, which struck, takes
    foot0's place) and the wheel translated along the slope so that foot0 is at the origin."""
    th = np.array(theta, float)
    th[2] -= 2.0 * np.pi / int(n_spokes)
    foot = np.array([th[0] + leg_length * np.sin(th[2]), th[1] - leg_length * np.cos(th[2])])
    th[:2] -= foot
    return th, np.array(dtheta, float)


def periodic_gait(**parameters):
    """The steady gait as a fixed point of the stride map (Newton shooting from the scene's
    start, :func:`convimpact.simulation.find_periodic_orbit`); its one multiplier is
    ``parameters["eta"] ** 2`` (module docstring).

    Raises
    ------
    PeriodicOrbitError
        when the slope is too shallow for a steady gait (the wheel stops: no strike).
    """
    from convimpact.scenes import load_scene
    from convimpact.simulation import find_periodic_orbit

    scene = load_scene("rimless_wheel", **parameters)
    n, leg = int(scene.parameters["n_spokes"]), float(scene.parameters["leg_length"])
    return find_periodic_orbit(scene, reduce=lambda th, dth: reduce(th, dth, n, leg),
                               t_max=max(float(scene.t_end), 3.0))
