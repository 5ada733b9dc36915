"""Law pereira-nikravesh's search in one compiled call
(:mod:`convimpact.impact.laws.pn_complementarity_search`): the law's own search (its
``_search`` and ``_pick`` over the same kernels) as the second method on random impacts and
on a sliding box, warm starts across steps; its pruned search
(:mod:`convimpact.impact.laws.pn_complementarity_prune`): the dominated slide sets and the
excluded stick sets of a box's corners by hand."""

import re

import numpy as np
import pytest

from convimpact.bench.several_problems import four_corner_box, random_several
from convimpact.impact.conic.paths import backend, parse_options
from convimpact.impact.laws import pn_complementarity as pc
from convimpact.impact.laws import pn_complementarity_impulse as pimp
from convimpact.impact.laws import pn_complementarity_prune as pp
from convimpact.impact.laws import pn_complementarity_search as ps
from convimpact.impact.problem.build import build_problem

OPTS = parse_options("clarabel", {})
BACKEND = backend("clarabel")


@pytest.fixture(scope="module", autouse=True)
def compiled_path():
    pimp.compile_kernels()


def _problem(args):
    return build_problem(args["M"], args["Jc"], args["dq"], args["e"], args["mu"])


def _law(P):
    """The law's own search and pick: (impulse, the sets its warning lists)."""
    _, found, failures, _ = pc._search(P, BACKEND, OPTS)
    assert not failures
    best, notes = pc._pick(P, found)
    return best[2], _listed(notes)


def _listed(notes):
    return [sorted(re.findall(r"\[[0-9, ]+\]", n)) for n in notes]


def _same_velocities(P, a, b, rtol=1e-10):
    scale = np.max(np.abs(P.v_minus))
    jump = P.delassus @ (np.asarray(a) - np.asarray(b)).ravel()
    return np.max(np.abs(jump)) <= rtol * scale


CASES = [(seed, n, d) for seed in range(6) for n in (2, 3, 4) for d in (2, 3)]


def test_one_call_is_the_laws_search_on_random_impacts():
    """Random impacts (odd seeds sliding harder): wherever the one call answers, its
    impulse is the law's own search's (velocities to 1e-10, impulse to 1e-8 of its size),
    with the same sets in the warning. It answers 11 of these 36; the others need an
    interior-point program somewhere, which only the law's own search runs."""
    answered = 0
    for seed, n, d in CASES:
        args = random_several(seed, n, d)
        args["dq"] = np.asarray(args["dq"], float) * (1.0 + 4.0 * (seed % 2))
        P = _problem(args)
        notes: list = []
        got = pimp.compiled_impulse(P, BACKEND, OPTS, notes)
        if got is None:
            continue
        answered += 1
        want, listed = _law(P)
        assert _same_velocities(P, got, want)
        assert np.max(np.abs(got - want)) <= 1e-8 * max(np.max(np.abs(want)), 1e-300)
        assert _listed(notes) == listed
    assert answered >= len(CASES) // 4


def _sliding_box(step: int, e: float = 0.0):
    """The box sliding on its four corners (e = 0), its speed falling as Coulomb's law
    makes it (a step of a time stepper: gravity's h g approach at every corner)."""
    g, h, mu = 9.81, 2e-3, 0.3
    speed = 2.0 - mu * g * h * step
    return _problem(four_corner_box(mu=mu, e=e, velocity=(speed, 0.0, -g * h),
                                    angular_velocity=(0.0, 0.0, 0.0)))


def test_warm_started_steps_keep_the_laws_answer():
    """Steps of a sliding box with warm starts (the previous step's slide programs): the
    law's velocities on every step (its impulse may be another member of the four corners'
    family: same velocities and energy), the same warning; cold, the same impulse."""
    warm = ps.SlideWarmStart()
    for step in range(8):
        P = _sliding_box(step)
        want, listed = _law(P)
        notes: list = []
        got = pimp.compiled_impulse(P, BACKEND, OPTS, notes, warm)
        assert got is not None and _same_velocities(P, got, want)
        assert _listed(notes) == listed and listed  # all four sliding, and three of them
        assert warm.full_slide and not warm.pruned
        cold = pimp.compiled_impulse(P, BACKEND, OPTS, [])
        np.testing.assert_allclose(cold, want, rtol=0, atol=1e-13)


