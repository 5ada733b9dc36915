"""fit_coefficients: e and mu recovered from trajectories written in closed form (not simulated),
the intervals' coverage and scaling, the identifiability verdicts, and bad input.

The data come from the closed forms of the scenes, never from the simulator under test:
the ball's flights are parabolas joined by Newton's law with Coulomb friction at a point
contact (v_y+ = -e v_y-, v_x+ = v_x - mu (1 + e) |v_y-| while that stays >= 0, else 0), and
the sliding box decelerates at mu g.
"""

import numpy as np
import pytest

from convimpact.errors import (NonFiniteError, ParameterError, ShapeError,
                                      UnknownOptionError)
from convimpact.problems._box import corner_normal_forces
from convimpact.scenes import load_scene
from convimpact.simulation import simulate
from convimpact.studies import (CoefficientFit, FitError, Observations, fit_coefficients,
                                synthetic_observations, with_coefficients)

G = 9.81
RADIUS = 0.1
HEIGHT = 1.0
#: integration tolerances of the noisy fits (the noise, not the integration, sets their error)
LOOSE = {"rtol": 1e-8, "atol": 1e-10}


def ball_states(times, e, mu, speed, height=HEIGHT, radius=RADIUS):
    """(x, y, x_dot, y_dot) of the bouncing ball at ``times``, in closed form (impacts
    resolved as in the module docstring; right-continuous at an impact)."""
    out = []
    for t in np.atleast_1d(times):
        s, x, y, vx, vy = 0.0, 0.0, height, speed, 0.0
        while True:
            # next impact: y + vy tau - g tau^2 / 2 = radius
            tau = (vy + np.sqrt(vy ** 2 + 2 * G * (y - radius))) / G
            if s + tau > t:
                d = t - s
                out.append((x + vx * d, y + vy * d - 0.5 * G * d * d, vx, vy - G * d))
                break
            s, x, y = s + tau, x + vx * tau, radius
            v_n = G * tau - vy  # approach speed
            vx = max(vx - mu * (1 + e) * v_n, 0.0)
            vy = e * v_n
    return np.array(out)


def apex_heights(e, n, height=HEIGHT, radius=RADIUS):
    """Heights of the ball's first n apexes above its contact height: e^(2k) (h - r)."""
    return (height - radius) * e ** (2 * np.arange(1, n + 1))


def ball_observations(times, e, mu, speed, noise=0.0, seed=None, channels=("x", "y")):
    states = ball_states(times, e, mu, speed)[:, [("x", "y", "x_dot", "y_dot").index(c)
                                                  for c in channels]]
    rng = np.random.default_rng(seed)
    return Observations(times, states + noise * rng.standard_normal(states.shape), channels)


def guess_ball(speed, e=0.6, mu=0.2):
    return load_scene("bouncing_ball", e=e, mu=mu, speed=speed)


# ------------------------------------------------------------------------------------------
# closed-form checks of the data themselves


def test_the_closed_form_data_bounce_with_the_heights_of_e():
    # e = sqrt(h_{k+1} / h_k) from the apexes of the generated trajectory
    e = 0.8
    t = np.linspace(0.0, 2.4, 24001)
    y = ball_states(t, e, 0.0, 0.0)[:, 1]
    peaks = [y[i] for i in range(1, len(y) - 1) if y[i - 1] < y[i] >= y[i + 1]]
    assert len(peaks) >= 2
    assert np.allclose(np.array(peaks[:2]) - RADIUS, apex_heights(e, 2), rtol=1e-6)
    assert np.sqrt((peaks[1] - RADIUS) / (peaks[0] - RADIUS)) == pytest.approx(e, rel=1e-6)


# ------------------------------------------------------------------------------------------
# recovery without noise


