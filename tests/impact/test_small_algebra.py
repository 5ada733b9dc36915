"""The full path's small algebra (:mod:`convimpact.impact.problem.dense`): the Cholesky factor
and the triangular solves -- on Python floats up to ``SMALL_MAX`` rows, LAPACK/BLAS above --
against independent references (numpy.linalg.cholesky, scipy.linalg.solve_triangular) on
random SPD matrices of sizes 1..40, and the same typed errors as before on input that is not
positive definite.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg as sla

import convimpact as ci
from convimpact.impact.problem import dense as sl
from convimpact.impact.problem.build import build_problem, check_mass_matrix

SIZES = range(1, 41)
RTOL = 1e-13


def _spd(rng, k: int) -> np.ndarray:
    A = rng.normal(size=(k, k))
    return A @ A.T / k + np.diag(rng.uniform(0.5, 2.0, k))


def _rel(a, b) -> float:
    return float(np.max(np.abs(a - b)) / np.max(np.abs(b)))


def test_both_branches_are_exercised():
    assert 1 <= sl.SMALL_MAX < max(SIZES)


@pytest.mark.parametrize("k", SIZES)
def test_cholesky_matches_numpy(k):
    rng = np.random.default_rng(100 + k)
    for _ in range(3):
        M = _spd(rng, k)
        L, info = sl.cholesky_lower(M)
        assert info == 0 and L.shape == (k, k) and L.dtype == np.float64
        assert not np.triu(L, 1).any()  # lower, the rest exactly zero
        assert _rel(L, np.linalg.cholesky(M)) <= RTOL
        assert _rel(L @ L.T, M) <= RTOL


@pytest.mark.parametrize("k", SIZES)
def test_triangular_solves_match_scipy(k):
    rng = np.random.default_rng(200 + k)
    L = np.linalg.cholesky(_spd(rng, k))
    for r in (1, 2, 3, 5):
        B = rng.normal(size=(k, r))
        for trans in (0, 1):
            X = sl.tri_solve(L, B, trans)
            ref = sla.solve_triangular(L, B, lower=True, trans=trans)
            assert X.shape == (k, r) and _rel(X, ref) <= RTOL, (r, trans)
        # a transposed (non-contiguous) right-hand side, as the reduction passes rows.T
        X = sl.tri_solve(L, np.ascontiguousarray(B.T).T)
        assert _rel(X, sla.solve_triangular(L, B, lower=True)) <= RTOL
    b = rng.normal(size=k)
    for trans in (0, 1):
        x = sl.tri_solve(L, b, trans)
        assert x.shape == (k,)
        assert _rel(x, sla.solve_triangular(L, b, lower=True, trans=trans)) <= RTOL


@pytest.mark.parametrize("k", [1, 2, 3, 6, 12, 13, 30])
def test_no_right_hand_side(k):
    L = np.linalg.cholesky(_spd(np.random.default_rng(k), k))
    assert sl.tri_solve(L, np.zeros((k, 0))).shape == (k, 0)


def _indefinite(rng, k: int, j: int) -> np.ndarray:
    """SPD but for the pivot j (0-based), made negative: LAPACK's info is j + 1."""
    M = _spd(rng, k)
    L = np.linalg.cholesky(M)
    L[j, j] = 0.0
    M = L @ L.T
    M[j, j] -= 0.5
    return 0.5 * (M + M.T)


@pytest.mark.parametrize("k", [1, 2, 3, 4, 6, 9, 12, 13, 20, 40])
def test_not_positive_definite_same_decision_and_error(k):
    rng = np.random.default_rng(300 + k)
    for j in sorted({0, k // 2, k - 1}):
        M = _indefinite(rng, k, j)
        L, info = sl.cholesky_lower(M)
        assert info == j + 1 == sla.lapack.dpotrf(M, 1, 1)[1]
        with pytest.raises(ci.MassMatrixError, match="not positive definite"):
            check_mass_matrix(M)
        Jc = np.zeros((2, k))
        Jc[0, 0] = Jc[1, -1] = 1.0
        with pytest.raises(ci.MassMatrixError, match="not positive definite"):
            build_problem(M, Jc, -np.ones(k))
        with pytest.raises(ci.MassMatrixError, match="not positive definite"):
            ci.resolve_impact(M, Jc, -np.ones(k), method="closed-form")
    # singular (a zero row and column: the last pivot is exactly 0) and negative definite
    S = _spd(rng, k)
    S[-1], S[:, -1] = 0.0, 0.0
    for M in (S, -_spd(rng, k)):
        assert sl.cholesky_lower(M)[1] == sla.lapack.dpotrf(M, 1, 1)[1] != 0
        with pytest.raises(ci.MassMatrixError):
            check_mass_matrix(M)


@pytest.mark.parametrize("k", [2, 3, 6, 20])
def test_infinite_entry_is_a_typed_error(k):
    M = np.eye(k)
    M[0, 1] = M[1, 0] = np.inf  # exactly symmetric with a finite diagonal
    assert sl.cholesky_lower(M)[1] != 0
    with pytest.raises(ci.InputError):
        check_mass_matrix(M)


@pytest.mark.parametrize("k", [3, 30])
def test_zero_pivot_in_a_factor_is_a_mass_matrix_error(k):
    L = np.linalg.cholesky(_spd(np.random.default_rng(k), k))
    L[1, 1] = 0.0
    with pytest.raises(ci.MassMatrixError):
        sl.tri_solve(L, np.ones((k, 2)))
    with pytest.raises(ci.MassMatrixError):
        sl.tri_solve(L, np.ones(k), trans=1)


@pytest.mark.parametrize("k, m", [(3, 1), (6, 2), (20, 5)])
def test_closed_loop_reduction_matches_the_dense_formula(k, m):
    """W = Jc G Jc^T with G = M^-1 - M^-1 C^T (C M^-1 C^T)^-1 C M^-1, and the loop impulse
    of the map back, against numpy's dense inverse."""
    rng = np.random.default_rng(400 + k)
    M = _spd(rng, k)
    C = rng.normal(size=(m, k))
    Q, _ = np.linalg.qr(C.T)
    dq = rng.normal(size=k)
    dq -= Q @ (Q.T @ dq)
    Jc = rng.normal(size=(3, k))
    P = build_problem(M, Jc, dq, C=C)
    Mi = np.linalg.inv(M)
    G = Mi - Mi @ C.T @ np.linalg.solve(C @ Mi @ C.T, C @ Mi)
    assert _rel(P.delassus, Jc @ G @ Jc.T) <= 1e-11
    pi = rng.normal(size=3)
    d_dq, dsigma = P.velocity_jump(pi)
    ref_sigma = -np.linalg.solve(C @ Mi @ C.T, C @ Mi @ Jc.T @ pi)
    assert _rel(dsigma, ref_sigma) <= 1e-11
    assert _rel(d_dq, Mi @ (Jc.T @ pi + C.T @ ref_sigma)) <= 1e-11
