"""The paper's scenes: impact states, approach velocities, hand-derived mass matrices."""

from __future__ import annotations

import json

import numpy as np
import pytest

import convimpact as ci
from convimpact.errors import UnknownOptionError
from convimpact.mechanism import Mechanism
from convimpact.scenes import Scene, list_scenes, load_scene

L, m = 1.0, 1.0


def test_registry_lists_every_scene():
    assert {"pendulum_planar", "pendulum_3d", "slider_crank", "bouncing_rod",
            "bouncing_ball"} <= set(list_scenes())
    with pytest.raises(UnknownOptionError):
        load_scene("pendulum_planar", case="c")


@pytest.mark.parametrize("name,params", [
    ("pendulum_planar", {"case": "a"}), ("pendulum_planar", {"case": "b"}),
    ("pendulum_planar", {"case": "drop"}), ("pendulum_3d", {}),
    ("slider_crank", {"mass_ratio": 5}), ("bouncing_rod", {}), ("bouncing_ball", {"speed": 1.0})])
def test_every_scene_is_well_formed(name, params):
    s = load_scene(name, **params)
    assert isinstance(s, Scene) and isinstance(s.mechanism, Mechanism)
    mech = s.mechanism
    k = mech.n_coordinates
    assert s.theta0.shape == s.dtheta0.shape == (k,) and s.t_end > 0
    assert len(s.description) > 100
    assert s.parameters.get("assumptions") or "chose" in s.description
    json.dumps(dict(s.parameters))  # JSON-ready parameters
    # the simulation starts separated, assembled, with SPD mass matrix and finite forces
    assert all(mech.contact_gap(c, s.theta0) > 0 for c in mech.contact_names)
    assert np.allclose(mech.loop_residual(s.theta0), 0.0, atol=1e-10)
    assert np.allclose(mech.loop_jacobian(s.theta0) @ s.dtheta0, 0.0, atol=1e-10)
    assert np.linalg.eigvalsh(mech.mass_matrix(s.theta0))[0] > 1e-6
    assert np.all(np.isfinite(mech.generalized_forces(0.0, s.theta0, s.dtheta0)))
    if s.impact_state is not None:
        th, dth = s.impact_state
        assert mech.contact_gap(s.impact_contact, th) == pytest.approx(0.0, abs=1e-12)
        assert mech.contact_jacobian(s.impact_contact, th)[0] @ dth < 0  # approaching


@pytest.mark.parametrize("case,printed", [("a", (-1.309, -2.683)), ("b", (-0.416, -2.956))])
def test_planar_pendulum_approach_velocity_matches_the_paper(case, printed):
    s = load_scene("pendulum_planar", case=case)
    th, dth = s.impact_state
    v = s.mechanism.contact_jacobian("tip", th) @ dth
    assert np.round(v, 3).tolist() == list(printed)
    fr = s.mechanism.contact_frame("tip", th)
    assert np.allclose(fr.normal, [0, 1]) and np.allclose(fr.tangents[0], [-1, 0])  # t = -x


def test_spatial_pendulum_approach_velocity_matches_the_paper():
    s = load_scene("pendulum_3d")
    th, dth = s.impact_state
    assert dth[0] == 1.0  # theta3_dot = 1 rad/s
    v = s.mechanism.contact_jacobian("tip", th) @ dth
    assert np.round(v, 3).tolist() == [-1.309, -2.683, 0.809]
    fr = s.mechanism.contact_frame("tip", th)
    assert np.allclose(fr.tangents, [[-1, 0, 0], [0, 0, 1]])  # t1 = -x, t2 = +z


def _planar_pendulum_mass_matrix(phi1, phi2):
    """Hand derivation: absolute-angle inertia matrix A, then theta = (phi1, phi2 - phi1)."""
    A = np.array([[4 / 3 * m * L ** 2, 0.5 * m * L ** 2 * np.cos(phi1 - phi2)],
                  [0.5 * m * L ** 2 * np.cos(phi1 - phi2), m * L ** 2 / 3]])
    T = np.array([[1.0, 0.0], [1.0, 1.0]])  # phi_dot = T theta_dot
    return T.T @ A @ T


