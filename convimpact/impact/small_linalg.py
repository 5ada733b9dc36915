"""Small dense linear algebra: on plain Python floats for the single-contact kernels, and the
factorization and triangular solves of the public path.

One contact's Delassus block is 2 x 2 (planar) or 3 x 3 (spatial); numpy's per-call overhead
would dominate such solves, so they are written out: the adjugate inverse with one step of
iterative refinement when ill-conditioned, and a scale-free singularity test
(det W / tr(W)^d <= :data:`SINGULAR_RTOL`) that raises a typed error naming the conic paths.

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

from .errors import MassMatrixError, ShapeError, SingularSystemError, as_real_array

#: relative determinant below which W is treated as singular: det W <= tol * trace(W)^d
#: (in the plane det/trace^2 ~ 1/cond(W), matching the closed form's cond(W) >= 1e12)
SINGULAR_RTOL = 1e-12


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


def unit_or(x1: float, x2: float, fallback: tuple[float, float]) -> tuple[float, float]:
    n = math.hypot(x1, x2)
    if n > 0.0:
        return x1 / n, x2 / n
    return fallback


def angle_from_slip(v1: float, v2: float, t1: float, t2: float) -> float:
    """Angle in [0, 2 pi) of t measured counter-clockwise from v_t- (from t1 if v_t- = 0)."""
    if v1 == 0.0 and v2 == 0.0:
        a = math.atan2(t2, t1)
    else:
        a = math.atan2(v1 * t2 - v2 * t1, v1 * t1 + v2 * t2)
    return a % math.tau


def singular_error(law: str, det: float) -> SingularSystemError:
    return SingularSystemError(
        f"the Delassus matrix W = Jc M^-1 Jc^T of this contact is singular (det W = {det:.3e}): "
        "its normal and tangential motions are dependent here, so the exact fast solve of law "
        f"{law!r} (which inverts W on its interior branch) has no unique answer; use "
        "method='clarabel' or method='cvxpy' (law='dissipative' or 'ccp' accept a singular W)")


def inverse3(w: list, law: str) -> tuple:
    """Symmetric inverse of the 3 x 3 W as (i00, i01, i02, i11, i12, i22, det W / tr(W)^3)."""
    tr = w[0][0] + w[1][1] + w[2][2]
    g = 1.0 / tr  # work on W / tr(W): no under- or overflow of det for any scale of W
    A, B1, B2 = w[0][0] * g, w[0][1] * g, w[0][2] * g
    C11, C12, C22 = w[1][1] * g, w[1][2] * g, w[2][2] * g
    k00 = C11 * C22 - C12 * C12
    k01 = B2 * C12 - B1 * C22
    k02 = B1 * C12 - B2 * C11
    det = A * k00 + B1 * k01 + B2 * k02  # det W / tr(W)^3
    if not det > SINGULAR_RTOL:
        raise singular_error(law, det * tr * tr * tr)
    f = g / det  # inv(W) = inv(W / tr) / tr
    return (k00 * f, k01 * f, k02 * f, (A * C22 - B2 * B2) * f, (B1 * B2 - A * C12) * f,
            (A * C11 - B1 * B1) * f, det)


def solve3(inv: tuple, r0: float, r1: float, r2: float) -> tuple[float, float, float]:
    i00, i01, i02, i11, i12, i22 = inv[:6]
    return (i00 * r0 + i01 * r1 + i02 * r2, i01 * r0 + i11 * r1 + i12 * r2,
            i02 * r0 + i12 * r1 + i22 * r2)


def linsolve3(w: list, inv: tuple, r0: float, r1: float, r2: float) -> tuple[float, float, float]:
    """W x = r by the adjugate inverse, plus one step of iterative refinement when W is
    ill-conditioned (det W / tr(W)^3 < 1e-3)."""
    x0, x1, x2 = solve3(inv, r0, r1, r2)
    if inv[6] >= 1e-3:
        return x0, x1, x2
    (A, B1, B2), (_, C11, C12), (_, _, C22) = w
    d0, d1, d2 = solve3(inv, r0 - (A * x0 + B1 * x1 + B2 * x2),
                        r1 - (B1 * x0 + C11 * x1 + C12 * x2),
                        r2 - (B2 * x0 + C12 * x1 + C22 * x2))
    return x0 + d0, x1 + d1, x2 + d2


def solve2(w: list, r0: float, r1: float, law: str) -> tuple[float, float]:
    """Solve the 2 x 2 W x = r (adjugate; one refinement step when ill-conditioned)."""
    A, B, C = w[0][0], w[0][1], w[1][1]
    tr = A + C
    a, b, c = A / tr, B / tr, C / tr  # W / tr(W): scale-free determinant test
    det = a * c - b * b  # det W / tr(W)^2
    if not det > SINGULAR_RTOL:
        raise singular_error(law, det * tr * tr)
    f = 1.0 / (det * tr)  # 1 / det W, as (1 / det(W / tr)) / tr^2 times tr
    x0, x1 = (c * r0 - b * r1) * f, (a * r1 - b * r0) * f
    if det < 1e-3:
        d0, d1 = r0 - (A * x0 + B * x1), r1 - (B * x0 + C * x1)
        x0, x1 = x0 + (c * d0 - b * d1) * f, x1 + (a * d1 - b * d0) * f
    return x0, x1
