"""The Clarabel backend of the cone QP: Clarabel's own Python API (``method="clarabel"``).

The cone QP of :mod:`convimpact.impact.conic.qp` (``minimize 1/2 x^T W x + q^T x`` s.t. ``E x = f``,
``x_i in K_mu_i``) is written in Clarabel's standard form ``A x + s = b, s in K``:

* rows ``0..m-1``: ``E x + s = f``, s in the zero cone (the Newton equalities of P_N);
* then, for frictionless contacts, ``x_t + s = 0`` (zero cone) and ``-x_n + s = 0`` (s >= 0);
* then one second-order cone per frictional contact: ``s = (mu x_n, x_t)``, i.e. rows
  ``-mu e_n``, ``-e_t``, b = 0.

Every column of A has exactly ``m + 1`` entries (the m equality rows and its one cone row) and
P is the dense upper triangle of W, so the CSC arrays (``indptr``, ``indices``, ``data``) are
written by hand once per structure; a solver is built once per (structure, tolerances) and
every later call only ``update``s the numeric values of P, q, A, b (presolve off, structural
zeros kept, as Clarabel requires for data updates).

Tolerances (option ``tol``, default :data:`convimpact.impact.conic.qp.DEFAULT_TOL` = 1e-10) set
Clarabel's ``tol_gap_abs``, ``tol_gap_rel`` and ``tol_feas`` on the scaled problem (unit-size
data), ``tol_ktratio = 1e-3 sqrt(tol)``; ``max_iter`` its iteration limit. Clarabel's defaults
(1e-8) give impulses to about 1e-5 on sliding contacts; 1e-10 gives about 1e-9 or better.
Statuses other than ``Solved`` and ``AlmostSolved`` raise SolverError (what is accepted:
:func:`convimpact.impact.conic.qp.solve_cone_qp`).
"""

from __future__ import annotations

import numpy as np

from ...errors import SolverError
from .qp import ConeQP, QPSolution, status_message


class _Built:
    """One Clarabel solver and the index maps of its CSC data, for one structure."""

    def __init__(self, structure: tuple, tol: float, max_iter: int) -> None:
        import clarabel
        import scipy.sparse as sp

        n, d, frictionless, m = structure
        N = n * d
        self.m = m
        # cone row of every variable, and the coefficient pattern of that row
        cone_row = np.empty(N, dtype=np.int64)
        n_fl = sum(frictionless)
        row = m
        for i in range(n):  # zero cone: tangents of frictionless contacts
            if frictionless[i]:
                cone_row[i * d + 1:(i + 1) * d] = np.arange(row, row + d - 1)
                row += d - 1
        n_zero = row
        for i in range(n):  # nonnegative cone: normals of frictionless contacts
            if frictionless[i]:
                cone_row[i * d] = row
                row += 1
        self.fric_contacts = [i for i in range(n) if not frictionless[i]]
        for i in self.fric_contacts:  # one second-order cone per frictional contact
            cone_row[i * d:(i + 1) * d] = np.arange(row, row + d)
            row += d
        self.n_rows = row
        self.frictionless = np.array(frictionless, dtype=bool)
        self.d = d
        self.N = N
        # A: column j holds rows 0..m-1 (equalities) and cone_row[j]
        self.A_indptr = np.arange(N + 1, dtype=np.int64) * (m + 1)
        self.A_indices = np.column_stack(
            [np.tile(np.arange(m, dtype=np.int64), (N, 1)), cone_row[:, None]]).ravel()
        # P: dense upper triangle, column by column
        self.P_cols, self.P_rows = np.tril_indices(N)
        self.P_indptr = np.concatenate(([0], np.cumsum(np.arange(1, N + 1)))).astype(np.int64)
        cones = []
        if n_zero:
            cones.append(clarabel.ZeroConeT(n_zero))
        if n_fl:
            cones.append(clarabel.NonnegativeConeT(n_fl))
        cones += [clarabel.SecondOrderConeT(d) for _ in self.fric_contacts]
        settings = clarabel.DefaultSettings()
        settings.verbose = False
        settings.presolve_enable = False
        settings.input_sparse_dropzeros = False
        settings.tol_gap_abs = tol
        settings.tol_gap_rel = tol
        settings.tol_feas = tol
        settings.tol_ktratio = 1e-3 * tol ** 0.5
        settings.max_iter = int(max_iter)
        self._solved = clarabel.SolverStatus.Solved
        self._almost = clarabel.SolverStatus.AlmostSolved
        # a feasible placeholder instance fixes the structure; values come by update()
        W0 = np.eye(N)
        E0 = np.ones((m, N))
        mu0 = np.ones(n)
        P0 = sp.csc_matrix((self.P_data(W0), self.P_rows, self.P_indptr), shape=(N, N))
        A0 = sp.csc_matrix((self.A_data(E0, mu0), self.A_indices, self.A_indptr),
                           shape=(self.n_rows, N))
        self.solver = clarabel.DefaultSolver(P0, np.zeros(N), A0, np.zeros(self.n_rows), cones,
                                             settings)
        if not self.solver.is_data_update_allowed():  # pragma: no cover - settings above
            raise SolverError("internal: Clarabel refuses data updates with these settings")

    def P_data(self, W: np.ndarray) -> np.ndarray:
        return W[self.P_rows, self.P_cols]

    def A_data(self, E: np.ndarray, mu: np.ndarray) -> np.ndarray:
        d = self.d
        coef = np.empty(self.N)
        for i in range(mu.shape[0]):
            if self.frictionless[i]:
                coef[i * d] = -1.0
                coef[i * d + 1:(i + 1) * d] = 1.0
            else:
                coef[i * d] = -mu[i]
                coef[i * d + 1:(i + 1) * d] = -1.0
        return np.vstack([E, coef[None]]).ravel(order="F")

    def solve(self, qp: ConeQP) -> QPSolution:
        b = np.zeros(self.n_rows)
        b[:self.m] = qp.f
        self.solver.update(P=self.P_data(qp.W), q=np.asarray(qp.q, dtype=float),
                           A=self.A_data(qp.E, qp.mu), b=b)
        sol = self.solver.solve()
        status = str(sol.status)
        if sol.status != self._solved and sol.status != self._almost:
            raise SolverError(status_message(status) + " (method='clarabel')")
        return QPSolution(np.array(sol.x, dtype=float), status, int(sol.iterations),
                          float(sol.solve_time), converged=sol.status == self._solved)


class ClarabelBackend:
    """Clarabel's own API: one solver per (structure, tol, max_iter), updated with new data."""

    name = "clarabel"

    def __init__(self) -> None:
        self._built: dict[tuple, _Built] = {}

    def solve(self, qp: ConeQP, tol: float, max_iter: int) -> QPSolution:
        key = (qp.structure, float(tol), int(max_iter))
        built = self._built.get(key)
        if built is None:
            built = _Built(qp.structure, tol, max_iter)
            self._built[key] = built
        return built.solve(qp)

