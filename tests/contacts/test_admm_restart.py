"""The engine's ADMM on large sparse problems is joined by a second run from zero, once, where
it crawls near a solution (admm.AdmmRace, admm.CRAWL_DROP).

The path is forced on a small brick wall of the corpus (the sizes that choose it and the
window of the rule made small, Newton's tries switched off), and the starts the engine
gives the ADMM are recorded. Oracles, none of them the code under test: the natural-map
residual recomputed here with this folder's own projection onto the friction cone
(``test_contact_admm.coulomb_residual``), and the CCP answer the ADMM must start from first,
checked here against the CCP's own natural map (within 1e-6: the interior point's iterate,
its Newton finish being off).
"""

import itertools

import numpy as np
import pytest
import scipy.sparse as sp

from convimpact.bench.contact_corpus import corpus
from convimpact.contacts import admm, engine

from .cone_checks import project_cone
from .cone_checks import coulomb_residual


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
    real = admm.coulomb_admm

    def recording(W_, b_, mu_, r0, sparse, **kw):
        starts.append(np.array(r0, dtype=float))
        return real(W_, b_, mu_, r0, sparse, **kw)

    monkeypatch.setattr(admm, "coulomb_admm", recording)
    # the sparse ADMM's branch on 48 rows, the interior point on the law and Newton's tries
    # off (newton_iter 0), the rule's window 50 iterations
    monkeypatch.setattr(engine, "DENSE_ADMM_MAX_ROWS", 0)
    monkeypatch.setattr(engine, "SPARING_NEWTON_MAX_ROWS", 0)
    monkeypatch.setattr(engine, "COULOMB_IP_ITER", 0)
    monkeypatch.setattr(engine, "LONG_NEWTON_FROM", 0.0)
    monkeypatch.setattr(engine, "ADMM_STALL_ITER", 50)
    monkeypatch.setattr(admm, "CRAWL_ITER", 50)
    monkeypatch.setattr(admm, "CRAWL_WINDOW", 1)
    monkeypatch.setattr(engine, "ADMM_STALL_ABOVE", 10.0)
    monkeypatch.setattr(admm, "CRAWL_DROP", crawl_drop)
    n = mu.shape[0]
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        R = engine._solve(W, b.reshape(n, d), mu, d, True, 1e-8, 100, 0, 20000, True)
    return R, starts


def test_crawling_admm_restarts_from_zero_once(monkeypatch, wall):
    # a required drop to 0: every window is a crawl, so the run from zero joins at the
    # second mark (100 iterations), and only once
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


def test_newton_stall_window_stops_where_the_best_residual_has_not_halved(wall):
    """newton_finish(stall_steps=k) stops at the first step s >= k where the best residual is
    above half of what it was k steps earlier; the residuals of every step are recomputed
    here (runs of 1, 2, ... steps without the window give the same iterates: Newton is
    deterministic); tol 0 is never met, and from zero Newton crawls here (30 steps without
    the window end at 1.3e-2), so the window stops it early."""
    from convimpact.contacts.finish import newton_finish

    W, b, mu, d = wall
    n = mu.shape[0]
    Wd = W.toarray()
    r0 = np.zeros((n, d))
    k = 3
    history = [coulomb_residual(Wd, b, mu, r0)]
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        for m in range(1, 31):
            r, _, steps = newton_finish(W, b.reshape(n, d), mu, r0, coulomb=True, tol=0.0,
                                        max_iter=m, sparse=True)
            if steps < m:  # the line search stopped it: no further step exists
                break
            history.append(min(history[-1], coulomb_residual(Wd, b, mu, r)))
        expected = next((s for s in range(k, len(history))
                         if history[s] > 0.5 * history[s - k]), None)
        assert expected is not None  # a crawl within the runs above
        _, res, steps = newton_finish(W, b.reshape(n, d), mu, r0, coulomb=True, tol=0.0,
                                      max_iter=30, sparse=True, stall_steps=k)
    assert steps == expected
    assert res == pytest.approx(history[expected], rel=1e-6, abs=1e-15)


def _stand_in_runs(monkeypatch) -> list:
    """admm.coulomb_admm replaced by runs that yield their start's label (0, 1, ...) as a
    (1, 3) array, a crawl judged every 30 iterations over a window of one mark; returns the
    list the runs' starts are appended to."""
    starts = []

    def fake(W, b, mu, r0, sparse, **kw):
        label = float(len(starts))
        starts.append(np.array(r0, dtype=float))
        return itertools.repeat(np.full((1, 3), label))

    monkeypatch.setattr(admm, "coulomb_admm", fake)
    monkeypatch.setattr(admm, "CRAWL_ITER", 30)
    monkeypatch.setattr(admm, "CRAWL_WINDOW", 1)
    monkeypatch.setattr(admm, "CRAWL_DROP", 0.1)
    return starts