@pytest.mark.parametrize("case", ["a", "b"])
def test_planar_pendulum_mass_matrix_by_hand(case):
    s = load_scene("pendulum_planar", case=case)
    th, _ = s.impact_state
    phi1, phi2 = th[0], th[0] + th[1]
    assert np.allclose(s.mechanism.mass_matrix(th), _planar_pendulum_mass_matrix(phi1, phi2),
                       atol=1e-14)


def test_spatial_pendulum_mass_matrix_by_hand():
    s = load_scene("pendulum_3d")
    th, _ = s.impact_state
    M = s.mechanism.mass_matrix(th)
    phi1, phi2 = th[1], th[1] + th[2]
    x1 = L * np.cos(phi1)
    x2 = x1 + L * np.cos(phi2)
    # moment of the slender rods about the vertical axis: integral of x^2 dm along each rod
    I_y = m * (x1 ** 2) / 3 + m * (x1 ** 2 + x1 * x2 + x2 ** 2) / 3
    expected = np.zeros((3, 3))
    expected[0, 0] = I_y
    expected[1:, 1:] = _planar_pendulum_mass_matrix(phi1, phi2)
    assert np.allclose(M, expected, atol=1e-14)
    assert np.linalg.eigvalsh(M)[0] > 0.05  # SPD at the impact state


def test_spatial_pendulum_mass_matrix_is_singular_with_both_rods_vertical():
    """The honest limitation of zero axial inertia: base rotation then moves nothing."""
    mech = load_scene("pendulum_3d").mechanism
    M = mech.mass_matrix(np.array([0.3, -np.pi / 2, 0.0]))
    assert abs(np.linalg.eigvalsh(M)[0]) < 1e-14


def test_slider_crank_generalized_mass_by_hand():
    s = load_scene("slider_crank", mass_ratio=5)
    p = s.parameters
    th, dth = s.impact_state
    r, l, m1, m2, m3 = (p["crank_length"], p["coupler_length"], p["crank_mass"],
                        p["coupler_mass"], p["slider_mass"])
    phi, w = th[0], dth[0]
    psi = np.arcsin(-r * np.sin(phi) / l)
    psid = -r * np.cos(phi) * w / (l * np.cos(psi))
    vA = r * w * np.array([-np.sin(phi), np.cos(phi)])
    vG = vA + 0.5 * l * psid * np.array([-np.sin(psi), np.cos(psi)])
    xdot = -r * np.sin(phi) * w - l * np.sin(psi) * psid
    T = 0.5 * m1 * r * r / 3 * w * w + 0.5 * m2 * vG @ vG + 0.5 * m2 * l * l / 12 * psid ** 2 \
        + 0.5 * m3 * xdot ** 2
    m_eff = 2 * T / xdot ** 2  # one degree of freedom: T = m_eff xdot^2 / 2
    assert p["generalized_slide_mass"] == pytest.approx(m_eff, rel=1e-10)
    assert p["free_slider_mass"] == pytest.approx(5 * m_eff, rel=1e-12)
    assert dth[2] == pytest.approx(xdot, rel=1e-10) and xdot > 0
    assert dth[3] == pytest.approx(-xdot)  # slider 4 approaches with slider 3's speed
    assert th[0] == pytest.approx(np.radians(-60.0))
    assert th[2] == pytest.approx(r * np.cos(phi) + l * np.cos(psi), abs=1e-12)
    # the central impact has no tangential relative velocity
    Jc = s.mechanism.contact_jacobian("blocks", th)
    assert Jc[0] @ dth == pytest.approx(-2 * xdot) and Jc[1] @ dth == pytest.approx(0.0, abs=1e-14)


