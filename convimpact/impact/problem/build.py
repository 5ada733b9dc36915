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

Validation is typed (:func:`~convimpact.errors.as_real_array`): a string, a boolean,
a complex number or None is a ShapeError (for ``e``, ``mu`` a ParameterError) naming the
entry. Every tolerance is relative to the data's own scales, so M times ``a`` and dq times
``b`` change no decision. The common case (float arrays, one contact, no loops) costs a handful
of numpy calls: the small checks run on Python floats, and the factorization and triangular
solves are :mod:`~convimpact.impact.problem.dense`'s (Python floats up to ``SMALL_MAX`` rows,
LAPACK/BLAS on one thread above: no BLAS thread is woken for a tiny matrix). For several
contacts the checks on W and v- (exact symmetry, finiteness, degenerate normals, immobile
tangents) run in one compiled call (:func:`~convimpact.contacts.interior_point.contact_checks`),
which hands every case but the plain one to the Python checks; W's nested lists are then
formed on first use.
"""

from __future__ import annotations

import math
import sys
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

import numpy as np

from ...errors import (DegenerateContactError, MassMatrixError, NonFiniteError, ParameterError,
                       ShapeError, as_real_array, real_number)
from .reduction import (  # noqa: F401  (re-exported: the tolerances are this module's API)
    _LOOP_MAX,
    IMMOBILE_RTOL,
    LOOP_RANK_RTOL,
    LOOP_VELOCITY_RTOL,
    TINY_NORMAL,
    _contact_space,
    _finite,
    _plain_contacts,
    _symmetrize,
)
from .dense import cholesky_lower, empty_matrix, tri_solve

#: relative tolerance on the asymmetry of M
SYMMETRY_RTOL = 1e-10
#: scales within which products of a contact's W and v of degree <= 3 stay far from under-
#: and overflow: the single-contact kernels are called unscaled inside, rescaled outside
SAFE_SCALE = (2.0 ** -166, 2.0 ** 166)  # about 1e-50 .. 1e50
_F64 = np.dtype(np.float64)


def _new(cls, values: dict):
    """An instance of a frozen dataclass from all its field values, without the per-field
    ``object.__setattr__`` of its generated ``__init__`` (the public call's hot path)."""
    obj = object.__new__(cls)
    obj.__dict__.update(values)
    return obj


# --------------------------------------------------------------------------------------------
# the checks of each argument


def check_mass_matrix(M) -> tuple[np.ndarray, np.ndarray]:
    """Validate a generalized mass matrix; return it symmetrized with its lower Cholesky factor.

    Raises
    ------
    ShapeError, NonFiniteError, MassMatrixError
    """
    M = as_real_array("M", M)
    if M.ndim != 2 or M.shape[0] != M.shape[1] or M.shape[0] == 0:
        raise ShapeError(f"M must be a square k x k matrix with k >= 1, got shape {M.shape}")
    k = M.shape[0]
    # exactly symmetric (a NaN fails ==) with a finite diagonal: then an infinite entry
    # makes the factorization fail or leaves a non-finite last pivot (on Python floats for
    # small M, one vectorized comparison for larger ones)
    if k > _LOOP_MAX:
        exact = bool((M == M.T).all())
        tr = float(M.trace())
    else:
        m = M.tolist()
        exact = True
        tr = m[0][0]
        for i in range(1, k):
            row = m[i]
            tr += row[i]
            for j in range(i):
                if row[j] != m[j][i]:
                    exact = False
    if not (exact and math.isfinite(tr)):
        _finite("M", M)
        scale = float(np.max(np.abs(M)))
        asym = float(np.max(np.abs(M - M.T)))
        if asym > SYMMETRY_RTOL * scale:
            raise MassMatrixError(
                f"M is not symmetric (max |M - M^T| = {asym:.3e} for max |M| = {scale:.3e}); "
                "a generalized mass matrix B^T M B (eq. 3) is symmetric: check its assembly"
            )
        M = 0.5 * M + 0.5 * M.T  # as 0.5 (M + M^T), without overflow near the float maximum
    L, info = cholesky_lower(M)
    if info != 0 or not math.isfinite(L[k - 1, k - 1]):
        _finite("M", M)
        lam = float(np.linalg.eigvalsh(M)[0])
        raise MassMatrixError(
            f"M is not positive definite (smallest eigenvalue {lam:.3e}); every body needs "
            "positive mass and the joint coordinates must be independent"
        ) from None
    return M, L


def _per_contact(name: str, value, n: int, upper: float, lower: float = 0.0) -> np.ndarray:
    """e, mu or e_t: real, finite, in [lower, upper] (upper finite), one per contact."""
    if type(value) is float and lower <= value <= upper:  # the common case: finite, in range
        return np.array([value] * n)
    if type(value) is list and len(value) == n and all(type(x) is float for x in value) \
            and math.isfinite(sum(value)) and min(value) >= lower and max(value) <= upper:
        # a list of finite floats in range (a NaN or an infinity makes the sum non-finite)
        return np.array(value)
    if isinstance(value, (list, tuple)) or (isinstance(value, np.ndarray) and value.ndim):
        a = as_real_array(name, value, ParameterError)
        if a.shape != (n,):
            raise ShapeError(
                f"{name} must be a scalar or one value per contact ({n}), got shape {a.shape}")
        values = a.tolist()
    else:
        values = [real_number(name, value)] * n
    if not all(map(math.isfinite, values)):
        raise NonFiniteError(f"{name} contains NaN or infinity; pass finite values")
    if not (min(values) >= lower and max(values) <= upper):
        if name == "e_t":
            raise ParameterError(
                f"tangential restitution e_t must lie in [-1, 1], got {values}: outside it "
                "the Chatterjee-Ruina law creates energy (T+ - T- has the term "
                "1/2 k (k - 2) |J_II - J_I|_W^2 with k = 1 + e_t)")
        if name == "e":
            raise ParameterError(
                f"coefficient of restitution e must lie in [0, 1], got {values}")
        raise ParameterError(
            f"coefficient of friction mu must be >= 0, got {values} (the paper's negative "
            "mu of Figs. 5-7 is a sign convention of its landscapes: use "
            "convimpact.studies.landscape for those)")
    return np.array(values)


def check_restitution(e, n_contacts: int = 1) -> np.ndarray:
    """Validate the coefficient(s) of restitution: real, finite and in [0, 1]."""
    return _per_contact("e", e, n_contacts, 1.0)


def check_friction(mu, n_contacts: int = 1) -> np.ndarray:
    """Validate the coefficient(s) of friction: real, finite and non-negative."""
    return _per_contact("mu", mu, n_contacts, sys.float_info.max)


def check_tangential_restitution(e_t, n_contacts: int = 1) -> np.ndarray:
    """Validate the tangential restitution(s) of law ``chatterjee-ruina``: real, finite and in
    [-1, 1] (the range in which the law cannot create energy)."""
    return _per_contact("e_t", e_t, n_contacts, 1.0, -1.0)


def _float_matrices(Jc: list) -> bool:
    """Whether ``Jc`` is a non-empty list of float64 matrices, all of one shape."""
    if not Jc:
        return False
    shape = Jc[0].shape if type(Jc[0]) is np.ndarray else None
    for j in Jc:
        if type(j) is not np.ndarray or j.dtype is not _F64 or j.shape != shape \
                or len(shape) != 2:
            return False
    return True


def _jacobians(Jc, k: int) -> tuple[np.ndarray, bool]:
    """The contact Jacobians as a (n_contacts, d, k) float array, and whether one was passed."""
    if type(Jc) is np.ndarray:
        J = as_real_array("Jc", Jc)
        single = J.ndim != 3
    elif type(Jc) is list and _float_matrices(Jc):
        # the common case of several contacts: a list of float matrices of one shape
        J = np.array(Jc)
        single = False
    else:
        # a list or tuple of matrices is several contacts; a nested list of numbers is one
        single = not (isinstance(Jc, (list, tuple)) and (len(Jc) == 0 or np.ndim(Jc[0]) == 2))
        if not single:
            if len(Jc) == 0 or len({np.shape(j) for j in Jc}) != 1:
                raise ShapeError(
                    "Jc must be a (d, k) array or a non-empty list of them, all of one shape")
            Jc = [as_real_array("Jc", j) for j in Jc]
        J = as_real_array("Jc", Jc)
        if single and J.ndim == 3:
            single = False
    if J.ndim == 2:
        J = J[None]
    if J.ndim != 3 or J.shape[1] not in (2, 3) or J.shape[2] != k:
        raise ShapeError(
            f"each contact Jacobian must be 2 x {k} (planar rows n, t) or 3 x {k} (spatial rows "
            f"n, t1, t2) to match M ({k} x {k}); got {J.shape[1:] if J.ndim == 3 else J.shape}"
        )
    return J, single


# --------------------------------------------------------------------------------------------
# the validated problem


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
    tangential_restitution : (n_contacts,) e_t per contact for the laws that have one
        (``chatterjee-ruina``), else None.
    loop_jacobian : (m, k) C of eq. (7); m = 0 for open loops.
    single : True when the caller passed one Jacobian (results are then un-stacked).
    delassus : (n_contacts d, n_contacts d) W = Jc G Jc^T.
    v_minus : (n_contacts, d) contact-frame relative velocities before impact.
    loop_matrix : (m, m) C M^-1 C^T.
    notes : statements about the data that every result repeats in its warnings (a contact
        whose normal row is zero can only be "separating").
    approaching : per contact, v_n- < 0.
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
    notes: tuple[str, ...] = ()
    tangential_restitution: np.ndarray | None = None
    # derived from the fields above (build_problem sets them; __post_init__ otherwise)
    approaching: tuple[bool, ...] = field(init=False, repr=False)
    _minv_jt: Any = field(init=False, repr=False)  # M^-1 Jc^T, (k, n_contacts d)
    _minv_ct: Any = field(init=False, repr=False)  # M^-1 C^T, (k, m)
    _loop_cho: Any = field(init=False, repr=False)  # lower Cholesky factor of C M^-1 C^T
    _vl: Any = field(init=False, repr=False)  # v_minus as a flat Python list
    _rows: Any = field(init=False, repr=False)  # the stacked Jacobians, (n_contacts d, k)

    def __post_init__(self):
        """The derived caches of a problem built field by field (or by dataclasses.replace)."""
        n, d, k = self.jacobians.shape
        L, C = self.cholesky, self.loop_jacobian
        rows = self.jacobians.reshape(n * d, k)
        v = self.v_minus.ravel().tolist()
        m = C.shape[0]
        derived = dict(
            approaching=tuple(v[i * d] < 0.0 for i in range(n)),
            _minv_jt=tri_solve(L, tri_solve(L, rows.T), trans=1),
            _minv_ct=tri_solve(L, tri_solve(L, C.T), trans=1) if m else empty_matrix((k, 0)),
            _loop_cho=cholesky_lower(self.loop_matrix)[0] if m else None,
            _vl=v, _lists=(self.delassus.tolist(), v), _rows=rows)
        self.__dict__.update(derived)

    @cached_property
    def _lists(self) -> tuple[list, list]:
        """(W, v) as nested Python lists (set by :func:`build_problem` where it formed them,
        else on first access)."""
        return self.delassus.tolist(), self._vl

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

    @property
    def jacobian_rows(self) -> np.ndarray:
        """The stacked contact Jacobians, (n_contacts d, k)."""
        return self._rows

    def contact_block(self, i: int) -> tuple[np.ndarray, np.ndarray]:
        """Delassus block ``W_ii`` and ``v_minus[i]`` of contact i."""
        d = self.dim
        return self.delassus[i * d:(i + 1) * d, i * d:(i + 1) * d], self.v_minus[i]

    def contact_lists(self, i: int) -> tuple[list, list]:
        """``W_ii`` and ``v_minus[i]`` of contact i as Python lists (the kernels' input; they
        must not be modified)."""
        if self.n_contacts == 1:
            return self._lists
        d = self.dim
        w, v = self._lists
        return [row[i * d:(i + 1) * d] for row in w[i * d:(i + 1) * d]], v[i * d:(i + 1) * d]

    def velocity_jump(self, impulse: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Joint-velocity jump and loop impulses for contact-frame impulses ``impulse``.

        ``Delta theta_dot = M^-1 (Jc^T pi + C^T Delta sigma)`` (eqs. 29, 44), with
        ``Delta sigma`` such that ``C Delta theta_dot = 0`` (eq. 43).
        """
        d_dq = self._minv_jt @ (impulse.ravel() if type(impulse) is np.ndarray
                                else np.ravel(impulse))
        if self._loop_cho is None:
            return d_dq, np.zeros(0)
        La = self._loop_cho  # Delta sigma = -(C M^-1 C^T)^-1 C Delta theta_dot (eq. 43)
        dsigma = -tri_solve(La, tri_solve(La, self.loop_jacobian @ d_dq), trans=1)
        return d_dq + self._minv_ct @ dsigma, dsigma

    @cached_property
    def _mass_scale(self) -> float:
        return float(np.max(np.abs(self.mass_matrix)))

    def kinetic_energy(self, dq: np.ndarray) -> float:
        """T = 1/2 dq^T M dq (eq. 58); ``inf`` (or 0) where T itself leaves double precision's
        range although M and dq do not."""
        dq = np.asarray(dq, dtype=float)
        ds = float(np.max(np.abs(dq))) if dq.size else 0.0
        ms = self._mass_scale
        if 1e-100 <= ds <= 1e100 and 1e-100 <= ms <= 1e100:
            return 0.5 * float(dq @ self.mass_matrix @ dq)
        if ds == 0.0:
            return 0.0
        u = dq / ds
        return 0.5 * float(u @ (self.mass_matrix / ms) @ u) * ms * ds * ds


def _check_contacts(J: np.ndarray, w: list, mu: np.ndarray) -> tuple[np.ndarray, tuple]:
    """Degenerate contacts: a zero (or underflowed) normal row raises, unless only the normal
    row is exactly zero (then the contact cannot approach: noted); a contact whose tangents
    move no mass is frictionless. Returns mu and the notes."""
    n, d, _ = J.shape
    if n == 1 and w[0][0] >= TINY_NORMAL:  # the common case: one contact, its normal moving
        wt = w[1][1] if d == 2 or w[1][1] >= w[2][2] else w[2][2]
        if wt <= IMMOBILE_RTOL * w[0][0] and mu[0] > 0.0:
            mu = np.zeros(1)
        return mu, ()
    diag = [w[i][i] for i in range(n * d)]
    big = max(diag)
    notes = []
    immobile = []
    for i in range(n):
        wn, wt = diag[i * d], max(diag[i * d + 1:(i + 1) * d])
        if not wn >= TINY_NORMAL:
            zero_row = not J[i, 0].any()
            if not (zero_row and wt >= TINY_NORMAL):
                where = "" if n == 1 else f" of contact {i}"
                what = ("is zero, and so are its tangent rows" if zero_row else
                        f"is numerically zero relative to M's scale (c_n^T M^-1 c_n = {wn:.3e} "
                        "underflows double precision)")
                raise DegenerateContactError(
                    f"the contact Jacobian's normal row{where} {what}: the contact cannot "
                    "approach or take an impulse; check the contact normal and the Jacobian "
                    "(or rescale units), or leave the contact out")
            notes.append(
                f"contact {i}: the contact Jacobian's normal row is zero (the contact point "
                "cannot move along its normal here, e.g. a grazing contact at a singular "
                "configuration): it cannot approach and takes no impulse")
        immobile.append(wt <= IMMOBILE_RTOL * big)
    # a contact whose tangent directions move no mass (e.g. a central impact of sliders along
    # their slide line) cannot take a friction impulse: it would do no work and is
    # undetermined, so the contact is frictionless whatever mu says
    if any(immobile) and mu.max() > 0.0:
        mu = np.where(immobile, 0.0, mu)
    return mu, tuple(notes)


def build_problem(M, Jc, dq, e=0.0, mu=0.0, C=None, e_t=None) -> ImpactProblem:
    """Validate raw impact data and reduce it to contact space.

    Parameters
    ----------
    M : (k, k) array_like
        Generalized mass matrix in joint coordinates (eq. 3), symmetric positive definite.
    Jc : (d, k) array_like, or a sequence of them, or a (n_contacts, d, k) array
        Contact Jacobian(s) in the contact frame, rows n, t (planar) or n, t1, t2 (spatial).
        A contact's normal row may be zero only if its tangent rows are not (the contact then
        cannot approach), and may not be numerically zero relative to M's scale.
    dq : (k,) array_like
        Joint velocities before impact.
    e, mu : float or per-contact sequence
        Coefficients of restitution (in [0, 1]) and friction (>= 0): real numbers, not
        strings or booleans.
    C : (m, k) array_like, optional
        Loop-constraint Jacobian (eq. 7); must have full row rank and satisfy C dq = 0.
    e_t : float or per-contact sequence, optional
        Tangential restitution in [-1, 1], for law ``chatterjee-ruina``.

    Returns
    -------
    ImpactProblem

    Raises
    ------
    ShapeError, NonFiniteError, MassMatrixError, ParameterError, DegenerateContactError,
    LoopConstraintError

    Examples
    --------
    Built once, resolved under several laws (W = Jc M^-1 Jc^T = I / 2, v- = Jc dq):

    >>> import numpy as np, convimpact as ci
    >>> P = ci.build_problem(2 * np.eye(2), np.array([[0., 1.], [1., 0.]]), [1., -1.],
    ...                      e=0.5, mu=0.3)
    >>> P.delassus.tolist(), P.v_minus.tolist()
    ([[0.5, 0.0], [0.0, 0.5]], [[-1.0, 1.0]])
    >>> [ci.solve_problem(P, law).regime for law in ("pereira-nikravesh", "ccp")]
    ['slide', 'slide']
    """
    Mf, L = check_mass_matrix(M)
    k = Mf.shape[0]
    J, single = _jacobians(Jc, k)
    n, d, _ = J.shape
    dqf = as_real_array("dq", dq)
    if dqf.shape != (k,):
        raise ShapeError(f"dq must be a vector of length {k} to match M, got shape {dqf.shape}")
    e = check_restitution(e, n)
    mu = check_friction(mu, n)
    et = None if e_t is None else check_tangential_restitution(e_t, n)
    # the problem owns its arrays: the caller may change theirs in place afterwards (before
    # the diagnostics, measured on first access, are read)
    M = Mf.copy() if Mf is M else Mf
    dq = dqf.copy() if dqf is dq else dqf
    if type(Jc) is np.ndarray:
        J = J.copy()
    rows = J.reshape(n * d, k)
    X, W, v, C, A, minv_ct, loop_cho = _contact_space(L, rows, dq, C)
    vl = v.tolist()
    notes = ()
    lists = None
    # several contacts: W symmetrized and the plain case recognized in one compiled call
    # (W's lists are then formed on first use); else, and for one contact, the checks below
    if n == 1 or not _plain_contacts(W, v, d):
        w = _symmetrize(W)
        if not math.isfinite(sum(map(sum, w)) + sum(vl)):  # NaN or inf input, or an overflow
            _finite("M", M)
            _finite("Jc", J)
            _finite("dq", dq)
            if not (np.isfinite(W).all() and np.isfinite(v).all()):
                raise NonFiniteError(
                    "the impact overflows double precision (Delassus matrix or contact "
                    "velocities not finite); rescale the units of M, Jc and dq")
        mu, notes = _check_contacts(J, w, mu)
        lists = (w, vl)
    derived = dict(
        mass_matrix=M, cholesky=L, jacobians=J, dq_minus=dq, restitution=e, friction=mu,
        loop_jacobian=C, single=single, delassus=W, v_minus=v.reshape(n, d), loop_matrix=A,
        notes=notes, tangential_restitution=et,
        approaching=tuple([vl[i] < 0.0 for i in range(0, n * d, d)]),
        _minv_jt=tri_solve(L, X, trans=1), _minv_ct=minv_ct, _loop_cho=loop_cho, _vl=vl,
        _rows=rows)
    if lists is not None:
        derived["_lists"] = lists
    return _new(ImpactProblem, derived)
