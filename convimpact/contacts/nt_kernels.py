"""The per-iteration cone algebra of the vectorized interior point (:mod:`.ccp_interior`),
compiled: one call per group of cones of one dimension for what :mod:`.cones` does in a dozen
numpy calls (on the corpus's problems of 100-500 contacts the interior point spent about
half its time in them, a millisecond an iteration in calls on arrays of a few hundred rows).

The algebra is the compiled dense kernels' (:mod:`.interior_point`: CVXOPT's Nesterov-Todd
scaling of a second-order cone, ``T = beta (2 v v^T - J)``, ``T z = T^-1 x = lambda``),
applied cone by cone to a group's rows, flattened (k cones of dimension m; m = 1: the
frictionless normals, ``T = sqrt(x / z)``). A scaling is ``(v, beta)``, both of the rows'
length (beta at each cone's first entry).
"""

from __future__ import annotations

import numpy as np

from ..compiled import announce
from ..compiled import jit as _jit
from .interior_point import _apply_t, _jordan_solve, _max_step, _nt_scaling


#: first compilation of this module's kernels on 2 cores (s), announced
COMPILE_SECONDS = 3


def announce_compilation() -> None:
    """Say on stderr, once, that these kernels compile now (a cold cache)."""
    announce("interior point's cone kernels", COMPILE_SECONDS, nt_blocks, scaled_rhs,
             corrector_target)


@_jit
def nt_blocks(x, z, m):
    """The scalings of the cones of ``x``, ``z`` (flat, interior points): ``(v, beta, lam,
    H)``, ``lam = T z`` and the Newton system's blocks ``H = T^-2`` (k, m, m)."""
    N = x.shape[0]
    k = N // m
    v = np.empty(N)
    beta = np.empty(N)
    lam = np.empty(N)
    H = np.empty((k, m, m))
    e = np.zeros(N)
    col = np.empty(N)
    for c in range(k):
        o = c * m
        _nt_scaling(x, z, o, m, v, beta)
        _apply_t(v, beta, o, m, z, lam, False)
        # T^-2 column by column: T^-1 (T^-1 e_j)
        for j in range(m):
            e[o + j] = 1.0
            _apply_t(v, beta, o, m, e, col, True)
            e[o + j] = 0.0
            _apply_t(v, beta, o, m, col, e, True)
            for i in range(m):
                H[c, i, j] = e[o + i]
                e[o + i] = 0.0
    return v, beta, lam, H


@_jit
def scaled_rhs(v, beta, lam, target, m):
    """``T^-1 (lam \\ target)`` cone by cone (flat)."""
    N = lam.shape[0]
    t = np.empty(N)
    out = np.empty(N)
    for o in range(0, N, m):
        _jordan_solve(lam, target, o, m, t)
        _apply_t(v, beta, o, m, t, out, True)
    return out


@_jit
def affine_target(lam, m):
    """``-lam o lam`` cone by cone (flat; ``o`` the Jordan product)."""
    N = lam.shape[0]
    out = np.empty(N)
    for o in range(0, N, m):
        s = 0.0
        for j in range(o, o + m):
            s += lam[j] * lam[j]
        out[o] = -s
        for j in range(o + 1, o + m):
            out[j] = -2.0 * lam[o] * lam[j]
    return out


@_jit
def corrector_target(v, beta, lam, dx, dz, centering, m):
    """Mehrotra's corrector right-hand side cone by cone (flat):
    ``centering e - lam o lam - (T^-1 dx) o (T dz)``."""
    N = lam.shape[0]
    sx = np.empty(N)
    sz = np.empty(N)
    out = np.empty(N)
    for o in range(0, N, m):
        _apply_t(v, beta, o, m, dx, sx, True)
        _apply_t(v, beta, o, m, dz, sz, False)
        s = 0.0
        for j in range(o, o + m):
            s += lam[j] * lam[j] + sx[j] * sz[j]
        out[o] = centering - s
        for j in range(o + 1, o + m):
            out[j] = -2.0 * lam[o] * lam[j] - (sx[o] * sz[j] + sz[o] * sx[j])
    return out


@_jit
def max_step(x, dx, z, dz, m):
    """The largest step (at most 1e30) keeping ``x + a dx`` and ``z + a dz`` in every cone."""
    N = x.shape[0]
    starts = np.arange(0, N, m)
    sizes = np.full(starts.shape[0], m)
    return _max_step(x, dx, z, dz, starts, sizes, 1e30)