def test_slider_crank_driving_torque_regulates_crank_speed():
    s = load_scene("slider_crank")
    th, dth = s.impact_state
    K = s.parameters["speed_gain"]
    mech = s.mechanism
    slow = dth.copy()
    slow[0] -= 1.0
    # f is affine in the applied torque: only theta1's component gains K * 1 (plus the
    # velocity-product change, removed by comparing with the unregulated forces)
    f_reg = mech.generalized_forces(0.0, th, slow) - mech.generalized_forces(0.0, th, dth)
    from convimpact.problems.slider_crank import _build
    free = _build(s.parameters["free_slider_mass"], 0.83, 0.0, 0.0, 20.0).mechanism()
    f_free = free.generalized_forces(0.0, th, slow) - free.generalized_forces(0.0, th, dth)
    assert np.allclose(f_reg - f_free, [K, 0, 0, 0], atol=1e-12)


@pytest.mark.parametrize("ratio", [1, 5, 10])
def test_slider_crank_plastic_impact_energy_loss(ratio):
    """e = 0, head-on with equal speeds: T_L / T- = 4 r / (1 + r)^2 for a 1-DOF crank-slider.

    (The paper's Fig. 3 reads ~100 %, 54 % and 32 % for r = 1, 5, 10.)
    """
    from convimpact.problems import slider_crank
    args = slider_crank.impact_arguments(mass_ratio=ratio, e=0.0)
    assert set(args) == {"M", "Jc", "dq", "C", "e", "mu"} and args["C"].shape == (2, 4)
    res = ci.resolve_impact(**args)
    T = 0.5 * args["dq"] @ args["M"] @ args["dq"]
    assert res.energy_loss / T == pytest.approx(4 * ratio / (1 + ratio) ** 2, rel=1e-9)
    if ratio == 1:
        assert np.allclose(res.dq_plus, 0.0, atol=1e-9)  # the system comes to a halt


def test_paper_impact_arguments_feed_resolve_impact():
    from convimpact.problems import pendulum_3d, pendulum_planar
    a = pendulum_planar.impact_arguments("a", e=0.5, mu=0.3)
    assert a["C"] is None and a["Jc"].shape == (2, 2) and a["e"] == 0.5 and a["mu"] == 0.3
    b = pendulum_3d.impact_arguments()
    assert b["Jc"].shape == (3, 3)
    for args in (a, b):
        r = ci.resolve_impact(**args)
        # Newton's restitution on the normal relative velocity (eq. 21)
        assert (args["Jc"] @ r.dq_plus)[0] == pytest.approx(-args["e"] * (args["Jc"] @ args["dq"])[0])


def test_bouncing_ball_zeno_time_closed_form():
    from convimpact.problems.bouncing_ball import zeno_time
    s = load_scene("bouncing_ball", e=0.5, height=1.0, radius=0.1)
    assert s.mechanism.contact_gap("floor", s.theta0) == pytest.approx(0.9)
    t1 = np.sqrt(2 * 0.9 / 9.81)
    assert zeno_time(0.5, 1.0, 0.1) == pytest.approx(3 * t1)  # t1 + 2 t1 e / (1 - e), e = 1/2


def test_bouncing_rod_ends_and_frame():
    s = load_scene("bouncing_rod", tilt=30.0, height=1.0)
    mech = s.mechanism
    assert mech.contact_gap("end_a", s.theta0) == pytest.approx(1.0 - 0.5 * np.sin(np.radians(30)))
    assert mech.contact_gap("end_b", s.theta0) == pytest.approx(1.0 + 0.5 * np.sin(np.radians(30)))
    assert np.allclose(mech.mass_matrix(s.theta0), np.diag([1.0, 1.0, 1 / 12]))


# -- sustained-contact scenes: bodies placed resting on contacts ------------------------------
RESTING = {
    "rocking_block": ({}, ("right_corner",)),
    "sliding_box": ({}, ("left_corner", "right_corner")),
    "incline_box": ({}, ("left_corner", "right_corner")),
    "spinning_ball": ({}, ("floor",)),
    "rimless_wheel": ({}, ("foot0",)),
    "painleve_rod": ({}, ("foot",)),
}
RESTING_CASES = [(n, p, c) for n, (p, c) in RESTING.items()] + [
    ("spinning_ball", {"spatial": True}, ("floor",)),
    ("spinning_ball", {"spatial": True, "omega0": 15.0, "spin_axis_deg": 0.0}, ("floor",)),
    ("incline_box", {"mu": 0.4, "v0": 1.0}, ("left_corner", "right_corner")),
]


