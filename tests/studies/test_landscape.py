"""Landscapes against single resolve_impact calls and the sliding kernel at sampled points."""

import numpy as np
import pytest

import convimpact as ci
from convimpact.studies.landscape import REGIMES, closed_form_landscape, law_landscape


def _rod(phi_deg, dq):
    phi = np.radians(phi_deg)
    M = np.diag([1.0, 1.0, 1.0 / 12.0])
    Jc = np.array([[0.0, 1.0, -0.5 * np.cos(phi)], [1.0, 0.0, 0.5 * np.sin(phi)]])
    return M, Jc, np.asarray(dq, float)


@pytest.mark.parametrize("phi, dq", [(30.0, [1.0, -1.0, 0.0]), (60.0, [-0.5, -2.0, 1.5]),
                                     (-45.0, [2.0, -0.5, -1.0]), (20.0, [0.0, -1.0, 0.0])])
def test_closed_form_landscape_matches_pointwise(phi, dq):
    M, Jc, dq = _rod(phi, dq)
    e = np.linspace(0, 1, 11)
    mu = np.linspace(-0.5, 2.0, 26)
    L = closed_form_landscape(M, Jc, dq, e, mu)
    v = Jc @ dq
    s = np.sign(v[1]) if v[1] != 0 else 1.0
    W = Jc @ np.linalg.inv(M) @ Jc.T
    for i, ei in enumerate(e):
        for j, mj in enumerate(mu):
            if mj >= 0:
                r = ci.resolve_impact(M, Jc, dq, e=ei, mu=mj, method="closed-form")
                assert REGIMES[L.regime[i, j]] == r.regime
                np.testing.assert_allclose([L.normal_impulse[i, j], L.tangential_impulse[i, j, 0]],
                                           r.impulse, rtol=1e-9, atol=1e-12)
                assert L.energy_loss[i, j] == pytest.approx(r.energy_loss, rel=1e-9, abs=1e-12)
                assert L.energy_gained[i, j] == r.diagnostics.energy_gained
                assert L.slip_reversal[i, j] == r.diagnostics.slip_reversal
                assert L.friction_pushes_slip[i, j] == r.diagnostics.friction_pushes_slip
            elif not L.stick_possible[i, j]:
                # negative mu: the friction impulse acts along the slip (the paper's convention);
                # with no slip, the slip sign is taken opposite to the sticking impulse
                if v[1] == 0:
                    s = -np.sign(np.linalg.solve(W, -np.array([(1 + ei) * v[0], 0.0]))[1])
                if L.jammed[i, j]:
                    with pytest.raises(ci.NonPositiveEffectiveMassError):
                        ci.sliding_impulse(W, v, ei, -mj, np.array([s]))
                    assert np.isnan(L.normal_impulse[i, j])
                else:
                    pi, _ = ci.sliding_impulse(W, v, ei, -mj, np.array([s]))
                    np.testing.assert_allclose(
                        [L.normal_impulse[i, j], L.tangential_impulse[i, j, 0]], pi, rtol=1e-9)
    # NaN only where jammed
    assert np.all(np.isfinite(L.energy_loss) | L.jammed)


def test_stick_region_matches_stiction_interval():
    M, Jc, dq = _rod(30.0, [0.3, -1.0, 0.5])
    e = np.linspace(0, 1, 201)
    for mu in (0.3, 0.8, 1.5):
        L = closed_form_landscape(M, Jc, dq, e, [mu])
        iv = ci.stiction_interval(M, Jc, dq, mu=mu, opposing=False)
        inside = (e >= iv.lower - 1e-12) & (e <= iv.upper + 1e-12) if not iv.empty else 0 * e
        np.testing.assert_array_equal(L.stick_possible[:, 0], inside.astype(bool))


def test_law_landscape_marks_failures_and_matches_pointwise():
    M, Jc, dq = _rod(60.0, [-0.5, -2.0, 1.5])
    e, mu = np.linspace(0, 1, 4), np.linspace(0, 1, 4)
    L = law_landscape(M, Jc, dq, e, mu, law="pereira-nikravesh", method="closed-form",
                      progress=False)
    C = closed_form_landscape(M, Jc, dq, e, mu)
    np.testing.assert_allclose(L.energy_loss, C.energy_loss, rtol=1e-9)
    np.testing.assert_array_equal(L.regime, C.regime)
    assert not L.failed.any()
    d = L.as_dict()
    assert d["counts"]["stick"] + d["counts"]["slide"] + d["counts"]["frictionless"] == 16


