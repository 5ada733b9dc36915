"""Trajectory sensitivities of the event-driven scheme (``simulate(..., sensitivities=True)``).

Every derivative is checked against a second method: closed forms derived here by hand (the
bouncing ball, the box sliding to rest) and central finite differences of whole simulations
run at tight tolerances (rtol 1e-11, event_tol 1e-13), the perturbations small enough for
the run to keep its sequence of events and modes.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from convimpact.errors import NotSupportedError, ParameterError
from convimpact.problems import (bouncing_ball, bouncing_rod, pendulum_planar, rocking_block,
                                 slider_crank, sliding_box)
from convimpact.simulation import simulate, simulate_with

G = 9.81
TIGHT = dict(rtol=1e-11, atol=1e-12, event_tol=1e-13)
#: step of the finite differences of whole simulations: their round-off (~1e-12) over the
#: step leaves ~1e-6 of noise, their truncation ~h^2 ~1e-12
H = 1e-6


def final_state(res) -> np.ndarray:
    return np.concatenate([res.theta[-1], res.dtheta[-1]])


def fd_state(scene, span, directions, **options) -> np.ndarray:
    """d x(t_final) / d x(t0) along ``directions`` (columns), central differences."""
    x0 = np.concatenate([scene.theta0, scene.dtheta0])
    k = len(scene.theta0)
    cols = []
    for d in np.asarray(directions, float).T:
        xp, xm = x0 + H * d, x0 - H * d
        rp = simulate(scene, span, (xp[:k], xp[k:]), **options)
        rm = simulate(scene, span, (xm[:k], xm[k:]), **options)
        cols.append((final_state(rp) - final_state(rm)) / (2 * H))
    return np.array(cols).T


def fd_parameter(make, parameters, name, span, **options) -> np.ndarray:
    """d x(t_final) / d parameter (the scene's one coefficient shared by its contacts)."""
    up = make(**{**parameters, name: parameters[name] + H})
    down = make(**{**parameters, name: parameters[name] - H})
    return (final_state(simulate(up, span, **options))
            - final_state(simulate(down, span, **options))) / (2 * H)


def assert_close(actual, expected, rtol=2e-5):
    scale = max(1.0, float(np.max(np.abs(expected))))
    np.testing.assert_allclose(actual, expected, rtol=rtol, atol=rtol * scale)


# ---- the bouncing ball: closed forms -------------------------------------------------------------
def ball_first_impact(height: float, radius: float) -> tuple[float, float]:
    """Time and speed of the first impact of a ball released from rest: the centre falls
    h' = height - radius, t1 = sqrt(2 h'/g), |v-| = g t1."""
    t1 = np.sqrt(2 * (height - radius) / G)
    return float(t1), float(G * t1)


@pytest.mark.parametrize("e", [0.5, 0.8])
def test_ball_saltation_is_the_classic_matrix(e):
    """Ball on the floor, x = (x, y, vx, vy): the impact reset R = diag(1, 1, 1, -e) on a gap
    g = y - r with g_x = (0, 1, 0, 0), x_dot- = (vx, v-, 0, -g), x_dot+ = (vx, -e v-, 0, -g):
    S = R + (x_dot+ - R x_dot-) g_x / v- has S_yy = 1 + (-e v- - v-)/v- = -e,
    S_vy,y = (-g - e g)/v- = (1 + e) g / |v-|, S_vy,vy = -e, the x and vx rows unchanged."""
    scene = bouncing_ball.make_scene(e=e, mu=0.0, height=1.0, speed=0.3)
    res = simulate(scene, (0.0, 0.6), sensitivities=True, **TIGHT)
    t1, v = ball_first_impact(1.0, 0.1)
    S = res.impacts[0].saltation
    expected = np.eye(4)
    expected[1, 1] = -e
    expected[3, 1] = (1 + e) * G / v
    expected[3, 3] = -e
    np.testing.assert_allclose(S, expected, atol=1e-7)
    rec = res.event_sensitivities[0]
    assert rec.kind == "impact" and rec.contacts == ("floor",) and rec.switching == "gap"
    # the impact time moves by -dy/v-: d tau/dy = 1/|v-|
    np.testing.assert_allclose(rec.time_gradient, [0.0, 1.0 / v, 0.0, 0.0], atol=1e-9)


@pytest.mark.parametrize("e, integrator", [(0.5, "DOP853"), (0.8, "DOP853"), (0.5, "Radau"),
                                           (0.5, "RK45")])
def test_ball_final_state_derivatives_match_the_hand_derivation(e, integrator):
    """After one bounce, at T: y(T) = r + e V (T - t1) - g (T - t1)^2 / 2, v(T) = e V - g (T - t1)
    with V = g t1, t1 = sqrt(2 (h - r)/g), dt1/dh = 1/(g t1). Hence
    dy/de = V (T - t1), dv/de = V; dy/dh = ((1 + e)(T - t1) - e t1)/t1, dv/dh = (1 + e)/t1;
    x(T) = x0 + u T: dx/dx0 = 1, dx/du = T. Radau (implicit: solve_ivp on the variational
    equations) and RK45 (its steps followed) as well as the default DOP853."""
    T, u = 0.7, 0.3
    scene = bouncing_ball.make_scene(e=e, mu=0.0, height=1.0, speed=u)
    res = simulate(scene, (0.0, T), sensitivities=True, integrator=integrator, **TIGHT)
    assert len(res.impacts) == 1
    t1, V = ball_first_impact(1.0, 0.1)
    Phi = res.state_transition
    assert Phi.shape == (4, 4)
    np.testing.assert_allclose(Phi[1, 1], ((1 + e) * (T - t1) - e * t1) / t1, rtol=1e-8)
    np.testing.assert_allclose(Phi[3, 1], (1 + e) / t1, rtol=1e-8)
    np.testing.assert_allclose(Phi[0, [0, 2]], [1.0, T], rtol=1e-9)
    de = res.parameter_sensitivity["e"]
    assert de.shape == (4, 1) and res.parameter_sensitivity["mu"].shape == (4, 1)
    np.testing.assert_allclose(de[:, 0], [0.0, V * (T - t1), 0.0, V], rtol=1e-8, atol=1e-9)


def test_ball_state_just_after_the_impact_is_the_return_map():
    """On the section just after the impact (time moving with the perturbation): the centre
    is at y = r whatever h, so dy+/dh = 0 (the fixed-time derivative saltation @ Phi- is
    -e instead: the section moves the time); v+ = e g t1 with dt1/dh = 1/(g t1), so
    dv+/dh = e / t1; x+ = x0 + u t1, so dx+/dh = u / (g t1); and dv+/de = g t1."""
    e, u = 0.5, 0.3
    res = simulate(bouncing_ball.make_scene(e=e, mu=0.0, height=1.0, speed=u), (0.0, 0.6),
                   sensitivities=True, **TIGHT)
    t1, V = ball_first_impact(1.0, 0.1)
    at = res.event_sensitivities[0]
    np.testing.assert_allclose(at.state_transition[:, 1], [u / V, 0.0, 0.0, e / t1],
                               rtol=1e-8, atol=1e-9)
    np.testing.assert_allclose(at.parameter_sensitivity["e"][:, 0], [0.0, 0.0, 0.0, V],
                               rtol=1e-8, atol=1e-9)
    # the impact time: h - r + w t - g t^2/2 = 0 (w the initial vertical speed) gives
    # dt1/dh = 1/(g t1 - w) = 1/V, dt1/dw = t1/V = 1/g; e does not move it
    np.testing.assert_allclose(at.time_sensitivity["state"], [0.0, 1.0 / V, 0.0, 1.0 / G],
                               atol=1e-9)
    np.testing.assert_allclose(at.time_sensitivity["e"], [0.0], atol=1e-12)


def test_ball_sliding_impact_matches_finite_differences_of_whole_runs():
    """A frictional (sliding) impact: every column of dx/dx0 and d/d(e, mu)."""
    make = bouncing_ball.make_scene
    params = dict(e=0.6, mu=0.2, height=1.0, speed=3.0)
    scene = make(**params)
    span = (0.0, 0.8)
    res = simulate(scene, span, sensitivities=True, **TIGHT)
    assert res.impacts[0].regime == ("slide",)
    assert_close(res.state_transition, fd_state(scene, span, np.eye(4), **TIGHT))
    for name in ("e", "mu"):
        assert_close(res.parameter_sensitivity[name][:, 0],
                     fd_parameter(make, params, name, span, **TIGHT))


def test_sensitivities_at_t_eval_match_finite_differences_of_the_samples():
    scene = bouncing_ball.make_scene(e=0.5, mu=0.0, height=1.0, speed=0.3)
    t_eval = np.linspace(0.0, 0.7, 8)  # the impact at 0.428 lies between samples
    res = simulate(scene, (0.0, 0.7), t_eval=t_eval, sensitivities=True, **TIGHT)
    series = res.sensitivity_series
    np.testing.assert_array_equal(series["t"], t_eval)
    assert series["state"].shape == (8, 4, 4) and series["e"].shape == (8, 4, 1)
    x0 = np.concatenate([scene.theta0, scene.dtheta0])
    for j in (1, 3):  # the height and the vertical speed
        d = np.zeros(4)
        d[j] = H
        samples = [simulate(scene, (0.0, 0.7), (x[:2], x[2:]), t_eval=t_eval, **TIGHT)
                   for x in (x0 + d, x0 - d)]
        fd = (np.hstack([samples[0].theta, samples[0].dtheta])
              - np.hstack([samples[1].theta, samples[1].dtheta])) / (2 * H)
        assert_close(series["state"][:, :, j], fd)


# ---- a double pendulum striking the floor: impacts and flight ------------------------------------
def test_pendulum_striking_the_floor_matches_finite_differences():
    make = pendulum_planar.make_scene
    params = dict(case="a", e=0.5, mu=0.3)
    scene = make(**params)
    span = (0.0, 0.8)
    res = simulate(scene, span, sensitivities=True, **TIGHT)
    assert len(res.impacts) == 2  # two sliding impacts of the tip, flight between
    assert all(ev.saltation is not None and ev.saltation.shape == (4, 4) for ev in res.impacts)
    assert_close(res.state_transition, fd_state(scene, span, np.eye(4), **TIGHT))
    for name in ("e", "mu"):
        assert_close(res.parameter_sensitivity[name][:, 0],
                     fd_parameter(make, params, name, span, **TIGHT))
    # on the section just after the second impact: its state and time as functions of x(0)
    second = res.event_sensitivities[1]
    x0 = np.concatenate([scene.theta0, scene.dtheta0])
    after, when = [], []
    for sign in (1.0, -1.0):
        cols, times = [], []
        for j in range(4):
            x = x0.copy()
            x[j] += sign * H
            ev = simulate(scene, span, (x[:2], x[2:]), **TIGHT).impacts[1]
            cols.append(np.concatenate([ev.theta, ev.dtheta_plus]))
            times.append(ev.time)
        after.append(np.array(cols).T)
        when.append(np.array(times))
    assert_close(second.state_transition, (after[0] - after[1]) / (2 * H))
    assert_close(second.time_sensitivity["state"], (when[0] - when[1]) / (2 * H))


def test_lift_off_of_a_held_contact_matches_finite_differences_of_whole_runs():
    """A plastic strike closes the tip on the floor (t = 0.4415 s); the held tip's normal
    force then falls through zero and the tip lifts off (t = 0.9055 s): the lift-off's
    saltation (a switched vector field, the state continuous) carries the transition."""
    scene = pendulum_planar.make_scene(case="a", e=0.0, mu=0.0)
    span = (0.0, 1.2)
    res = simulate(scene, span, sensitivities=True, **TIGHT)
    kinds = [ev.kind for ev in res.contact_events]
    assert kinds == ["persist", "release"]
    assert res.contact_events[1].time == pytest.approx(0.9055182, abs=1e-6)
    assert_close(res.state_transition, fd_state(scene, span, np.eye(4), **TIGHT))


# ---- the bouncing rod: frictional impacts with rotation ------------------------------------------
def test_spinning_rod_bouncing_on_its_ends_matches_finite_differences():
    make = bouncing_rod.make_scene
    params = dict(e=0.5, mu=0.3)
    # launched sideways and spinning, so that each impact slides (from rest the first impact
    # would start at zero slip, a mode boundary where the derivative is one-sided)
    scene = dataclasses.replace(make(**params), dtheta0=np.array([0.8, 0.0, 1.0]))
    span = (0.0, 0.7)
    res = simulate(scene, span, sensitivities=True, **TIGHT)
    assert [ev.contacts for ev in res.impacts] == [("end_a",), ("end_b",), ("end_a",)]
    assert not any(ev.one_sided for ev in res.event_sensitivities)
    assert_close(res.state_transition, fd_state(scene, span, np.eye(6), **TIGHT))
    sens = {name: res.parameter_sensitivity[name] for name in ("e", "mu")}
    assert sens["e"].shape == (6, 2)  # one column per contact (end_a, end_b)
    for name in ("e", "mu"):
        x0 = (scene.theta0, scene.dtheta0)

        def run(value):
            s = dataclasses.replace(make(**{**params, name: value}), dtheta0=x0[1])
            return final_state(simulate(s, span, **TIGHT))
        fd = (run(params[name] + H) - run(params[name] - H)) / (2 * H)
        assert_close(sens[name].sum(axis=1), fd)  # the scene's coefficient is both ends'


# ---- the rocking block: impacts that close one corner and release the other ---------------------
@pytest.mark.parametrize("e", [0.0, 0.3])
def test_rocking_block_matches_finite_differences_along_its_pivoting_motion(e):
    """Housner's block pivots on a corner, lands on the other (the first lifts off in the
    impact), rocks back (e = 0.3: the landings bounce until they accumulate). Perturbations
    that keep the corner on the floor: the initial tilt (the scene places the block on its
    corner, so the direction is the derivative of theta0) and a rate about the corner (the
    null direction of its contact Jacobian)."""
    span = (0.0, 1.2)

    def make(tilt=0.1, **changes):
        return rocking_block.make_scene(**{"e": e, "mu": 1.0, "tilt": tilt, **changes})
    scene = make()
    res = simulate(scene, span, sensitivities=True, **TIGHT)
    assert res.event_sensitivities[1].kind == "impact"
    assert res.impacts[0].released == ("right_corner",)
    Phi = res.state_transition
    d_tilt = (make(0.1 + H).theta0 - make(0.1 - H).theta0) / (2 * H)
    fd = (final_state(simulate(make(0.1 + H), span, **TIGHT))
          - final_state(simulate(make(0.1 - H), span, **TIGHT))) / (2 * H)
    assert_close(Phi[:, :3] @ d_tilt, fd)
    J = scene.mechanism.contact_jacobian("right_corner", scene.theta0)
    about_corner = np.linalg.svd(J)[2][-1]
    runs = [simulate(scene, span, (scene.theta0, s * H * about_corner), **TIGHT)
            for s in (1.0, -1.0)]
    assert_close(Phi[:, 3:] @ about_corner,
                 (final_state(runs[0]) - final_state(runs[1])) / (2 * H))
    if e > 0:
        fd_e = (final_state(simulate(make(e=e + H), span, **TIGHT))
                - final_state(simulate(make(e=e - H), span, **TIGHT))) / (2 * H)
        assert_close(res.parameter_sensitivity["e"].sum(axis=1), fd_e, rtol=1e-6)


# ---- a rod falling over on a rough floor: stick -> slip, then a slip reversal --------------------
def falling_rod(mu: float = 0.3, tilt: float = 80.0):
    """A uniform rod (1 m, 1 kg) standing on its end on the floor, tilted ``tilt`` degrees
    from the horizontal, released from rest: it pivots on its sticking end until the friction
    it needs exceeds mu times the normal force, then the end slides (and later reverses)."""
    from convimpact.model import Joint, ModelBuilder, place_resting

    b = ModelBuilder(planar=True)
    b.add_body("rod", "ground", Joint.free(), 1.0, (0.0, 0.0), 1.0 / 12.0, joint_name="float",
               coordinate_names=["x", "y", "phi"])
    b.add_contact("base", body="rod", point=(-0.5, 0.0), normal=(0.0, 1.0),
                  plane_point=(0.0, 0.0), e=0.0, mu=mu)
    mech = b.build().mechanism()
    phi = np.radians(tilt)
    guess = np.array([0.5 * np.cos(phi), 0.5 * np.sin(phi), phi])
    return mech, place_resting(mech, guess, ["base"], fixed=["phi"])


def test_falling_rod_stick_slip_and_slip_reversal_match_finite_differences():
    """Stick -> slip is located on the friction-cone margin mu lambda_n - |lambda_t|, which
    depends on mu: the parameter jump's g_mu term is checked by the mu column. The
    accelerations are continuous at the onset, so S is the identity on the admissible
    directions (a rate about the sticking end, say)."""
    span = (0.0, 0.7)
    mech, th0 = falling_rod()
    res = simulate(mech, span, (th0, np.zeros(3)), sensitivities=True, **TIGHT)
    kinds = [ev.kind for ev in res.event_sensitivities]
    assert kinds == ["start", "stick-slip", "slip-reversal"]
    onset = res.event_sensitivities[1]
    assert onset.switching == "friction margin" and onset.contacts == ("base",)
    th_onset = res.theta[np.searchsorted(res.t, onset.time)]
    turn = np.r_[0.0, 0.0, 0.0, np.linalg.svd(mech.contact_jacobian("base", th_onset))[2][-1]]
    np.testing.assert_allclose(onset.saltation @ turn, turn, atol=1e-7)
    d_tilt = (falling_rod(tilt=80.0 + H)[1] - falling_rod(tilt=80.0 - H)[1]) / (2 * H)
    about_end = np.linalg.svd(mech.contact_jacobian("base", th0))[2][-1]
    Phi = res.state_transition

    def run(mu=0.3, tilt=80.0, rate=0.0):
        m, th = falling_rod(mu, tilt)
        return final_state(simulate(m, span, (th, rate * about_end), **TIGHT))
    assert_close(Phi[:, :3] @ d_tilt, (run(tilt=80.0 + H) - run(tilt=80.0 - H)) / (2 * H))
    assert_close(Phi[:, 3:] @ about_end, (run(rate=H) - run(rate=-H)) / (2 * H))
    assert_close(res.parameter_sensitivity["mu"][:, 0], (run(mu=0.3 + H) - run(mu=0.3 - H)) / (2 * H))


def test_rod_dropped_from_rest_says_its_first_impact_is_one_sided():
    """Dropped from rest the rod's end hits with zero slip, where the sliding impact's
    tangent -sgn(v_t-) jumps: the derivative exists on each side only, and the run says so."""
    res = simulate(bouncing_rod.make_scene(), (0.0, 0.45), sensitivities=True)
    first = res.event_sensitivities[0]
    assert first.kind == "impact" and first.one_sided  # the law's statement of the boundary
    assert any(w.startswith("sensitivities: 1 event(s) with one-sided") for w in res.warnings)


# ---- the box sliding to rest: the slip -> stick transition ---------------------------------------
def test_box_sliding_to_rest_matches_the_closed_form_and_its_stop_saltation():
    """The box decelerates at mu g and stops at x0 + v0^2/(2 mu g) (then sticks): at the end
    dx/dx0 = 1, dx/dv0 = v0/(mu g), dx/dmu = -v0^2/(2 mu^2 g), every velocity derivative 0.
    At the stop (slip velocity g = -vx through zero, t = -x), x_dot- has ax = -mu g and
    x_dot+ has ax = 0, so S = I + (x_dot+ - x_dot-) g_x/(g_x x_dot-) zeroes vx's row (the
    box stops whatever its speed was)."""
    v0, mu = 3.0, 0.3
    scene = sliding_box.make_scene(v0=v0, mu=mu)
    span = (0.0, 1.5)
    res = simulate(scene, span, sensitivities=True, **TIGHT)
    kinds = [ev.kind for ev in res.event_sensitivities]
    assert kinds == ["start", "slip-stick"]
    stop = res.event_sensitivities[1]
    np.testing.assert_allclose(stop.time, v0 / (mu * G), rtol=1e-9)
    # the admissible directions (x, vx): S = [[1, 0], [0, 0]] there; velocities that would
    # violate the held corners (vy, phi_dot) are projected out by the reset (zero columns)
    S = stop.saltation
    np.testing.assert_allclose(S[np.ix_([0, 3], [0, 3])], [[1.0, 0.0], [0.0, 0.0]], atol=1e-7)
    np.testing.assert_allclose(S[3], 0.0, atol=1e-7)
    np.testing.assert_allclose(S[:, 4:], 0.0, atol=1e-7)
    Phi = res.state_transition
    np.testing.assert_allclose(Phi[0, 0], 1.0, rtol=1e-9)
    np.testing.assert_allclose(Phi[0, 3], v0 / (mu * G), rtol=1e-8)
    np.testing.assert_allclose(Phi[3:, :], 0.0, atol=1e-8)
    dmu = res.parameter_sensitivity["mu"]
    np.testing.assert_allclose(dmu[0].sum(), -v0 ** 2 / (2 * mu ** 2 * G), rtol=1e-8)
    np.testing.assert_allclose(res.parameter_sensitivity["e"], 0.0, atol=1e-12)
    # the derivatives along the floor, against finite differences of whole runs (a
    # perturbation out of the floor would start the box penetrating or flying)
    along = np.zeros((6, 2))
    along[0, 0] = along[3, 1] = 1.0
    assert_close(Phi @ along, fd_state(scene, span, along, **TIGHT))


# ---- a closed loop: the slider-crank striking a free slider -------------------------------------
def test_slider_crank_impact_through_its_loop_matches_finite_differences():
    """The loop (C, 2 rows) takes part in the impact and in the flow; the perturbed starts
    are assembled (theta onto Psi = 0, theta_dot onto C theta_dot = 0), and the analytic
    derivative is applied to the assembled direction."""
    from convimpact.simulation.initial import consistent_start

    scene = slider_crank.make_scene()
    th0 = scene.theta0.copy()
    th0[3] += 0.005  # the free slider starts 5 mm away: the impact comes at t > 0
    span = (0.0, 0.05)
    res = simulate(scene, span, (th0, scene.dtheta0), sensitivities=True, **TIGHT)
    assert len(res.impacts) == 1 and res.event_sensitivities[0].kind == "impact"

    def start(eps, j):
        th, dth = th0.copy(), scene.dtheta0.copy()
        (th if j < 4 else dth)[j % 4] += eps
        return consistent_start(scene.mechanism, th, dth, assemble=True,
                                projection_tol=1e-12, contact_tol=1e-8)
    for j in (0, 3, 4, 7):  # crank angle, free slider, their rates
        up, down = start(H, j), start(-H, j)
        direction = (np.concatenate(up) - np.concatenate(down)) / (2 * H)
        fd = (final_state(simulate(scene, span, up, **TIGHT))
              - final_state(simulate(scene, span, down, **TIGHT))) / (2 * H)
        assert_close(res.state_transition @ direction, fd)
    e = scene.parameters["e"]
    runs = [simulate(slider_crank.make_scene(e=e + s * H), span, (th0, scene.dtheta0), **TIGHT)
            for s in (1.0, -1.0)]
    assert_close(res.parameter_sensitivity["e"][:, 0],
                 (final_state(runs[0]) - final_state(runs[1])) / (2 * H))


# ---- an impact under constraints (loops, held contacts): the chain through C ---------------------
@pytest.mark.parametrize("seed", [3, 5, 8])
def test_impact_constraint_derivative_matches_differences_of_resolve_impact(seed):
    """d dq_plus along a perturbation dC of the constraint rows, the pre-impact velocity kept
    admissible (projected onto C dq = 0): the law's analytic jacobians chained through the
    constrained inverse (``constraint_derivative``) plus ``jacobian["dq"]`` times the
    projection's change, against central differences of resolve_impact itself."""
    from convimpact.impact import resolve_impact
    from convimpact.simulation.run_record import project_onto
    from convimpact.simulation.saltation import constraint_derivative

    rng = np.random.default_rng(seed)
    k = 4
    A = rng.normal(size=(k, k))
    M = A @ A.T + k * np.eye(k)
    J, C, dC = rng.normal(size=(2, k)), rng.normal(size=(1, k)), rng.normal(size=(1, k))
    dq0 = rng.normal(size=k)
    if J[0] @ project_onto(M, C, dq0) >= 0.0:
        dq0 = -dq0  # approaching

    def run(eps):
        Ce = C + eps * dC
        dq = project_onto(M, Ce, dq0)
        return np.asarray(resolve_impact(M, J, dq, 0.4, 0.3, Ce).dq_plus), dq

    dq = run(0.0)[1]
    res = resolve_impact(M, J, dq, 0.4, 0.3, C, derivatives=True)
    up, down = run(H), run(-H)
    fd = (up[0] - down[0]) / (2 * H)
    chained = (res.jacobian["dq"] @ ((up[1] - down[1]) / (2 * H))
               + constraint_derivative(res, M, J, C, dC[..., None])[:, 0])
    np.testing.assert_allclose(chained, fd, atol=1e-8 * max(1.0, np.max(np.abs(fd))))


# ---- the options ---------------------------------------------------------------------------------
def test_without_sensitivities_the_fields_are_empty():
    res = simulate(bouncing_ball.make_scene(), (0.0, 0.5))
    assert res.state_transition is None and not res.parameter_sensitivity
    assert res.event_sensitivities == () and res.impacts[0].saltation is None


@pytest.mark.parametrize("value", ["yes", 1, None, 1.0])
def test_sensitivities_must_be_a_boolean(value):
    with pytest.raises(ParameterError, match="sensitivities"):
        simulate(bouncing_ball.make_scene(), (0.0, 0.1), sensitivities=value)


def test_moreau_jean_refuses_sensitivities_naming_the_event_driven_scheme():
    with pytest.raises(NotSupportedError, match="event-driven"):
        simulate_with(bouncing_ball.make_scene(), (0.0, 0.1), scheme="moreau-jean", h=1e-3,
                      sensitivities=True)
    res = simulate_with(bouncing_ball.make_scene(), (0.0, 0.1), scheme="moreau-jean", h=1e-3,
                        sensitivities=False)
    assert res.state_transition is None
