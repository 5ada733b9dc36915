"""Law ``stronge`` on Moreau–Jean's steps without an impact, island by island without
resolve_impact (:mod:`convimpact.simulation.moreau_stronge`).

Second method: the same runs with that path switched off (every island through
``resolve_impact``, as before it existed); closed forms: a box sliding on four corners
decelerates at mu g and stops after v0^2 / (2 mu g); the complete orthogonal decomposition
of :mod:`convimpact.impact.conic.polish_cod` against numpy's SVD.
"""

from __future__ import annotations

import numpy as np
import pytest

from convimpact.bench.moreau_scenes import GRAVITY, HALF, MU, box_row
from convimpact.compiled import plain
from convimpact.impact.conic.polish_cod import cod_min_norm_solve, cod_null_space
from convimpact.impact.laws import stronge_contacts
from convimpact.model import Joint, ModelBuilder
from convimpact.simulation import moreau_stronge
from convimpact.simulation.moreau import simulate_moreau

H = 2e-3


def _run(mech, q, v, span, direct: bool, monkeypatch, **kw):
    """simulate_moreau with law stronge, with or without the direct path (the law's memory
    of compressions emptied first, so that both runs start alike)."""
    stronge_contacts._WARM.clear()
    with monkeypatch.context() as m:
        if not direct:
            m.setattr(moreau_stronge.StrongeIslands, "applies",
                      classmethod(lambda cls, *a: None))
        return simulate_moreau(mech, (0.0, span), (q, v), h=H, law="stronge", **kw)


def _same(a, b):
    for name in ("theta", "dtheta"):
        x, y = np.asarray(getattr(a, name)), np.asarray(getattr(b, name))
        assert x.shape == y.shape
        scale = max(float(np.max(np.abs(y))), 1.0)
        assert np.max(np.abs(x - y)) <= 1e-12 * scale, name


@pytest.mark.parametrize("sliding", [True, False])
def test_boxes_as_through_resolve_impact(sliding, monkeypatch):
    mech, q, v = box_row(2, sliding)
    span = 30 * H
    fast = _run(mech, q, v, span, True, monkeypatch)
    full = _run(mech, q, v, span, False, monkeypatch)
    _same(fast, full)
    # the direct path answered every island after the first step (no memory before it)
    assert fast.contact_solver["certified"] == 2 * (30 - 1)
    assert full.contact_solver["certified"] == 0


def test_box_slides_to_the_closed_form_stop(monkeypatch):
    mech, q, v = box_row(1, True)
    v0 = 1.0
    v[0] = v0
    res = _run(mech, q, v, 0.5, True, monkeypatch)
    t, th, dth = np.asarray(res.t), np.asarray(res.theta), np.asarray(res.dtheta)
    # Coulomb on four corners: v = v0 - mu g t until it stops, then rest
    moving = t < v0 / (MU * GRAVITY) - H
    assert np.max(np.abs(dth[moving, 0] - (v0 - MU * GRAVITY * t[moving]))) <= 1e-12
    assert np.max(np.abs(dth[-1])) <= 1e-12
    assert abs(th[-1, 0] - v0 ** 2 / (2 * MU * GRAVITY)) <= 0.5 * v0 * H
    assert np.max(np.abs(th[:, 2] - HALF[2])) <= 1e-12
    assert np.max(np.abs(dth[:, 1:])) <= 1e-12
    # most steps took the direct path; the first and the stop went through resolve_impact
    assert res.contact_solver["certified"] >= 240


def _box_and_ball():
    """A box on four corners sliding next to a ball (one contact) dropped onto the floor
    with restitution: islands of one contact and impact steps go through resolve_impact."""
    a, b, c = HALF
    inertia = np.diag([(b * b + c * c) / 3, (a * a + c * c) / 3, (a * a + b * b) / 3])
    builder = ModelBuilder(planar=False, gravity=(0.0, 0.0, -GRAVITY))
    builder.add_body("box", "ground", Joint.free(), 1.0, (0.0, 0.0, 0.0), inertia,
                     joint_name="box_float")
    for j, (sx, sy) in enumerate(((-1, -1), (1, -1), (1, 1), (-1, 1))):
        builder.add_contact(f"corner{j}", body="box", point=(sx * a, sy * b, -c),
                            normal=(0.0, 0.0, 1.0), e=0.0, mu=MU)
    builder.add_body("ball", "ground", Joint.free(), 0.5, (0.0, 0.0, 0.0),
                     0.002 * np.eye(3), joint_name="ball_float")
    builder.add_contact("ball_bottom", body="ball", point=(0.0, 0.0, -0.05),
                        normal=(0.0, 0.0, 1.0), e=0.5, mu=MU)
    mech = builder.build().mechanism()
    q = np.zeros(12)
    v = np.zeros(12)
    q[2] = c
    q[6], q[8] = 2.0, 0.06
    v[0] = 1.0
    v[6] = 0.3
    return mech, q, v


