"""The ``humanoid_push`` scene in MuJoCo, for the bench section ``sustained-scale``.

TALOS's legs (registry package ``example-robot-data``, loaded by Pinocchio, arms, torso and head
locked: :func:`convimpact.model.pinocchio_robots.talos_legs`) are written as MJCF from the
reduced Pinocchio model itself, so both simulators integrate the same 18 coordinates one to
one (MuJoCo's ``qpos``/``qvel`` are our ``theta``/``theta_dot``):

* the base is one body carrying six joints in the order of our root chain: slides along the
  world's x, y, z, then hinges about z (yaw), the turned y (pitch), the twice-turned x (roll)
  (MuJoCo composes a body's joints in order, each in the frame the previous ones turned);
* each leg joint is a body at Pinocchio's joint placement, a hinge about its axis, with the
  joint's inertia (mass, centre of mass, rotational inertia about it) from the reduced model;
* each sole is a box geom of the URDF's foot (0.21 x 0.13 m) whose bottom face is the sole
  frame's z = 0 (MuJoCo's box-plane collision gives its four corner contacts; ours are
  those four corners as points), condim 3 with the scene's mu, MuJoCo's default soft contact;
* the PD control is MuJoCo's own joint stiffness kp (``springref`` the reference posture) and
  damping kd (integrated implicitly by its Euler scheme); the gravity feedforward and the push
  are generalized forces in ``qfrc_applied``, read from our mechanism's applied forces
  (``generalized_forces`` of the scene minus those of the bare robot), so nothing is restated.

The MJCF's kinematics is checked against ours (:func:`max_point_mismatch`: the sole corners at
perturbed postures). Observables are computed with our model on MuJoCo's states, independent
of MuJoCo's contact data: the sole corners' penetration (``contact_gap``), the base's sideways
displacement and roll, and the energy T + V (gravity and the PD springs) before the push.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from .sustained_scale_peers import PeerRun, step_loop

#: MuJoCo's default timestep (s)
TIMESTEP = 0.002
#: the soles' box half height (m): only its bottom face touches the floor
SOLE_HALF_HEIGHT = 0.01
_AXES = {"X": "1 0 0", "Y": "0 1 0", "Z": "0 0 1"}


def _quat(R: np.ndarray) -> str:
    """MuJoCo's (w, x, y, z) of a rotation matrix (its own conversion)."""
    import mujoco

    q = np.empty(4)
    mujoco.mju_mat2Quat(q, np.ascontiguousarray(R, dtype=float).ravel())
    return " ".join(repr(float(v)) for v in q)


def _vec(v) -> str:
    return " ".join(repr(float(x)) for x in v)


def _inertial(inertia) -> str:
    I = np.asarray(inertia.inertia)
    return (f'<inertial pos="{_vec(inertia.lever)}" mass="{float(inertia.mass)!r}" '
            f'fullinertia="{_vec([I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2]])}"/>')


def _joint(model, j: int, q_ref: np.ndarray, kp: float, kd: float) -> str:
    kind = model.joints[j].shortname()
    if kind not in ("JointModelRX", "JointModelRY", "JointModelRZ"):
        raise ValueError(f"joint {model.names[j]} is a {kind}: the writer handles RX/RY/RZ legs")
    return (f'<joint name="{model.names[j]}" type="hinge" axis="{_AXES[kind[-1]]}" '
            f'stiffness="{kp!r}" springref="{float(q_ref[model.idx_qs[j]])!r}" '
            f'damping="{kd!r}"/>')


