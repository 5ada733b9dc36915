"""The coordinate groups of a time step (simulation/islands.coordinate_groups, a compiled
union-find) against scipy's connected components of the same coupling pattern: the same
components, numbered the same way (by their lowest coordinate)."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from convimpact.simulation.islands import coordinate_groups


def test_groups_are_scipys_connected_components():
    rng = np.random.default_rng(20261127)
    for _ in range(200):
        k = int(rng.integers(1, 40))
        A = rng.random((k, k)) < rng.uniform(0.0, 0.2)
        A = A | A.T
        np.fill_diagonal(A, True)
        groups = coordinate_groups(A)
        n, label = connected_components(sp.csr_matrix(A), directed=False)
        np.testing.assert_array_equal(groups.label, label)
        assert groups.count == n
        for g, members in enumerate(groups.members):
            np.testing.assert_array_equal(members, np.flatnonzero(label == g))


def test_free_bodies_are_one_group_each():
    blocks = np.kron(np.eye(5, dtype=bool), np.ones((6, 6), dtype=bool))
    groups = coordinate_groups(blocks)
    assert groups.count == 5
    assert list(groups.by_size) == [6]
    np.testing.assert_array_equal(groups.by_size[6][1], np.arange(30).reshape(5, 6))
