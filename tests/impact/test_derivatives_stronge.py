"""Law "stronge": the exact impulse derivative (convimpact.impact.laws.stronge_derivative)
against finite differences of the public law (build_problem + solve_problem(..., "stronge")),
hand-derived closed forms, and the one-sided statements at the mode boundaries.

The data are built as M = W^-1, Jc = I, dq = v- so that v- is exact (a zero pre-impact slip
stays zero) and W is W to round-off. Finite differences are the fourth-order central stencil
(step 1e-4, a thousandth of the smallest velocity: truncation ~1e-12, the law's own
round-off ~1e-14 / 1e-4), one-sided ones a
third-order forward stencil at a boundary.
"""

from __future__ import annotations

import numpy as np
import pytest

from convimpact.errors import ParameterError
from convimpact.impact.laws.stronge import impulse_derivative
from convimpact.impact.problem.build import build_problem
from convimpact.impact.resolve import solve_problem

H = 1e-4


def solve(W, v, e, mu):
    W = np.asarray(W, dtype=float)
    P = build_problem(np.linalg.inv(W), np.eye(len(v)), np.asarray(v, dtype=float), e, mu)
    return P, solve_problem(P, "stronge")


def impulse(W, v, e, mu):
    return solve(W, v, e, mu)[1].impulse


def _perturbed(W, v, e, mu, which, t):
    """The data with parameter ``which`` moved by t: ("W", i, j) symmetric, ("v", j), "e",
    "mu"."""
    W, v = np.array(W, dtype=float), np.array(v, dtype=float)
    if which[0] == "W":
        _, i, j = which
        W[i, j] += t
        if i != j:
            W[j, i] += t
    elif which[0] == "v":
        v[which[1]] += t
    elif which == "e":
        e += t
    else:
        mu += t
    return W, v, e, mu


def central(W, v, e, mu, which, h=H):
    f = lambda t: impulse(*_perturbed(W, v, e, mu, which, t))  # noqa: E731
    return (-f(2 * h) + 8 * f(h) - 8 * f(-h) + f(-2 * h)) / (12 * h)


def one_sided(W, v, e, mu, which, sign, h=1e-4):
    """Third-order one-sided difference on the side ``sign`` (+1: t > 0)."""
    f = lambda t: impulse(*_perturbed(W, v, e, mu, which, sign * t))  # noqa: E731
    return sign * (-11 * f(0) + 18 * f(h) - 9 * f(2 * h) + 2 * f(3 * h)) / (6 * h)


def column(D, which):
    """The derivative's column for a perturbation ``which`` (symmetric for W)."""
    if which[0] == "W":
        _, i, j = which
        return D.W[:, i, j] + (D.W[:, j, i] if i != j else 0.0)
    if which[0] == "v":
        return D.v[:, which[1]]
    return (D.e if which == "e" else D.mu)[:, 0]


def parameters(d):
    return ([("W", i, j) for i in range(d) for j in range(i, d)]
            + [("v", j) for j in range(d)] + ["e", "mu"])


def derivative(W, v, e, mu, other_side=False):
    P, r = solve(W, v, e, mu)
    return impulse_derivative(P, r, other_side=other_side), r


def worst_error(W, v, e, mu, D, skip=()):
    """max over the parameters of |ours - FD| relative to the derivative's scale."""
    d = len(v)
    ours = {w: column(D, w) for w in parameters(d) if w not in skip}
    fd = {w: central(W, v, e, mu, w) for w in ours}
    scale = max(np.max(np.abs(x)) for x in fd.values())
    return max(np.max(np.abs(ours[w] - fd[w])) for w in ours) / scale


W2 = [[2.0, 0.5], [0.5, 1.0]]
W3 = [[2.0, 0.5, 0.3], [0.5, 1.0, 0.2], [0.3, 0.2, 1.5]]


