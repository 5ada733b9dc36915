"""Scenes of the ``moreau-scale`` bench section, ours and MuJoCo's (MJCF written in code).

* **box row** (:func:`box_row`, :func:`box_row_mjcf`): ``n`` equal boxes (half sizes
  0.2 x 0.15 x 0.1 m, 1 kg, uniform inertia; chosen) side by side on the floor z = 0, 1 m
  apart (they never touch), each on a free joint (ours: translations then Cardan X-Y-Z angles;
  MuJoCo: ``freejoint``), gravity -z. Ours: the four bottom corners of each box are point
  contacts with the floor (4 n contacts); MuJoCo: a ``box`` geom on a ``plane`` (its
  box-plane collision gives the same four corner contacts). mu = 0.3, e = 0 (MuJoCo's default
  soft contact, ``solref = (0.02, 1)``: it has no restitution parameter). Sliding: every box
  launched at 2 m/s along +x (Coulomb: it stops after 2 / (0.3 g) = 0.68 s, beyond the
  span); at rest: v = 0.
* **disc pile** (:func:`disc_pile_mjcf`): the scene ``disc_pile`` of ``problems/`` as MJCF:
  each disc a sphere of its radius on slide joints x, z and a hinge about y (our planar
  x, y, phi), mass and in-plane inertia ours, the floor and the two walls planes; MuJoCo
  collides every pair of spheres (ours: the scene's candidate pairs).

Both use MuJoCo's elliptic cone (``condim = 3``, the Coulomb cone) and the step h of the run.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from ..model import Joint, ModelBuilder

GRAVITY = 9.81
HALF = (0.2, 0.15, 0.1)
BOX_MASS = 1.0
MU = 0.3
SLIDE_SPEED = 2.0
SPACING = 1.0


def box_row(n: int, sliding: bool):
    """``(mechanism, theta0, dtheta0)`` of n boxes on the floor (see the module docstring)."""
    a, b, c = HALF
    m = BOX_MASS
    inertia = np.diag([m * (b * b + c * c) / 3, m * (a * a + c * c) / 3,
                       m * (a * a + b * b) / 3])
    builder = ModelBuilder(planar=False, gravity=(0.0, 0.0, -GRAVITY))
    for i in range(n):
        builder.add_body(f"box{i}", "ground", Joint.free(), m, (0.0, 0.0, 0.0), inertia,
                         joint_name=f"float{i}")
        for j, (sx, sy) in enumerate(((-1, -1), (1, -1), (1, 1), (-1, 1))):
            builder.add_contact(f"box{i}_corner{j}", body=f"box{i}", point=(sx * a, sy * b, -c),
                                normal=(0.0, 0.0, 1.0), e=0.0, mu=MU)
    mech = builder.build().mechanism()
    q = np.zeros(6 * n)
    v = np.zeros(6 * n)
    q[0::6] = SPACING * np.arange(n)
    q[2::6] = c
    if sliding:
        v[0::6] = SLIDE_SPEED
    return mech, q, v


def box_row_mjcf(n: int, h: float) -> str:
    """MJCF of the box row (initial velocities are set on the data)."""
    a, b, c = HALF
    geom = f'friction="{MU!r} 0 0" condim="3"'
    body = "".join(
        f'<body name="box{i}" pos="{SPACING * i!r} 0 {c!r}"><freejoint/>'
        f'<geom type="box" size="{a!r} {b!r} {c!r}" mass="{BOX_MASS!r}" {geom}/></body>'
        for i in range(n))
    return (f'<mujoco><option timestep="{h!r}" gravity="0 0 {-GRAVITY!r}" cone="elliptic">'
            f'<flag energy="enable"/></option><worldbody>'
            f'<geom type="plane" size="0 0 1" {geom}/>{body}</worldbody></mujoco>')


def disc_pile_mjcf(scene, h: float) -> str:
    """MJCF of the disc pile scene (our x, y are MuJoCo's x, z)."""
    p = scene.parameters
    radii, masses, mu = p["radii"], p["masses"], float(p["mu"])
    width = float(p["box_width"])
    th = np.asarray(scene.theta0, float)
    geom = f'friction="{mu!r} 0 0" condim="3"'
    walls = (f'<geom type="plane" size="0 0 1" {geom}/>'
             f'<geom type="plane" pos="0 0 0" zaxis="1 0 0" size="0 0 1" {geom}/>'
             f'<geom type="plane" pos="{width!r} 0 0" zaxis="-1 0 0" size="0 0 1" {geom}/>')
    bodies = []
    for i, (r, m) in enumerate(zip(radii, masses)):
        r, m = float(r), float(m)
        inertia = 0.5 * m * r * r
        bodies.append(
            f'<body name="disc{i}" pos="{float(th[3 * i])!r} 0 {float(th[3 * i + 1])!r}">'
            f'<inertial pos="0 0 0" mass="{m!r}" diaginertia="{inertia!r} {inertia!r} '
            f'{inertia!r}"/><joint type="slide" axis="1 0 0"/><joint type="slide" '
            f'axis="0 0 1"/><joint type="hinge" axis="0 -1 0"/>'
            f'<geom type="sphere" size="{r!r}" {geom}/></body>')
    return (f'<mujoco><option timestep="{h!r}" gravity="0 0 {-GRAVITY!r}" cone="elliptic">'
            f'<flag energy="enable"/></option><worldbody>{walls}{"".join(bodies)}'
            '</worldbody></mujoco>')


@dataclass(frozen=True)
class MujocoRun:
    """One MuJoCo rollout: wall time (s, stepping only), the largest penetration (m, from a
    second, sampled rollout), energies (T + V) at every step of that rollout, the largest
    number of contacts at one step, the final qpos and qvel."""

    wall: float
    max_penetration: float
    energy: np.ndarray
    max_contacts: int
    final_qpos: np.ndarray
    final_qvel: np.ndarray


def run_mujoco(xml: str, t_end: float, qvel0: np.ndarray | None = None) -> MujocoRun:
    """Step MuJoCo over [0, t_end]: once timed (stepping only), once sampled."""
    import mujoco

    model = mujoco.MjModel.from_xml_string(xml)
    steps = int(round(t_end / model.opt.timestep))

    def fresh():
        data = mujoco.MjData(model)
        if qvel0 is not None:
            data.qvel[:] = qvel0
        mujoco.mj_forward(model, data)
        return data

    data = fresh()
    t0 = time.perf_counter()
    for _ in range(steps):
        mujoco.mj_step(model, data)
    wall = time.perf_counter() - t0
    data = fresh()
    energy = [float(data.energy[0] + data.energy[1])]
    pen, most = 0.0, 0
    for _ in range(steps):
        mujoco.mj_step(model, data)
        nc = int(data.ncon)
        if nc:
            pen = max(pen, -float(np.min(data.contact.dist[:nc])))
        most = max(most, nc)
        energy.append(float(data.energy[0] + data.energy[1]))
    return MujocoRun(wall, max(pen, 0.0), np.array(energy), most, data.qpos.copy(),
                     data.qvel.copy())


def box_row_qvel(n: int, sliding: bool) -> np.ndarray:
    """MuJoCo's initial qvel of the box row (freejoint: linear, then angular velocity)."""
    v = np.zeros(6 * n)
    if sliding:
        v[0::6] = SLIDE_SPEED
    return v
