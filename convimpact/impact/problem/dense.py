"""Small dense linear algebra of the public path: the factorization and triangular solves of
the reduction, one contact's data as plain floats, and the singular-W error the exact kernels
raise (their own 2 x 2 and 3 x 3 solves are compiled, in
:mod:`convimpact.impact.laws.algebra`).

:func:`cholesky_lower` and :func:`tri_solve` (the full path's ``M = L L^T``, ``L^-1 B`` and
``L^-T B``, and the loop matrix's factor and solves) call no LAPACK routine that hands a tiny
matrix to BLAS threads. OpenBLAS's LAPACK ``dtrtrs``, used here before, splits the right-hand
sides of any solve with two or more of them over its threads, whatever the size: with other
processes on the machine one 3 x 3 solve then waited for a descheduled thread (measured: 0.05
to 21 ms a call instead of about 1 us). Now:

* up to :data:`SMALL_MAX` rows (planar mechanisms, loop matrices ``C M^-1 C^T``) they run on
  Python floats -- no LAPACK or BLAS call at all -- for 3 to 8 us more per full-path call;
* above, LAPACK's ``dpotrf`` (numpy's factor, as np.linalg.cholesky) and BLAS's ``dtrsm``,
  which OpenBLAS keeps on one thread below its own size thresholds (measured: no CPU time in
  its worker threads for k = 3 .. 60 with 1 .. 9 right-hand sides). On Python floats a 6 x 6
  factor and its two solves would add about 19 us to the 30 us of build_problem and
  assemble_result.
"""

from __future__ import annotations

import math
from functools import lru_cache
from operator import mul as _mul

import numpy as np
import scipy.linalg as sla

from ...errors import MassMatrixError, ShapeError, SingularSystemError, as_real_array

#: largest matrix factored and solved on Python floats by :func:`cholesky_lower` and
#: :func:`tri_solve` (no LAPACK/BLAS call); above it LAPACK's dpotrf and BLAS's dtrsm (see the
#: module's docstring for the measurements behind it)
SMALL_MAX = 4

_dpotrf = sla.lapack.dpotrf  # LAPACK Cholesky: the positive-definiteness test (k > SMALL_MAX)
_dtrsm = sla.blas.dtrsm  # BLAS triangular solve (k > SMALL_MAX; not LAPACK's threaded dtrtrs)
try:  # numpy.linalg.cholesky's own kernel, without its per-call error-state wrapping
    from numpy.linalg import _umath_linalg

    _numpy_cholesky = _umath_linalg.cholesky_lo
except (ImportError, AttributeError):  # pragma: no cover - other numpy layouts
    _numpy_cholesky = None


def _cholesky_rows(m: list) -> tuple[list, int]:
    """Lower Cholesky factor of the k x k nested list ``m``, row by row on Python floats: the
    rows of L (row i holds its i + 1 leading entries) and LAPACK's info -- 0, or j + 1 for the
    first pivot ``m[j][j] - sum_p L[j][p]^2`` that is not positive (or NaN), as dpotrf decides;
    the rows computed before it are returned then."""
    L: list = []
    for j, mj in enumerate(m):
        row: list = []
        for Lp in L:  # L[j][p] = (m[j][p] - sum_q<p L[j][q] L[p][q]) / L[p][p]
            row.append((mj[len(row)] - sum(map(_mul, row, Lp))) / Lp[-1])
        s = mj[j] - sum(map(_mul, row, row))
        if not s > 0.0:
            return L, j + 1
        row.append(math.sqrt(s))
        L.append(row)
    return L, 0


def cholesky_lower(M: np.ndarray) -> tuple[np.ndarray, int]:
    """Lower Cholesky factor of M (float64, symmetric) and LAPACK's info (0: positive definite).

    Up to :data:`SMALL_MAX` rows on Python floats (:func:`_cholesky_rows`: the decision is
    dpotrf's -- the first pivot that is not positive -- on this factor's round-off); above, scipy's
    dpotrf decides and the factor is numpy's (the one np.linalg.cholesky returns), dpotrf's where
    numpy's is unavailable or disagrees at the edge of positive definiteness. Where info != 0
    the factor is partial (its rows before the failing pivot).
    """
    k = M.shape[0]
    if k <= SMALL_MAX:
        rows, info = _cholesky_rows(M.tolist())
        pad = [0.0] * k
        flat: list = []
        for r in rows:  # row-major, zeros above the diagonal (and in rows not reached)
            flat += r
            flat += pad[len(r):]
        flat += pad * (k - len(rows))
        return np.array(flat).reshape(k, k), info
    L, info = _dpotrf(M, 1, 1)  # lower, clean (positional: the public call's hot path)
    if info == 0 and _numpy_cholesky is not None:
        Ln = _numpy_cholesky(M)  # M is float64 (validated): numpy's d->d loop
        if Ln[k - 1, k - 1] == Ln[k - 1, k - 1]:  # not NaN
            return Ln, 0
    return L, info


