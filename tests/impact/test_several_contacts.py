"""The exact several-contact solver (``method="interior"``, convimpact.impact.several.interior):
laws ccp and dissipative (a convex cone program) and coulomb (Newton on its natural map).

Oracles: a second method (Clarabel's and cvxpy's conic paths, KKT-polished), hand derivations
(a planar box landing flat on two corners: frictionless, and sticking with a large mu), the
frictionless law as a non-negative least-squares problem solved by scipy's NNLS, and the KKT
conditions of the law recomputed here from the answer.
"""

import numpy as np
import pytest
import scipy.linalg as sla
from scipy.optimize import nnls

import convimpact as ci
from convimpact.bench.several_problems import four_corner_box, random_several
from convimpact.impact.problem.build import build_problem
from convimpact.impact.resolve import SINGLE_CONTACT_METHODS, choose_method

LAWS = ("ccp", "dissipative")
ALL_LAWS = ("ccp", "dissipative", "coulomb")


def _relative(a, b):
    return np.abs(np.asarray(a) - np.asarray(b)).max() / max(np.abs(b).max(), 1e-300)


@pytest.mark.parametrize("law", LAWS)
@pytest.mark.parametrize("mu", [0.1, 0.3, 1.0])
def test_four_corner_box_matches_the_conic_paths(law, mu):
    """Rank-6 W of size 12: impulses are not unique, theta_dot+ is."""
    args = four_corner_box(mu=mu)
    r = ci.resolve_impact(**args, law=law, method="interior")
    for method in ("clarabel", "cvxpy"):
        ref = ci.resolve_impact(**args, law=law, method=method)
        assert _relative(r.dq_plus, ref.dq_plus) <= 1e-8, method
        assert r.regime == ref.regime
    # the total impulse on the box (force and moment) is unique as well
    J = np.vstack(args["Jc"])
    assert _relative(J.T @ r.impulse.ravel(), J.T @ ref.impulse.ravel()) <= 1e-8
    assert r.diagnostics.extras["kkt_residual"] <= 1e-10


@pytest.mark.parametrize("seed", range(12))
def test_random_two_to_eight_contacts_match_clarabel(seed):
    n = 2 + seed % 7
    dim = 2 + seed % 2
    args = random_several(seed, n, dim)
    for law in ALL_LAWS:
        r = ci.resolve_impact(**args, law=law, method="interior")
        ref = ci.resolve_impact(**args, law=law, method="clarabel")
        assert _relative(r.impulse, ref.impulse) <= 1e-8, (law, n, dim)
        assert _relative(r.dq_plus, ref.dq_plus) <= 1e-8
        assert r.regime == ref.regime


def test_cvxpy_agrees_on_a_spatial_eight_contact_problem():
    args = random_several(99, 8, 3, cond=1e3)
    r = ci.resolve_impact(**args, law="ccp", method="interior")
    ref = ci.resolve_impact(**args, law="ccp", method="cvxpy")
    assert _relative(r.impulse, ref.impulse) <= 1e-8


def _planar_box(vx, vy, omega=0.0, a=0.3, c=0.1, m=2.0):
    """A planar box (x, y, phi) landing flat on its corners (+-a, -c); frames (n, t) = (y, x)."""
    inertia = m * (4 * a * a + 4 * c * c) / 12.0
    M = np.diag([m, m, inertia])
    # velocity of corner p: v + omega x p = (vx - omega p_y, vy + omega p_x)
    Jc = [np.array([[0.0, 1.0, sx * a], [1.0, 0.0, c]]) for sx in (-1.0, 1.0)]
    return M, Jc, np.array([vx, vy, omega])


@pytest.mark.parametrize("law", LAWS)
@pytest.mark.parametrize("e", [0.0, 0.5, 1.0])
def test_two_symmetric_frictionless_contacts_by_hand(law, e):
    """Flat landing, mu = 0: each corner takes m (1 + e) |v_y| / 2 and the box rebounds at
    -e v_y without turning (ccp and Poisson's scaling both give Newton's rebound here)."""
    m, vy = 2.0, -1.5
    M, Jc, dq = _planar_box(0.7, vy, m=m)
    r = ci.resolve_impact(M, Jc, dq, e=e, mu=0.0, law=law, method="interior")
    expected = m * (1 + e) * abs(vy) / 2
    np.testing.assert_allclose(r.impulse[:, 0], [expected, expected], rtol=1e-12)
    np.testing.assert_allclose(r.impulse[:, 1], [0.0, 0.0], atol=1e-12 * expected)
    np.testing.assert_allclose(r.dq_plus, [0.7, -e * vy, 0.0], atol=1e-12)
    assert r.regime == ("frictionless", "frictionless")


