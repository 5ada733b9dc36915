"""A contact problem given as a Delassus matrix: ``u = W r + b``, the way contact problems are
exchanged and compared in the field, solved and certified by the contact engine.

Per contact ``r_i = (r_n, r_t[, r_t2])``, normal first; ``K_mu = {|r_t| <= mu r_n}``.

* ``law="coulomb"``: Coulomb's law in De Saxce's form, ``K ∋ r ⊥ u + mu |u_t| e_n ∈ K*``;
* ``law="ccp"``: its convex relaxation (Anitescu's), ``K ∋ r ⊥ u ∈ K*``.

The answer is certified by the relative natural-map residual
``|r - P_K(r - y)| / max(|b|, |r|, |u|)`` (``y = u + mu |u_t| e_n`` for Coulomb, ``y = u``
for the CCP), computed on the data as given; above ``tol`` the call raises
:class:`UncertifiedSolutionError` carrying the best answer reached, never returns it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from ..errors import (
    NonFiniteError,
    ParameterError,
    ShapeError,
    SolverError,
    as_real_array,
    real_number,
)
from . import engine
from .generalized import generalized_inputs

CONTACT_LAWS = ("coulomb", "ccp")
#: a sparse W of at most this many rows is checked and solved dense
DENSE_CHECK_ROWS = 120
#: relative asymmetry of W accepted (W is a Delassus matrix J M^-1 J^T: symmetric)
SYMMETRY_RTOL = 1e-10


@dataclass(frozen=True)
class ContactSolution:
    """The certified answer of :func:`solve_contact_problem`.

    Attributes
    ----------
    impulse : ndarray (n, d)
        Contact impulses (or forces), normal first.
    velocity : ndarray (n, d)
        ``W r + b`` per contact.
    residual : float
        The relative natural-map residual of the law (at most ``tol``).
    status : str
        ``"solved"``.
    iterations : int
        Interior-point iterations and Newton steps, summed.
    law : str
    tol : float
    """

    impulse: np.ndarray
    velocity: np.ndarray
    residual: float
    status: str
    iterations: int
    law: str
    tol: float

    @property
    def n_contacts(self) -> int:
        return self.impulse.shape[0]

    @property
    def dim(self) -> int:
        return self.impulse.shape[1]


class UncertifiedSolutionError(SolverError):
    """The contact engine did not certify an answer at ``tol``: ``residual`` is the best
    natural-map residual reached and ``solution`` the (uncertified) :class:`ContactSolution`
    there. Loosen ``tol`` knowingly, or check the data (a W that is not positive
    semidefinite, a Coulomb problem without solution)."""

    def __init__(self, message: str, residual: float, solution: ContactSolution):
        super().__init__(message)
        self.residual = residual
        self.solution = solution


def _check_W(W, N: int):
    if sp.issparse(W) and W.shape == (N, N) and N <= DENSE_CHECK_ROWS:
        W = W.toarray()  # small: the dense checks (and the compiled kernels) are cheaper
    if sp.issparse(W):
        if W.shape != (N, N):
            raise ShapeError(f"W must be square of size n*d = {N}, got shape {W.shape}")
        W = sp.csr_matrix(W)
        if W.dtype.kind not in "fiu":
            raise ShapeError(f"W must be a real matrix, got dtype {W.dtype}")
        W = W.astype(float)
        if not np.all(np.isfinite(W.data)):
            raise NonFiniteError("W has a non-finite entry (nan or inf)")
        asym = abs(W - W.T).max() if W.nnz else 0.0
        big = abs(W).max() if W.nnz else 0.0
    else:
        W = as_real_array("W", W)
        if W.ndim != 2 or W.shape[0] != W.shape[1]:
            raise ShapeError(f"W must be a square matrix, got shape {W.shape}")
        if W.shape != (N, N):
            raise ShapeError(f"W must be square of size n*d = {N} (from b), got {W.shape}")
        if not np.all(np.isfinite(W)):
            raise NonFiniteError("W has a non-finite entry (nan or inf)")
        asym = float(np.max(np.abs(W - W.T), initial=0.0))
        big = float(np.max(np.abs(W), initial=0.0))
    if asym > SYMMETRY_RTOL * big:
        raise ShapeError(f"W must be symmetric (a Delassus matrix J M^-1 J^T): its largest "
                         f"asymmetry is {asym:.3g} of a largest entry {big:.3g}")
    diag = W.diagonal()
    if np.any(diag < -SYMMETRY_RTOL * big):
        i = int(np.argmin(diag))
        raise ShapeError(f"W must be positive semidefinite: its diagonal entry {i} is "
                         f"{diag[i]:.6g} < 0")
    return W, big


def generalized_serves(W) -> bool:
    """Whether :func:`solve_contact_problem` uses ``mass_matrix`` and ``jacobian`` on the
    Delassus matrix W (n*d rows): where the engine works on sparse W, W sparse with at least
    :data:`~.ccp_interior.SPARSE_MIN_ROWS` rows and at most
    :data:`~.ccp_interior.SPARSE_MAX_DENSITY` of its entries nonzero (a fixed rule on the
    data, no timing); elsewhere they are only checked."""
    return engine.use_sparse(W, W.shape[0])


def solve_contact_problem(W, b, mu, *, law: str = "coulomb", tol: float = 1e-8,
                          dim: int | None = None, max_iter: int = 100,
                          newton_iter: int = 30, mass_matrix=None,
                          jacobian=None) -> ContactSolution:
    """Solve the contact problem ``u = W r + b`` with friction cones ``mu``.

    Parameters
    ----------
    W : (n*d, n*d) array_like or scipy.sparse matrix, or None
        The Delassus matrix (symmetric positive semidefinite), contacts in order, each contact's
        rows normal first. None: ``J M^-1 J^T`` from ``mass_matrix`` and ``jacobian``.
    b : (n*d,) or (n, d) array_like
        The free velocity (``u`` at ``r = 0``).
    mu : float or (n,) array_like
        Friction coefficients, >= 0 (0: frictionless; the tangential impulse is then 0).
    law : {"coulomb", "ccp"}
        Coulomb's law (De Saxce's form) or its convex relaxation.
    tol : float
        Acceptance threshold of the relative natural-map residual.
    dim : {2, 3}, optional
        Contact dimension, when the sizes leave it ambiguous (a scalar ``mu`` and n*d
        divisible by 6).
    max_iter, newton_iter : int
        Interior-point iterations and Newton steps allowed.
    mass_matrix, jacobian : optional, both or neither
        The problem in generalized coordinates: ``M`` (m, m) symmetric positive definite and
        ``J`` (n*d, m), dense or scipy.sparse, with ``W = J M^-1 J^T`` (checked on probe
        vectors when W is given too). Where the engine works on sparse W (large, thin
        problems), it then solves its linear systems through ``G = J L^-T`` (``M = L L^T``,
        block by block): the ADMM's by Woodbury's identity on the m x m ``c I + G^T G`` (its
        symbolic factorization kept), the Newton steps through a sparse 2m-row system
        (:mod:`convimpact.contacts.generalized`); elsewhere (:func:`generalized_serves`)
        they are only checked. The problem and its certificate (on ``W``
        and ``b``) are unchanged; ``b`` stays the contact-space free velocity (``J`` times
        the generalized one, with any restitution shift).

    Returns
    -------
    ContactSolution

    Raises
    ------
    ShapeError, NonFiniteError, ParameterError, MassMatrixError
        Bad input, naming the argument (a ShapeError also where W is not
        ``J M^-1 J^T``).
    UncertifiedSolutionError
        No answer certified at ``tol`` (carries the best one reached).

    Examples
    --------
    One planar contact that slides: r_t = -mu r_n, and u_n = 0 gives r_n = 1 / 1.85.

    >>> import numpy as np, convimpact as ci
    >>> sol = ci.solve_contact_problem([[2.0, 0.5], [0.5, 1.0]], [-1.0, 0.5], mu=0.3)
    >>> sol.status, np.round(sol.impulse, 4).tolist(), np.round(sol.velocity, 4).tolist()
    ('solved', [[0.5405, -0.1622]], [[0.0, 0.6081]])
    """
    if not isinstance(law, str) or law not in CONTACT_LAWS:
        raise ParameterError(f"law must be one of {CONTACT_LAWS}, got {law!r}")
    tol = real_number("tol", tol)
    if not (math.isfinite(tol) and tol > 0.0):
        raise ParameterError(f"tol must be a finite number > 0, got {tol!r}")
    for name, value in (("max_iter", max_iter), ("newton_iter", newton_iter)):
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
            raise ParameterError(f"{name} must be an integer >= 1, got {value!r}")
    b = as_real_array("b", b)
    if not np.all(np.isfinite(b)):
        raise NonFiniteError("b has a non-finite entry (nan or inf)")
    mu_arr = as_real_array("mu", mu, ParameterError)
    if mu_arr.ndim > 1:
        raise ShapeError(f"mu must be a number or a vector (one per contact), got shape "
                         f"{mu_arr.shape}")
    if not np.all(np.isfinite(mu_arr)) or np.any(mu_arr < 0.0):
        raise ParameterError(f"friction coefficients mu must be finite and >= 0, got {mu!r}")
    d = _dimension(b, mu_arr, dim)
    N = b.size
    n = N // d
    mu_arr = np.broadcast_to(mu_arr, (n,)).astype(float) if mu_arr.ndim == 0 else mu_arr
    if mu_arr.shape != (n,):
        raise ShapeError(f"mu has {mu_arr.size} entries for {n} contacts (b has {N} = "
                         f"{n} x {d} entries)")
    generalized = None
    if (mass_matrix is None) != (jacobian is None):
        raise ParameterError("mass_matrix and jacobian go together: pass both or neither")
    if W is None and mass_matrix is None:
        raise ShapeError("W is None: pass the Delassus matrix, or mass_matrix and jacobian")
    W = None if W is None else _check_W(W, N)[0]
    if mass_matrix is not None:
        generalized = generalized_inputs(mass_matrix, jacobian, N, W)
        W = _check_W(generalized.delassus(), N)[0] if W is None else W
    R = engine.solve(W, b.reshape(n, d), mu_arr, d, coulomb=law == "coulomb", tol=tol,
                     max_iter=int(max_iter), newton_iter=int(newton_iter),
                     generalized=generalized)
    sol = ContactSolution(R.impulse, R.velocity, float(R.residual),
                          "solved" if R.converged else "not certified", int(R.iterations),
                          law, tol)
    if not R.converged:
        raise UncertifiedSolutionError(
            f"the contact engine did not certify the {law} problem ({n} contacts) at tol "
            f"{tol:g}: best natural-map residual {R.residual:.3g} ({R.message})",
            float(R.residual), sol)
    return sol


def _dimension(b: np.ndarray, mu: np.ndarray, dim) -> int:
    if dim is not None:
        if isinstance(dim, bool) or dim not in (2, 3):
            raise ParameterError(f"dim must be 2 or 3, got {dim!r}")
        d = int(dim)
    elif b.ndim == 2:
        d = b.shape[1]
    elif mu.ndim == 1 and mu.size:
        if b.size % mu.size:
            raise ShapeError(f"b has {b.size} entries, not a multiple of the {mu.size} "
                             "contacts of mu")
        d = b.size // mu.size
    elif b.size % 6 == 0:
        raise ShapeError(f"b has {b.size} entries, both n*2 and n*3 with a scalar mu: "
                         "pass dim=2 or dim=3")
    else:
        d = 2 if b.size % 2 == 0 else 3
    if b.ndim == 2 and b.shape[1] != d or b.ndim > 2:
        raise ShapeError(f"b must be (n*d,) or (n, d) with d = {d}, got shape {b.shape}")
    if d not in (2, 3) or b.size % d or b.size == 0:
        raise ShapeError(f"contacts must be planar (d = 2) or spatial (d = 3) with at least "
                         f"one contact: b has {b.size} entries for d = {d}")
    return d