def _forward(rows: list, cols: list) -> list:
    """L^-1 b for each column b of ``cols``, L given by its rows (forward substitution)."""
    out = []
    for b in cols:
        x: list = []
        for Li, bi in zip(rows, b):  # x_i = (b_i - sum_p<i L_ip x_p) / L_ii
            x.append((bi - sum(map(_mul, Li, x))) / Li[len(x)])
        out.append(x)
    return out


def _backward(rev: list, cols: list) -> list:
    """L^-T b for each column b of ``cols``, L given by its columns reversed (``rev[i][q] =
    L[k-1-q][i]``; back substitution)."""
    k = len(rev)
    out = []
    for b in cols:
        y: list = []  # x_{k-1}, x_{k-2}, ... as they are found
        for i in range(k - 1, -1, -1):  # x_i = (b_i - sum_p>i L_pi x_p) / L_ii
            Ri = rev[i]
            y.append((b[i] - sum(map(_mul, Ri, y))) / Ri[len(y)])
        y.reverse()
        out.append(y)
    return out


def tri_solve(L: np.ndarray, B: np.ndarray, trans: int = 0) -> np.ndarray:
    """Solve L X = B (trans=0) or L^T X = B (trans=1) for lower-triangular L (k x k) and B of
    shape (k, r) or (k,); X has B's shape.

    Up to :data:`SMALL_MAX` rows on Python floats (forward or back substitution, column by
    column), above by BLAS's dtrsm.

    Raises
    ------
    MassMatrixError
        where a diagonal entry of L is zero (LAPACK dtrtrs's singularity test; a factor from a
        successful Cholesky factorization has none).
    """
    k = L.shape[0]
    vector = B.ndim == 1
    if k <= SMALL_MAX:
        cols = [B.tolist()] if vector else B.T.tolist()
        try:
            X = _backward(L[::-1].T.tolist(), cols) if trans else _forward(L.tolist(), cols)
        except ZeroDivisionError:
            raise _singular_factor() from None
        if vector:
            return np.array(X[0])
        return np.array(X).T if X else np.zeros((k, 0))
    if not L.diagonal().all():
        raise _singular_factor()
    X = _dtrsm(1.0, L, B[:, None] if vector else B, 0, 1, trans)  # left, lower (positional)
    return X[:, 0] if vector else X


def _singular_factor() -> MassMatrixError:
    return MassMatrixError("triangular solve failed: the Cholesky factor has a zero pivot")


@lru_cache(maxsize=64)
def empty_matrix(shape: tuple[int, int]) -> np.ndarray:
    """A shared read-only empty matrix (no loops: C, C M^-1 C^T and M^-1 C^T)."""
    a = np.zeros(shape)
    a.flags.writeable = False
    return a


def as_lists(W, v) -> tuple[list, list, int]:
    """One contact's W (d x d) and v (d,) as Python lists, d = 2 or 3.

    Raises
    ------
    ShapeError
        for other shapes, or entries that are not real numbers (strings, booleans, complex).
    """
    W = as_real_array("W", W)
    v = as_real_array("v", v)
    d = v.shape[0] if v.ndim == 1 else 0
    if d in (2, 3) and W.shape == (d, d):
        return W.tolist(), v.tolist(), d
    raise ShapeError(
        f"a single contact needs W of shape (d, d) and v of length d with d = 2 (n, t) or "
        f"3 (n, t1, t2); got W {np.shape(W)} and v {np.shape(v)}")


def angle_from_slip(v1: float, v2: float, t1: float, t2: float) -> float:
    """Angle in [0, 2 pi) of t measured counter-clockwise from v_t- (from t1 if v_t- = 0)."""
    if v1 == 0.0 and v2 == 0.0:
        a = math.atan2(t2, t1)
    else:
        a = math.atan2(v1 * t2 - v2 * t1, v1 * t1 + v2 * t2)
    return a % math.tau


def singular_error(law: str, det: float) -> SingularSystemError:
    """The exact kernels' SINGULAR status (det W / tr(W)^d below the compiled algebra's
    ``SINGULAR_RTOL``) as the typed error naming the paths that accept a singular W."""
    return SingularSystemError(
        f"the Delassus matrix W = Jc M^-1 Jc^T of this contact is singular (det W = {det:.3e}): "
        "its normal and tangential motions are dependent here, so the exact fast solve of law "
        f"{law!r} (which inverts W on its interior branch) has no unique answer; use "
        "method='clarabel' or method='cvxpy' (law='dissipative' or 'ccp' accept a singular W)")
