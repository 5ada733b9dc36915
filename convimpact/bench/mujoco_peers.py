"""MuJoCo as an outside simulation peer (optional: PyPI package ``mujoco``).

The three scenes of the ``mujoco`` bench section are written as MJCF in code, with our masses,
inertias, lengths, gravity and initial state. Our planar x-y plane (gravity along -y) is
MuJoCo's x-z plane (gravity along -z), and every scene's joint coordinates are ours, one to
one (MuJoCo's ``qpos``/``qvel`` are our ``theta``/``theta_dot``):

* ``bouncing_ball``: slide x, slide z, a sphere of the ball's radius on the floor z = 0;
* ``bouncing_rod``: slide x, slide z, hinge about -y (so that a positive angle turns +x toward
  +z, our counter-clockwise phi), through the rod's centre; each end is a small sphere of
  radius :data:`TIP_RADIUS` at (±L/2, 0, 0) and the floor is lowered by that radius, so the
  sphere's distance to the floor is the end point's height (our gap);
* ``pendulum drop``: two hinges about -y (rod 1 at the origin, rod 2 at rod 1's end), the tip
  of rod 2 a small sphere over the floor y = -1.5 L lowered by its radius.

Masses and inertias come from explicit ``<inertial>`` elements (the contact spheres carry no
mass); in-plane rotational inertia is ours, the out-of-plane entries are irrelevant to the
planar motion and only keep MuJoCo's inertia valid. Friction: MuJoCo's elliptic cone
(``condim = 3``: the Coulomb cone) with the scene's mu on both geoms, or ``condim = 1``
(frictionless) where mu = 0. Within a soft impact MuJoCo's friction force stays in the cone
but is not bound to oppose the slip: on the double pendulum's first impact (tip sliding
along -x throughout) it turns from +x to -x half-way, and the converged rebound keeps
T+ = 12.6 J of T- = 16.3 J where the frictionless rigid impact keeps 10.7 J and the Coulomb
one 8.4 J (``cone="pyramidal"`` and ``impratio`` up to 100 change nothing).

**Calibration.** MuJoCo's soft contact is a mass-normalized damped spring set by
``solref = (timeconst, dampratio)`` and the impedance ``solimp``; we use a constant impedance
(:data:`SOLIMP`, so the spring is linear) and, for a chosen ``timeconst``, find by bisection
the ``dampratio`` whose *converged* rebound (RK4 at the timesteps
``timeconst / CALIBRATION_STEPS_PER_TC`` and its half, extrapolated to zero: the contact's onset
and release between steps make the error first order) of the ball striking the floor at its
impact speed restitutes the scene's e:
``e_mj^2 = (v_z^2 + 2 g (z - r)) / v_in^2`` at separation (the apex height the ball would reach,
which is what e sets). Because the reference acceleration is mass-normalized, the same
``dampratio`` restitutes e at any effective mass.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

#: radius of the small spheres standing for point contacts (m); the floor is lowered by it
TIP_RADIUS = 1e-3
#: constant impedance (dmin = dmax): the soft contact is a linear damped spring
SOLIMP = (0.99, 0.99, 0.001, 0.5, 2.0)
#: calibration timestep = timeconst / this
CALIBRATION_STEPS_PER_TC = 1000
GRAVITY = 9.81
#: rollouts longer than this (s) are timed once
REPEAT_BELOW = 0.5
#: a calibration ball still touching after this many time constants did not rebound
SEPARATION_WITHIN_TC = 20


def mujoco_version() -> str | None:
    """The installed MuJoCo's version, or None when it is missing."""
    try:
        import mujoco
    except ImportError:
        return None
    return str(mujoco.__version__)


@dataclass(frozen=True)
class ContactSetting:
    """MuJoCo's contact parameters of one run.

    Attributes
    ----------
    timeconst, dampratio : ``solref``.
    timestep : ``option/timestep`` (s).
    integrator : ``"Euler"``, ``"RK4"`` or ``"implicitfast"``.
    """

    timeconst: float
    dampratio: float
    timestep: float
    integrator: str = "Euler"


def _solref(c: ContactSetting) -> str:
    return f'solref="{c.timeconst!r} {c.dampratio!r}" solimp="{" ".join(map(repr, SOLIMP))}"'


def _contact_attrs(c: ContactSetting, mu: float) -> str:
    fr = f'condim="3" friction="{mu!r} 0 0"' if mu > 0 else 'condim="1"'
    return f"{fr} {_solref(c)}"


def _header(c: ContactSetting) -> str:
    return (f'<mujoco><option timestep="{c.timestep!r}" gravity="0 0 {-GRAVITY!r}" '
            f'integrator="{c.integrator}" cone="elliptic"/><worldbody>')


def _floor(c: ContactSetting, mu: float, z: float) -> str:
    return f'<geom name="floor" type="plane" pos="0 0 {z!r}" size="0 0 1" {_contact_attrs(c, mu)}/>'


#: slide joints along x and z: our planar x, y
_SLIDES = ('<joint name="x" type="slide" axis="1 0 0"/>'
           '<joint name="y" type="slide" axis="0 0 1"/>')


