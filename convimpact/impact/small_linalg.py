"""Small dense linear algebra: on plain Python floats for the single-contact kernels, and the
direct LAPACK calls of the public path.

One contact's Delassus block is 2 x 2 (planar) or 3 x 3 (spatial); numpy's per-call overhead
would dominate such solves, so they are written out: the adjugate inverse with one step of
iterative refinement when ill-conditioned, and a scale-free singularity test
(det W / tr(W)^d <= :data:`SINGULAR_RTOL`) that raises a typed error naming the conic paths.
:func:`cholesky_lower` and :func:`tri_solve` call LAPACK without the per-call wrapping of
numpy.linalg and scipy.linalg (a few microseconds each, which a small impact cannot afford).
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np
import scipy.linalg as sla

from .errors import MassMatrixError, ShapeError, SingularSystemError, as_real_array

#: relative determinant below which W is treated as singular: det W <= tol * trace(W)^d
#: (in the plane det/trace^2 ~ 1/cond(W), matching the closed form's cond(W) >= 1e12)
SINGULAR_RTOL = 1e-12


_dpotrf = sla.lapack.dpotrf  # LAPACK Cholesky: the positive-definiteness test
_dtrtrs = sla.lapack.dtrtrs  # LAPACK triangular solve, without scipy's per-call checks
try:  # numpy.linalg.cholesky's own kernel, without its per-call error-state wrapping
    from numpy.linalg import _umath_linalg

    _numpy_cholesky = _umath_linalg.cholesky_lo
except (ImportError, AttributeError):  # pragma: no cover - other numpy layouts
    _numpy_cholesky = None


def cholesky_lower(M: np.ndarray) -> tuple[np.ndarray, int]:
    """Lower Cholesky factor of M and LAPACK's info (0: positive definite).

    scipy's dpotrf decides; the factor is then numpy's (the one np.linalg.cholesky returns,
    so that results stay bit for bit those of numpy's factorization), dpotrf's where numpy's
    is unavailable or disagrees at the edge of positive definiteness.
    """
    L, info = _dpotrf(M, 1, 1)  # lower, clean (positional: the public call's hot path)
    if info == 0 and _numpy_cholesky is not None:
        Ln = _numpy_cholesky(M)  # M is float64 (validated): numpy's d->d loop
        k = M.shape[0] - 1
        if Ln[k, k] == Ln[k, k]:  # not NaN
            return Ln, 0
    return L, info


def tri_solve(L: np.ndarray, B: np.ndarray, trans: int = 0) -> np.ndarray:
    """Solve L X = B (trans=0) or L^T X = B (trans=1) for lower-triangular L."""
    X, info = _dtrtrs(L, B, 1, trans)  # lower (positional: the public call's hot path)
    if info != 0:  # pragma: no cover - L comes from a successful Cholesky factorization
        raise MassMatrixError(f"triangular solve failed (LAPACK info {info})")
    return X


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
