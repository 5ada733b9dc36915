"""The small compiled algebra that the recursive algorithms share, and dense Cholesky.

Quantities live in rows of 2-D work arrays and are addressed as (array, row, column offset),
never through views made in the loops (see :mod:`convimpact.model.tree_layout`), so the helpers
here take that triple and return tuples of scalars or write in place:

* 3-vectors and row-major 3 x 3 matrices: :func:`_cross`, :func:`_mv`, :func:`_mm`;
* spatial vectors (linear part first, about the world origin or a node's origin):
  :func:`_dot6`, the ten-number inertia ``Y = (m, h, Ixx, Iyy, Izz, Ixy, Ixz, Iyz)`` times a
  motion (:func:`_ymul`) and an inertia carried to another point and added (:func:`_shift_add`);
* the lower Cholesky factor of M (:func:`_cholesky`, :func:`cholesky`; the factorization and
  the back substitution are :mod:`convimpact.impact.problem.compiled_reduction`'s, which the
  impact lanes share) and solves with it (:func:`cho_solve_vec`, :func:`cho_solve_mat`), and
  :func:`all_finite`: the simulator's right-hand side calls these directly.

The compiled modules of the recursive algorithms decorate their entry points with
:data:`convimpact.compiled.jit` and the functions called from compiled code only with
:data:`convimpact.compiled.jit_internal` (no CPython wrapper), like every compiled function of
the package: :mod:`convimpact.compiled` keeps their cache and retires it when any compiled
source changes.
"""

from __future__ import annotations

import math

from ..compiled import jit, jit_internal
from ..impact.problem.compiled_reduction import back_substitute, cholesky_into
from .tree_layout import NOT_DEFINITE, OK


# ---- small algebra on (array, row, column offset) ---------------------------------------------
@jit_internal
def _cross(a0, a1, a2, b0, b1, b2):
    return a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0


@jit_internal
def _dot6(A, i, a, B, j, b):
    return (A[i, a] * B[j, b] + A[i, a + 1] * B[j, b + 1] + A[i, a + 2] * B[j, b + 2]
            + A[i, a + 3] * B[j, b + 3] + A[i, a + 4] * B[j, b + 4] + A[i, a + 5] * B[j, b + 5])


@jit_internal
def _mv(A, i, a, x0, x1, x2):
    """The 3 x 3 matrix stored row-major at A[i, a:a+9] times (x0, x1, x2)."""
    return (A[i, a] * x0 + A[i, a + 1] * x1 + A[i, a + 2] * x2,
            A[i, a + 3] * x0 + A[i, a + 4] * x1 + A[i, a + 5] * x2,
            A[i, a + 6] * x0 + A[i, a + 7] * x1 + A[i, a + 8] * x2)


@jit_internal
def _mm(A, i, a, B, j, b, C, l, c):
    """C[l, c:c+9] = A[i, a:a+9] B[j, b:b+9] (3 x 3, row-major)."""
    for r in range(3):
        a0, a1, a2 = A[i, a + 3 * r], A[i, a + 3 * r + 1], A[i, a + 3 * r + 2]
        for q in range(3):
            C[l, c + 3 * r + q] = a0 * B[j, b + q] + a1 * B[j, b + 3 + q] + a2 * B[j, b + 6 + q]


@jit_internal
def _ymul(Y, i, y, X, j, x, O, l, o):
    """O[l, o:o+6] = Y X for the 10-number inertia Y[i, y:y+10] = (m, h, Ixx, Iyy, Izz, Ixy,
    Ixz, Iyz) about the origin and the motion X[j, x:x+6] = (v, w)."""
    m = Y[i, y]
    h0, h1, h2 = Y[i, y + 1], Y[i, y + 2], Y[i, y + 3]
    v0, v1, v2 = X[j, x], X[j, x + 1], X[j, x + 2]
    w0, w1, w2 = X[j, x + 3], X[j, x + 4], X[j, x + 5]
    O[l, o] = m * v0 - (h1 * w2 - h2 * w1)
    O[l, o + 1] = m * v1 - (h2 * w0 - h0 * w2)
    O[l, o + 2] = m * v2 - (h0 * w1 - h1 * w0)
    O[l, o + 3] = (h1 * v2 - h2 * v1) + Y[i, y + 4] * w0 + Y[i, y + 7] * w1 + Y[i, y + 8] * w2
    O[l, o + 4] = (h2 * v0 - h0 * v2) + Y[i, y + 7] * w0 + Y[i, y + 5] * w1 + Y[i, y + 9] * w2
    O[l, o + 5] = (h0 * v1 - h1 * v0) + Y[i, y + 8] * w0 + Y[i, y + 9] * w1 + Y[i, y + 6] * w2


@jit_internal
def _shift_add(Y, i, y, d0, d1, d2, O, l, o):
    """O[l, o:o+10] += the inertia Y[i, y:y+10] about a point A, expressed about B = A - d."""
    m = Y[i, y]
    h0, h1, h2 = Y[i, y + 1], Y[i, y + 2], Y[i, y + 3]
    hd = 2.0 * (h0 * d0 + h1 * d1 + h2 * d2) + m * (d0 * d0 + d1 * d1 + d2 * d2)
    O[l, o] += m
    O[l, o + 1] += h0 + m * d0
    O[l, o + 2] += h1 + m * d1
    O[l, o + 3] += h2 + m * d2
    O[l, o + 4] += Y[i, y + 4] + hd - 2.0 * h0 * d0 - m * d0 * d0
    O[l, o + 5] += Y[i, y + 5] + hd - 2.0 * h1 * d1 - m * d1 * d1
    O[l, o + 6] += Y[i, y + 6] + hd - 2.0 * h2 * d2 - m * d2 * d2
    O[l, o + 7] += Y[i, y + 7] - (h0 * d1 + d0 * h1) - m * d0 * d1
    O[l, o + 8] += Y[i, y + 8] - (h0 * d2 + d0 * h2) - m * d0 * d2
    O[l, o + 9] += Y[i, y + 9] - (h1 * d2 + d1 * h2) - m * d1 * d2


# ---- dense Cholesky -------------------------------------------------------------------------
@jit_internal
def _cholesky(M, L, k):
    return OK if cholesky_into(M, L, k, 0.0) else NOT_DEFINITE


@jit
def cholesky(M, L):
    """Lower Cholesky factor of M into L (upper triangle untouched); False when M is not
    positive definite."""
    return cholesky_into(M, L, M.shape[0], 0.0)


@jit
def cho_solve_vec(L, b, out):
    """``out = (L L^T)^-1 b`` for a lower Cholesky factor L (out may be b)."""
    for i in range(L.shape[0]):
        s = b[i]
        for p in range(i):
            s -= L[i, p] * out[p]
        out[i] = s / L[i, i]
    back_substitute(L, out)


@jit
def cho_solve_mat(L, B, out):
    """``out = (L L^T)^-1 B`` column by column, B of shape (n, m) (out may be B)."""
    n = L.shape[0]
    m = B.shape[1]
    for c in range(m):
        for i in range(n):
            s = B[i, c]
            for p in range(i):
                s -= L[i, p] * out[p, c]
            out[i, c] = s / L[i, i]
        for i in range(n - 1, -1, -1):
            s = out[i, c]
            for p in range(i + 1, n):
                s -= L[p, i] * out[p, c]
            out[i, c] = s / L[i, i]


@jit
def all_finite(a):
    """True when every entry of the 1-D array ``a`` is finite."""
    for i in range(a.shape[0]):
        if not math.isfinite(a[i]):
            return False
    return True
