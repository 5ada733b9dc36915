"""Coulomb's law by a lightly damped Newton method straight from the CCP's answer: a try of
the contact engine (:mod:`.engine`) on mid-size problems before its ADMM's way.

From the CCP's answer, the Newton finish (:func:`.finish.newton_finish`) with its
Levenberg-Marquardt weight ``damping |F| / scale`` at ``damping`` = :data:`DAMPING` certified
the stacks of the corpus where the full weight crawled: a 100-box stack (300 rows) in 5
steps, planar stacks of 100 and 200 blocks (200 and 400 rows) in 3 and 4, where the full
weight's 20 steps ended at 1e-4 to 6e-7 and the ADMM took 1,400-4,700 iterations. On walls
and piles it crawls from its first step (1e-3 to 5e-2 on sphere and capsule piles of 126-145
contacts) or stalls within two (5e-4 on a 4x4 brick wall), and the try ends there
(:data:`FIRST`, :data:`STALL_STEPS`): the engine goes on from the same CCP answer.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from .ccp_interior import EngineResult, solve_ccp, use_sparse
from .cones import natural_map_residual, project
from .finish import newton_finish

#: the Levenberg-Marquardt weight's factor (1: the finish's own, Yamashita and Fukushima's)
DAMPING = 1e-3
#: at most this many steps, ending after the first where it did not drop by FIRST[1] (the
#: stacks' first step: 30-200x; the piles': 1-2x, 0.01-0.03 from the solution) and where the
#: best residual has not halved in STALL_STEPS
STEPS = 10
FIRST = (1, 0.1)
STALL_STEPS = 2


def light_direct(W, b: np.ndarray, mu: np.ndarray, d: int, *, tol: float, max_iter: int,
                 sparse: bool | None = None) -> tuple[EngineResult, EngineResult]:
    """The CCP's answer (:func:`.ccp_interior.solve_ccp`) and, from it, the light Newton try
    on Coulomb's law: returns ``(result, ccp)``, ``result.converged`` when its natural-map
    residual on the original data is at most ``tol`` (its iterations count the CCP's)."""
    n = mu.shape[0]
    if sparse is None:
        sparse = use_sparse(W, n * d)
    W = sp.csr_matrix(W) if sparse else (W.toarray() if sp.issparse(W) else np.asarray(W))
    b = np.asarray(b, dtype=float).reshape(n, d)
    ccp = solve_ccp(W, b, mu, d, tol=tol, max_iter=max_iter, sparse=sparse)
    r, res, steps = newton_finish(W, b, mu, ccp.impulse, coulomb=True, tol=tol,
                                  max_iter=STEPS, sparse=sparse, damping=DAMPING,
                                  stall_steps=STALL_STEPS, first=FIRST)
    r, res, u = on_cones(W, b, mu, r, True, tol)
    ok = bool(res <= tol)
    return (EngineResult(r, u, float(res), ccp.iterations + steps, ok,
                         "converged" if ok else "the light Newton try stalled"), ccp)


def on_cones(W, b: np.ndarray, mu: np.ndarray, r: np.ndarray, coulomb: bool, tol: float):
    """``(r, residual, u)``: ``r`` (a Newton answer, which may lie outside the cones by up to
    its residual) projected onto the cones where that keeps its natural-map residual at most
    ``tol``, else ``r`` itself; the residual and ``u = W r + b`` of the one returned."""
    res, u = natural_map_residual(W, b, mu, r, coulomb=coulomb)
    p = project(r, mu)
    resp, up = natural_map_residual(W, b, mu, p, coulomb=coulomb)
    return (p, resp, up) if resp <= tol else (r, res, u)
