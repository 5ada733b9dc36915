"""The held contacts' forces of the canonical equations
(:class:`~convimpact.simulation.canonical.CanonicalEquations`, of which :class:`HeldForces` is a
part): the multipliers ``nu`` of the held rows (eqs. 8, 9), the forces of the rows dropped as
redundant in a sliding group, the contacts' forces in their frames and the friction power.

A sliding group with redundant rows (a table on four legs spinning as it slides) is
statically indeterminate, and the distribution moves the motion (each leg's friction follows
its own normal force): ``E nu = -(C M^-1 f + C_dot theta_dot)`` with
``E = C M^-1 [C^T + D_c | J_r^T + D_r]`` of full row rank, and nu is its least-norm solution
in the forces' norm, offset along the indeterminate directions by the force problem's choice at
the segment's start (:meth:`HeldForces.start_from`). The rank is the kept rows' count, fixed at
the event that formed the set, so round-off cannot switch the formula within a segment.
"""

from __future__ import annotations

from typing import Mapping

import numpy as np

from ..errors import SimulationError
from ..model import recursive as _rc


class Factors:
    """The factorizations of one configuration, shared by everything evaluated there.

    Attributes
    ----------
    M : (k, k) mass matrix; ``L`` its lower Cholesky factor.
    C : (n_constraints, k) loops' C and the held rows.
    A : (k, n_constraints) ``M^-1 C^T``; ``S`` = ``C M^-1 C^T`` and ``SL`` its lower
        Cholesky factor (None without constraints or until asked for).
    jac : the held contacts' full Jacobians (rows n, t...).
    """

    __slots__ = ("M", "L", "C", "A", "SL", "jac", "S")

    def __init__(self, M, L, C, A, SL, jac):
        self.M, self.L, self.C, self.A, self.SL, self.jac = M, L, C, A, SL, jac
        self.S = None  # C M^-1 C^T, with A

    def solve(self, b: np.ndarray) -> np.ndarray:
        """``M^-1 b`` for a vector or a (k, m) matrix."""
        return _cho_solve(self.L, b)


def _cho_solve(L: np.ndarray, b: np.ndarray) -> np.ndarray:
    b = np.asarray(b, dtype=float)
    if b.ndim == 1:
        out = np.empty(b.shape[0])
        _rc.cho_solve_vec(L, np.ascontiguousarray(b), out)
        return out
    out = np.empty(b.shape)
    _rc.cho_solve_mat(L, np.ascontiguousarray(b), out)
    return out


def _cholesky(M: np.ndarray) -> np.ndarray | None:
    L = np.zeros(M.shape)
    return L if _rc.cholesky(np.ascontiguousarray(M, dtype=float), L) else None