def test_bouncing_and_sliding_ball_recovers_e_and_mu_without_noise():
    times = np.linspace(0.05, 2.4, 48)
    obs = ball_observations(times, e=0.8, mu=0.1, speed=3.0)
    fit = fit_coefficients(guess_ball(3.0), obs)
    assert isinstance(fit, CoefficientFit) and fit.converged
    assert fit.estimate("e") == pytest.approx(0.8, abs=1e-7)
    assert fit.estimate("mu") == pytest.approx(0.1, abs=1e-7)
    assert fit.verdicts == {"e": "identified", "mu": "identified"}
    assert np.max(np.abs(fit.residuals)) < 1e-7
    assert fit.activity["floor"]["sliding_impacts"] >= 4
    # the scene's own coefficients were the starting point, and were not changed
    assert tuple(fit.initial) == (0.6, 0.2)
    assert fit.coefficients["floor"] == pytest.approx((0.8, 0.1), abs=1e-7)


# ------------------------------------------------------------------------------------------
# noise: coverage, the noise estimate, and the 1 / sqrt(N) scaling


def test_noisy_fits_cover_the_truth_and_match_their_spread():
    """Seeds 0-9: the truth inside the 95 % interval in at least 8 of the 10 fits (9.5
    expected; 7 or fewer has probability 1 %), and the scatter of the estimates over the seeds
    agrees with the reported standard errors (Monte Carlo: the standardised errors have a
    spread near 1; over 40 seeds it is 0.95, with 38 of 40 intervals covering)."""
    e, sigma = 0.7, 0.004
    times = np.linspace(0.05, 1.5, 40)
    covered, z = 0, []
    for seed in range(10):
        obs = ball_observations(times, e=e, mu=0.0, speed=0.0, noise=sigma, seed=seed,
                                channels=("y",))
        # (the cheaper derivatives for one parameter: three plain runs per iteration)
        fit = fit_coefficients(guess_ball(0.0, e=0.68), obs, parameters=("e",),
                               simulate_options=LOOSE, jacobian="finite-differences")
        lo, hi = fit.interval("e")
        covered += lo < e < hi
        # the residuals' estimate of the noise: within the chi-square range of 39 dof
        assert 0.6 * sigma < fit.noise[0] < 1.4 * sigma
        # Student's t with 39 degrees of freedom
        assert hi - lo == pytest.approx(2 * 2.022691 * fit.standard_errors[0], rel=1e-6)
        z.append((fit.estimate("e") - e) / fit.standard_errors[0])
    assert covered >= 8
    assert np.all(np.abs(z) < 3.5)
    assert 0.5 < np.std(z, ddof=1) < 1.6


def test_interval_width_scales_as_sigma_over_sqrt_n():
    e, mu, sigma = 0.8, 0.1, 0.003
    widths = {}
    for n in (30, 120):
        times = np.linspace(0.05, 2.4, n)
        obs = ball_observations(times, e=e, mu=mu, speed=3.0, noise=sigma, seed=3)
        fit = fit_coefficients(guess_ball(3.0, e=0.78, mu=0.11), obs, noise=sigma,
                               simulate_options=LOOSE)
        assert not fit.noise_estimated and fit.noise.tolist() == [sigma, sigma]
        for name, truth in (("e", e), ("mu", mu)):
            lo, hi = fit.interval(name)
            assert lo < truth < hi
        widths[n] = np.diff(fit.confidence_intervals, axis=1).ravel()
        # known noise: the interval is estimate -+ 1.96 standard errors
        assert widths[n] == pytest.approx(2 * 1.959964 * fit.standard_errors, rel=1e-6)
    # four times the samples over the same span: half the width
    assert widths[30] / widths[120] == pytest.approx([2.0, 2.0], rel=0.15)


def test_confidence_ellipse_is_the_covariance_contour():
    times = np.linspace(0.05, 2.4, 40)
    obs = ball_observations(times, e=0.8, mu=0.1, speed=3.0, noise=0.003, seed=5)
    fit = fit_coefficients(guess_ball(3.0, e=0.78, mu=0.11), obs, noise=0.003,
                           simulate_options=LOOSE)
    ring = fit.confidence_ellipse("e", "mu", points=64)
    d = ring - fit.estimates
    q = np.einsum("ij,jk,ik->i", d, np.linalg.inv(fit.covariance), d)
    assert q == pytest.approx(np.full(64, 5.991465), rel=1e-6)  # chi2(2) at 95 %
    # its extent along e is the 2-d (not the 1-d) quantile times the standard error
    half = 0.5 * (ring[:, 0].max() - ring[:, 0].min())
    assert half == pytest.approx(np.sqrt(5.991465) * fit.standard_errors[0], rel=1e-3)


