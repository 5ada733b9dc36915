"""Periodic orbits (find_periodic_orbit) of the walkers, against closed forms, the papers'
numbers, an independent reduced model and finite differences in another chart."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import fsolve

from convimpact.errors import (NonFiniteError, ParameterError, ShapeError,
                                      UnknownOptionError)
from convimpact.scenes import load_scene
from convimpact.simulation import (PeriodicOrbitError, find_periodic_orbit, simulate,
                                   stride_map)


# ---- rimless wheel: closed form ----------------------------------------------------------


def _rimless_closed_form(slope_deg, n_spokes, rho, leg=1.0, g=9.81):
    """McGeer's wheel by hand: w+ = eta w- at a strike (angular momentum about the new
    foot), w-^2 = w+^2 + 4 (g / (l (1 + rho^2))) sin(alpha) sin(gamma) over a step (energy);
    P(w) = eta sqrt(w^2 + c), P'(w*) = eta^2 w* / P(w*) = eta^2."""
    alpha, gam = np.pi / n_spokes, np.radians(slope_deg)
    eta = (np.cos(2 * alpha) + rho ** 2) / (1 + rho ** 2)
    c = 4 * g / (leg * (1 + rho ** 2)) * np.sin(alpha) * np.sin(gam)
    w_plus = eta * np.sqrt(c / (1 - eta ** 2))
    return w_plus, eta ** 2, alpha - gam


@pytest.mark.parametrize("params", [{}, {"n_spokes": 6, "slope_deg": 12.0, "rho": 0.3,
                                         "omega0": 1.0}])
def test_rimless_wheel_fixed_point_and_multiplier_match_the_closed_form(params):
    from convimpact.problems import rimless_wheel

    orbit = rimless_wheel.periodic_gait(**params)
    w_plus, multiplier, lean_back = _rimless_closed_form(
        params.get("slope_deg", 5.0), params.get("n_spokes", 8), params.get("rho", 0.1))
    assert orbit.dtheta[2] == pytest.approx(w_plus, abs=1e-7)
    assert orbit.theta[2] == pytest.approx(-lean_back, abs=1e-9)  # phi: leaning back
    assert orbit.multipliers.shape == (1,)
    assert orbit.multipliers[0].real == pytest.approx(multiplier, abs=1e-6)
    assert orbit.stable and orbit.residual <= 1e-9
    assert orbit.held_contacts == ("foot0",) and orbit.section_contacts == ("foot1",)
    # the translation along the slope is the one trivial direction, removed by reduce
    (trivial,) = orbit.trivial_multipliers
    gam = np.radians(params.get("slope_deg", 5.0))
    assert abs(trivial.direction[:2] @ [np.cos(gam), np.sin(gam)]) == pytest.approx(1, abs=1e-6)
    assert trivial.value < 1e-6


def test_rimless_wheel_multiplier_from_the_state_transition_matrices():
    from convimpact.problems import rimless_wheel

    orbit = find_periodic_orbit(load_scene("rimless_wheel"), reduce=rimless_wheel.reduce,
                                jacobian="state-transition")
    _, multiplier, _ = _rimless_closed_form(5.0, 8, 0.1)
    assert orbit.jacobian_method == "state-transition"
    assert orbit.multipliers[0].real == pytest.approx(multiplier, abs=1e-6)


# ---- simplest walker: Garcia et al. and an independent reduced model -------------------


def _garcia_reduced_model(gamma):
    """Garcia et al.'s beta -> 0 equations, written here from the paper: theta'' =
    sin(theta - gamma), phi'' = theta'' + sin(phi) (theta'^2 - cos(theta - gamma)); heel
    strike at phi = 2 theta (the root after the legs have crossed, theta < 0), then
    theta+ = -theta-, theta_dot+ = cos(2 theta) theta_dot-, phi+ = -2 theta-,
    phi_dot+ = cos(2 theta)(1 - cos(2 theta)) theta_dot-. Returns the fixed point of the
    (theta, theta_dot) map and the eigenvalues of its central-difference Jacobian."""
    def rhs(t, y):
        th, ph, thd, phd = y
        thdd = np.sin(th - gamma)
        return [thd, phd, thdd, thdd + np.sin(ph) * (thd ** 2 - np.cos(th - gamma))]

    def collision(t, y):
        return y[1] - 2 * y[0]

    def stride(z):
        th, thd = z
        y0 = [th, 2 * th, thd, (1 - np.cos(2 * th)) * thd]
        sol = solve_ivp(rhs, (0, 6), y0, method="DOP853", rtol=1e-13, atol=1e-13,
                        events=collision)
        # the paper ignores the root at the legs' crossing (theta ~ 0): the strike is the
        # first root with the stance leg well forward
        th_m, _, thd_m, _ = next(y for y in sol.y_events[0] if y[0] < -0.05)
        return np.array([-th_m, np.cos(2 * th_m) * thd_m])

    z = fsolve(lambda z: stride(z) - z, [0.20031, -0.19983], xtol=1e-13)
    h = 1e-6
    J = np.column_stack([(stride(z + e) - stride(z - e)) / (2 * h) for e in h * np.eye(2)])
    return z, np.linalg.eigvals(J)


