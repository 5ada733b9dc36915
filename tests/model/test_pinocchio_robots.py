"""The registry robot (Solo-12 of example-robot-data) and its scene ``robot_drop``.

In free fall a robot whose joints sit at their PD reference moves as one rigid body: the base
falls as z0 - g t^2 / 2 and no coordinate but base_z changes (gravity gives every body the
same acceleration, so no joint torque arises). The scene's start is checked against its
parameters; the landing itself (about a minute of simulation) is the scene's figure.
"""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("pinocchio")

import convimpact as ci  # noqa: E402
from convimpact.errors import ParameterError  # noqa: E402
from convimpact.model import pinocchio_robots as robots  # noqa: E402
from convimpact.scenes import list_scenes, load_scene  # noqa: E402

try:
    robots.robot_data_dir()
except robots.RobotDataUnavailableError:
    pytest.skip("the robot models need example-robot-data (pip install -e \".[test-full]\")",
                allow_module_level=True)


def test_robot_data_is_found_without_downloading():
    path = robots.robot_file("solo_description/robots/solo12.urdf")
    assert path.is_file() and path.suffix == ".urdf"
    assert robots.robot_data_dir().name == "robots"


def test_scene_starts_as_parametrized():
    assert "robot_drop" in list_scenes()
    scene = load_scene("robot_drop", height=0.08, tilt=[0.0, 0.02, 0.0])
    mech = scene.mechanism
    gaps = [mech.contact_gap(c, scene.theta0) for c in mech.contact_names]
    assert min(gaps) == pytest.approx(0.08, abs=1e-12)
    # pitch about the turned y axis lifts the hind feet: front feet lower
    assert gaps[0] < gaps[2] and gaps[1] < gaps[3]
    assert scene.parameters["coordinates"][:3] == ["base_x", "base_y", "base_z"]
    with pytest.raises(ParameterError, match="pitch"):
        load_scene("robot_drop", tilt=[0.0, 1.5, 0.0])


def test_free_fall_is_rigid_and_ballistic():
    scene = load_scene("robot_drop", height=0.1, tilt=[0.1, 0.05, 0.08])
    t1 = 0.1  # the first foot lands at sqrt(2 * 0.1 / 9.81) = 0.143 s
    res = ci.simulate(scene, (0.0, t1), rtol=1e-10, atol=1e-12)
    assert len(res.impacts) == 0
    expected = scene.theta0.copy()
    expected[2] -= 0.5 * 9.81 * t1 ** 2
    assert np.allclose(res.theta[-1], expected, atol=1e-9)
    assert res.dtheta[-1][2] == pytest.approx(-9.81 * t1, abs=1e-9)
    E = res.kinetic_energy + res.potential_energy
    assert np.ptp(E) < 1e-9


def test_pd_springs_are_in_the_potential_energy():
    # at rest the PD torques and gravity are conservative: f = -dV/dtheta (central differences)
    scene = load_scene("robot_drop", kp=4.0, kd=0.3)
    mech = scene.mechanism
    th = scene.theta0 + np.random.default_rng(2).normal(scale=0.1, size=18)
    h = 1e-6
    grad = np.array([(mech.potential_energy(th + h * e) - mech.potential_energy(th - h * e)) / (2 * h)
                     for e in np.eye(18)])
    assert np.allclose(mech.generalized_forces(0.0, th, np.zeros(18)), -grad, atol=1e-7)
    # the dampers only take energy out: the applied torques tau = f + nle (f = -nle + tau)
    # change with theta_dot by -kd (joint rates), so theta_dot . d tau = -kd |joint rates|^2
    import pinocchio as pin
    data = mech.model.createData()
    dth = np.random.default_rng(3).normal(size=18)

    def tau(v):
        return mech.generalized_forces(0.0, th, v) + pin.nonLinearEffects(mech.model, data, th, v)
    assert dth @ (tau(dth) - tau(np.zeros(18))) == pytest.approx(-0.3 * np.sum(dth[6:] ** 2),
                                                                   rel=1e-10)