@pytest.mark.parametrize("law", ["ccp", "coulomb"])
@pytest.mark.parametrize("e", [0.0, 0.4])
def test_two_contacts_sticking_by_hand(e, law):
    """Flat landing with mu = 2 (m |v_x| well inside mu m (1 + e) |v_y|): both corners stick,
    theta_dot+ = (0, -e v_y, 0) -- the only motion with zero slip and Newton's normal velocity
    at both corners. W is singular (4 rows, 3 coordinates); the net impulse is
    (-m v_x, -m (1 + e) v_y) with no moment."""
    m, vx, vy = 2.0, 0.6, -1.5
    M, Jc, dq = _planar_box(vx, vy, m=m)
    r = ci.resolve_impact(M, Jc, dq, e=e, mu=2.0, law=law, method="interior")
    np.testing.assert_allclose(r.dq_plus, [0.0, -e * vy, 0.0], atol=1e-11)
    assert r.regime == ("stick", "stick")
    np.testing.assert_allclose(r.impulse.sum(axis=0), [-m * (1 + e) * vy, -m * vx], rtol=1e-11)


@pytest.mark.parametrize("law", ALL_LAWS)
@pytest.mark.parametrize("seed", range(6))
def test_frictionless_contacts_equal_nnls(seed, law):
    """mu = 0: min 1/2 |A pi|^2 + b^T pi over pi >= 0 (W = A^T A, A = L^-1 Jn^T) is the NNLS
    problem min |A pi + c| with A^T c = b."""
    n = 2 + seed
    args = random_several(seed, n, 2 + seed % 2)
    args["mu"] = 0.0
    if law == "dissipative":
        args["e"] = 0.0  # its plastic phase; Poisson's scaling is tested by hand above
    r = ci.resolve_impact(**args, law=law, method="interior")
    P = build_problem(args["M"], args["Jc"], args["dq"], args["e"], 0.0, None)
    Jn = np.array([J[0] for J in args["Jc"]])
    A = sla.solve_triangular(np.linalg.cholesky(args["M"]), Jn.T, lower=True)
    b = P.v_minus[:, 0] + P.restitution * np.minimum(P.v_minus[:, 0], 0.0)
    c, *_ = np.linalg.lstsq(A.T, b, rcond=None)
    expected, _ = nnls(A, -c)
    assert _relative(r.impulse[:, 0], expected) <= 1e-9
    assert np.all(r.impulse[:, 1:] == 0.0)


@pytest.mark.parametrize("seed", range(8))
def test_answer_satisfies_the_laws_kkt_conditions(seed):
    """Recomputed here: pi in K_mu, z = W pi + b in K_mu*, pi_i . z_i = 0 per contact."""
    args = random_several(100 + seed, 2 + seed % 7, 3 - seed % 2)
    r = ci.resolve_impact(**args, law="ccp", method="interior")
    P = build_problem(args["M"], args["Jc"], args["dq"], args["e"], args["mu"], None)
    b = P.v_minus.copy()
    b[:, 0] += P.restitution * np.minimum(P.v_minus[:, 0], 0.0)
    pi = r.impulse
    z = b + (P.delassus @ pi.ravel()).reshape(pi.shape)
    X, V = np.abs(pi).max(), np.abs(b).max()
    for i, mu in enumerate(P.friction):
        assert np.linalg.norm(pi[i, 1:]) <= mu * pi[i, 0] + 1e-12 * X
        assert mu * np.linalg.norm(z[i, 1:]) <= z[i, 0] + 1e-10 * V
        assert abs(pi[i] @ z[i]) <= 1e-10 * X * V
    assert r.diagnostics.extras["polished"] and r.diagnostics.extras["kkt_residual"] <= 1e-10


def test_auto_chooses_it_for_several_contacts_only():
    several = build_problem(**four_corner_box())
    assert choose_method(several, "ccp") == "interior"
    assert choose_method(several, "dissipative") == "interior"
    # Coulomb's law at several contacts takes the contact engine by default too
    assert choose_method(several, "coulomb") == "interior"
    assert ci.resolve_impact(**four_corner_box(), law="ccp").method == "interior"
    one = build_problem(np.eye(2), np.array([[0.0, 1.0], [1.0, 0.0]]), [1.0, -1.0], 0.5, 0.3)
    assert choose_method(one, "ccp") == "fast"
    assert "interior" not in SINGLE_CONTACT_METHODS


def test_a_rigid_pinch_has_no_solution_and_raises():
    """A particle between a floor and a ceiling: W is singular and, with e = 0.5 on the
    floor, the CCP objective decreases without bound along equal opposite impulses."""
    Jc = [np.array([[0.0, 1.0], [1.0, 0.0]]), np.array([[0.0, -1.0], [1.0, 0.0]])]
    with pytest.raises(ci.SolverError, match="certificate"):
        ci.resolve_impact(np.eye(2), Jc, [0.3, -1.0], e=[0.5, 0.0], mu=0.3, law="ccp",
                          method="interior")


