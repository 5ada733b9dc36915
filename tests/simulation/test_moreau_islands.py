"""Moreau–Jean through ``resolve_impact`` island by island (:mod:`convimpact.simulation.
moreau_impact`): rows of boxes past pereira-nikravesh's 8 contacts per call against
Coulomb's closed form and the statics of a box at rest; the islands' answer against the
coupled single call (a second method) for laws whose problem separates; a loop keeps its
contacts in one island.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from convimpact.bench.moreau_scenes import BOX_MASS, GRAVITY, HALF, MU, box_row
from convimpact.errors import NotSupportedError
from convimpact.model import Joint, ModelBuilder
from convimpact.simulation import moreau_engine as me
from convimpact.simulation.moreau import simulate_moreau
from convimpact.simulation.moreau_impact import ImpactSolver

H = 2e-3


def _row(n: int, vx: float):
    mech, q, v = box_row(n, False)
    v[0::6] = vx
    return mech, q, v


def test_pereira_nikravesh_row_past_eight_contacts_slides_to_rest_by_coulomb():
    # 3 boxes, 12 corner contacts: sliding at v0, Coulomb's law gives v(t) = v0 - mu g t
    # until t* = v0 / (mu g) = 0.034 s, then rest; each step removes mu g h exactly
    v0, n = 0.1, 3
    mech, q, v = _row(n, v0)
    r = simulate_moreau(mech, (0.0, 0.05), (q, v), h=H, law="pereira-nikravesh")
    t = np.asarray(r.t)
    exact = np.maximum(v0 - MU * GRAVITY * t, 0.0)
    for i in range(n):
        np.testing.assert_allclose(r.dtheta[:, 6 * i], exact, rtol=0, atol=1e-12)
    assert np.all(r.dtheta[-1] == pytest.approx(0.0, abs=1e-12))  # stopped, stays
    np.testing.assert_allclose(r.theta[:, 2::6], HALF[2], rtol=0, atol=1e-12)  # no lift
    assert r.max_penetration < 1e-12
    # stopping distance: the discrete sum of v_k h (midpoint rule, theta = 1/2)
    k = np.arange(int(np.ceil(v0 / (MU * GRAVITY * H))) + 2)
    vk = np.maximum(v0 - MU * GRAVITY * H * k, 0.0)
    dist = float(np.sum(0.5 * (vk[:-1] + vk[1:])) * H)
    assert r.theta[-1][0] - q[0] == pytest.approx(dist, rel=1e-9)
    assert dist == pytest.approx(v0 ** 2 / (2 * MU * GRAVITY), rel=0.05)
    assert r.contact_solver["largest_island"] == 4
    assert r.contact_solver["resolve_impact_calls"] == n * (len(t) - 1)
    # the single call of all 12 contacts is refused by the law's definition
    with pytest.raises(NotSupportedError, match="at most 8"):
        simulate_moreau(mech, (0.0, 2 * H), (q, v), h=H, law="pereira-nikravesh",
                        islands=False)


@pytest.mark.parametrize("sliding", [True, False])
def test_direct_impulses_are_the_full_calls_on_the_interior_point_path(monkeypatch, sliding):
    """pereira-nikravesh islands on steps without an impact take the law's impulse directly
    (compiled stick tier, certified slides); the reference runs every island through
    resolve_impact on the Python path (Clarabel and its polish): the same trajectory."""
    from convimpact.impact.laws import pn_complementarity as pc
    from convimpact.simulation import moreau_impact as mi

    mech, q, v = box_row(2, sliding)
    span = (0.0, 10 * H)
    fast = simulate_moreau(mech, span, (q, v), h=H, law="pereira-nikravesh")
    monkeypatch.setattr(mi, "DIRECT_LAW", "none")
    monkeypatch.setattr(pc, "compiled_kernels", lambda: False)
    slow = simulate_moreau(mech, span, (q, v), h=H, law="pereira-nikravesh")
    calls = ("resolve_impact_calls", "largest_island")
    assert [fast.contact_solver[k] for k in calls] == [slow.contact_solver[k] for k in calls]
    np.testing.assert_allclose(fast.dtheta, slow.dtheta, rtol=0, atol=1e-12)
    np.testing.assert_allclose(fast.theta, slow.theta, rtol=0, atol=1e-14)


def _step(mech, q, v, C=None):
    """One step's data as the loop hands it to the solver (theta = 1/2 at q, no drift)."""
    ev = me.Evaluator(mech, mech.contact_names)
    M, _, J = ev.positions(q)
    C = np.zeros((0, q.size)) if C is None else C
    inv = me.inverse_mass(M, C, me.GroupCache())
    v_free = v + H * (inv.G @ np.asarray(mech.generalized_forces(0.0, q, v), float))
    return SimpleNamespace(index=0, tm=H / 2, hk=H, qm=q, v=v, M=M, inv=inv, C=C,
                           v_free=v_free, sigma=np.zeros(C.shape[0]),
                           active=np.arange(J.shape[0]), Ja=J)