def talos_mjcf(scene) -> str:
    """MJCF of the ``humanoid_push`` scene (see the module docstring)."""
    mech = scene.mechanism
    model = mech.model
    p = scene.parameters
    kp, kd, mu = p["kp"], p["kd"], p["mu"]
    q_ref = np.asarray(scene.theta0, float)
    root = ("base_x", "base_y", "base_z", "base_yaw", "base_pitch", "base_roll")
    if tuple(model.names[1:7]) != root:
        raise ValueError("the writer expects the free root chain base_x ... base_roll")
    for j in range(1, 7):
        if np.linalg.norm(model.jointPlacements[j].translation) > 0 or j < 6 and \
                model.inertias[j].mass != 0:
            raise ValueError("the root chain's joints must be massless and coincident")
    children: dict[int, list[int]] = {}
    for j in range(7, model.njoints):
        children.setdefault(int(model.parents[j]), []).append(j)
    soles = {int(f.parentJoint): f for f in model.frames if f.name.endswith("_sole_link")}
    from ..model.pinocchio_robots import TALOS_SOLE

    def geoms(j: int) -> str:
        if j not in soles:
            return ""
        f = soles[j].placement
        centre = f.translation + f.rotation @ np.array([0.0, 0.0, SOLE_HALF_HEIGHT])
        return (f'<geom name="{soles[j].name}" type="box" pos="{_vec(centre)}" '
                f'quat="{_quat(f.rotation)}" size="{TALOS_SOLE[0]!r} {TALOS_SOLE[1]!r} '
                f'{SOLE_HALF_HEIGHT!r}" friction="{mu!r} 0.005 0.0001" condim="3" '
                'mass="0"/>')

    def body(j: int) -> str:
        M = model.jointPlacements[j]
        inner = "".join(body(c) for c in children.get(j, []))
        return (f'<body name="{model.names[j]}_body" pos="{_vec(M.translation)}" '
                f'quat="{_quat(M.rotation)}">{_joint(model, j, q_ref, kp, kd)}'
                f'{_inertial(model.inertias[j])}{geoms(j)}{inner}</body>')

    base = "".join(
        f'<joint name="{n}" type="{"slide" if k < 3 else "hinge"}" '
        f'axis="{_AXES["XYZZYX"[k]]}"/>' for k, n in enumerate(root))
    legs = "".join(body(c) for c in children.get(6, []))
    g = -float(np.linalg.norm(model.gravity.linear))
    return (f'<mujoco><compiler angle="radian"/>'
            f'<option timestep="{TIMESTEP!r}" gravity="0 0 {g!r}"/>'
            '<worldbody><geom name="floor" type="plane" size="0 0 1" '
            f'friction="{mu!r} 0.005 0.0001"/>'
            f'<body name="base">{base}{_inertial(model.inertias[6])}{legs}</body>'
            '</worldbody></mujoco>')


def applied_forces(scene) -> tuple[np.ndarray, np.ndarray]:
    """``(feedforward, push)``: the scene's generalized forces at the reference posture at
    rest, before and during the push, minus those of the bare robot (gravity alone)."""
    from ..model.pinocchio_robots import talos_legs

    p = scene.parameters
    bare, _ = talos_legs(mu=p["mu"], e=p["e"])
    q = np.asarray(scene.theta0, float)
    v = np.zeros_like(q)
    gravity = np.asarray(bare.generalized_forces(0.0, q, v), float)
    before = np.asarray(scene.mechanism.generalized_forces(0.0, q, v), float) - gravity
    during = np.asarray(scene.mechanism.generalized_forces(
        p["t_push"] + 0.5 * p["duration"], q, v), float) - gravity
    # the feedforward holds the legs (zero on the base); what the push adds is the rest
    return before, during - before


def _model(scene):
    import mujoco

    return mujoco.MjModel.from_xml_string(talos_mjcf(scene))


def max_point_mismatch(scene, samples: int = 5, seed: int = 0) -> float:
    """Largest distance (m) between a sole corner placed by MuJoCo and by our model at the
    reference posture and at ``samples`` postures perturbed by up to 0.3 rad / 0.1 m."""
    import mujoco

    model = _model(scene)
    data = mujoco.MjData(model)
    mech = scene.mechanism
    rng = np.random.default_rng(seed)
    from ..model.pinocchio_robots import TALOS_SOLE

    corners = np.array([[sx * TALOS_SOLE[0], sy * TALOS_SOLE[1], -SOLE_HALF_HEIGHT]
                        for sx, sy in ((-1, -1), (-1, 1), (1, -1), (1, 1))])
    worst = 0.0
    for k in range(samples + 1):
        q = np.asarray(scene.theta0, float) + (0 if k == 0 else rng.uniform(-0.3, 0.3, model.nq))
        data.qpos[:] = q
        mujoco.mj_kinematics(model, data)
        for side in ("left", "right"):
            g = model.geom(f"{side}_sole_link").id
            pts = data.geom_xpos[g] + corners @ data.geom_xmat[g].reshape(3, 3).T
            ours = np.array([mech.contact_point(f"{side}_sole_{i}", q) for i in range(4)])
            worst = max(worst, float(np.max(np.linalg.norm(pts - ours, axis=1))))
    return worst