def test_iterations_cut_short_raise_instead_of_answering():
    args = random_several(5, 6, 3)
    with pytest.raises(ci.SolverError, match="certificate"):
        ci.resolve_impact(**args, law="ccp", method="interior", max_iter=2, newton_iter=0)


@pytest.mark.parametrize("options, error", [
    ({"tolerance": 1e-9}, ci.UnknownOptionError),
    ({"tol": 2.0}, ci.ParameterError),
    ({"tol": float("nan")}, ci.ParameterError),
    ({"max_iter": 0}, ci.ParameterError),
    ({"max_iter": True}, ci.ParameterError),
    ({"newton_iter": -1}, ci.ParameterError),
])
def test_bad_options_are_typed_errors(options, error):
    with pytest.raises(error):
        ci.resolve_impact(**four_corner_box(), law="ccp", method="interior", **options)


def test_laws_without_an_interior_path_say_so():
    with pytest.raises(ci.NotSupportedError, match="interior"):
        ci.resolve_impact(**four_corner_box(), law="pereira-nikravesh", method="interior")


@pytest.mark.parametrize("mu", [0.1, 0.3, 1.0])
def test_coulomb_on_the_box_satisfies_coulombs_conditions(mu):
    """Coulomb's law on four corners may have a family of solutions (the conic path may pick
    another): the answer is checked on the law itself, recomputed here -- pi in K_mu, and per
    contact either sticking (u = 0), or sliding with u_n = 0 and pi_t = -mu pi_n u_t / |u_t|,
    or separated (pi = 0, u_n >= 0) -- and on energy (the box's T+ <= T-)."""
    args = four_corner_box(mu=mu)
    r = ci.resolve_impact(**args, law="coulomb", method="interior")
    P = build_problem(args["M"], args["Jc"], args["dq"], args["e"], args["mu"], None)
    u = r.v_plus.copy()
    u[:, 0] += P.restitution * np.minimum(P.v_minus[:, 0], 0.0)
    X, V = np.abs(r.impulse).max(), np.abs(P.v_minus).max()
    for pi, ui in zip(r.impulse, u):
        assert np.linalg.norm(pi[1:]) <= mu * pi[0] + 1e-12 * X
        if pi[0] <= 1e-12 * X:
            assert ui[0] >= -1e-10 * V
        elif np.linalg.norm(ui[1:]) <= 1e-10 * V:
            assert abs(ui[0]) <= 1e-10 * V
        else:
            assert abs(ui[0]) <= 1e-10 * V
            np.testing.assert_allclose(pi[1:], -mu * pi[0] * ui[1:] / np.linalg.norm(ui[1:]),
                                       atol=1e-10 * X)
    assert r.energy_loss >= 0.0


#: an ill-conditioned closed-loop impact (cond(M) ~ 1e8, two planar contacts, two loop rows,
#: W singular) on which the interior path's Newton finish stalls at a certificate of 9e-9
ILL_CONDITIONED = dict(
    M=np.array([[48250752.17777422, -17053716.931289874, -40194675.79730325, -3069025.52529791],
                [-17053716.931289874, 6240702.894269733, 14244839.549250485, 1048579.2914307027],
                [-40194675.79730325, 14244839.549250485, 33491249.592327107, 2549948.6162327267],
                [-3069025.52529791, 1048579.2914307027, 2549948.6162327267, 201365.4461583318]]),
    Jc=[np.array([[0.6495531192293286, -1.1113182681288547, -1.3117843730010095,
                   -0.2472256852919779],
                  [-0.6905639340436003, -0.9874656567997497, -0.40040984779979955,
                   2.505621479668208]]),
        np.array([[0.38476445876770243, -0.11473027914250619, -0.32375773676848474,
                   1.3430071876894356],
                  [-0.11839687126148046, 0.2497917767282335, -0.20381923497281174,
                   2.2957600741215387]])],
    dq=np.array([-0.373936059181351, 1.0572110264239538, -0.5242930047136248,
                 -0.8239286443708125]),
    C=np.array([[0.36588007375131876, 0.3065221292346992, -0.8616089592282268,
                 0.7755263473916723],
                [-0.02719293706982823, 0.9401153049776061, -0.10155130746266813,
                 1.283255939217054]]),
    e=[0.3118694442244885, 0.07146961572314803], mu=[0.7483969244075669, 0.21442972994038803])


def test_auto_hands_an_uncertified_impact_to_clarabel_and_says_so():
    with pytest.raises(ci.SolverError, match="certificate"):
        ci.resolve_impact(**ILL_CONDITIONED, law="dissipative", method="interior")
    r = ci.resolve_impact(**ILL_CONDITIONED, law="dissipative")
    ref = ci.resolve_impact(**ILL_CONDITIONED, law="dissipative", method="clarabel")
    assert r.method == "clarabel"
    assert any("interior cannot treat this impact" in n and "used clarabel instead" in n
               for n in r.diagnostics.notes)
    np.testing.assert_array_equal(r.dq_plus, ref.dq_plus)
