"""What a simulator needs from a mechanism: the contract between modelling and integration.

:class:`Mechanism` is a structural protocol (``typing.Protocol``). The joint-coordinate models
of :mod:`convimpact.model` satisfy it, and so can any user object (a hand-written particle, a
Pinocchio wrapper). Every method is a plain function of the state (theta, theta_dot); nothing
here keeps state between calls.
"""

from __future__ import annotations

from typing import Protocol, Sequence, runtime_checkable

import numpy as np


@runtime_checkable
class Mechanism(Protocol):
    """A multibody system in joint coordinates theta (k of them) with m loop constraints.

    Attributes
    ----------
    n_coordinates : int
        k, the number of joint coordinates (the dimension of theta).
    n_loop_constraints : int
        m, the number of loop-closure constraints Psi(theta) = 0 (0 for open trees).
    contact_names : sequence of str
        The candidate contacts, in a fixed order.
    """

    n_coordinates: int
    n_loop_constraints: int
    contact_names: Sequence[str]

    def mass_matrix(self, theta: np.ndarray) -> np.ndarray:
        """M(theta) = B^T M B, (k, k) symmetric positive definite (eq. 3)."""

    def mass_matrix_dot(self, theta: np.ndarray, dtheta: np.ndarray) -> np.ndarray:
        """dM/dt along theta_dot, (k, k) (for eq. 11: p_dot = f + M_dot theta_dot)."""

    def generalized_forces(self, t: float, theta: np.ndarray, dtheta: np.ndarray) -> np.ndarray:
        """f = B^T (g - M B_dot theta_dot) with gravity and applied joint forces (eq. 4), (k,)."""

    def loop_residual(self, theta: np.ndarray) -> np.ndarray:
        """Psi(theta), (m,) (eq. 6)."""

    def loop_jacobian(self, theta: np.ndarray) -> np.ndarray:
        """C(theta) = dPsi/dtheta, (m, k) (eq. 7)."""

    def loop_jacobian_dot(self, theta: np.ndarray, dtheta: np.ndarray) -> np.ndarray:
        """C_dot(theta, theta_dot), (m, k) (eqs. 8, 14)."""

    def contact_gap(self, name: str, theta: np.ndarray) -> float:
        """Signed gap of a contact: > 0 separated, 0 touching, < 0 penetrating."""

    def contact_jacobian(self, name: str, theta: np.ndarray) -> np.ndarray:
        """Contact Jacobian in the contact frame, rows n, t (2, k) or n, t1, t2 (3, k).

        The normal points toward body i, so d(gap)/dt = Jc[0] @ theta_dot.
        """

    def contact_parameters(self, name: str) -> tuple[float, float]:
        """(e, mu) of a contact: restitution and friction coefficients."""

    def kinetic_energy(self, theta: np.ndarray, dtheta: np.ndarray) -> float:
        """T = 1/2 theta_dot^T M theta_dot."""

    def potential_energy(self, theta: np.ndarray) -> float:
        """V(theta) of gravity (and of conservative applied forces, if any)."""
