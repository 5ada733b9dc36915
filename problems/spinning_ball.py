"""A ball launched sliding on the floor: friction turns the slip into rolling.

A uniform solid sphere (radius 0.1 m, mass 1 kg, I = 2/5 m r^2; chosen) resting on the floor
y = 0 (y is vertical), e = 0, mu = 0.2, launched with its centre at v0 = 2 m/s and the spin
omega0 (default 0: a pure sliding start). Placed with :func:`convimpact.model.place_resting`
(gap exactly 0); its initial normal velocity is 0.

Planar (``spatial=False``): a free planar joint, theta = (x, y, phi), the centre's position
and the rotation angle (counter-clockwise positive); a disc of radius r (the contact point at
the centre, ``radius=r``) against the floor, n = +y, t = -x. The launch is dtheta0 =
(v0, 0, omega0): v0 along +x, omega0 = phi_dot. The slip of the bottom point along +x is
s = x_dot + r phi_dot (the contact's tangential velocity is Jc[1] theta_dot = -s); rolling
forward (+x) has phi_dot = -x_dot / r, so omega0 > 0 is BACKSPIN when v0 > 0.

Spatial (``spatial=True``): a free 3-D joint, theta = (x, y, z, rx, ry, rz), the centre and
body-fixed X-Y-Z Cardan angles (their rates are not the angular velocity: dtheta0 is solved
from the wanted velocity and angular velocity through B); the sphere against the floor
(n = +y, t1 = +x, t2 = -z). The launch velocity is v0 (cos d, 0, sin d), d =
``direction_deg`` (from +x toward +z); the spin vector is omega0 (cos b, 0, sin b) about the
horizontal axis at b = ``spin_axis_deg`` (default d + 90 degrees, the axis for which
omega0 > 0 is backspin, as in the planar case). With d = 30 the slip is not along any
coordinate or contact axis. A three-angle set is singular where its middle angle is +-90
degrees (M is then singular), so the initial Cardan angles are chosen, from the closed-form
angular velocity (below), to keep the middle angle farthest from +-90 degrees over the whole
motion (slip and rolling): the body z axis along the rolling axis when that works (the middle
angle is then constant while rolling), else vertical, else the best of a grid; the bound is
``parameters["max_middle_cardan_angle_deg"]`` (30 degrees for the defaults).

Closed forms (Coulomb friction at the contact; gravity and the normal force through the
centre): the friction -mu m g s/|s| changes the slip at s_dot = F/m + r^2 F / I
= 3.5 F / m, so the slip keeps its direction and its magnitude decays at 3.5 mu g; the ball
rolls after t_roll = |s0| / (3.5 mu g), with v_f = v0 - s0 / 3.5 (vectors). Planar: s0 =
v0 + r omega0 and the final speed is x_dot_f = (5 v0 - 2 r omega0) / 7 (angular momentum
about the contact point, I phi_dot - m r x_dot, is conserved); afterwards it rolls at
constant speed (no rolling resistance).

Parameters of :func:`make_scene`: v0 (2 m/s), omega0 (0 rad/s), radius (0.1 m), mass
(1 kg), mu (0.2), e (0), spatial (False), direction_deg (30, spatial only), spin_axis_deg
(None = direction_deg + 90, spatial only), t_end (2 s).
"""

from __future__ import annotations

from types import MappingProxyType
from typing import Optional

import numpy as np

from convimpact.model import Joint, ModelBuilder, place_resting, rest_velocity
from convimpact.scenes import Scene
from convimpact.validation import Flag, NonNegative, OrNone, Positive, Real, Unit


#: the parameters of :func:`make_scene` and their ranges, checked by ``load_scene`` before
#: the scene is built (an error names the parameter)
PARAMETERS = {"v0": Real(), "omega0": Real(), "radius": Positive(), "mass": Positive(),
              "mu": NonNegative(), "e": Unit(), "spatial": Flag(), "direction_deg": Real(),
              "spin_axis_deg": OrNone(Real()), "t_end": Positive()}


G = 9.81


