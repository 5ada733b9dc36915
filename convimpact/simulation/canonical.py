"""Right-hand side of the canonical equations of motion (Section 2.2, eqs. 10-15).

The integration array is ``y = [theta, p]`` (eq. 15). For open loops ``theta_dot = M^-1 p``
(eq. 10) and ``p_dot = f + M_dot theta_dot`` (eq. 11). For closed loops ``theta_dot`` and the
loop multipliers ``sigma`` solve eqs. (7) and (13) together::

    M theta_dot - C^T sigma = p,     C theta_dot = 0,

and ``p_dot = f + M_dot theta_dot - C_dot^T sigma`` (eq. 14).

Contacts that the simulator holds closed (persistent contacts, see
:mod:`convimpact.simulation.zeno`) enter exactly like loop constraints: their normal rows
``c_n^T`` are appended to ``C`` and their gaps to ``Psi``. Their multipliers are the normal
contact impulses (in ``sigma``) and forces (in ``nu``).
"""

from __future__ import annotations

from typing import Sequence

import numpy as np
import scipy.linalg as sla

from ..impact.errors import SimulationError
from ..mechanism import Mechanism


class CanonicalEquations:
    """The canonical equations of a mechanism with a fixed set of held contacts.

    Built once per set of held contacts (the set changes only at events); calling the object
    evaluates ``y_dot`` (eq. 15) and counts the evaluations in :attr:`nfev`.

    Parameters
    ----------
    mechanism : Mechanism
        The model.
    held_contacts : sequence of str
        Contacts whose gap is held at zero as an extra bilateral constraint.
    """

    def __init__(self, mechanism: Mechanism, held_contacts: Sequence[str] = ()):
        self.mechanism = mechanism
        self.k = int(mechanism.n_coordinates)
        self.n_loops = int(mechanism.n_loop_constraints)
        self.held = tuple(held_contacts)
        self.n_constraints = self.n_loops + len(self.held)
        self.nfev = 0
        self._jdot = getattr(mechanism, "contact_jacobian_dot", None)

    # -- constraints: loops then held contact normals ---------------------------------------
    def residual(self, theta: np.ndarray) -> np.ndarray:
        """Psi(theta) of the loops (eq. 6) followed by the gaps of the held contacts."""
        parts = []
        if self.n_loops:
            parts.append(np.asarray(self.mechanism.loop_residual(theta), float).ravel())
        if self.held:
            parts.append(np.array([self.mechanism.contact_gap(c, theta) for c in self.held]))
        return np.concatenate(parts) if parts else np.zeros(0)

    def jacobian(self, theta: np.ndarray) -> np.ndarray:
        """C(theta) (eq. 7) with the held contacts' normal rows c_n^T appended."""
        rows = []
        if self.n_loops:
            rows.append(np.asarray(self.mechanism.loop_jacobian(theta), float).reshape(-1, self.k))
        for c in self.held:
            rows.append(np.asarray(self.mechanism.contact_jacobian(c, theta), float)[:1])
        return np.vstack(rows) if rows else np.zeros((0, self.k))

    def _normal_row_dot(self, name: str, theta: np.ndarray, dtheta: np.ndarray) -> np.ndarray:
        if self._jdot is not None:
            return np.asarray(self._jdot(name, theta, dtheta), float)[0]
        # directional central difference of c_n along theta_dot (exact up to O(h^2))
        speed = float(np.linalg.norm(dtheta))
        if speed == 0.0:
            return np.zeros(self.k)
        h = 1e-5 * (1.0 + float(np.linalg.norm(theta))) / speed
        jp = np.asarray(self.mechanism.contact_jacobian(name, theta + h * dtheta), float)[0]
        jm = np.asarray(self.mechanism.contact_jacobian(name, theta - h * dtheta), float)[0]
        return (jp - jm) / (2.0 * h)

    def jacobian_dot(self, theta: np.ndarray, dtheta: np.ndarray) -> np.ndarray:
        """C_dot(theta, theta_dot) (eqs. 8, 14) with the held contacts' rows appended."""
        rows = []
        if self.n_loops:
            rows.append(np.asarray(self.mechanism.loop_jacobian_dot(theta, dtheta),
                                   float).reshape(-1, self.k))
        for c in self.held:
            rows.append(self._normal_row_dot(c, theta, dtheta)[None])
        return np.vstack(rows) if rows else np.zeros((0, self.k))

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

    def __call__(self, t: float, y: np.ndarray) -> np.ndarray:
        """y_dot = [theta_dot, p_dot] (eq. 15)."""
        self.nfev += 1
        k = self.k
        theta, p = y[:k], y[k:]
        dtheta, sigma, _ = self.velocities(theta, p)
        mech = self.mechanism
        pdot = (np.asarray(mech.generalized_forces(t, theta, dtheta), float)
                + np.asarray(mech.mass_matrix_dot(theta, dtheta), float) @ dtheta)  # eq. (11)
        if len(sigma):
            pdot = pdot - self.jacobian_dot(theta, dtheta).T @ sigma  # eq. (14)
        out = np.concatenate([dtheta, pdot])
        if not np.all(np.isfinite(out)):
            raise SimulationError(
                f"the right-hand side became non-finite at t = {t:.9g} (theta = "
                f"{np.round(theta, 6).tolist()}); check the model's forces or reduce max_step")
        return out

    def multipliers(self, t: float, y: np.ndarray) -> np.ndarray:
        """Constraint forces nu = sigma_dot (eq. 9): loops first, then held-contact normals.

        From ``M theta_ddot - C^T nu = f`` and ``C theta_ddot + C_dot theta_dot = 0`` (eq. 8).
        A held contact pushes (compressive) while its entry is positive.
        """
        k = self.k
        theta, p = y[:k], y[k:]
        dtheta, _, (M, cho, C, A, scho) = self.velocities(theta, p)
        if A is None:
            return np.zeros(0)
        f = np.asarray(self.mechanism.generalized_forces(t, theta, dtheta), float)
        rhs = C @ sla.cho_solve(cho, f) + self.jacobian_dot(theta, dtheta) @ dtheta
        return -sla.cho_solve(scho, rhs)
