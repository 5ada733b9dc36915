"""The certificates that exclude active sets of law pereira-nikravesh before solving them
(:mod:`convimpact.impact.laws.pn_complementarity_exclusion`) and the re-certified warm start
of the full set's slide program (:func:`~convimpact.impact.laws.pn_complementarity_slide.
warm_kkt_point`). Second method: the law's own stick and slide candidates (``stick_on``,
``slide_on`` by the interior-point method, its admissibility test ``_admissible``, all run as
Python) on every excluded set; closed forms on a box sliding on its four corners; a tall box
that friction tips, where the certificate must not fire and the law's answer is the edge."""

import itertools

import numpy as np
import pytest

from convimpact.bench.several_problems import four_corner_box, random_several
from convimpact.impact.conic.paths import backend, parse_options
from convimpact.impact.laws import pn_complementarity as pc
from convimpact.impact.laws import pn_complementarity_impulse as pimp
from convimpact.impact.laws import pn_complementarity_search as ps
from convimpact.impact.laws.pn_complementarity_exclusion import (excluded_sets,
                                                                 no_admissible_impulse,
                                                                 no_sticking_impulse)
from convimpact.impact.laws.pn_complementarity_prune import SINGLE_ACCURACY
from convimpact.impact.laws.pn_complementarity_slide import slide_set, warm_kkt_point
from convimpact.impact.problem.build import SAFE_SCALE, build_problem

OPTS = parse_options("clarabel", {})
BACKEND = backend("clarabel")
TOL = OPTS.accuracy(True)  # the slide programs' admissibility tolerance (1e-9)
G, H = 9.81, 2e-3


@pytest.fixture(scope="module", autouse=True)
def compiled_path():
    pimp.compile_kernels()


def _problem(args):
    return build_problem(args["M"], args["Jc"], args["dq"], args["e"], args["mu"])


def _data(P):
    b = pc.newton_velocity_shift(P)
    W, bf, vf, mu = pc._kernel_data(P, b)
    return b, W, bf, vf, mu


def _against_the_law(P):
    """(sets excluded, of which the law admits a candidate) over every subset: for the
    first certificate both the law's sticking and sliding impulses, for the second its
    sticking impulse."""
    b, W, bf, _, mu = _data(P)
    n, d = P.n_contacts, P.dim
    excluded = wrong = 0
    for k in range(1, n + 1):
        for A in itertools.combinations(range(n), k):
            member = np.zeros(n, dtype=bool)
            member[list(A)] = True
            none = no_admissible_impulse(W, bf, mu, d, member, TOL, pc.VELOCITY_SLACK_MAX,
                                         pc.CONE_RTOL)
            stick = no_sticking_impulse(W, bf, mu, d, member, TOL, pc.VELOCITY_SLACK_MAX,
                                        pc.CONE_RTOL)
            if not (none or stick):
                continue
            excluded += 1
            pi = pc.stick_on(P, A, b)
            wrong += pi is not None and pc._admissible(P, A, pi, b, SINGLE_ACCURACY)
            if none:
                got = pc.slide_on(P, A, b, BACKEND, OPTS)
                wrong += got is not None and pc._admissible(P, A, got[0], b, TOL)
    return excluded, wrong


@pytest.mark.parametrize("dim", [2, 3])
def test_no_excluded_set_has_a_candidate_the_law_admits_on_random_impacts(dim):
    excluded = 0
    for seed in range(25):
        for n in (2, 3):
            got, wrong = _against_the_law(_problem(random_several(seed, n, dim)))
            assert wrong == 0, (seed, n)
            excluded += got
    assert excluded > 10  # the certificates do fire (the test is not vacuous)