@pytest.mark.parametrize("law", ["pereira-nikravesh", "stronge", "dissipative"])
def test_a_box_at_rest_carries_its_weight(law):
    n = 3
    mech, q, v = box_row(n, False)
    st = _step(mech, q, v)
    s = ImpactSolver(mech, law=law, method="auto", impact_options={}, e_t=None,
                     rest_velocity=1e-6)
    v_new, _ = s.solve(st)
    assert np.max(np.abs(v_new)) < 1e-12 and s.calls == n
    pi = s.impulse.reshape(n, 4, 3)
    corners = np.array([(sx * HALF[0], sy * HALF[1])
                        for sx, sy in ((-1, -1), (1, -1), (1, 1), (-1, 1))])
    w = BOX_MASS * GRAVITY * H
    for i in range(n):
        assert np.all(pi[i, :, 0] >= -1e-12 * w)
        assert pi[i, :, 0].sum() == pytest.approx(w, rel=1e-9)       # the weight
        # no net moment about the centre (x and y), no friction (to the laws' solver
        # tolerances: Stronge's integration and the interior point leave ~1e-9 w)
        assert abs(pi[i, :, 0] @ corners[:, 0]) < 1e-7 * w
        assert abs(pi[i, :, 0] @ corners[:, 1]) < 1e-7 * w
        assert np.max(np.abs(pi[i, :, 1:])) < 1e-7 * w
        # the symmetric (least-norm) share; P-N's equally dissipative active sets (all
        # four corners, a diagonal pair, three) tie, and it takes the largest set's
        # least-norm impulse
        np.testing.assert_allclose(pi[i, :, 0], w / 4, rtol=1e-6)


@pytest.mark.parametrize("law,method", [("dissipative", "clarabel"), ("ccp", "clarabel")])
def test_islands_answer_the_coupled_single_call(law, method):
    # two boxes: one sliding along x, one along y and spinning; 8 contacts in 2 islands
    # (slowly: the cone complementarity's u_n = mu |u_t| stays below g h, so the boxes keep
    # touching and every step has both islands)
    mech, q, v = box_row(2, False)
    v[0], v[7], v[11] = 0.01, 0.005, 0.02
    runs = [simulate_moreau(mech, (0.0, 10 * H), (q, v), h=H, law=law, method=method,
                            islands=split) for split in (True, False)]
    a, b = runs
    np.testing.assert_allclose(a.theta, b.theta, rtol=0, atol=1e-9)
    np.testing.assert_allclose(a.dtheta, b.dtheta, rtol=0, atol=1e-7)
    assert a.contact_solver["resolve_impact_calls"] == 2 * 10
    assert b.contact_solver["resolve_impact_calls"] == 10
    assert (a.contact_solver["largest_island"], b.contact_solver["largest_island"]) == (4, 8)


def _linkage_and_block(length=0.6, mass=1.0):
    """Planar: bars A and B end to end on the floor, pinned by a loop at A's right end and
    B's left end, each touching the floor at its outer end; a block C far away on its two
    corners. A and B are free joints of the tree: only the loop couples them."""
    b = ModelBuilder(planar=True)
    inertia = mass * length ** 2 / 12
    for name in ("A", "B", "C"):
        b.add_body(name, "ground", Joint.free(), mass, (0.0, 0.0), inertia,
                   joint_name=f"free_{name}")
    b.add_contact("A_end", body="A", point=(-length / 2, 0.0), normal=(0.0, 1.0), mu=0.4)
    b.add_contact("B_end", body="B", point=(length / 2, 0.0), normal=(0.0, 1.0), mu=0.4)
    b.add_contact("C_left", body="C", point=(-0.1, -0.05), normal=(0.0, 1.0), mu=0.4)
    b.add_contact("C_right", body="C", point=(0.1, -0.05), normal=(0.0, 1.0), mu=0.4)
    b.add_loop("pin", "revolute", "A", "B", origin_a=(length / 2, 0.0),
               origin_b=(-length / 2, 0.0))
    q = np.array([0.0, 0.0, 0.0, length, 0.0, 0.0, 5.0, 0.05, 0.0])
    v = np.array([0.3, -0.2, 0.0, 0.3, -0.2, 0.0, 0.0, -0.5, 0.0])
    return b.build().mechanism(), q, v


def test_an_island_touching_a_loop_stays_one_island():
    mech, q, v = _linkage_and_block()
    C = np.asarray(mech.loop_jacobian(q), float)
    # A's and B's contacts move disjoint coordinates, joined only through the loop
    st = _step(mech, q, v, C)
    s = ImpactSolver(mech, law="dissipative", method="auto", impact_options={}, e_t=None,
                     rest_velocity=1e-6)
    v_new, sigma = s.solve(st)
    assert s.calls == 2 and s.largest_island == 2          # {A_end, B_end} and {C}
    assert np.max(np.abs(C @ v_new)) < 1e-10 * np.max(np.abs(v))   # the pin holds
    # C's block lands plastically (e = 0) on both corners: v = 0 exactly, by symmetry
    assert np.max(np.abs(v_new[6:])) < 1e-9
    # the same step as one coupled call
    one = ImpactSolver(mech, law="dissipative", method="auto", impact_options={}, e_t=None,
                       rest_velocity=1e-6, islands=False)
    v_one, sigma_one = one.solve(st)
    np.testing.assert_allclose(v_new, v_one, rtol=0, atol=1e-8)
    np.testing.assert_allclose(sigma, sigma_one, rtol=0, atol=1e-8)
    np.testing.assert_allclose(s.impulse, one.impulse, rtol=0, atol=1e-8)
    assert one.calls == 1 and one.largest_island == 4


