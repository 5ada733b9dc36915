"""Solo-12 quadruped (registry package ``example-robot-data``) dropped onto the floor.

The robot's URDF is loaded by Pinocchio (:func:`convimpact.model.pinocchio_robots.solo12`:
18 coordinates, a free base as x, y, z and Z-Y-X Euler angles, four point feet against the
floor z = 0 with Coulomb friction). Its twelve joints are held by PD controllers around the
SRDF's "standing" posture, tau = -kp (q - q_ref) - kd q_dot; the springs' energy
1/2 kp |q - q_ref|^2 is part of the potential energy, so the total energy T + V can only fall
(dampers, plastic impacts). The robot starts in that posture, its feet ``height`` above the
floor, tilted by (yaw, pitch, roll) = ``tilt`` so the feet strike one after the other; each
foot strikes plastically (e = 0) and then sticks or slips (mu) while the others land.

Needs the optional packages ``pin`` (Pinocchio) and ``example-robot-data``; nothing is
downloaded (their absence raises a typed error naming the package to install).
:func:`figure` draws the run (heights, contact forces and modes, energy, side views).
"""

from __future__ import annotations

from pathlib import Path
from types import MappingProxyType
from typing import Sequence

import numpy as np

from convimpact.scenes import Scene
from convimpact.validation import NonNegative, Positive, Unit, Vector


#: the parameters of :func:`make_scene` and their ranges, checked by ``load_scene`` before
#: the scene is built (an error names the parameter)
PARAMETERS = {"height": Positive(), "tilt": Vector(3), "mu": NonNegative(), "e": Unit(),
              "kp": NonNegative(), "kd": NonNegative(), "t_end": Positive()}


LEGS = ("FL", "FR", "HL", "HR")


def make_scene(height: float = 0.1, tilt: Sequence[float] = (0.1, 0.05, 0.08), mu: float = 0.8,
               e: float = 0.0, kp: float = 3.0, kd: float = 0.2, t_end: float = 0.6) -> Scene:
    """Solo-12 dropped from ``height`` (m, lowest foot above the floor) with base attitude
    ``tilt`` (yaw, pitch, roll, rad), foot friction ``mu`` and restitution ``e``, joint PD
    gains ``kp`` (N m/rad) and ``kd`` (N m s/rad) around the standing posture."""
    from convimpact.errors import ParameterError
    from convimpact.model.pinocchio_robots import SOLO12_FEET, solo12, solo12_standing

    tilt = np.asarray(tilt, dtype=float)
    if tilt.shape != (3,) or np.abs(tilt[1]) >= 1.2:
        raise ParameterError("tilt must be (yaw, pitch, roll) with |pitch| < 1.2 rad (the Euler "
                             f"angles are singular at pitch = +-pi/2), got {tilt.tolist()}")
    reference = solo12_standing(solo12(), 0.0)
    joints = np.arange(6, 18)
    ref = reference[joints]

    def pd(t, q, v):
        tau = np.zeros(18)
        tau[joints] = -kp * (q[joints] - ref) - kd * v[joints]
        return tau

    def spring(q):
        return 0.5 * kp * float(np.sum((q[joints] - ref) ** 2))

    mech = solo12(mu=mu, e=e, applied_forces=pd, applied_potential=spring)
    theta0 = reference.copy()
    theta0[3:6] = tilt
    theta0[2] += height - min(mech.contact_gap(f, theta0) for f in SOLO12_FEET)
    description = (
        "Solo-12 quadruped of the registry package example-robot-data (URDF loaded by "
        "Pinocchio, 2.5 kg, 12 joints) with a free base (x, y, z, yaw, pitch, roll), dropped "
        f"with its lowest foot {height} m above the floor, tilted by (yaw, pitch, roll) = "
        f"{tilt.round(3).tolist()} rad; joints held by PD control (kp = {kp} N m/rad, "
        f"kd = {kd} N m s/rad) around the SRDF standing posture, whose spring energy counts as "
        f"potential energy. Point feet at the foot frames, e = {e}, mu = {mu}, floor z = 0, "
        "gravity 9.81 m/s^2 along -z.")
    params = dict(height=height, tilt=tilt.tolist(), mu=mu, e=e, kp=kp, kd=kd,
                  robot="solo_description/robots/solo12.urdf (example-robot-data)",
                  coordinates=list(mech.coordinate_names),
                  assumptions=["point feet at the foot frames' origins (the URDF's foot collision "
                               "is a mesh)", "PD control around the SRDF 'standing' posture",
                               "Euler-angle base (singular at pitch = +-pi/2)"])
    return Scene(name="robot_drop", description=description, mechanism=mech, theta0=theta0,
                 dtheta0=np.zeros(18), t_end=t_end, parameters=MappingProxyType(params))


def _leg_points(mech, theta) -> dict[str, np.ndarray]:
    """World positions of each leg's HAA, HFE, KFE and foot frames, and the base's corners."""
    out = {}
    for leg in LEGS:
        out[leg] = np.array([mech.frame_placement(f"{leg}_{j}", theta)[1]
                             for j in ("HAA", "HFE", "KFE", "FOOT")])
    return out


