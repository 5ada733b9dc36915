"""Dual (weak-duality) certificates of the largest-smallest-margin program
(simulation/force_dual.py) against a closed form and against Clarabel's optimum.

The closed form is test_sustained_margin_programs.py's: four sticking corners of a body on a
plane under m g and a tangential load T through their centroid; whatever the distribution,
the margins mu N_i - |T_i| sum to at most mu m g - T, so t* = (mu m g - T) / 4. The same sum
is the dual point: multipliers z_i = (1/4) (1, -1, 0) on every corner's cone (the ray
opposite the tangential load) give b'z = sum_i (mu N_i - T1_i) / 4 = (mu m g - T) / 4 for any
balanced distribution (A'z = 0: the sum is determinate), w'z = 1: the bound is t* itself.
"""

from __future__ import annotations

import numpy as np
import pytest

from convimpact.simulation import force_distribution, force_dual
from convimpact.simulation.force_distribution import (STICK, _clarabel, _margin_blocks,
                                                      _range_basis, max_margin_distribution)

from .test_sustained_margin_programs import MU, G, M, _largest, _problem

SCALE = M * G


def _blocks(T):
    lam0, Z = _problem(T)
    blocks = _margin_blocks(np.full(4, MU), 3, [STICK] * 4, lam0 / SCALE, _range_basis(Z))
    r = blocks[0][1].shape[1]
    blocks.append(("nn", np.zeros((1, r)), np.ones(1), np.ones(1)))  # tau <= 1
    return lam0, Z, blocks


def _equal_shares(beta=0.25, phi=0.0, corners=range(4)):
    """The active set of rays on ``corners`` with multipliers beta (1, -cos phi, -sin phi)."""
    kinds = [("ray", 3) if i in corners else None for i in range(4)] + [None]
    parts = [np.array([0.1, beta, phi]) if i in corners else np.zeros(0) for i in range(4)]
    return kinds, parts + [np.zeros(0)]


def _solver_optimum(blocks):
    """t* and the multipliers by Clarabel (stage 1's program)."""
    A = np.vstack([b[1] for b in blocks])
    b = np.concatenate([b[2] for b in blocks])
    w = np.concatenate([b[3] for b in blocks])
    r = A.shape[1]
    q = np.zeros(r + 1)
    q[r] = -1.0
    sol = _clarabel(np.zeros((r + 1, r + 1)), q, np.hstack([A, w[:, None]]), b,
                    [(k[0], len(k[2])) for k in blocks])
    assert str(sol.status) == "Solved"
    return float(sol.x[r]), np.asarray(sol.z, float)


@pytest.mark.parametrize("T", [1.0, 4.9, 6.0, 8.0])
def test_the_equal_shares_multipliers_bound_the_margin_by_its_closed_form(T):
    _, _, blocks = _blocks(T)
    bound = force_dual.refusal_bound(blocks, {"active": _equal_shares()})
    assert bound == pytest.approx(_largest(T) / SCALE, abs=1e-12)
    t_star, _ = _solver_optimum(blocks)
    assert t_star == pytest.approx(_largest(T) / SCALE, abs=1e-8)


def test_multipliers_off_the_dual_cone_or_off_stationarity_certify_nothing():
    _, _, blocks = _blocks(6.0)
    z = force_dual.active_multipliers(blocks, _equal_shares())
    assert force_dual.dual_bound(blocks, z) == pytest.approx(_largest(6.0) / SCALE, abs=1e-12)
    outside = z.copy()
    outside[1] *= 1.1  # |z_t| > z_0 on the first corner's cone
    assert force_dual.dual_bound(blocks, outside) is None
    three = force_dual.active_multipliers(blocks, _equal_shares(corners=range(3)))
    three *= 4.0 / 3.0  # w'z = 1, but the sum over three corners is not determinate
    assert force_dual.dual_bound(blocks, three) is None


def test_candidate_multipliers_from_elsewhere_are_moved_to_a_dual_point_that_bounds():
    """Multipliers of a nearby program (other sizes on the same rays; other angles) are
    moved onto A'z = 0, w'z = 1 and into the cones: the bound is exact from the rays' own
    angles (the equal shares, rescaled), and holds, within 0.2 % of t* here, from angles
    0.02 rad off."""
    _, _, blocks = _blocks(6.0)
    exact = _largest(6.0) / SCALE
    bound = force_dual.refusal_bound(blocks, {"active": _equal_shares(beta=0.4)})
    assert bound == pytest.approx(exact, abs=1e-12)
    bound = force_dual.refusal_bound(blocks, {"active": _equal_shares(beta=0.4, phi=0.02)})
    assert exact <= bound <= exact * (1.0 - 2e-3) < 0.0


def test_no_dual_point_ever_undercuts_the_solvers_optimum():
    """Weak duality, on random programs (random loads, a random distribution's data moved
    along Z, random candidate multipliers on random supports): every bound certified lies
    at or above Clarabel's largest smallest margin."""
    rng = np.random.default_rng(20261127)
    certified = 0
    for _ in range(40):
        T = float(rng.uniform(0.0, 9.0))
        _, _, blocks = _blocks(T)
        t_star, z_solver = _solver_optimum(blocks)
        corners = [i for i in range(4) if rng.uniform() < 0.8] or [0]
        kinds = [("ray", 3) if i in corners else None for i in range(4)] + [None]
        parts = [np.array([0.1, rng.uniform(0.05, 1.0), rng.uniform(-0.5, 0.5)])
                 if i in corners else np.zeros(0) for i in range(4)] + [np.zeros(0)]
        bound = force_dual.refusal_bound(blocks, {"active": (kinds, parts)})
        if bound is not None:
            certified += 1
            assert bound >= t_star - 1e-9
        # the solver's own multipliers, moved to a dual point, bound it tightly
        z = force_dual.dual_point(blocks, z_solver)
        tight = None if z is None else force_dual.dual_bound(blocks, z)
        assert tight is not None and abs(tight - t_star) <= 1e-7
    assert certified >= 10  # (the supports of all four corners: the equal shares)


def test_a_refusal_is_certified_only_below_the_level_asked():
    """max_margin_distribution's refusal (a finite ``below``): where Newton's method at the
    nearby active set fails (here: the warm start's distribution of another size), the
    dual point certifies t* < below when it is (T = 6: t* < 0 <= below + guard), and never
    when it is not (T = 4: t* > 0): then the program is solved (by the compiled cold start,
    certified: the solver is not needed), with the closed-form margin."""
    calls = []
    solver = force_distribution._clarabel

    def counted(*args):
        calls.append(1)
        return solver(*args)
    force_distribution._clarabel = counted
    try:
        for T, refused in ((6.0, True), (4.0, False)):
            lam0, Z, _ = _blocks(T)
            warm = {"active": _equal_shares(), "lam": np.zeros(3), "tau": 0.0}
            calls.clear()
            lam, margin = max_margin_distribution(np.full(4, MU), 3, [STICK] * 4, lam0, Z,
                                                  SCALE, below=-1e-9 * SCALE, warm=warm)
            if refused:
                assert not calls  # certified by the dual point alone
                assert margin < -1e-9 * SCALE
                np.testing.assert_array_equal(lam, lam0)  # lam0, with its own margin
            else:
                assert not calls  # (force_cold_start certified it)
                assert margin == pytest.approx(_largest(T), abs=1e-9)
    finally:
        force_distribution._clarabel = solver
