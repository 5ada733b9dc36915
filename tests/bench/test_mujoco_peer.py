"""MuJoCo as a simulation peer: its MJCF scenes are ours, its calibrated rebound restitutes e,
and the ``mujoco`` bench section runs (quick). Skipped without ``mujoco``."""

from __future__ import annotations

import math

import numpy as np
import pytest

mujoco = pytest.importorskip("mujoco")

from convimpact.bench import mujoco_peers as mp  # noqa: E402
from convimpact.bench.mujoco_accuracy import ball_reference, errors  # noqa: E402
from convimpact.bench.registry import BenchConfig  # noqa: E402
from convimpact.scenes import load_scene  # noqa: E402
from convimpact.simulation import simulate  # noqa: E402

SETTING = mp.ContactSetting(timeconst=0.005, dampratio=0.25, timestep=1e-4)


def _scene(label):
    name, params, _ = mp.SCENES[label]
    return load_scene(name, **params)


@pytest.mark.parametrize("label", list(mp.SCENES))
def test_mass_matrix_bias_and_gaps_are_ours(label):
    """mj_fullM is our M, -qfrc_bias our f (gravity, Coriolis) and the contact spheres'
    distance to the floor our gaps, at random states."""
    scene = _scene(label)
    model, data = mp.build_model(label, scene, SETTING)
    mech = scene.mechanism
    floor = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "floor")
    rng = np.random.default_rng(7)
    for _ in range(5):
        q = scene.theta0 + rng.normal(scale=0.7, size=model.nq)
        v = rng.normal(scale=2.0, size=model.nv)
        data.qpos[:], data.qvel[:] = q, v
        mujoco.mj_forward(model, data)
        M = np.zeros((model.nv, model.nv))
        mujoco.mj_fullM(model, data, M)
        np.testing.assert_allclose(M, mech.mass_matrix(q), rtol=0, atol=1e-12)
        np.testing.assert_allclose(-data.qfrc_bias, mech.generalized_forces(0.0, q, v),
                                   rtol=0, atol=1e-12)
        for c in mech.contact_names:
            geom = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM,
                                     "ball" if label == "bouncing ball" else c)
            dist = mujoco.mj_geomDistance(model, data, geom, floor, 10.0, None)
            assert dist == pytest.approx(mech.contact_gap(c, q), abs=1e-12)


def test_free_fall_matches_the_closed_form():
    """RK4 is exact on the ball's parabola: before the first impact y = h - g t^2 / 2."""
    scene = _scene("bouncing ball")
    c = mp.ContactSetting(0.005, 0.25, 1e-3, "RK4")
    run = mp.simulate_mujoco("bouncing ball", scene, 0.4, c)
    h = scene.parameters["height"]
    np.testing.assert_allclose(run.qpos[:, 1], h - 0.5 * 9.81 * run.time ** 2, atol=1e-12)
    np.testing.assert_allclose(run.qvel[:, 1], -9.81 * run.time, atol=1e-12)
    np.testing.assert_allclose(run.time, 1e-3 * np.arange(1, 401), atol=1e-12)


def test_pendulum_swing_matches_our_integration():
    """The double pendulum's swing before the tip reaches the floor (0.515 s), MuJoCo RK4 at
    h = 1e-4 against our DOP853 at rtol 1e-12: a second, independent integration."""
    scene = _scene("pendulum drop")
    c = mp.ContactSetting(0.005, 0.25, 1e-4, "RK4")
    run = mp.simulate_mujoco("pendulum drop", scene, 0.5, c)
    ours = simulate(scene, (0.0, 0.5), rtol=1e-12, atol=1e-14)
    assert not ours.impacts
    np.testing.assert_allclose(run.qpos[-1], ours.theta[-1], atol=1e-9)
    np.testing.assert_allclose(run.qvel[-1], ours.dtheta[-1], atol=1e-8)


@pytest.fixture(scope="module")
def calibration():
    return mp.calibrate(0.005, 0.5, tol=1e-6)


def test_calibrated_rebound_restitutes_e(calibration):
    """The calibrated contact restitutes e on the dropped ball's first apex, r + e^2 (h - r)
    (closed form), to the accuracy of the step, at any mass (the reference acceleration is
    mass-normalized)."""
    cal = calibration
    assert 0.2 < cal.dampratio < 0.3  # a linear spring-damper restituting 0.5: zeta = 0.215
    assert abs(cal.restitution_reached - 0.5) < 1e-6 and cal.convergence < 1e-5
    scene = _scene("bouncing ball")
    ref = ball_reference(scene.parameters, 1.0)
    for mass in (1.0, 7.0):
        sc = load_scene("bouncing_ball", mass=mass)
        c = mp.ContactSetting(cal.timeconst, cal.dampratio, cal.timeconst / 1000)
        run = mp.simulate_mujoco("bouncing ball", sc, ref.t_mid + 1e-3, c)
        th, dth = run.state_at(ref.t_mid)
        err = errors(sc.mechanism, ball_reference(sc.parameters, 1.0), th, dth, th, dth)
        assert err["rebound_error"] < 1e-3
    # an unconverged step restitutes something else: the check has teeth
    coarse = mp.ball_rebound(cal.timeconst, cal.dampratio, steps_per_tc=4)
    assert abs(coarse - 0.5) > 1e-3


def test_ball_reference_closed_form():
    """Impact times t1 (1 + 2 e + ...) and the state at t_end by hand."""
    scene = _scene("bouncing ball")
    ref = ball_reference(scene.parameters, 1.0)
    t1 = math.sqrt(2 * 0.9 / 9.81)
    assert ref.impact_times == pytest.approx((t1, 2 * t1))  # e = 1/2: flight 2 e t1 = t1
    s = 1.0 - 2 * t1
    v = 0.25 * 9.81 * t1
    np.testing.assert_allclose(ref.state_end, [0, 0.1 + v * s - 4.905 * s * s, 0, v - 9.81 * s])
    assert ref.energy_mid == pytest.approx(9.81 * (0.1 + 0.25 * 0.9))


def test_section_quick(tmp_path):
    """The section runs in quick mode: both simulators measured on the three scenes, the
    calibration stated, ours within 1e-6 of the closed form on the ball, a real PNG."""
    from convimpact.bench.mujoco_section import mujoco_section

    res = mujoco_section(BenchConfig.make(tmp_path, quick=True), lambda m: None)
    scenes = {r["scene"] for r in res.records}
    assert scenes == set(mp.SCENES)
    ours = [r for r in res.records if r["simulator"] == "ours" and r["scene"] == "bouncing ball"]
    assert ours and all(r["rebound_error"] < 1e-6 for r in ours)
    assert any("dampratio" in s for s in res.summary)
    assert (tmp_path / res.figures[0]).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
