"""Law pereira-nikravesh in Moreau–Jean: the islands of a resting or sliding mode answered in
one compiled call per step (:mod:`convimpact.simulation.moreau_pn_islands`), against the
law's full search through ``resolve_impact`` on the same states, the path without it, and
Coulomb's closed forms."""

from types import SimpleNamespace

import numpy as np
import pytest

from convimpact import resolve_impact
from convimpact.bench.moreau_scenes import BOX_MASS, GRAVITY, MU, box_row
from convimpact.impact.laws import pn_complementarity_impulse as pimp
from convimpact.simulation import moreau_engine as me
from convimpact.simulation import moreau_impact as mi
from convimpact.simulation import moreau_pn_islands as mpi
from convimpact.simulation.moreau import simulate_moreau
from convimpact.simulation.moreau_impact import ImpactSolver
from convimpact.simulation.moreau_step_kernels import dense_support

H = 2e-3
LAW = "pereira-nikravesh"


@pytest.fixture(scope="module", autouse=True)
def compiled_path():
    pimp.compile_kernels()


@pytest.fixture
def answered(monkeypatch):
    """Counts the island steps the one-call path answers over a test (every solver's)."""
    count = [0]
    solve = mpi.PnIslands.solve

    def counted(self, solver, st):
        before = self.answered
        out = solve(self, solver, st)
        count[0] += self.answered - before
        return out

    monkeypatch.setattr(mpi.PnIslands, "solve", counted)
    return count


def _run(mech, q, v, span, islands=True, own_search=False):
    """``islands=False``: without the one-call path (the solver's Python path on every
    island); ``own_search``: the law's own search (``_search``, ``_pick``) on every step."""
    saved, saved_impulse = mi.PnIslands.applies, pimp.compiled_impulse
    if not islands or own_search:
        mi.PnIslands.applies = classmethod(lambda cls, *args: None)
    if own_search:
        pimp.compiled_impulse = lambda *args: None
    try:
        return simulate_moreau(mech, (0.0, span), (q, v), h=H, law=LAW)
    finally:
        mi.PnIslands.applies, pimp.compiled_impulse = saved, saved_impulse


def _step(mech, q, v, index=0):
    """One step's data as the loop hands it to the solver (theta = 1/2 at q)."""
    ev = me.Evaluator(mech, mech.contact_names)
    M, _, J = ev.positions(q)
    C = np.zeros((0, q.size))
    inv = me.inverse_mass(M, C, me.GroupCache())
    v_free = v + H * (inv.G @ np.asarray(mech.generalized_forces(0.0, q, v), float))
    return SimpleNamespace(index=index, tm=H / 2, hk=H, qm=q, v=v, M=M, inv=inv, C=C,
                           v_free=v_free, sigma=np.zeros(0), active=np.arange(J.shape[0]),
                           Ja=J)


