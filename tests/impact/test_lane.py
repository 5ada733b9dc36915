"""resolve_impact's compiled lane (one open-loop contact): the invariants of every answer, the
hand-over of every non-plain case to the full path, and the private copies behind the
diagnostics."""

import numpy as np
import pytest

import convimpact as ci
from convimpact.impact.exact import lane
from convimpact.impact.problem.build import build_problem
from convimpact.impact.resolve import solve_problem

LAWS = ("pereira-nikravesh", "coulomb", "ccp", "dissipative")


def random_impact(rng, d, k):
    A = rng.normal(size=(k, k))
    M = A @ A.T + 0.5 * np.eye(k)
    J = rng.normal(size=(d, k))
    dq = rng.normal(size=k)
    if J[0] @ dq > 0:
        dq = -dq
    return M, J, dq


@pytest.mark.parametrize("law", LAWS)
@pytest.mark.parametrize("d", [2, 3])
def test_lane_answers_keep_momentum_energy_and_the_full_path(law, d):
    """Over random systems: M (dq+ - dq-) = Jc^T pi (eq. 29), v+- = Jc dq+-, and the energy
    loss equals T(dq-) - T(dq+) computed from M by hand; the full path (LAPACK reduction,
    solve_problem) gives the same impulse to round-off."""
    rng = np.random.default_rng(7 + d)
    for _ in range(60):
        M, J, dq = random_impact(rng, d, int(rng.integers(d, 7)))
        e, mu = float(rng.uniform()), float(rng.uniform(0, 1.5))
        try:
            r = ci.resolve_impact(M, J, dq, e=e, mu=mu, law=law)
        except ci.ConvImpactError as exc:
            with pytest.raises(type(exc)):
                solve_problem(build_problem(M, J, dq, e, mu), law, "auto")
            continue
        scale = np.abs(J.T @ r.impulse).max()
        assert np.abs(M @ (r.dq_plus - dq) - J.T @ r.impulse).max() <= 1e-11 * scale
        np.testing.assert_allclose(r.v_minus, J @ dq, rtol=1e-13, atol=1e-13)
        vs = max(np.abs(r.v_minus).max(), np.abs(r.v_plus).max())
        assert np.abs(r.v_plus - J @ r.dq_plus).max() <= 1e-10 * vs
        T0, T1 = 0.5 * dq @ M @ dq, 0.5 * r.dq_plus @ M @ r.dq_plus
        assert r.energy_loss == pytest.approx(T0 - T1, rel=1e-9, abs=1e-12 * T0)
        full = solve_problem(build_problem(M, J, dq, e, mu), law, "fast")
        tol = 1e-9 * max(1.0, r.diagnostics.delassus_condition * 1e-4)
        assert np.abs(r.impulse - full.impulse).max() <= tol * np.abs(full.impulse).max()
        assert r.regime == full.regime or r.diagnostics.delassus_condition > 1e6
        assert r.method == "fast" and r.law == law


def test_the_diagnostics_measure_private_copies():
    """The caller may overwrite M, Jc and dq before reading the diagnostics."""
    M, J, dq = 2.0 * np.eye(2), np.array([[0.0, 1.0], [1.0, 0.0]]), np.array([1.0, -1.0])
    r = ci.resolve_impact(M, J, dq, e=0.5, mu=0.3)
    M[:] = 7.0
    J[:] = 0.0
    dq[:] = 3.0
    assert r.diagnostics.energy_before == pytest.approx(2.0)  # 1/2 * 2 * (1 + 1)
    assert r.diagnostics.momentum_residual < 1e-14
    assert r.diagnostics.mass_condition == pytest.approx(1.0)
    assert r.diagnostics.restitution_residual < 1e-14


def test_every_non_plain_case_goes_to_the_full_path():
    J = np.array([[0.0, 1.0], [1.0, 0.0]])
    # separating: the full path's result and note
    r = ci.resolve_impact(np.eye(2), J, [1.0, 1.0])
    assert r.regime == "separating" and r.diagnostics.warnings
    # M symmetric only to round-off: symmetrized by the full path, same answer as exact
    Ms = np.array([[2.0, 1e-17], [0.0, 2.0]])
    a = ci.resolve_impact(Ms, J, [1.0, -1.0], e=0.5, mu=0.3)
    b = ci.resolve_impact(2.0 * np.eye(2), J, [1.0, -1.0], e=0.5, mu=0.3)
    np.testing.assert_allclose(a.impulse, b.impulse, rtol=1e-15)
    # far from unit scale: rescaled by the full path, impulse exactly scaled
    big = ci.resolve_impact(2e60 * np.eye(2), J, [1.0, -1.0], e=0.5, mu=0.3)
    np.testing.assert_allclose(big.impulse, 1e60 * b.impulse, rtol=1e-14)
    # tangents that move no mass: frictionless (build_problem's rule)
    Jn = np.array([[1.0, 0.0], [0.0, 0.0]])
    r = ci.resolve_impact(np.eye(2), Jn, [-1.0, 0.0], e=0.5, mu=0.8, law="coulomb")
    assert r.impulse[0] == pytest.approx(1.5) and r.impulse[1] == 0.0
    # bad input: the full path's typed errors
    with pytest.raises(ci.MassMatrixError):
        ci.resolve_impact(-np.eye(2), J, [1.0, -1.0])
    with pytest.raises(ci.ParameterError):
        ci.resolve_impact(np.eye(2), J, [1.0, -1.0], e=True)
    with pytest.raises(ci.NonFiniteError):
        ci.resolve_impact(np.eye(2), J, [np.nan, -1.0])


