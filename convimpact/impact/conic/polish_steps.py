"""The linear algebra of the polish's Newton (:mod:`.polish_newton`), compiled, on the small
dense matrices of one active set: products by loops (numba's BLAS wrappers cost seconds of
compilation per shape kind), the minimum-norm least-squares step from the singular value
decomposition (:func:`_min_norm_solve`: redundant contacts make the Jacobian singular) and the
square step by Gaussian elimination with complete pivoting, which falls back to it on a small
pivot (:func:`_pivoted_step`). :mod:`.polish_cod` gives the same minimum-norm step without the
SVD where a caller asks for it.
"""

from __future__ import annotations

import numpy as np

from ...compiled import jit_internal as _jit_internal
from ..problem.compiled_reduction import back_substitute

#: the pivoted steps' rank cut on a singular J (sqrt(1e-15): eigenvalues of J^T J below 1e-15)
SINGULAR_RCOND = 3.1622776601683795e-08


@_jit_internal
def _absmax(a):
    out = 0.0
    for v in a.ravel():
        if abs(v) > out or v != v:
            out = abs(v)
    return out


@_jit_internal
def _matvec(A, x):
    """A x by loops (numba's BLAS wrappers cost seconds of compilation per shape kind)."""
    out = np.zeros(A.shape[0])
    for r in range(A.shape[0]):
        acc = 0.0
        for c in range(A.shape[1]):
            acc += A[r, c] * x[c]
        out[r] = acc
    return out


@_jit_internal
def _matmat(A, B):
    """A B by loops."""
    out = np.zeros((A.shape[0], B.shape[1]))
    for r in range(A.shape[0]):
        for k in range(A.shape[1]):
            a = A[r, k]
            if a != 0.0:
                for c in range(B.shape[1]):
                    out[r, c] += a * B[k, c]
    return out


@_jit_internal
def _min_norm_solve(A, y, rcond):
    """The minimum-norm least-squares solution of ``A s = y``, singular values of A at most
    ``rcond`` times the largest taken as zero (numpy's ``lstsq`` with that ``rcond``, from
    the singular value decomposition; the Jacobian is singular on redundant contacts)."""
    U, sv, Vt = np.linalg.svd(A, full_matrices=False)
    k = sv.size
    top = sv[0] if k else 0.0
    g = np.zeros(k)
    for a in range(k):
        if sv[a] > rcond * top:
            acc = 0.0
            for r in range(U.shape[0]):
                acc += U[r, a] * y[r]
            g[a] = acc / sv[a]
    out = np.zeros(Vt.shape[1])
    for a in range(k):
        if g[a] != 0.0:
            for c in range(Vt.shape[1]):
                out[c] += Vt[a, c] * g[a]
    return out


@_jit_internal
def _pivoted_step(J, F):
    """The minimum-norm solution of ``J s = -F`` for the square J of an active set (one
    equation per unknown): Gaussian elimination with complete pivoting where every pivot
    exceeds 1e-10 of the largest (J safely nonsingular: the solution is the minimum-norm one
    to round-off); at a smaller pivot (redundant contacts) the minimum-norm step with singular
    values below 3.2e-8 of the largest taken as zero (the redundant directions, which
    round-off leaves at 1e-16)."""
    n = F.size
    A = J.copy()
    r = -F
    perm = np.arange(n)
    first = 0.0
    for k in range(n):
        p, c, big = k, k, 0.0
        for i in range(k, n):
            for j in range(k, n):
                if abs(A[i, j]) > big:
                    big, p, c = abs(A[i, j]), i, j
        if k == 0:
            first = big
        if not big > 1e-10 * first or big == 0.0:
            return _min_norm_solve(J, -F, SINGULAR_RCOND)
        if p != k:
            for j in range(n):
                A[k, j], A[p, j] = A[p, j], A[k, j]
            r[k], r[p] = r[p], r[k]
        if c != k:
            for i in range(n):
                A[i, k], A[i, c] = A[i, c], A[i, k]
            perm[k], perm[c] = perm[c], perm[k]
        for i in range(k + 1, n):
            fct = A[i, k] / A[k, k]
            if fct != 0.0:
                for j in range(k + 1, n):
                    A[i, j] -= fct * A[k, j]
                r[i] -= fct * r[k]
    back_substitute(A.T, r)  # A x = r, A upper = (A^T)^T
    x = np.empty(n)
    for k in range(n):
        x[perm[k]] = r[k]
    return x
