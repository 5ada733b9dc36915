"""The humanoid TALOS (registry package ``example-robot-data``) standing on flat feet, pushed.

The robot's URDF is loaded by Pinocchio (:func:`convimpact.model.pinocchio_robots.talos_legs`):
a free base (x, y, z, yaw, pitch, roll) and the twelve leg joints, the arms, torso and head
locked in the SRDF's "half_sitting" posture (their links rigidly attached: a scene models no
more than it needs), 90.3 kg. Each flat sole touches the floor z = 0 at its four corners:
8 closed contacts, e = 0, one mu. The two feet on the floor are redundant supports (24
contact force components against 18 coordinates): the forces are statically indeterminate,
the force problem picks its documented distribution and the run notes it.

The leg joints are held by PD control around the posture with a gravity feedforward,
tau = tau_ff - kp (q - q_ref) - kd q_dot; tau_ff holds the posture under gravity with the
least-norm contact forces, so the robot stands still (the force problem's distribution is
the same least-norm one) until the push: a horizontal force ``push`` (N) along the base's
+y axis (sideways), at the base's origin, over [t_push, t_push + duration]. The springs'
energy 1/2 kp |q - q_ref|^2 - tau_ff . (q - q_ref) is potential energy; the dampers and the
contacts dissipate, the push does work.

Closed form checked by the tests: standing, the normal forces total m g and their moments
about the soles balance the weight (the distribution itself is the least-norm one); the
base does not move before the push.

Needs the optional packages ``pin`` (Pinocchio) and ``example-robot-data``; nothing is
downloaded (their absence raises a typed error naming the package to install).
"""

from __future__ import annotations

from types import MappingProxyType

import numpy as np

from convimpact.scenes import Scene
from convimpact.validation import NonNegative, Positive, Real, Unit

PARAMETERS = {"push": Real(), "t_push": NonNegative(), "duration": NonNegative(),
              "mu": NonNegative(), "e": Unit(), "kp": NonNegative(), "kd": NonNegative(),
              "t_end": Positive()}

G = 9.81


def make_scene(push: float = 120.0, t_push: float = 0.1, duration: float = 0.2,
               mu: float = 0.8, e: float = 0.0, kp: float = 1500.0, kd: float = 30.0,
               t_end: float = 0.8) -> Scene:
    """TALOS standing, pushed sideways by ``push`` N over [t_push, t_push + duration] s,
    soles' friction ``mu`` and restitution ``e``, leg PD gains ``kp`` (N m/rad) and ``kd``
    (N m s/rad)."""
    from convimpact.model.pinocchio_robots import talos_legs

    mech0, q_ref = talos_legs(mu=mu, e=e)
    k = mech0.n_coordinates
    joints = np.arange(6, k)
    tau_ff, lam = _feedforward(mech0, q_ref)
    y_axis = mech0.coordinate_index("base_y")

    def control(t, q, v):
        tau = np.zeros(k)
        tau[joints] = tau_ff[joints] - kp * (q[joints] - q_ref[joints]) - kd * v[joints]
        if t_push <= t <= t_push + duration:
            tau[y_axis] += push
        return tau

    def potential(q):
        dq = q[joints] - q_ref[joints]
        return 0.5 * kp * float(dq @ dq) - float(tau_ff[joints] @ dq)

    mech, _ = talos_legs(mu=mu, e=e, applied_forces=control, applied_potential=potential)
    normal = lam.reshape(-1, 3)[:, 0]
    description = (
        "TALOS humanoid of the registry package example-robot-data (URDF loaded by Pinocchio; "
        "arms, torso and head locked in the SRDF half_sitting posture; free base and 12 leg "
        f"joints; {_mass(mech0, q_ref):.1f} kg) standing on its flat soles (4 corners each: "
        f"8 contacts, e = {e}, mu = {mu}, floor z = 0); leg joints held by PD control (kp = "
        f"{kp} N m/rad, kd = {kd} N m s/rad) with a gravity feedforward; pushed sideways "
        f"(+y) by {push} N at the base over [{t_push}, {t_push + duration}] s.")
    params = dict(push=push, t_push=t_push, duration=duration, mu=mu, e=e, kp=kp, kd=kd,
                  mass=_mass(mech0, q_ref), gravity=G,
                  standing_normal_forces=normal.tolist(),
                  robot="talos_data/robots/talos_reduced.urdf (example-robot-data)",
                  coordinates=list(mech.coordinate_names),
                  assumptions=["arms, torso and head locked in half_sitting",
                               "soles as four corner contacts of the URDF's foot box",
                               "PD control with a gravity feedforward (least-norm forces)",
                               "the push acts at the base origin, horizontally, constant"])
    return Scene(name="humanoid_push", description=description, mechanism=mech,
                 theta0=q_ref, dtheta0=np.zeros(k), t_end=t_end,
                 parameters=MappingProxyType(params))