def test_simplest_walker_matches_garcia_and_a_reduced_model():
    from convimpact.problems import simplest_walker as sw

    orbit = sw.periodic_gait()
    g = sw.gait(orbit)
    # Garcia's numbers (beta -> 0); the scene's feet weigh beta = 1e-5: O(beta) shifts
    assert g["stance_angle"] == pytest.approx(0.20031090049483, abs=3e-6)
    assert g["stance_rate"] == pytest.approx(-0.19983247291764, abs=3e-6)
    assert g["interleg_angle"] == pytest.approx(-2 * g["stance_angle"], abs=1e-9)
    z, eig = _garcia_reduced_model(0.009)
    assert z == pytest.approx([0.20031090049483, -0.19983247291764], abs=1e-9)
    pair = orbit.multipliers[:2]
    # beta = 1e-5 moves them by ~1.5e-4, the differencing error is ~3e-5
    assert np.sort_complex(pair) == pytest.approx(np.sort_complex(eig), abs=3e-4)
    # the printed eigenvalues of Garcia's simulation code: -0.19120868949940 +/- 0.5563i
    assert abs(pair[0]) == pytest.approx(abs(-0.19120868949940 + 0.55633363687106j),
                                         abs=2e-3)
    # the third multiplier: the swing leg's pre-strike rate, forgotten as beta -> 0
    assert abs(orbit.multipliers[2]) < 1e-3
    assert orbit.stable and orbit.period == pytest.approx(3.8825, abs=1e-3)


# ---- compass gait: fixed point by plain simulation, multipliers by differences ---------


def test_compass_gait_fixed_point_and_multipliers_by_finite_differences():
    from convimpact.problems import compass_gait as cg

    scene = load_scene("compass_gait")
    orbit = cg.periodic_gait()
    g = cg.gait(orbit)
    # both feet on the slope at heel strike: the legs symmetric about the normal
    assert g["interleg_angle"] == pytest.approx(-2 * g["stance_angle"], abs=1e-9)
    # one stride by a plain simulation (default tolerances), legs switched by hand
    res = simulate(scene, (0.0, 2.0), (orbit.theta, orbit.dtheta), max_impacts=1)
    assert res.impacts[0].contacts == ("swing_foot",)
    assert res.impacts[0].released == ("stance_foot",)
    th, dth = cg.reduce(res.theta[-1], res.dtheta[-1])
    assert np.concatenate([th, dth]) == pytest.approx(orbit.state, abs=1e-6)
    assert res.impacts[0].time == pytest.approx(orbit.period, abs=1e-8)
    # the stride map in the papers' chart (stance angle, its rate, the interleg rate; the
    # interleg angle is -2 x stance angle on the section), differenced here
    from convimpact.problems._walker import stance_state

    def chart_map(u):
        y0 = stance_state(u[0], u[1], -2 * u[0], u[2], scene.parameters["slope"], 1.0)
        z, _ = stride_map(scene, y0, reduce=cg.reduce, t_max=3.0)
        v = cg.gait_parameters(z[:4], z[4:], scene.parameters["slope"])
        return np.array([v["stance_angle"], v["stance_rate"], v["interleg_rate"]])

    u0 = np.array([g["stance_angle"], g["stance_rate"], g["interleg_rate"]])
    assert chart_map(u0) == pytest.approx(u0, abs=1e-8)
    h = 1e-5
    J = np.column_stack([(chart_map(u0 + e) - chart_map(u0 - e)) / (2 * h)
                         for e in h * np.eye(3)])
    assert np.sort_complex(orbit.multipliers) == pytest.approx(
        np.sort_complex(np.linalg.eigvals(J)), abs=2e-4)
    assert orbit.stable
    names = sorted(t.name for t in orbit.trivial_multipliers)
    assert names == ["symmetry removed by reduce",
                     "time shift along the orbit (the section is the impact)"]


