"""Robots standing on the floor, for the contact-problem corpus
(:mod:`convimpact.bench.contact_corpus`).

The robots are URDF files of the installed registry package ``example-robot-data`` loaded by
Pinocchio (nothing is downloaded; :func:`convimpact.model.pinocchio_robots.robot_file` finds
them):

* ``talos``: the humanoid TALOS (``talos_reduced.urdf``, free base, 38 velocity coordinates)
  in the SRDF's "half_sitting" posture with its arms, torso and head joints moved by up to
  0.2 rad; each flat sole (the URDF's 0.21 x 0.13 m foot box) touches the floor at its four
  corners: 8 contacts;
* ``solo``: the quadruped Solo-12 (``solo12.urdf``, 18 coordinates) in the SRDF "standing"
  posture of :data:`~convimpact.model.pinocchio_robots.SOLO12_STANDING` with every joint
  moved by up to 0.1 rad; four point feet at the foot frames' origins: 4 contacts.

``M`` is Pinocchio's joint-space mass matrix (``crba``) and each contact's rows are the
world-aligned velocity Jacobian of the contact point (``getFrameJacobian`` in
``LOCAL_WORLD_ALIGNED``, shifted from the sole frame to the corner) along the frame
(z, x, y), so rows are normal first. Several robots side by side share nothing: M is block
diagonal. Pinocchio's free-flyer velocity is expressed in the base frame, which is aligned
with the world in these postures.
"""

from __future__ import annotations

from functools import lru_cache
from typing import Any, Sequence

import numpy as np
import scipy.sparse as sp

from .contact_scenes import GRAVITY, REST_STEP

#: sole half sizes of TALOS (its URDF's foot collision box 0.21 x 0.13 m)
TALOS_SOLE = (0.105, 0.065)
TALOS_SOLES = ("left_sole_link", "right_sole_link")
SOLO_FEET = ("FL_FOOT", "FR_FOOT", "HL_FOOT", "HR_FOOT")


@lru_cache(maxsize=None)
def _load(robot: str) -> tuple[Any, np.ndarray, tuple[int, ...]]:
    """(model, reference posture, indices of the configuration entries to perturb)."""
    import pinocchio as pin

    from ..model.pinocchio_robots import SOLO12_STANDING, robot_file

    if robot == "talos":
        model = pin.buildModelFromUrdf(str(robot_file("talos_data/robots/talos_reduced.urdf")),
                                       pin.JointModelFreeFlyer())
        pin.loadReferenceConfigurations(model, str(robot_file("talos_data/srdf/talos.srdf")),
                                        False)
        q = np.array(model.referenceConfigurations["half_sitting"])
        free = tuple(model.joints[j].idx_q for j in range(2, model.njoints)
                     if not model.names[j].startswith("leg_"))
    elif robot == "solo":
        model = pin.buildModelFromUrdf(str(robot_file("solo_description/robots/solo12.urdf")),
                                       pin.JointModelFreeFlyer())
        q = np.array(pin.neutral(model))
        for leg, angles in SOLO12_STANDING.items():
            for joint, angle in zip(("HAA", "HFE", "KFE"), angles):
                q[model.joints[model.getJointId(f"{leg}_{joint}")].idx_q] = angle
        free = tuple(model.joints[j].idx_q for j in range(2, model.njoints))
    else:
        raise ValueError(f"unknown robot {robot!r}")
    return model, q, free


def _robot_blocks(robot: str, rng: np.random.Generator
                  ) -> tuple[np.ndarray, list[np.ndarray], list[np.ndarray], list[int]]:
    """(M, per-contact 3 x nv Jacobians (z, x, y), contact points, foot index per contact)
    of one perturbed robot."""
    import pinocchio as pin

    model, q_ref, free = _load(robot)
    data = model.createData()
    q = q_ref.copy()
    q[list(free)] += rng.uniform(-1.0, 1.0, len(free)) * (0.2 if robot == "talos" else 0.1)
    M = np.array(pin.crba(model, data, q))
    M = np.triu(M) + np.triu(M, 1).T
    pin.computeJointJacobians(model, data, q)
    pin.framesForwardKinematics(model, data, q)
    axes = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    blocks, points, feet = [], [], []
    if robot == "talos":
        corners = [(sx * TALOS_SOLE[0], sy * TALOS_SOLE[1], 0.0)
                   for sx in (-1, 1) for sy in (-1, 1)]
        frames = TALOS_SOLES
    else:
        corners, frames = [(0.0, 0.0, 0.0)], SOLO_FEET
    for foot, name in enumerate(frames):
        fid = model.getFrameId(name)
        Jf = np.array(pin.getFrameJacobian(model, data, fid, pin.LOCAL_WORLD_ALIGNED))
        oMf = data.oMf[fid]
        for corner in corners:
            r = oMf.rotation @ np.asarray(corner)
            skew = np.array([[0, -r[2], r[1]], [r[2], 0, -r[0]], [-r[1], r[0], 0]])
            blocks.append(axes @ (Jf[:3] - skew @ Jf[3:]))
            points.append(oMf.translation + r)
            feet.append(foot)
    return M, blocks, points, feet


def robot_scene(rng: np.random.Generator, robots: Sequence[str], mode: str
                ) -> dict[str, Any]:
    """M, M^-1, J (sparse), the pre-impact velocity and per-contact groups of ``robots``
    standing side by side (each robot's own perturbed posture).

    Velocities: "impact" - the base descends at 0.3-1 m/s with lateral velocities up to
    0.5 m/s, base rates up to 0.5 rad/s and joint rates up to 1 rad/s; "rest" - the base falls
    at g h (h = 10 ms), lateral velocities up to 0.1 m/s, rates a tenth of the above.
    """
    Ms, Minvs, rows, dqs, groups, points = [], [], [], [], [], []
    for robot in robots:
        M, blocks, pts, feet = _robot_blocks(robot, rng)
        nv = M.shape[0]
        Minv = np.linalg.inv(M)
        Ms.append(M)
        Minvs.append(0.5 * (Minv + Minv.T))
        rows.append(sp.csr_matrix(np.vstack(blocks)))
        points.extend(pts)
        base = (max(groups) + 1) if groups else 0
        groups.extend(base + f for f in feet)
        dq = np.zeros(nv)
        if mode == "impact":
            dq[:2] = rng.uniform(-0.5, 0.5, 2)
            dq[2] = -rng.uniform(0.3, 1.0)
            dq[3:6] = rng.uniform(-0.5, 0.5, 3)
            dq[6:] = rng.uniform(-1.0, 1.0, nv - 6)
        else:
            dq[:2] = rng.uniform(-0.1, 0.1, 2)
            dq[2] = -GRAVITY * REST_STEP
            dq[3:6] = rng.uniform(-0.05, 0.05, 3)
            dq[6:] = rng.uniform(-0.1, 0.1, nv - 6)
        dqs.append(dq)
    J = sp.block_diag(rows, format="csr")
    M = sp.block_diag(Ms, format="csr")
    Minv = sp.block_diag(Minvs, format="csr")
    for A in (M, Minv, J):
        A.eliminate_zeros()
        A.sort_indices()
    return dict(M=M, Minv=Minv, J=J, dq=np.concatenate(dqs), groups=np.asarray(groups),
                points=np.asarray(points), k_per_robot=[m.shape[0] for m in Ms])