def test_landscape_rejects_spatial_and_bad_e():
    M = np.eye(3)
    with pytest.raises(ci.ShapeError):
        closed_form_landscape(M, np.eye(3), [0, 0, -1.0], [0.5], [0.1])
    with pytest.raises(ci.ParameterError):
        closed_form_landscape(*_rod(30.0, [1.0, -1.0, 0.0]), [1.5], [0.1])


@pytest.mark.parametrize("d", [2, 3])
@pytest.mark.parametrize("law", ci.LAWS)
def test_contact_landscape_batch_equals_the_per_point_kernel(law, d, monkeypatch):
    """contact_landscape solves a large grid with the compiled batch (forced here on a small
    one); the per-point kernel (the library's loop for small grids) gives the same impulses to
    1e-10, regimes and failures."""
    from convimpact.impact.problem.build import build_problem
    from convimpact.studies import landscape
    from convimpact.studies.landscape import _loop_grid, contact_landscape

    monkeypatch.setattr(landscape, "BATCH_MIN_POINTS", 0)

    rng = np.random.default_rng(300 + d)
    for _ in range(3):
        A = rng.normal(size=(4, 4))
        M = A @ A.T + 0.5 * np.eye(4)
        Jc = rng.normal(size=(d, 4))
        dq = rng.normal(size=4)
        if Jc[0] @ dq > 0:
            Jc[0] *= -1.0
        e, mu = np.linspace(0, 1, 6), np.linspace(0, 1.5, 7)
        L = contact_landscape(M, Jc, dq, e, mu, law=law, progress=False)
        W, v = build_problem(M, Jc, dq, 0.0, 0.0).contact_block(0)
        pi, regime, jam, failed = _loop_grid(W, v, e, mu, law, False)
        shape = (e.size, mu.size)
        np.testing.assert_array_equal(L.failed, failed.reshape(shape))
        np.testing.assert_array_equal(L.jammed, jam.reshape(shape))
        np.testing.assert_array_equal(L.regime, regime.reshape(shape))
        ok = ~L.failed
        got = np.concatenate([L.normal_impulse[..., None], L.tangential_impulse], axis=-1)
        scale = np.max(np.abs(pi[ok.ravel()]))
        np.testing.assert_allclose(got[ok], pi.reshape(shape + (d,))[ok], rtol=0,
                                   atol=1e-10 * scale)


@pytest.mark.parametrize("d", [2, 3])
def test_stronge_landscape_against_resolve_impact(d):
    """law 'stronge' (not in the batch: the per-point loop) against resolve_impact at every
    point: impulse, energy loss, flags; and it never gains energy."""
    from convimpact.studies.landscape import contact_landscape

    rng = np.random.default_rng(410 + d)
    A = rng.normal(size=(3, 3))
    M = A @ A.T + 0.5 * np.eye(3)
    Jc = rng.normal(size=(d, 3))
    dq = rng.normal(size=3)
    if Jc[0] @ dq > 0:
        Jc[0] *= -1.0
    e, mu = np.linspace(0, 1, 4), np.linspace(0, 1.2, 4)
    L = contact_landscape(M, Jc, dq, e, mu, law="stronge", progress=False)
    assert not L.energy_gained.any()
    for i, ei in enumerate(e):
        for j, mj in enumerate(mu):
            try:
                r = ci.resolve_impact(M, Jc, dq, e=ei, mu=mj, law="stronge")
            except ci.ConvImpactError:
                assert L.failed[i, j]
                continue
            assert REGIMES[L.regime[i, j]] == r.regime
            np.testing.assert_allclose(
                [L.normal_impulse[i, j], *L.tangential_impulse[i, j]], r.impulse, rtol=1e-12,
                atol=1e-14)
            assert L.energy_loss[i, j] == pytest.approx(r.energy_loss, rel=1e-9, abs=1e-12)
            assert L.slip_reversal[i, j] == r.diagnostics.slip_reversal
