"""The event-driven run's shortcuts, each checked against the full computation it replaces,
on the box stack (problems/box_stack.py: it tips at t_tip = t_push + n w / ((2n - 1) h) /
ramp = 0.44 s, closed form; its top box starts to slide later):

* a slip-onset combination refused because the same combination with its onsets sticking
  was (force_solver._refused_as_stuck): every one so refused is refused when solved;
* the force problem at an event warm-started from the located margin's program (and each
  later combination from the first one's): the same modes and forces as without;
* a margin's zero located from the predicted bracket (EventWatch.locate_margin): the time
  Brent's method over the whole step finds, to its tolerance;
* a combination's refusal certified by a dual point (force_dual.refusal_bound): the
  solver's optimum of each such program is below the level asked too;
* a step's dense output built on first use (event_driven.StepDense): the samples of a run
  that keeps every interpolant, bit for bit, with fewer right-hand sides.
"""

from __future__ import annotations

import numpy as np
import pytest

from convimpact.errors import SimulationError
from convimpact.scenes import load_scene
from convimpact.simulation import (contact_events, event_watch, force_distribution,
                                   force_solver, simulate)
from convimpact.simulation.event_driven import StepDense


def _run(stack, **options):
    return simulate(stack.mechanism, (0.0, stack.t_end), (stack.theta0, stack.dtheta0),
                    breakpoints=[stack.parameters["t_push"]], **options)


def _tip_time(res) -> float:
    return next(iv.t_start for iv in res.modes_of("box0_c0") if iv.mode == "open")


def _slip_onset(res) -> float:
    return next(iv.t_start for iv in res.modes_of("box2_c0") if iv.mode == "slip")


@pytest.fixture(scope="module")
def stack():
    return load_scene("box_stack", t_end=0.7)


@pytest.fixture(scope="module")
def onsets(stack):
    """The force problems the run posed (with the warm starts it passed) and solved."""
    seen = []
    solve = contact_events.solve_contact_forces

    def spy(P, rtol=force_solver.RTOL, warm=None):
        given = None if warm is None else {**warm, "earlier": list(warm.get("earlier", ()))}
        sol = solve(P, rtol, warm=warm)
        seen.append((P, given, sol))
        return sol
    contact_events.solve_contact_forces = spy
    try:
        res = _run(stack)
    finally:
        contact_events.solve_contact_forces = solve
    return res, seen


def test_the_stack_tips_and_slides_as_before(onsets, stack):
    res, seen = onsets
    p = stack.parameters
    n, w, h = p["n_boxes"], p["width"], p["height"]
    t_tip = p["t_push"] + n * w / ((2 * n - 1) * h) / p["ramp"]
    assert abs(_tip_time(res) - t_tip) < 2e-9
    # the top box slides from rest: its four corners at once, the lower boxes sticking
    t_slip = _slip_onset(res)
    assert t_tip < t_slip < stack.t_end
    assert [sol.modes.count("slip") for _, _, sol in seen] == [0, 0, 4]


def test_combinations_refused_as_stuck_are_refused_when_solved(onsets):
    _, seen = onsets
    P, _, sol = seen[-1]  # the top box's slip onset: 4 edge contacts, 16 combinations
    calls = []
    rule = force_solver._refused_as_stuck

    def spy(P_, choice, edges, picks, refused):
        out = rule(P_, choice, edges, picks, refused)
        calls.append((list(choice), out))
        return out
    force_solver._refused_as_stuck = spy
    try:
        again = force_solver.solve_contact_forces(P)
    finally:
        force_solver._refused_as_stuck = rule
    refused = [choice for choice, out in calls if out]
    assert len(refused) == 10  # two or three of the top box's corners sticking
    for choice in refused:  # solved in full, each is refused too
        assert force_solver._exact(P, choice, force_solver.RTOL) is None
    assert again.modes == sol.modes
    np.testing.assert_allclose(again.force, sol.force, atol=1e-9 * P.scales[1])


