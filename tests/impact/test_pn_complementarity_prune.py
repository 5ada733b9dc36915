"""The sticking screen of law pereira-nikravesh's pruned search
(:func:`convimpact.impact.laws.pn_complementarity_prune.stick_clearly_inadmissible`): a stick
set it excludes is never admissible by the law's own test (the law's ``stick_on`` and
``_admissible``: the stick tier's eigendecomposition and LU, not the screen's Cholesky bounds,
run as Python), on random impacts and on a box on
four corners sliding, landing and nearly at rest; and on the sliding box it excludes the
lone corners, whose sticking impulses need a friction far outside the cone (by hand)."""

import itertools

import numpy as np
import pytest

from convimpact.bench.several_problems import four_corner_box, random_several
from convimpact.impact.laws import pn_complementarity as pc
from convimpact.impact.laws.pn_complementarity_prune import (SINGLE_ACCURACY,
                                                            stick_clearly_inadmissible)
from convimpact.impact.problem.build import build_problem


def _problem(args):
    return build_problem(args["M"], args["Jc"], args["dq"], args["e"], args["mu"])


def _screen_against_the_law(P):
    """(sets excluded by the screen, of which the law finds admissible) over every subset."""
    b = pc.newton_velocity_shift(P)
    W = np.ascontiguousarray(P.delassus)
    mu = np.ascontiguousarray(P.friction, dtype=float)
    excluded = wrong = 0
    n = P.n_contacts
    for k in range(1, n + 1):
        for A in itertools.combinations(range(n), k):
            member = np.zeros(n, dtype=bool)
            member[list(A)] = True
            if not stick_clearly_inadmissible(W, b.ravel().copy(), mu, P.dim, member,
                                              pc.CONE_RTOL, pc.VELOCITY_SLACK_MAX,
                                              SINGLE_ACCURACY):
                continue
            excluded += 1
            pi = pc.stick_on(P, A, b)
            wrong += pi is not None and pc._admissible(P, A, pi, b, SINGLE_ACCURACY)
    return excluded, wrong


@pytest.mark.parametrize("dim", [2, 3])
def test_the_screen_never_excludes_a_set_the_law_admits_on_random_impacts(dim):
    excluded = 0
    for seed in range(40):
        for n in (1, 2, 3):
            got, wrong = _screen_against_the_law(_problem(random_several(seed, n, dim)))
            assert wrong == 0, (seed, n)
            excluded += got
    assert excluded > 20  # the screen does exclude sets (the test is not vacuous)


@pytest.mark.parametrize("velocity, angular, mu", [
    ((2.0, 0.0, -0.02), (0.0, 0.0, 0.0), 0.3),     # sliding, landing softly
    ((1.2, 0.3, -0.01), (0.0, 0.0, 0.5), 0.3),     # sliding sideways, turning
    ((0.0, 0.0, -1.0), (0.3, -0.2, 0.5), 1.0),     # landing, tumbling
    ((1e-3, 0.0, -0.02), (0.0, 0.0, 0.0), 0.3),    # nearly at rest: corners may stick
    ((0.8, 0.3, -1.0), (0.3, -0.2, 0.5), 0.05),    # slippery
])
def test_the_screen_never_excludes_a_set_the_law_admits_on_a_box(velocity, angular, mu):
    P = _problem(four_corner_box(mu=mu, e=0.0, velocity=velocity, angular_velocity=angular))
    _, wrong = _screen_against_the_law(P)
    assert wrong == 0


def test_the_screen_excludes_the_lone_corners_of_a_sliding_box():
    """Box (0.2, 0.15, 0.1), 1 kg, sliding at 2 m/s and landing at 0.02 m/s, mu = 0.3: a lone
    corner stops by an impulse of tangential part about m_eff 2 and normal part about m_eff
    0.02 (ratio near 100 >> mu). The screen excludes each lone corner; the pairs (W_SS of
    rank 5: a pair of corners does not see the rotation about its edge) are left to the
    law's stick tier."""
    P = _problem(four_corner_box(mu=0.3, e=0.0, velocity=(2.0, 0.0, -0.02),
                                 angular_velocity=(0.0, 0.0, 0.0)))
    b = pc.newton_velocity_shift(P)
    W = np.ascontiguousarray(P.delassus)
    mu = np.full(4, 0.3)
    for i in range(4):
        pi = pc.stick_on(P, (i,), b)[i]
        assert np.hypot(pi[1], pi[2]) > 10.0 * 0.3 * abs(pi[0])  # far outside the cone
        member = np.arange(4) == i
        assert stick_clearly_inadmissible(W, b.ravel().copy(), mu, 3, member, pc.CONE_RTOL,
                                          pc.VELOCITY_SLACK_MAX, SINGLE_ACCURACY)
    pair = np.array([True, True, False, False])
    assert not stick_clearly_inadmissible(W, b.ravel().copy(), mu, 3, pair, pc.CONE_RTOL,
                                          pc.VELOCITY_SLACK_MAX, SINGLE_ACCURACY)


def test_the_pruned_search_keeps_only_the_pairs_of_a_sliding_box_for_its_stick_tier():
    """Sliding box: the lone corners go by the screen, three and four corners by the rank
    argument (they fix all six motions while the full set slips); the six pairs are left."""
    from convimpact.impact.laws.pn_complementarity_prune import _screened_stick_sets
    from convimpact.impact.laws.pn_complementarity_slide import slide_set

    P = _problem(four_corner_box(mu=0.3, e=0.0, velocity=(2.0, 0.0, -0.02),
                                 angular_velocity=(0.0, 0.0, 0.0)))
    b = pc.newton_velocity_shift(P).ravel()
    W, v, mu = np.ascontiguousarray(P.delassus), P.v_minus.ravel(), P.friction
    status, pi_full = slide_set(W, v, b, mu, 3, np.arange(4))
    assert status == 1
    subsets, masks = pc.candidate_sets(4, (True,) * 4)
    escale = 0.5 * np.max(np.abs(v)) ** 2 / np.max(np.diag(W))
    keep = _screened_stick_sets(W, b, v, mu, 3, masks, pi_full, escale, pc.CONE_RTOL,
                                pc.VELOCITY_SLACK_MAX, np.zeros(len(masks), dtype=bool))
    assert [A for A, k in zip(subsets, keep) if k] == list(itertools.combinations(range(4), 2))