def ball_mjcf(params, c: ContactSetting) -> str:
    """MJCF of the bouncing ball (``params``: the scene's parameters)."""
    m, r, mu = params["mass"], params["radius"], params["mu"]
    inertia = 0.4 * m * r ** 2
    return (_header(c) + _floor(c, mu, 0.0)
            + f'<body name="ball"><inertial pos="0 0 0" mass="{m!r}" '
              f'diaginertia="{inertia!r} {inertia!r} {inertia!r}"/>'
              + _SLIDES
              + f'<geom name="ball" type="sphere" size="{r!r}" {_contact_attrs(c, mu)}/>'
              '</body></worldbody></mujoco>')


def rod_mjcf(params, c: ContactSetting) -> str:
    """MJCF of the bouncing rod."""
    m, L, mu = params["mass"], params["length"], params["mu"]
    i_t = m * L ** 2 / 12.0
    ends = "".join(f'<geom name="{n}" type="sphere" size="{TIP_RADIUS!r}" pos="{s * L!r} 0 0" '
                   f'{_contact_attrs(c, mu)}/>' for n, s in (("end_a", -0.5), ("end_b", 0.5)))
    return (_header(c) + _floor(c, mu, -TIP_RADIUS)
            + f'<body name="rod"><inertial pos="0 0 0" mass="{m!r}" '
              f'diaginertia="{1e-3 * i_t!r} {i_t!r} {i_t!r}"/>'
              + _SLIDES
              + '<joint name="phi" type="hinge" axis="0 -1 0"/>'
              + ends + '</body></worldbody></mujoco>')


def pendulum_mjcf(params, c: ContactSetting) -> str:
    """MJCF of the planar double pendulum (case "drop")."""
    m, L, mu, floor_y = params["mass"], params["length"], params["mu"], params["floor_y"]
    i_t = m * L ** 2 / 12.0

    def rod(name: str, pos: float, inner: str) -> str:
        return (f'<body name="{name}" pos="{pos!r} 0 0"><inertial pos="{L / 2!r} 0 0" '
                f'mass="{m!r}" diaginertia="{1e-3 * i_t!r} {i_t!r} {i_t!r}"/>'
                f'<joint name="{name}_hinge" type="hinge" axis="0 -1 0"/>{inner}</body>')

    tip = (f'<geom name="tip" type="sphere" size="{TIP_RADIUS!r}" pos="{L!r} 0 0" '
           f'{_contact_attrs(c, mu)}/>')
    return (_header(c) + _floor(c, mu, floor_y - TIP_RADIUS)
            + rod("rod1", 0.0, rod("rod2", L, tip)) + '</worldbody></mujoco>')


#: scene label -> (scene name, scene parameters, MJCF builder)
SCENES = {
    "bouncing ball": ("bouncing_ball", {}, ball_mjcf),
    "bouncing rod": ("bouncing_rod", {}, rod_mjcf),
    "pendulum drop": ("pendulum_planar", {"case": "drop"}, pendulum_mjcf),
}


def build_model(label: str, scene, c: ContactSetting):
    """``(MjModel, MjData)`` of a scene at its initial state (``qpos = theta0``)."""
    import mujoco

    xml = SCENES[label][2](scene.parameters, c)
    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)
    data.qpos[:] = scene.theta0
    data.qvel[:] = scene.dtheta0
    mujoco.mj_forward(model, data)
    return model, data