@pytest.mark.parametrize("name, W, v, e, mu, phases", [
    ("slip throughout", W2, [-1.0, 2.0], 0.5, 0.3, "slip"),
    ("slip -> stick, stop in compression", W2, [-1.0, 0.2], 0.5, 0.8, "slip-stick"),
    ("slip -> stick, stop in restitution", W2, [-1.0, 0.3], 0.9, 0.8, "slip-stick"),
    ("slip -> reversal", [[2.0, 0.9], [0.9, 1.0]], [-1.0, -0.1], 0.5, 0.3, "slip-reversal"),
    ("slip -> reversal in restitution", [[2.0, 0.9], [0.9, 1.0]], [-1.0, -0.6], 0.9, 0.3,
     "slip-reversal"),
    ("stick from the start", W2, [-1.0, 0.0], 0.5, 0.8, "stick"),
    ("onset from the start", [[2.0, 0.9], [0.9, 1.0]], [-1.0, 0.0], 0.5, 0.3, "onset"),
    ("spatial curved slip throughout", W3, [-1.0, 3.0, -2.0], 0.6, 0.3, "slip"),
    ("spatial curved slip, stops in restitution", W3, [-1.0, 0.3, -0.4], 0.6, 0.9, "slip"),
    ("spatial curved slip -> stick", W3, [-1.0, 0.1, -0.15], 0.6, 0.9, "slip-stick"),
    # the slip settles on the stable stopping direction -t1 (mu W_t2t2 > W_t1t1 mu + W_nt1),
    # stops, and cannot stick (|W_tt^-1 W_tn| = 1 > mu): onset along +t1
    ("spatial curved slip -> onset", [[2.0, 0.5, 0.0], [0.5, 0.5, 0.0], [0.0, 0.0, 2.0]],
     [-1.0, -0.1, 0.1], 0.6, 0.5, "slip-onset"),
    ("spatial stick from the start", W3, [-1.0, 0.0, 0.0], 0.5, 0.9, "stick"),
    ("spatial onset from the start", [[2.0, 0.9, 0.5], [0.9, 1.0, 0.1], [0.5, 0.1, 1.2]],
     [-1.0, 0.0, 0.0], 0.6, 0.3, "onset"),
])
def test_every_phase_sequence_against_finite_differences(name, W, v, e, mu, phases):
    D, r = derivative(W, v, e, mu)
    assert D.regimes == (phases,)
    d = len(v)
    # a zero pre-impact slip followed by an onset is a boundary in v_t; followed by a stick
    # it is none, but the impulse is only once differentiable there (a central difference
    # straddles the kink of its second derivative): both tested one-sided below
    zero_slip = not np.any(v[1:])
    onset = zero_slip and phases == "onset"
    skip = [("v", j) for j in range(1, d)] if zero_slip else []
    assert worst_error(W, v, e, mu, D, skip) < 1e-8
    if onset:
        assert any("zero pre-impact slip" in s for s in D.one_sided)
    else:
        assert D.one_sided == ()



# --------------------------------------------------------------------------------------------
# closed forms derived by hand


def test_frictionless_newton_closed_form_and_right_derivative_in_mu():
    """mu = 0: pi_n = -(1 + e) v_n / W_nn. For mu -> 0+ a slip that does not stop has one
    linear phase, pi = (1 + e) p_c (1, -mu s) with p_c = -v_n / (W_nn - mu s W_tn): so
    d pi_n / d mu = -(1 + e) v_n s W_tn / W_nn^2 and d pi_t / d mu = (1 + e) v_n s / W_nn."""
    A, B, vn, e, s = 2.0, 0.5, -1.0, 0.5, 1.0
    D, r = derivative(W2, [vn, 0.3], e, 0.0)
    assert D.regimes == ("frictionless",)
    np.testing.assert_allclose(r.impulse, [-(1 + e) * vn / A, 0.0], rtol=1e-15)
    np.testing.assert_allclose(column(D, "e"), [-vn / A, 0.0], rtol=1e-14, atol=1e-16)
    np.testing.assert_allclose(column(D, ("v", 0)), [-(1 + e) / A, 0.0], rtol=1e-14,
                               atol=1e-16)
    np.testing.assert_allclose(column(D, ("W", 0, 0)), [(1 + e) * vn / A ** 2, 0.0],
                               rtol=1e-14, atol=1e-16)
    np.testing.assert_allclose(column(D, "mu"),
                               [-(1 + e) * vn * s * B / A ** 2, (1 + e) * vn * s / A],
                               rtol=1e-13)
    assert any("mu = 0" in t for t in D.one_sided)
    # the right derivative is the forward difference's
    np.testing.assert_allclose(column(D, "mu"), one_sided(W2, [vn, 0.3], e, 0.0, "mu", +1),
                               rtol=1e-7)


