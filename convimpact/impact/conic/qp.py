"""The cone QP every impact law reduces to, and how a backend solves it.

With the Delassus matrix ``W`` of :class:`~convimpact.impact.problem.build.ImpactProblem` (loops
already eliminated, so ``C theta_dot+ = 0`` holds by construction and ``Delta sigma`` is
recovered by ``ImpactProblem.velocity_jump``), ``pi = (pi_1, ..., pi_n)``, ``pi_i = (pi_n, pi_t)``
and ``K_mu = {|pi_t| <= mu pi_n}``, each law of :mod:`convimpact.impact.laws` reduces to one or
several instances of

    minimize 1/2 pi^T W pi + q^T pi   subject to   E pi = f,   pi_i in K_mu_i,

solved by a *backend* (:mod:`~convimpact.impact.conic.clarabel_backend`,
:mod:`~convimpact.impact.conic.cvxpy_backend`). A frictionless contact (mu_i = 0) is posed as
``pi_n >= 0, pi_t = 0`` rather than as a degenerate cone. The program is a
:class:`~convimpact.impact.conic.program.ConeQP` (importable from here).

Accuracy. Every program is equilibrated (:func:`equilibrated`), solved by the interior-point
method and then polished (:mod:`~convimpact.impact.conic.polish`: Newton on the KKT equations
of its active set, kept only when that set is consistent). Polished answers are exact to
round-off (measured KKT residuals 1e-16 .. 1e-14; with an ill-conditioned W, cond(W) eps: 1e-6
at cond(M) = 1e10, as for the closed forms); raw interior-point impulses on the cone boundary
only to about sqrt(tol) (1e-5 at Clarabel's default 1e-8, 1e-6 at 1e-10), which is what the
results then claim (``extras["polished"]``, ``"kkt_residual"``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np

from ...errors import SolverError
from .polish import TINY, VELOCITY_RESIDUAL_MAX, kkt_residual, polish_cone_qp, roundoff_floor
from .program import ConeQP

#: default conic tolerance (gap and feasibility, on the scaled problem)
DEFAULT_TOL = 1e-10
#: default interior-point iteration limit
DEFAULT_MAX_ITER = 200
#: largest relative KKT residual accepted from a conic solve (or 1e3 x its tolerance)
KKT_ACCEPT = 1e-6


@dataclass(frozen=True)
class QPSolution:
    """Answer of a backend: the minimizer and the solver's own report."""

    x: np.ndarray
    status: str
    iterations: int
    solve_time: float = float("nan")
    polished: bool = False
    kkt_residual: float = float("nan")
    converged: bool = True  # False: the solver stopped short (e.g. AlmostSolved)


class Backend(Protocol):
    """A conic solver for :class:`ConeQP` (compiled/built once per structure, then updated)."""

    name: str

    def solve(self, qp: ConeQP, tol: float, max_iter: int) -> QPSolution:
        """Solve a *scaled* QP (entries of order one); raise SolverError when it fails."""
        ...


def equilibrated(qp: ConeQP) -> tuple[ConeQP, np.ndarray] | None:
    """The program in unit-size variables, and the scale s of its unknowns (``pi = s * y``).

    Per contact, ``pi_i = c_i y_i`` with ``c_i = 1 / sqrt(max diag W_ii)`` (a uniform scaling
    of the contact's rows keeps its cone K_mu), so every contact's block of ``D W D`` has a
    unit diagonal however far apart the contacts' effective masses are (a light link next to
    a heavy body); then ``y = alpha z``, ``alpha = s_q / s_W`` (s_W = max |(D W D)_ij|,
    s_q = max(|D q|, |f|)) and ``(E D / s_E) z = f s_W / (s_q s_E)`` (s_E = max |(E D)_ij|),
    so the solver's absolute tolerances act as relative ones. None when the program is
    trivial (q = 0 and f = 0: z = 0).

    Raises
    ------
    SolverError
        when W is zero (no contact moves any mass).
    """
    d, n = qp.dim, qp.n_contacts
    diag = np.diag(qp.W).reshape(n, d).max(axis=1) if qp.W.size else np.zeros(n)
    c = np.where(diag > 0.0, 1.0 / np.sqrt(np.where(diag > 0.0, diag, 1.0)), 1.0)
    D = np.repeat(c, d)
    W = D[:, None] * qp.W * D[None, :]
    q = D * qp.q
    E = qp.E * D[None, :]
    sW = float(np.max(np.abs(W))) if W.size else 0.0
    sq = max(float(np.max(np.abs(q), initial=0.0)), float(np.max(np.abs(qp.f), initial=0.0)))
    if not sW > 0.0:
        raise SolverError("the Delassus matrix is zero: no contact moves any mass")
    if sq == 0.0:
        return None
    sE = max(float(np.max(np.abs(E), initial=0.0)), TINY) if E.size else 1.0
    scaled = ConeQP(W / sW, q / sq, qp.mu, qp.dim, E / sE, qp.f * (sW / (sq * sE)))
    return scaled, D * (sq / sW)