# ---- reduce and bad input -----------------------------------------------------------------


def test_the_leg_switch_relabels_the_legs_and_moves_the_new_stance_foot_to_the_origin():
    from convimpact.problems import compass_gait as cg
    from convimpact.problems._walker import stance_state

    scene = load_scene("compass_gait")
    slope = scene.parameters["slope"]
    # a heel-strike posture: stance leg 0.25 rad forward of the normal, swing 0.25 behind it
    th, dth = stance_state(-0.25, -1.0, 0.5, 0.7, slope, 1.0)
    th2, dth2 = cg.reduce(th, dth)
    # by hand: the swing leg's absolute angle phi_st + phi_sw becomes the stance leg's
    assert th2[2] == pytest.approx(th[2] + th[3]) and th2[3] == pytest.approx(-th[3])
    assert dth2[2] == pytest.approx(dth[2] + dth[3]) and dth2[3] == pytest.approx(-dth[3])
    assert dth2[:2] == pytest.approx(dth[:2])  # a translation keeps the hip's velocity
    foot = th2[:2] + [np.sin(th2[2]), -np.cos(th2[2])]
    assert foot == pytest.approx([0.0, 0.0], abs=1e-12)
    assert scene.mechanism.contact_gap("stance_foot", th2) == pytest.approx(0.0, abs=1e-12)
    # twice: the legs back in their roles, the other foot at the origin
    th3, _ = cg.reduce(th2, dth2)
    assert th3[2:] == pytest.approx(th[2:])


def test_without_reduce_a_walker_has_no_fixed_point():
    scene = load_scene("rimless_wheel")
    with pytest.raises(PeriodicOrbitError):
        find_periodic_orbit(scene, max_iterations=3)


def test_reduce_must_be_callable_and_return_the_state():
    scene = load_scene("rimless_wheel")
    with pytest.raises(ParameterError, match="reduce"):
        find_periodic_orbit(scene, reduce="leg switch")
    with pytest.raises(ShapeError, match="reduce"):
        find_periodic_orbit(scene, reduce=lambda th, dth: th)
    with pytest.raises(ShapeError):
        find_periodic_orbit(scene, reduce=lambda th, dth: (th[:2], dth))


@pytest.mark.parametrize("kwargs, error", [
    ({"section": "apex"}, UnknownOptionError),
    ({"jacobian": "complex-step"}, UnknownOptionError),
    ({"tol": "1e-9"}, ParameterError),
    ({"tol": True}, ParameterError),
    ({"tol": -1.0}, ParameterError),
    ({"max_iterations": 2.5}, ParameterError),
    ({"strides": 0}, ParameterError),
    ({"step": float("nan")}, NonFiniteError),
    ({"t_max": 0.0}, ParameterError),
    ({"y0": (np.zeros(3), np.full(3, np.nan))}, NonFiniteError),
    ({"y0": (np.zeros(2), np.zeros(3))}, ShapeError),
    ({"simulate_options": {"max_impacts": 3}}, ParameterError),
    ({"progress": 1}, ParameterError),
])
def test_bad_input_is_refused_with_a_typed_error(kwargs, error):
    scene = load_scene("rimless_wheel")
    with pytest.raises(error):
        find_periodic_orbit(scene, **kwargs)


def test_a_bare_mechanism_needs_a_start_and_a_longest_stride():
    mech = load_scene("rimless_wheel").mechanism
    with pytest.raises(ShapeError, match="y0"):
        find_periodic_orbit(mech)
    scene = load_scene("rimless_wheel")
    with pytest.raises(ShapeError, match="t_max"):
        find_periodic_orbit(mech, (scene.theta0, scene.dtheta0))


def test_no_strike_within_t_max_and_no_convergence_give_no_answer():
    from convimpact.problems import rimless_wheel

    scene = load_scene("rimless_wheel")
    with pytest.raises(PeriodicOrbitError, match="no impact within t_max"):
        find_periodic_orbit(scene, reduce=rimless_wheel.reduce, t_max=0.05)
    with pytest.raises(PeriodicOrbitError, match="did not converge"):
        find_periodic_orbit(scene, reduce=rimless_wheel.reduce, max_iterations=1, tol=1e-15)
