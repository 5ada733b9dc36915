"""References and accuracy measures of the ``mujoco`` bench section.

Two errors of a run over ``[0, t_end]``, the same for our event-driven simulator and MuJoCo:

* ``rebound_error``: ``|E(t_m) - E_ref(t_m)| / T_ref-`` with E the mechanical energy (our
  mechanism's kinetic plus potential energy of the run's joint state), ``t_m`` the midpoint
  between the reference's first and second impacts (both runs are then in free flight, so
  E is the energy the first rebound left) and ``T_ref-`` the kinetic energy just before the
  first impact. For the ball it is the error of the first apex height over the drop height
  ``h - r``. It does not depend on when the rebound happened, so a compliant contact's time
  shift is not counted against it;
* ``final_state_error``: ``|y(t_end) - y_ref(t_end)| / |y_ref(t_end)|``, y = (theta, theta_dot).

References: the ball in closed form (impact times ``t_1 = sqrt(2 (h - r) / g)``, then flights of
``2 e^i t_1``; apex ``r + e^2 (h - r)``); the rod and the double pendulum our event-driven run at
``rtol = 1e-12`` (law ``coulomb``), whose own error is estimated by its distance to the run at
``rtol = 1e-10`` (stated in the section's meta).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

#: law of our runs and references (Newton's restitution with Coulomb friction)
LAW = "coulomb"
REFERENCE_RTOL = 1e-12
CHECK_RTOL = 1e-10


@dataclass(frozen=True)
class Reference:
    """What a run is compared with.

    Attributes
    ----------
    t_end : end of the span.
    t_mid : the instant of the rebound energy (midpoint of the first two impacts).
    energy_mid : the reference's mechanical energy at ``t_mid``.
    kinetic_before : kinetic energy just before the first impact.
    state_end : (theta, theta_dot) at ``t_end``.
    impact_times : the reference's impact instants within the span.
    source : "closed form" or the event-driven run's settings.
    self_error : for a simulated reference, its rebound and final-state distance to the run
        at ``rtol = 1e-10`` (None for the closed form).
    """

    t_end: float
    t_mid: float
    energy_mid: float
    kinetic_before: float
    state_end: np.ndarray
    impact_times: tuple[float, ...]
    source: str
    self_error: dict | None = None


def ball_reference(params, t_end: float) -> Reference:
    """The closed form of the frictionless ball dropped from rest."""
    g, e, r, h, m = (params["gravity"], params["e"], params["radius"], params["height"],
                     params["mass"])
    t1 = math.sqrt(2.0 * (h - r) / g)
    v1 = g * t1
    times = [t1]
    while True:
        nxt = times[-1] + 2.0 * e ** len(times) * v1 / g
        if nxt > t_end:
            break
        times.append(nxt)
    # state at t_end: the last impact before it, then free flight
    k = len(times)
    v_up = e ** k * v1
    s = t_end - times[-1]
    y = r + v_up * s - 0.5 * g * s * s
    vy = v_up - g * s
    t_mid = 0.5 * (times[0] + times[1]) if len(times) > 1 else t1 + e * v1 / g
    return Reference(
        t_end=t_end, t_mid=t_mid, energy_mid=m * g * (r + e * e * (h - r)),
        kinetic_before=m * g * (h - r), state_end=np.array([0.0, y, 0.0, vy]),
        impact_times=tuple(times), source="closed form")


def simulated_reference(scene, t_end: float) -> Reference:
    """Our event-driven run at ``rtol = 1e-12`` (and its distance to the run at 1e-10)."""
    from ..simulation import simulate

    runs = [simulate(scene, (0.0, t_end), law=LAW, rtol=rt, atol=1e-2 * rt, dense_output=True)
            for rt in (REFERENCE_RTOL, CHECK_RTOL)]
    ref, check = runs
    times = tuple(float(i.time) for i in ref.impacts)
    t_mid = 0.5 * (times[0] + times[1])
    mech = scene.mechanism

    def energy(res):
        th, dth = state_from_dense(mech, res, t_mid)
        return mech.kinetic_energy(th, dth) + mech.potential_energy(th)

    y_end = np.concatenate([ref.theta[-1], ref.dtheta[-1]])
    y_chk = np.concatenate([check.theta[-1], check.dtheta[-1]])
    t_before = float(ref.impacts[0].kinetic_energy_minus)
    self_error = {"rebound_error": abs(energy(check) - energy(ref)) / t_before,
                  "final_state_error": float(np.linalg.norm(y_chk - y_end)
                                             / np.linalg.norm(y_end)),
                  "rtol": CHECK_RTOL}
    return Reference(t_end=t_end, t_mid=t_mid, energy_mid=energy(ref), kinetic_before=t_before,
                     state_end=y_end, impact_times=times,
                     source=f"event-driven, law {LAW}, rtol {REFERENCE_RTOL:g}, "
                            f"atol {1e-2 * REFERENCE_RTOL:g}",
                     self_error=self_error)


def state_from_dense(mech, res, t: float) -> tuple[np.ndarray, np.ndarray]:
    """``(theta, theta_dot)`` of an event-driven result's dense output at ``t``."""
    y = np.asarray(res.sol(t), float)
    k = y.size // 2
    theta, p = y[:k], y[k:]
    return theta, np.linalg.solve(mech.mass_matrix(theta), p)


def errors(mech, ref: Reference, theta_mid, dtheta_mid, theta_end, dtheta_end) -> dict:
    """``rebound_error`` and ``final_state_error`` of a run's states at ``t_mid``, ``t_end``."""
    e_mid = mech.kinetic_energy(theta_mid, dtheta_mid) + mech.potential_energy(theta_mid)
    y = np.concatenate([theta_end, dtheta_end])
    return {"rebound_error": float(abs(e_mid - ref.energy_mid) / ref.kinetic_before),
            "final_state_error": float(np.linalg.norm(y - ref.state_end)
                                       / np.linalg.norm(ref.state_end))}
