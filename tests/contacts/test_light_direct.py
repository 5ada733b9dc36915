"""The engine's light Newton try from the CCP's answer (:mod:`convimpact.contacts.light_direct`)
and the ADMM-first try's rules (light Newton, crawl).

Oracles, none of them the code under test: Coulomb's natural-map residual recomputed here with
this folder's own projection onto the friction cone (``test_contact_admm.coulomb_residual``),
the CCP's likewise (``test_admm_restart.ccp_residual``), and the cone membership checked with
that projection.
"""

import numpy as np
import pytest

from convimpact.bench.contact_corpus import corpus
from convimpact.contacts import engine, first_tries, light_direct

from .cone_checks import project_cone
from .test_admm_restart import ccp_residual
from .cone_checks import coulomb_residual


@pytest.fixture(scope="module")
def cases():
    return {c.name: c for c in corpus(names=["planar-stack-200", "sphere-pile-hex-126",
                                             "robot-feet-2talos-2solo-24", "planar-stack-40",
                                             "box-stack-100"])}


def _data(case):
    n, d = case.n_contacts, case.dim
    return case.W, np.asarray(case.b, float).reshape(n, d), np.asarray(case.mu, float), d


def test_the_light_try_certifies_a_planar_stack_on_the_cones(cases):
    case = cases["planar-stack-200"]
    W, b, mu, d = _data(case)
    with np.errstate(divide="ignore", invalid="ignore"):
        R, ccp = light_direct.light_direct(W, b, mu, d, tol=1e-8, max_iter=100)
    assert R.converged
    assert coulomb_residual(W.toarray(), b, mu, R.impulse) <= 1e-8
    assert project_cone(R.impulse, mu) == pytest.approx(R.impulse, abs=1e-12)
    # the CCP answer it started from is the CCP's (its own natural map, computed here)
    assert ccp_residual(W.toarray(), b, mu, ccp.impulse) <= 1e-8
    E = engine.solve(W, b, mu, d, coulomb=True)
    assert E.converged and coulomb_residual(W.toarray(), b, mu, E.impulse) <= 1e-8


def test_the_light_try_gives_way_on_a_pile_after_one_step(cases):
    """A sphere pile: the try stops after its first step (FIRST) and is not certified; the
    engine certifies it on its other ways from the same CCP answer."""
    case = cases["sphere-pile-hex-126"]
    W, b, mu, d = _data(case)
    with np.errstate(divide="ignore", invalid="ignore"):
        R, ccp = light_direct.light_direct(W, b, mu, d, tol=1e-8, max_iter=100)
    assert not R.converged
    assert coulomb_residual(W.toarray(), b, mu, R.impulse) > 1e-8
    assert R.iterations - ccp.iterations <= light_direct.FIRST[0]
    E = engine.solve(W, b, mu, d, coulomb=True)
    assert E.converged and coulomb_residual(W.toarray(), b, mu, E.impulse) <= 1e-8


@pytest.mark.parametrize("name", ["robot-feet-2talos-2solo-24", "planar-stack-40"])
def test_the_admm_first_try_gives_way_where_it_crawls(cases, name):
    """Below COMPILED_MAX_ROWS the ADMM-first try ends after its second batch of 200 where it
    crawls (these two: 2-5x a batch); the compiled kernels certify them after it."""
    if name not in cases:  # the corpus leaves the robots out without their models
        pytest.skip("the robot models need example-robot-data (pip install -e \".[test-full]\")")
    W, b, mu, d = _data(cases[name])
    R = first_tries.admm_first(W, b, mu, d, True, 1e-8, 30, True)
    assert not R.converged and R.iterations <= 400 + first_tries.ADMM_FIRST_POLISH_STEPS
    E = engine.solve(W, b, mu, d, coulomb=True)
    assert E.converged and coulomb_residual(W.toarray(), b, mu, E.impulse) <= 1e-8
    # the engine's count holds the failed try's iterations (the same deterministic run)
    # and the kernels' after it
    assert E.iterations > R.iterations


def test_the_admm_first_light_newton_certifies_a_box_stack_on_the_cones(cases):
    W, b, mu, d = _data(cases["box-stack-100"])
    R = first_tries.admm_first(W, b, mu, d, True, 1e-8, 30, True)
    assert R.converged
    assert coulomb_residual(W.toarray(), b, mu, R.impulse) <= 1e-8
    assert project_cone(R.impulse, mu) == pytest.approx(R.impulse, abs=1e-9)
