"""The largest-smallest-margin program (:func:`~.force_distribution.max_margin_distribution`,
stage 1) solved without the cone solver from a cold start: a compiled primal-dual
interior-point method's last point
(:func:`~.force_interior_kernels.primal_dual_max_min`) refined by Newton's method on
the program's optimality conditions (:func:`~.force_distribution_polish._polish_max_min`),
which certifies it: stationarity and the active cones' equations to 1e-12, every inactive
cone's slack and every active cone's multiplier in its cone (a KKT point of the convex
program: its optimum). Where that polish does not converge in the cones (a degenerate
optimum: the box stack's slip onset of its middle box, on which Clarabel ends "AlmostSolved"
and the polish fails from its point too), the interior point itself is accepted where it
meets the conditions Clarabel's answer is held to (:func:`optimality_residuals` within the
caller's tolerance, 1e-8, on the original data; its gap s'z is 1e-11), as the caller accepts
the solver's there; otherwise None: the caller asks Clarabel.
"""

from __future__ import annotations

import numpy as np

from .force_distribution_polish import _cone_violation, _polish_max_min
from .force_interior_kernels import primal_dual_max_min

#: the interior-point method's duality gap s'z at which its point is handed to the polish
#: (an active cone's slack and an inactive one's multiplier are then ~1e-11 against entries
#: of order one: the active set reads off as from the solver's point; with 1e-8 the polish
#: did not certify two degenerate programs of the box stack, t* ~ -3.3e-8, that it
#: certifies from 1e-11)
COLD_GAP = 1e-11


def cold_max_min(blocks, rtol: float):
    """(y, t*, kinds, active) of the max-min program on ``blocks`` (kind, A, b, w; the
    last one the bound tau <= 1) as :func:`~.force_distribution_polish._polish_max_min`
    returns them: certified there (``active`` not None), or, where the polish does not
    converge, the interior point with every :func:`optimality_residuals` at most ``rtol``
    (``active`` None, as the polish returns a solver's point it cannot refine). None where
    the interior-point method fails, the blocks are not of its form (a second-order cone
    of three rows whose ``w`` is ``(w0 > 0, 0, 0)``, half-lines with ``w > 0`` or ``A, w =
    0 < b``), or neither certificate holds."""
    tau0 = np.inf
    for (kind, Ab, bb, wb) in blocks:
        if kind == "soc":
            if bb.size != 3 or not (wb[0] > 0.0 and wb[1] == 0.0 and wb[2] == 0.0):
                return None
            tau0 = min(tau0, (bb[0] - np.hypot(bb[1], bb[2])) / wb[0])
        elif np.all(wb > 0.0):
            tau0 = min(tau0, float(np.min(bb / wb)))
        elif not (np.all(wb == 0.0) and np.all(bb > 0.0) and not np.any(Ab)):
            return None
    if not np.isfinite(tau0):
        return None
    # the kernel's cones: a second-order cone of three rows, each row of a half-line block
    sizes = np.concatenate([[3] if blk[0] == "soc" else np.ones(len(blk[2]), dtype=np.int64)
                            for blk in blocks]).astype(np.int64)
    starts = np.zeros(sizes.size, dtype=np.int64)
    np.cumsum(sizes[:-1], out=starts[1:])
    A = np.vstack([blk[1] for blk in blocks])
    G = np.ascontiguousarray(np.hstack([A, np.concatenate([blk[3] for blk in blocks])[:, None]]))
    b = np.concatenate([blk[2] for blk in blocks])
    x = np.zeros(G.shape[1])
    x[-1] = tau0 - 1.0  # (every slack at least 1 inside its cone)
    z = np.zeros(b.size)
    try:
        if not primal_dual_max_min(G, b, starts, sizes, x, z, COLD_GAP):
            return None
    except np.linalg.LinAlgError:  # (a singular Newton system)
        return None
    got = _polish_max_min(blocks, x, z)
    if got[3] is not None:
        return got
    q = np.zeros(x.size)
    q[-1] = -1.0
    cones = [(blk[0], len(blk[2])) for blk in blocks]
    residuals = optimality_residuals(np.zeros((x.size, x.size)), q, G, b, cones, x, z)
    return got if all(v <= rtol for v in residuals.values()) else None


def optimality_residuals(P: np.ndarray, q: np.ndarray, A: np.ndarray, b: np.ndarray, cones,
                         x: np.ndarray, z: np.ndarray) -> dict:
    """The optimality conditions of ``argmin x'Px/2 + q'x s.t. b - A x in the cones`` at
    (x, multipliers z), each relative to the size of its terms (as a solver's own
    criteria): s = b - A x and z in their (self-dual) cones, stationarity P x + q + A'z =
    0, complementarity s'z = 0."""
    s = b - A @ x
    Px, Az = P @ x, A.T @ z

    def big(*vs):
        return 1.0 + max(float(np.max(np.abs(v), initial=0.0)) for v in vs)

    return {"primal cone": _cone_violation(s, cones) / big(b, A @ x),
            "dual cone": _cone_violation(z, cones) / big(z),
            "stationarity": float(np.max(np.abs(Px + q + Az))) / big(Px, q, Az),
            "complementarity": abs(float(s @ z)) / big(0.5 * float(x @ Px) + float(q @ x),
                                                      float(b @ z))}
