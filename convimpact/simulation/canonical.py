"""Right-hand side of the canonical equations of motion (Section 2.2, eqs. 10-15).

The integration array is ``y = [theta, p]`` (eq. 15). For open loops ``theta_dot = M^-1 p``
(eq. 10) and ``p_dot = f + M_dot theta_dot`` (eq. 11). For closed loops ``theta_dot`` and the
loop multipliers ``sigma`` solve eqs. (7) and (13) together::

    M theta_dot - C^T sigma = p,     C theta_dot = 0,

and ``p_dot = f + M_dot theta_dot - C_dot^T sigma`` (eq. 14).

Contacts that the simulator holds closed enter like loop constraints, by their mode
(:class:`HeldMode`):

* ``"stick"`` (resting, rolling): all rows of the contact Jacobian (n and t, or n, t1, t2)
  join ``C``; their multipliers are the normal and friction forces;
* ``"slip"`` (sliding with Coulomb friction): the normal row joins ``C`` and the friction force
  ``-mu lambda_n c_t^T s`` (s the unit slip direction) is a generalized force driven by the
  normal multiplier, so ``p_dot = f + M_dot theta_dot - C_dot^T sigma + D nu`` with ``D`` the
  friction columns; the multipliers solve ``C M^-1 (C^T + D) nu = -(C M^-1 f + C_dot theta_dot)``,
  a non-symmetric system whose singularity is Painleve's;
* ``"frictionless"``: the normal row only (a bilateral frictionless constraint).

Only the normal rows (gaps) are position constraints (``residual``, ``position_jacobian``);
tangential rows constrain velocities. Rows found redundant at the event that formed the set
(``dropped``: a box on two corners sticking has one tangential row too many) are left out.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping, Sequence

import numpy as np
import scipy.linalg as sla

from ..impact.errors import SimulationError
from ..mechanism import Mechanism

#: a held contact's rows: (contact name, row of its Jacobian: 0 normal, 1.. tangents)
Row = tuple[str, int]
#: configurations whose contact Jacobians are remembered (theta and theta +- h theta_dot)
JACOBIAN_MEMO = 6


@dataclass(frozen=True)
class HeldMode:
    """How a held contact is closed: ``kind`` "stick", "slip" or "frictionless".

    ``direction`` is, for "slip", the unit slip direction in the contact's tangent basis at
    the start of the segment (planar: ``(+1,)`` or ``(-1,)``); spatial slips follow the slip
    velocity's direction during the segment and use ``direction`` only while it is ~0 (an
    onset). ``mu`` is the contact's friction coefficient.
    """

    kind: str = "frictionless"
    direction: tuple[float, ...] = ()
    mu: float = 0.0


FRICTIONLESS = HeldMode()


class CanonicalEquations:
    """The canonical equations of a mechanism with a fixed set of held contacts and modes.

    Built once per set of held contacts and modes (they change only at events); calling the
    object evaluates ``y_dot`` (eq. 15) and counts the evaluations in :attr:`nfev`.

    Parameters
    ----------
    mechanism : Mechanism
        The model.
    held_contacts : sequence of str
        Contacts held closed.
    modes : mapping of contact name to :class:`HeldMode`, optional
        Their modes (default: frictionless, the normal row only).
    dropped : collection of (contact, row)
        Redundant rows left out of the constraints.
    dims : mapping of contact name to its number of rows (2 planar, 3 spatial), optional
        (default: read from the contact Jacobian at theta = 0).
    slip_floor : float
        Slip speed below which a spatial sliding contact's friction keeps its stored
        direction (the slip velocity's direction is round-off there); the run updates the
        stored direction at every accepted step.
    """

    def __init__(self, mechanism: Mechanism, held_contacts: Sequence[str] = (),
                 modes: Mapping[str, HeldMode] | None = None, dropped=(),
                 dims: Mapping[str, int] | None = None, slip_floor: float = 0.0):
        self.mechanism = mechanism
        self.k = int(mechanism.n_coordinates)
        self.n_loops = int(mechanism.n_loop_constraints)
        self.held = tuple(held_contacts)
        modes = dict(modes or {})
        self.modes = {c: modes.get(c, FRICTIONLESS) for c in self.held}
        self.slip_floor = float(slip_floor)
        self.dropped = frozenset(tuple(r) for r in dropped)
        self.rows: list[Row] = []
        self.position_rows: list[Row] = []
        self.slipping: list[tuple[str, int]] = []  # (contact, index of its normal row)
        for c in self.held:
            mode = self.modes[c]
            dim = 1
            if mode.kind == "stick":
                dim = int(dims[c]) if dims and c in dims else int(
                    np.asarray(mechanism.contact_jacobian(c, np.zeros(self.k)), float).shape[0])
            for j in range(dim):
                if (c, j) in self.dropped:
                    continue
                if j == 0:
                    self.position_rows.append((c, 0))
                    if mode.kind == "slip" and mode.mu > 0.0:
                        self.slipping.append((c, len(self.rows)))
                self.rows.append((c, j))
        self.n_constraints = self.n_loops + len(self.rows)
        self.nfev = 0
        self._jdot = getattr(mechanism, "contact_jacobian_dot", None)
        self._jac_memo: dict[bytes, dict[str, np.ndarray]] = {}

    # -- contact rows ------------------------------------------------------------------------
    def contact_jacobians(self, theta: np.ndarray) -> dict[str, np.ndarray]:
        """The full Jacobians (rows n, t...) of the held contacts at theta (the last few
        configurations are remembered: one right-hand side asks for them several times)."""
        key = np.asarray(theta, float).tobytes()
        hit = self._jac_memo.get(key)
        if hit is None:
            hit = {c: np.asarray(self.mechanism.contact_jacobian(c, theta), float)
                   for c in self.held}
            if len(self._jac_memo) >= JACOBIAN_MEMO:
                self._jac_memo.pop(next(iter(self._jac_memo)))
            self._jac_memo[key] = hit
        return hit

    def contact_jacobians_dot(self, theta: np.ndarray,
                              dtheta: np.ndarray) -> dict[str, np.ndarray]:
        """d/dt of the held contacts' Jacobians along theta_dot (analytic when the mechanism
        has ``contact_jacobian_dot``, else a directional central difference, O(h^2))."""
        if self._jdot is not None:
            return {c: np.asarray(self._jdot(c, theta, dtheta), float) for c in self.held}
        speed = float(np.linalg.norm(dtheta))
        if speed == 0.0 or not self.held:
            return {c: np.zeros((1, self.k)) for c in self.held}
        h = 1e-5 * (1.0 + float(np.linalg.norm(theta))) / speed
        jp = self.contact_jacobians(theta + h * dtheta)
        jm = self.contact_jacobians(theta - h * dtheta)
        return {c: (jp[c] - jm[c]) / (2.0 * h) for c in self.held}

    def _stack(self, rows: Sequence[Row], jac: Mapping[str, np.ndarray],
               loops: np.ndarray | None) -> np.ndarray:
        parts = [] if loops is None else [loops]
        if rows:
            parts.append(np.array([jac[c][j] if j < len(jac[c]) else np.zeros(self.k)
                                   for c, j in rows]))
        return np.vstack(parts) if parts else np.zeros((0, self.k))

    def _loop_rows(self, theta: np.ndarray) -> np.ndarray | None:
        if not self.n_loops:
            return None
        return np.asarray(self.mechanism.loop_jacobian(theta), float).reshape(-1, self.k)

    # -- constraints -------------------------------------------------------------------------
    def residual(self, theta: np.ndarray) -> np.ndarray:
        """Psi(theta) of the loops (eq. 6) followed by the held contacts' gaps."""
        parts = []
        if self.n_loops:
            parts.append(np.asarray(self.mechanism.loop_residual(theta), float).ravel())
        if self.position_rows:
            parts.append(np.array([self.mechanism.contact_gap(c, theta)
                                   for c, _ in self.position_rows]))
        return np.concatenate(parts) if parts else np.zeros(0)

    def position_jacobian(self, theta: np.ndarray) -> np.ndarray:
        """The Jacobian of :meth:`residual`: loops' C and the held contacts' normal rows."""
        return self._stack(self.position_rows, self.contact_jacobians(theta),
                           self._loop_rows(theta))

    def jacobian(self, theta: np.ndarray) -> np.ndarray:
        """C(theta) (eq. 7) with the held contacts' rows appended (velocity constraints)."""
        return self._stack(self.rows, self.contact_jacobians(theta), self._loop_rows(theta))

    def jacobian_dot(self, theta: np.ndarray, dtheta: np.ndarray) -> np.ndarray:
        """C_dot(theta, theta_dot) (eqs. 8, 14) with the held contacts' rows appended."""
        loops = None
        if self.n_loops:
            loops = np.asarray(self.mechanism.loop_jacobian_dot(theta, dtheta),
                               float).reshape(-1, self.k)
        return self._stack(self.rows, self.contact_jacobians_dot(theta, dtheta), loops)

    def slip_direction(self, c: str, jac: np.ndarray, dtheta: np.ndarray) -> np.ndarray:
        """The unit slip direction of sliding contact ``c`` (tangent basis): the slip
        velocity's in space (the stored one while it is ~0), the stored sign in the plane."""
        mode = self.modes[c]
        stored = np.asarray(mode.direction, float)
        if len(jac) == 2:
            return stored
        vt = jac[1:] @ dtheta
        norm = float(np.linalg.norm(vt))
        return vt / norm if norm > self.slip_floor and norm > 0.0 else stored

    def friction_columns(self, theta: np.ndarray, dtheta: np.ndarray,
                         jac: Mapping[str, np.ndarray] | None = None) -> np.ndarray:
        """D (k, n_constraints): the generalized friction force per unit normal multiplier
        of each sliding contact, ``-mu c_t^T s`` in its normal row's column."""
        D = np.zeros((self.k, self.n_constraints))
        if not self.slipping:
            return D
        jac = self.contact_jacobians(theta) if jac is None else jac
        for c, i in self.slipping:
            s = self.slip_direction(c, jac[c], dtheta)
            D[:, self.n_loops + i] = -self.modes[c].mu * (jac[c][1:].T @ s)
        return D

    # -- eqs. (7) + (13) ---------------------------------------------------------------------
    def _factor(self, theta: np.ndarray):
        M = np.asarray(self.mechanism.mass_matrix(theta), float)
        try:
            cho = sla.cho_factor(M, lower=True, check_finite=True)
        except (np.linalg.LinAlgError, ValueError) as exc:
            raise SimulationError(
                f"the mass matrix is not positive definite or not finite at theta = "
                f"{np.round(theta, 6).tolist()}: {exc}") from None
        C = self.jacobian(theta)
        if C.shape[0] == 0:
            return M, cho, C, None, None
        A = sla.cho_solve(cho, C.T)  # M^-1 C^T
        S = C @ A  # C M^-1 C^T
        try:
            scho = sla.cho_factor(S, lower=True)
        except np.linalg.LinAlgError:
            raise SimulationError(
                "the constraint Jacobian (loops and held contacts) lost rank: C M^-1 C^T is "
                "singular (a dead-centre configuration or redundant held contacts)") from None
        return M, cho, C, A, scho

    def velocities(self, theta: np.ndarray, p: np.ndarray):
        """theta_dot and sigma from ``M theta_dot - C^T sigma = p``, ``C theta_dot = 0``.

        Returns
        -------
        dtheta, sigma, (M, cho_factor(M), C, M^-1 C^T, cho_factor(C M^-1 C^T))
        """
        M, cho, C, A, scho = self._factor(theta)
        dtheta = sla.cho_solve(cho, p)  # eq. (10)
        if A is None:
            return dtheta, np.zeros(0), (M, cho, C, A, scho)
        sigma = -sla.cho_solve(scho, C @ dtheta)  # eqs. (7), (13)
        dtheta = dtheta + A @ sigma
        return dtheta, sigma, (M, cho, C, A, scho)

    def momentum(self, theta: np.ndarray, dtheta: np.ndarray,
                 sigma: np.ndarray | None = None) -> np.ndarray:
        """p = M theta_dot - C^T sigma (eq. 13; eq. 10 for open loops)."""
        p = np.asarray(self.mechanism.mass_matrix(theta), float) @ dtheta
        if sigma is not None and len(sigma):
            p = p - self.jacobian(theta).T @ sigma
        return p

    def _multipliers(self, t: float, theta: np.ndarray, dtheta: np.ndarray, factors, f,
                     Cdot: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(nu, D): ``C M^-1 (C^T + D) nu = -(C M^-1 f + C_dot theta_dot)`` (eqs. 8, 9)."""
        M, cho, C, A, scho = factors
        D = self.friction_columns(theta, dtheta)
        rhs = C @ sla.cho_solve(cho, f) + Cdot @ dtheta
        if not self.slipping:
            return -sla.cho_solve(scho, rhs), D
        K = C @ A + C @ sla.cho_solve(cho, D)
        try:
            nu = -np.linalg.solve(K, rhs)
        except np.linalg.LinAlgError:
            raise SimulationError(
                f"Painleve's paradox at t = {t:.9g}: the sliding contacts' force system "
                "C M^-1 (C^T + D) is singular (effective normal mass zero)") from None
        return nu, D

    def __call__(self, t: float, y: np.ndarray) -> np.ndarray:
        """y_dot = [theta_dot, p_dot] (eq. 15)."""
        self.nfev += 1
        k = self.k
        theta, p = y[:k], y[k:]
        dtheta, sigma, factors = self.velocities(theta, p)
        mech = self.mechanism
        f = np.asarray(mech.generalized_forces(t, theta, dtheta), float)
        pdot = f + np.asarray(mech.mass_matrix_dot(theta, dtheta), float) @ dtheta  # eq. (11)
        if len(sigma):
            Cdot = self.jacobian_dot(theta, dtheta)
            pdot = pdot - Cdot.T @ sigma  # eq. (14)
            if self.slipping:  # Coulomb friction of the sliding contacts, driven by nu_n
                nu, D = self._multipliers(t, theta, dtheta, factors, f, Cdot)
                pdot = pdot + D @ nu
        out = np.concatenate([dtheta, pdot])
        if not np.all(np.isfinite(out)):
            raise SimulationError(
                f"the right-hand side became non-finite at t = {t:.9g} (theta = "
                f"{np.round(theta, 6).tolist()}); check the model's forces or reduce max_step")
        return out

    def multipliers(self, t: float, y: np.ndarray) -> np.ndarray:
        """Constraint forces nu = sigma_dot (eq. 9): loops first, then the held rows.

        From ``M theta_ddot - (C^T + D) nu = f`` and ``C theta_ddot + C_dot theta_dot = 0``
        (eq. 8). A held contact pushes (compressive) while its normal entry is positive.
        """
        k = self.k
        theta, p = y[:k], y[k:]
        dtheta, _, factors = self.velocities(theta, p)
        if factors[3] is None:
            return np.zeros(0)
        f = np.asarray(self.mechanism.generalized_forces(t, theta, dtheta), float)
        nu, _ = self._multipliers(t, theta, dtheta, factors, f,
                                  self.jacobian_dot(theta, dtheta))
        return nu

    def contact_forces(self, t: float, y: np.ndarray) -> dict[str, np.ndarray]:
        """The held contacts' forces in their frames (normal first) from the multipliers;
        a redundant (dropped) row reads zero, a sliding contact's friction is -mu lambda_n s."""
        k, m = self.k, self.n_loops
        theta = y[:k]
        nu = self.multipliers(t, y)
        dtheta, _, _ = self.velocities(theta, y[k:])
        jac = self.contact_jacobians(theta)
        out = {c: np.zeros(len(jac[c])) for c in self.held}
        for i, (c, j) in enumerate(self.rows):
            out[c][j] = nu[m + i]
        for c, _ in self.slipping:
            out[c][1:] = -self.modes[c].mu * out[c][0] * self.slip_direction(c, jac[c], dtheta)
        return out