def _planar(v0, omega0, radius, mass, mu, e):
    b = ModelBuilder(planar=True)
    b.add_body("ball", "ground", Joint.free(), mass, (0.0, 0.0), 0.4 * mass * radius ** 2,
               joint_name="float", coordinate_names=["x", "y", "phi"])
    b.add_contact("floor", body="ball", point=(0.0, 0.0), radius=radius, normal=(0.0, 1.0),
                  e=e, mu=mu)
    mech = b.build().mechanism()
    theta0 = place_resting(mech, np.array([0.0, 2.0 * radius, 0.0]), ["floor"],
                           fixed=["x", "phi"])
    dtheta0 = rest_velocity(mech, theta0, np.array([v0, 0.0, omega0]), ["floor"])
    s0 = v0 + radius * omega0
    closed = dict(slip0=s0, roll_time=abs(s0) / (3.5 * mu * G) if mu > 0 else None,
                  final_speed=(5.0 * v0 - 2.0 * radius * omega0) / 7.0,
                  final_omega=-(5.0 * v0 - 2.0 * radius * omega0) / (7.0 * radius))
    return mech, theta0, dtheta0, closed


def _rodrigues(w: np.ndarray, h: float) -> np.ndarray:
    """exp(h [w]x): the rotation by the angle h |w| about w."""
    ang = h * float(np.linalg.norm(w))
    if ang == 0.0:
        return np.eye(3)
    k = w / np.linalg.norm(w)
    K = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.eye(3) + np.sin(ang) * K + (1.0 - np.cos(ang)) * K @ K


def _initial_angles(w0: np.ndarray, wf: np.ndarray, t_roll: float) -> tuple[np.ndarray, float]:
    """Initial Cardan angles keeping the middle one farthest from +-90 degrees; its bound.

    The world angular velocity is w0 -> wf linearly over the slip phase, then wf. With
    R(t) = Q(t) R0 (Q' = [w]x Q, Q(0) = I) the middle X-Y-Z angle is b(t) = asin(q(t) . z0)
    with q = Q^T e_x and z0 = R0 e_z, so z0 is chosen far from the curve +-q(t), sampled over
    the slip phase and one turn of the rolling (after which q(t) repeats). Candidates: the
    rolling axis, the vertical, and a spiral grid of the sphere.
    """
    ex = np.array([1.0, 0.0, 0.0])
    qs, Q = [ex], np.eye(3)
    n_slip = 400
    for i in range(n_slip if t_roll > 0 else 0):
        h = t_roll / n_slip
        Q = _rodrigues(w0 + (wf - w0) * (i + 0.5) / n_slip, h) @ Q
        qs.append(Q.T @ ex)
    speed = float(np.linalg.norm(wf))
    if speed > 0:
        for psi in np.linspace(0.0, 2 * np.pi, 181):
            qs.append((_rodrigues(wf, psi / speed) @ Q).T @ ex)
    qs = np.array(qs)
    axis = next((a for a in (wf, w0) if np.linalg.norm(a) > 1e-12), np.array([0, 0, 1.0]))
    axis = -axis if (axis[2], axis[0]) < (0.0, 0.0) else axis  # z >= 0: gentler angles
    j = np.arange(600) + 0.5
    polar, azim = np.arccos(1 - 2 * j / 600), np.pi * (1 + 5 ** 0.5) * j
    grid = np.stack([np.sin(polar) * np.cos(azim), np.sin(polar) * np.sin(azim),
                     np.cos(polar)], axis=1)
    cands = np.vstack([axis / np.linalg.norm(axis), [[0.0, 1.0, 0.0]], grid])
    worst = np.max(np.abs(cands @ qs.T), axis=1)
    best = int(np.argmin(worst))
    if worst[0] <= worst[best] + 1e-3:  # prefer the rolling axis, then the vertical
        best = 0
    elif worst[1] <= worst[best] + 1e-3:
        best = 1
    z0 = cands[best]
    # Rx(a) Ry(b) e_z = (sin b, -cos b sin a, cos b cos a) = z0
    angles = np.array([np.arctan2(-z0[1], z0[2]), np.arcsin(np.clip(z0[0], -1, 1)), 0.0])
    return angles, float(np.degrees(np.arcsin(min(1.0, worst[best]))))