class HeldForces:
    """The force methods of :class:`~convimpact.simulation.canonical.CanonicalEquations`
    (see the module docstring); they use its factors, velocities, rates and friction
    columns."""

    def unknown_weights(self) -> np.ndarray:
        """(n_unknowns,) the squared force norm per unit of each force unknown: ``1 + mu^2``
        for a sliding contact's normal force (its friction ``-mu lambda_n s`` follows it),
        1 for the other rows."""
        w = np.ones(self.n_unknowns)
        for c, i in self.slipping:
            w[self.n_loops + i] = 1.0 + self.modes[c].mu ** 2
        return w

    def start_from(self, t: float, y: np.ndarray, forces: Mapping[str, np.ndarray]) -> None:
        """Start the segment from the force problem's distribution ``forces`` (contact ->
        its force, normal first) of the redundant sliding group.

        Where that distribution is not the least-norm one (the force problem took the
        largest smallest margin: the least-norm distribution has a normal force <= 0), its
        difference z0 from the least-norm distribution at (t, y) is kept, and during the
        segment the unknowns are ``z0 + W^-1 E^T (E W^-1 E^T)^-1 (rhs - E z0)``: the
        least-norm distribution plus z0's part along the current indeterminate directions
        (the start's choice exactly at the start, smooth in the state).
        """
        self.offset = None
        self._velocity_memo = self._terms_memo = None
        if not self.redundant:
            return
        x = np.zeros(self.n_unknowns)
        for i, (c, j) in enumerate(self.rows + self.redundant):
            x[self.n_loops + i] = float(forces[c][j]) if j < len(forces[c]) else 0.0
        w = self.unknown_weights()
        least = self._unknowns(t, y)
        z0 = x - least
        scale = max(float(np.sqrt(np.sum(w * x * x))), 1e-300)
        if float(np.sqrt(np.sum(w * z0 * z0))) > 1e-9 * scale:
            self.offset = z0
            self._velocity_memo = self._terms_memo = None

    def _multipliers(self, t: float, theta: np.ndarray, dtheta: np.ndarray, F: Factors, f,
                     Cdot: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(nu, D): ``C M^-1 (C^T + D) nu = -(C M^-1 f + C_dot theta_dot)`` (eqs. 8, 9).

        With redundant rows in a sliding group (:attr:`redundant`) nu has their forces
        too, past the constraints' multipliers: ``E nu = -(C M^-1 f + C_dot
        theta_dot)`` with ``E = C M^-1 [C^T + D_c | J_r^T + D_r]`` (m, m + r) of full row
        rank, and nu is its least-norm solution in the forces' norm (weights
        :meth:`unknown_weights`, W): ``nu = -W^-1 E^T (E W^-1 E^T)^-1 rhs``, plus the
        segment's :attr:`offset` z0 along the indeterminate directions (:meth:`start_from`).
        """
        D = self.friction_columns(theta, dtheta, F.jac)
        rhs = F.C @ _cho_solve(F.L, f) + Cdot @ dtheta
        if not self.slipping:
            return -_cho_solve(F.SL, rhs), D
        m = self.n_constraints
        K = F.C @ _cho_solve(F.L, D)
        K[:, :m] += F.S
        if self.redundant:
            Jr = np.array([F.jac[c][j] for c, j in self.redundant])  # (r, k)
            K[:, m:] += F.C @ _cho_solve(F.L, Jr.T)
        try:
            if self.redundant:
                w = self.unknown_weights()
                G = (K / w) @ K.T
                if self.offset is None:
                    nu = -(K.T @ np.linalg.solve(G, rhs)) / w
                else:
                    z0 = self.offset
                    nu = z0 - (K.T @ np.linalg.solve(G, rhs + K @ z0)) / w
            else:
                nu = -np.linalg.solve(K, rhs)
        except np.linalg.LinAlgError:
            raise SimulationError(
                f"Painleve's paradox at t = {t:.9g}: the sliding contacts' force system "
                "C M^-1 (C^T + D) is singular (effective normal mass zero)") from None
        return nu, D

    def friction_power(self, t: float, y: np.ndarray) -> float:
        """Power of the sliding contacts' friction forces, ``sum lambda_t . v_t`` (<= 0),
        lambda_t = -mu lambda_n s (:meth:`contact_forces`)."""
        if not self.slipping:
            return 0.0
        k = self.k
        got = self._compiled_terms(t, y)
        if got is not None:
            return got[1]
        dtheta, _, F = self.velocities(y[:k], y[k:])
        forces = self.contact_forces(t, y)
        return sum(float(forces[c][1:] @ (F.jac[c][1:] @ dtheta)) for c, _ in self.slipping)

    def multipliers(self, t: float, y: np.ndarray) -> np.ndarray:
        """Constraint forces nu = sigma_dot (eq. 9): loops first, then the held rows.

        From ``M theta_ddot - (C^T + D) nu = f`` and ``C theta_ddot + C_dot theta_dot = 0``
        (eq. 8). A held contact pushes (compressive) while its normal entry is positive.
        """
        return self._unknowns(t, y)[:self.n_constraints]

    def _unknowns(self, t: float, y: np.ndarray) -> np.ndarray:
        """(n_unknowns,) the multipliers nu, then the redundant sliding contacts' normal
        forces (:meth:`_multipliers`)."""
        got = self._compiled_terms(t, y)
        if got is not None:
            return got[0].copy()
        k = self.k
        theta, p = y[:k], y[k:]
        dtheta, _, F = self.velocities(theta, p)
        if not F.C.shape[0]:
            return np.zeros(0)
        f, _, Jd = self._rates(t, np.ascontiguousarray(theta, dtype=float), dtheta, True)
        nu, _ = self._multipliers(t, theta, dtheta, F, f, self._cdot(theta, dtheta, Jd))
        return nu

    def contact_forces(self, t: float, y: np.ndarray) -> dict[str, np.ndarray]:
        """The held contacts' forces in their frames (normal first) from the multipliers;
        a redundant (dropped) row reads zero outside a sliding group (there: its force in
        the distribution in force), a sliding contact's friction is -mu lambda_n s."""
        k, m = self.k, self.n_loops
        got = self._compiled_terms(t, y)
        if got is not None:  # n_loops = 0
            nu, _, _, dirs, _ = got
            out = {c: np.zeros(self._d) for c in self.held}
            for i, (c, j) in enumerate(self.rows + self.redundant):
                out[c][j] = nu[i]
            for (c, _), s in zip(self.slipping, dirs):
                out[c][1:] = -self.modes[c].mu * out[c][0] * s
            return out
        theta = y[:k]
        nu = self._unknowns(t, y)
        dtheta, _, F = self.velocities(theta, y[k:])
        jac = F.jac
        out = {c: np.zeros(len(jac[c])) for c in self.held}
        for i, (c, j) in enumerate(self.rows + self.redundant):
            out[c][j] = nu[m + i]
        for c, _ in self.slipping:
            out[c][1:] = -self.modes[c].mu * out[c][0] * self.slip_direction(c, jac[c], dtheta)
        return out
