"""Independent islands of a time step's contact problem.

Coordinates are *coupled* when the mass matrix or a loop constraint couples them
(``M_ij != 0``, or i and j in one row of C): the connected components of that graph are the
step's *groups* (a free body's six coordinates, a robot's whole tree). The inverse mass G of
a step is block diagonal over the groups. Active contacts join the groups whose coordinates
they move (the nonzero columns of their Jacobian rows); the connected components of groups
joined by contacts are the *islands*. The Delassus matrix ``W = J G J^T`` is block diagonal
over the islands (a contact row of one island has no column in another's groups), so each
island's contact problem is solved apart, and the answer is the whole problem's.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..compiled import jit as _jit


@_jit
def _components(rows, gid, na, ng):
    """Component (its root node) of each node of the graph contacts (0..na-1) -- groups
    (na..na+ng-1) with edges (rows[e], na + gid[e]): union-find with path halving."""
    parent = np.arange(na + ng)
    for e in range(rows.shape[0]):
        a = rows[e]
        b = na + gid[e]
        while parent[a] != a:
            parent[a] = parent[parent[a]]
            a = parent[a]
        while parent[b] != b:
            parent[b] = parent[parent[b]]
            b = parent[b]
        if a != b:
            parent[max(a, b)] = min(a, b)
    for i in range(na + ng):
        r = i
        while parent[r] != r:
            r = parent[r]
        parent[i] = r
    return parent


@dataclass(frozen=True)
class Groups:
    """The coordinate groups of a step.

    Attributes
    ----------
    label : (k,) group of each coordinate.
    members : per group, its coordinates (sorted).
    by_size : per group size s, ``(groups, coordinates)``: the group indices and an
        (n_groups, s) array of their coordinates (for batched factorizations).
    """

    label: np.ndarray
    members: tuple[np.ndarray, ...]
    by_size: dict

    @property
    def count(self) -> int:
        return len(self.members)


def coordinate_groups(pattern: np.ndarray) -> Groups:
    """Groups of the symmetric coupling pattern (k, k) (bool: M_ij != 0 or loop-coupled):
    its connected components (union-find, :func:`_components`), numbered by their lowest
    coordinate, as scipy's ``connected_components`` numbers them."""
    k = pattern.shape[0]
    i, j = np.nonzero(pattern)
    roots = _components(i.astype(np.int64), j.astype(np.int64), 0, k)
    _, label = np.unique(roots, return_inverse=True)  # (roots: each component's lowest)
    n = int(label.max()) + 1 if k else 0
    order = np.argsort(label, kind="stable")
    counts = np.bincount(label, minlength=n)
    members = tuple(np.split(order, np.cumsum(counts)[:-1])) if k else ()
    by_size: dict = {}
    for g, idx in enumerate(members):
        by_size.setdefault(idx.size, []).append(g)
    by_size = {s: (np.array(gs), np.array([members[g] for g in gs]))
               for s, gs in sorted(by_size.items())}
    return Groups(label, members, by_size)


def contact_islands(moves: np.ndarray, groups: Groups, split: bool = True
                    ) -> list[tuple[np.ndarray, np.ndarray]]:
    """The islands of the active contacts.

    Parameters
    ----------
    moves : (n_active, k) bool, contact c's rows have a nonzero entry in column j.
    groups : the step's coordinate groups.
    split : False puts every active contact into one island (the whole problem).

    Returns
    -------
    list of (contacts, coordinates): indices into the active contacts and the coordinates
    of the island's groups, both sorted.
    """
    na = moves.shape[0]
    if na == 0:
        return []
    ng = groups.count
    rows, cols = np.nonzero(moves)
    gid = groups.label[cols]
    if not split:
        gs = np.unique(gid)
        return [(np.arange(na), groups.members[gs[0]] if gs.size == 1 else
                 np.sort(np.concatenate([groups.members[g] for g in gs])))]
    # the bipartite graph contacts -- groups: its components are the islands
    comp = _components(rows, gid, na, ng)
    comp_c, comp_g = comp[:na], comp[na:]
    order = np.argsort(comp_c, kind="stable")
    bounds = np.flatnonzero(np.diff(comp_c[order])) + 1
    gorder = np.argsort(comp_g, kind="stable")
    gbounds = np.flatnonzero(np.diff(comp_g[gorder])) + 1
    groups_of = {int(comp_g[gs[0]]): gs for gs in np.split(gorder, gbounds)}
    out = []
    for cs in np.split(order, bounds):
        gs = groups_of[int(comp_c[cs[0]])]
        cols_i = groups.members[gs[0]] if gs.size == 1 else np.sort(
            np.concatenate([groups.members[g] for g in gs]))
        out.append((np.sort(cs), cols_i))
    return out