def test_sensitivities_and_finite_differences_give_the_same_fit():
    """The two sources of the trajectory's derivatives (the simulator's sensitivities, the
    default, and central differences of whole runs): the same estimates and uncertainty."""
    times = np.linspace(0.05, 2.4, 30)
    obs = ball_observations(times, e=0.8, mu=0.1, speed=3.0, noise=0.003, seed=7)
    fits = {how: fit_coefficients(guess_ball(3.0, e=0.78, mu=0.11), obs, noise=0.003,
                                  jacobian=how)
            for how in ("sensitivities", "finite-differences")}
    exact, differenced = fits["sensitivities"], fits["finite-differences"]
    assert exact.jacobian == "sensitivities" and differenced.jacobian == "finite-differences"
    assert exact.estimates == pytest.approx(differenced.estimates, abs=1e-8)
    assert exact.standard_errors == pytest.approx(differenced.standard_errors, rel=1e-4)
    assert exact.singular_values == pytest.approx(differenced.singular_values, rel=1e-4)


def test_a_frictionless_truth_stops_mu_on_its_bound():
    # data without friction: the unconstrained optimum has mu < 0; the fit holds mu at 0
    times = np.linspace(0.05, 2.0, 30)
    obs = ball_observations(times, e=0.8, mu=0.0, speed=3.0, noise=0.003, seed=2)
    fit = fit_coefficients(guess_ball(3.0, e=0.75, mu=0.05), obs, noise=0.003,
                           jacobian="finite-differences", simulate_options=LOOSE)
    assert fit.estimate("mu") == 0.0
    assert fit.interval("mu")[0] == 0.0 and fit.interval("mu")[1] > 0.0
    assert any("lies on its bound" in n for n in fit.notes)
    lo, hi = fit.interval("e")
    assert lo < 0.8 < hi


def test_a_model_that_does_not_fit_is_said_so():
    # mu held at a wrong value: e alone cannot make up for it; with the noise given, the
    # residuals far above it are flagged (chi-square beyond its 99.9 % quantile)
    times = np.linspace(0.05, 1.2, 24)
    obs = ball_observations(times, e=0.8, mu=0.1, speed=3.0, noise=0.003, seed=1)
    fit = fit_coefficients(guess_ball(3.0, e=0.75, mu=0.3), obs, parameters=("e",),
                           noise=0.003, jacobian="finite-differences", simulate_options=LOOSE)
    assert fit.reduced_chi_square > 100
    assert any("does not fit" in n for n in fit.notes)
    good = fit_coefficients(guess_ball(3.0, e=0.75, mu=0.1), obs, parameters=("e",),
                            noise=0.003, jacobian="finite-differences", simulate_options=LOOSE)
    assert 0.5 < good.reduced_chi_square < 1.6  # chi-square / 47 dof
    assert not any("does not fit" in n for n in good.notes)


# ------------------------------------------------------------------------------------------
# identifiability


def test_mu_is_not_identifiable_when_the_ball_never_slides():
    times = np.linspace(0.05, 1.5, 40)
    obs = ball_observations(times, e=0.7, mu=0.0, speed=0.0, noise=0.003, seed=2)
    fit = fit_coefficients(guess_ball(0.0, e=0.6, mu=0.2), obs)
    assert fit.identifiable == {"e": True, "mu": False}
    assert fit.verdicts["mu"] == "not identifiable"
    assert fit.interval("mu") is None
    assert np.isnan(fit.standard_errors[1]) and np.isnan(fit.confidence_intervals[1]).all()
    assert fit.estimate("mu") == 0.2  # held at its start
    assert any("mu is not identifiable" in n and "never slides" in n for n in fit.notes)
    lo, hi = fit.interval("e")
    assert lo < 0.7 < hi
    with pytest.raises(ParameterError, match="not identifiable"):
        fit.confidence_ellipse("e", "mu")


