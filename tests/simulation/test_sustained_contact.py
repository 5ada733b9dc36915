"""Sustained contact with Coulomb friction in the event-driven scheme, against closed forms.

Every reference is derived independently in ``closed_forms.py`` (Newton-Euler, energy and
angular-momentum balances; nothing there calls convimpact). Acceptance: the scenes match
their closed forms to 1e-6 (relative) at the default tolerances.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import minimize_scalar

import convimpact as ci

from . import closed_forms as cf
from .coulomb_checks import assert_coulomb, slip_velocity

REL = 1e-6


def _first(res, contact, mode):
    return next(iv for iv in res.modes_of(contact) if iv.mode == mode)


def _energy_never_rises_between_impacts(res, rtol=1e-8):
    """Friction never adds energy: between impacts E(t) does not increase, and its drop
    equals the recorded friction work (plus the impacts' losses and the corrections)."""
    E = res.total_energy
    scale = max(1.0, float(np.max(np.abs(E))))
    jumps = {ev.time for ev in res.impacts} | {c.time for c in res.contact_events}
    for j in range(1, len(E)):
        if any(res.t[j - 1] <= tj <= res.t[j] for tj in jumps):
            continue
        assert E[j] - E[j - 1] <= rtol * scale, f"energy rose at t = {res.t[j]}"
    lost = (sum(ev.energy_loss for ev in res.impacts) + res.friction_dissipation[-1]
            - sum(c.energy_change for c in res.contact_events))
    assert E[0] - E[-1] == pytest.approx(lost, abs=1e-6 * scale)


@pytest.mark.parametrize("v0,omega0", [(2.0, 0.0), (2.0, 5.0), (1.0, -30.0)])
def test_planar_ball_slides_then_rolls_at_the_closed_form(v0, omega0):
    scene = ci.load_scene("spinning_ball", v0=v0, omega0=omega0)
    r, mu = scene.parameters["radius"], scene.parameters["mu"]
    res = ci.simulate(scene, t_span=(0.0, 1.0))
    assert res.status == 0
    t_roll, v_final = cf.ball_rolling(v0, omega0, r, mu)
    assert _first(res, "floor", "stick").t_start == pytest.approx(t_roll, rel=REL)
    assert res.dtheta[-1, 0] == pytest.approx(v_final, rel=REL)
    # the slip decays linearly at 3.5 mu g while sliding, in its initial direction
    s0 = v0 + r * omega0
    sliding = res.contact_mode[:, 0] == 2
    vt = slip_velocity(scene.mechanism, "floor", res.theta[sliding], res.dtheta[sliding])[:, 0]
    n_t = scene.mechanism.contact_jacobian("floor", scene.theta0)[1]
    expect = np.sign(s0) * (abs(s0) - 3.5 * mu * cf.G * res.t[sliding])
    np.testing.assert_allclose(vt * np.sign(n_t @ [1.0, 0.0, 0.0]), expect,
                               atol=REL * abs(s0))
    counts = assert_coulomb(res, scene.mechanism)
    assert counts["slip"] > 0 and counts["stick"] > 0
    _energy_never_rises_between_impacts(res)


def test_spatial_ball_slip_keeps_its_direction_and_rolls_at_the_closed_form():
    scene = ci.load_scene("spinning_ball", spatial=True, v0=2.0, omega0=8.0)
    p = scene.parameters
    res = ci.simulate(scene, t_span=(0.0, 1.0))
    assert res.status == 0
    v0 = np.asarray(p["launch_velocity"], float)
    w0 = np.asarray(p["spin_vector"], float)
    t_roll, v_final, _ = cf.ball_rolling_spatial(v0, w0, p["radius"], p["mu"])
    assert _first(res, "floor", "stick").t_start == pytest.approx(t_roll, rel=REL)
    np.testing.assert_allclose(res.dtheta[-1, :3], v_final, rtol=0, atol=REL * np.linalg.norm(v0))
    sliding = res.contact_mode[:, 0] == 2
    vt = slip_velocity(scene.mechanism, "floor", res.theta[sliding], res.dtheta[sliding])
    speed = np.linalg.norm(vt, axis=1)
    moving = speed > 1e-6 * speed[0]  # the last slip sample is at the located stop
    vt, speed = vt[moving], speed[moving]
    sliding[np.flatnonzero(sliding)[~moving]] = False
    direction = vt / speed[:, None]
    np.testing.assert_allclose(direction, np.broadcast_to(direction[0], direction.shape),
                               atol=1e-8)
    s0 = float(speed[0])
    np.testing.assert_allclose(speed, s0 - 3.5 * p["mu"] * cf.G * res.t[sliding],
                               atol=REL * s0)
    assert_coulomb(res, scene.mechanism)
    _energy_never_rises_between_impacts(res)


def test_box_slides_to_rest_at_the_closed_form_distance():
    scene = ci.load_scene("sliding_box", v0=3.0, mu=0.3)
    res = ci.simulate(scene)
    t_stop, d_stop = cf.box_stopping(3.0, 0.3)
    for c in ("left_corner", "right_corner"):
        modes = res.modes_of(c)
        assert [iv.mode for iv in modes] == ["slip", "stick"]  # closed from the start
        assert modes[0].t_start == 0.0 and modes[1].t_start == pytest.approx(t_stop, rel=REL)
    assert res.theta[-1, 0] - scene.theta0[0] == pytest.approx(d_stop, rel=REL)
    np.testing.assert_allclose(res.dtheta[-1], 0.0, atol=1e-9)
    # the normal forces carry the weight (after the first sample: the state before the
    # start's contacts were closed)
    total = res.contact_force[1:, :, 0].sum(axis=1)
    np.testing.assert_allclose(total, scene.parameters["mass"] * cf.G, rtol=1e-8)
    assert_coulomb(res, scene.mechanism)
    _energy_never_rises_between_impacts(res)


@pytest.mark.parametrize("mu", [0.3, 0.5, float(np.tan(np.radians(30))) * (1 + 1e-6), 0.7])
def test_box_on_incline_holds_iff_mu_at_least_tan_else_accelerates(mu):
    scene = ci.load_scene("incline_box", slope_deg=30.0, mu=mu)
    res = ci.simulate(scene, t_span=(0.0, 1.0))
    assert res.status == 0
    slope = np.radians(30.0)
    a = cf.incline(mu, slope)
    down = np.asarray(scene.parameters["down_direction"], float)
    travelled = (res.theta[:, :2] - scene.theta0[:2]) @ down
    if a == 0.0:
        assert {iv.mode for iv in res.mode_intervals} == {"stick"}
        np.testing.assert_allclose(travelled, 0.0, atol=1e-12)
    else:
        assert {iv.mode for iv in res.mode_intervals} == {"slip"}
        np.testing.assert_allclose(travelled, 0.5 * a * res.t ** 2, rtol=REL, atol=1e-12)
    assert_coulomb(res, scene.mechanism)


def test_rocking_block_lands_at_housners_time_and_its_pivot_never_slides():
    scene = ci.load_scene("rocking_block")
    p = scene.parameters
    res = ci.simulate(scene, t_span=(0.0, 1.5), dense_output=True)
    assert res.status == 0
    t_land = cf.housner_first_landing_time(p["tilt"], p["alpha"], p["R"])
    first = res.impacts[0]
    assert first.time == pytest.approx(t_land, rel=REL)
    assert first.contacts == (p["lifted"],) and p["pivot"] in first.released
    # angular velocity ratio at the landing: Housner's r = 1 - 1.5 sin^2 alpha
    assert first.dtheta_plus[2] / first.dtheta_minus[2] == pytest.approx(
        cf.housner_restitution(p["alpha"]), rel=REL)
    # the next amplitude, from the dense output, against the amplitude map
    nxt = res.impacts[1].time
    peak = minimize_scalar(lambda t: -abs(res.sol(t)[2]), bounds=(first.time, nxt),
                           method="bounded", options={"xatol": 1e-10})
    assert abs(res.sol(peak.x)[2]) == pytest.approx(
        cf.housner_amplitude_map(p["tilt"], p["alpha"]), rel=REL)
    # a pivot never slides: every closed interval of either corner is a stick
    assert {iv.mode for iv in res.mode_intervals} <= {"open", "stick"}
    counts = assert_coulomb(res, scene.mechanism)
    assert counts["stick"] > 10


def test_rimless_wheel_steps_follow_mcgeers_map_and_the_stance_foot_sticks():
    scene = ci.load_scene("rimless_wheel")
    p = scene.parameters
    res = ci.simulate(scene, t_span=(0.0, 4.0))
    assert res.status == 0 and len(res.impacts) >= 4
    # angular velocity just before each strike: McGeer's step map from the first one
    w = p["omega_minus_first"]
    for ev in res.impacts:
        assert ev.dtheta_minus[2] == pytest.approx(w, rel=REL)
        assert ev.dtheta_plus[2] == pytest.approx(p["eta"] * w, rel=REL)
        w = cf.rimless_wheel_step_map(w, p["n_spokes"], p["slope"], p["leg_length"], p["rho"])
    assert {iv.mode for iv in res.mode_intervals} <= {"open", "stick"}
    assert_coulomb(res, scene.mechanism)


def test_rimless_wheel_on_its_limit_cycle_walks_at_mcgeers_steady_speed():
    scene = ci.load_scene("rimless_wheel")
    p = scene.parameters
    steady = ci.load_scene("rimless_wheel", omega0=p["omega_vertical_steady"])
    res = ci.simulate(steady, t_span=(0.0, 3.0))
    w_minus, w_plus = cf.rimless_wheel_steady_speed(p["n_spokes"], p["slope"],
                                                    p["leg_length"], p["rho"])
    assert len(res.impacts) >= 3
    for ev in res.impacts:
        assert ev.dtheta_minus[2] == pytest.approx(w_minus, rel=REL)
        assert ev.dtheta_plus[2] == pytest.approx(w_plus, rel=REL)


def test_painleve_rod_is_detected_and_recorded():
    scene = ci.load_scene("painleve_rod")
    p = scene.parameters
    res = ci.simulate(scene)
    assert res.status == 2 and "Painleve" in res.message and res.warnings
    (ev,) = res.painleve
    assert ev.time == 0.0 and ev.contacts == ("foot",) and ev.kind == "inconsistent"
    A = cf.painleve_effective_mass(p["angle"], p["mu"], p["slip_sign_along_lean"], p["mass"],
                                   p["half_length"])
    assert ev.effective_mass[0] == pytest.approx(A, rel=1e-9) and A < 0
    with pytest.raises(ci.PainleveError) as err:
        ci.simulate(scene, painleve="raise")
    assert err.value.result is not None and err.value.result.status == 2
    assert err.value.event.kind == "inconsistent"
    # below the critical mu the same rod slides on, its normal force positive
    ok = ci.simulate(ci.load_scene("painleve_rod", mu=0.5), t_span=(0.0, 0.2))
    assert ok.status == 0 and ok.painleve == ()


def test_a_contact_touching_at_rest_at_the_start_starts_closed():
    scene = ci.load_scene("sliding_box", v0=0.0)
    res = ci.simulate(scene, t_span=(0.0, 0.5))
    assert [iv.mode for iv in res.modes_of("left_corner")] == ["stick"]
    np.testing.assert_allclose(res.theta, np.broadcast_to(scene.theta0, res.theta.shape),
                               atol=1e-12)


def test_spatial_box_on_four_corners_slides_to_rest_in_its_launch_direction():
    """Four corners, three normal rows' worth of independent constraints: the normal forces
    are indeterminate (a table on four legs), the motion is not. The box stops after
    v0^2/(2 mu g) along its launch direction; the normal forces total m g, and at rest each
    corner carries m g / 4 (the max-margin distribution is the symmetric one)."""
    from convimpact.model import Joint, ModelBuilder
    b = ModelBuilder(planar=False)
    m, a, c, h, mu, v0, psi = 1.0, 0.4, 0.3, 0.2, 0.3, 0.8, 0.5
    inertia = np.diag([m * (c * c + h * h), m * (a * a + c * c), m * (a * a + h * h)]) / 12
    b.add_body("box", "ground", Joint.free(), m, (0, 0, 0), inertia, joint_name="float")
    for i, (sx, sz) in enumerate([(-1, -1), (1, -1), (1, 1), (-1, 1)]):
        b.add_contact(f"c{i}", body="box", point=(sx * a / 2, -h / 2, sz * c / 2),
                      normal=(0, 1, 0), plane_point=(0, 0, 0), e=0.0, mu=mu)
    mech = b.build().mechanism()
    th0 = np.zeros(6)
    th0[1] = h / 2
    dth0 = np.zeros(6)
    dth0[[0, 2]] = v0 * np.cos(psi), v0 * np.sin(psi)
    res = ci.simulate(mech, (0.0, 0.35), (th0, dth0))
    t_stop, d_stop = cf.box_stopping(v0, mu)
    for name in mech.contact_names:
        assert [iv.mode for iv in res.modes_of(name)] == ["slip", "stick"]
        assert res.modes_of(name)[1].t_start == pytest.approx(t_stop, rel=REL)
    np.testing.assert_allclose(res.theta[-1, [0, 2]], d_stop * np.array([np.cos(psi), np.sin(psi)]),
                               rtol=REL)
    normal = res.contact_force[1:, :, 0]
    np.testing.assert_allclose(normal.sum(axis=1), m * cf.G, rtol=1e-8)
    assert np.all(normal > 0.0)
    np.testing.assert_allclose(normal[res.contact_mode[1:, 0] == 1], m * cf.G / 4, rtol=1e-8)
    assert_coulomb(res, mech)
    _energy_never_rises_between_impacts(res)


def test_spatial_box_at_rest_off_centre_carries_the_least_squares_loads_without_squeezing():
    """Four corners, the centre of mass e off the middle along x: the normal forces are the
    least-squares solution of the three equilibrium equations (sum n = m g, sum x_i n_i =
    m g e, sum z_i n_i = 0 with corners at x_i = +-a/2, z_i = +-c/2), n_i = m g (1/4 +
    s_i e / (2 a)), and no tangential force: the lightly loaded corners bind, the heavily
    loaded ones could also squeeze each other without losing the largest margin; the least
    norm leaves them unsqueezed."""
    from convimpact.model import Joint, ModelBuilder
    b = ModelBuilder(planar=False)
    m, a, c, h, mu, e = 1.0, 0.4, 0.3, 0.2, 0.3, 0.05
    inertia = np.diag([m * (c * c + h * h), m * (a * a + c * c), m * (a * a + h * h)]) / 12
    b.add_body("box", "ground", Joint.free(), m, (0, 0, 0), inertia, joint_name="float")
    signs = [(-1, -1), (1, -1), (1, 1), (-1, 1)]
    for i, (sx, sz) in enumerate(signs):
        b.add_contact(f"c{i}", body="box", point=(sx * a / 2 - e, -h / 2, sz * c / 2),
                      normal=(0, 1, 0), plane_point=(0, 0, 0), e=0.0, mu=mu)
    mech = b.build().mechanism()
    th0 = np.zeros(6)
    th0[1] = h / 2
    res = ci.simulate(mech, (0.0, 0.2), (th0, np.zeros(6)))
    for name in mech.contact_names:
        assert [iv.mode for iv in res.modes_of(name)] == ["stick"]
    expected = m * cf.G * np.array([0.25 + sx * e / (2 * a) for sx, _ in signs])
    force = res.contact_force[1:]
    np.testing.assert_allclose(force[:, :, 0], np.broadcast_to(expected, force.shape[:2]),
                               rtol=1e-12)
    np.testing.assert_allclose(force[:, :, 1:], 0.0, atol=1e-12 * m * cf.G)
    assert_coulomb(res, mech)


def test_a_held_contact_whose_force_falls_through_zero_lifts_off():
    """Signorini's condition on a held contact: the double pendulum's tip, closed on the floor
    by a plastic strike, is pressed and then pulled by the swinging rods. At the instant its
    normal force crosses zero the closed and the open solutions of the force problem coincide;
    the contact must open there (it once stayed held and its force grew to -100 N)."""
    from convimpact.problems import pendulum_planar

    res = ci.simulate(pendulum_planar.make_scene(case="a", e=0.0, mu=0.0), (0.0, 1.2))
    force = np.asarray(res.contact_force)[:, 0, 0]
    assert float(np.max(force)) > 5.0  # it was pressed
    assert float(np.min(force)) >= -1e-9 * float(np.max(force))  # never pulled
    release = [ev for ev in res.contact_events if ev.kind == "release"]
    assert len(release) == 1
    after = np.asarray(res.t) > release[0].time + 0.05
    assert not np.asarray(res.held)[after].any()  # open after the release
