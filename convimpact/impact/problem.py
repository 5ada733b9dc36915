"""One impact, validated and reduced to contact space.

:func:`build_problem` checks the raw matrices of :func:`convimpact.resolve_impact` and forms,
once, everything every impact law needs:

* the Delassus matrix ``W = Jc G Jc^T`` with ``G = M^-1`` for open loops and the
  loop-constrained inverse ``G = M^-1 - M^-1 C^T (C M^-1 C^T)^-1 C M^-1`` for closed loops.
  ``W`` is the Schur complement of the paper's bordered matrices of eqs. (51)/(52): eliminating
  ``Delta sigma`` from them leaves ``W pi = rhs``;
* the pre-impact contact-frame velocities ``v_minus = Jc theta_dot`` (eq. 17);
* the map back from contact impulses to the velocity jump and loop impulses (eqs. 29, 44, 45).

Every impact law then works on ``(W, v_minus, e, mu)`` only, and
:meth:`ImpactProblem.velocity_jump` turns its impulse into ``theta_dot_plus``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence, Union

import numpy as np
import scipy.linalg as sla

from .errors import (
    LoopConstraintError,
    MassMatrixError,
    NonFiniteError,
    ParameterError,
    ShapeError,
)

ArrayLike = Union[np.ndarray, Sequence[float], float]

#: relative tolerance on the asymmetry of M
SYMMETRY_RTOL = 1e-10
#: relative singular-value threshold below which C is declared rank deficient (C M^-1 C^T
#: squares the ratio, so 1e-7 keeps its condition number below about 1e14)
LOOP_RANK_RTOL = 1e-7
#: relative tolerance on C theta_dot = 0 for the pre-impact velocity
LOOP_VELOCITY_RTOL = 1e-6


_dtrtrs = sla.lapack.dtrtrs  # LAPACK triangular solve, without scipy's per-call checks


def _tri_solve(L: np.ndarray, B: np.ndarray, trans: int = 0) -> np.ndarray:
    """Solve L X = B (trans=0) or L^T X = B (trans=1) for lower-triangular L."""
    X, info = _dtrtrs(L, B, lower=1, trans=trans)
    if info != 0:  # pragma: no cover - L comes from a successful Cholesky factorization
        raise MassMatrixError(f"triangular solve failed (LAPACK info {info})")
    return X


def _finite(name: str, a: np.ndarray) -> np.ndarray:
    if not np.all(np.isfinite(a)):
        raise NonFiniteError(f"{name} contains NaN or infinity; pass finite values")
    return a


def _as_float_array(name: str, value) -> np.ndarray:
    try:
        a = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ShapeError(f"{name} must be a numeric array, got {type(value).__name__}") from exc
    return a


def check_mass_matrix(M) -> tuple[np.ndarray, np.ndarray]:
    """Validate a generalized mass matrix; return it symmetrized with its lower Cholesky factor.

    Raises
    ------
    ShapeError, NonFiniteError, MassMatrixError
    """
    M = _as_float_array("M", M)
    if M.ndim != 2 or M.shape[0] != M.shape[1] or M.shape[0] == 0:
        raise ShapeError(f"M must be a square k x k matrix with k >= 1, got shape {M.shape}")
    _finite("M", M)
    scale = float(np.max(np.abs(M)))
    asym = float(np.max(np.abs(M - M.T)))
    if asym > SYMMETRY_RTOL * max(scale, 1e-300):
        raise MassMatrixError(
            f"M is not symmetric (max |M - M^T| = {asym:.3e} for max |M| = {scale:.3e}); "
            "a generalized mass matrix B^T M B (eq. 3) is symmetric: check its assembly"
        )
    M = 0.5 * (M + M.T)
    try:
        L = np.linalg.cholesky(M)
    except np.linalg.LinAlgError:
        lam = float(np.linalg.eigvalsh(M)[0])
        raise MassMatrixError(
            f"M is not positive definite (smallest eigenvalue {lam:.3e}); every body needs "
            "positive mass and the joint coordinates must be independent"
        ) from None
    return M, L


def _per_contact(name: str, value, n_contacts: int) -> np.ndarray:
    a = _as_float_array(name, value)
    if a.ndim == 0:
        a = np.full(n_contacts, float(a))
    if a.shape != (n_contacts,):
        raise ShapeError(
            f"{name} must be a scalar or one value per contact ({n_contacts}), got shape {a.shape}"
        )
    return _finite(name, a)


def check_restitution(e, n_contacts: int = 1) -> np.ndarray:
    """Validate the coefficient(s) of restitution: finite and in [0, 1]."""
    e = _per_contact("e", e, n_contacts)
    if np.any(e < 0.0) or np.any(e > 1.0):
        raise ParameterError(f"coefficient of restitution e must lie in [0, 1], got {e.tolist()}")
    return e


def check_friction(mu, n_contacts: int = 1) -> np.ndarray:
    """Validate the coefficient(s) of friction: finite and non-negative."""
    mu = _per_contact("mu", mu, n_contacts)
    if np.any(mu < 0.0):
        raise ParameterError(
            f"coefficient of friction mu must be >= 0, got {mu.tolist()} (the paper's negative "
            "mu of Figs. 5-7 is a sign convention of its landscapes: use "
            "convimpact.studies.landscape for those)"
        )
    return mu


@dataclass(frozen=True, eq=False)
class ImpactProblem:
    """A validated impact: matrices in joint coordinates and their contact-space reduction.

    Attributes
    ----------
    mass_matrix : (k, k) generalized mass matrix M (eq. 3), symmetrized.
    cholesky : (k, k) lower Cholesky factor of M.
    jacobians : (n_contacts, d, k) contact Jacobians, rows n, t (d = 2) or n, t1, t2 (d = 3).
    dq_minus : (k,) joint velocities before impact.
    restitution, friction : (n_contacts,) e and mu per contact.
    loop_jacobian : (m, k) C of eq. (7); m = 0 for open loops.
    single : True when the caller passed one Jacobian (results are then un-stacked).
    delassus : (n_contacts d, n_contacts d) W = Jc G Jc^T.
    v_minus : (n_contacts, d) contact-frame relative velocities before impact.
    loop_matrix : (m, m) C M^-1 C^T.
    """

    mass_matrix: np.ndarray
    cholesky: np.ndarray
    jacobians: np.ndarray
    dq_minus: np.ndarray
    restitution: np.ndarray
    friction: np.ndarray
    loop_jacobian: np.ndarray
    single: bool
    delassus: np.ndarray
    v_minus: np.ndarray
    loop_matrix: np.ndarray
    _minv_jt: np.ndarray  # M^-1 Jc^T, (k, n_contacts d)
    _minv_ct: np.ndarray  # M^-1 C^T, (k, m)
    _loop_cho: tuple | None  # Cholesky factor of C M^-1 C^T

    @property
    def n_coordinates(self) -> int:
        return self.mass_matrix.shape[0]

    @property
    def n_contacts(self) -> int:
        return self.jacobians.shape[0]

    @property
    def dim(self) -> int:
        """2 for planar contacts (n, t), 3 for spatial ones (n, t1, t2)."""
        return self.jacobians.shape[1]

    @property
    def n_loops(self) -> int:
        return self.loop_jacobian.shape[0]

    @property
    def planar(self) -> bool:
        return self.dim == 2

    def contact_block(self, i: int) -> tuple[np.ndarray, np.ndarray]:
        """Delassus block ``W_ii`` and ``v_minus[i]`` of contact i."""
        d = self.dim
        return self.delassus[i * d:(i + 1) * d, i * d:(i + 1) * d], self.v_minus[i]

    def velocity_jump(self, impulse: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Joint-velocity jump and loop impulses for contact-frame impulses ``impulse``.

        ``Delta theta_dot = M^-1 (Jc^T pi + C^T Delta sigma)`` (eqs. 29, 44), with
        ``Delta sigma`` such that ``C Delta theta_dot = 0`` (eq. 43).
        """
        pi = np.ravel(impulse)
        d_dq = self._minv_jt @ pi
        dsigma = np.zeros(0)
        if self.n_loops:
            dsigma = -sla.cho_solve(self._loop_cho, self.loop_jacobian @ d_dq)
            d_dq = d_dq + self._minv_ct @ dsigma
        return d_dq, dsigma

    def kinetic_energy(self, dq: np.ndarray) -> float:
        """T = 1/2 dq^T M dq (eq. 58)."""
        return 0.5 * float(dq @ self.mass_matrix @ dq)


