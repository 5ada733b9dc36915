"""A contact that approaches at round-off changes no answer (issue 15, item 1).

Housner's rocking block and McGeer's rimless wheel land on a new corner (foot) while the old
one touches with v_n- = 0 -- or -1e-16 from cos/sin round-off, or -1e-12 as an integrator
leaves it. Newton's law in complementarity form (v_n+ + e v_n- >= 0, pi_n >= 0,
complementary) lets the old corner lift off whatever the sign of that round-off; imposing
v_n+ = -e v_n- wherever v_n- < 0 made both stop dead (omega+ = 0) or raised "P_N is
infeasible". Every law on every multi-contact path must give the classical answers.

Independent numbers (derived here, not by the code):

* Rocking block, half-width b, half-height c, R^2 = b^2 + c^2, I_G = m R^2 / 3, rotating at
  omega about the right corner P when the left corner L lands. The landing impulse passes
  through L, so the angular momentum about L is conserved: before,
  H_L = I_G omega + m (G - L) x v_G with G - L = (b, c), v_G = omega z x (G - P)
  = omega (-c, -b), so H_L = m omega (R^2/3 + c^2 - b^2); after, rotating about L,
  H_L = (4/3) m R^2 omega+. Hence omega+ / omega = (1 + 3 cos 2 alpha) / 4
  = 1 - 1.5 sin^2 alpha (alpha = atan(b / c)), and P rises at 2 b omega+ > 0 (it lifts off).
  A perturbation rotating at eps about L changes the pivot's v_n- by 2 b eps and H_L by
  (4/3) m R^2 eps, so omega+ = (1 - 1.5 sin^2 alpha) omega + eps exactly.
* Rimless wheel (scene docstring, re-derived the same way about the new foot F):
  omega+ = eta omega-, eta = (cos(2 pi / n) + rho^2) / (1 + rho^2); a rotation eps about F
  adds eps to omega+.
* Frictionless pairs: Newton's complementarity problem solved by hand (below).
"""

import math

import numpy as np
import pytest

import convimpact as ci
from convimpact.impact.laws import PER_CONTACT_LAWS
from convimpact.model import place_resting
from convimpact.problems.rimless_wheel import make_scene as make_wheel
from convimpact.problems.rocking_block import make_scene as make_block

PATHS = ("clarabel", "cvxpy")
#: the pivot's pre-impact normal velocity: touching, cos/sin round-off, what an integrator
#: leaves, and separating at round-off
PERTURBATIONS = (0.0, -1e-16, -1e-12, 1e-12)


def block_landing(delta, width=0.2, height=1.0, omega=1.0):
    """(impact arguments, expected omega+, Housner's omega+) for the block landing flat on its
    left corner while rotating at omega about its right corner, whose v_n- is ``delta``."""
    mech = make_block(width=width, height=height).mechanism
    b, c = width / 2, height / 2
    eps = delta / width  # a rotation eps about the landing corner moves the pivot at 2 b eps
    dq = omega * np.array([-c, -b, 1.0]) + eps * np.array([-c, b, 1.0])
    args = ci.impact_arguments(mech, np.array([0.0, c, 0.0]), dq,
                               ["left_corner", "right_corner"])
    alpha = math.atan(b / c)
    housner = (1.0 - 1.5 * math.sin(alpha) ** 2) * omega
    return args, housner + eps, housner


def wheel_strike(delta=None, rho=0.1, omega=1.0, e=None, mu=None):
    """(impact arguments, expected omega+) for the rimless wheel striking with foot7 while
    rotating at omega about foot0, placed touching exactly (place_resting: v_n- of foot0 is
    cos/sin round-off); ``delta`` adds that much to foot0's v_n- by a rotation about foot7."""
    scene = make_wheel(rho=rho)
    mech, par = scene.mechanism, scene.parameters
    n = par["n_spokes"]
    guess = np.array([0.0, 1.0, math.pi / n + par["slope"]])
    theta = place_resting(mech, guess, ["foot0", "foot7"], fixed=["x"])
    phi = theta[2]
    foot = {k: theta[:2] + par["leg_length"] * np.array(
        [math.cos(phi + a), math.sin(phi + a)]) for k, a in
        (("foot0", -math.pi / 2), ("foot7", -math.pi / 2 + 2 * math.pi * 7 / n))}
    r0 = theta[:2] - foot["foot0"]
    dq = omega * np.array([-r0[1], r0[0], 1.0])
    eps = 0.0
    if delta is not None:
        eps = delta / float(np.linalg.norm(foot["foot0"] - foot["foot7"]))
        r7 = theta[:2] - foot["foot7"]
        dq = dq + eps * np.array([-r7[1], r7[0], 1.0])
    kw = {k: v for k, v in (("e", e), ("mu", mu)) if v is not None}
    args = ci.impact_arguments(mech, theta, dq, ["foot7", "foot0"], **kw)
    return args, par["eta"] * omega + eps