def solve_cone_qp(backend: Backend, qp: ConeQP, tol: float = DEFAULT_TOL,
                  max_iter: int = DEFAULT_MAX_ITER, polish: bool = True) -> QPSolution:
    """Equilibrate a cone QP (:func:`equilibrated`), solve it with ``backend``, scale back.

    With ``polish`` the answer is refined by :func:`polish_cone_qp` (Newton on the KKT
    equations of its active set, every active set when the interior-point answer is too
    rough to classify). An answer the solver flagged as inaccurate (``AlmostSolved``) is
    accepted only when the polish certifies it; otherwise, and for every other failure,
    SolverError names the status. Without equality rows the answer must also pass the
    relative KKT test (:func:`~convimpact.impact.conic.polish.kkt_residual` at most
    max(KKT_ACCEPT, 1e3 tol), or 1e3 times its round-off floor -- cond(W) eps -- capped at
    :data:`~convimpact.impact.conic.polish.VELOCITY_RESIDUAL_MAX`).
    """
    eq = equilibrated(qp)
    if eq is None:
        return QPSolution(np.zeros_like(qp.q), "trivial", 0, 0.0, True, 0.0)
    scaled, s = eq
    sol = backend.solve(scaled, tol, max_iter)
    x, polished = sol.x, False
    if polish:
        x, polished = polish_cone_qp(scaled, sol.x)
    if not (sol.converged or polished):
        # an answer the solver itself did not certify is used only when the KKT polish
        # certifies it (residual at round-off on a consistent active set)
        raise SolverError(status_message(sol.status) + f" (method={backend.name!r})")
    kkt = kkt_residual(scaled, x)
    # round-off of an ill-conditioned W excuses up to VELOCITY_RESIDUAL_MAX, never more
    floor = min(1e3 * roundoff_floor(scaled, x), VELOCITY_RESIDUAL_MAX)
    if qp.E.size == 0 and not kkt <= max(KKT_ACCEPT, 1e3 * tol, floor):
        # a status of "optimal" is not enough: on an unbounded program some front ends return
        # a huge iterate marked converged; without equality rows the KKT residual is exact
        # (no multiplier fit), so it tells. (P_N, with equalities, is refined and checked by
        # its own law afterwards.)
        raise SolverError(
            f"the {backend.name} solver reported {sol.status!r} but its answer violates the "
            f"optimality conditions (relative KKT residual {kkt:.2e}): the program is probably "
            "unbounded (no impulse in the friction cones can satisfy the law, e.g. a rigid "
            "pinch) or badly scaled; try law='coulomb' or 'dissipative', or method='clarabel'")
    return QPSolution(x * s, sol.status, sol.iterations, sol.solve_time, polished,
                      kkt, sol.converged)


def status_message(status: str) -> str:
    s = status.lower()
    if "infeasible" in s and "dual" not in s and "unbounded" not in s:
        hint = ("the constraints admit no impulse in the friction cone (Newton's equalities "
                "cannot all hold with compressive impulses, or a Painleve-like jam): use "
                "law='coulomb', 'ccp' or 'dissipative'")
    elif "unbounded" in s or "dual" in s:
        hint = ("the objective is unbounded below over the cone: contacts oppose each other "
                "through a mechanism-free direction (W singular with a rigid pinch) and the "
                "restitution terms differ; use equal e on opposing contacts or law='dissipative'")
    else:
        hint = ("the interior-point method did not reach the tolerance: loosen tol (option "
                "'tol'), raise 'max_iter', or check the conditioning of the Delassus matrix")
    return f"conic solver status {status!r}: {hint}"