@pytest.mark.parametrize("velocity, angular, mu, half", [
    ((2.0, 0.0, -0.02), (0.0, 0.0, 0.0), 0.3, (0.2, 0.15, 0.1)),    # sliding, landing softly
    ((1.2, 0.3, -0.01), (0.0, 0.0, 0.5), 0.3, (0.2, 0.15, 0.1)),    # sideways, turning
    ((0.0, 0.0, -1.0), (0.3, -0.2, 0.5), 1.0, (0.2, 0.15, 0.1)),    # landing, tumbling
    ((1e-3, 0.0, -0.02), (0.0, 0.0, 0.0), 0.3, (0.2, 0.15, 0.1)),   # nearly at rest
    ((2.0, 0.0, -0.02), (0.0, 0.0, 0.0), 0.5, (0.05, 0.15, 0.3)),   # tall: friction tips it
])
def test_no_excluded_set_has_a_candidate_the_law_admits_on_a_box(velocity, angular, mu, half):
    P = _problem(four_corner_box(mu=mu, e=0.0, velocity=velocity, angular_velocity=angular,
                                 half_sizes=half))
    _, wrong = _against_the_law(P)
    assert wrong == 0


def _sliding_box(half=(0.2, 0.15, 0.1), mu=0.3, speed=2.0):
    """The box of the Moreau-Jean bench on its four corners (order (-a,-b), (-a,b), (a,-b),
    (a,b)) one step into its slide: v_n- = -g h, sliding along +x."""
    return _problem(four_corner_box(mu=mu, e=0.0, velocity=(speed, 0.0, -G * H),
                                    angular_velocity=(0.0, 0.0, 0.0), half_sizes=half))


def test_a_sliding_box_excludes_its_edges_and_corners_and_every_stick_set():
    """By hand: pushing up the far corners of an edge (or of a lone corner) presses its
    corners down (2.8 per unit impulse against 0.3 x 2.4 of slip) and the far corners
    approach at 2 g h: no impulse on an edge or a corner keeps them out of the floor. The
    diagonals and the three-corner sets are left (their slides are admissible: the
    dominated-set argument takes them), and no set can stop a 2 m/s slip within mu."""
    P = _sliding_box()
    _, W, bf, _, mu = _data(P)
    subsets, masks = pc.candidate_sets(4, (True,) * 4)
    none, stick = excluded_sets(W, bf, mu, 3, masks, TOL, pc.VELOCITY_SLACK_MAX, pc.CONE_RTOL)
    edges = {(0, 1), (2, 3), (0, 2), (1, 3)}
    expected = [len(A) == 1 or A in edges for A in subsets]
    assert none.tolist() == expected
    assert stick.all()


def test_the_sliding_box_gets_the_closed_form_impulse_from_the_pruned_search():
    """The law's answer (its own search, and the compiled pruned search through the
    certificates) slides on all four corners: total normal impulse m g h, friction mu m g h
    against the slip, and no pitch, so the front pair carries (m g h / 2)(1 + mu c / a) and
    the back pair (m g h / 2)(1 - mu c / a) (the friction's moment about the centre)."""
    a, c, m, mu = 0.2, 0.1, 1.0, 0.3
    P = _sliding_box()
    (dT, A, own, _), _ = pc._pick(P, pc._search(P, BACKEND, OPTS)[1])
    assert tuple(A) == (0, 1, 2, 3)
    b, W, bf, vf, mu_ = _data(P)
    subsets, masks = pc.candidate_sets(4, (True,) * 4)
    warm = ps.SlideWarmStart()
    starts = warm.get("k", len(subsets), 4, 3)
    args = (W, bf, vf, mu_, np.zeros(4), 3, masks, ps.tuple_ranks(tuple(subsets)), TOL,
            pc.STICK_COND_MAX, pc.CONE_RTOL, pc.VELOCITY_SLACK_MAX, *SAFE_SCALE)
    status, tier, pi, *_ = ps.search(*args, *starts, True)
    assert status == ps.DONE and tier == ps.SLIDE_TIER
    for imp in (pi.reshape(4, 3), own):
        front, back = imp[2, 0] + imp[3, 0], imp[0, 0] + imp[1, 0]
        assert front == pytest.approx(m * G * H / 2 * (1 + mu * c / a), rel=1e-10)
        assert back == pytest.approx(m * G * H / 2 * (1 - mu * c / a), rel=1e-10)
        assert imp[:, 1].sum() == pytest.approx(-mu * m * G * H, rel=1e-10)
        assert np.abs(imp[:, 2]).max() < 1e-12
    # the next step (the same impulse: the previous answer re-certified, no Newton)
    assert warm_kkt_point(W, vf, bf, mu_, 3, pi, pc.CONE_RTOL)
    status, _, again, *_ = ps.search(*args, *starts, True)
    np.testing.assert_allclose(again, pi, rtol=0, atol=1e-15)


