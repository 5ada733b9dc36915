"""Shared model of the two-legged walkers (compass gait, simplest walking model).

Two straight legs of length L = a + b hinged at the hip, point feet, walking down a slope of
angle gamma that DESCENDS TO THE RIGHT: the plane through the origin with the normal
(sin gamma, cos gamma), the walker moving toward +x. Coordinates theta = (x, y, phi_st,
phi_sw): the hip's position, the stance leg's angle (counter-clockwise from hanging straight
down; a free planar joint of the stance leg, the hip mass carried by it) and the swing leg's
angle relative to it (a revolute joint at the hip). The angle of the stance leg from the
slope's normal (the papers' theta) is phi_st + gamma; the interleg angle phi_sw is positive
when the swing foot is ahead (downhill) of the stance foot.

Masses: the hip mass m_H at the hip, each leg's mass m at the distance b from the hip (a from
its foot), no moment of inertia about it (the papers' point masses). The feet are point
contacts "stance_foot" and "swing_foot" with the slope, e = 0 (plastic heel strike), friction
mu (sticking: the papers' no-slip foot).

Foot scuffing. With straight legs the swing foot passes below the slope near mid-stance (the
foot height relative to the stance foot is 2 L sin(psi) sin(phi_sw / 2), psi the tilt of the
legs' bisector from the normal, zero at heel strike; it is negative between the zeros of psi
and of phi_sw). Goswami et al. (1998) and Garcia et al. (1998) ignore this interference:
only the heel-strike root of the collision condition counts. Here, as there, the swing
foot's contact is inactive until the swing leg has passed the stance leg: its gap is the
foot's height once phi_sw >= ``activation`` (a positive interleg angle by which the
foot has come back above the slope: the swing foot is below it between the legs' crossing
and the zero of psi, and above it from there to heel strike, where psi = 0 again), and
before that |height| + L (activation - phi_sw) > 0, continuous at the switch when the foot
is above the slope there. A state far from a gait (a swing foot still below the slope at
``activation``) gives a spurious strike there: the scenes choose ``activation`` about half
the gait's interleg angle at heel strike. The stance foot's gap is always its height. Roles are fixed
within a stride; at heel strike the swing foot sticks, the stance foot lifts off (the impact
law with e = 0: the old foot's contact is released when it would pull), and the stride map's
``reduce`` (:func:`swap_legs`) relabels the legs and puts the new stance foot at the origin.
"""

from __future__ import annotations

import numpy as np

from convimpact.model import Joint, ModelBuilder
from convimpact.model.mechanism import ModelMechanism


class WalkerMechanism(ModelMechanism):
    """The walker's model with the swing foot's contact inactive before the legs cross."""

    def __init__(self, model, leg_length: float, activation: float):
        super().__init__(model)
        self.leg_length = float(leg_length)
        self.activation = float(activation)

    def contact_gap(self, name: str, theta: np.ndarray) -> float:
        h = super().contact_gap(name, theta)
        if name != "swing_foot":
            return h
        interleg = float(theta[3])
        if interleg >= self.activation:
            return h
        return abs(h) + self.leg_length * (self.activation - interleg)


def build_walker(hip_mass: float, leg_mass: float, a: float, b: float, slope: float,
                 gravity: float, mu: float, activation: float) -> WalkerMechanism:
    """The two-legged walker's mechanism (see the module docstring)."""
    L = a + b
    total = hip_mass + leg_mass
    c = leg_mass * b / total  # the stance body's centre of mass below the hip
    inertia = hip_mass * c ** 2 + leg_mass * (b - c) ** 2
    bld = ModelBuilder(planar=True, gravity=(0.0, -gravity))
    bld.add_body("stance_leg", "ground", Joint.free(), total, (0.0, -c), inertia,
                 joint_name="hip", coordinate_names=["x", "y", "phi_st"])
    bld.add_body("swing_leg", "stance_leg", Joint.revolute(), leg_mass, (0.0, -b), 0.0,
                 joint_name="phi_sw", allow_singular_inertia=True)
    normal = (np.sin(slope), np.cos(slope))
    for leg, name in (("stance_leg", "stance_foot"), ("swing_leg", "swing_foot")):
        bld.add_contact(name, body=leg, point=(0.0, -L), normal=normal, plane_point=(0.0, 0.0),
                        e=0.0, mu=mu)
    return WalkerMechanism(bld.build(), L, activation)


