"""The scenes of problems/ through the simulator: oracles independent of the scene code.

Closed forms (the ball's bouncing sequence and accumulation time), conservation of energy
between impacts, the law's reported loss at each impact, loop closure through the impact,
and the impact jump against ``resolve_impact`` on the state the simulator located.
"""

from __future__ import annotations

import numpy as np
import pytest

import convimpact as ci
from convimpact.scenes import list_scenes, load_scene
from convimpact.simulation import simulate

G = 9.81

pytestmark = pytest.mark.skipif(
    not {"bouncing_ball", "bouncing_rod", "pendulum_planar", "pendulum_3d",
         "slider_crank"} <= set(list_scenes()), reason="scenes not available")


def _energy_bookkeeping(res, atol):
    """Total energy changes only by the law's loss at each impact, the velocity corrections
    of contacts switching to closed, and the work of sliding friction (never negative)."""
    E = res.total_energy
    for ev in res.impacts:
        assert ev.energy_loss == pytest.approx(ev.kinetic_energy_minus - ev.kinetic_energy_plus,
                                               abs=1e-10)
    lost = sum(ev.energy_loss for ev in res.impacts) - sum(c.energy_change
                                                           for c in res.contact_events)
    assert np.all(np.diff(res.friction_dissipation) >= -1e-12)
    lost += res.friction_dissipation[-1]
    assert E[0] - E[-1] == pytest.approx(lost, abs=atol)


def test_bouncing_ball_closed_form_sequence_and_rest():
    scene = load_scene("bouncing_ball", e=0.5, height=1.0, speed=0.2)
    res = simulate(scene, (0.0, 2.0), zeno_time_tol=1e-5)
    r = scene.parameters["radius"]
    h = 1.0 - r  # the centre falls h before the surface touches
    t1, v1 = np.sqrt(2 * h / G), np.sqrt(2 * G * h)
    t_inf = t1 + 2 * 0.5 * v1 / (G * (1 - 0.5))
    times = t1 + np.concatenate([[0.0], np.cumsum([2 * 0.5**j * v1 / G for j in range(1, 6)])])
    np.testing.assert_allclose([ev.time for ev in res.impacts[:6]], times, atol=1e-10)
    for j, ev in enumerate(res.impacts[:6]):
        assert ev.dtheta_plus[1] == pytest.approx(0.5 ** (j + 1) * v1, rel=1e-9)
    (persist,) = [c for c in res.contact_events if c.kind == "persist"]
    assert 0.0 <= t_inf - persist.time <= 1e-5
    # at rest on the floor afterwards, and the run goes on to the end, rolling... sliding on
    assert res.status == 0 and res.t[-1] == 2.0
    after = res.t > persist.time
    np.testing.assert_allclose(res.theta[after, 1], r, atol=1e-9)
    np.testing.assert_allclose(res.theta[after, 0], 0.2 * res.t[after], atol=1e-9)


def test_bouncing_rod_comes_to_rest():
    scene = load_scene("bouncing_rod")
    res = simulate(scene)
    assert res.status == 0 and res.t[-1] == scene.t_end
    assert res.held[-1] == 2  # both ends held: lying on the floor
    assert res.theta[-1, 1] == pytest.approx(0.0, abs=1e-9)
    assert np.sin(res.theta[-1, 2]) == pytest.approx(0.0, abs=1e-9)
    assert res.kinetic_energy[-1] == pytest.approx(0.0, abs=1e-10)
    assert len(res.impacts) < 500
    _energy_bookkeeping(res, atol=1e-6)


@pytest.mark.parametrize("name", ["pendulum_planar", "pendulum_3d"])
def test_double_pendulum_strikes_floor_repeatedly(name):
    scene = load_scene(name)
    res = simulate(scene)
    assert res.status == 0 and len(res.impacts) >= 3
    _energy_bookkeeping(res, atol=1e-6)
    mech = scene.mechanism
    for ev in res.impacts[:3]:
        assert abs(mech.contact_gap("tip", ev.theta)) <= 1e-8
        Jc = mech.contact_jacobian("tip", ev.theta)
        assert Jc[0] @ ev.dtheta_minus < 0.0  # approaching
        e, mu = mech.contact_parameters("tip")
        ref = ci.resolve_impact(mech.mass_matrix(ev.theta), Jc, ev.dtheta_minus, e, mu)
        np.testing.assert_allclose(ev.dtheta_plus, ref.dq_plus, atol=1e-10)
        # Newton's restitution on the normal (both laws of the default path, eq. 21)
        assert Jc[0] @ ev.dtheta_plus == pytest.approx(-e * (Jc[0] @ ev.dtheta_minus), rel=1e-8)


def test_slider_crank_closed_through_impact():
    scene = load_scene("slider_crank")
    res = simulate(scene)
    mech = scene.mechanism
    assert res.status == 0 and len(res.impacts) >= 1
    ev = res.impacts[0]
    assert ev.contacts == ("blocks",) and ev.loop_impulse.shape == (2,)
    C = mech.loop_jacobian(ev.theta)
    assert np.max(np.abs(C @ ev.dtheta_plus)) <= 1e-10
    # stated bounds over the whole run: |Psi| <= projection_tol, |C dq| at round-off
    assert res.max_loop_residual <= 1e-10
    assert res.max_loop_velocity_residual <= 1e-10
    # central impact, e = 0.83: eq. (21) and eq. (59) with the effective mass from a null space
    Jn = mech.contact_jacobian("blocks", ev.theta)[0]
    vn = Jn @ ev.dtheta_minus
    assert Jn @ ev.dtheta_plus == pytest.approx(-0.83 * vn, rel=1e-9)
    N = np.linalg.svd(C)[2][C.shape[0]:].T
    M = mech.mass_matrix(ev.theta)
    m_nn = Jn @ N @ np.linalg.solve(N.T @ M @ N, N.T @ Jn)
    assert ev.energy_loss == pytest.approx((1 - 0.83**2) * vn**2 / (2 * m_nn), rel=1e-9)
    # the regulator brings the crank back near omega_ref after the impact
    omega = scene.parameters["omega_ref"]
    late = res.t > 0.5 * scene.t_end
    assert np.mean(res.dtheta[late, 0]) == pytest.approx(omega, rel=0.1)


def test_cli_runs_a_real_scene_and_benchmarks_it(capsys, tmp_path):
    import json

    from convimpact import cli

    assert cli.main(["simulate", "bouncing_ball", "--json", "--t-end", "1.5"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["scene"] == "bouncing_ball" and out["n_impacts"] >= 10
    assert out["parameters"]["e"] == 0.5
    assert out["series"]["t"][-1] == 1.5
    assert cli.main(["simulate", "bouncing_ball", "--bench", "--repeats", "1", "--json",
                     "--out", str(tmp_path)]) == 0
    bench = json.loads(capsys.readouterr().out)
    (row,) = bench["rows"]
    assert row["scene"] == "bouncing_ball" and row["nfev"] > 0
    assert row["rhs_per_second"] > 0 and 0 <= row["impact_share"] <= 1
    assert (tmp_path / "simulation_benchmark.json").exists()
