"""The humanoid_push scene written as MJCF for MuJoCo (convimpact.bench.humanoid_peer): the
MJCF must be the same mechanism as ours, checked by MuJoCo's own kinematics and dynamics
against Pinocchio's (a second implementation), and MuJoCo's standing robot must carry its
weight on its soles."""

from __future__ import annotations

import numpy as np
import pytest

from convimpact.scenes import load_scene


@pytest.fixture(scope="module")
def scene():
    pytest.importorskip("pinocchio")
    pytest.importorskip("mujoco")
    from convimpact.model.pinocchio_robots import RobotDataUnavailableError
    try:
        return load_scene("humanoid_push")
    except RobotDataUnavailableError:
        pytest.skip("example-robot-data not installed")


def test_mjcf_places_the_sole_corners_where_our_model_does(scene):
    from convimpact.bench.humanoid_peer import max_point_mismatch

    assert max_point_mismatch(scene, samples=4) < 1e-12


def test_mjcf_has_our_mass_matrix_gravity_and_springs(scene):
    """MuJoCo's joint-space inertia and bias forces equal Pinocchio's M(q) and the gravity
    forces at a perturbed posture; its PD springs vanish at the reference posture (angles in
    radians) and pull back with kp elsewhere."""
    import mujoco

    from convimpact.bench import humanoid_peer as hp
    from convimpact.model.pinocchio_robots import talos_legs

    model = hp._model(scene)
    data = mujoco.MjData(model)
    bare, _ = talos_legs(mu=scene.parameters["mu"], e=scene.parameters["e"])
    q0 = np.asarray(scene.theta0, float)
    q = q0 + np.random.default_rng(3).uniform(-0.2, 0.2, q0.size)
    data.qpos[:] = q
    mujoco.mj_forward(model, data)
    M = np.zeros((model.nv, model.nv))
    column = np.zeros(model.nv)
    for j, unit in enumerate(np.eye(model.nv)):  # mj_mulM's signature is the stable one
        mujoco.mj_mulM(model, data, column, unit)
        M[:, j] = column
    np.testing.assert_allclose(M, bare.mass_matrix(q), atol=1e-10 * np.abs(M).max())
    np.testing.assert_allclose(data.qfrc_bias, -np.asarray(bare.generalized_forces(
        0.0, q, np.zeros_like(q))), atol=1e-9)
    kp = scene.parameters["kp"]
    np.testing.assert_allclose(data.qfrc_passive[6:], -kp * (q - q0)[6:], atol=1e-9)
    data.qpos[:] = q0
    mujoco.mj_forward(model, data)
    np.testing.assert_allclose(data.qfrc_passive, 0.0, atol=1e-9)


def test_mujoco_robot_stands_on_its_soles_before_the_push(scene):
    """Before the push MuJoCo's contact forces carry the weight m g (the feedforward holds the
    legs), its soles sink by millimetres at most (soft contact) and do not creep."""
    import mujoco

    from convimpact.bench import humanoid_peer as hp

    model = hp._model(scene)
    data = mujoco.MjData(model)
    data.qpos[:] = scene.theta0
    feedforward, push = hp.applied_forces(scene)
    p = scene.parameters
    assert push[scene.mechanism.coordinate_index("base_y")] == pytest.approx(p["push"])
    assert np.count_nonzero(push) == 1
    data.qfrc_applied[:] = feedforward
    while data.time < 0.9 * p["t_push"]:
        mujoco.mj_step(model, data)
    total = np.zeros(6)
    for k in range(data.ncon):
        f = np.zeros(6)
        mujoco.mj_contactForce(model, data, k, f)
        total[:3] += data.contact[k].frame.reshape(3, 3).T @ f[:3]
    weight = p["mass"] * p["gravity"]
    assert total[2] == pytest.approx(weight, rel=0.02)
    run_obs = hp.observables(scene, np.array([0.0, data.time]),
                             np.array([scene.theta0, data.qpos.copy()]),
                             np.array([scene.dtheta0, data.qvel.copy()]))
    assert run_obs["penetration"] < 3e-3
    assert run_obs["sole_slip"] < 1e-3