def test_per_contact_rod_one_end_slides_the_other_sticks():
    """The rod's end_a slides at its impacts, end_b sticks: both e and mu[end_a] are
    estimated, mu[end_b] is not identifiable but bounded below by the friction its sticking
    impact needed -- checked by simulating just below (end_b then slides) and above."""
    truth = with_coefficients(load_scene("bouncing_rod"),
                              {"end_a": (0.7, 0.25), "end_b": (0.5, 0.4)})
    sigma = [0.003, 0.003, 0.01]
    obs = synthetic_observations(truth, np.arange(1, 36) / 50, ("x", "y", "phi"),
                                 noise=sigma, seed=4)
    guess = load_scene("bouncing_rod", e=0.6, mu=0.3)
    fit = fit_coefficients(guess, obs, per_contact=True, noise=sigma,
                           initial={"mu[end_a]": 0.2, "mu[end_b]": 0.6})
    for name, true in (("e[end_a]", 0.7), ("e[end_b]", 0.5), ("mu[end_a]", 0.25)):
        lo, hi = fit.interval(name)
        assert lo < true < hi, name
    assert fit.verdicts["mu[end_b]"] == "not identifiable"
    bound = fit.activity["end_b"]["stick_friction_ratio"]
    assert 0.3 < bound <= 0.4
    assert any(f"mu[end_b] >= {bound:.4g}" in n for n in fit.notes)
    e_b = fit.coefficients["end_b"][0]
    for factor, regime in ((0.98, "slide"), (1.02, "stick")):
        run = simulate(with_coefficients(guess, {**fit.coefficients,
                                                  "end_b": (e_b, factor * bound)}), (0, 0.7))
        assert [ev.regime[0] for ev in run.impacts if ev.contacts == ("end_b",)] == [regime]


def test_sliding_box_recovers_mu_from_its_parabola_and_says_e_is_not_identifiable():
    v0, mu = 3.0, 0.3
    box = load_scene("sliding_box", v0=v0, mu=0.4)
    times = np.linspace(0.05, 0.8, 30)
    x = box.theta0[0] + v0 * times - 0.5 * mu * G * times ** 2
    fit = fit_coefficients(box, Observations(times, x, ("x",)), initial={"e": 0.5})
    assert fit.verdicts == {"e": "not identifiable", "mu": "identified"}
    assert any("never impacts" in n or "no contact impacts" in n for n in fit.notes)
    assert fit.estimate("mu") == pytest.approx(mu, abs=1e-8)


def test_per_contact_friction_of_a_translating_box_is_only_a_combination():
    # the box translates: only the total friction mu_l N_l + mu_r N_r shows in x(t)
    v0, mu = 3.0, 0.3
    box = load_scene("sliding_box", v0=v0, mu=0.4)
    times = np.linspace(0.05, 0.8, 30)
    x = box.theta0[0] + v0 * times - 0.5 * mu * G * times ** 2
    fit = fit_coefficients(box, Observations(times, x, ("x",)), parameters=("mu",),
                           per_contact=True, jacobian="finite-differences")
    assert fit.parameter_names == ("mu[left_corner]", "mu[right_corner]")
    assert not any(fit.identifiable.values())
    assert any("only a combination" in n for n in fit.notes)
    assert fit.singular_values[1] < 1e-6 * fit.singular_values[0]
    # the combination itself is right: the corners' friction forces add up to mu m g, with
    # the normal forces of the box decelerating at mu g (moments about the centre)
    forces = corner_normal_forces(0.4, 0.2, 1.0 * G, -mu * 1.0 * G)
    total = sum(fit.estimate(f"mu[{c}]") * forces[c] for c in ("left_corner", "right_corner"))
    assert total == pytest.approx(mu * G, rel=1e-6)


