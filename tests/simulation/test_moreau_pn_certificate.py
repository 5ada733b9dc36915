"""Law pereira-nikravesh in Moreau–Jean: resting islands answered by the certificate of
:mod:`convimpact.simulation.moreau_pn_kernels` (the law's answer without its search of every
active set), and the law's diagnostic of several admissible active sets kept as one warning
of the run (:mod:`convimpact.simulation.moreau_impact`)."""

import re
from types import SimpleNamespace

import numpy as np
import pytest

from convimpact.bench.moreau_scenes import BOX_MASS, GRAVITY, HALF, MU, box_row
from convimpact.impact.laws import pn_complementarity as pc
from convimpact.impact.laws import pn_complementarity_impulse as pimp
from convimpact.simulation import moreau_engine as me
from convimpact.simulation import moreau_impact as mi
from convimpact.simulation.moreau import simulate_moreau
from convimpact.simulation.moreau_impact import ImpactSolver

H = 2e-3
LAW = "pereira-nikravesh"


@pytest.fixture(scope="module", autouse=True)
def compiled_path():
    """The certificate runs once the law's compiled path is taken (a warm cache, or here)."""
    pimp.compile_kernels()


def _run(mech, q, v, span, certificate=True, prune=True):
    """``certificate=False``: resting islands searched; ``prune=False``: sliding islands
    searched in full on every step."""
    saved, saved_impulse = mi.ImpactSolver._certify, mi.several_contacts_impulse
    saved_islands = mi.PnIslands.applies
    if not certificate:
        mi.ImpactSolver._certify = lambda *args: None
    if not prune:
        mi.several_contacts_impulse = lambda *a: saved_impulse(*a[:5])
    if not (certificate and prune):  # nor the modes' one-call path (moreau_pn_islands)
        mi.PnIslands.applies = classmethod(lambda cls, *args: None)
    try:
        return simulate_moreau(mech, (0.0, span), (q, v), h=H, law=LAW)
    finally:
        mi.ImpactSolver._certify = saved
        mi.several_contacts_impulse = saved_impulse
        mi.PnIslands.applies = saved_islands


def _step(mech, q, v):
    """One step's data as the loop hands it to the solver (theta = 1/2 at q)."""
    ev = me.Evaluator(mech, mech.contact_names)
    M, _, J = ev.positions(q)
    C = np.zeros((0, q.size))
    inv = me.inverse_mass(M, C, me.GroupCache())
    v_free = v + H * (inv.G @ np.asarray(mech.generalized_forces(0.0, q, v), float))
    return SimpleNamespace(index=0, tm=H / 2, hk=H, qm=q, v=v, M=M, inv=inv, C=C,
                           v_free=v_free, sigma=np.zeros(0), active=np.arange(J.shape[0]),
                           Ja=J)


def test_a_resting_box_is_searched_once_then_certified_with_its_weight_on_four_corners():
    """First step of the resting mode: the law's search; the next: the certificate alone,
    whose answer is the closed form: each corner of a box at rest carries m g h / 4 (the
    least-norm share of the law's tie rule on four symmetric corners), no friction, v = 0."""
    n = 2
    mech, q, v = box_row(n, False)
    st = _step(mech, q, v)
    s = ImpactSolver(mech, law=LAW, method="auto", impact_options={}, e_t=None,
                     rest_velocity=1e-6)
    for searched, certified in ((n, 0), (n, n)):
        v_new, _ = s.solve(st)
        assert (s.checks, s.certified) == (searched, certified)
        assert np.max(np.abs(v_new)) < 1e-12
        pi = s.impulse.reshape(n, 4, 3)
        np.testing.assert_allclose(pi[:, :, 0], BOX_MASS * GRAVITY * H / 4, rtol=1e-12)
        assert np.max(np.abs(pi[:, :, 1:])) < 1e-15
    assert s.run_warnings() == ()


def _tilted_drop():
    mech, q, v = box_row(1, False)
    q = q.copy()
    q[2] += 0.02       # 2 cm above the floor
    q[3:5] = 0.05, 0.03  # tilted: lands on one corner, rocks onto the others
    return mech, q, v


@pytest.mark.parametrize("scene", ["rest", "drop"])
def test_trajectories_with_and_without_the_certificate_agree(scene):
    """The certificate changes no answer: the same trajectory (to round-off) as the law's
    search on every step, the same ambiguous steps and warning."""
    mech, q, v = box_row(2, False) if scene == "rest" else _tilted_drop()
    span = 0.06 if scene == "rest" else 0.3
    fast = _run(mech, q, v, span)
    slow = _run(mech, q, v, span, certificate=False)
    assert fast.contact_solver["certified"] > 0.8 * fast.n_contact_steps
    assert slow.contact_solver["certified"] == 0
    same = ("resolve_impact_calls", "largest_island", "ambiguous")
    assert [fast.contact_solver[k] for k in same] == [slow.contact_solver[k] for k in same]
    assert (fast.contact_solver["searched"] + fast.contact_solver["certified"]
            == slow.contact_solver["searched"])
    # the same warning but for the number of island steps searched
    searched = re.compile(r"of the \d+ island steps searched")
    assert [searched.sub("", w) for w in fast.warnings] == [searched.sub("", w)
                                                            for w in slow.warnings]
    assert len(fast.warnings) == (scene == "drop")
    np.testing.assert_allclose(fast.theta, slow.theta, rtol=0, atol=1e-14)
    np.testing.assert_allclose(fast.dtheta, slow.dtheta, rtol=0, atol=1e-12)
    if scene == "drop":  # it comes to rest on its face, at its half height
        assert np.max(np.abs(fast.dtheta[-1])) < 1e-9
        assert abs(fast.theta[-1, 2] - HALF[2]) < 1e-3