@dataclass(frozen=True)
class MujocoRun:
    """One MuJoCo run: the state after every step and the wall time of the stepping.

    Attributes
    ----------
    time : (n,) time after each step.
    qpos, qvel : (n, nv) the state after each step (our theta, theta_dot).
    wall_time : seconds of ``mujoco.rollout.rollout`` (the stepping loop in C).
    setting : the contact setting.
    cpu_time : the process's CPU seconds of the same rollout.
    """

    time: np.ndarray
    qpos: np.ndarray
    qvel: np.ndarray
    wall_time: float
    setting: ContactSetting
    cpu_time: float = math.nan

    def state_at(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """``(theta, theta_dot)`` at the recorded step nearest to ``t``."""
        i = int(np.argmin(np.abs(self.time - t)))
        return self.qpos[i], self.qvel[i]


def simulate_mujoco(label: str, scene, t_end: float, c: ContactSetting,
                    repeat: int = 1) -> MujocoRun:
    """Roll the scene out from its initial state to ``t_end`` (best wall time of ``repeat``;
    a rollout longer than :data:`REPEAT_BELOW` seconds is not repeated).

    The number of steps is ``round(t_end / timestep)``; ``c.timestep`` should divide ``t_end``
    (see :func:`timestep_grid`).
    """
    import mujoco
    from mujoco import rollout

    model, data = build_model(label, scene, c)
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    s0 = np.empty(mujoco.mj_stateSize(model, spec))
    mujoco.mj_getState(model, data, s0, spec)
    n = int(round(t_end / c.timestep))
    best = cpu = math.inf
    states = None
    for _ in range(max(1, repeat)):
        t0, c0 = time.perf_counter(), time.process_time()
        states, _ = rollout.rollout(model, data, s0[None], nstep=n)
        best = min(best, time.perf_counter() - t0)
        cpu = min(cpu, time.process_time() - c0)
        if best > REPEAT_BELOW:
            break
    st = states[0]
    nq, nv = model.nq, model.nv
    return MujocoRun(time=st[:, 0].copy(), qpos=st[:, 1:1 + nq].copy(),
                     qvel=st[:, 1 + nq:1 + nq + nv].copy(), wall_time=best, setting=c,
                     cpu_time=cpu)


def timestep_grid(t_end: float, timeconst: float, ratios) -> list[float]:
    """Timesteps near ``timeconst / ratio`` that divide ``t_end`` exactly."""
    return [t_end / math.ceil(t_end * r / timeconst) for r in ratios]


def ball_rebound(timeconst: float, dampratio: float, e_height: float = 0.9,
                 radius: float = 0.1, integrator: str = "RK4",
                 steps_per_tc: int = CALIBRATION_STEPS_PER_TC) -> float:
    """MuJoCo's restitution of a ball striking the floor after falling ``e_height``.

    The ball starts touching (centre at ``radius``) at the impact speed
    ``v_in = sqrt(2 g e_height)`` and is stepped until the contact has separated; returns
    ``sqrt((v^2 + 2 g (z - r)) / v_in^2)`` at separation, or 0 when the ball has not left
    the floor within :data:`SEPARATION_WITHIN_TC` time constants (an overdamped contact).
    """
    import mujoco

    params = {"mass": 1.0, "radius": radius, "mu": 0.0}
    c = ContactSetting(timeconst, dampratio, timeconst / steps_per_tc, integrator)
    model = mujoco.MjModel.from_xml_string(ball_mjcf(params, c))
    data = mujoco.MjData(model)
    v_in = math.sqrt(2.0 * GRAVITY * e_height)
    data.qpos[:] = (0.0, radius)
    data.qvel[:] = (0.0, -v_in)
    for _ in range(SEPARATION_WITHIN_TC * steps_per_tc):
        mujoco.mj_step(model, data)
        z, vz = data.qpos[1], data.qvel[1]
        if vz > 0.0 and z > radius:
            return math.sqrt(max(vz ** 2 + 2.0 * GRAVITY * (z - radius), 0.0)) / v_in
    return 0.0


@dataclass(frozen=True)
class Calibration:
    """The ``dampratio`` whose converged rebound restitutes ``restitution``.

    Attributes
    ----------
    timeconst, dampratio : MuJoCo's ``solref``.
    restitution : the target e.
    restitution_reached : the converged (extrapolated) rebound's e at that ``dampratio``.
    convergence : its change when the calibration's steps are halved (its accuracy).
    timestep : the calibration's coarser timestep (extrapolated from it and its half).
    iterations : bisection steps.
    """

    timeconst: float
    dampratio: float
    restitution: float
    restitution_reached: float
    convergence: float
    timestep: float
    iterations: int


def converged_rebound(timeconst: float, dampratio: float,
                      steps_per_tc: int = CALIBRATION_STEPS_PER_TC) -> float:
    """:func:`ball_rebound` extrapolated to a zero timestep (Richardson, first order: the
    contact's onset and release fall between steps)."""
    coarse = ball_rebound(timeconst, dampratio, steps_per_tc=steps_per_tc)
    fine = ball_rebound(timeconst, dampratio, steps_per_tc=2 * steps_per_tc)
    return 2.0 * fine - coarse


def calibrate(timeconst: float, restitution: float, tol: float = 1e-7,
              bracket: tuple[float, float] = (0.01, 1.0)) -> Calibration:
    """Bisection on ``dampratio`` (the rebound falls as the damping grows) to ``tol``, on the
    extrapolated rebound (:func:`converged_rebound`)."""
    lo, hi = bracket
    f_lo = converged_rebound(timeconst, lo) - restitution
    f_hi = converged_rebound(timeconst, hi) - restitution
    if f_lo < 0 or f_hi > 0:
        raise ValueError(f"restitution {restitution} not bracketed by dampratio {bracket}: "
                         f"rebounds {f_lo + restitution:.4g}, {f_hi + restitution:.4g}")
    it = 0
    while hi - lo > tol * hi and it < 60:
        mid = 0.5 * (lo + hi)
        if converged_rebound(timeconst, mid) > restitution:
            lo = mid
        else:
            hi = mid
        it += 1
    zeta = 0.5 * (lo + hi)
    reached = converged_rebound(timeconst, zeta)
    finer = converged_rebound(timeconst, zeta, steps_per_tc=2 * CALIBRATION_STEPS_PER_TC)
    return Calibration(timeconst=timeconst, dampratio=zeta, restitution=restitution,
                       restitution_reached=reached, convergence=abs(finer - reached),
                       timestep=timeconst / CALIBRATION_STEPS_PER_TC, iterations=it)
