"""The engine's ADMM on large sparse problems starts again from zero, once, where it crawls
near a solution (engine.ADMM_CRAWL_DROP).

The path is forced on a small brick wall of the corpus (the sizes that choose it and the
window of the rule made small, Newton's tries switched off), and the starts the engine
gives the ADMM are recorded. Oracles, none of them the code under test: the natural-map
residual recomputed here with this folder's own projection onto the friction cone
(``test_contact_admm.coulomb_residual``), and the CCP answer the ADMM must start from first,
checked here against the CCP's own natural map (within 1e-6: the interior point's iterate,
its Newton finish being off).
"""

import numpy as np
import pytest
import scipy.sparse as sp

from convimpact.bench.contact_corpus import corpus
from convimpact.contacts import engine

from .cone_checks import project_cone
from .test_contact_admm import coulomb_residual


def ccp_residual(W, b, mu, r):
    """The CCP's natural-map residual (y = u), computed here."""
    n, d = r.shape
    u = (W @ r.ravel() + np.ravel(b)).reshape(n, d)
    err = np.linalg.norm(r - project_cone(r - u, mu))
    return err / max(np.linalg.norm(b), np.linalg.norm(r), np.linalg.norm(u))


@pytest.fixture(scope="module")
def wall():
    (case,) = corpus(names=["box-wall-2x2-16"])
    return sp.csr_matrix(case.W), np.asarray(case.b, float), np.asarray(case.mu, float), case.dim


def _run(monkeypatch, wall, crawl_drop):
    W, b, mu, d = wall
    starts = []
    real = engine.coulomb_admm

    def recording(W_, b_, mu_, r0, sparse, **kw):
        starts.append(np.array(r0, dtype=float))
        return real(W_, b_, mu_, r0, sparse, **kw)

    monkeypatch.setattr(engine, "coulomb_admm", recording)
    # the sparse ADMM's branch on 48 rows, the interior point on the law and Newton's tries
    # off (newton_iter 0), the rule's window 50 iterations
    monkeypatch.setattr(engine, "DENSE_ADMM_MAX_ROWS", 0)
    monkeypatch.setattr(engine, "SPARING_NEWTON_MAX_ROWS", 0)
    monkeypatch.setattr(engine, "COULOMB_IP_ITER", 0)
    monkeypatch.setattr(engine, "LONG_NEWTON_FROM", 0.0)
    monkeypatch.setattr(engine, "ADMM_STALL_ITER", 50)
    monkeypatch.setattr(engine, "ADMM_STALL_ABOVE", 10.0)
    monkeypatch.setattr(engine, "ADMM_CRAWL_DROP", crawl_drop)
    n = mu.shape[0]
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        R = engine._solve(W, b.reshape(n, d), mu, d, True, 1e-8, 100, 0, 20000, True)
    return R, starts


def test_crawling_admm_restarts_from_zero_once(monkeypatch, wall):
    # a required drop to 0: every window is a crawl, so the restart comes at the second
    # mark (100 iterations), and only once
    W, b, mu, d = wall
    R, starts = _run(monkeypatch, wall, 0.0)
    assert len(starts) == 2
    # the CCP answer first (the interior point's, its Newton finish off here)...
    assert np.abs(starts[0]).max() > 0.0
    assert ccp_residual(W, b, mu, starts[0]) <= 1e-6
    assert np.all(starts[1] == 0.0)               # ...then zero
    assert R.converged
    assert coulomb_residual(W.toarray(), b, mu, R.impulse) <= 1e-8


def test_no_restart_without_a_crawl(monkeypatch, wall):
    # a required drop of 1 (none: the ADMM's best never rises): no window is a crawl, the
    # ADMM runs from the CCP answer alone
    W, b, mu, d = wall
    R, starts = _run(monkeypatch, wall, 1.0)
    assert len(starts) == 1
    assert R.converged
    assert coulomb_residual(W.toarray(), b, mu, R.impulse) <= 1e-8
