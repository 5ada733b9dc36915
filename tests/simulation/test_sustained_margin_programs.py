"""The largest smallest margin of redundant contacts' forces (max_margin_distribution): its
margin-only paths (``below``: the first stage alone; ``warm``: Newton's method at the last
program's active set) against a closed form.

Four sticking corners (+-a, 0, +-c) of a body on a plane (n = +y), loaded by m g along -y and
a tangential force T along x through the corners' centroid (no moment about it): the 12
forces (N_i, T1_i, T2_i) balance 6 equations, 6 directions are indeterminate. The margins
mu N_i - |(T1_i, T2_i)| sum, whatever the distribution, to at most mu m g - T (sum N_i = m g
and sum |T_i| >= |sum T_i| = T), so the smallest is at most (mu m g - T) / 4, which the
equal shares N_i = m g / 4, T_i = (T / 4, 0) reach: t* = (mu m g - T) / 4, positive or not.
"""

from __future__ import annotations

import numpy as np
import pytest

from convimpact.simulation.force_distribution import STICK, max_margin_distribution

M, G, MU, A, C = 1.0, 9.81, 0.5, 0.3, 0.2
CORNERS = [(-A, -C), (A, -C), (A, C), (-A, C)]


def _problem(T):
    """(lam0, Z): the least-norm balanced forces (12,) and the indeterminate directions."""
    B = np.zeros((6, 12))  # rows: force x, y, z, moment x, y, z about the centroid
    for i, (x, z) in enumerate(CORNERS):
        n, t1, t2 = 3 * i, 3 * i + 1, 3 * i + 2
        B[1, n] = B[0, t1] = B[2, t2] = 1.0
        # r x f with r = (x, 0, z), f = (T1, N, T2)
        B[3, n], B[4, t1], B[4, t2], B[5, n] = -z, z, -x, x
    rhs = np.array([T, M * G, 0.0, 0.0, 0.0, 0.0])
    lam0 = np.linalg.lstsq(B, rhs, rcond=None)[0]
    _, sv, Vt = np.linalg.svd(B)
    Z = Vt[int(np.sum(sv > 1e-12 * sv[0])):].T
    return lam0, Z


def _largest(T):
    return (MU * M * G - T) / 4.0


@pytest.mark.parametrize("T", [1.0, 2.0, 4.9])
def test_the_full_program_and_its_first_stage_reach_the_closed_form_margin(T):
    lam0, Z = _problem(T)
    mu, combo = np.full(4, MU), [STICK] * 4
    lam, margin = max_margin_distribution(mu, 3, combo, lam0, Z, M * G)
    assert margin == pytest.approx(_largest(T), abs=1e-10)
    np.testing.assert_allclose(lam.reshape(4, 3), np.tile([M * G / 4, T / 4, 0.0], (4, 1)),
                               atol=1e-9)  # the equal shares: the maximizer is unique here
    _, first = max_margin_distribution(mu, 3, combo, lam0, Z, M * G, below=np.inf)
    assert first == pytest.approx(_largest(T), abs=1e-10)


def test_warm_started_margins_follow_the_closed_form_through_zero():
    """A sequence of loads through the group's slip threshold T = mu m g: each margin-only
    call after the first starts from the last one's active set."""
    mu, combo, warm = np.full(4, MU), [STICK] * 4, {}
    for T in np.linspace(4.0, 5.5, 7):
        lam0, Z = _problem(T)
        _, margin = max_margin_distribution(mu, 3, combo, lam0, Z, M * G, below=np.inf,
                                            warm=warm)
        assert margin == pytest.approx(_largest(T), abs=1e-10)
    assert warm.get("active") is not None


def test_a_combination_clearly_below_the_bound_is_left_after_the_first_stage():
    """Past the threshold (T > mu m g) the largest margin is negative: asked only whether
    it reaches ``below``, the program answers with that margin (no distribution chosen)."""
    T = 6.0
    lam0, Z = _problem(T)
    _, margin = max_margin_distribution(np.full(4, MU), 3, [STICK] * 4, lam0, Z, M * G,
                                        below=-1e-9 * M * G)
    assert margin == pytest.approx(_largest(T), abs=1e-10)
    assert margin < 0.0