def test_islands_left_to_resolve_impact_and_impacts(monkeypatch):
    mech, q, v = _box_and_ball()
    span = 60 * H
    fast = _run(mech, q, v, span, True, monkeypatch)
    full = _run(mech, q, v, span, False, monkeypatch)
    _same(fast, full)
    assert len(fast.impacts) == len(full.impacts) >= 1
    for x, y in zip(fast.impacts, full.impacts):
        assert x.time == y.time and x.contacts == y.contacts
    assert fast.contact_solver["certified"] > 0


def test_other_methods_and_options_keep_their_path(monkeypatch):
    mech, q, v = box_row(1, True)
    # a single-contact method on several contacts still refuses, as resolve_impact does
    with pytest.raises(Exception) as fast_error:
        _run(mech, q, v, 4 * H, True, monkeypatch, method="fast")
    with pytest.raises(Exception) as full_error:
        _run(mech, q, v, 4 * H, False, monkeypatch, method="fast")
    assert type(fast_error.value) is type(full_error.value)
    # an option the conic path does not know is reported as before
    with pytest.raises(Exception) as fast_error:
        _run(mech, q, v, 4 * H, True, monkeypatch, impact_options={"no_such_option": 1})
    with pytest.raises(Exception) as full_error:
        _run(mech, q, v, 4 * H, False, monkeypatch, impact_options={"no_such_option": 1})
    assert type(fast_error.value) is type(full_error.value)
    assert str(fast_error.value).splitlines()[0] == str(full_error.value).splitlines()[0]


def _rank_deficient(rng, m, n, r):
    return rng.standard_normal((m, r)) @ rng.standard_normal((r, n))


@pytest.mark.parametrize("shape", [(12, 12, 6), (12, 12, 12), (9, 12, 5), (12, 8, 3)])
def test_cod_against_the_svd(shape):
    rng = np.random.default_rng(7)
    m, n, r = shape
    A = _rank_deficient(rng, m, n, r)
    y = rng.standard_normal(m)
    x = plain(cod_min_norm_solve)(A, y, 1e-13)
    assert np.allclose(x, np.linalg.lstsq(A, y, rcond=1e-13)[0], rtol=0, atol=1e-10)
    N = plain(cod_null_space)(A, 1e-9)
    assert N.shape == (n, n - r)
    # orthonormal, and the same space as the SVD's right singular vectors beyond the rank
    assert np.allclose(N.T @ N, np.eye(n - r), atol=1e-12)
    V = np.linalg.svd(A)[2][r:].T
    assert np.allclose(N @ N.T, V @ V.T, atol=1e-10)


@pytest.mark.parametrize("spin", [0.0, 2.0])
def test_fast_warm_start_decides_as_the_svd(spin, monkeypatch):
    """warm_compression's fast mode (COD, kappa eliminated, the family test skipped without
    a boundary contact) against its SVD mode on the law's own problems and starts along a
    run (a box sliding, and sliding while it spins: a family of motions)."""
    from convimpact.impact.laws.stronge_contacts_warm import (MOVING, REDUNDANT, STILL,
                                                              UNIQUE, warm_compression)

    seen = []
    law_warm = stronge_contacts._warm_plastic

    def spy(P, opts):
        starts = [s.copy() for s in stronge_contacts._WARM.get(stronge_contacts._warm_key(P), [])]
        seen.append((P, starts))
        return law_warm(P, opts)

    monkeypatch.setattr(stronge_contacts, "_warm_plastic", spy)
    mech, q, v = box_row(1, True)
    v[5] = spin
    _run(mech, q, v, 0.1, False, monkeypatch)
    kinds = set()
    for P, starts in seen:
        W = np.ascontiguousarray(P.delassus)
        b = np.ascontiguousarray(P.v_minus).ravel()
        mu = np.ascontiguousarray(P.friction, dtype=float)
        for start in starts:
            fast, svd = (warm_compression(W, b, mu, 3, start, flag) for flag in (True, False))
            kinds.add(int(svd[0]))
            # STILL (no boundary contact: not told apart) stands for UNIQUE or REDUNDANT
            assert fast[0] == svd[0] or (fast[0] == STILL and svd[0] in (UNIQUE, REDUNDANT))
            if svd[0] in (UNIQUE, REDUNDANT):
                assert np.max(np.abs(W @ (fast[1] - svd[1]))) <= 1e-12 * np.max(np.abs(b))
    assert (MOVING in kinds) == (spin != 0.0)
