"""Closed forms of the ``sustained`` bench section: its observables and their exact values.

Each scene of :mod:`convimpact.bench.sustained_section` that has a closed form gets a list of
:class:`Observable` (:func:`observables`, the headline one first): the ball's roll time and final
speed, the sliding box's stop time and stop distance, the incline box's distance down the slope,
the rocking block's first landing time (Housner, by quadrature,
:func:`housner_first_landing_time`) and the rimless wheel's first strike time (quadrature,
:func:`wheel_first_strike_time`) and its angular velocity just before it.
:func:`closed_form_errors` measures a run against them. Event-driven times are its located
events; Moreau–Jean's are on its grid (see the section's docstring).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable, Sequence

import numpy as np
from scipy.integrate import quad

#: Moreau–Jean's stick time: first sample whose slip speed is at most this times the initial
STICK_TOL = 1e-6
#: errors below this are round-off: no observed order is fitted through them
ROUNDOFF = 1e-12


def housner_first_landing_time(tilt: float, alpha: float, R: float, g: float = 9.81) -> float:
    """Exact time from rest at the tilt theta0 until Housner's block lands flat.

    Pivoting on a corner, I_O theta'' = -m g R sin(alpha - theta) with p^2 = m g R / I_O =
    3 g / (4 R); the energy integral from rest at theta0 gives
    theta'^2 = 2 p^2 (cos(alpha - theta0) - cos(alpha - theta)), so

        T = int_0^theta0 dtheta / sqrt(2 p^2 (cos(alpha - theta0) - cos(alpha - theta))).

    With cos(alpha - theta0) - cos(alpha - theta) = 2 sin(alpha - (theta + theta0)/2)
    sin((theta0 - theta)/2) and theta = theta0 (1 - s^2) the 1/sqrt singularity at theta0
    goes: T = int_0^1 2 theta0 ds / sqrt(2 p^2 theta0 sin(alpha - theta0 + x) sinc(x)),
    x = theta0 s^2 / 2 (the linearized (1/p) arccosh(1/(1 - theta0/alpha)) is only close).
    """
    p2 = 3.0 * g / (4.0 * R)

    def integrand(s: float) -> float:
        x = 0.5 * tilt * s * s
        return 2.0 * tilt / math.sqrt(2.0 * p2 * tilt * math.sin(alpha - tilt + x)
                                      * float(np.sinc(x / math.pi)))

    return float(quad(integrand, 0.0, 1.0, epsabs=0.0, epsrel=1e-13, limit=200)[0])


def wheel_first_strike_time(omega0: float, stance_angle: float, leg_length: float, rho: float,
                            g: float = 9.81) -> float:
    """Time from the vertical stance leg turning at omega0 > 0 until the next foot strikes.

    An inverted pendulum about the stance foot, J sigma'' = m g l sin(sigma) with
    J = m l^2 (1 + rho^2), sigma the leg's angle from the vertical: sigma'^2 = omega0^2 +
    k (1 - cos sigma), k = 2 g / (l (1 + rho^2)), and the strike comes at sigma = pi/n + slope
    (``parameters["stance_angle_at_strike"]``): T = int_0^(pi/n + slope) dsigma / sigma'.
    """
    k = 2.0 * g / (leg_length * (1.0 + rho ** 2))
    return float(quad(lambda s: 1.0 / math.sqrt(omega0 ** 2 + k * (1.0 - math.cos(s))), 0.0,
                      stance_angle, epsabs=0.0, epsrel=1e-13, limit=200)[0])


@dataclass(frozen=True)
class Observable:
    """A closed-form observable: ``extract(result, scheme) -> value or None`` (None: missed)."""

    name: str
    exact: float
    extract: Callable[[Any, str], float | None]
    relative: bool = True


def _stick_time(mech, contact: str, extrapolate: bool = False
                ) -> Callable[[Any, str], float | None]:
    """The time a slipping contact first sticks: the event-driven scheme's located event, or
    Moreau–Jean's first sample whose slip speed is at most STICK_TOL times the initial one
    (``extrapolate``: the zero of the slip speed extrapolated linearly from the last two
    slipping samples, clipped to that step; the grid time when there are fewer)."""

    def extract(res, scheme: str) -> float | None:
        if scheme != "moreau-jean":
            return next((iv.t_start for iv in res.modes_of(contact) if iv.mode == "stick"),
                        None)
        vt = np.array([np.linalg.norm(mech.contact_jacobian(contact, th)[1:] @ v)
                       for th, v in zip(res.theta, res.dtheta)])
        hit = np.flatnonzero(vt <= STICK_TOL * max(vt[0], 1e-300))
        if not hit.size:
            return None
        j = int(hit[0])
        if not extrapolate or j < 2 or not vt[j - 2] > vt[j - 1]:
            return float(res.t[j])
        t0, t1 = res.t[j - 2], res.t[j - 1]
        t_zero = t1 + vt[j - 1] * (t1 - t0) / (vt[j - 2] - vt[j - 1])
        return float(min(max(t_zero, t1), res.t[j]))

    return extract


def _first_impact(contact: str, attr: str | None):
    """The first impact of ``contact`` (others, e.g. Moreau–Jean's impulses on a pivot that
    lifts by round-off and comes back, are skipped): its time, or its pre-impact phi_dot."""

    def extract(res, scheme: str) -> float | None:
        ev = next((ev for ev in res.impacts if contact in ev.contacts), None)
        if ev is None:
            return None
        return float(ev.time) if attr is None else float(np.asarray(ev.dtheta_minus)[2])

    return extract


def observables(key: str, scene, span: Sequence[float]) -> list[Observable]:
    """The closed-form observables of a scene (first: the headline one)."""
    p = scene.parameters
    mech, t1 = scene.mechanism, float(span[1])
    if key in ("ball", "ball-3d"):
        speed = ((lambda r, s: float(np.linalg.norm(r.dtheta[-1, :3]))) if p["spatial"] else
                 (lambda r, s: float(r.dtheta[-1, 0])))
        return [Observable("roll_time", float(p["roll_time"]), _stick_time(mech, "floor")),
                Observable("final_speed", float(p["final_speed"]), speed),
                Observable("roll_time_extrapolated", float(p["roll_time"]),
                           _stick_time(mech, "floor", extrapolate=True))]
    if key == "sliding-box":
        x0 = float(scene.theta0[0])
        return [Observable("stop_time", float(p["stop_time"]),
                           _stick_time(mech, "left_corner")),
                Observable("stop_distance", float(p["stop_distance"]),
                           lambda r, s: float(r.theta[-1, 0] - x0)),
                Observable("stop_time_extrapolated", float(p["stop_time"]),
                           _stick_time(mech, "left_corner", extrapolate=True))]
    if key.startswith("incline"):
        down = np.asarray(p["down_direction"], float)
        x0 = np.asarray(scene.theta0[:2], float)
        return [Observable("distance_down", 0.5 * float(p["acceleration_from_rest"]) * t1 ** 2,
                           lambda r, s: float((r.theta[-1, :2] - x0) @ down),
                           relative=not p["holds"])]
    if key == "rocking-block":
        return [Observable("first_landing_time",
                           housner_first_landing_time(p["tilt"], p["alpha"], p["R"],
                                                      p["gravity"]),
                           _first_impact(p["lifted"], None))]
    if key == "rimless-wheel":
        foot = p["next_feet"][0]
        return [Observable("first_strike_time",
                           wheel_first_strike_time(p["omega0"], p["stance_angle_at_strike"],
                                                   p["leg_length"], p["rho"], p["gravity"]),
                           _first_impact(foot, None)),
                Observable("omega_minus_first", float(p["omega_minus_first"]),
                           _first_impact(foot, "dtheta_minus"))]
    return []


def closed_form_errors(res, scheme: str, obs: Sequence[Observable]) -> dict[str, Any]:
    """{name: {value, exact, error, relative}}; a missed observable has error 1."""
    out = {}
    for o in obs:
        v = o.extract(res, scheme)
        if v is None:
            err = 1.0
        elif o.relative:
            err = abs(v - o.exact) / max(abs(o.exact), 1e-300)
        else:
            err = abs(v - o.exact)
        out[o.name] = {"value": v, "exact": o.exact, "error": float(err), "relative": o.relative}
    return out