def run_push(scene, repeat: int = 1) -> PeerRun:
    """The scene in MuJoCo from its initial state to ``t_end``, stepped in a Python loop
    (the push switches on and off); the medians over ``repeat`` runs (at most 3) of the
    wall and CPU time of ``mj_step`` alone."""
    runs = [_run_push(scene) for _ in range(max(1, min(repeat, 3)))]
    r = runs[-1]
    return PeerRun(r.time, r.qpos, r.qvel, float(np.median([x.wall_time for x in runs])),
                   float(np.median([x.cpu_time for x in runs])))


def _run_push(scene) -> PeerRun:
    import mujoco

    model = _model(scene)
    data = mujoco.MjData(model)
    data.qpos[:] = scene.theta0
    data.qvel[:] = scene.dtheta0
    feedforward, push = applied_forces(scene)
    p = scene.parameters
    nstep = int(round(scene.t_end / TIMESTEP))

    def forces(data):
        on = p["t_push"] <= data.time <= p["t_push"] + p["duration"]
        data.qfrc_applied[:] = feedforward + (push if on else 0.0)
    return step_loop(model, data, nstep, forces)


def observables(scene, t: np.ndarray, theta: np.ndarray, dtheta: np.ndarray
                ) -> dict[str, Any]:
    """What both runs are compared on, computed with our model on either's states: deepest
    sole corner below the floor, the base's sideways displacement at the end and largest
    roll, the energy T + V's largest rise and its loss before the push (nothing does work then: the
    PD's dampers and the contacts only dissipate, so it may only fall), the soles' slip."""
    mech = scene.mechanism
    p = scene.parameters
    names = list(mech.contact_names)
    iy, iroll = (mech.coordinate_index(n) for n in ("base_y", "base_roll"))
    gaps = np.array([[mech.contact_gap(c, th) for c in names] for th in theta])
    before = t < p["t_push"]
    E = np.array([mech.kinetic_energy(th, dth) + mech.potential_energy(th)
                  for th, dth in zip(theta[before], dtheta[before])])
    corners0 = np.array([mech.contact_point(c, theta[0]) for c in names])
    corners1 = np.array([mech.contact_point(c, theta[-1]) for c in names])
    return {"penetration": float(max(0.0, -gaps.min())),
            "base_y_end": float(theta[-1, iy]),
            "max_roll": float(np.max(np.abs(theta[:, iroll]))),
            "energy_rise_before_push": float(E.max() - E[0]) if E.size else 0.0,
            "energy_loss_before_push": float(E[0] - E[-1]) if E.size else 0.0,
            "sole_slip": float(np.max(np.linalg.norm((corners1 - corners0)[:, :2], axis=1)))}


def humanoid_records(repeat: int = 1) -> list[dict[str, Any]]:
    """Ours (event-driven, one run timed after an untimed one: seconds) and MuJoCo
    (:func:`run_push`) on the default ``humanoid_push``: wall and CPU time per simulated second
    and :func:`observables`."""
    from ..scenes import load_scene
    from ..simulation import simulate

    scene = load_scene("humanoid_push")
    # untimed first: it compiles what only this scene reaches (with a cold cache the timed run
    # was 1,085x MuJoCo's time, 531x after it)
    simulate(scene.mechanism, (0.0, scene.t_end), (scene.theta0, scene.dtheta0))
    t0, c0 = time.perf_counter(), time.process_time()
    res = simulate(scene.mechanism, (0.0, scene.t_end), (scene.theta0, scene.dtheta0))
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    ours = {"part": "simulation", "scene": "humanoid_push", "contacts": 8,
            "scheme": "event-driven", "status": res.status, "impacts": len(res.impacts),
            "wall_per_second": wall / scene.t_end, "cpu_per_second": cpu / scene.t_end,
            **observables(scene, np.asarray(res.t), np.asarray(res.theta),
                          np.asarray(res.dtheta))}
    run = run_push(scene, repeat)
    mj = {"part": "simulation", "scene": "humanoid_push", "contacts": 8, "scheme": "mujoco",
          "wall_per_second": run.wall_time / scene.t_end,
          "cpu_per_second": run.cpu_time / scene.t_end,
          "kinematics_mismatch": max_point_mismatch(scene),
          **observables(scene, run.time, run.qpos, run.qvel)}
    return [ours, mj]