def test_a_kernel_refusal_under_auto_falls_back_to_the_conic_path():
    """A singular W (a central impact with friction) is refused by the fast kernel of the
    paper's law; method="auto" hands it to the conic paths, as the full path always did."""
    M = np.eye(1)
    J = np.array([[1.0], [1.0]])  # n and t rows identical: W singular
    with pytest.raises(ci.SingularSystemError):
        ci.resolve_impact(M, J, [-1.0], e=0.5, mu=0.3, method="fast")
    r = ci.resolve_impact(M, J, [-1.0], e=0.5, mu=0.3, law="ccp")
    assert r.method != "fast" or r.diagnostics.cone_violation <= 1e-9


def test_compile_lane_reports_seconds():
    assert lane.compile_lane() >= 0.0
    assert lane._COMPILED  # numba is a core dependency


ALL_LAWS = LAWS + ("stronge",)


def _tier1(monkeypatch, *args, **kwargs):
    """resolve_impact through tier 1 (the compiled reduction and map back around the law's
    kernel called from Python)."""
    with monkeypatch.context() as m:
        m.setattr(lane, "_SOLVE", None)
        m.setattr(lane, "_CALLS", -10 ** 9)
        return ci.resolve_impact(*args, **kwargs)


@pytest.mark.parametrize("d", [2, 3])
def test_both_tiers_agree_with_the_full_path(monkeypatch, d):
    """Tier 2 (the whole call compiled) and tier 1 (the reduction compiled, the law's kernel
    called from Python) against the full path (build_problem's LAPACK reduction, the law by
    ``solve_problem``): the same impulse to round-off, regime, effective mass, and the same
    notes and extras (which the lane measures on first access)."""
    lane.compile_lane()
    assert lane._SOLVE is not None
    rng = np.random.default_rng(40 + d)
    for law in ALL_LAWS:
        for _ in range(8 if (law == "stronge" and d == 3) else 60):
            M, J, dq = random_impact(rng, d, int(rng.integers(d, 7)))
            e, mu = float(rng.uniform()), float(rng.uniform(0, 1.5))
            try:
                fast = ci.resolve_impact(M, J, dq, e=e, mu=mu, law=law)
            except ci.ConvImpactError as exc:
                with pytest.raises(type(exc)):
                    _tier1(monkeypatch, M, J, dq, e=e, mu=mu, law=law)
                continue
            tier1 = _tier1(monkeypatch, M, J, dq, e=e, mu=mu, law=law)
            slow = solve_problem(build_problem(M, J, dq, e, mu), law, "fast")
            scale = np.abs(slow.impulse).max()
            assert np.abs(fast.impulse - slow.impulse).max() <= 1e-12 * scale
            assert np.abs(tier1.impulse - slow.impulse).max() <= 1e-12 * scale
            assert tier1.regime == slow.regime
            assert fast.regime == slow.regime
            a, b = fast.diagnostics, slow.diagnostics
            assert (a.effective_mass is None) == (b.effective_mass is None)
            if b.effective_mass is not None:
                assert a.effective_mass == pytest.approx(b.effective_mass, rel=1e-12)
            assert a.notes == b.notes and a.warnings == b.warnings
            assert set(a.extras) == set(b.extras)
            assert a.restitution_residual == pytest.approx(b.restitution_residual, abs=1e-12)


def test_tier_two_is_taken_after_hot_calls(monkeypatch):
    """Without numba's disk cache the whole call is compiled only once the lane is hot."""
    lane.compile_lane()
    solve = lane._SOLVE
    monkeypatch.setattr(lane, "_SOLVE", None)
    monkeypatch.setattr(lane, "_CALLS", 0)
    monkeypatch.setattr(lane, "HOT_CALLS", 3)
    J = np.array([[0.0, 1.0], [1.0, 0.0]])
    for expected in (None, None, solve):
        r = ci.resolve_impact(2.0 * np.eye(2), J, [1.0, -1.0], e=0.5, mu=0.3)
        assert lane._SOLVE is expected
        # the README's particle, by hand: W = I/2, pi_n = (1 + e) 1 / W_nn = 3, slide with
        # pi_t = -mu pi_n = -0.9, so v+ = (-1 + 3/2, 1 - 0.9/2) = (0.5, 0.55)
        np.testing.assert_allclose(r.v_plus, [0.5, 0.55], rtol=1e-14)