def test_a_tall_box_that_friction_tips_keeps_its_front_edge_and_the_law_takes_it():
    """Half sizes (0.05, 0.15, 0.3), mu = 0.5: mu c / a = 3 > 1, so the back pair's share
    (m g h / 2)(1 - mu c / a) would be negative: sliding flat is inadmissible and the box
    tips onto its front edge. The certificate must not exclude that edge (its far corners
    lift), and the compiled search, pruned (by the certificates) or not, returns the law's own
    answer or hands the problem to it."""
    P = _sliding_box(half=(0.05, 0.15, 0.3), mu=0.5)
    b, W, bf, vf, mu = _data(P)
    front = np.array([False, False, True, True])
    assert not no_admissible_impulse(W, bf, mu, 3, front, TOL, pc.VELOCITY_SLACK_MAX,
                                     pc.CONE_RTOL)
    (_, A, own, _), _ = pc._pick(P, pc._search(P, BACKEND, OPTS)[1])
    assert tuple(A) == (2, 3)
    subsets, masks = pc.candidate_sets(4, (True,) * 4)
    for prune in (False, True):
        starts = ps.SlideWarmStart().get("k", len(subsets), 4, 3)
        status, tier, pi, *_ = ps.search(
            W, bf, vf, mu, np.zeros(4), 3, masks, ps.tuple_ranks(tuple(subsets)), TOL,
            pc.STICK_COND_MAX, pc.CONE_RTOL, pc.VELOCITY_SLACK_MAX, *SAFE_SCALE, *starts,
            prune)
        assert status == ps.DONE or not prune  # (unpruned: may hand back to the law)
        if status == ps.DONE:
            np.testing.assert_allclose(W @ pi, W @ own.ravel(), rtol=0, atol=1e-10)
    got = pimp.compiled_impulse(P, BACKEND, OPTS)
    assert got is None or np.allclose(W @ got.ravel(), W @ own.ravel(), rtol=0, atol=1e-10)


def test_a_previous_answer_is_re_certified_only_where_it_is_a_minimizer():
    """warm_kkt_point: the full set's minimizer (slide_set, cold) passes; the same impulse
    with a normal part 1e-6 off (u_n no longer 0), or its friction turned by 1e-3 rad, or on
    a box that slides sideways too (the friction's direction has changed), fails."""
    P = _sliding_box()
    _, W, bf, vf, mu = _data(P)
    st, pi = slide_set(W, vf, bf, mu, 3, np.arange(4))
    assert st == 1 and warm_kkt_point(W, vf, bf, mu, 3, pi, pc.CONE_RTOL)
    off = pi.copy()
    off[0] *= 1 + 1e-6
    assert not warm_kkt_point(W, vf, bf, mu, 3, off, pc.CONE_RTOL)
    turned = pi.reshape(4, 3).copy()
    c, s = np.cos(1e-3), np.sin(1e-3)
    turned[:, 1:] = turned[:, 1:] @ np.array([[c, s], [-s, c]])
    assert not warm_kkt_point(W, vf, bf, mu, 3, turned.ravel(), pc.CONE_RTOL)
    Q = _problem(four_corner_box(mu=0.3, e=0.0, velocity=(2.0, 0.5, -G * H),
                                 angular_velocity=(0.0, 0.0, 0.0)))
    _, W2, bf2, vf2, mu2 = _data(Q)
    assert not warm_kkt_point(W2, vf2, bf2, mu2, 3, pi, pc.CONE_RTOL)