def test_stick_from_the_start_closed_form():
    """A contact at rest that can stick (|W_tn| <= mu W_tt) sticks throughout, one linear
    phase: pi = (1 + e) p_c (1, lambda_s), lambda_s = -W_tn / W_tt,
    p_c = -v_n W_tt / det W. By hand: d pi / d e = p_c (1, lambda_s),
    d pi_n / d v_n = -(1 + e) W_tt / det W, d pi_n / d mu = 0."""
    A, B, C, vn, e = 2.0, 0.5, 1.0, -1.0, 0.5
    det = A * C - B * B
    pc, lam = -vn * C / det, -B / C
    D, r = derivative(W2, [vn, 0.0], e, 0.8)
    assert D.regimes == ("stick",)
    np.testing.assert_allclose(r.impulse, (1 + e) * pc * np.array([1.0, lam]), rtol=1e-14)
    np.testing.assert_allclose(column(D, "e"), pc * np.array([1.0, lam]), rtol=1e-13)
    np.testing.assert_allclose(column(D, ("v", 0)), -(1 + e) * C / det * np.array([1, lam]),
                               rtol=1e-13)
    np.testing.assert_allclose(column(D, "mu"), [0.0, 0.0], atol=1e-15)
    # d pi / d W_nn = (1 + e) v_n C^2 / det^2 (1, lambda_s) (lambda_s does not depend on A)
    np.testing.assert_allclose(column(D, ("W", 0, 0)),
                               (1 + e) * vn * C * C / det ** 2 * np.array([1, lam]),
                               rtol=1e-13)


def test_slip_throughout_closed_form():
    """One slip phase: pi = (1 + e) p_c (1, -mu s), p_c = -v_n / a_n, a_n = W_nn - mu s W_tn;
    d pi_n / d W_tn = -(1 + e) v_n mu s / a_n^2 (the symmetric pair W_nt = W_tn)."""
    A, B, vn, e, mu, s = 2.0, 0.5, -1.0, 0.5, 0.3, 1.0
    an = A - mu * s * B
    D, r = derivative(W2, [vn, 2.0], e, mu)
    assert D.regimes == ("slip",)
    pn = -(1 + e) * vn / an
    np.testing.assert_allclose(r.impulse, [pn, -mu * s * pn], rtol=1e-14)
    dn = -(1 + e) * vn * mu * s / an ** 2
    np.testing.assert_allclose(column(D, ("W", 0, 1)), [dn, -mu * s * dn], rtol=1e-13)
    np.testing.assert_allclose(column(D, ("W", 1, 1)), [0.0, 0.0], atol=1e-15)
    np.testing.assert_allclose(column(D, ("v", 1)), [0.0, 0.0], atol=1e-15)


# --------------------------------------------------------------------------------------------
# mode boundaries


def _sides_match(D, W, v, e, mu, which):
    """The derivative and its other side are the two one-sided differences (either way)."""
    plus, minus = (one_sided(W, v, e, mu, which, sg, 1e-5) for sg in (1, -1))
    ours, other = column(D, which), column(D.other_side, which)
    scale = max(np.max(np.abs(plus)), np.max(np.abs(minus)))
    assert np.max(np.abs(plus - minus)) > 1e-3 * scale  # a true kink
    err = min(max(np.max(np.abs(ours - plus)), np.max(np.abs(other - minus))),
              max(np.max(np.abs(ours - minus)), np.max(np.abs(other - plus))))
    assert err < 1e-6 * scale


def test_stick_or_slip_at_rest_boundary_is_one_sided_in_mu():
    """|W_tn| = mu W_tt when the slip stops: stick for mu above, reversal below."""
    D, _ = derivative(W2, [-1.0, -0.2], 0.5, 0.5, other_side=True)
    assert any("between stick and slip" in t for t in D.one_sided)
    assert D.regimes == ("slip-stick",) and D.other_side.regimes == ("slip-reversal",)
    np.testing.assert_allclose(column(D, "mu"), one_sided(W2, [-1.0, -0.2], 0.5, 0.5, "mu",
                                                           +1, 1e-5), rtol=1e-6)
    np.testing.assert_allclose(column(D.other_side, "mu"),
                               one_sided(W2, [-1.0, -0.2], 0.5, 0.5, "mu", -1, 1e-5),
                               rtol=1e-6)


def test_slip_stopping_at_the_end_of_restitution_is_one_sided():
    """p_s = v_t / (mu W_tt - W_tn) = 0.35625 / 0.3 = 1.1875 = (1 + e) p_c = p_f."""
    W, v, e, mu = W2, [-1.0, 0.35625], 0.9, 0.8
    D, _ = derivative(W, v, e, mu, other_side=True)
    assert any("end of restitution" in t for t in D.one_sided)
    _sides_match(D, W, v, e, mu, ("v", 1))


