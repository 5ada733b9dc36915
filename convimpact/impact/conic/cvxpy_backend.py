"""The cvxpy backend of the cone QP: cvxpy + Clarabel, one DPP program per structure."""

from __future__ import annotations

import warnings

import numpy as np

from ...errors import SolverError
from .qp import ConeQP, QPSolution, status_message


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
                # warm_start=False: cvxpy would otherwise hand the previous call's Clarabel
                # solver the new data by update(), which assumes the same sparsity pattern;
                # cvxpy drops the data's exact zeros (a decoupled W, a zero of E), so the
                # pattern changes between calls and the solver ran on mixed-up data
                # (measured: 'user_limit' after 200 iterations on a program that fresh
                # solves in 8)
                problem.solve(solver=cp.CLARABEL, warm_start=False, tol_gap_abs=tol,
                              tol_gap_rel=tol, tol_feas=tol, tol_ktratio=1e-3 * tol ** 0.5,
                              max_iter=max_iter)
        except cp.error.SolverError as exc:
            raise SolverError(f"cvxpy/Clarabel failed on the impact program: {exc}") from exc
        status = str(problem.status)
        stats = problem.solver_stats
        iters = int(stats.num_iters) if stats is not None and stats.num_iters is not None else -1
        if status not in (cp.OPTIMAL, cp.OPTIMAL_INACCURATE) or x.value is None:
            raise SolverError(status_message(status))
        t = float(stats.solve_time) if stats is not None and stats.solve_time else float("nan")
        return QPSolution(np.array(x.value, dtype=float), status, iters, t,
                          converged=status == cp.OPTIMAL)