def test_registry_lists_the_sustained_contact_scenes():
    assert set(RESTING) <= set(list_scenes())


@pytest.mark.parametrize("name,params,resting", RESTING_CASES)
def test_resting_scene_is_well_formed(name, params, resting):
    s = load_scene(name, **params)
    mech = s.mechanism
    k = mech.n_coordinates
    assert s.name == name and s.theta0.shape == s.dtheta0.shape == (k,)
    assert 2.0 <= s.t_end <= 3.0 and len(s.description) > 100
    assert s.parameters.get("assumptions")
    json.dumps(dict(s.parameters))
    for c in mech.contact_names:
        gap = mech.contact_gap(c, s.theta0)
        if c in resting:
            assert abs(gap) <= 1e-12  # placed exactly
            assert abs(mech.contact_jacobian(c, s.theta0)[0] @ s.dtheta0) <= 1e-12
            assert mech.contact_parameters(c) == (s.parameters["e"], s.parameters["mu"])
        else:
            assert gap > 1e-3
    assert np.linalg.eigvalsh(mech.mass_matrix(s.theta0))[0] > 1e-6
    assert np.all(np.isfinite(mech.generalized_forces(0.0, s.theta0, s.dtheta0)))


def test_rocking_block_constants_and_pose():
    from tests.simulation import closed_forms as cf
    s = load_scene("rocking_block")
    p, mech = s.parameters, s.mechanism
    alpha, R = np.arctan(0.2), 0.5 * np.hypot(0.2, 1.0)
    assert p["alpha"] == pytest.approx(alpha) and p["R"] == pytest.approx(R)
    assert p["p_squared"] == pytest.approx(cf.housner_p2(R))
    assert p["impact_ratio"] == pytest.approx(cf.housner_restitution(alpha))
    assert p["first_landing_time_linearized"] == pytest.approx(
        cf.housner_first_landing_time_linear(0.1, alpha, R))
    # tilted by 0.1 rad about the right corner: the left corner is w sin(tilt) up
    assert s.theta0[2] == -0.1
    assert mech.contact_gap("left_corner", s.theta0) == pytest.approx(0.2 * np.sin(0.1))
    assert np.allclose(s.dtheta0, 0.0)


def test_box_scenes_constants():
    from tests.simulation import closed_forms as cf
    s = load_scene("sliding_box")
    t, d = cf.box_stopping(3.0, 0.3)
    assert s.parameters["stop_time"] == pytest.approx(t)
    assert s.parameters["stop_distance"] == pytest.approx(d)
    assert np.allclose(s.dtheta0, [3.0, 0.0, 0.0]) and s.theta0[1] == pytest.approx(0.1)
    N = s.parameters["normal_forces_sliding"]
    assert N["left_corner"] + N["right_corner"] == pytest.approx(9.81)
    assert N["right_corner"] > N["left_corner"] > 0  # the leading corner carries more
    a = np.radians(30.0)
    for mu, v0 in ((0.7, 0.0), (0.4, 0.0), (0.7, 1.0), (0.4, -1.0)):
        s = load_scene("incline_box", mu=mu, v0=v0)
        p = s.parameters
        assert p["holds"] == (mu >= np.tan(a))
        assert p["acceleration_from_rest"] == pytest.approx(cf.incline(mu, a))
        ref = cf.incline_stopping(v0, mu, a)
        if ref is None:
            assert p["stop_time"] is None
        else:
            assert (p["stop_time"], p["stop_distance_down"]) == pytest.approx(ref)
        down = np.array([-np.cos(a), -np.sin(a)])
        assert np.allclose(s.dtheta0[:2], v0 * down) and s.theta0[2] == pytest.approx(a)


