"""A model as a :class:`convimpact.mechanism.Mechanism`: the object simulators and scenes use.

:class:`ModelMechanism` pairs an immutable :class:`~convimpact.model.builder.Model` with one
private :class:`~convimpact.model.data.Data` and forwards each protocol method to the
evaluation functions, so M, f, C and the contact Jacobians at one state share one tree walk.
Obtain it with ``model.mechanism()``.

The protocol methods validate their input (shape, finiteness: checked by the compiled pass
itself, at no cost) and return new arrays. The simulator's right-hand side uses the entry
points :meth:`ModelMechanism.rhs_positions` and :meth:`ModelMechanism.rhs_velocities`
instead, which hand out the workspace itself (no copies): one compiled pass per configuration
gives M, its Cholesky factor and every contact's gap and Jacobian; one per velocity gives f,
p_dot = f + M_dot theta_dot and the contact Jacobians' time derivatives.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from . import contacts as _contacts
from . import dynamics as _dyn
from . import kinematics as _kin
from . import loops as _loops
from . import recursive as _rc

#: stages of one configuration pass of the right-hand side
RHS_POSITIONS = _rc.MASS | _rc.CHOL | _rc.CONTACT
#: stages of one velocity pass (CDOT added when contact rates are asked for)
RHS_VELOCITIES = _rc.BIAS


class ModelMechanism:
    """A joint-coordinate model evaluated through the Mechanism protocol.

    Parameters
    ----------
    model : the :class:`~convimpact.model.builder.Model` to evaluate (``model.mechanism()``
        builds this object).

    Attributes
    ----------
    model : the underlying :class:`Model`.
    data : the :class:`~convimpact.model.data.Data` workspace (last evaluated state).
    n_coordinates, n_loop_constraints, contact_names, coordinate_names : as in the model.
    """

    def __init__(self, model):
        self.model = model
        self.data = model.create_data()
        self.n_coordinates: int = model.n_coordinates
        self.n_loop_constraints: int = model.n_loop_constraints
        self.contact_names: Sequence[str] = model.contact_names
        self.coordinate_names: Sequence[str] = model.coordinate_names

    def __repr__(self) -> str:
        kind = "planar" if self.model.planar else "spatial"
        return (f"ModelMechanism({kind}, k={self.n_coordinates}, "
                f"m={self.n_loop_constraints}, contacts={list(self.contact_names)})")

    @property
    def planar(self) -> bool:
        return self.model.planar

    # -- Mechanism protocol -------------------------------------------------------------
    def mass_matrix(self, theta: np.ndarray) -> np.ndarray:
        """M(theta) = B^T M B, (k, k) (eq. 3)."""
        return _dyn.mass_matrix(self.model, self.data, theta)

    def mass_matrix_dot(self, theta: np.ndarray, dtheta: np.ndarray) -> np.ndarray:
        """dM/dt along theta_dot, (k, k) (eq. 11)."""
        return _dyn.mass_matrix_dot(self.model, self.data, theta, dtheta)

    def generalized_forces(self, t: float, theta: np.ndarray, dtheta: np.ndarray) -> np.ndarray:
        """f = B^T (g - M B_dot theta_dot) + applied joint forces, (k,) (eq. 4)."""
        return _dyn.generalized_forces(self.model, self.data, t, theta, dtheta)

    def momentum_rate(self, t: float, theta: np.ndarray, dtheta: np.ndarray) -> np.ndarray:
        """p_dot = f + M_dot theta_dot with the applied forces, (k,) (eq. 11), in one pass."""
        return _dyn.momentum_rate(self.model, self.data, t, theta, dtheta)

    def loop_residual(self, theta: np.ndarray) -> np.ndarray:
        """Psi(theta), (m,) (eq. 6)."""
        return _loops.loop_residual(self.model, self.data, theta)

    def loop_jacobian(self, theta: np.ndarray) -> np.ndarray:
        """C(theta), (m, k) (eq. 7)."""
        return _loops.loop_jacobian(self.model, self.data, theta)

    def loop_jacobian_dot(self, theta: np.ndarray, dtheta: np.ndarray) -> np.ndarray:
        """C_dot(theta, theta_dot), (m, k) (eqs. 8, 14)."""
        return _loops.loop_jacobian_dot(self.model, self.data, theta, dtheta)

    def contact_gap(self, name: str, theta: np.ndarray) -> float:
        """Signed gap of contact ``name``."""
        return _contacts.contact_gap(self.model, self.data, name, theta)

    def contact_jacobian(self, name: str, theta: np.ndarray) -> np.ndarray:
        """Jc of contact ``name``, rows n, t (2, k) or n, t1, t2 (3, k)."""
        return _contacts.contact_jacobian(self.model, self.data, name, theta)

    def contact_jacobian_dot(self, name: str, theta: np.ndarray, dtheta: np.ndarray) -> np.ndarray:
        """d Jc / dt along theta_dot of contact ``name``, (2, k) or (3, k) (exact)."""
        return _contacts.contact_jacobian_dot(self.model, self.data, name, theta, dtheta)

    def contact_parameters(self, name: str) -> tuple[float, float]:
        """(e, mu) of contact ``name``."""
        spec = self.model.contact(name)
        return spec.restitution, spec.friction

    def kinetic_energy(self, theta: np.ndarray, dtheta: np.ndarray) -> float:
        """T = 1/2 theta_dot^T M theta_dot."""
        return _dyn.kinetic_energy(self.model, self.data, theta, dtheta)

    def potential_energy(self, theta: np.ndarray) -> float:
        """Gravitational potential energy."""
        return _dyn.potential_energy(self.model, self.data, theta)

    # -- the simulator's right-hand side: the workspace itself, no copies -----------------
    def contact_index(self, name: str) -> int:
        """Position of contact ``name`` in :attr:`contact_names` (and in the Data arrays)."""
        return _contacts._index(self.model, name)

    def rhs_positions(self, theta: np.ndarray):
        """M, its lower Cholesky factor and every contact's gap, frame and Jacobian at theta
        (a float64 C-contiguous (k,) array: the fast path). Returns the
        :class:`~convimpact.model.data.Data` (its arrays are views, overwritten by the next
        evaluation at another state; ``data.chol_ok`` False when M is not positive definite)."""
        self.data.compute(RHS_POSITIONS, theta)
        return self.data

    def rhs_velocities(self, t: float, theta: np.ndarray, dtheta: np.ndarray,
                       contact_rates: bool = False):
        """``(f, p_dot, data)`` at (t, theta, theta_dot): f of eq. (4) and p_dot = f + M_dot
        theta_dot of eq. (11), both with the applied forces (new arrays; the applied forces
        are not validated), and the Data holding the contact Jacobians' rates when
        ``contact_rates``."""
        d = self.data
        d.compute(RHS_VELOCITIES | (_rc.CDOT if contact_rates else 0), theta, dtheta)
        f = d.bias.copy()
        pdot = d.momentum_rate.copy()
        applied = self.model.applied_forces
        if applied is not None:
            Q = np.asarray(applied(t, theta.copy(), dtheta.copy()), dtype=float)
            f += Q
            pdot += Q
        return f, pdot, d

    def rhs_free(self, t: float, theta: np.ndarray, p: np.ndarray, out: np.ndarray) -> bool:
        """The canonical equations' rate with no constraint in force, written into ``out``
        (2k,): ``out[:k] = theta_dot = M^-1 p`` and ``out[k:] = p_dot = f + M_dot theta_dot``
        (eqs. 10, 11, with the applied forces). ``theta``, ``p`` and ``out`` float64
        C-contiguous. Returns False (``out`` undefined) when M is not positive definite."""
        d = self.data
        d.compute(RHS_POSITIONS, theta)
        if not d.chol_ok:
            return False
        k = theta.shape[0]
        dtheta = out[:k]
        _rc.cho_solve_vec(d.L, p, dtheta)
        d.compute(RHS_VELOCITIES, theta, dtheta)
        out[k:] = d.momentum_rate
        applied = self.model.applied_forces
        if applied is not None:
            out[k:] += np.asarray(applied(t, theta.copy(), dtheta.copy()), dtype=float)
        return True

    # -- extras ---------------------------------------------------------------------------
    def contact_frame(self, name: str, theta: np.ndarray) -> _contacts.ContactFrame:
        """Gap, contact point, normal, tangents and Jc of contact ``name``."""
        return _contacts.contact_frame(self.model, self.data, name, theta)

    def velocity_transformation(self, theta: np.ndarray) -> np.ndarray:
        """B of eq. (1), stacking (c_dot, w) of every moving body."""
        return _dyn.velocity_transformation(self.model, self.data, theta)

    def coordinate_index(self, name: str) -> int:
        """Index in theta of a coordinate (or one-coordinate joint) name."""
        return self.model.coordinate_index(name)

    def point_position(self, body: str, local, theta: np.ndarray) -> np.ndarray:
        """World position of a point given in body ``body``'s frame."""
        b = _kin.body_index(self.model, body)
        _kin.ensure_configuration(self.model, self.data, theta)
        return _kin.world_point(self.data, b, np.asarray(local, dtype=float))

    def point_jacobian(self, body: str, local, theta: np.ndarray) -> np.ndarray:
        """Jacobian (d, k) of the velocity of a point given in body ``body``'s frame."""
        x = self.point_position(body, local, theta)
        return _kin.point_jacobian(self.model, self.data, _kin.body_index(self.model, body), x)[0]

    def body_placement(self, body: str, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """World (rotation, origin) of body ``body``'s frame."""
        _kin.ensure_configuration(self.model, self.data, theta)
        return _kin.frame_placement(self.model, self.data, body)

    def assemble(self, theta: np.ndarray, fixed: Sequence = (), tol: float = 1e-12,
                 max_iter: int = 50) -> np.ndarray:
        """Newton assembly onto Psi = 0 (see :func:`convimpact.model.loops.assemble`)."""
        return _loops.assemble(self, theta, fixed, tol, max_iter)

    def consistent_velocity(self, theta: np.ndarray, dtheta: np.ndarray,
                            fixed: Sequence = ()) -> np.ndarray:
        """Velocities satisfying C theta_dot = 0 (see :func:`convimpact.model.loops.consistent_velocity`)."""
        return _loops.consistent_velocity(self, theta, dtheta, fixed)