def build_problem(M, Jc, dq, e=0.0, mu=0.0, C=None) -> ImpactProblem:
    """Validate raw impact data and reduce it to contact space.

    Parameters
    ----------
    M : (k, k) array_like
        Generalized mass matrix in joint coordinates (eq. 3), symmetric positive definite.
    Jc : (d, k) array_like, or a sequence of them, or a (n_contacts, d, k) array
        Contact Jacobian(s) in the contact frame, rows n, t (planar) or n, t1, t2 (spatial).
    dq : (k,) array_like
        Joint velocities before impact.
    e, mu : float or per-contact sequence
        Coefficients of restitution (in [0, 1]) and friction (>= 0).
    C : (m, k) array_like, optional
        Loop-constraint Jacobian (eq. 7); must have full row rank and satisfy C dq = 0.
    """
    M, L = check_mass_matrix(M)
    k = M.shape[0]

    # a list or tuple of matrices is several contacts; a nested list of numbers is one matrix
    single = not (isinstance(Jc, (list, tuple)) and (len(Jc) == 0 or np.ndim(Jc[0]) == 2))
    if not single:
        if len(Jc) == 0 or len({np.shape(j) for j in Jc}) != 1:
            raise ShapeError("Jc must be a (d, k) array or a non-empty list of them, all of one shape")
        Jc = [np.asarray(j, dtype=float) for j in Jc]
    J = _as_float_array("Jc", Jc)
    if single and J.ndim == 3:
        single = False
    if J.ndim == 2:
        J = J[None]
    if J.ndim != 3 or J.shape[1] not in (2, 3) or J.shape[2] != k:
        raise ShapeError(
            f"each contact Jacobian must be 2 x {k} (planar rows n, t) or 3 x {k} (spatial rows "
            f"n, t1, t2) to match M ({k} x {k}); got {J.shape[1:] if J.ndim == 3 else J.shape}"
        )
    _finite("Jc", J)
    n_contacts, d, _ = J.shape

    dq = _as_float_array("dq", dq)
    if dq.shape != (k,):
        raise ShapeError(f"dq must be a vector of length {k} to match M, got shape {dq.shape}")
    _finite("dq", dq)
    e = check_restitution(e, n_contacts)
    mu = check_friction(mu, n_contacts)

    Jflat = J.reshape(n_contacts * d, k)
    X = _tri_solve(L, Jflat.T)  # L^-1 Jc^T
    minv_jt = _tri_solve(L, X, trans=1)  # M^-1 Jc^T
    W = X.T @ X

    if C is None:
        C = np.zeros((0, k))
    C = _as_float_array("C", C)
    if C.ndim == 1 and C.size == k:
        C = C[None]
    if C.ndim != 2 or C.shape[1] != k:
        raise ShapeError(f"C must be an m x {k} loop-constraint Jacobian, got shape {C.shape}")
    _finite("C", C)
    m = C.shape[0]
    loop_cho = None
    minv_ct = np.zeros((k, 0))
    A = np.zeros((0, 0))
    if m:
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
        resid = float(np.linalg.norm(C @ dq))
        if resid > LOOP_VELOCITY_RTOL * s[0] * max(float(np.linalg.norm(dq)), 1e-300):
            raise LoopConstraintError(
                f"dq violates the loop constraints: |C dq| = {resid:.3e} (eq. 7 requires 0); "
                "project dq onto the null space of C before the impact"
            )
        Y = _tri_solve(L, C.T)  # L^-1 C^T
        minv_ct = _tri_solve(L, Y, trans=1)
        A = Y.T @ Y
        try:
            loop_cho = sla.cho_factor(A, lower=True)
        except np.linalg.LinAlgError:
            raise LoopConstraintError(
                "C M^-1 C^T is numerically singular: the loop constraints are (nearly) "
                "dependent in this configuration; remove redundant rows of C or move off the "
                "singular configuration") from None
        B = Y.T @ X
        W = W - B.T @ sla.cho_solve(loop_cho, B)
    W = 0.5 * (W + W.T)
    # a contact whose tangent directions move no mass (e.g. a central impact of sliders along
    # their slide line) cannot take a friction impulse: it would do no work and is
    # undetermined, so the contact is frictionless whatever mu says
    idx = np.arange(n_contacts) * d
    tangential = np.array([float(np.max(np.abs(np.diag(W)[i + 1:i + d]))) for i in idx])
    immobile = tangential <= 1e-14 * max(float(np.max(np.abs(np.diag(W)))), 1e-300)
    if np.any(immobile & (mu > 0)):
        mu = np.where(immobile, 0.0, mu)
    v_minus = (Jflat @ dq).reshape(n_contacts, d)
    with np.errstate(over="ignore", invalid="ignore"):
        T_minus = 0.5 * float(dq @ M @ dq)
    if not (np.all(np.isfinite(W)) and np.all(np.isfinite(v_minus)) and np.isfinite(T_minus)):
        raise NonFiniteError(
            "the impact overflows double precision (Delassus matrix, contact velocities or "
            "kinetic energy not finite); rescale the units of M, Jc and dq")
    return ImpactProblem(
        mass_matrix=M, cholesky=L, jacobians=J, dq_minus=dq, restitution=e, friction=mu,
        loop_jacobian=C, single=single, delassus=W, v_minus=v_minus, loop_matrix=A,
        _minv_jt=minv_jt, _minv_ct=minv_ct, _loop_cho=loop_cho,
    )