def test_warm_started_force_problems_give_the_cold_answers(onsets):
    _, seen = onsets
    warmed = [(P, warm, sol) for P, warm, sol in seen if warm is not None]
    assert len(warmed) == 2  # the tip and the slip onset, each after a located margin
    for P, _, sol in warmed:
        cold = force_solver.solve_contact_forces(P)
        assert cold.modes == sol.modes
        np.testing.assert_allclose(cold.force, sol.force, atol=1e-9 * P.scales[1])
        np.testing.assert_allclose(cold.acceleration, sol.acceleration,
                                   atol=1e-9 * P.scales[0])


def test_predicted_margin_brackets_find_brents_zeros(stack, onsets, monkeypatch):
    res, _ = onsets
    calls = []
    locate = event_watch.EventWatch.locate_margin

    def count(self, fun, *args):
        def counted(s):
            calls.append(s)
            return fun(s)
        return locate(self, counted, *args)
    monkeypatch.setattr(event_watch.EventWatch, "locate_margin", count)
    _run(stack)
    predicted = len(calls)
    calls.clear()
    monkeypatch.setattr(event_watch, "_illinois_root", lambda *a, **k: None)  # no predictor
    full = _run(stack)  # Brent's method over each step
    brent = len(calls)
    # the same events, to the location tolerance (event_tol = 1e-12) and the states'
    # round-off between the runs; the same motion
    for a, b in ((_tip_time(full), _tip_time(res)), (_slip_onset(full), _slip_onset(res))):
        assert abs(a - b) < 1e-11
    np.testing.assert_allclose(res.theta[-1], full.theta[-1], rtol=0, atol=1e-9)
    np.testing.assert_allclose(res.dtheta[-1], full.dtheta[-1], rtol=0, atol=1e-8)
    # the margin's programs: fewer from the predicted brackets
    assert predicted < brent / 2


def test_lazy_dense_output_changes_no_sample(stack):
    kept = _run(stack, dense_output=True)
    lazy = _run(stack)
    for key in ("t", "theta", "dtheta", "friction_dissipation"):
        assert np.array_equal(getattr(kept, key), getattr(lazy, key))
    assert [e.time for e in kept.contact_events] == [e.time for e in lazy.contact_events]
    assert lazy.nfev < kept.nfev  # DOP853's interpolant costs three right-hand sides a step


def test_an_expired_step_builds_no_dense_output():
    class Solver:
        def dense_output(self):
            raise AssertionError("not to be called")
    step = StepDense(Solver())
    step.expire()
    with pytest.raises(SimulationError):
        step(0.0)


def test_refusals_certified_by_dual_points_are_the_solvers_refusals(onsets):
    """At the top box's slip onset, the four combinations with one corner sticking are
    refused by a dual point from the located margin's active set (force_dual.refusal_bound),
    without the solver: for each so certified, Clarabel's largest smallest margin of the
    same program lies below the level asked too (and at or below the bound: weak duality);
    the answer is the one the run took."""
    _, seen = onsets
    P, given, sol = seen[-1]
    bounds = []
    certify = force_distribution.refusal_bound

    def spy(blocks, warm, level=None):
        out = certify(blocks, warm, level)
        bounds.append((blocks, out))
        return out
    force_distribution.refusal_bound = spy
    try:
        again = force_solver.solve_contact_forces(
            P, warm={**given, "earlier": list(given.get("earlier", ()))})
    finally:
        force_distribution.refusal_bound = certify
    level = -force_solver.RTOL - force_distribution.BELOW_GUARD  # (relative: the scale)
    certified = [(blocks, b) for blocks, b in bounds if b is not None and b < level]
    assert len(certified) == 4  # the four combinations with one corner of the top box sticking
    for blocks, bound in certified:
        A = np.vstack([blk[1] for blk in blocks])
        b = np.concatenate([blk[2] for blk in blocks])
        w = np.concatenate([blk[3] for blk in blocks])
        r = A.shape[1]
        q = np.zeros(r + 1)
        q[r] = -1.0
        out = force_distribution._clarabel(np.zeros((r + 1, r + 1)), q,
                                           np.hstack([A, w[:, None]]), b,
                                           [(blk[0], len(blk[2])) for blk in blocks])
        t_star = float(out.x[r])
        assert t_star <= bound + 1e-9
        assert t_star < level
    assert again.modes == sol.modes
    np.testing.assert_array_equal(again.force, sol.force)