# ------------------------------------------------------------------------------------------
# failure and bad input


def test_an_unconverged_fit_raises_with_its_last_iterate():
    obs = ball_observations(np.linspace(0.05, 2.4, 30), e=0.8, mu=0.1, speed=3.0)
    with pytest.raises(FitError, match="did not converge") as info:
        fit_coefficients(guess_ball(3.0, e=0.3, mu=0.5), obs, max_iterations=1)
    assert info.value.result.converged is False
    assert info.value.result.iterations == 1


@pytest.fixture(scope="module")
def small():
    times = np.linspace(0.05, 0.5, 5)
    return guess_ball(0.0), Observations(times, ball_states(times, 0.6, 0.0, 0.0)[:, 1], ("y",))


@pytest.mark.parametrize("kwargs, error, match", [
    (dict(noise="0.01"), ParameterError, "noise"),
    (dict(noise=True), ParameterError, "noise"),
    (dict(noise=-1.0), ParameterError, "noise"),
    (dict(noise=float("nan")), NonFiniteError, "noise"),
    (dict(noise=[0.1, 0.2]), ShapeError, "noise"),
    (dict(initial={"e": "0.5"}), ParameterError, "initial"),
    (dict(initial={"e": True}), ParameterError, "initial"),
    (dict(initial={"e": 1.5}), ParameterError, r"\[0, 1\]"),
    (dict(initial={"mu": -0.1}), ParameterError, "initial"),
    (dict(initial={"f": 0.1}), UnknownOptionError, "initial"),
    (dict(parameters=("e", "k")), UnknownOptionError, "'k'"),
    (dict(parameters=()), ParameterError, "parameters"),
    (dict(per_contact="yes"), ParameterError, "per_contact"),
    (dict(confidence_level=95), ParameterError, "confidence_level"),
    (dict(confidence_level="0.95"), ParameterError, "confidence_level"),
    (dict(max_iterations=2.5), ParameterError, "max_iterations"),
    (dict(max_iterations=True), ParameterError, "max_iterations"),
    (dict(jacobian="complex-step"), UnknownOptionError, "jacobian"),
    (dict(simulate_options={"t_eval": [0.1]}), ParameterError, "t_eval"),
    (dict(t0=0.2), ParameterError, "t0"),
])
def test_bad_arguments_raise_typed_errors(small, kwargs, error, match):
    scene, obs = small
    with pytest.raises(error, match=match):
        fit_coefficients(scene, obs, **kwargs)


@pytest.mark.parametrize("make, error, match", [
    (lambda: Observations([0.1, 0.2], ["a", "b"], ("y",)), ShapeError, "observed values"),
    (lambda: Observations([0.1, 0.2], [1.0, np.nan], ("y",)), NonFiniteError, "NaN"),
    (lambda: Observations([0.2, 0.1], [1.0, 1.0], ("y",)), ParameterError, "sorted"),
    (lambda: Observations([0.1, 0.2], [1.0, 1.0, 1.0], ("y",)), ShapeError, "one row"),
    (lambda: Observations([0.1, 0.2], [[1.0, 1.0]] * 2, ("y",)), ShapeError, "channel"),
    (lambda: Observations(["0.1"], [1.0], ("y",)), ShapeError, "times"),
    (lambda: Observations([True, False], [1.0, 1.0], ("y",)), ShapeError, "times"),
])
def test_bad_observations_raise_typed_errors(make, error, match):
    with pytest.raises(error, match=match):
        make()


def test_unknown_channel_and_wrong_data_type_are_named(small):
    scene, obs = small
    with pytest.raises(UnknownOptionError, match="'z'.*x, y"):
        fit_coefficients(scene, Observations(obs.times, obs.values, ("z",)))
    with pytest.raises(ParameterError, match="Observations"):
        fit_coefficients(scene, (obs.times, obs.values))
    with pytest.raises(ParameterError, match="cannot estimate"):
        fit_coefficients(scene, Observations(obs.times[:2], obs.values[:2], ("y",)))
