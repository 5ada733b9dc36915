"""MuJoCo runs of the many-contact event-driven scenes (``table``, ``box_stack``), for the
bench section ``sustained-scale`` (:mod:`convimpact.bench.sustained_scale_section`).

The same bodies as the scenes of ``problems/``, in MuJoCo's frame (z up; ours: y up), with
MuJoCo's default settings except what the scene fixes: ``timestep`` 2 ms (its default),
Euler, the default pyramidal cone and soft contact (``solref`` 0.02 1), ``condim`` 3 with the
scene's mu. The table's legs are spheres of radius :data:`FOOT_RADIUS` (a point foot has no
MuJoCo geom), their lowest points on the floor at the start; the stack's boxes are box geoms
(MuJoCo's box-box and box-plane collisions give the corner contacts), pushed through
``xfrc_applied`` at the top box's centre, set before each step.

Measured per run: the wall time of the stepping (``rollout`` in C for the table; a Python
loop of ``mj_step`` for the stack, whose push changes every step), the state after every
step, and from it (numpy, independent of MuJoCo's contact data) the deepest penetration of a
foot or box corner below its support and the energy T + V.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np

#: radius of the MuJoCo table's spherical feet (m)
FOOT_RADIUS = 0.005
#: MuJoCo's default timestep (s)
TIMESTEP = 0.002
GRAVITY = 9.81


@dataclass(frozen=True)
class PeerRun:
    """One MuJoCo run: states after each step and the stepping's wall time."""

    time: np.ndarray
    qpos: np.ndarray
    qvel: np.ndarray
    wall_time: float
    cpu_time: float = float("nan")  # the process's CPU time of the stepping


def _quat_matrix(q: np.ndarray) -> np.ndarray:
    """Rotation matrices (n, 3, 3) of unit quaternions (n, 4) (w, x, y, z)."""
    w, x, y, z = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
        np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
        np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1)],
        axis=1)


def table_mjcf(p: Mapping[str, Any]) -> str:
    """MJCF of the ``table`` scene (parameters ``p``): a free body, sphere feet, a floor."""
    m, mu, R, h, n = p["mass"], p["mu"], p["radius"], p["height"], p["legs"]
    feet = "".join(
        f'<geom type="sphere" size="{FOOT_RADIUS!r}" pos="{R * math.cos(a)!r} '
        f'{R * math.sin(a)!r} {-h + FOOT_RADIUS!r}" friction="{mu!r} 0.005 0.0001"/>'
        for a in 2 * np.pi * np.arange(n) / n + 0.3)
    return (f'<mujoco><option timestep="{TIMESTEP!r}" gravity="0 0 {-GRAVITY!r}"/><worldbody>'
            f'<geom type="plane" size="0 0 1" friction="{mu!r} 0.005 0.0001"/>'
            f'<body name="table" pos="0 0 {h!r}"><freejoint/>'
            f'<inertial pos="0 0 0" mass="{m!r}" diaginertia="{0.05 * m!r} {0.05 * m!r} '
            f'{0.08 * m!r}"/>{feet}</body></worldbody></mujoco>')


def stack_mjcf(p: Mapping[str, Any]) -> str:
    """MJCF of the ``box_stack`` scene: boxes w (x) by d (y) by h (z), stacked."""
    n, w, h, d, m, mu = (p[k] for k in ("n_boxes", "width", "height", "depth", "mass", "mu"))
    bodies = "".join(
        f'<body name="box{i}" pos="0 0 {(i + 0.5) * h!r}"><freejoint/>'
        f'<geom type="box" size="{w / 2!r} {d / 2!r} {h / 2!r}" mass="{m!r}" '
        f'friction="{mu!r} 0.005 0.0001"/></body>' for i in range(n))
    return (f'<mujoco><option timestep="{TIMESTEP!r}" gravity="0 0 {-GRAVITY!r}"/><worldbody>'
            f'<geom type="plane" size="0 0 1" friction="{mu!r} 0.005 0.0001"/>{bodies}'
            '</worldbody></mujoco>')


def run_table(p: Mapping[str, Any], t_end: float, repeat: int = 1) -> PeerRun:
    """The table launched at v0 (at ``direction_deg``) or at rest, rolled out in C
    (``repeat`` rollouts from the same state: the median wall time)."""
    import mujoco
    from mujoco import rollout

    model = mujoco.MjModel.from_xml_string(table_mjcf(p))
    data = mujoco.MjData(model)
    psi = math.radians(p["direction_deg"])
    data.qvel[:3] = p["v0"] * math.cos(psi), p["v0"] * math.sin(psi), 0.0
    mujoco.mj_forward(model, data)
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    s0 = np.empty(mujoco.mj_stateSize(model, spec))
    mujoco.mj_getState(model, data, s0, spec)
    nstep = int(round(t_end / TIMESTEP))
    rollout.rollout(model, data, s0[None], nstep=min(nstep, 10))  # warm-up
    walls, cpus = [], []
    for _ in range(max(1, repeat)):
        t0, c0 = time.perf_counter(), time.process_time()
        states, _ = rollout.rollout(model, data, s0[None], nstep=nstep)
        walls.append(time.perf_counter() - t0)
        cpus.append(time.process_time() - c0)
    st = states[0]
    return PeerRun(st[:, 0].copy(), st[:, 1:8].copy(), st[:, 8:14].copy(),
                   float(np.median(walls)), float(np.median(cpus)))