def test_a_sliding_box_warns_of_its_admissible_active_sets_on_the_modes_first_step():
    """A box sliding on four corners: the law finds several admissible active sets with
    different velocities (all four corners sliding, and three of them); the first step of
    the sliding mode is searched in full and warns, the next ones are searched without the
    dominated sets (pruned); the speed is Coulomb's, v0 - mu g t. Searched in full on every
    step instead, every step warns, with the same trajectory."""
    mech, q, v = box_row(1, True)
    res = _run(mech, q, v, 0.04)
    cs = res.contact_solver
    assert cs["certified"] == 0
    assert cs["ambiguous"] == cs["searched"] == 1
    assert cs["pruned"] == res.n_steps - 1 == 19
    (warning,) = res.warnings
    assert "several admissible active sets with different velocities on 1 of the 1" in warning
    assert "t = 0.001)" in warning
    np.testing.assert_allclose(res.dtheta[-1, 0], 2.0 - MU * GRAVITY * 0.04, rtol=1e-9)
    full = _run(mech, q, v, 0.04, prune=False)
    assert full.contact_solver["ambiguous"] == full.contact_solver["searched"] == 20
    assert "on 20 of the 20" in full.warnings[0] and "t = 0.001, 0.003" in full.warnings[0]
    np.testing.assert_allclose(res.theta, full.theta, rtol=0, atol=1e-14)
    np.testing.assert_allclose(res.dtheta, full.dtheta, rtol=0, atol=1e-12)


def test_a_box_that_stops_is_searched_once_sliding_and_once_at_rest():
    """Sliding at v0 = mu g t_stop, the box stops after t_stop (Coulomb, to one step): the
    first sliding step is searched in full (and ambiguous), the next sliding ones pruned,
    the first resting step searched, then the resting mode is certified; the box stays at
    rest."""
    t_stop = 0.02
    mech, q, v = box_row(1, True)
    v = v.copy()
    v[0] = MU * GRAVITY * t_stop
    res = _run(mech, q, v, 0.06)
    speed = np.abs(res.dtheta[:, 0])
    moving = res.t[speed > 1e-12]
    assert abs(moving[-1] + H - t_stop) <= H + 1e-12
    cs = res.contact_solver
    sliding_steps = int(np.sum(speed[:-1] > 1e-12))
    assert cs["ambiguous"] >= 1
    assert cs["pruned"] >= sliding_steps - 2
    assert cs["searched"] <= 4
    assert cs["certified"] + cs["searched"] + cs["pruned"] == res.n_steps
    assert np.max(np.abs(res.dtheta[-1])) < 1e-12
    assert len(res.warnings) == 1


def _certify_one_box(sliding=False, mu=MU, e_eff=0.0):
    """certify_islands on one box's four corners: (status, impulses (4, 3))."""
    from convimpact.impact.problem.build import IMMOBILE_RTOL, TINY_NORMAL
    from convimpact.simulation.moreau_pn_kernels import certify_islands

    mech, q, v = box_row(1, sliding)
    st = _step(mech, q, v)
    Ja = np.ascontiguousarray(st.Ja)
    r, v_new, status = np.zeros((4, 3)), st.v_free.copy(), np.zeros(1, dtype=np.int64)
    mus = np.full(4, MU)
    mus[0] = mu
    certify_islands(Ja, st.v_free, np.full(4, e_eff), mus, st.inv.G, np.arange(4),
                    np.array([0, 4]), np.arange(6), np.array([0, 6]), 3, pc.STICK_COND_MAX,
                    pc.CONE_RTOL, pc.VELOCITY_SLACK_MAX, IMMOBILE_RTOL, TINY_NORMAL, r, v_new,
                    status)
    return int(status[0]), r, v_new


def test_the_certificate_holds_only_where_its_argument_does():
    """Resting box: certified, m g h / 4 per corner and v = 0 (closed form). It declines
    (the law searches) where sticking on every contact is not the least T+ over every
    impulse: the box sliding (no sticking set is admissible), a frictionless corner (its
    tangent rows are not stuck), restitution acting (b != v-: u_n = -e v_n- is not 0)."""
    from convimpact.simulation.moreau_pn_kernels import SEARCH, STICK

    status, r, v_new = _certify_one_box()
    assert status == STICK
    np.testing.assert_allclose(r[:, 0], BOX_MASS * GRAVITY * H / 4, rtol=1e-12)
    assert np.max(np.abs(r[:, 1:])) < 1e-15 and np.max(np.abs(v_new)) < 1e-12
    assert _certify_one_box(sliding=True)[0] == SEARCH
    assert _certify_one_box(mu=0.0)[0] == SEARCH
    assert _certify_one_box(e_eff=0.5)[0] == SEARCH
