"""Minimum-norm least squares and null spaces of small dense matrices without the singular value
decomposition, compiled: a complete orthogonal decomposition (Householder QR with column
pivoting, then a QR of the leading rows' transpose), for the active-set Newtons of
:mod:`convimpact.impact.conic.polish_newton` where their caller asks for it.

``A P = Q R`` with column pivoting (the largest remaining column first) reveals the rank: the
diagonal ``|R_kk|`` falls with k and tracks the singular values (within modest factors in
practice, not in the worst case); the rank is the number of ``|R_kk| > rcond |R_00|``. The
rank's rows ``[R11 R12] = [S^T 0] Z^T`` (a QR of their transpose, Z orthogonal) give

* the minimum-norm least-squares solution of ``A x = y`` (singular directions dropped):
  ``x = P Z_1 S^-T (Q^T y)_1``, the same vector as the SVD's pseudo-inverse with the same
  rank (the minimum-norm solution is unique once the rank is fixed);
* an orthonormal basis of the null space: ``P Z_2``, spanning the same space as the SVD's
  right singular vectors of the dropped singular values.

Both decide the rank by ``|R_kk|`` where the SVD decides it by the singular values: the same
decision wherever the matrix's singular values are clearly on one side of the cut (exactly
singular directions at round-off next to well-conditioned ones, as redundant contacts give),
possibly a different one for a singular value near the cut. Cost: about ``4 n^3`` flops for
n x n, no LAPACK call (numba's SVD of a 12 x 12 matrix costs some 20-30 us, mostly outside
the arithmetic).
"""

from __future__ import annotations

import numpy as np

from ...compiled import jit_internal as _jit_internal
from ..problem.compiled_reduction import back_substitute
from .polish_steps import _matvec


@_jit_internal
def _reflect(R, k, v):
    """The Householder reflection zeroing ``R[k+1:, k]``: its vector into ``v[k:]``, applied
    to the columns k.. of R; returns ``2 / |v|^2`` (0 when the column is already zero)."""
    m, n = R.shape
    alpha = 0.0
    for i in range(k, m):
        alpha += R[i, k] * R[i, k]
    alpha = np.sqrt(alpha)
    if alpha == 0.0:
        return 0.0
    if R[k, k] > 0.0:
        alpha = -alpha
    for i in range(k, m):
        v[i] = R[i, k]
    v[k] -= alpha
    vn = 0.0
    for i in range(k, m):
        vn += v[i] * v[i]
    if vn == 0.0:
        return 0.0
    f = 2.0 / vn
    for j in range(k, n):
        s = 0.0
        for i in range(k, m):
            s += v[i] * R[i, j]
        s *= f
        for i in range(k, m):
            R[i, j] -= s * v[i]
    for i in range(k + 1, m):
        R[i, k] = 0.0
    return f


@_jit_internal
def householder_qr(A, pivot, want_q=True):
    """``A[:, perm] = Q R`` (A (m, n)): Q (m, m) orthogonal (explicit; the identity unless
    ``want_q``), R (m, n) upper triangular, perm the column order (the largest remaining
    column norm first when ``pivot``, else the identity)."""
    m, n = A.shape
    R = A.copy()
    Q = np.eye(m)
    perm = np.arange(n)
    v = np.empty(m)
    for k in range(min(m, n)):
        if pivot:
            p, best = k, -1.0
            for j in range(k, n):
                s = 0.0
                for i in range(k, m):
                    s += R[i, j] * R[i, j]
                if s > best:
                    best, p = s, j
            if p != k:
                for i in range(m):
                    R[i, k], R[i, p] = R[i, p], R[i, k]
                perm[k], perm[p] = perm[p], perm[k]
        f = _reflect(R, k, v)
        if f == 0.0 or not want_q:
            continue
        for i in range(m):
            s = 0.0
            for a in range(k, m):
                s += Q[i, a] * v[a]
            s *= f
            for a in range(k, m):
                Q[i, a] -= s * v[a]
    return Q, R, perm


@_jit_internal
def _rank(R, rcond):
    """The number of leading ``|R_kk| > rcond |R_00|`` (pivoted R)."""
    k = min(R.shape[0], R.shape[1])
    if k == 0:
        return 0
    top = abs(R[0, 0])
    r = 0
    while r < k and abs(R[r, r]) > rcond * top and top > 0.0:
        r += 1
    return r


@_jit_internal
def cod_min_norm_solve(A, y, rcond):
    """The minimum-norm least-squares solution of ``A x = y``, directions of
    ``|R_kk| <= rcond |R_00|`` dropped (see the module docstring)."""
    n = A.shape[1]
    Q, R, perm = householder_qr(A, bool(True), bool(True))
    r = _rank(R, rcond)
    c = _matvec(Q[:, :r].T, y)  # (Q^T y)_1
    xp = np.zeros(n)
    if r == n:  # R11 x = c by back substitution (R11 = (R11^T)^T)
        xp = c
        back_substitute(R[:n].T, xp)
    elif r > 0:
        # [R11 R12] = [S^T 0] Z^T: Z (n, n), S (n, r)
        Z, S, _ = householder_qr(np.ascontiguousarray(R[:r].T), bool(False), bool(True))
        w = np.zeros(r)  # S11^T w = c (lower triangular)
        for k in range(r):
            acc = c[k]
            for j in range(k):
                acc -= S[j, k] * w[j]
            w[k] = acc / S[k, k]
        xp = _matvec(Z[:, :r], w)
    x = np.empty(n)
    for j in range(n):
        x[perm[j]] = xp[j]
    return x


@_jit_internal
def _trailing_basis(R, r):
    """``Z[:, r:]`` of ``[R11 R12]^T = Z S`` (the first r rows of R, n columns): the
    Householder reflections of that QR applied to ``[0; I]`` in reverse order, without
    forming Z."""
    n = R.shape[1]
    T = np.ascontiguousarray(R[:r].T)
    V = np.zeros((r, n))
    beta = np.zeros(r)
    for k in range(r):
        beta[k] = _reflect(T, k, V[k])
    E = np.zeros((n, n - r))
    for a in range(n - r):
        E[r + a, a] = 1.0
    for k in range(r - 1, -1, -1):
        if beta[k] == 0.0:
            continue
        for a in range(n - r):
            s = 0.0
            for i in range(k, n):
                s += V[k, i] * E[i, a]
            s *= beta[k]
            for i in range(k, n):
                E[i, a] -= s * V[k, i]
    return E


@_jit_internal
def cod_null_space(A, rcond):
    """An orthonormal basis (n, n - r) of the null space of ``A`` (m, n), the rank r cut at
    ``|R_kk| <= rcond |R_00|`` (see the module docstring)."""
    n = A.shape[1]
    _, R, perm = householder_qr(A, bool(True), bool(False))
    r = _rank(R, rcond)
    N = np.zeros((n, n - r))
    if r == n:
        return N
    if r == 0:
        for j in range(n):
            N[j, j] = 1.0
        return N
    B = _trailing_basis(R, r)
    for j in range(n):
        for a in range(n - r):
            N[perm[j], a] = B[j, a]
    return N


__all__ = ["householder_qr", "cod_min_norm_solve", "cod_null_space"]
