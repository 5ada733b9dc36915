"""The smooth extension of the largest smallest margin from one program's active set
(:func:`margin_extension`): the event location's predictor of a held group's margin
crossing zero (:meth:`~.event_watch.EventWatch.locate_margin`), no margin itself.
"""

from __future__ import annotations

import numpy as np

from .force_distribution import _margin_blocks, _range_basis, _zero_round_off
from .force_distribution_polish import _newton_max_min


def margin_extension(mu: np.ndarray, d: int, combo, lam0: np.ndarray, Z: np.ndarray,
                     fscale: float, state: tuple, orthonormal: bool = False) -> float | None:
    """The smooth extension of the largest smallest margin from one program's active set:
    the optimality conditions of :func:`~.force_distribution.max_margin_distribution`'s stage 1 with the cones'
    kinds of ``state`` (active set, maximizer, margin: a warm start's, at a nearby state)
    solved by Newton's method, without checking the cones. Where that active set is the
    program's it is the largest smallest margin (relative to ``fscale``); elsewhere a
    smooth continuation of it, not a margin of any distribution. None where Newton's
    method does not converge. (The event location's predictor of a margin's zero:
    :meth:`~.event_watch.EventWatch.locate_margin`.)"""
    active, lam_prev, tau = state
    lam0 = np.asarray(lam0, float).ravel()
    Q = _zero_round_off(Z) if orthonormal else _range_basis(Z)
    r = Q.shape[1]
    blocks = _margin_blocks(np.asarray(mu, float).ravel(), d, combo, lam0 / fscale, Q)
    if r == 0 or not blocks or active is None:
        return None
    blocks.append(("nn", np.zeros((1, r)), np.ones(1), np.ones(1)))
    kinds, parts = active
    if len(kinds) != len(blocks) or lam_prev is None or lam_prev.shape != lam0.shape:
        return None
    x0 = np.empty(r + 1)
    x0[:r] = Q.T @ ((lam_prev - lam0) / fscale)
    x0[r] = tau
    try:
        v = _newton_max_min(blocks, kinds, [p.copy() for p in parts], x0, check=False)
    except (ValueError, np.linalg.LinAlgError):  # a block's size differs: not this program
        return None
    return None if v is None else float(v[r])
