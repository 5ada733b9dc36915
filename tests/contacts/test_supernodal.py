"""The supernodal LDL^T (convimpact.contacts.supernodal) against dense solves with numpy:
positive definite and quasi-definite matrices, panels wider than its column blocks, a
refactorization with new values, a zero pivot handed to QDLDL, a changed pattern refused."""

import numpy as np
import pytest
import scipy.sparse as sp

from convimpact.contacts import supernodal
from convimpact.contacts.supernodal import PANEL_BLOCK, SupernodalLDL


@pytest.fixture
def always(monkeypatch):
    """The supernodes on every pattern (the engine keeps them for large fill-ins only)."""
    monkeypatch.setattr(supernodal, "MIN_FLOPS", 0.0)
    monkeypatch.setattr(supernodal, "MIN_WIDE_SHARE", 0.0)


def _spd(rng, n, density, dense_tail=0):
    B = sp.random(n, n, density=density, random_state=int(rng.integers(2**31)))
    A = B @ B.T + 0.1 * sp.identity(n)
    if dense_tail:  # a dense trailing block: one wide supernode at the top of the tree
        T = rng.standard_normal((dense_tail, dense_tail))
        A = A + sp.block_diag([sp.csc_matrix((n - dense_tail, n - dense_tail)),
                               sp.csc_matrix(T @ T.T)])
    return sp.csc_matrix(A)


def _quasi_definite(rng, n, m, density):
    G = sp.random(n, m, density=density, random_state=int(rng.integers(2**31)))
    return sp.csc_matrix(sp.bmat([[_spd(rng, n, density), G], [G.T, -sp.identity(m)]]))


def _check(f, A, rng):
    b = rng.standard_normal(A.shape[0])
    want = np.linalg.solve(A.toarray(), b)
    assert np.abs(f.solve(b) - want).max() <= 1e-10 * np.abs(want).max()


@pytest.mark.parametrize("kind", ["spd", "wide", "quasi-definite"])
def test_factor_and_refactor_solve_as_numpy(always, kind):
    rng = np.random.default_rng({"spd": 1, "wide": 2, "quasi-definite": 3}[kind])
    for _ in range(3):
        n = int(rng.integers(20, 200))
        if kind == "spd":
            A = _spd(rng, n, 3.0 / n)
        elif kind == "wide":
            A = _spd(rng, n + 3 * PANEL_BLOCK, 2.0 / n, dense_tail=3 * PANEL_BLOCK + 5)
        else:
            A = _quasi_definite(rng, n, int(rng.integers(5, 60)), 3.0 / n)
        f = SupernodalLDL(A)
        assert f.supernodal
        if kind == "wide":
            assert np.diff(f._start).max() > 3 * PANEL_BLOCK
        _check(f, A, rng)  # QDLDL's first factorization
        for _ in range(2):  # new values on the same pattern: the supernodes'
            B = A.copy()
            B.data = B.data * (1.0 + 0.2 * rng.random(B.nnz))
            B = sp.csc_matrix(0.5 * (B + B.T))
            B.data[B.data == 0.0] = 0.0
            f.update(sp.triu(B, format="csc"), upper=True)
            assert f.fallbacks == 0
            _check(f, B, rng)


def test_upper_triangle_given_and_full_matrix_agree(always):
    rng = np.random.default_rng(4)
    A = _spd(rng, 80, 0.05)
    f = SupernodalLDL(sp.triu(A, format="csc"), upper=True)
    f.update(A)
    _check(f, A, rng)


def test_zero_pivot_goes_to_qdldl_and_back(always):
    # [[1, 1], [1, 1 + t]]: LDL^T's second pivot is t, exactly 0 at t = 0
    def matrix(t):
        return sp.csc_matrix(np.array([[1.0, 1.0], [1.0, 1.0 + t]]))

    f = SupernodalLDL(matrix(1.0))
    f.update(matrix(0.0))
    assert f.fallbacks == 1
    f.update(matrix(3.0))
    assert f.fallbacks == 1
    np.testing.assert_allclose(f.solve(np.array([1.0, 2.0])),
                               np.linalg.solve(matrix(3.0).toarray(), [1.0, 2.0]), rtol=1e-14)


def test_another_pattern_is_refused(always):
    rng = np.random.default_rng(5)
    A = _spd(rng, 40, 0.1)
    f = SupernodalLDL(A)
    with pytest.raises(ValueError, match="pattern"):
        f.update(A + sp.identity(40) + sp.csc_matrix(([1.0, 1.0], ([0, 39], [39, 0])),
                                                     shape=(40, 40)))


def test_small_fill_stays_with_qdldl():
    # the default thresholds: a banded matrix's factorization is cheap, QDLDL keeps it
    n = 300
    A = sp.diags([np.full(n - 1, -1.0), np.full(n, 4.0), np.full(n - 1, -1.0)], [-1, 0, 1],
                 format="csc")
    f = SupernodalLDL(A)
    assert not f.supernodal
    f.update(A * 2.0)
    b = np.arange(n, dtype=float)
    np.testing.assert_allclose(f.solve(b), np.linalg.solve(2.0 * A.toarray(), b),
                               rtol=1e-12)