def test_slip_stopping_at_the_end_of_compression_is_no_boundary():
    """p_s = p_c = 0.1875 / 0.3 = 0.625: p_c(theta) has a kink there, the impulse has none
    (W_n(p_c) is the minimum of W_n, stationary in p): both one-sided differences agree with
    the derivative, and no boundary is stated."""
    W, v, e, mu = W2, [-1.0, 0.1875], 0.5, 0.8
    D, _ = derivative(W, v, e, mu)
    assert D.one_sided == ()
    for which in (("v", 1), ("W", 0, 1), "mu"):
        for sg in (1, -1):
            np.testing.assert_allclose(column(D, which),
                                       one_sided(W, v, e, mu, which, sg, 1e-5), rtol=1e-6)


@pytest.mark.parametrize("W, v, e, mu", [
    ([[2.0, 0.9], [0.9, 1.0]], [-1.0, 0.0], 0.5, 0.3),  # planar onset from rest
    ([[2.0, 0.5, 0.0], [0.5, 0.5, 0.0], [0.0, 0.0, 2.0]], [-1.0, 0.0, 0.0], 0.5, 0.5),
])
def test_zero_pre_impact_slip_with_onset_is_one_sided_in_v_t(W, v, e, mu):
    """At rest with |W_tt^-1 W_tn| > mu: a slip started along +t and one along -t lead to
    different first-order impulses (along the onset direction nothing changes; against it,
    the slip stops first; across it (space), it turns toward it): one-sided, per tangent."""
    D, _ = derivative(W, v, e, mu, other_side=True)
    assert any("zero pre-impact slip" in t for t in D.one_sided)
    for j in range(1, len(v)):
        _sides_match(D, W, v, e, mu, ("v", j))


@pytest.mark.parametrize("W, v, e, mu", [
    (W2, [-1.0, 0.0], 0.5, 0.8),
    (W3, [-1.0, 0.0, 0.0], 0.5, 0.9),
])
def test_zero_pre_impact_slip_that_sticks_is_two_sided(W, v, e, mu):
    """A contact at rest that sticks: a small slip either way stops and sticks, and the
    impulse is differentiable in v_t (both one-sided differences agree with it)."""
    D, _ = derivative(W, v, e, mu)
    assert D.one_sided == ()
    for j in range(1, len(v)):
        for sg in (1, -1):
            np.testing.assert_allclose(column(D, ("v", j)),
                                       one_sided(W, v, e, mu, ("v", j), sg, 1e-5), rtol=1e-6)


@pytest.mark.parametrize("W, v", [(W2, [-1.0, 0.3]), (W3, [-1.0, 0.3, 0.2])])
def test_zero_restitution_gives_the_right_derivative_in_e(W, v):
    """e = 0 ends the collision at p_c; for e -> 0+ restitution adds
    e sqrt(2 |W_n(p_c)| / a_n) of normal impulse (step 1e-3: the law's restitution target
    (1 - e^2) W_n(p_c) loses e^2's digits to round-off for tiny e)."""
    mu = 0.8 if len(v) == 2 else 0.4
    D, _ = derivative(W, v, 0.0, mu, other_side=True)
    assert any("e = 0" in t for t in D.one_sided)
    assert D.other_side is None  # e < 0 is no restitution: there is no other side
    np.testing.assert_allclose(column(D, "e"), one_sided(W, v, 0.0, mu, "e", +1, 1e-3),
                               rtol=1e-7)


def test_touching_contact_is_one_sided_in_v_n():
    """v_n- = 0: no impulse (zero derivative); the other side is the approaching limit,
    pi = -(1 + e) v_n (1, -mu s) / (W_nn - mu s W_tn) + o(v_n)."""
    A, B, e, mu = 2.0, 0.5, 0.5, 0.5
    D, r = derivative(W2, [0.0, 0.3], e, mu, other_side=True)
    assert D.regimes == ("separating",) and np.all(D.v == 0.0)
    assert D.other_side.regimes == ("slip",)
    assert any("v_n- = 0" in t for t in D.one_sided)
    expect = -(1 + e) * np.array([1.0, -mu]) / (A - mu * B)
    np.testing.assert_allclose(column(D.other_side, ("v", 0)), expect, rtol=1e-14)
    np.testing.assert_allclose(expect, one_sided(W2, [0.0, 0.3], e, mu, ("v", 0), -1),
                               rtol=1e-8)