def test_block_helper_is_what_it_says():
    """The constructed states: landing corner approaching at -omega w, pivot at delta."""
    for delta in PERTURBATIONS:
        args, _, _ = block_landing(delta)
        vn = [float(J[0] @ args["dq"]) for J in args["Jc"]]
        assert vn[0] == pytest.approx(-0.2, rel=1e-14)
        assert vn[1] == pytest.approx(delta, abs=1e-15 * 0.2 + 1e-3 * abs(delta))
    args, _ = wheel_strike()
    vn = [float(J[0] @ args["dq"]) for J in args["Jc"]]
    assert vn[0] < -0.5 and abs(vn[1]) < 1e-15  # touching to round-off


@pytest.mark.parametrize("law", ci.LAWS)
def test_rocking_block_lands_by_housners_ratio_whatever_the_pivots_round_off(law):
    answers = []
    for method in PATHS:
        for delta in PERTURBATIONS:
            args, expected, housner = block_landing(delta)
            r = ci.resolve_impact(**args, law=law, method=method)
            assert r.dq_plus[2] == pytest.approx(expected, rel=1e-9), (method, delta)
            assert r.dq_plus[2] == pytest.approx(housner, rel=1e-9), (method, delta)
            assert r.regime[1] == "separating" and r.v_plus[1, 0] > 0.1  # the pivot lifts
            assert not r.diagnostics.penetration
            answers.append(r.dq_plus)
    spread = np.max(np.abs(np.array(answers) - answers[0]))
    assert spread <= 1e-10 * np.max(np.abs(answers[0])), spread


@pytest.mark.parametrize("law", ci.LAWS)
def test_rimless_wheel_strikes_by_mcgeers_ratio_whatever_the_old_foots_round_off(law):
    answers = []
    for method in PATHS:
        for delta in (None, *PERTURBATIONS):
            args, expected = wheel_strike(delta)
            r = ci.resolve_impact(**args, law=law, method=method)
            assert r.dq_plus[2] == pytest.approx(expected, rel=1e-9), (method, delta)
            assert r.regime[1] == "separating"
            answers.append(r.dq_plus)
    spread = np.max(np.abs(np.array(answers) - answers[0]))
    assert spread <= 1e-10 * np.max(np.abs(answers[0])), spread


def test_pereira_nikravesh_lets_a_non_approaching_pair_separate():
    """Two frictionless normals of a unit particle, n1 . n2 = 0.9, v_n- = (-1, -0.1), e = 0.
    Newton at both needs W_nn pi = (1, 0.1) with W_nn = [[1, .9], [.9, 1]]: pi_2 < 0. In
    complementarity form contact 2 carries nothing: pi = (1, 0) and v_n2+ = -0.1 + 0.9 = 0.8
    (it separates): the same answer as the other laws (frictionless, they all solve the same
    linear complementarity problem)."""
    n1 = np.array([1.0, 0.0])
    n2 = np.array([0.9, math.sqrt(0.19)])
    Jc = [np.array([n1, [0.0, 1.0]]), np.array([n2, [-n2[1], n2[0]]])]
    dq = np.linalg.solve(np.array([n1, n2]), [-1.0, -0.1])
    for law in PER_CONTACT_LAWS:  # two contacts strike together, coupled: refused, by name
        with pytest.raises(ci.NotSupportedError, match="defined per contact.*ccp"):
            ci.resolve_impact(np.eye(2), Jc, dq, e=0.0, mu=0.0, law=law, method="clarabel")
    for law in (law for law in ci.LAWS if law not in PER_CONTACT_LAWS):
        for method in PATHS:
            r = ci.resolve_impact(np.eye(2), Jc, dq, e=0.0, mu=0.0, law=law, method=method)
            np.testing.assert_allclose(r.impulse[:, 0], [1.0, 0.0], atol=1e-10)
            assert r.v_plus[1, 0] == pytest.approx(0.8, abs=1e-10)
            assert r.regime[1] == "separating"