def run_stack(p: Mapping[str, Any], t_end: float, repeat: int = 1) -> PeerRun:
    """The box stack pushed at the top, stepped in a Python loop (the push changes); the
    median over ``repeat`` runs (at most 3) of the stepping's summed wall time."""
    runs = [_run_stack(p, t_end) for _ in range(max(1, min(repeat, 3)))]
    wall = float(np.median([r.wall_time for r in runs]))
    cpu = float(np.median([r.cpu_time for r in runs]))
    r = runs[-1]
    return PeerRun(r.time, r.qpos, r.qvel, wall, cpu)


def _run_stack(p: Mapping[str, Any], t_end: float) -> PeerRun:
    import mujoco

    model = mujoco.MjModel.from_xml_string(stack_mjcf(p))
    data = mujoco.MjData(model)
    n = p["n_boxes"]
    top = model.body(f"box{n - 1}").id
    nstep = int(round(t_end / TIMESTEP))

    def push(data):
        data.xfrc_applied[top, 0] = p["ramp"] * p["mass"] * GRAVITY * max(0.0, data.time
                                                                          - p["t_push"])
    return step_loop(model, data, nstep, push, record_start=False)


def step_loop(model, data, nstep: int, before_step, record_start: bool = True) -> PeerRun:
    """``nstep`` calls of ``mj_step`` in a Python loop, ``before_step(data)`` setting the
    applied forces before each; the states after each step (and the start's with
    ``record_start``), and the summed wall and CPU time of ``mj_step`` alone."""
    import mujoco

    times, qpos, qvel = [], [], []
    if record_start:
        times, qpos, qvel = [data.time], [data.qpos.copy()], [data.qvel.copy()]
    wall = cpu = 0.0
    for _ in range(nstep):
        before_step(data)
        t0, c0 = time.perf_counter(), time.process_time()
        mujoco.mj_step(model, data)
        wall += time.perf_counter() - t0
        cpu += time.process_time() - c0
        times.append(data.time)
        qpos.append(data.qpos.copy())
        qvel.append(data.qvel.copy())
    return PeerRun(np.array(times), np.array(qpos), np.array(qvel), wall, cpu)


def table_observables(p: Mapping[str, Any], run: PeerRun) -> dict[str, float]:
    """Stop time (speed first below 1e-3 v0), distance travelled, deepest foot penetration,
    largest |E - E(0)| over m g h (at rest) and the energy lost over 1/2 m v0^2 (sliding)."""
    m, h, R, n = p["mass"], p["height"], p["radius"], p["legs"]
    speed = np.linalg.norm(run.qvel[:, :2], axis=1)
    v0 = p["v0"]
    stop = (float(run.time[np.argmax(speed < 1e-3 * v0)]) if v0 > 0 and np.any(
        speed < 1e-3 * v0) else math.nan)
    rot = _quat_matrix(run.qpos[:, 3:7])
    a = 2 * np.pi * np.arange(n) / n + 0.3
    feet = np.stack([R * np.cos(a), R * np.sin(a), np.full(n, -h + FOOT_RADIUS)], axis=1)
    z = run.qpos[:, 2][:, None] + np.einsum("sj,fj->sf", rot[:, 2, :], feet)
    penetration = float(np.max(FOOT_RADIUS - z))
    inertia = m * np.array([0.05, 0.05, 0.08])
    T = 0.5 * m * np.sum(run.qvel[:, :3] ** 2, axis=1) + 0.5 * np.sum(
        inertia * run.qvel[:, 3:] ** 2, axis=1)
    E = T + m * GRAVITY * run.qpos[:, 2]
    E0 = 0.5 * m * v0 ** 2 + m * GRAVITY * h
    out = {"stop_time": stop,
           "distance": float(np.linalg.norm(run.qpos[-1, :2])),
           "penetration": penetration,
           "energy_drift": float(np.max(np.abs(E - E0))) / (m * GRAVITY * h)}
    if v0 > 0:
        out["energy_lost"] = float((E0 - E[-1]) / (0.5 * m * v0 ** 2))
    return out


def stack_observables(p: Mapping[str, Any], run: PeerRun) -> dict[str, float]:
    """Tip time (the lowest box's tilt first above :data:`TILT` rad) and the deepest corner
    penetration below the floor or the box below."""
    n, w, h, d = (p[k] for k in ("n_boxes", "width", "height", "depth"))
    corners = np.array([[sx * w / 2, sy * d / 2, -h / 2] for sx in (-1, 1) for sy in (-1, 1)])
    deepest = 0.0
    tilt = None
    for i in range(n):
        pos = run.qpos[:, 7 * i:7 * i + 3]
        rot = _quat_matrix(run.qpos[:, 7 * i + 3:7 * i + 7])
        if i == 0:
            tilt = np.arccos(np.clip(rot[:, 2, 2], -1.0, 1.0))
        pts = pos[:, None, :] + np.einsum("sij,cj->sci", rot, corners)
        if i == 0:
            depth = -pts[:, :, 2]
        else:  # below the top face of the box underneath, in its frame
            pb = run.qpos[:, 7 * (i - 1):7 * (i - 1) + 3]
            rb = _quat_matrix(run.qpos[:, 7 * (i - 1) + 3:7 * (i - 1) + 7])
            local = np.einsum("sji,scj->sci", rb, pts - pb[:, None, :])
            inside = (np.abs(local[:, :, 0]) <= w / 2) & (np.abs(local[:, :, 1]) <= d / 2)
            depth = np.where(inside, h / 2 - local[:, :, 2], 0.0)
        deepest = max(deepest, float(np.max(depth)))
    tipped = tilt > TILT
    return {"tip_time": float(run.time[np.argmax(tipped)]) if np.any(tipped) else math.nan,
            "penetration": deepest}


#: tilt of the lowest box (rad) taken as the stack's tipping, on both sides' trajectories
TILT = 1e-3
