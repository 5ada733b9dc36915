"""The stronge path's island layout in Moreau-Jean (simulation/moreau_stronge.StrongeIslands)
kept across new coordinate groups that leave its islands as they are, and laid out again
where they join islands: checked against the islands computed afresh
(simulation/islands.contact_islands) on a row of boxes."""

from __future__ import annotations

import numpy as np

from convimpact.bench.moreau_scenes import box_row
from convimpact.simulation.islands import contact_islands, coordinate_groups
from convimpact.simulation.moreau_stronge import StrongeIslands


def _layout(n_boxes):
    """A layout of the boxes' corner contacts, each box its own island, on per-coordinate
    groups (the first step's: M diagonal at zero rotation)."""
    mech, _, _ = box_row(n_boxes, True)
    k = 6 * n_boxes
    s = StrongeIslands(mech)
    moves = np.zeros((4 * n_boxes, k), dtype=bool)
    for c in range(4 * n_boxes):
        moves[c, 6 * (c // 4):6 * (c // 4) + 6] = True
    singles = coordinate_groups(np.eye(k, dtype=bool))
    islands = contact_islands(moves, singles)
    s._island_of = np.full(k, -1, dtype=np.int64)
    for i, (_, cols) in enumerate(islands):
        s._island_of[cols] = i
    return s, moves, k


def test_groups_within_the_islands_keep_the_layout():
    s, moves, k = _layout(3)
    per_body = coordinate_groups(np.kron(np.eye(3, dtype=bool), np.ones((6, 6), dtype=bool)))
    assert s._same_islands(per_body)
    # the islands computed afresh on those groups are the layout's
    again = contact_islands(moves, per_body)
    assert [list(cs) for cs, _ in again] == [[0, 1, 2, 3], [4, 5, 6, 7], [8, 9, 10, 11]]


def test_a_group_joining_two_boxes_lays_out_again():
    s, moves, k = _layout(3)
    pattern = np.kron(np.eye(3, dtype=bool), np.ones((6, 6), dtype=bool))
    pattern[0, 6] = pattern[6, 0] = True  # box 0 coupled to box 1
    joined = coordinate_groups(pattern)
    assert not s._same_islands(joined)
    assert len(contact_islands(moves, joined)) == 2
