"""Moreau–Jean on the contact engine (laws ccp and coulomb): closed forms, islands, warm starts.

Closed forms used (derived by hand, independent of the code):

* a block sliding on two corners with Coulomb friction decelerates at mu g and stops after
  v0^2 / (2 mu g) (both corners carry friction against the slip; no tipping for mu h < w);
* a stack of blocks at rest: per step of size h the contact impulses balance gravity, so the
  normal impulses across each interface sum to (weight of the blocks above it) x h, whatever
  their (statically indeterminate) split between the two corners;
* energy under gravity (V linear in q, so V(q+) - V(q) = -h f . v_{k+1} for theta = 1): a
  step changes E = T + V by r . u_{k+1} - (v_{k+1} - v_k)^T M (v_{k+1} - v_k) / 2 with
  u = J v, and with e = 0 both laws give r . u_{k+1} = -mu r_n |u_t| <= 0 (Coulomb) or 0
  (CCP), so E never rises (beyond round-off) for theta = 1. For theta = 1/2 the same algebra
  gives (r . u_k + r . u_{k+1}) / 2, and r . u_k (the impulse against the velocity at the
  step's start) has no sign: the midpoint scheme may gain energy on an impact step, by
  O(h) (measured in the bench section ``moreau-scale``), which is why the test takes theta = 1.
"""

from __future__ import annotations

import numpy as np
import pytest

from convimpact.bench.moreau_scenes import box_row
from convimpact.contacts import cones, engine
from convimpact.contacts.contact_problem import UncertifiedSolutionError
from convimpact.errors import ParameterError, UnknownOptionError
from convimpact.model import Joint, ModelBuilder
from convimpact.scenes import load_scene
from convimpact.simulation.moreau import simulate_moreau
from convimpact.simulation.moreau_kernels import natural_map_residual

G = 9.81


def _stack(n: int, mu: float = 0.5, width: float = 0.4, height: float = 0.2, mass=1.0):
    """Planar stack of n blocks: block 0 on the floor, block i's bottom corners on block
    i-1's top face (a plane of block i-1); resting exactly (gaps 0, velocities 0)."""
    b = ModelBuilder(planar=True)
    for i in range(n):
        b.add_body(f"b{i}", "ground", Joint.free(), mass, (0.0, 0.0),
                   mass * (width ** 2 + height ** 2) / 12, joint_name=f"f{i}")
        for side, sx in (("l", -0.5), ("r", 0.5)):
            if i == 0:
                b.add_contact(f"c{i}{side}", body="b0", point=(sx * width, -0.5 * height),
                              normal=(0.0, 1.0), mu=mu)
            else:
                b.add_contact(f"c{i}{side}", body=f"b{i}", point=(sx * width, -0.5 * height),
                              against=f"b{i - 1}", plane_point=(0.0, 0.5 * height),
                              normal=(0.0, 1.0), mu=mu)
    q = np.zeros(3 * n)
    q[1::3] = height * (0.5 + np.arange(n))
    return b.build().mechanism(), q, np.zeros(3 * n)


@pytest.mark.parametrize("h", [2e-3, 1e-3])
def test_sliding_box_stops_at_the_closed_form_distance(h):
    scene = load_scene("sliding_box")
    p = scene.parameters
    r = simulate_moreau(scene, (0.0, 1.2), h=h, law="coulomb")
    moved = r.theta[-1][0] - r.theta[0][0]
    assert abs(moved - p["stop_distance"]) <= 2 * p["v0"] * h   # O(h): v0 h per step error
    assert abs(r.dtheta[-1][0]) < 1e-9                         # it stays (static friction)
    assert r.settings["contact_solver"] == "engine" and r.contact_solver["problems"] > 0


@pytest.mark.parametrize("law", ["ccp", "coulomb"])
def test_resting_stack_impulses_balance_the_weights(law):
    n, h = 3, 2e-3
    mech, q, v = _stack(n)
    r = simulate_moreau(mech, (0.0, 10 * h), (q, v), h=h, law=law)
    # at rest throughout: no drift, no penetration
    assert np.max(np.abs(r.theta - q)) < 1e-12 and r.max_penetration < 1e-12
    from convimpact.simulation import moreau_engine as me

    # one step's impulses, through the same entry the loop uses
    ev = me.Evaluator(mech, mech.contact_names)
    qm = q.copy()
    M, gaps, J = ev.positions(qm)
    inv = me.inverse_mass(M, np.zeros((0, q.size)), me.GroupCache())
    v_free = h * (inv.G @ np.asarray(mech.generalized_forces(0.0, qm, v), float))
    b = np.einsum("cdk,k->cd", J, v_free)
    rr, _ = me.solve_step(np.arange(2 * n), J, b, np.full(2 * n, 0.5), inv,
                          coulomb=law == "coulomb", tol=1e-10, last=None, split=True,
                          counters=me.EngineCounters(), names=tuple(mech.contact_names))
    for i in range(n):
        assert rr[2 * i, 0] + rr[2 * i + 1, 0] == pytest.approx((n - i) * G * h, rel=1e-8)
        # no net friction across an interface (a self-balanced pair along it is as
        # indeterminate as the normal split, and within the certificate's tolerance)
        assert abs(rr[2 * i, 1] + rr[2 * i + 1, 1]) < 1e-9 * G * h