def _spatial(v0, omega0, radius, mass, mu, e, direction_deg, spin_axis_deg):
    d = np.radians(direction_deg)
    bdir = np.radians(direction_deg + 90.0 if spin_axis_deg is None else spin_axis_deg)
    v = v0 * np.array([np.cos(d), 0.0, np.sin(d)])
    w = omega0 * np.array([np.cos(bdir), 0.0, np.sin(bdir)])
    up = np.array([0.0, 1.0, 0.0])
    s0 = v + radius * np.cross(up, w)  # bottom-point velocity v + w x (-r up)
    vf = v - s0 / 3.5
    wf = np.cross(up, vf) / radius
    b = ModelBuilder(planar=False)
    b.add_body("ball", "ground", Joint.free(), mass, (0.0, 0.0, 0.0),
               [0.4 * mass * radius ** 2] * 3, joint_name="float",
               coordinate_names=["x", "y", "z", "rx", "ry", "rz"])
    b.add_contact("floor", body="ball", point=(0.0, 0.0, 0.0), radius=radius,
                  normal=(0.0, 1.0, 0.0), e=e, mu=mu)
    mech = b.build().mechanism()
    slip = float(np.linalg.norm(s0))
    t_roll = slip / (3.5 * mu * G) if mu > 0 else 0.0
    angles, max_middle = _initial_angles(w, wf if mu > 0 else w, t_roll)
    guess = np.concatenate([[0.0, 2.0 * radius, 0.0], angles])
    fixed = ["x", "z", "rx", "ry", "rz"]
    theta0 = place_resting(mech, guess, ["floor"], fixed=fixed)
    B = mech.velocity_transformation(theta0)  # rows: centre velocity, angular velocity
    dtheta0 = rest_velocity(mech, theta0, np.linalg.solve(B, np.concatenate([v, w])),
                            ["floor"])
    closed = dict(
        launch_velocity=v.tolist(), spin_vector=w.tolist(), slip0=s0.tolist(),
        slip_direction=(s0 / slip).tolist() if slip > 0 else None,
        roll_time=slip / (3.5 * mu * G) if mu > 0 else None,
        final_velocity=vf.tolist(), final_speed=float(np.linalg.norm(vf)),
        final_omega=wf.tolist(), initial_angles=angles.tolist(),
        max_middle_cardan_angle_deg=max_middle)
    return mech, theta0, dtheta0, closed


def make_scene(v0: float = 2.0, omega0: float = 0.0, radius: float = 0.1, mass: float = 1.0,
               mu: float = 0.2, e: float = 0.0, spatial: bool = False,
               direction_deg: float = 30.0, spin_axis_deg: Optional[float] = None,
               t_end: float = 2.0) -> Scene:
    """The sliding-then-rolling ball (see the module docstring)."""
    if spatial:
        mech, theta0, dtheta0, closed = _spatial(v0, omega0, radius, mass, mu, e,
                                                 direction_deg, spin_axis_deg)
        kind = (f"spatial (free 3-D joint, Cardan angles; launch direction {direction_deg} deg "
                "from +x toward +z in the floor plane)")
    else:
        mech, theta0, dtheta0, closed = _planar(v0, omega0, radius, mass, mu, e)
        kind = "planar (free planar joint x, y, phi; omega0 = phi_dot, > 0 is backspin)"
    description = (
        f"A uniform solid ball (r = {radius} m, m = {mass} kg, I = 2/5 m r^2; chosen), {kind}, "
        f"resting on the floor y = 0 (e = {e}, mu = {mu}; placed with place_resting) and "
        f"launched sliding at {v0} m/s with spin {omega0} rad/s. Assumed: Coulomb friction at "
        "the contact, no rolling resistance. The slip keeps its direction and decays at "
        "3.5 mu g; the ball rolls after |s0|/(3.5 mu g) and then keeps its speed, "
        "(5 v0 - 2 r omega0)/7 in the planar case."
    )
    params = dict(v0=v0, omega0=omega0, radius=radius, mass=mass, inertia=0.4 * mass * radius ** 2,
                  mu=mu, e=e, spatial=bool(spatial), gravity=G, slip_decay_rate=3.5 * mu * G,
                  **closed,
                  assumptions=["ball dimensions and mass chosen", "uniform solid sphere",
                               "Coulomb friction, no rolling resistance"])
    if spatial:
        params.update(direction_deg=direction_deg,
                      spin_axis_deg=(direction_deg + 90.0 if spin_axis_deg is None
                                     else spin_axis_deg))
    return Scene(name="spinning_ball", description=description, mechanism=mech, theta0=theta0,
                 dtheta0=dtheta0, t_end=t_end, parameters=MappingProxyType(params))
