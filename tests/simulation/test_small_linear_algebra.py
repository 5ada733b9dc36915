"""The event-driven run's small dense linear algebra, each against a second method: the
direct LAPACK least squares of the force problem's implications and Newton steps
(force_distribution_polish._lstsq) against scipy.linalg.lstsq calling the same routine, and
the redundant rows of a held set (sustained.redundant_rows) against rows built dependent by
construction."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg as sla

from convimpact.simulation.force_distribution_polish import _lstsq
from convimpact.simulation.sustained import redundant_rows


@pytest.mark.parametrize("shape", [(7, 4), (4, 7), (6, 6)])
@pytest.mark.parametrize("nrhs", [None, 1, 3])
def test_lstsq_is_scipys_gelsy_bit_for_bit(shape, nrhs):
    rng = np.random.default_rng(11)
    m, n = shape
    J = rng.standard_normal((m, 2)) @ rng.standard_normal((2, n))  # rank 2
    J = J + rng.standard_normal((m, n)) * (np.arange(n) < 2)  # full rank in two columns
    F = rng.standard_normal(m if nrhs is None else (m, nrhs))
    eps = float(np.finfo(float).eps)
    ours = _lstsq(J, F, eps)
    ref = sla.lstsq(J, F, cond=eps, lapack_driver="gelsy", check_finite=False)[0]
    assert ours.shape == ref.shape
    np.testing.assert_array_equal(ours, ref)


def test_redundant_rows_drop_exactly_the_rows_built_dependent():
    """Rows of a 9-coordinate system: a loop's row, five contacts' normal rows (random,
    independent), then tangential rows: three built as combinations of the rows before
    them and one random (independent). The dropped rows are the three combinations
    (normal rows are tried before tangential ones, each kept when it raises the rank of
    C M^-1 C^T; 7 independent rows stay below the 9 coordinates), whatever the positive
    definite M."""
    rng = np.random.default_rng(5)
    k = 9
    B = rng.standard_normal((k, k))
    M = B @ B.T + k * np.eye(k)
    base = rng.standard_normal((6, k))
    loop = base[:1]
    rows, jac, dependent = [], {}, set()
    for i in range(1, 6):
        c = f"c{i}"
        jac[c] = np.vstack([base[i], rng.standard_normal(k)])
        rows += [(c, 0)]
    # tangential rows: the first three combinations of the normal rows and the loop's
    for i in range(1, 4):
        c = f"c{i}"
        jac[c][1] = rng.standard_normal(i + 1) @ np.vstack([loop, base[1:i + 1]])
        rows.append((c, 1))
        dependent.add((c, 1))
    rows.append(("c4", 1))  # c4's tangential row: random, independent of the others
    dropped = redundant_rows(M, loop, rows, jac)
    assert dropped == frozenset(dependent)
