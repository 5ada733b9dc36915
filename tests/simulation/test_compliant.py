"""Compliant contact against closed forms of a free particle (no gravity) hitting a wall.

With penetration delta, rate u = delta_dot, onset rate v0 and F = k delta^n (1 + a u / v0):

* energy (e = 1, a = 0): m u^2 / 2 + k delta^(n+1) / (n + 1) is conserved, so
  delta_max = ((n + 1) m v0^2 / (2 k))^(1/(n+1)) and the duration is
  T = 2 delta_max / v0 * I_n,  I_n = int_0^1 dx / sqrt(1 - x^(n+1))
    = sqrt(pi) Gamma(1 + 1/(n+1)) / Gamma(1/2 + 1/(n+1)),
  hence T ~ k^(-1/(n+1)) (also with damping: a is independent of k, so the dimensionless
  problem depends on k only through the scale (m v0^2 / k)^(1/(n+1)));
* restitution: m u du / (1 + a u / v0) = -k delta^n d delta; integrated over an episode the
  right side vanishes, so int_{-v1}^{v0} u / (1 + s u) du = 0 with s = a / v0, i.e.
  a (1 + r) = ln((1 + a) / (1 - a r)), r = v1 / v0, independent of k, n and m.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import brentq
from scipy.special import gamma

from convimpact.errors import ParameterError, UnknownOptionError
from convimpact.scenes import load_scene
from convimpact.simulation import simulate_with
from convimpact.simulation.compliant import (
    CompliantResult,
    restitution_for,
    simulate_compliant,
)
from convimpact.simulation.testing import PointMass

V0 = 1.0


def hit(model="hunt-crossley", k=1e6, n=1.5, e=0.5, mu=0.0, vt=0.0, mass=1.0, **kw):
    pm = PointMass(mass=mass, g=0.0, e=e, mu=mu)
    return simulate_compliant(pm, (0.0, 0.15), (np.array([0.0, 0.02]), np.array([vt, -V0])),
                              model=model, stiffness=k, exponent=n, rtol=1e-10, atol=1e-13,
                              **kw)


def oracle_restitution(a: float) -> float:
    return brentq(lambda r: a * (1 + r) - math.log((1 + a) / (1 - a * r)), 1e-12,
                  min(1.0, 0.999999 / a))


@pytest.mark.parametrize("model,a_of_e", [
    ("hunt-crossley", lambda e: 1.5 * (1 - e)),
    ("lankarani-nikravesh", lambda e: 0.75 * (1 - e * e)),
])
@pytest.mark.parametrize("e", [0.5, 0.8, 0.95])
def test_effective_restitution_matches_the_exact_relation(model, a_of_e, e):
    if model == "lankarani-nikravesh" and e == 0.5:
        e = 0.7
    r = hit(model, e=e)
    assert isinstance(r, CompliantResult) and len(r.episodes) == 1
    ep = r.episodes[0]
    assert ep.approach_velocity == pytest.approx(-V0, abs=1e-9)
    assert ep.effective_restitution == pytest.approx(oracle_restitution(a_of_e(e)), abs=2e-6)
    # both models are built to restitute ~e as e -> 1 (their derivations' accuracy)
    if e >= 0.95:
        assert abs(ep.effective_restitution - e) < 0.01


@pytest.mark.parametrize("n", [1.0, 1.5])
def test_undamped_hertz_duration_and_penetration(n):
    k, m = 1e6, 2.0
    r = hit(e=1.0, k=k, n=n, mass=m)
    ep = r.episodes[0]
    dmax = ((n + 1) * m * V0 ** 2 / (2 * k)) ** (1 / (n + 1))
    I_n = math.sqrt(math.pi) * gamma(1 + 1 / (n + 1)) / gamma(0.5 + 1 / (n + 1))
    assert ep.duration == pytest.approx(2 * dmax / V0 * I_n, rel=1e-5)
    assert ep.max_penetration == pytest.approx(dmax, rel=1e-3)  # sampled at steps
    assert ep.effective_restitution == pytest.approx(1.0, abs=1e-6)


@pytest.mark.parametrize("model", ["hunt-crossley", "lankarani-nikravesh"])
def test_duration_scales_as_k_to_minus_one_over_n_plus_one(model):
    n = 1.5
    d1 = hit(model, k=1e5, n=n, e=0.8).episodes[0].duration
    d2 = hit(model, k=1e7, n=n, e=0.8).episodes[0].duration
    assert d1 / d2 == pytest.approx(100 ** (1 / (n + 1)), rel=1e-4)


def test_friction_impulse_bounded_by_mu_and_saturates_while_sliding():
    """|F_t| <= mu F_n at every instant, with equality up to (v_eps / v_t)^2 while the slip
    stays far above v_eps: the tangential change is mu times the normal one."""
    mu, e = 0.2, 0.5
    r = hit(e=e, mu=mu, vt=1.0, regularization_velocity=1e-4)
    ep = r.episodes[0]
    dvn = ep.dtheta_end[1] - ep.dtheta_start[1]
    dvt = ep.dtheta_end[0] - ep.dtheta_start[0]
    assert dvt < 0
    assert abs(dvt) == pytest.approx(mu * dvn, rel=1e-6)


def test_restitution_for_inverts_and_reports_the_reach():
    # HC reaches 0.5 (its e = 0 gives about 0.488); LN cannot go below about 0.663
    e_hc = restitution_for("hunt-crossley", 0.5)
    assert hit("hunt-crossley", e=e_hc).episodes[0].effective_restitution == pytest.approx(
        0.5, abs=1e-5)
    with pytest.raises(ParameterError):
        restitution_for("lankarani-nikravesh", 0.5)


def test_gravity_drop_stiffness_contact_steps_and_penetration():
    """Under gravity, a stiffer contact penetrates less (delta_max ~ k^(-1/(n+1))) and the
    integrator spends steps inside the contact (the stiffness's cost)."""
    pm = PointMass(e=0.9)
    runs = [simulate_compliant(pm, (0.0, 0.5), (np.array([0.0, 1.0]), np.zeros(2)),
                               model="lankarani-nikravesh", stiffness=k) for k in (1e5, 1e7)]
    p1, p2 = (r.max_penetration for r in runs)
    assert p1 / p2 == pytest.approx(100 ** (1 / 2.5), rel=0.05)
    assert all(r.n_contact_steps > 0 for r in runs)
    # the onset is located where the free fall meets the floor
    assert runs[1].episodes[0].t_start == pytest.approx(np.sqrt(2 / 9.81), abs=1e-8)


def test_closed_loop_keeps_constraints():
    scene = load_scene("slider_crank")
    r = simulate_with(scene, (0.0, 0.02), scheme="compliant", stiffness=1e7)
    assert r.status == 0 and len(r.episodes) == 1
    assert r.max_loop_residual <= 1e-9
    assert r.max_loop_velocity_residual <= 1e-8


def test_bad_input():
    pm = PointMass()
    y0 = (np.array([0.0, 1.0]), np.zeros(2))
    with pytest.raises(UnknownOptionError):
        simulate_compliant(pm, (0, 1), y0, model="kelvin", stiffness=1e6)
    with pytest.raises(ParameterError):
        simulate_compliant(pm, (0, 1), y0, stiffness=-1.0)
    with pytest.raises(ParameterError):
        simulate_compliant(pm, (0, 1), y0, stiffness=1e6, e=1.5)
    with pytest.raises(UnknownOptionError):
        simulate_compliant(pm, (0, 1), y0, stiffness={"wall": 1e6})
