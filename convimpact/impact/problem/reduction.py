"""The reduction of one impact to contact space (eqs. 29, 43-45), on validated arrays.

From the Cholesky factor L of M (``M = L L^T``) and the stacked contact rows, :func:`_reduce`
forms ``X = L^-1 Jc^T``, the Delassus matrix ``W = X^T X`` -- with closed loops the Schur
complement ``W - B^T A^-1 B`` with ``B = (L^-1 C^T)^T X`` and ``A = C M^-1 C^T``, which
eliminates the loop impulses Delta sigma from the bordered matrices of eqs. (51)/(52) --
symmetrized bit for bit, and ``v- = Jc dq`` (eq. 17). :func:`_loops` validates the loop
Jacobian C (shape, rank, ``C dq = 0``) on the way. :func:`_plain_contacts` recognizes the plain case of several
contacts in one compiled call. :mod:`convimpact.impact.problem.build` validates the raw input and
calls these.
"""

from __future__ import annotations

import sys

import numpy as np

from ...errors import LoopConstraintError, NonFiniteError, ShapeError, as_real_array
from .dense import cholesky_lower, empty_matrix, tri_solve

#: relative singular-value threshold below which C is declared rank deficient (C M^-1 C^T
#: squares the ratio, so 1e-7 keeps its condition number below about 1e14)
LOOP_RANK_RTOL = 1e-7
#: relative tolerance on C theta_dot = 0 for the pre-impact velocity
LOOP_VELOCITY_RTOL = 1e-6
#: a contact whose tangential Delassus entries are below this fraction of the largest
#: diagonal entry cannot take a friction impulse (it is treated as frictionless)
IMMOBILE_RTOL = 1e-14
#: smallest positive normal double (a c_n^T M^-1 c_n below it has underflowed)
TINY_NORMAL = sys.float_info.min
#: largest matrix whose exact symmetry is tested entry by entry on Python floats (beyond it
#: one vectorized comparison is cheaper)
_LOOP_MAX = 10


def _finite(name: str, a: np.ndarray) -> np.ndarray:
    if not np.isfinite(a).all():
        raise NonFiniteError(f"{name} contains NaN or infinity; pass finite values")
    return a


def _loops(C, L: np.ndarray, X: np.ndarray, W: np.ndarray, dq: np.ndarray, k: int) -> tuple:
    """Validate C and fold the loops into W: (C, W, C M^-1 C^T, M^-1 C^T, the lower Cholesky
    factor of C M^-1 C^T)."""
    C = as_real_array("C", C).copy()  # owned (see build_problem)
    if C.ndim == 1 and C.size == k:
        C = C[None]
    if C.ndim != 2 or C.shape[1] != k:
        raise ShapeError(f"C must be an m x {k} loop-constraint Jacobian, got shape {C.shape}")
    _finite("C", C)
    m = C.shape[0]
    if not m:
        return empty_matrix((0, k)), W, empty_matrix((0, 0)), empty_matrix((k, 0)), None
    if m >= k:
        raise LoopConstraintError(
            f"C has {m} rows for {k} joint coordinates: a loop Jacobian needs fewer "
            "constraints than coordinates (drop redundant rows)"
        )
    s = np.linalg.svd(C, compute_uv=False)
    if s[-1] <= LOOP_RANK_RTOL * s[0]:
        raise LoopConstraintError(
            f"C is rank deficient (singular values {s[0]:.3e} ... {s[-1]:.3e}): the loop "
            "closure is singular here (e.g. a dead-centre configuration) or has redundant "
            "rows; remove redundant constraints or move off the singular configuration"
        )
    ds = float(np.max(np.abs(dq)))
    u = dq / ds if ds > 0.0 else dq  # C dq relative to |C| |dq|, free of under/overflow
    resid = float(np.linalg.norm(C @ u))
    if resid > LOOP_VELOCITY_RTOL * s[0] * float(np.linalg.norm(u)):
        raise LoopConstraintError(
            f"dq violates the loop constraints: |C dq| = {resid * ds:.3e} (eq. 7 requires 0); "
            "project dq onto the null space of C before the impact"
        )
    Y = tri_solve(L, C.T)  # L^-1 C^T
    A = Y.T @ Y
    loop_cho, info = cholesky_lower(A)  # A = L_A L_A^T
    if info != 0:
        raise LoopConstraintError(
            "C M^-1 C^T is numerically singular: the loop constraints are (nearly) "
            "dependent in this configuration; remove redundant rows of C or move off the "
            "singular configuration")
    Z = tri_solve(loop_cho, Y.T @ X)  # L_A^-1 B: B^T A^-1 B = Z^T Z
    W = W - Z.T @ Z
    return C, W, A, tri_solve(L, Y, trans=1), loop_cho


def _symmetrize(W: np.ndarray) -> list:
    """W <- (W + W^T) / 2 in place (bit for bit), and W as nested lists."""
    w = W.tolist()
    r = len(w)
    if r > _LOOP_MAX and (W == W.T).all():  # exactly symmetric already (X^T X usually is)
        return w
    for i in range(1, r):
        for j in range(i):
            a, b = w[i][j], w[j][i]
            if a != b:
                w[i][j] = w[j][i] = W[i, j] = W[j, i] = (a + b) * 0.5
    return w


def _contact_space(L: np.ndarray, rows: np.ndarray, dq: np.ndarray, C) -> tuple:
    """Contact space of ``rows`` (r, k): (L^-1 rows^T, W (not yet symmetrized), rows dq, C,
    C M^-1 C^T, M^-1 C^T, the lower Cholesky factor of C M^-1 C^T)."""
    X = tri_solve(L, rows.T)  # L^-1 Jc^T
    W = X.T @ X
    v = rows @ dq
    k = L.shape[0]
    if C is None:
        return X, W, v, empty_matrix((0, k)), empty_matrix((0, 0)), empty_matrix((k, 0)), None
    C, W, A, minv_ct, loop_cho = _loops(C, L, X, W, dq, k)
    return X, W, v, C, A, minv_ct, loop_cho


def _reduce(L: np.ndarray, rows: np.ndarray, dq: np.ndarray, C) -> tuple:
    """Contact space of ``rows`` (r, k): (L^-1 rows^T, W (symmetrized) and its lists, rows dq,
    C, C M^-1 C^T, M^-1 C^T, the lower Cholesky factor of C M^-1 C^T)."""
    X, W, v, C, A, minv_ct, loop_cho = _contact_space(L, rows, dq, C)
    return X, W, _symmetrize(W), v, C, A, minv_ct, loop_cho


#: the compiled checks of several contacts (None: not loaded yet; False: unavailable)
_CONTACT_CHECKS = None


def _plain_contacts(W: np.ndarray, v: np.ndarray, d: int) -> bool:
    """Whether several contacts are the plain case, by the compiled
    :func:`~convimpact.contacts.interior_point.contact_checks` (which also symmetrizes W in
    place); False hands the decision to the Python checks (also when numba is missing)."""
    global _CONTACT_CHECKS
    checks = _CONTACT_CHECKS
    if checks is None:
        try:
            from ...contacts.interior_point import contact_checks as checks
        except ImportError:  # pragma: no cover - numba missing
            checks = False
        _CONTACT_CHECKS = checks
    if not checks or not (W.flags.c_contiguous and v.flags.c_contiguous):
        return False
    return checks(W, v, d, IMMOBILE_RTOL, TINY_NORMAL) == 0