def test_pereira_nikravesh_presses_a_receding_contact_instead_of_letting_it_penetrate():
    """n1 = (1, 0), n2 = (-0.9, sqrt(0.19)), v_n- = (-1, +0.1), e = 1, frictionless. Contact 1
    alone (pi_1 = 2) drives contact 2 to v_n2+ = 0.1 - 0.9 * 2 < 0, so both act:
    [[1, -.9], [-.9, 1]] pi = (2, -0.1) (u_n = 0 at both: v_n1+ = 1, v_n2+ = 0), i.e.
    pi = (1.91, 1.7) / 0.19 = (10.0526..., 8.9473...). Coulomb's and the CCP law agree."""
    n1 = np.array([1.0, 0.0])
    n2 = np.array([-0.9, math.sqrt(0.19)])
    Jc = [np.array([n1, [0.0, 1.0]]), np.array([n2, [-n2[1], n2[0]]])]
    dq = np.linalg.solve(np.array([n1, n2]), [-1.0, 0.1])
    for law in ("pereira-nikravesh", "coulomb", "ccp"):
        for method in PATHS:
            r = ci.resolve_impact(np.eye(2), Jc, dq, e=1.0, mu=0.0, law=law, method=method)
            np.testing.assert_allclose(r.impulse[:, 0], [1.91 / 0.19, 1.7 / 0.19], rtol=1e-9)
            np.testing.assert_allclose(r.v_plus[:, 0], [1.0, 0.0], atol=1e-9)


@pytest.mark.parametrize("e,mu", [(0.0, 0.1), (0.5, 0.05)])
def test_block_landing_flat_while_sliding_slides_on_both_corners(e, mu):
    """The block (w = 0.2, h = 1, m = 1) lands flat, translating at (2, -1). Sticking needs a
    friction impulse 2 > mu (1 + e): both corners slide. With v_n+ = -e v_n- at both corners
    the block does not rotate, v_y+ = e; the most dissipative slide puts all friction on the
    cones, mu (1 + e) in total, so v_x+ = 2 - mu (1 + e); the moment of that friction about the
    centre, (h/2) mu (1 + e), is balanced by (w/2)(pi_nR - pi_nL), both pi_n >= 0 while
    mu <= w / h."""
    mech = make_block().mechanism
    args = ci.impact_arguments(mech, np.array([0.0, 0.5, 0.0]), np.array([2.0, -1.0, 0.0]),
                               ["left_corner", "right_corner"], e=e, mu=mu)
    for method in PATHS:
        r = ci.resolve_impact(**args, law="pereira-nikravesh", method=method)
        np.testing.assert_allclose(r.dq_plus, [2.0 - mu * (1 + e), e, 0.0], atol=1e-9)
        assert r.regime == ("slide", "slide")
        assert r.diagnostics.extras["active_set"] == [0, 1]
        assert r.impulse[:, 0].sum() == pytest.approx(1 + e, rel=1e-9)


def block_matrices(width=0.2, height=1.0):
    """M and the corners' Jacobians [left, right] of the free block (x, y, phi), m = 1, written
    out: a corner at r from the centre moves at (x' - phi' r_y, y' + phi' r_x); rows
    n = +y, t = -x (the scene's frame)."""
    b, c = width / 2, height / 2
    M = np.diag([1.0, 1.0, (width ** 2 + height ** 2) / 12])
    J = [np.array([[0.0, 1.0, rx], [-1.0, 0.0, -c]]) for rx in (-b, b)]
    return M, J


@pytest.mark.parametrize("vx", [3.0, -3.0])
@pytest.mark.parametrize("mu", [1.0, 0.2])
def test_sliding_pivot_at_round_off_is_not_kicked(vx, mu):
    """The block lands on its left corner while rotating about its right one AND sliding at
    vx: the pivot slips along the floor at |vx| while touching (v_n- = delta). The maximal-
    dissipation laws gave a touching contact no friction of its own but an approaching one
    its full cone, so at delta = -1e-12 they kicked the pivot (dq+ changed by 0.3 against
    delta = +1e-12). With round-off counted as touching, every law lifts the pivot with no
    impulse, so the answer is the single-contact answer of the landing corner alone (the
    exact kernel, ``method="fast"``: a second method)."""
    M, J = block_matrices()
    b, c = 0.1, 0.5
    for delta in PERTURBATIONS:
        eps = delta / 0.2
        dq = np.array([vx - c, -b, 1.0]) + eps * np.array([-c, b, 1.0])
        assert float(J[1][0] @ dq) == pytest.approx(delta, abs=1e-16)
        assert abs(float(J[1][1] @ dq)) == pytest.approx(abs(vx), rel=1e-12)  # sliding
        for law in ci.LAWS:
            alone = ci.resolve_impact(M, J[0], dq, e=0.0, mu=mu, law=law, method="fast")
            for method in PATHS:
                r = ci.resolve_impact(M, J, dq, e=0.0, mu=mu, law=law, method=method)
                np.testing.assert_allclose(r.dq_plus, alone.dq_plus, rtol=0, atol=1e-10 * abs(vx),
                                           err_msg=f"{law} {method} {delta}")
                assert np.all(r.impulse[1] == 0.0) or np.max(np.abs(r.impulse[1])) <= 1e-12