@pytest.mark.parametrize("law", ["ccp", "coulomb"])
def test_energy_never_rises_on_a_settling_pile(law):
    scene = load_scene("disc_pile", columns=4, rows=3)
    r = simulate_moreau(scene, (0.0, 0.4), h=2e-3, law=law, theta=1.0)
    E = r.total_energy
    assert r.max_active_contacts >= 8                    # the pile did form
    assert np.max(np.diff(E)) <= 1e-9 * np.max(np.abs(E))
    assert E[-1] < E[0] - 0.1                            # it settled (lost energy)


@pytest.mark.parametrize("law", ["ccp", "coulomb"])
@pytest.mark.parametrize("sliding", [True, False])
def test_islands_and_warm_starts_change_nothing_beyond_the_certificate(law, sliding):
    mech, q, v = box_row(3, sliding)
    span = (0.0, 0.06)
    base = simulate_moreau(mech, span, (q, v), h=2e-3, law=law)
    whole = simulate_moreau(mech, span, (q, v), h=2e-3, law=law, islands=False)
    cold = simulate_moreau(mech, span, (q, v), h=2e-3, law=law, warm_start=False)
    assert base.contact_solver["problems"] > whole.contact_solver["problems"]
    assert cold.contact_solver["warm_started"] == 0
    if not (law == "ccp" and sliding):
        # (CCP's sliding box lifts off, u_n = mu |u_t| > 0, so its contacts reopen: nothing
        # to warm-start from)
        assert base.contact_solver["warm_started"] > 0
    for other in (whole, cold):
        assert np.max(np.abs(other.dtheta - base.dtheta)) < 1e-7
        assert np.max(np.abs(other.theta - base.theta)) < 1e-9


def test_pile_islands_agree_with_the_whole_problem():
    scene = load_scene("disc_pile", columns=4, rows=2)
    a = simulate_moreau(scene, (0.0, 0.25), h=2e-3, law="ccp")
    b = simulate_moreau(scene, (0.0, 0.25), h=2e-3, law="ccp", islands=False)
    assert a.contact_solver["problems"] > b.contact_solver["problems"]
    assert np.max(np.abs(a.theta - b.theta)) < 1e-7


@pytest.mark.parametrize("coulomb", [False, True])
def test_engine_warm_start_reaches_the_cold_answer(coulomb):
    rng = np.random.default_rng(3)
    n, d = 6, 3
    A = rng.standard_normal((n * d, 9))
    W = A @ A.T / 9 + 0.1 * np.eye(n * d)
    b = rng.standard_normal(n * d)
    mu = np.full(n, 0.4)
    cold = engine.solve(W, b, mu, d, coulomb=coulomb, tol=1e-10)
    warm = engine.solve(W, b + 1e-4, mu, d, coulomb=coulomb, tol=1e-10, start=cold.impulse)
    ref = engine.solve(W, b + 1e-4, mu, d, coulomb=coulomb, tol=1e-10)
    assert warm.converged and warm.message == "converged (warm start)"
    # the residual recomputed here, and the velocities of the two answers
    res, u = cones.natural_map_residual(W, (b + 1e-4).reshape(n, d), mu, warm.impulse, coulomb)
    assert res <= 1e-10
    assert np.max(np.abs(u - ref.velocity)) < 1e-7


def test_compiled_residual_is_the_engines():
    rng = np.random.default_rng(5)
    for d in (2, 3):
        n = 5
        A = rng.standard_normal((n * d, n * d))
        W = A @ A.T
        b, r = rng.standard_normal(n * d), rng.standard_normal(n * d)
        mu = rng.uniform(0.0, 1.0, n)
        for coulomb in (False, True):
            expect, _ = cones.natural_map_residual(W, b.reshape(n, d), mu, r.reshape(n, d),
                                                   coulomb)
            assert natural_map_residual(W, b, mu, d, r, coulomb) == pytest.approx(expect,
                                                                                  rel=1e-12)


def test_an_uncertified_step_raises():
    mech, q, v = box_row(1, True)
    with pytest.raises(UncertifiedSolutionError, match="step"):
        simulate_moreau(mech, (0.0, 0.01), (q, v), h=2e-3, law="ccp",
                        impact_options={"tol": 1e-300})


def test_engine_path_options_are_checked():
    mech, q, v = box_row(1, False)
    with pytest.raises(UnknownOptionError):
        simulate_moreau(mech, (0.0, 0.01), (q, v), h=2e-3, law="ccp",
                        impact_options={"rho": 1.0})
    with pytest.raises(ParameterError):
        simulate_moreau(mech, (0.0, 0.01), (q, v), h=2e-3, law="ccp", warm_start="yes")
    with pytest.raises(ParameterError):
        simulate_moreau(mech, (0.0, 0.01), (q, v), h=2e-3, law="ccp",
                        impact_options={"tol": -1.0})


def test_disc_pile_declares_moreau_jean_and_lists_its_neighbours():
    scene = load_scene("disc_pile", columns=4, rows=2)
    assert scene.simulation["scheme"] == "moreau-jean"
    import convimpact.problems.disc_pile as pile

    c, radii = pile.layout(4, 2, 0)
    pairs = pile.neighbour_pairs(c, radii)
    # row 0 holds sites 0..3 (0.1 m apart), row 1 sites 4..6: neighbours in the row and
    # across the rows are candidates; sites 0.3 m apart are not
    assert (0, 1) in pairs and (0, 4) in pairs and (0, 3) not in pairs
    # an unlisted pair pushed into overlap is measured: disc 3 moved 1 cm into disc 0
    th = scene.theta0.copy()
    th[9:11] = th[0:2] + np.array([radii[0] + radii[3] - 0.01, 0.0])
    assert pile.unlisted_overlap(th, radii, pairs) == pytest.approx(0.01, abs=1e-12)