def test_dominated_sets_of_a_box_by_hand():
    """Corners (-a,-b), (-a,b), (a,-b), (a,b) of a box on the floor: normal velocities are
    affine in (v_z, omega_x, omega_y), so any three corners at u_n = 0 hold the fourth at 0
    (dominated), and so does a diagonal pair (u_1 + u_2 = u_0 + u_3, both >= 0); an edge's
    pair lets the box tip about it and a lone corner about any axis through it (not
    dominated)."""
    P = _sliding_box(0)
    b = pc.newton_velocity_shift(P).ravel()
    W = P.delassus
    R = np.hstack([W[::3], (b[::3] * np.max(np.abs(W)) / np.max(np.abs(b[::3])))[:, None]])
    expect = {(0, 1, 2): True, (0, 1, 3): True, (0, 2, 3): True, (1, 2, 3): True,
              (0, 3): True, (1, 2): True, (0, 1): False, (0, 2): False, (1, 3): False,
              (2, 3): False, (0,): False, (1,): False, (2,): False, (3,): False}
    for A, dom in expect.items():
        member = np.zeros(4, dtype=bool)
        member[list(A)] = True
        assert pp.dominated(R, member) == dom, A


def test_the_pruned_search_picks_the_laws_answer():
    """A step of a sliding mode: the search without the dominated sets returns the law's
    velocities, sliding on every contact (so the mode goes on), and leaves the warning
    alone; a box that sticks is handed to the law's own search (its stick tier decides:
    m g h / 4 on each corner), which ends the mode."""
    warm = ps.SlideWarmStart()
    for step in range(4):
        P = _sliding_box(step)
        notes: list = []
        got = pimp.compiled_impulse(P, BACKEND, OPTS, notes, warm, prune=True)
        want, _ = _law(P)
        assert got is not None and _same_velocities(P, got, want)
        assert warm.full_slide and warm.pruned and notes == []
    still = _problem(four_corner_box(mu=0.3, e=0.0, velocity=(0.0, 0.0, -0.0196),
                                     angular_velocity=(0.0, 0.0, 0.0)))
    assert pimp.compiled_impulse(still, BACKEND, OPTS, [], warm, prune=True) is None
    got = pimp.several_contacts_impulse(still, BACKEND, OPTS, [], warm, prune=True)
    np.testing.assert_allclose(got[:, 0], 0.0196 * 1.0 / 4, rtol=1e-12)  # m g h / 4
    assert not warm.full_slide and not warm.pruned


def test_stick_sets_excluded_on_a_sliding_box_by_hand():
    """A box sliding on four corners: W has rank 6 (a rigid body's six motions), three or
    four corners fix all six (excluded while the full set slips), two corners leave the
    rotation about their line and one corner three rotations (kept for the stick tier). At
    rest (no slip) nothing is excluded."""
    P = _sliding_box(0)
    b = pc.newton_velocity_shift(P).ravel()
    W, v = P.delassus, P.v_minus.ravel()
    assert pp.rank_clear(W) == (6, True)
    subsets, masks = pc.candidate_sets(4, (True,) * 4)
    warm = ps.SlideWarmStart()
    pi_full = pimp.compiled_impulse(P, BACKEND, OPTS, [], warm).ravel()
    escale = 0.5 * np.max(np.abs(v)) ** 2 / np.max(np.diag(W))
    keep = pp._kept_stick_sets(W, b, v, P.friction, 3, masks, pi_full, escale)
    assert [A for A, k in zip(subsets, keep) if not k] == [(0, 1, 2, 3), (0, 1, 2), (0, 1, 3),
                                                            (0, 2, 3), (1, 2, 3)]
    still = _problem(four_corner_box(mu=0.3, e=0.0, velocity=(0.0, 0.0, -0.0196),
                                     angular_velocity=(0.0, 0.0, 0.0)))
    bs = pc.newton_velocity_shift(still).ravel()
    Ws = still.delassus
    at_rest = np.linalg.lstsq(Ws, -bs, rcond=None)[0]  # sticking on all four: u = 0
    keep = pp._kept_stick_sets(Ws, bs, still.v_minus.ravel(), still.friction, 3, masks,
                               at_rest, escale)
    assert keep.all()
