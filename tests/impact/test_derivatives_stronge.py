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

from convimpact.impact.errors import NotSupportedError, ParameterError
from convimpact.impact.laws.stronge import impulse_derivative, several_impulse_derivative
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
    zero_slip = not np.any(v[1:])
    # a zero pre-impact slip is a boundary in v_t: tested one-sided below
    skip = [("v", j) for j in range(1, d)] if zero_slip else []
    assert worst_error(W, v, e, mu, D, skip) < 1e-8
    if zero_slip:
        assert any("zero pre-impact slip" in s for s in D.one_sided)
    else:
        assert D.one_sided == ()