def stance_state(stance_angle: float, stance_rate: float, interleg: float,
                 interleg_rate: float, slope: float, leg_length: float):
    """(theta, dtheta) with the stance foot at the origin, its leg at ``stance_angle`` from
    the slope's normal (counter-clockwise: the hip behind the foot) turning at
    ``stance_rate``, the swing leg at ``interleg`` from it turning at ``interleg_rate``."""
    phi = stance_angle - slope
    hip = np.array([-leg_length * np.sin(phi), leg_length * np.cos(phi)])
    v_hip = stance_rate * np.array([-leg_length * np.cos(phi), -leg_length * np.sin(phi)])
    theta = np.array([hip[0], hip[1], phi, interleg])
    dtheta = np.array([v_hip[0], v_hip[1], stance_rate, interleg_rate])
    return theta, dtheta


def swap_legs(theta: np.ndarray, dtheta: np.ndarray, leg_length: float):
    """The leg switch at heel strike: the swing leg becomes the stance leg (phi_st' = phi_st +
    phi_sw, phi_sw' = -phi_sw), and the walker is translated (along the slope: both feet are on it)
    so that the new stance foot is at the origin (velocities unchanged by a translation).
    """
    th = np.array(theta, float)
    dth = np.array(dtheta, float)
    phi = th[2] + th[3]
    th[2], th[3] = phi, -th[3]
    dth[2], dth[3] = dth[2] + dth[3], -dth[3]
    foot = np.array([th[0] + leg_length * np.sin(phi), th[1] - leg_length * np.cos(phi)])
    th[:2] -= foot
    return th, dth


def gait_parameters(theta: np.ndarray, dtheta: np.ndarray, slope: float) -> dict:
    """The papers' variables of a state: stance angle from the normal, its rate, interleg
    angle and rate."""
    return {"stance_angle": float(theta[2] + slope), "stance_rate": float(dtheta[2]),
            "interleg_angle": float(theta[3]), "interleg_rate": float(dtheta[3])}


def gait_vector(orbit, slope: float) -> np.ndarray:
    """(stance angle, its rate, interleg angle, its rate) of a fixed point."""
    return np.array(list(gait_parameters(orbit.theta, orbit.dtheta, slope).values()))


def find_gait(scene, guess, *, strides: int = 1, **options):
    """Newton shooting for the walker's gait from the papers' variables ``guess`` (stance
    angle, its rate, interleg angle, its rate just after heel strike)."""
    from convimpact.simulation import find_periodic_orbit

    p = scene.parameters
    L = float(p["leg_length"])
    y0 = stance_state(*guess, float(p["slope"]), L)
    options.setdefault("t_max", 4.0 * float(scene.t_end))
    return find_periodic_orbit(scene, y0, reduce=lambda th, dth: swap_legs(th, dth, L),
                               strides=strides, **options)


def continue_gait(make, start_slope: float, start_gait, target: float, max_step: float,
                  **options):
    """The gait at ``target`` by continuation in slope from ``start_gait`` at
    ``start_slope`` (steps of at most ``max_step``, a secant predictor)."""
    n = int(np.ceil(abs(target - start_slope) / max_step - 1e-12))
    slopes = np.linspace(start_slope, target, n + 1)
    guess = np.asarray(start_gait, float)
    previous = None
    orbit = None
    for i, s in enumerate(slopes):
        orbit = find_gait(make(float(s)), guess, **options)
        current = gait_vector(orbit, float(s))
        if i + 1 < len(slopes):
            guess = current if previous is None else 2.0 * current - previous
        previous = current
    return orbit
