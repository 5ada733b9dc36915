"""The four impact laws as convex programs over the friction cone; the cvxpy solver path.

Every law is posed in contact space on the data of :class:`~convimpact.impact.problem.ImpactProblem`:
the Delassus matrix ``W`` (loops already eliminated, so ``C theta_dot+ = 0`` holds by
construction and ``Delta sigma`` is recovered by ``ImpactProblem.velocity_jump``), the
pre-impact velocities ``v-`` and ``e``, ``mu`` per contact. With ``pi = (pi_1, ..., pi_n)``,
``pi_i = (pi_n, pi_t)``, ``K_mu = {|pi_t| <= mu pi_n}`` and ``v+ = v- + W pi``, each law reduces
to one or several instances of the *cone QP*

    minimize 1/2 pi^T W pi + q^T pi   subject to   E pi = f,   pi_i in K_mu_i,

solved by a *backend* (:class:`CvxpyBackend` here, ``ClarabelBackend`` in
:mod:`convimpact.impact.conic.clarabel_backend`). A frictionless contact (mu_i = 0) is posed as
``pi_n >= 0, pi_t = 0`` rather than as a degenerate cone.

The laws (``law=``):

``"pereira-nikravesh"`` (Section 8)
    Stick test first: ``W_AA pi_A = -b_A`` with ``b = ((1+e) v_n-, v_t-)`` over the
    approaching contacts A (v_n- < 0), accepted when every impulse lies in its cone
    (eq. 53). Otherwise slide: one planar contact uses eq. (55) exactly as the closed form;
    in space and with several contacts the program P_N: minimize T+ (``q = v-``) subject to
    ``v_n+ = -e v_n-`` on the approaching contacts and ``pi in K_mu``. Where P_N's optimum lies
    on the cone boundary its tangent is the seed's maximal-dissipation direction (eq. 60); for
    one contact the angle is then polished by a bounded 1-D maximization of T_L. P_N's
    *interior* optimum is not sticking when e > 0, so where it is interior but the stick test
    failed one contact falls back to :func:`convimpact.impact.sweep.max_dissipation_direction` and the
    disagreement is flagged (several contacts: flagged only). Contacts with v_n- >= 0 take no
    impulse under this law (the seed's law is defined for approaching contacts); if the others'
    impulses would drive one of them into penetration (v_n+ < 0) a NotSupportedError names the
    complementarity laws. Infeasible P_N (a Painleve-like jam for one contact, incompatible
    Newton equalities for several) raises NonPositiveEffectiveMassError / SolverError.
``"coulomb"``
    Newton restitution and Coulomb friction opposing the post-impact slip (Moreau): with
    ``u = v+ + e min(v_n-, 0) n``, ``K_mu ∋ pi ⊥ u + mu |u_t| n ∈ K_mu*``. Solved as a fixed
    point over CCP programs with the shift ``s_i = mu_i |u_t,i|`` added to ``q_n`` (Anderson
    accelerated, safeguarded by damping), each iterate seeding an active-set Newton solve of
    Coulomb's conditions; one contact is finished (or rescued) by an exact single-contact
    solve. The final complementarity residual is checked: a SolverError, never a silently
    wrong answer. Contacts with v_n- >= 0 take part with complementarity (they may separate).
``"ccp"``
    Anitescu's relaxation: minimize 1/2 pi^T W pi + pi^T b over K_mu, ``b = v- + e min(v_n-, 0) n``.
    Exact when sticking; when sliding, ``v_n+`` is lifted by ``mu |v_t+|`` above Newton's value,
    reported as ``extras["normal_velocity_lift"]``. Non-approaching contacts take part with
    their normal only (b = v- there, pi_t = 0): they may be pressed by the others, never
    kicked along their slip.
``"dissipative"``
    The plastic maximal-dissipation impact (ccp with e = 0: minimize T+ over K_mu), its impulse
    scaled by (1 + e_i) per contact (Poisson). With one common e the energy loss is exactly
    ``1/2 (1 - e^2) pi_p^T W pi_p >= 0`` (complementarity gives ``pi_p^T v+_p = 0``). With
    *different* e per contact the loss is ``1/2 |pi_p|_W^2 - 1/2 |E pi_p|_W^2`` (E = diag(e)),
    which can be negative when contacts couple; the diagnostics then flag the energy gain.

Accuracy. Every program is scaled to unit data, solved by the interior-point method, and then
*polished*: each contact is classified (zero, interior, on the cone boundary) and the KKT
equations of that active set are solved by Newton's method (:func:`polish_cone_qp`); the
polish is kept only when its active set is consistent. Polished answers are exact to
round-off (measured KKT residuals 1e-16 .. 1e-14); raw interior-point impulses on the cone
boundary are only accurate to about sqrt(tol) (1e-5 at Clarabel's default 1e-8, 1e-6 at
1e-10), which is what the results then claim (``extras["polished"]``, ``"kkt_residual"``).

Options of both conic paths (keyword arguments of ``resolve_impact``): ``tol`` (the conic
solver's gap and feasibility tolerance on the scaled problem, default 1e-10), ``max_iter``
(interior-point iterations, default 200) and, for ``"coulomb"``, ``fixed_point_tol`` (default
1e-9 relative), ``max_fixed_point_iter`` (default 100), ``anderson_memory`` (default 5).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from typing import Any, Callable, Protocol

import numpy as np

from ..laws.pereira_nikravesh import (
    DELASSUS_COND_MAX,
    pereira_nikravesh as _pn_closed_form,
    sliding_impulse,
    stick_admissible,
)
from ..diagnostics import assemble_result
from ..errors import (
    NonPositiveEffectiveMassError,
    NotSupportedError,
    SolverError,
    UnknownOptionError,
    ParameterError,
)
from ..resolve import register_solver
from ..problem import ImpactProblem
from ..results import ImpactResult

#: default conic tolerance (gap and feasibility, on the scaled problem)
DEFAULT_TOL = 1e-10
#: default interior-point iteration limit
DEFAULT_MAX_ITER = 200
#: default relative tolerance of the Coulomb fixed point and of its complementarity check
DEFAULT_FIXED_POINT_TOL = 1e-9
DEFAULT_MAX_FIXED_POINT_ITER = 100
DEFAULT_ANDERSON_MEMORY = 5
#: relative distance from the cone boundary below which a P_N optimum counts as "on it"
BOUNDARY_RTOL = 1e-5
_TINY = 1e-300


# --------------------------------------------------------------------------------------------
# the cone QP and its backends


@dataclass(frozen=True, eq=False)
class ConeQP:
    """``minimize 1/2 x^T W x + q^T x  s.t.  E x = f,  x_i in K_mu_i`` in contact space.

    Attributes
    ----------
    W : (N, N) symmetric positive semidefinite, N = n_contacts d.
    q : (N,) linear term.
    mu : (n_contacts,) friction coefficients; mu_i = 0 poses pi_n >= 0, pi_t = 0.
    dim : d, 2 (planar) or 3 (spatial).
    E, f : (m, N), (m,) equality constraints (m may be 0).
    """

    W: np.ndarray
    q: np.ndarray
    mu: np.ndarray
    dim: int
    E: np.ndarray
    f: np.ndarray

    @property
    def n_contacts(self) -> int:
        return self.mu.shape[0]

    @property
    def structure(self) -> tuple:
        """What fixes the compiled program: sizes, which contacts are frictionless, m."""
        return (self.n_contacts, self.dim, tuple(bool(m == 0.0) for m in self.mu),
                self.E.shape[0])


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


def solve_cone_qp(backend: Backend, qp: ConeQP, tol: float = DEFAULT_TOL,
                  max_iter: int = DEFAULT_MAX_ITER, polish: bool = True) -> QPSolution:
    """Scale a cone QP to unit data, solve it with ``backend``, scale the answer back.

    With ``x = alpha y``, ``alpha = s_q / s_W`` (s_W = max |W_ij|, s_q = max(|q|, |f|)), the scaled
    program has ``W / s_W``, ``q / s_q`` and ``(E / s_E) y = f s_W / (s_q s_E)`` (s_E = max |E_ij|),
    so the solver's absolute tolerances act as relative ones. With ``polish`` the answer is
    refined by :func:`polish_cone_qp` (Newton on the KKT equations of its active set). An
    answer the solver flagged as inaccurate (``AlmostSolved``) is accepted only when the polish
    certifies it; otherwise, and for every other failure, SolverError names the status.
    """
    sW = float(np.max(np.abs(qp.W))) if qp.W.size else 0.0
    sq = max(float(np.max(np.abs(qp.q), initial=0.0)), float(np.max(np.abs(qp.f), initial=0.0)))
    if not sW > 0.0:
        raise SolverError("the Delassus matrix is zero: no contact moves any mass")
    if sq == 0.0:
        return QPSolution(np.zeros_like(qp.q), "trivial", 0, 0.0, True, 0.0)
    sE = max(float(np.max(np.abs(qp.E), initial=0.0)), _TINY) if qp.E.size else 1.0
    scaled = ConeQP(qp.W / sW, qp.q / sq, qp.mu, qp.dim, qp.E / sE, qp.f * (sW / (sq * sE)))
    sol = backend.solve(scaled, tol, max_iter)
    x, polished = sol.x, False
    if polish:
        x, polished = polish_cone_qp(scaled, sol.x)
    if not (sol.converged or polished):
        # an answer the solver itself did not certify is used only when the KKT polish
        # certifies it (residual at round-off on a consistent active set)
        raise SolverError(_status_message(sol.status) + f" (method={backend.name!r})")
    kkt = kkt_residual(scaled, x)
    if qp.E.size == 0 and not kkt <= max(KKT_ACCEPT, 1e3 * tol):
        # a status of "optimal" is not enough: on an unbounded program some front ends return
        # a huge iterate marked converged; without equality rows the KKT residual is exact
        # (no multiplier fit), so it tells. (P_N, with equalities, is refined and checked by
        # its own law afterwards.)
        raise SolverError(
            f"the {backend.name} solver reported {sol.status!r} but its answer violates the "
            f"optimality conditions (relative KKT residual {kkt:.2e}): the program is probably "
            "unbounded (no impulse in the friction cones can satisfy the law, e.g. a rigid "
            "pinch) or badly scaled; try law='coulomb' or 'dissipative', or method='clarabel'")
    return QPSolution(x * (sq / sW), sol.status, sol.iterations, sol.solve_time, polished,
                      kkt, sol.converged)


#: largest relative KKT residual accepted from a conic solve (or 1e3 x its tolerance)
KKT_ACCEPT = 1e-6
#: relative thresholds that classify a conic solution's contacts for the polish
POLISH_ZERO_RTOL = 1e-4
POLISH_BOUNDARY_RTOL = 1e-4
POLISH_MAX_NEWTON = 12


def _classify(qp: ConeQP, x: np.ndarray) -> list[str]:
    d = qp.dim
    X = max(float(np.max(np.abs(x))), _TINY)
    kinds = []
    for i, mu in enumerate(qp.mu):
        xi = x[i * d:(i + 1) * d]
        if np.linalg.norm(xi) <= POLISH_ZERO_RTOL * X or xi[0] <= 0.0:
            kinds.append("zero")
        elif mu == 0.0:
            kinds.append("act")
        elif mu * xi[0] - np.linalg.norm(xi[1:]) <= POLISH_BOUNDARY_RTOL * np.linalg.norm(xi):
            kinds.append("bnd")
        else:
            kinds.append("int")
    return kinds


def polish_cone_qp(qp: ConeQP, x0: np.ndarray, coulomb: bool = False) -> tuple[np.ndarray, bool]:
    """Newton refinement of an interior-point answer on its active set (KKT equations).

    Each contact is classified from ``x0`` as zero, interior, on the cone boundary, or (when
    frictionless) active; the KKT system ``W x + q - E^T lambda - z = 0``, ``E x = f`` is then
    solved by Newton's method with ``x_i = r (1, mu c)``, ``z_i = kappa (mu, -c)`` on boundary
    contacts (c a unit tangent: the complementary pair of K_mu and its dual), ``z_i = 0`` on
    interior ones and ``x_i = 0`` on zero ones. The answer is kept only when it is consistent
    (r > 0, kappa >= 0, interior points strictly inside, zero contacts' z in K*) and close to
    ``x0``; otherwise ``x0`` is returned unchanged.

    With ``coulomb=True`` the same active-set Newton solves Coulomb's law instead of the cone
    QP's KKT system (E must be empty): ``u = W x + q`` with ``u_i = 0`` (stick),
    ``u_i = kappa (0, -c)`` on sliding contacts (no normal lift) and ``u_n >= 0`` on zero ones.

    Returns
    -------
    x, polished (True when the refinement was accepted)
    """
    d, n, m = qp.dim, qp.n_contacts, qp.E.shape[0]
    N = n * d
    kinds = _classify(qp, x0)
    # unknown layout
    slots: list[tuple[int, int]] = []
    u0: list[float] = []
    for i, k in enumerate(kinds):
        xi = x0[i * d:(i + 1) * d]
        start = len(u0)
        if k == "int":
            u0 += list(xi)
        elif k == "act":
            u0.append(xi[0])
        elif k == "bnd":
            # kappa estimate from the stationarity residual
            g = qp.W[i * d:(i + 1) * d] @ x0 + qp.q[i * d:(i + 1) * d]
            if coulomb:
                tdir = xi[1:] / max(np.linalg.norm(xi[1:]), _TINY)
                kap = max(-float(g[1:] @ tdir), 0.0)
            else:
                kap = max(float(g[0]) / qp.mu[i], 0.0)
            if d == 3:
                u0 += [xi[0], math.atan2(xi[2], xi[1]), kap]
            else:
                u0 += [xi[0], kap]
        slots.append((start, len(u0)))
    n_prim = len(u0)
    if m:
        Eact = qp.E
        lam0, *_ = np.linalg.lstsq(Eact.T, qp.W @ x0 + qp.q, rcond=None)
        u0 += list(lam0)
    u = np.array(u0, dtype=float)
    sign = [float(np.sign(x0[i * d + 1])) or 1.0 for i in range(n)] if d == 2 else None
    U = u.size
    if U == 0:
        return np.zeros(N), True

    def unpack(u):
        x = np.zeros(N)
        z = np.zeros(N)
        Jx = np.zeros((N, U))
        Jz = np.zeros((N, U))
        for i, k in enumerate(kinds):
            s, e_ = slots[i]
            o = i * d
            mu = qp.mu[i]
            zn = 0.0 if coulomb else mu
            if k == "int":
                x[o:o + d] = u[s:e_]
                Jx[o:o + d, s:e_] = np.eye(d)
            elif k == "act":
                x[o] = u[s]
                Jx[o, s] = 1.0
            elif k == "bnd":
                if d == 3:
                    r, a, kap = u[s:e_]
                    c, sn = math.cos(a), math.sin(a)
                    x[o:o + 3] = r * np.array([1.0, mu * c, mu * sn])
                    Jx[o:o + 3, s] = [1.0, mu * c, mu * sn]
                    Jx[o:o + 3, s + 1] = [0.0, -r * mu * sn, r * mu * c]
                    z[o:o + 3] = kap * np.array([zn, -c, -sn])
                    Jz[o:o + 3, s + 1] = [0.0, kap * sn, -kap * c]
                    Jz[o:o + 3, s + 2] = [zn, -c, -sn]
                else:
                    r, kap = u[s:e_]
                    sg = sign[i]
                    x[o:o + 2] = r * np.array([1.0, mu * sg])
                    Jx[o:o + 2, s] = [1.0, mu * sg]
                    z[o:o + 2] = kap * np.array([zn, -sg])
                    Jz[o:o + 2, s + 1] = [zn, -sg]
        return x, z, Jx, Jz

    eq_rows = np.zeros(N, dtype=bool)
    for i, k in enumerate(kinds):
        if k in ("int", "bnd"):
            eq_rows[i * d:(i + 1) * d] = True
        elif k == "act":
            eq_rows[i * d] = True
    Jlam = np.zeros((m, U))
    Jlam[:, n_prim:] = np.eye(m)

    def residual(u):
        x, z, Jx, Jz = unpack(u)
        lam = u[n_prim:]
        G = qp.W @ x + qp.q - qp.E.T @ lam - z
        dG = qp.W @ Jx - qp.E.T @ Jlam - Jz
        F = np.concatenate([G[eq_rows], qp.E @ x - qp.f])
        J = np.vstack([dG[eq_rows], qp.E @ Jx])
        return F, J, x, G

    best = None
    f0 = None
    for it in range(POLISH_MAX_NEWTON):
        F, J, x, G = residual(u)
        fn = float(np.max(np.abs(F), initial=0.0))
        f0 = fn if f0 is None else f0
        if best is None or fn < best[0]:
            best = (fn, u.copy())
        if fn <= 1e-14 or (it >= 4 and best[0] > 1e-6 * f0):
            break  # converged, or not converging quadratically: wrong active set
        # minimum-norm Newton step: the KKT Jacobian is singular when contacts are redundant
        step, *_ = np.linalg.lstsq(J, -F, rcond=1e-13)
        u = u + step
    F, J, x, G = residual(best[1])
    u = best[1]
    if not float(np.max(np.abs(F), initial=0.0)) <= 1e-11:
        return x0, False
    # consistency of the active set
    X = max(float(np.max(np.abs(x0))), _TINY)
    for i, k in enumerate(kinds):
        s, e_ = slots[i]
        xi, gi, mu = x[i * d:(i + 1) * d], G[i * d:(i + 1) * d], qp.mu[i]
        if k == "zero":
            if mu == 0.0 or coulomb:
                if gi[0] < -1e-10:
                    return x0, False
            elif mu * np.linalg.norm(gi[1:]) > gi[0] + 1e-10:
                return x0, False
        elif k == "act" and xi[0] < 0.0:
            return x0, False
        elif k == "int" and not np.linalg.norm(xi[1:]) < mu * xi[0]:
            return x0, False
        elif k == "bnd" and not (u[s] > 0.0 and u[e_ - 1] >= -1e-12):
            return x0, False
    if np.max(np.abs(x - x0)) > 1e-2 * X:
        return x0, False
    return x, True


def kkt_residual(qp: ConeQP, x: np.ndarray) -> float:
    """Relative KKT residual of a cone-QP answer (on scaled, unit-size data).

    The multipliers of ``E x = f`` are fitted by least squares on the rows where the cone
    leaves the stationarity free of a dual (interior and frictionless-normal rows, or all
    rows when there are none); then ``z = W x + q - E^T lambda`` and the residual is the max of
    |E x - f|, the cone violation of x, the dual-cone violation of z and |x_i . z_i|.
    """
    d, n, m = qp.dim, qp.n_contacts, qp.E.shape[0]
    g = qp.W @ x + qp.q
    lam = np.zeros(m)
    if m:
        rows = np.zeros(n * d, dtype=bool)
        for i, k in enumerate(_classify(qp, x)):
            if k == "int":
                rows[i * d:(i + 1) * d] = True
            elif k == "act":
                rows[i * d] = True
        if rows.sum() < m:
            rows[:] = True
        lam, *_ = np.linalg.lstsq(qp.E.T[rows], g[rows], rcond=None)
    z = g - qp.E.T @ lam
    r = float(np.max(np.abs(qp.E @ x - qp.f), initial=0.0))
    for i, mu in enumerate(qp.mu):
        xi, zi = x[i * d:(i + 1) * d], z[i * d:(i + 1) * d]
        if mu == 0.0:
            r = max(r, max(0.0, -xi[0]), float(np.max(np.abs(xi[1:]))), max(0.0, -zi[0]),
                    abs(xi[0] * zi[0]))
        else:
            r = max(r, max(0.0, np.linalg.norm(xi[1:]) - mu * xi[0]),
                    max(0.0, mu * np.linalg.norm(zi[1:]) - zi[0]), abs(float(xi @ zi)))
    return r


def psd_factor(W: np.ndarray) -> np.ndarray:
    """A square factor F with ``F^T F = W`` for a symmetric PSD (possibly singular) W.

    Eigendecomposition with eigenvalues clipped at zero: robust when contacts are redundant
    (W singular) and round-off makes tiny eigenvalues negative.
    """
    lam, Q = np.linalg.eigh(0.5 * (W + W.T))
    return (np.sqrt(np.clip(lam, 0.0, None))[:, None] * Q.T)


class CvxpyBackend:
    """cvxpy + Clarabel, one DPP program compiled per structure and re-solved with Parameters.

    The quadratic term is ``1/2 sum_squares(F x)`` with F a Parameter (``quad_form`` with a
    parametric matrix passes ``is_dpp`` yet recompiles on every call).
    """

    name = "cvxpy"

    def __init__(self) -> None:
        self._programs: dict[tuple, tuple] = {}

    def _program(self, structure: tuple):
        prog = self._programs.get(structure)
        if prog is not None:
            return prog
        import cvxpy as cp

        n, d, frictionless, m = structure
        N = n * d
        x = cp.Variable(N)
        F = cp.Parameter((N, N))
        q = cp.Parameter(N)
        n_fric = sum(not f for f in frictionless)
        mu = cp.Parameter(n_fric, nonneg=True) if n_fric else None
        cons = []
        k = 0
        for i in range(n):
            if frictionless[i]:
                cons += [x[i * d] >= 0, x[i * d + 1:(i + 1) * d] == 0]
            else:
                cons.append(cp.SOC(mu[k] * x[i * d], x[i * d + 1:(i + 1) * d]))
                k += 1
        E = f = None
        if m:
            E = cp.Parameter((m, N))
            f = cp.Parameter(m)
            cons.append(E @ x == f)
        problem = cp.Problem(cp.Minimize(0.5 * cp.sum_squares(F @ x) + q @ x), cons)
        if not problem.is_dpp():  # pragma: no cover - structural guarantee
            raise SolverError("internal: the cone QP is not DPP")
        prog = (problem, x, F, q, mu, E, f)
        self._programs[structure] = prog
        return prog

    def solve(self, qp: ConeQP, tol: float, max_iter: int) -> QPSolution:
        import cvxpy as cp

        problem, x, F, q, mu, E, f = self._program(qp.structure)
        F.value = psd_factor(qp.W)
        q.value = qp.q
        if mu is not None:
            mu.value = qp.mu[qp.mu != 0.0]
        if E is not None:
            E.value = qp.E
            f.value = qp.f
        try:
            with warnings.catch_warnings():
                # "may be inaccurate": such answers are used only when the KKT polish of
                # solve_cone_qp certifies them, otherwise SolverError reports the status
                warnings.simplefilter("ignore", UserWarning)
                problem.solve(solver=cp.CLARABEL, tol_gap_abs=tol, tol_gap_rel=tol, tol_feas=tol,
                              tol_ktratio=1e-3 * tol ** 0.5, max_iter=max_iter)
        except cp.error.SolverError as exc:
            raise SolverError(f"cvxpy/Clarabel failed on the impact program: {exc}") from exc
        status = str(problem.status)
        stats = problem.solver_stats
        iters = int(stats.num_iters) if stats is not None and stats.num_iters is not None else -1
        if status not in (cp.OPTIMAL, cp.OPTIMAL_INACCURATE) or x.value is None:
            raise SolverError(_status_message(status))
        t = float(stats.solve_time) if stats is not None and stats.solve_time else float("nan")
        return QPSolution(np.array(x.value, dtype=float), status, iters, t,
                          converged=status == cp.OPTIMAL)


def _status_message(status: str) -> str:
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


# --------------------------------------------------------------------------------------------
# options


@dataclass(frozen=True)
class ProgramOptions:
    """Validated options of the conic solver paths (see the module docstring)."""

    tol: float = DEFAULT_TOL
    max_iter: int = DEFAULT_MAX_ITER
    fixed_point_tol: float = DEFAULT_FIXED_POINT_TOL
    max_fixed_point_iter: int = DEFAULT_MAX_FIXED_POINT_ITER
    anderson_memory: int = DEFAULT_ANDERSON_MEMORY

    def accuracy(self, polished: bool) -> float:
        """Relative accuracy claimed for impulses (the ``tol`` passed to assemble_result).

        Polished answers (Newton on the KKT equations) are accurate to round-off, claimed 1e-9;
        raw interior-point answers on the cone boundary to about sqrt(tol) (measured:
        1e-6 at tol = 1e-10), claimed 10 sqrt(tol).
        """
        return 1e-9 if polished else 10.0 * math.sqrt(self.tol)


def parse_options(method: str, options: dict) -> ProgramOptions:
    """Validate the keyword options of a conic path; unknown names raise UnknownOptionError."""
    known = ProgramOptions.__dataclass_fields__
    unknown = sorted(set(options) - set(known))
    if unknown:
        raise UnknownOptionError(
            f"method {method!r} does not know option(s) {', '.join(unknown)}; "
            f"it accepts {', '.join(known)}")
    out = ProgramOptions(**options)
    for name in ("tol", "fixed_point_tol"):
        v = getattr(out, name)
        if not (isinstance(v, (int, float)) and math.isfinite(v) and 0.0 < v < 1.0):
            raise ParameterError(f"option {name} must be a number in (0, 1), got {v!r}")
    for name in ("max_iter", "max_fixed_point_iter", "anderson_memory"):
        v = getattr(out, name)
        if not (isinstance(v, (int, np.integer)) and v >= (0 if name == "anderson_memory" else 1)):
            raise ParameterError(f"option {name} must be a positive integer, got {v!r}")
    return out


# --------------------------------------------------------------------------------------------
# helpers shared by the laws


def _normal_mask(n: int, d: int) -> np.ndarray:
    m = np.zeros(n * d, dtype=bool)
    m[::d] = True
    return m


def _newton_shift(P: ImpactProblem) -> np.ndarray:
    """``b - v- = e min(v_n-, 0) n`` per contact, flattened."""
    s = np.zeros((P.n_contacts, P.dim))
    s[:, 0] = P.restitution * np.minimum(P.v_minus[:, 0], 0.0)
    return s.ravel()


def _pi_scale(P: ImpactProblem) -> float:
    """Impulse scale |v-| / max|W| for relative thresholds."""
    return max(float(np.max(np.abs(P.v_minus))), _TINY) / max(float(np.max(np.abs(P.delassus))),
                                                              _TINY)


def _regimes_from_slip(P: ImpactProblem, pi: np.ndarray, vplus: np.ndarray,
                       tol: float) -> list[str]:
    """Regime per contact from the impulse and the (law's own) post-impact slip."""
    pscale = _pi_scale(P)
    vscale = max(float(np.max(np.abs(P.v_minus))), _TINY)
    out = []
    for i in range(P.n_contacts):
        if pi[i, 0] <= tol * pscale:
            out.append("separating")
        elif P.friction[i] == 0.0:
            out.append("frictionless")
        elif np.linalg.norm(vplus[i, 1:]) <= 10 * tol * vscale:
            out.append("stick")
        else:
            out.append("slide")
    return out


def _cone_qp(P: ImpactProblem, q: np.ndarray, E=None, f=None, mu=None) -> ConeQP:
    N = P.n_contacts * P.dim
    E = np.zeros((0, N)) if E is None else E
    f = np.zeros(0) if f is None else f
    return ConeQP(P.delassus, q, P.friction if mu is None else mu, P.dim, E, f)


def coulomb_residual(W: np.ndarray, b: np.ndarray, mu: np.ndarray, d: int,
                     pi: np.ndarray) -> float:
    """Relative residual of ``K ∋ pi ⊥ y = u + mu |u_t| n ∈ K*`` with ``u = W pi + b``.

    Max of the cone violation of pi, the dual-cone violation of y and the per-contact
    complementarity |pi_i . y_i|, each relative to |pi| and |b|.
    """
    n = mu.shape[0]
    x = pi.reshape(n, d)
    u = (W @ pi + b).reshape(n, d)
    y = u.copy()
    y[:, 0] += mu * np.linalg.norm(u[:, 1:], axis=1)
    ps = max(float(np.linalg.norm(pi)), _TINY)
    vs = max(float(np.linalg.norm(b)), float(np.max(np.abs(W))) * ps, _TINY)
    r = 0.0
    for i in range(n):
        r = max(r, max(0.0, np.linalg.norm(x[i, 1:]) - mu[i] * x[i, 0], -x[i, 0]) / ps)
        if mu[i] == 0.0:
            r = max(r, max(0.0, -y[i, 0]) / vs, np.linalg.norm(x[i, 1:]) / ps)
            r = max(r, abs(x[i, 0] * y[i, 0]) / (ps * vs))
        else:
            # y_n carries mu |u_t|: measure against mu-scaled velocities, so round-off in u_t
            # is not magnified by a large mu into a false failure
            vsi = vs * max(1.0, float(mu[i]))
            r = max(r, max(0.0, mu[i] * np.linalg.norm(y[i, 1:]) - y[i, 0]) / vsi)
            r = max(r, abs(float(x[i] @ y[i])) / (ps * vsi))
    return float(r)


# --------------------------------------------------------------------------------------------
# law: ccp and dissipative


def solve_ccp(P: ImpactProblem, backend: Backend, opts: ProgramOptions,
              restitution: np.ndarray | None = None) -> tuple[np.ndarray, QPSolution]:
    """Anitescu's program: minimize 1/2 pi^T W pi + pi^T b over K_mu, b = v- + e min(v_n-,0) n.

    Returns the impulse (n_contacts, d) and the backend's report.
    """
    e = P.restitution if restitution is None else restitution
    s = np.zeros((P.n_contacts, P.dim))
    s[:, 0] = e * np.minimum(P.v_minus[:, 0], 0.0)
    b = P.v_minus.ravel() + s.ravel()
    # a contact that is not approaching takes no friction impulse of its own: it enters with
    # its normal only (pi_t = 0), so it may be pressed by the others but is never kicked
    # along its slip (the single-contact rule "not approaching: no impulse")
    mu = np.where(P.v_minus[:, 0] < 0.0, P.friction, 0.0)
    sol = solve_cone_qp(backend, _cone_qp(P, b, mu=mu), opts.tol, opts.max_iter)
    return sol.x.reshape(P.n_contacts, P.dim), sol


def _ccp_result(P: ImpactProblem, backend: Backend, method: str,
                opts: ProgramOptions) -> ImpactResult:
    pi, sol = solve_ccp(P, backend, opts)
    vplus = P.v_minus + (P.delassus @ pi.ravel()).reshape(P.n_contacts, P.dim)
    newton = -P.restitution * np.minimum(P.v_minus[:, 0], 0.0)
    lift = vplus[:, 0] - newton  # = mu |v_t+| where pi_n > 0 (complementarity)
    slip = np.linalg.norm(vplus[:, 1:], axis=1)
    extras = {
        "normal_velocity_lift": lift.tolist(),
        "mu_times_slip": (P.friction * slip).tolist(),
        "solver_status": sol.status,
        "iterations": sol.iterations,
        "tolerance": opts.tol,
        "polished": sol.polished,
        "kkt_residual": sol.kkt_residual,
    }
    acc = opts.accuracy(sol.polished)
    regimes = _regimes_from_slip(P, pi, vplus, acc)
    return assemble_result(P, pi, regimes, "ccp", method, tol=acc, extras=extras)


def _dissipative_result(P: ImpactProblem, backend: Backend, method: str,
                        opts: ProgramOptions) -> ImpactResult:
    plastic, sol = solve_ccp(P, backend, opts, restitution=np.zeros(P.n_contacts))
    pi = plastic * (1.0 + P.restitution)[:, None]  # Poisson's hypothesis
    flat = plastic.ravel()
    W = P.delassus
    Ep = (plastic * P.restitution[:, None]).ravel()
    predicted = 0.5 * float(flat @ W @ flat) - 0.5 * float(Ep @ W @ Ep)
    vplus_plastic = P.v_minus + (W @ flat).reshape(P.n_contacts, P.dim)
    extras = {
        "plastic_impulse": plastic.tolist(),
        "plastic_energy_loss": 0.5 * float(flat @ W @ flat),
        "predicted_energy_loss": predicted,  # 1/2 (1 - e^2) pi_p^T W pi_p for a common e
        "plastic_normal_velocity_lift": vplus_plastic[:, 0].tolist(),
        "solver_status": sol.status,
        "iterations": sol.iterations,
        "tolerance": opts.tol,
        "polished": sol.polished,
        "kkt_residual": sol.kkt_residual,
    }
    acc = opts.accuracy(sol.polished)
    warnings = []
    if np.ptp(P.restitution) > 0 and predicted < 0:
        warnings.append("different e per contact: Poisson scaling of coupled contacts gains "
                        "energy here (1/2 |pi_p|_W^2 < 1/2 |E pi_p|_W^2)")
    if np.ptp(P.restitution) > 0:
        lam = np.linalg.eigvalsh(W)
        if not lam[0] > 1e-10 * lam[-1]:
            warnings.append(
                "different e per contact on a singular Delassus matrix: the plastic impulse is "
                "not unique, so the Poisson-scaled answer (theta_dot+) depends on which plastic "
                "impulse the solver found; use one e for coupled contacts")
    regimes = _regimes_from_slip(P, plastic, vplus_plastic, acc)
    return assemble_result(P, pi, regimes, "dissipative", method, tol=acc,
                           extras=extras, warnings=tuple(warnings))


# --------------------------------------------------------------------------------------------
# law: coulomb (fixed point over CCP programs)


def _single_contact_coulomb_candidates(W: np.ndarray, b: np.ndarray,
                                       mu: float) -> list[np.ndarray]:
    """Every solution of the one-contact Coulomb problem with b_n < 0 (exact, no iteration).

    Stick: ``pi = -W^-1 b`` when it lies in K_mu. Slide: ``pi = pi_n (1, mu d)`` with
    ``u_n = 0`` and ``u_t = -lambda d``, lambda >= 0; in space the direction angle solves the
    smooth trigonometric equation ``cross(g_n u_t, d) = 0`` (g = W (1, mu d)), found by sampling
    and bracketing (Brent) to machine precision.
    """
    d = W.shape[0]
    out: list[np.ndarray] = []
    if np.linalg.cond(W) < DELASSUS_COND_MAX:
        stick = np.linalg.solve(W, -b)
        if stick_admissible(stick, mu, rtol=1e-12):
            out.append(stick)
    if mu == 0.0:
        return out

    def slide(dirv: np.ndarray):
        g = np.concatenate(([1.0], mu * dirv))
        wg = W @ g
        if not wg[0] > 1e-14 * np.max(np.abs(W)):
            return None
        pn = -b[0] / wg[0]
        if pn <= 0:
            return None
        ut = pn * wg[1:] + b[1:]
        if float(ut @ dirv) > 1e-12 * max(np.linalg.norm(ut), _TINY) and \
                np.linalg.norm(ut) > 1e-13 * np.linalg.norm(b):
            return None
        return pn * g

    if d == 2:
        for s in (-1.0, 1.0):
            c = slide(np.array([s]))
            if c is not None:
                out.append(c)
        return out

    def h(a):
        c, s = np.cos(a), np.sin(a)
        g0 = W[:, 0][:, None] + mu * (W[:, 1][:, None] * c + W[:, 2][:, None] * s)
        ht = -b[0] * g0[1:] + g0[0] * b[1:, None]  # g_n u_t / pi_n ... times g_n
        return ht[0] * s - ht[1] * c

    grid = np.linspace(-np.pi, np.pi, 721)
    vals = h(grid)
    from scipy.optimize import brentq

    roots = []
    for k in range(grid.size - 1):
        a0, a1 = grid[k], grid[k + 1]
        if vals[k] == 0.0:
            roots.append(a0)
        elif vals[k] * vals[k + 1] < 0:
            roots.append(brentq(lambda a: float(h(np.array([a]))[0]), a0, a1, xtol=1e-15))
    for a in roots:
        c = slide(np.array([np.cos(a), np.sin(a)]))
        if c is not None:
            out.append(c)
    return out


def solve_coulomb(P: ImpactProblem, backend: Backend,
                  opts: ProgramOptions) -> tuple[np.ndarray, dict[str, Any]]:
    """Coulomb's law with Newton restitution by a fixed point over shifted CCP programs.

    The shift ``s_i = mu_i |u_t,i|`` (u = W pi + b) enters ``q_n``; the map ``s -> s(pi(s))`` is
    iterated with Anderson acceleration (memory ``anderson_memory``), safeguarded: when a step
    does not reduce the fixed-point residual the history is dropped and the mixing halved. If
    that pass fails, a second pass runs the plain iteration (up to ``max_fixed_point_iter``
    programs each).
    After every program the iterate's active set (stick / slide / separate per contact) is
    handed to an active-set Newton solve of Coulomb's conditions themselves
    (:func:`polish_cone_qp` with ``coulomb=True``); once that certifies a solution (residual at
    round-off, consistent active set) the iteration stops. This is what converges on the
    paper's Section 9.3 pendulum, where the plain fixed point does not. For one contact the
    answer is finished by the exact single-contact solve (the candidate nearest the iterate),
    which also rescues a fixed point that did not converge. When Coulomb's law has several
    solutions (large mu, several contacts) the one reached from the CCP start is returned.

    Returns
    -------
    impulse (n_contacts, d), info dict (iterations, residuals, how it was finished)
    """
    n, d = P.n_contacts, P.dim
    W = P.delassus
    b = P.v_minus.ravel() + _newton_shift(P)
    mu = P.friction
    fric = mu > 0.0
    nmask = _normal_mask(n, d)
    vscale = max(float(np.max(np.abs(P.v_minus))), _TINY)

    def solve_for(s: np.ndarray):
        q = b.copy()
        q[nmask] += s
        sol = solve_cone_qp(backend, _cone_qp(P, q), opts.tol, opts.max_iter)
        u = (W @ sol.x + b).reshape(n, d)
        return sol, mu * np.linalg.norm(u[:, 1:], axis=1)

    sW = max(float(np.max(np.abs(W))), _TINY)
    sb = max(float(np.max(np.abs(b))), _TINY)
    unit = ConeQP(W / sW, b / sb, mu, d, np.zeros((0, n * d)), np.zeros(0))
    iters = conic_iters = 0
    converged = polished = newton = False
    last_x = None
    res_norm = math.inf
    status = ""
    # first Anderson-accelerated and safeguarded (restart with halved mixing when the residual
    # does not drop), then, if that fails, the plain iteration, which is slower but reaches
    # active sets that the accelerated one jumps over
    for memory in ([opts.anderson_memory, 0] if opts.anderson_memory else [0]):
        s = np.zeros(n)
        hist_s: list[np.ndarray] = []
        hist_r: list[np.ndarray] = []
        prev = math.inf
        beta = 1.0  # mixing; halved whenever a step fails to reduce the residual
        for _ in range(opts.max_fixed_point_iter):
            sol, gs = solve_for(s)
            iters += 1
            conic_iters += max(sol.iterations, 0)
            status, last_x, polished = sol.status, sol.x, sol.polished
            r = gs - s
            res_norm = float(np.max(np.abs(r))) / vscale
            if res_norm <= max(opts.fixed_point_tol, opts.accuracy(sol.polished)) or \
                    not np.any(fric):
                converged = True
                break
            # active-set Newton on Coulomb's conditions from this iterate
            if n > 1:
                y, ok = polish_cone_qp(unit, sol.x * (sW / sb), coulomb=True)
                if ok and coulomb_residual(W, b, mu, d, y * (sb / sW)) <= 1e-11:
                    last_x, converged, newton = y * (sb / sW), True, True
                    break
            if memory and res_norm > 0.9 * prev and hist_s:  # safeguard: restart, damp
                hist_s.clear()
                hist_r.clear()
                beta = max(beta * 0.5, 1.0 / 16.0)
            prev = res_norm
            hist_s.append(s.copy())
            hist_r.append(r.copy())
            if len(hist_s) > memory + 1:
                hist_s.pop(0)
                hist_r.pop(0)
            s_new = s + beta * r
            if len(hist_s) >= 2 and memory > 0:  # Anderson (type II) step
                dR = np.array([hist_r[k + 1] - hist_r[k] for k in range(len(hist_r) - 1)]).T
                dS = np.array([hist_s[k + 1] - hist_s[k] for k in range(len(hist_s) - 1)]).T
                gamma, *_ = np.linalg.lstsq(dR, r, rcond=None)
                s_new = s_new - (dS + beta * dR) @ gamma
            s = np.maximum(s_new, 0.0)
        if converged or (n == 1 and fric[0]):
            break  # one contact: the exact solve below finishes or rescues
    pi = last_x.reshape(n, d)
    finished = "fixed point" + (" (polished programs)" if polished else "")
    if newton:
        finished = "active-set Newton on Coulomb's conditions"
    elif n > 1:
        y, ok = polish_cone_qp(unit, pi.ravel() * (sW / sb), coulomb=True)
        if ok and coulomb_residual(W, b, mu, d, y * (sb / sW)) <= \
                coulomb_residual(W, b, mu, d, pi.ravel()):
            pi, newton = (y * (sb / sW)).reshape(n, d), True
            finished += ", then active-set Newton"
    n_solutions = None
    if n == 1 and fric[0]:
        # exact single-contact solve: finishes a converged iterate to machine precision and
        # rescues one that did not converge (the candidate nearest the last iterate)
        cands = _single_contact_coulomb_candidates(W, b, float(mu[0]))
        n_solutions = len(cands)
        if cands:
            k = int(np.argmin([np.linalg.norm(c - pi[0]) for c in cands]))
            pi = cands[k][None]
            finished = "exact single-contact solve"
    acc = opts.accuracy(polished or newton or finished.startswith("exact"))
    resid = coulomb_residual(W, b, mu, d, pi.ravel())
    info = {
        "fixed_point_iterations": iters,
        "fixed_point_converged": converged,
        "fixed_point_residual": res_norm,
        "conic_iterations": conic_iters,
        "solver_status": status,
        "finished_by": finished,
        "complementarity_residual": resid,
        "tolerance": opts.tol,
        "accuracy": acc,
    }
    if n_solutions is not None:
        info["single_contact_solutions"] = n_solutions
    if resid > max(opts.fixed_point_tol, acc) * 10:
        raise SolverError(
            f"Coulomb fixed point did not converge: after {iters} CCP programs the "
            f"complementarity residual is {resid:.3e} (fixed-point residual {res_norm:.3e}); "
            "raise max_fixed_point_iter, or use law='ccp' or 'dissipative' (single programs)")
    return pi, info


def _coulomb_result(P: ImpactProblem, backend: Backend, method: str,
                    opts: ProgramOptions) -> ImpactResult:
    pi, info = solve_coulomb(P, backend, opts)
    vplus = P.v_minus + (P.delassus @ pi.ravel()).reshape(P.n_contacts, P.dim)
    acc = info["accuracy"]
    regimes = _regimes_from_slip(P, pi, vplus, acc)
    return assemble_result(P, pi, regimes, "coulomb", method, tol=acc, extras=info)


# --------------------------------------------------------------------------------------------
# law: pereira-nikravesh


def joint_stick_impulse(P: ImpactProblem) -> np.ndarray | None:
    """Stick test of several contacts (eqs. 42/52 jointly): impulse or None when not admissible.

    Unknowns: pi_n of every approaching contact and pi_t of its frictional ones; equations:
    ``v_n+ = -e v_n-`` and ``v_t+ = 0`` there. Contacts with v_n- >= 0 carry no impulse. A singular
    system is solved in the least-squares sense and accepted only when consistent.
    """
    n, d = P.n_contacts, P.dim
    active = P.v_minus[:, 0] < 0.0
    sel = np.zeros((n, d), dtype=bool)
    sel[active, 0] = True
    sel[active & (P.friction > 0.0), 1:] = True
    rhs = P.v_minus.copy()
    rhs[:, 0] *= 1.0 + P.restitution
    S = sel.ravel()
    Wss = P.delassus[np.ix_(S, S)]
    r = -rhs.ravel()[S]
    if np.linalg.cond(Wss) < DELASSUS_COND_MAX:
        x = np.linalg.solve(Wss, r)
    else:
        x, *_ = np.linalg.lstsq(Wss, r, rcond=None)
        if np.linalg.norm(Wss @ x - r) > 1e-9 * max(np.linalg.norm(r), _TINY):
            return None
    pi = np.zeros(n * d)
    pi[S] = x
    pi = pi.reshape(n, d)
    for i in np.flatnonzero(active):
        if P.friction[i] > 0 and not stick_admissible(pi[i], float(P.friction[i])):
            return None
        if P.friction[i] == 0 and pi[i, 0] < 0:
            return None
    vplus = P.v_minus + (P.delassus @ pi.ravel()).reshape(n, d)
    if np.any(vplus[~active, 0] < -1e-12 * max(float(np.max(np.abs(P.v_minus))), _TINY)):
        return None
    return pi


def solve_pn_program(P: ImpactProblem, backend: Backend,
                     opts: ProgramOptions) -> tuple[np.ndarray, QPSolution]:
    """The program P_N over the approaching contacts: minimize T+ s.t. v_n+ = -e v_n-, pi in K.

    Contacts with v_n- >= 0 are left out (zero impulse). Returns the full (n_contacts, d)
    impulse and the solver report; infeasibility raises a typed error naming other laws.
    """
    n, d = P.n_contacts, P.dim
    active = np.flatnonzero(P.v_minus[:, 0] < 0.0)
    idx = np.concatenate([np.arange(i * d, (i + 1) * d) for i in active])
    W = P.delassus[np.ix_(idx, idx)]
    v = P.v_minus[active].ravel()
    nrows = np.arange(0, idx.size, d)
    E = W[nrows]
    f = -(1.0 + P.restitution[active]) * P.v_minus[active, 0]
    qp = ConeQP(W, v, P.friction[active], d, E, f)
    try:
        sol = solve_cone_qp(backend, qp, opts.tol, opts.max_iter)
    except SolverError as exc:
        if "infeasible" in str(exc).lower() or "Infeasible" in str(exc):
            if active.size == 1:
                raise NonPositiveEffectiveMassError(
                    "P_N is infeasible: no impulse in the friction cone restores v_n+ = -e v_n- "
                    "(Painleve-like jam, the sliding denominator of eq. (38) is not positive "
                    "in any admissible direction); use law='coulomb', 'ccp' or 'dissipative'"
                ) from exc
            raise SolverError(
                "P_N is infeasible: Newton's restitution cannot hold at every approaching "
                "contact with compressive impulses in the friction cones; use law='coulomb', "
                f"'ccp' or 'dissipative', which allow contacts to separate ({exc})") from exc
        raise
    pi = np.zeros((n, d))
    pi[active] = sol.x.reshape(active.size, d)
    return pi, sol


def _tl_slide(W: np.ndarray, v: np.ndarray, e: float, mu: float, a: float) -> float:
    """T_L (eq. 60) for a slide along angle a with pi_n from eq. (38); -inf where not defined."""
    g = np.array([1.0, mu * math.cos(a), mu * math.sin(a)])
    den = float(W[0] @ g)
    if den <= 0:
        return -math.inf
    pi = (-(1.0 + e) * v[0] / den) * g
    return -float(pi @ v + 0.5 * pi @ W @ pi)


def _polish_direction(W: np.ndarray, v: np.ndarray, e: float, mu: float,
                      direction: np.ndarray) -> np.ndarray:
    """Refine the spatial sliding angle near P_N's answer by a bounded maximization of T_L."""
    from scipy.optimize import minimize_scalar

    a0 = math.atan2(direction[1], direction[0])
    span = 1e-3
    res = minimize_scalar(lambda a: -_tl_slide(W, v, e, mu, a), bounds=(a0 - span, a0 + span),
                          method="bounded", options={"xatol": 1e-13})
    a = float(res.x)
    if not res.success or abs(a - a0) > 0.99 * span or \
            _tl_slide(W, v, e, mu, a) < _tl_slide(W, v, e, mu, a0):
        return direction
    return np.array([math.cos(a), math.sin(a)])


def _pn_result(P: ImpactProblem, backend: Backend, method: str,
               opts: ProgramOptions) -> ImpactResult:
    n, d = P.n_contacts, P.dim
    law = "pereira-nikravesh"
    if n == 1 and P.planar:
        # one planar contact: the law is the closed form (stick test, then eq. 55)
        W, v = P.contact_block(0)
        impulse, regime, denom = _pn_closed_form(W, v, float(P.restitution[0]),
                                                 float(P.friction[0]))
        return assemble_result(P, impulse[None], [regime], law, method, effective_mass=denom,
                               tol=1e-12, extras={"stick_test": regime == "stick",
                                                  "slide_rule": "eq. (55)"})
    active = P.v_minus[:, 0] < 0.0
    stick = joint_stick_impulse(P)
    if stick is not None:
        regimes = ["separating" if not active[i] else
                   ("frictionless" if P.friction[i] == 0 else "stick") for i in range(n)]
        return assemble_result(P, stick, regimes, law, method, tol=1e-10,
                               extras={"stick_test": True})
    pi, sol = solve_pn_program(P, backend, opts)
    acc = opts.accuracy(sol.polished)
    warnings: list[str] = []
    interior = []
    regimes = []
    denom = None
    for i in range(n):
        if not active[i]:
            interior.append(False)
            regimes.append("separating")
            continue
        if P.friction[i] == 0:
            interior.append(False)
            regimes.append("frictionless")
            continue
        pt = np.linalg.norm(pi[i, 1:])
        interior.append(bool(pt < P.friction[i] * pi[i, 0] * (1.0 - BOUNDARY_RTOL)))
        regimes.append("slide")
    extras: dict[str, Any] = {"stick_test": False, "solver_status": sol.status,
                              "iterations": sol.iterations, "tolerance": opts.tol,
                              "polished": sol.polished, "kkt_residual": sol.kkt_residual,
                              "pn_interior": interior, "pn_disagreement": any(interior)}
    if n == 1 and P.friction[0] > 0:
        W, v = P.contact_block(0)
        e, mu = float(P.restitution[0]), float(P.friction[0])
        if interior[0]:
            try:  # the boundary search of the other solver paths (lazy imports)
                from ..sweep import max_dissipation_direction
            except ImportError:
                from ..fast import max_dissipation_direction
            direction = np.asarray(max_dissipation_direction(W, v, e, mu, tol=opts.tol),
                                   dtype=float)
            warnings.append("P_N's optimum is interior but the stick test failed: the sliding "
                            "direction comes from the boundary search (maximal T_L on the cone)")
            extras["slide_rule"] = "boundary search (sweep)"
        else:
            direction = _polish_direction(W, v, e, mu, pi[0, 1:] / np.linalg.norm(pi[0, 1:]))
            extras["slide_rule"] = "P_N (boundary optimum, polished)"
        impulse, denom = sliding_impulse(W, v, e, mu, direction)
        extras["slide_angle"] = math.atan2(direction[1], direction[0])
        pi = impulse[None]
        acc = 1e-9
    elif any(interior):
        warnings.append("P_N's optimum is interior at some contacts although the joint stick "
                        "test failed: those contacts slide with friction inside the cone "
                        "(not Coulomb); compare law='coulomb'")
    vplus = P.v_minus + (P.delassus @ pi.ravel()).reshape(n, d)
    vscale = max(float(np.max(np.abs(P.v_minus))), _TINY)
    bad = np.flatnonzero((~active) & (vplus[:, 0] < -1e3 * acc * vscale))
    if bad.size:
        raise NotSupportedError(
            f"law 'pereira-nikravesh' gives no impulse to contacts with v_n- >= 0, and contact(s) "
            f"{bad.tolist()} would then penetrate (v_n+ < 0); use law='coulomb', 'ccp' or "
            "'dissipative', which treat every contact with complementarity")
    return assemble_result(P, pi, regimes, law, method, effective_mass=denom, tol=acc,
                           extras=extras, warnings=tuple(warnings))


# --------------------------------------------------------------------------------------------
# registration


LAW_RESULTS: dict[str, Callable[[ImpactProblem, Backend, str, ProgramOptions], ImpactResult]] = {
    "pereira-nikravesh": _pn_result,
    "coulomb": _coulomb_result,
    "ccp": _ccp_result,
    "dissipative": _dissipative_result,
}

_CVXPY = CvxpyBackend()


def _make(law: str, method: str, backend_getter: Callable[[], Backend]):
    def solver(problem: ImpactProblem, **options) -> ImpactResult:
        opts = parse_options(method, options)
        return LAW_RESULTS[law](problem, backend_getter(), method, opts)

    solver.__name__ = f"{law.replace('-', '_')}_{method}"
    solver.__doc__ = f"Law {law!r} by the {method} conic path (see convimpact.impact.conic.programs)."
    return solver


for _law in LAW_RESULTS:
    register_solver(_law, "cvxpy")(_make(_law, "cvxpy", lambda: _CVXPY))