def test_race_alternates_then_drops_the_run_that_is_passed(monkeypatch):
    """admm.AdmmRace with stand-in runs (each yields its start's label, as an array): a first
    run whose residual stays at 1e-6 is a crawl at the second mark (window 1, 30 iterations
    apart), the run from zero joins and the two alternate ten iterations each; once a
    residual of the second is below the first's best, only the second runs."""
    starts = _stand_in_runs(monkeypatch)
    race = admm.AdmmRace(None, None, None, np.ones((1, 3)), True, below=1e-4, tol=1e-8)
    seen = []
    # 60 iterations of the first run, its residual halved from the first mark (30) to the
    # second (60): a crawl (above CRAWL_DROP), with ln(1e-6 / 1e-8) / ln 2 * 30 = 199
    # iterations to tol at that rate, below REPLACE_BEYOND: the two runs then alternate
    for k in range(6):
        seen.append(race.next()[0, 0])
        race.judge(2e-6 if k < 3 else 1e-6)
    assert seen == [0.0] * 6 and len(starts) == 2 and np.all(starts[1] == 0.0)
    residual = {0.0: 1e-6, 1.0: 1e-5}
    seen = []
    for _ in range(6):  # both, in turns: the second's residual above the first's best
        label = race.next()[0, 0]
        seen.append(label)
        race.judge(residual[label])
    assert seen == [0.0, 1.0] * 3
    label = race.next()[0, 0]  # the first's turn
    race.judge(1e-6)
    label = race.next()[0, 0]
    assert label == 1.0
    race.judge(5e-7)  # the second passes the first: only it runs from here
    assert [race.next()[0, 0] for _ in range(5)] == [1.0] * 5
    assert len(starts) == 2  # and no third run joins


def test_newton_first_steps_rule_stops_a_try_that_has_not_contracted(wall):
    """newton_finish(first=(2, drop)) stops after two steps exactly where the best residual is
    then above drop times the start's; the residuals are recomputed here from runs of one and
    two steps (Newton is deterministic), and drop is set on either side of the ratio found."""
    from convimpact.contacts.finish import newton_finish

    W, b, mu, d = wall
    n = mu.shape[0]
    Wd = W.toarray()
    r0 = np.zeros((n, d))
    history = [coulomb_residual(Wd, b, mu, r0)]
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        for m in (1, 2):
            r, _, steps = newton_finish(W, b.reshape(n, d), mu, r0, coulomb=True, tol=0.0,
                                        max_iter=m, sparse=True)
            assert steps == m
            history.append(min(history[-1], coulomb_residual(Wd, b, mu, r)))
        ratio = history[2] / history[0]
        assert 0.0 < ratio < 1.0
        _, res, steps = newton_finish(W, b.reshape(n, d), mu, r0, coulomb=True, tol=0.0,
                                      max_iter=10, sparse=True, first=(2, 0.5 * ratio))
        assert steps == 2
        assert res == pytest.approx(history[2], rel=1e-6, abs=1e-15)
        _, _, steps = newton_finish(W, b.reshape(n, d), mu, r0, coulomb=True, tol=0.0,
                                    max_iter=10, sparse=True, first=(2, 2.0 * ratio))
    assert steps > 2


@pytest.mark.parametrize("later, beyond, replaced", [(1e-6, 4000, True),     # flat: never
                                                     (1e-6 / 2, 4000, False),  # 199 left
                                                     (1e-6 / 2, 150, True)])
def test_race_drops_a_first_run_too_slow_for_tol(monkeypatch, later, beyond, replaced):
    """admm.AdmmRace with stand-in runs: at the join, the first run is dropped at once where
    its rate over the window (later / 1e-6 per 30 iterations) would take more than
    REPLACE_BEYOND iterations to reach tol (1e-8): ln(later / tol) / ln(1e-6 / later) * 30,
    infinite for a flat run, 199 for a halving one."""
    starts = _stand_in_runs(monkeypatch)
    monkeypatch.setattr(admm, "REPLACE_BEYOND", beyond)
    race = admm.AdmmRace(None, None, None, np.ones((1, 3)), True, below=1e-4, tol=1e-8)
    for k in range(6):
        assert race.next()[0, 0] == 0.0
        race.judge(1e-6 if k < 3 else later)
    assert len(starts) == 2 and np.all(starts[1] == 0.0)
    labels = []
    for _ in range(4):
        labels.append(race.next()[0, 0])
        race.judge(1e-3)  # the second run far behind: only a drop at the join removes the first
    assert labels == ([1.0] * 4 if replaced else [0.0, 1.0] * 2)
