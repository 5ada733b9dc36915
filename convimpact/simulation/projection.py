"""Coordinate projection onto the constraint manifold Psi = 0 and C theta_dot = 0.

Integrating eqs. (13)-(14) keeps ``C theta_dot = 0`` exactly (theta_dot is solved from it) but
lets ``Psi(theta)`` drift with the integration error (the paper's closing remark of Section 2.2).
After steps whose drift exceeds a tolerance and after every impact the simulator moves theta
back onto ``Psi = 0`` by the M-weighted smallest correction (Gauss-Newton with the metric M)
and projects theta_dot M-orthogonally onto the null space of C.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla

from ..errors import AssemblyError


def project_positions(residual, jacobian, mass_matrix, theta: np.ndarray, tol: float,
                      max_iter: int = 30) -> tuple[np.ndarray, float, int]:
    """Bring theta onto ``residual(theta) = 0`` by the M-weighted minimal correction.

    Iterates ``theta <- theta - M^-1 C^T (C M^-1 C^T)^-1 Psi`` with M frozen at the start.

    Parameters
    ----------
    residual, jacobian : callables of theta returning Psi (m,) and C (m, k).
    mass_matrix : (k, k) metric M.
    theta : starting coordinates.
    tol : required max |Psi|.
    max_iter : iteration limit.

    Returns
    -------
    theta, final max |Psi|, number of iterations.

    Raises
    ------
    AssemblyError
        when the iteration does not reach ``tol`` (the message reports the residual).
    """
    theta = np.array(theta, dtype=float)
    r = np.asarray(residual(theta), float)
    if r.size == 0:
        return theta, 0.0, 0
    cho = sla.cho_factor(mass_matrix, lower=True)
    err = float(np.max(np.abs(r)))
    it = 0
    while err > tol:
        if it >= max_iter or not np.isfinite(err):
            raise AssemblyError(
                f"could not assemble the constraints Psi(theta) = 0: max |Psi| = {err:.3e} after "
                f"{it} Newton iterations (tolerance {tol:.1e}); start closer to an assembled "
                "configuration or away from a singular (dead-centre) one")
        C = np.asarray(jacobian(theta), float)
        A = sla.cho_solve(cho, C.T)
        try:
            step = A @ np.linalg.solve(C @ A, r)
        except np.linalg.LinAlgError:
            raise AssemblyError(
                f"the constraint Jacobian is singular at theta = {np.round(theta, 6).tolist()} "
                f"(max |Psi| = {err:.3e}); the closure cannot be assembled from here") from None
        theta = theta - step
        r = np.asarray(residual(theta), float)
        err = float(np.max(np.abs(r)))
        it += 1
    return theta, err, it


def project_velocities(mass_matrix: np.ndarray, C: np.ndarray, dtheta: np.ndarray) -> np.ndarray:
    """M-orthogonal projection of theta_dot onto ``C theta_dot = 0`` (eq. 7).

    ``theta_dot - M^-1 C^T (C M^-1 C^T)^-1 C theta_dot``: the velocity closest in kinetic
    energy metric, i.e. the outcome of a frictionless plastic impulse on the constraints.
    """
    dtheta = np.asarray(dtheta, float)
    if C.shape[0] == 0:
        return dtheta.copy()
    cho = sla.cho_factor(mass_matrix, lower=True)
    A = sla.cho_solve(cho, C.T)
    return dtheta - A @ np.linalg.solve(C @ A, C @ dtheta)