def test_a_result_of_another_problem_or_law_is_refused():
    P, r = solve(W2, [-1.0, 0.2], 0.5, 0.8)
    P2, r2 = solve(W2, [-1.0, 0.4], 0.5, 0.8)
    with pytest.raises(ParameterError, match="not this problem's answer"):
        impulse_derivative(P, r2)
    with pytest.raises(ParameterError, match="law"):
        impulse_derivative(P, solve_problem(P, "ccp"))


def test_spatial_stick_or_onset_at_rest_boundary():
    """mu = |W_tt^-1 W_tn| with the contact at rest: stick for mu above, onset below (mu and
    W_tn move the contact across); v_t has no directional derivative there (a slip started
    along a tangent slows without stopping): stated."""
    W, v, e = np.array(W3), [-1.0, 0.0, 0.0], 0.5
    mu = float(np.linalg.norm(np.linalg.solve(W[1:, 1:], W[1:, 0])))
    D, _ = derivative(W, v, e, mu, other_side=True)
    assert D.regimes == ("stick",) and D.other_side.regimes == ("onset",)
    assert any("between stick and slip" in t for t in D.one_sided)
    assert any("slows without stopping" in t for t in D.one_sided)
    for which in ("mu", ("W", 0, 1)):
        _sides_match(D, W, v, e, mu, which)


def test_inside_a_mode_there_is_no_other_side():
    D, _ = derivative(W3, [-1.0, 0.3, -0.4], 0.6, 0.9, other_side=True)
    assert D.one_sided == () and D.other_side is None


@pytest.mark.parametrize("v", [[-1.0, 0.2], [-1.0, 0.3, -0.4]])
def test_units(v):
    """The law is homogeneous, pi(a W, b v) = (b / a) pi(W, v): in units where W is 1e6 and
    v 1e-3 times larger, d pi / dW scales by b / a^2, d pi / dv by 1 / a, d pi / d(e, mu) by
    b / a -- and the derivative there still matches central differences (steps scaled)."""
    W = np.array(W2 if len(v) == 2 else W3)
    a, b = 1e6, 1e-3
    D, _ = derivative(W, v, 0.6, 0.9)
    Ds, _ = derivative(a * W, b * np.array(v), 0.6, 0.9)
    np.testing.assert_allclose(Ds.W, D.W * b / a ** 2, rtol=1e-9, atol=1e-12 * b / a ** 2)
    np.testing.assert_allclose(Ds.v, D.v / a, rtol=1e-9, atol=1e-12 / a)
    np.testing.assert_allclose(Ds.mu, D.mu * b / a, rtol=1e-9, atol=1e-12 * b / a)
    fd = central(a * W, b * np.array(v), 0.6, 0.9, ("W", 0, 1), h=1e-4 * a)
    np.testing.assert_allclose(column(Ds, ("W", 0, 1)), fd, rtol=1e-7)


@pytest.mark.parametrize("W, v, mu", [
    ([[2.0, 0.9], [0.9, 1.0]], [-1.0, -1e-17], 0.3),  # a round-off slip against W_tn
    ([[2.0, 0.5, 0.0], [0.5, 0.5, 0.0], [0.0, 0.0, 2.0]], [-1.0, 0.0, 1e-17], 0.5),
])
def test_round_off_pre_impact_slip_is_a_zero_slip(W, v, mu):
    """A pre-impact slip of 1e-17 (cos / sin round-off) is a zero slip's boundary too: the
    derivative is one side's (in the plane the round-off slip's sign), the other side the
    opposite direction's -- as the one-sided differences from exactly zero slip say."""
    e = 0.5
    D, _ = derivative(W, v, e, mu, other_side=True)
    assert any("zero pre-impact slip" in t for t in D.one_sided)
    zero = [v[0]] + [0.0] * (len(v) - 1)
    plus, minus = (one_sided(W, zero, e, mu, ("v", 1), sg, 1e-5) for sg in (1, -1))
    first, second = (minus, plus) if len(v) == 2 else (plus, minus)
    scale = np.max(np.abs(plus)) + np.max(np.abs(minus))
    np.testing.assert_allclose(column(D, ("v", 1)), first, atol=1e-6 * scale)
    np.testing.assert_allclose(column(D.other_side, ("v", 1)), second, atol=1e-6 * scale)