def figure(result, mechanism, path: Path) -> Path:
    """Heights, feet's normal forces and modes, energy and side views of a run (PNG)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from convimpact.bench.charts import save_chart

    from convimpact.simulation.result import MODE_NAMES

    t = result.t
    k = mechanism.n_coordinates
    if result.sol is not None:  # the dense output on a fine grid (steps are long)
        tt = np.linspace(t[0], t[-1], 600)
        th_d = np.array([result.sol(ti)[:k] for ti in tt])
        # velocities by central differences of the interpolant (p = M theta_dot - C^T sigma
        # while contacts are held, so p alone does not give them)
        h = 1e-7 * float(t[-1] - t[0])
        lo, hi = np.maximum(tt - h, t[0]), np.minimum(tt + h, t[-1])
        dth_d = np.array([(result.sol(b)[:k] - result.sol(a)[:k]) / (b - a)
                          for a, b in zip(lo, hi)])
    else:
        tt, th_d, dth_d = t, result.theta, result.dtheta
    T_d = np.array([mechanism.kinetic_energy(a, b) for a, b in zip(th_d, dth_d)])
    E_d = T_d + np.array([mechanism.potential_energy(a) for a in th_d])
    feet = [f"{leg}_FOOT" for leg in LEGS]
    fig, axes = plt.subplots(2, 2, figsize=(13, 8.5))
    ax = axes[0, 0]
    ax.plot(tt, th_d[:, 2], color="black", lw=1.8, label="base z")
    for i, f in enumerate(feet):
        ax.plot(tt, [mechanism.contact_gap(f, th) for th in th_d], color=f"C{i}", label=f)
    for ev in result.impacts:
        ax.axvline(ev.time, color="gray", lw=0.6, ls=":")
    ax.set_ylabel("height above the floor [m]")
    ax.set_title("base and feet heights (dotted: impacts)")
    ax.legend(fontsize=8, ncol=2)
    ax = axes[0, 1]
    for i, f in enumerate(feet):
        j = list(result.contact_names).index(f)
        ax.plot(t, result.contact_force[:, j, 0], color=f"C{i}", label=f"{f} normal")
        tang = np.linalg.norm(result.contact_force[:, j, 1:], axis=1)
        ax.plot(t, tang, color=f"C{i}", ls="--", lw=0.9)
    ax.set_ylabel("contact force [N] (solid: normal, dashed: |tangential|)")
    ax.set_title("sustained contact forces (weight 24.5 N); dots: modes of FL, FR, HL, HR\n"
                 "at the run's samples (green stick, red slip, grey free)", fontsize=10)
    modes = result.contact_mode
    for i, f in enumerate(feet):
        j = list(result.contact_names).index(f)
        held = [MODE_NAMES[m] for m in modes[:, j]]
        ax.scatter(t, np.full(len(t), -1.0 - 0.6 * i), c=[
            {"stick": "tab:green", "slip": "tab:red"}.get(m, "lightgray") for m in held], s=3)
    ax.set_ylim(bottom=-1.8 - 0.6 * len(feet))
    ax.legend(fontsize=8)
    ax = axes[1, 0]
    E = result.kinetic_energy + result.potential_energy
    ax.plot(tt, E_d - E_d[0], color="black", label="T + V - E(0)")
    ax.plot(tt, T_d, color="tab:blue", label="T")
    ax.set_xlabel("t [s]")
    ax.set_ylabel("energy [J]")
    ax.set_title(f"energy (V: gravity + PD springs); largest rise between the run's "
                 f"samples {max(0.0, float(np.max(np.diff(E)))):.1e} J")
    ax.legend(fontsize=8)
    ax = axes[1, 1]
    picks = [0.0] + [ev.time for ev in result.impacts[:1]] + [float(t[-1])]
    for k, tk in enumerate(picks):
        th = result.sol(tk)[:18] if result.sol is not None else result.theta[np.searchsorted(t, tk)]
        pts = _leg_points(mechanism, th)
        shade = 0.25 + 0.75 * k / max(1, len(picks) - 1)
        hips = np.array([pts[leg][0] for leg in ("FL", "FR", "HR", "HL", "FL")])
        ax.plot(hips[:, 0], hips[:, 2], color=(0, 0, 0, shade), lw=2.5)
        for i, leg in enumerate(LEGS):
            ax.plot(pts[leg][:, 0], pts[leg][:, 2], color=f"C{i}", alpha=shade, marker="o", ms=3)
        ax.text(hips[0, 0], hips[0, 2] + 0.02, f"t = {tk:.3f} s", fontsize=8, alpha=shade)
    ax.axhline(0.0, color="saddlebrown", lw=2)
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("z [m]")
    ax.set_title("side view (x-z): start, first impact, end")
    fig.suptitle("Solo-12 (example-robot-data URDF through Pinocchio) dropped on the floor: "
                 f"{len(result.impacts)} impacts, event-driven with sustained stick/slip contacts",
                 fontsize=11)
    fig.tight_layout(rect=(0, 0, 1, 0.96))
    path = Path(path)
    save_chart(fig, path.parent, path.name, dpi=110)
    return path


def main(out: str = "docs/figures/robot_drop.png") -> None:
    """Simulate the default scene and write :func:`figure` (about a minute)."""
    from convimpact.simulation import simulate

    scene = make_scene()
    res = simulate(scene, rtol=1e-6, atol=1e-8, dense_output=True)
    E = res.kinetic_energy + res.potential_energy
    gaps = [min(scene.mechanism.contact_gap(f, th) for f in scene.mechanism.contact_names)
            for th in res.theta]
    print(f"{len(res.impacts)} impacts, {res.nfev} RHS, wall {res.wall_time:.1f} s; max energy "
          f"rise {np.max(np.diff(E)):.2e} J, energy lost {E[0] - E[-1]:.4f} J, deepest "
          f"penetration {min(gaps):.2e} m; {res.message}")
    print(figure(res, scene.mechanism, Path(out)))


if __name__ == "__main__":
    main()
