"""law="stronge" through the library's entry points: resolve_impact's methods, the
diagnostics' energetic restitution, the scale-free dispatcher's extras, simulate on scenes.

Oracles: a second solver path (the conic entries against the kernel), Newton's law worked by
hand where it must differ from the energetic one, exact powers of two for units, and energy
conservation bookkeeping (T+ <= T- at every impact of a run).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import convimpact as ci
from convimpact.impact.diagnostics import energetic_residual
from convimpact.errors import NotSupportedError
from convimpact.impact.exact.dispatch import solve_contact

from .convex_systems import random_system


@pytest.mark.parametrize("d", [2, 3])
def test_methods_agree_and_auto_picks_the_kernel(d):
    for seed in range(6):
        M, Jc, dq, C = random_system(seed + 20, d, 1, seed % 2)
        auto = ci.resolve_impact(M, Jc, dq, e=0.5, mu=0.4, C=C, law="stronge")
        assert auto.method == "fast"
        for method in ("clarabel", "cvxpy"):
            r = ci.resolve_impact(M, Jc, dq, e=0.5, mu=0.4, C=C, law="stronge", method=method)
            np.testing.assert_allclose(r.impulse, auto.impulse, rtol=1e-12, atol=1e-14)
    for method in ("closed-form", "sweep"):
        with pytest.raises(NotSupportedError, match="stronge"):
            ci.resolve_impact(M, Jc, dq, e=0.5, mu=0.4, C=C, law="stronge", method=method)


def test_diagnostics_measure_energetic_not_newtons_restitution():
    """A rod struck off-centre: W_tn != 0, so Stronge's v_n+ differs from Newton's -e v_n-;
    the diagnostics measure the energetic condition (held) and Newton's gap is real."""
    M = np.diag([1.0, 1.0, 1.0 / 12.0])
    phi = math.radians(40.0)
    Jc = np.array([[0.0, 1.0, -0.5 * math.cos(phi)], [1.0, 0.0, 0.5 * math.sin(phi)]])
    dq = np.array([1.0, -1.0, 0.0])
    e = 0.5
    r = ci.resolve_impact(M, Jc, dq, e=e, mu=0.3, law="stronge")
    vn_minus, vn_plus = r.v_minus[0], r.v_plus[0]
    newton_gap = abs(vn_plus + e * vn_minus) / abs(vn_minus)
    assert newton_gap > 1e-3  # not Newton's law
    assert r.diagnostics.restitution_residual <= 1e-9
    assert r.diagnostics.held()["restitution"]
    ex = r.diagnostics.extras
    assert -ex["normal_work_restitution"] / ex["normal_work_compression"] == pytest.approx(
        e * e, rel=1e-9)
    # the works add up with friction's to the energy change, measured independently by eq. 58
    assert ex["normal_work_compression"] + ex["normal_work_restitution"] + \
        ex["friction_work"] == pytest.approx(-r.energy_loss, rel=1e-12)


def test_energetic_residual_by_hand():
    works = np.array([[-2.0, 0.5], [-1.0, 0.36], [0.0, 0.0]])  # e^2 = 0.25, 0.36 held exactly
    assert energetic_residual(works, np.array([0.5, 0.6, 0.3])) == pytest.approx(0.0, abs=1e-15)
    # contact 0 restores 0.5 of work where e = 0.6 wants 0.72: |0.5 - 0.72| / 2 = 0.11
    assert energetic_residual(works, np.array([0.6, 0.6, 0.3])) == pytest.approx(0.11)


@pytest.mark.parametrize("d", [2, 3])
def test_extras_carry_their_units_through_the_scale_free_dispatcher(d):
    """W 2^a, v 2^b: impulses scale by 2^(b - a), energies by 2^(2b - a), exactly."""
    rng = np.random.default_rng(60 + d)
    A = rng.normal(size=(d, d))
    W = A @ A.T + 0.5 * np.eye(d)
    v = rng.normal(size=d)
    v[0] = -abs(v[0])
    base = solve_contact(W, v, 0.6, 0.5, "stronge")
    a, b = 200, -170  # far outside the kernels' safe range: the dispatcher rescales
    far = solve_contact(W * 2.0 ** a, v * 2.0 ** b, 0.6, 0.5, "stronge")
    imp, en = 2.0 ** (b - a), 2.0 ** (2 * b - a)
    for key, unit in (("compression_impulse", imp), ("normal_work_compression", en),
                      ("normal_work_restitution", en), ("friction_work", en)):
        assert far.extras[key] == pytest.approx(base.extras[key] * unit, rel=1e-10), key
    np.testing.assert_allclose(np.array(far.extras["phase_impulses"]),
                               np.array(base.extras["phase_impulses"]) * imp, rtol=1e-10)
    assert far.extras["energetic_restitution"] == pytest.approx(0.6, rel=1e-10)


@pytest.mark.parametrize("scene", ["pendulum_planar", "pendulum_3d", "bouncing_rod"])
def test_simulate_scenes_under_stronge_never_gain_energy_at_an_impact(scene):
    from convimpact.scenes import load_scene

    res = ci.simulate(load_scene(scene), law="stronge")
    assert res.impacts
    for ev in res.impacts:
        assert ev.kinetic_energy_plus <= ev.kinetic_energy_minus * (1.0 + 1e-9) + 1e-12
        assert ev.result.law == "stronge"
    assert res.law_flags.get("energy_gained", 0) == 0