@pytest.mark.parametrize("omega0", [0.0, 10.0, -30.0])
def test_spinning_ball_constants(omega0):
    from tests.simulation import closed_forms as cf
    s = load_scene("spinning_ball", omega0=omega0)
    t, v = cf.ball_rolling(2.0, omega0, 0.1, 0.2)
    assert s.parameters["roll_time"] == pytest.approx(t)
    assert s.parameters["final_speed"] == pytest.approx(v)
    assert np.allclose(s.dtheta0, [2.0, 0.0, omega0])
    # the spatial scene: velocity and spin through B, closed forms in vector form
    s3 = load_scene("spinning_ball", spatial=True, omega0=omega0, direction_deg=30.0)
    mech = s3.mechanism
    B = mech.velocity_transformation(s3.theta0)
    v_w = B @ s3.dtheta0
    d = np.radians(30.0)
    u = np.array([np.cos(d), 0.0, np.sin(d)])
    assert np.allclose(v_w[:3], 2.0 * u)
    assert np.allclose(v_w[3:], omega0 * np.array([-np.sin(d), 0.0, np.cos(d)]))
    t3, vf, wf = cf.ball_rolling_spatial(v_w[:3], v_w[3:], 0.1, 0.2)
    assert s3.parameters["roll_time"] == pytest.approx(t3) and t3 == pytest.approx(t)
    assert np.allclose(s3.parameters["final_velocity"], vf)
    assert np.allclose(s3.parameters["final_omega"], wf)
    # the initial slip, in the contact frame, is along neither tangent
    slip = mech.contact_jacobian("floor", s3.theta0)[1:] @ s3.dtheta0
    assert np.min(np.abs(slip)) > 0.1 * np.max(np.abs(slip))
    assert s3.parameters["max_middle_cardan_angle_deg"] <= 45.0


def test_rimless_wheel_constants_and_start():
    from tests.simulation import closed_forms as cf
    s = load_scene("rimless_wheel")
    p, mech = s.parameters, s.mechanism
    slope = np.radians(5.0)
    assert p["eta"] == pytest.approx(cf.rimless_wheel_eta(8, 0.1))
    w_minus, w_plus = cf.rimless_wheel_steady_speed(8, slope, 1.0, 0.1)
    assert p["omega_minus_steady"] == pytest.approx(w_minus)
    assert p["omega_plus_steady"] == pytest.approx(w_plus)
    # standing on foot0, leg vertical, turning about the foot (the foot does not move)
    assert s.theta0[2] == 0.0 and s.dtheta0[2] == p["omega0"] == 0.7
    assert np.allclose(mech.contact_jacobian("foot0", s.theta0) @ s.dtheta0, 0.0, atol=1e-14)
    # the hub is l above the foot: the foot at x = 0 is on the slope y = x tan(slope)
    assert s.theta0[1] == pytest.approx(1.0)
    # starting on the limit cycle: the first strike already has the steady w-
    s2 = load_scene("rimless_wheel", omega0=p["omega_vertical_steady"])
    assert s2.parameters["omega_minus_first"] == pytest.approx(w_minus)


def test_painleve_rod_starts_in_the_paradox():
    from tests.simulation import closed_forms as cf
    s = load_scene("painleve_rod")
    p, mech = s.parameters, s.mechanism
    th, dth = s.theta0, s.dtheta0
    A_ref = cf.painleve_effective_mass(np.radians(60.0), 1.5, -1, 1.0, 0.5)
    assert p["painleve_A"] == pytest.approx(A_ref) and A_ref < 0
    assert p["regime"] == "inconsistent" and p["normal_free_acceleration"] < 0
    # the same A from the mechanism: Jn M^-1 (Jn - mu sign(v_t) Jt)
    Jc = mech.contact_jacobian("foot", th)
    vt = Jc[1] @ dth
    assert abs(vt) == pytest.approx(1.0)
    A = Jc[0] @ np.linalg.solve(mech.mass_matrix(th), Jc[0] - 1.5 * np.sign(vt) * Jc[1])
    assert A == pytest.approx(A_ref, rel=1e-12)
    # leaning toward -x: the foot is right of and below the centre
    foot = mech.contact_frame("foot", th).point
    assert foot[0] > th[0] and foot[1] == pytest.approx(0.0, abs=1e-12)
