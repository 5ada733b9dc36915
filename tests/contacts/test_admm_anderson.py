"""The Anderson-accelerated sparse ADMM (convimpact.contacts.admm_anderson): Coulomb's law
solved on a small brick wall from zero, with W's own factorization and through ``W = G G^T``,
its iterates in the friction cones, its extrapolations taken, and its reported residual the
one recomputed here.

Oracles, none of them the code under test: Coulomb's natural-map residual and the projection
onto the friction cone written in this folder (``cone_checks``).
"""

import numpy as np
import pytest

from convimpact.contacts import admm
from convimpact.contacts.admm_anderson import AndersonAdmmRun

from .cone_checks import best_coulomb_residual



@pytest.mark.parametrize("with_g", [True, False])
def test_accelerated_run_solves_coulombs_law(brick_wall_44, with_g):
    W, b, mu, d, G = brick_wall_44
    n = mu.shape[0]
    factor = type("F", (), {"G": G})() if with_g else None
    run = admm.coulomb_admm(W, b, mu, np.zeros((n, d)), True, factor=factor,
                            relax=admm.RELAX, anderson=True)
    assert isinstance(run, AndersonAdmmRun)
    # every iterate given lies in the cones (the extrapolations do not leave)
    best = best_coulomb_residual(run, W, b, mu, in_cones=True)
    assert best <= 1e-8
    assert run.info[4] > 0  # extrapolations were kept


def test_rejecting_every_extrapolation_is_the_plain_run(brick_wall_44):
    # a safeguard of zero keeps no extrapolation: each time the run goes back to the plain
    # iterate it extrapolated from (ten iterations spent on the rejected one), so its iterates
    # are the plain ADMM's, taken here from the plain run, each given once or twice in order
    W, b, mu, d, _ = brick_wall_44
    n = mu.shape[0]
    plain = admm.coulomb_admm(W, b, mu, np.zeros((n, d)), True, relax=admm.RELAX)
    run = AndersonAdmmRun(W, b, mu, np.zeros((n, d)), None, L=plain.L, rho=plain.rho,
                          eta=plain.eta, relax=plain.relax, balance=plain.balance,
                          step=plain.step, safeguard=0.0)
    p = next(plain)
    repeats = 0
    for _ in range(40):
        a = next(run)
        scale = max(1.0, np.abs(a).max())
        if np.abs(a - p).max() > 1e-12 * scale:
            p = next(plain)
            assert np.abs(a - p).max() <= 1e-12 * scale
        else:
            repeats += 1
    assert repeats > 1  # (the first iterate's own match counted once)
    assert run.info[4] == 0 and run.info[5] > 0