def test_the_one_call_answers_are_the_laws_full_search_on_the_same_states(answered):
    """Three boxes sliding (two sideways and turning) and one at rest, the same state on
    three steps: after the first step of each mode, the compiled call; its velocities are those of
    ``resolve_impact``'s full search of each island (the law's whole stick and slide
    tiers), and a resting box's corners carry m g h / 4 (closed form)."""
    mech, q, v = box_row(4, True)
    v = v.copy()
    v[6], v[7], v[11] = 1.2, 0.3, 0.5
    v[12:18] = 0.7, -0.4, 0.0, 0.0, 0.0, -0.8
    v[18:24] = 0.0
    s = ImpactSolver(mech, law=LAW, method="auto", impact_options={}, e_t=None,
                     rest_velocity=1e-6)
    for index in range(3):
        st = _step(mech, q, v, index)
        v_new, _ = s.solve(st)
    # the first step searches every island; on the next two the compiled call answers
    # every box: 0, 1, 2 sliding on four corners (box 1's edge pair, whose program once
    # needed the interior-point method, is certified to have no admissible impulse) and 3
    # at rest
    assert answered[0] == 8
    assert s.pruned == 6 and s.certified == 2 and s.checks == 4
    for b in range(4):
        cols = np.arange(6 * b, 6 * b + 6)
        J = [st.Ja[4 * b + c][:, cols] for c in range(4)]
        full = resolve_impact(st.M[np.ix_(cols, cols)], J, st.v_free[cols], np.zeros(4),
                              np.full(4, MU), law=LAW)
        np.testing.assert_allclose(v_new[cols], full.dq_plus, rtol=0, atol=1e-12)
    # box 3 at rest: the closed form, every corner m g h / 4, no friction
    np.testing.assert_allclose(s.impulse[12:, 0], BOX_MASS * GRAVITY * H / 4, rtol=1e-12)
    assert np.max(np.abs(s.impulse[12:, 1:])) < 1e-15
    # sliding boxes: Coulomb's impulse, mu m g h in total against the slip
    np.testing.assert_allclose(s.impulse[:4, 0].sum(), BOX_MASS * GRAVITY * H, rtol=1e-12)
    np.testing.assert_allclose(np.hypot(*s.impulse[:4, 1:].sum(axis=0)),
                               MU * BOX_MASS * GRAVITY * H, rtol=1e-12)


def test_a_box_slides_to_coulombs_stopping_distance_on_the_one_call_path(answered):
    """v0 = 0.4 m/s on four corners: stops after v0 / (mu g) = 0.136 s, v0^2 / (2 mu g) =
    27.2 mm further (to the step's order, v0 h), then rests; the steps inside both modes are
    answered by the compiled call, and the trajectory is the law's own search's."""
    v0 = 0.4
    mech, q, v = box_row(1, True)
    v = v.copy()
    v[0] = v0
    fast = _run(mech, q, v, 0.18)
    assert answered[0] >= 0.8 * fast.n_steps
    slow = _run(mech, q, v, 0.18, own_search=True)
    distance = fast.theta[-1, 0] - q[0]
    assert abs(distance - v0 ** 2 / (2 * MU * GRAVITY)) <= v0 * H
    moving = fast.t[np.abs(fast.dtheta[:, 0]) > 1e-12]
    assert abs(moving[-1] + H - v0 / (MU * GRAVITY)) <= H
    assert np.max(np.abs(fast.dtheta[-1])) < 1e-12
    np.testing.assert_allclose(fast.theta, slow.theta, rtol=0, atol=1e-13)
    np.testing.assert_allclose(fast.dtheta, slow.dtheta, rtol=0, atol=1e-11)


def test_islands_left_to_the_solver_share_the_step(answered):
    """A box sliding, one at rest and one dropped tilted (landing on a corner, an impact,
    rocking onto the others): on the steps the dropped box needs the solver's own path,
    the other two are still answered by the compiled call; the trajectory is the same as
    without it and as the law's own search, and the same warnings."""
    mech, q, v = box_row(3, True)
    q, v = q.copy(), v.copy()
    v[6:] = 0.0
    q[14] += 0.02
    q[15:17] = 0.05, 0.03
    fast = _run(mech, q, v, 0.12)
    with_python = answered[0]
    slow = _run(mech, q, v, 0.12, islands=False)
    own = _run(mech, q, v, 0.12, own_search=True)
    assert with_python > 1.5 * fast.n_steps
    for other in (slow, own):
        np.testing.assert_allclose(fast.theta, other.theta, rtol=0, atol=1e-12)
        np.testing.assert_allclose(fast.dtheta, other.dtheta, rtol=0, atol=1e-10)
    same = ("resolve_impact_calls", "largest_island", "ambiguous", "certified", "pruned",
            "searched")
    assert [fast.contact_solver[k] for k in same] == [slow.contact_solver[k] for k in same]
    assert len(fast.impacts) == len(slow.impacts) > 0
    assert fast.warnings == slow.warnings