def _feedforward(mech, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(tau_ff, lambda): the joint torques holding posture q at rest under gravity and the
    contact forces (n, t1, t2 per contact) they rest on: the least-norm forces balancing the
    base's rows, 0 = f_base + J_base^T lambda, then tau = -(f + J^T lambda) on the joints."""
    k = mech.n_coordinates
    f = np.asarray(mech.generalized_forces(0.0, q, np.zeros(k)), float)
    J = np.vstack([np.asarray(mech.contact_jacobian(c, q), float) for c in mech.contact_names])
    lam = np.linalg.lstsq(J[:, :6].T, -f[:6], rcond=None)[0]
    tau = -(f + J.T @ lam)
    tau[:6] = 0.0
    return tau, lam


def _mass(mech, q: np.ndarray) -> float:
    return float(np.asarray(mech.mass_matrix(q), float)[0, 0])


#: frames drawn in the front view: base, then each leg from hip to sole
_CHAIN = ["leg_{side}_1_link", "leg_{side}_3_link", "leg_{side}_4_link", "leg_{side}_5_link",
          "{side}_sole_link"]


def figure(result, mechanism, path) -> "Path":
    """Base motion, sole forces and modes, energy and front views of a run (PNG)."""
    from pathlib import Path

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from convimpact.bench.charts import save_chart

    from convimpact.simulation.result import MODE_NAMES

    t = result.t
    names = list(result.contact_names)
    iy, iroll = (mechanism.coordinate_index(n) for n in ("base_y", "base_roll"))
    fig, axes = plt.subplots(2, 2, figsize=(13, 8.5))
    ax = axes[0, 0]
    ax.plot(t, result.theta[:, iy] * 100, color="black", label="base y [cm]")
    ax.plot(t, np.degrees(result.theta[:, iroll]), color="tab:purple", label="base roll [deg]")
    for ev in result.impacts:
        ax.axvline(ev.time, color="gray", lw=0.5, ls=":")
    ax.set_title("base: sideways position and roll (dotted: impacts)")
    ax.set_xlabel("t [s]")
    ax.legend(fontsize=8)
    ax = axes[0, 1]
    for j, c in enumerate(names):
        ax.plot(t, result.contact_force[:, j, 0], color=f"C{j}", lw=1.0, label=c)
        ax.scatter(t, np.full(len(t), -40.0 - 12.0 * j), s=3, c=[
            {"stick": "tab:green", "slip": "tab:red"}.get(MODE_NAMES[m], "lightgray")
            for m in result.contact_mode[:, j]])
    ax.set_ylim(bottom=-50.0 - 12.0 * len(names))
    ax.set_title("sole corners' normal forces [N]; dots: modes per corner\n"
                 "(green stick, red slip, grey open)", fontsize=10)
    ax.set_xlabel("t [s]")
    ax.legend(fontsize=7, ncol=2)
    ax = axes[1, 0]
    E = result.kinetic_energy + result.potential_energy
    ax.plot(t, E - E[0], color="black", label="T + V - E(0)")
    ax.plot(t, result.kinetic_energy, color="tab:blue", label="T")
    ax.set_xlabel("t [s]")
    ax.set_ylabel("energy [J]")
    ax.set_title("energy (V: gravity + PD springs; the push does work)")
    ax.legend(fontsize=8)
    ax = axes[1, 1]
    roll = np.abs(result.theta[:, iroll])
    picks = sorted({0, int(np.argmax(roll)), len(t) - 1})
    for k, i in enumerate(picks):
        shade = 0.3 + 0.7 * k / max(1, len(picks) - 1)
        for side, color in (("left", "tab:blue"), ("right", "tab:orange")):
            pts = np.array([mechanism.frame_placement(f.format(side=side), result.theta[i])[1]
                            for f in ["base_link"] + _CHAIN])
            ax.plot(pts[:, 1], pts[:, 2], color=color, alpha=shade, marker="o", ms=3,
                    label=f"{side} leg, t = {t[i]:.3f} s")
    ax.set_xlim(-0.45, 0.45)
    ax.legend(fontsize=7, loc="center right")
    ax.axhline(0.0, color="saddlebrown", lw=2)
    ax.set_aspect("equal")
    ax.set_xlabel("y [m] (the push is along +y)")
    ax.set_ylabel("z [m]")
    ax.set_title("front view (y-z) of the legs: start, largest roll, end")
    fig.suptitle(f"TALOS (example-robot-data URDF through Pinocchio) pushed sideways: "
                 f"{len(result.impacts)} impacts, event-driven, 8 sole corners", fontsize=11)
    fig.tight_layout(rect=(0, 0, 1, 0.96))
    path = Path(path)
    save_chart(fig, path.parent, path.name, dpi=110)
    return path


def main(out: str = "docs/figures/humanoid_push.png") -> None:
    """Simulate the default scene and write :func:`figure`."""
    from convimpact.simulation import simulate

    scene = make_scene()
    res = simulate(scene)
    print(f"{len(res.impacts)} impacts, wall {res.wall_time:.1f} s; {res.message}")
    print(figure(res, scene.mechanism, out))


if __name__ == "__main__":
    main()