def test_a_row_landing_flat_is_one_impact_event_of_every_island():
    # 3 boxes touching the floor at 1 m/s downward, e = 0: on the first step every corner
    # takes the plastic impulse; v_free = -(1 + g h/1) on each box (gravity over the step),
    # so the law's energy loss is 3 x 1/2 m (1 + g h)^2 and each box takes m (1 + g h)
    n = 3
    mech, q, v = box_row(n, False)
    v[2::6] = -1.0
    r = simulate_moreau(mech, (0.0, 3 * H), (q, v), h=H, law="pereira-nikravesh")
    ev = r.impacts[0]
    assert ev.time == pytest.approx(H / 2)
    # the contacts listed are those with a normal impulse (P-N's stick tier may land a box
    # on a subset of its corners: the support of a flat box is indeterminate)
    names = list(mech.contact_names)
    pushed = {names[i] for i in np.flatnonzero(ev.impulse[:, 0] > 0.0)}
    assert set(ev.contacts) == pushed and {c.split("_")[0] for c in pushed} == {
        f"box{i}" for i in range(n)}
    assert ev.result is None                       # several islands: no single result
    vz = 1.0 + GRAVITY * H
    assert ev.energy_loss == pytest.approx(n * 0.5 * BOX_MASS * vz ** 2, rel=1e-12)
    np.testing.assert_allclose(ev.impulse[:, 0].reshape(n, 4).sum(axis=1), BOX_MASS * vz,
                               rtol=1e-12)
    np.testing.assert_allclose(ev.dtheta_plus, 0.0, atol=1e-12)
    assert ev.kinetic_energy_minus == pytest.approx(n * 0.5 * BOX_MASS, rel=1e-12)
    assert ev.kinetic_energy_plus == pytest.approx(0.0, abs=1e-20)
    assert set(ev.regime) <= {"stick", "separating"} and len(ev.regime) == 4 * n


def _landing_block(e: float, mu: float = 0.3):
    """Planar block (0.4 x 0.2 m, 1 kg) landing flat on its two corners at 1 m/s down and
    0.1 m/s sideways: both corners strike together and couple through the rotation; with
    e > 0 it bounces and lands again, then slides to rest. (Flat and slowly sideways: an
    active contact always approaches, the cone complementarity's lift mu |u_t| staying below
    g h; where one does not, the engine keeps its friction and resolve_impact's law drops
    it, a documented difference of the two paths.)"""
    b = ModelBuilder(planar=True)
    b.add_body("block", "ground", Joint.free(), 1.0, (0.0, 0.0), (0.4 ** 2 + 0.2 ** 2) / 12,
               joint_name="free")
    for name, sx in (("left", -0.2), ("right", 0.2)):
        b.add_contact(name, body="block", point=(sx, -0.1), normal=(0.0, 1.0), e=e, mu=mu)
    return b.build().mechanism(), np.array([0.0, 0.1, 0.0]), np.array([0.1, -1.0, 0.0])


@pytest.mark.parametrize("e", [0.0, 0.6])
def test_dissipative_on_the_engine_is_the_law_through_resolve_impact(e):
    # the engine solves ccp's plastic problem and scales by 1 + e_eff; resolve_impact
    # (method clarabel, island by island) runs the law's own program: a second method
    mech, q, v = _landing_block(e)
    runs = [simulate_moreau(mech, (0.0, 0.3), (q, v), h=H, law="dissipative", method=m,
                            impact_options=({"tol": 1e-10} if m == "auto" else {}))
            for m in ("auto", "clarabel")]
    a, b = runs
    assert a.settings.get("contact_solver") == "engine" and a.contact_solver["problems"] > 0
    assert b.contact_solver["resolve_impact_calls"] > 0
    assert len(a.impacts) == len(b.impacts) >= (2 if e else 1)  # it bounces with e > 0
    np.testing.assert_allclose(a.dtheta, b.dtheta, rtol=0, atol=1e-6)
    np.testing.assert_allclose(a.theta, b.theta, rtol=0, atol=1e-8)
    for x, y in zip(a.impacts, b.impacts):
        # J^T pi (unique; the split of the friction between the two corners is not)
        np.testing.assert_allclose(x.generalized_impulse, y.generalized_impulse, atol=1e-7)
        assert x.time == y.time and x.contacts == y.contacts