def test_the_kernel_declines_impact_steps_and_other_layouts():
    """A step with an approaching contact (v_n,k < -rest_velocity) is left whole to the
    solver (-1, nothing written); other active contacts than the layout's: -2."""
    mech, q, v = box_row(1, False)
    v = v.copy()
    v[2] = -0.5  # falling onto the floor
    st = _step(mech, q, v)
    s = ImpactSolver(mech, law=LAW, method="auto", impact_options={}, e_t=None,
                     rest_velocity=1e-6)
    path = s.pn_islands
    assert path is not None
    assert path.solve(s, st) is None and path.pending(st) is None
    v_new, _ = s.solve(st)  # the solver's impact step: Newton's e = 0, the box stops
    assert np.max(np.abs(v_new)) < 1e-12 and len(s.impacts) == 1
    flat = path._flat
    Ja = np.ascontiguousarray(st.Ja[:3])
    args = (Ja, np.zeros(3), st.v_free, np.ascontiguousarray(st.inv.G), np.arange(3),
            *flat[:7], flat[7], flat[8], path.mu, *flat[9:15], path.tols, np.zeros((3, 3)),
            st.v_free.copy(), flat[15], flat[16],
            *dense_support(len(mech.contact_names), q.size)[1:])
    assert mpi.pn_islands(*args)[0] == -2


@pytest.mark.parametrize("case", ["rest", "turned", "creeping", "sliding"])
def test_the_certificate_in_the_islands_coordinates_is_the_contact_space_one(case):
    """coordinate_certificate (the sticking impulse from the 6 x 6 B^T B of the island's
    coordinates) against stick_certificate (W's 12 x 12 eigen-decomposition, the law's
    stick_solve): the same decision and impulse. Closed forms: at rest each corner carries
    m g h / 4; a box creeping at 1 mm/s sticks (it needs m v = 1e-3 N s of friction, less
    than mu m g h = 5.9e-3), the corners' tangential impulses summing to -m v; sliding at
    2 m/s no stick set is admissible."""
    from convimpact.impact.laws import pn_complementarity as pc
    from convimpact.simulation.moreau_pn_kernels import (coordinate_certificate,
                                                         stick_certificate)

    mech, q, v = box_row(1, case == "sliding")
    q, v = q.copy(), v.copy()
    if case == "turned":
        q[5] = 0.3
    if case == "creeping":
        v[0] = 1e-3
    st = _step(mech, q, v)
    Ja, G = np.ascontiguousarray(st.Ja), np.ascontiguousarray(st.inv.G)
    cons, cols = np.arange(4), np.arange(6)
    W = Ja.reshape(12, 6) @ G @ Ja.reshape(12, 6).T
    W = 0.5 * (W + W.T)
    vm = Ja.reshape(12, 6) @ st.v_free
    mu = np.full(4, MU)
    consts = (pc.STICK_COND_MAX, pc.CONE_RTOL, pc.VELOCITY_SLACK_MAX)
    x, ok = coordinate_certificate(Ja, G, cons, cols, 3, W, vm, mu, *consts)
    x2, ok2 = stick_certificate(W, vm, mu, 3, *consts, np.empty(12, dtype=np.int64))
    assert ok == ok2 == (case != "sliding")
    if case == "sliding":
        return
    np.testing.assert_allclose(x, x2, rtol=0, atol=1e-13 * np.max(np.abs(x2)))
    pi = x.reshape(4, 3)
    np.testing.assert_allclose(pi[:, 0].sum(), BOX_MASS * GRAVITY * H, rtol=1e-12)
    if case == "rest":
        np.testing.assert_allclose(pi[:, 0], BOX_MASS * GRAVITY * H / 4, rtol=1e-12)
    if case == "creeping":
        np.testing.assert_allclose(pi[:, 1].sum(), -BOX_MASS * 1e-3, rtol=1e-12)
