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
  ``-mu lambda_n c_t^T s`` (s the unit slip direction: the slip velocity's, or in space one
  frozen for the segment while the slip keeps it, :mod:`~.event_watch`) is a generalized
  force driven by the normal multiplier, so ``p_dot = f + M_dot theta_dot - C_dot^T sigma + D nu`` with ``D`` the
  friction columns; the multipliers solve ``C M^-1 (C^T + D) nu = -(C M^-1 f + C_dot theta_dot)``,
  a non-symmetric system whose singularity is Painleve's;
* ``"frictionless"``: the normal row only (a bilateral frictionless constraint).

Only the normal rows (gaps) are position constraints (``residual``, ``position_jacobian``);
tangential rows constrain velocities. Rows found redundant at the event that formed the set
(``dropped``: a box on two corners sticking has one tangential row too many) are left out of
the constraints; where a held contact slides with friction their forces stay unknowns (the
distribution of a sliding redundant group moves the motion: the least-norm one, from the
force problem's at the segment's start, :meth:`CanonicalEquations._multipliers`).

One evaluation factors M once (Cholesky) and shares the factor between the velocities, the
multipliers and the friction columns. For a :class:`~convimpact.model.ModelMechanism` the
terms come from its compiled passes without copies or conversions (the run validated its
initial state): one per configuration (M, its factor, every contact Jacobian) and one per
velocity (f, p_dot = f + M_dot theta_dot by Lagrange's equations, the contact Jacobians'
exact rates). Any other
:class:`~convimpact.mechanism.Mechanism` is evaluated through the protocol (f + M_dot
theta_dot; ``contact_jacobian_dot`` when it has one, else a central difference).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Mapping, Sequence

import numpy as np

from ..errors import NonFiniteError, SimulationError
from ..mechanism import Mechanism
from ..model import recursive as _rc
from .canonical_compiled import CompiledHeldPath
from .canonical_forces import Factors, HeldForces, _cho_solve, _cholesky  # noqa: F401 (used here and by sustained)

#: a held contact's rows: (contact name, row of its Jacobian: 0 normal, 1.. tangents)
Row = tuple[str, int]
#: configurations whose position terms are remembered (an evaluation and the queries that
#: follow it at the same state ask for them several times)
POSITION_MEMO = 4


@dataclass(frozen=True)
class HeldMode:
    """How a held contact is closed: ``kind`` "stick", "slip" or "frictionless".

    ``direction`` is, for "slip", the unit slip direction in the contact's tangent basis at
    the start of the segment (planar: ``(+1,)`` or ``(-1,)``); spatial slips follow the slip
    velocity's direction during the segment and use ``direction`` only while it is ~0 (an
    onset). ``mu`` is the contact's friction coefficient. ``frozen`` (spatial "slip"): the
    friction keeps ``direction`` during the whole segment instead of following the slip
    velocity; the run holds it so only while the slip velocity keeps that direction (to
    :data:`~.event_watch.SLIP_TURN_TOL` rad, an event otherwise: see
    :mod:`~convimpact.simulation.event_watch`), where the two are the same force.
    """

    kind: str = "frictionless"
    direction: tuple[float, ...] = ()
    mu: float = 0.0
    frozen: bool = False


FRICTIONLESS = HeldMode()


def _is_model(mechanism) -> bool:
    """True for a :class:`~convimpact.model.ModelMechanism` evaluated as it is (no subclass
    overriding the protocol, no wrapper forwarding to one)."""
    from ..model.mechanism import ModelMechanism
    if not isinstance(mechanism, ModelMechanism):
        return False
    cls = type(mechanism)
    return all(getattr(cls, m) is getattr(ModelMechanism, m)
               for m in ("mass_matrix", "mass_matrix_dot", "generalized_forces",
                         "contact_jacobian", "contact_gap", "rhs_positions", "rhs_velocities"))


class CanonicalEquations(HeldForces, CompiledHeldPath):
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
        self._model = _is_model(mechanism)
        self.rows: list[Row] = []
        self.position_rows: list[Row] = []
        self.slipping: list[tuple[str, int]] = []  # (contact, index of its normal row)
        dim_of: dict[str, int] = {}
        for c in self.held:
            mode = self.modes[c]
            dim = 1
            if mode.kind == "stick":
                if dims and c in dims:
                    dim = int(dims[c])
                elif self._model:
                    dim = mechanism.data.d
                else:
                    dim = int(np.asarray(mechanism.contact_jacobian(c, np.zeros(self.k)),
                                         float).shape[0])
            dim_of[c] = dim
            for j in range(dim):
                if (c, j) in self.dropped:
                    continue
                if j == 0:
                    self.position_rows.append((c, 0))
                    if mode.kind == "slip" and mode.mu > 0.0:
                        self.slipping.append((c, len(self.rows)))
                self.rows.append((c, j))
        self.n_constraints = self.n_loops + len(self.rows)
        #: where a contact slides with friction, the dropped (redundant) rows' forces are
        #: unknowns too, past the constraints' (the sliding redundant group's distribution
        #: moves the motion: :meth:`_multipliers`; without loops only): ``redundant`` those
        #: rows, ``redundant_slipping`` the sliding contacts among them (normal rows)
        self.redundant: list[Row] = []
        self.redundant_slipping: list[str] = []
        if not self.n_loops and self.dropped and any(
                self.modes[c].kind == "slip" and self.modes[c].mu > 0.0 for c in self.held):
            for c in self.held:
                mode = self.modes[c]
                for j in range(dim_of[c]):
                    if (c, j) not in self.dropped:
                        continue
                    if j == 0 and mode.kind == "slip" and mode.mu > 0.0:
                        self.slipping.append((c, len(self.rows) + len(self.redundant)))
                        self.redundant_slipping.append(c)
                    self.redundant.append((c, j))
        #: the force unknowns: the constraints' multipliers, then the redundant rows' forces
        self.n_unknowns = self.n_constraints + len(self.redundant)
        #: the redundant sliding group's offset from its least-norm distribution (n_unknowns,)
        #: or None: set at the segment's start (:meth:`start_from`)
        self.offset: np.ndarray | None = None
        self.nfev = 0
        self._jdot = getattr(mechanism, "contact_jacobian_dot", None)
        self._memo: dict[bytes, Factors] = {}
        if self._model:
            index = {c: mechanism.contact_index(c) for c in self.held}
            self._held_index = np.array([index[c] for c in self.held], dtype=np.intp)
            self._row_contact = np.array([index[c] for c, _ in self.rows], dtype=np.intp)
            self._row_row = np.array([j for _, j in self.rows], dtype=np.intp)
            self._d = mechanism.data.d
            self._slip_index = np.array([index[c] for c, _ in self.slipping], dtype=np.intp)
            self._extra_contact = np.array([index[c] for c, _ in self.redundant], dtype=np.intp)
            self._extra_row = np.array([j for _, j in self.redundant], dtype=np.intp)
        #: the sliding contacts' columns among the constraints
        self._slip_cols = np.array([self.n_loops + i for _, i in self.slipping], dtype=np.intp)
        #: the compiled right-hand side (:mod:`.canonical_kernels`): a model, held rows,
        #: no loops
        self._compiled = self._model and bool(self.rows) and not self.n_loops
        if self._compiled:  # nu, power, indicator, the slip directions
            self._aux_size = (self.n_unknowns + 2
                              + len(self.slipping) * max(self._d - 1, 1))
        #: the last state's compiled velocities and terms (asked for several times at a
        #: step's end)
        self._velocity_memo = self._terms_memo = None
        #: changes of the stored slip directions (:meth:`set_slip_direction`), and the
        #: compiled path's arrays of them (modes, version, directions, mu)
        self._modes_version = 0
        self._slip_arrays = None

    # ---- terms of one configuration ---------------------------------------------------------
    def factors(self, theta: np.ndarray, constraints: bool = True) -> Factors:
        """M, its Cholesky factor, the held contacts' Jacobians and C at theta, and with
        ``constraints`` ``M^-1 C^T`` and the factor of ``C M^-1 C^T`` (the last few
        configurations are remembered)."""
        theta = np.ascontiguousarray(theta, dtype=float)
        key = theta.tobytes()
        F = self._memo.get(key)
        if F is None:
            F = self._positions(theta)
            if len(self._memo) >= POSITION_MEMO:
                self._memo.pop(next(iter(self._memo)))
            self._memo[key] = F
        if constraints and F.A is None and F.C.shape[0]:
            A = _cho_solve(F.L, F.C.T)  # M^-1 C^T
            S = F.C @ A  # C M^-1 C^T
            SL = _cholesky(S)
            if SL is None:
                raise SimulationError(
                    "the constraint Jacobian (loops and held contacts) lost rank: C M^-1 C^T is "
                    "singular (a dead-centre configuration or redundant held contacts)")
            F.A, F.SL, F.S = A, SL, S
        return F

    def _positions(self, theta: np.ndarray) -> Factors:
        if self._model:
            d = self.mechanism.rhs_positions(theta)
            M = d.M.copy()
            L = d.L.copy() if d.chol_ok else None
            rows = d.contact_jacobian[self._row_contact, self._row_row] if self.rows else None
            jac = {c: d.contact_jacobian[i, :self._d].copy()
                   for c, i in zip(self.held, self._held_index)}
        else:
            M = np.asarray(self.mechanism.mass_matrix(theta), float)
            L = _cholesky(M)
            jac = {c: np.asarray(self.mechanism.contact_jacobian(c, theta), float)
                   for c in self.held}
            rows = (np.array([jac[c][j] if j < len(jac[c]) else np.zeros(self.k)
                              for c, j in self.rows]) if self.rows else None)
        if L is None:
            raise SimulationError(
                f"the mass matrix is not positive definite or not finite at theta = "
                f"{np.round(theta, 6).tolist()}")
        parts = []
        if self.n_loops:
            parts.append(np.asarray(self.mechanism.loop_jacobian(theta), float).reshape(-1, self.k))
        if rows is not None:
            parts.append(rows)
        C = (parts[0] if len(parts) == 1 else np.vstack(parts)) if parts else np.zeros((0, self.k))
        return Factors(M, L, C, None, None, jac)

    def contact_jacobians(self, theta: np.ndarray) -> dict[str, np.ndarray]:
        """The full Jacobians (rows n, t...) of the held contacts at theta."""
        return self.factors(theta, constraints=False).jac

    # ---- terms of one state -----------------------------------------------------------------
    def _rates(self, t: float, theta: np.ndarray, dtheta: np.ndarray, rates: bool):
        """(f, p_dot without constraint forces, the held rows' rates or None) at the state."""
        if self._model:
            f, pdot, d = self.mechanism.rhs_velocities(t, theta, dtheta, rates and bool(self.rows))
            Jd = (d.contact_jacobian_dot[self._row_contact, self._row_row]
                  if rates and self.rows else None)
            return f, pdot, Jd
        mech = self.mechanism
        f = np.asarray(mech.generalized_forces(t, theta, dtheta), float)
        pdot = f + np.asarray(mech.mass_matrix_dot(theta, dtheta), float) @ dtheta  # eq. (11)
        Jd = None
        if rates and self.rows:
            jd = self.contact_jacobians_dot(theta, dtheta)
            Jd = np.array([jd[c][j] if j < len(jd[c]) else np.zeros(self.k)
                           for c, j in self.rows])
        return f, pdot, Jd

    def generalized_forces(self, t: float, theta: np.ndarray, dtheta: np.ndarray) -> np.ndarray:
        """f of eq. (4) at the state (the mechanism's, through the fast pass when it has one)."""
        theta = np.ascontiguousarray(theta, dtype=float)
        dtheta = np.ascontiguousarray(dtheta, dtype=float)
        return self._rates(t, theta, dtheta, False)[0]

    def contact_jacobians_dot(self, theta: np.ndarray,
                              dtheta: np.ndarray) -> dict[str, np.ndarray]:
        """d/dt of the held contacts' Jacobians along theta_dot (exact when the mechanism
        has ``contact_jacobian_dot``, else a directional central difference, O(h^2))."""
        if self._model:
            theta = np.ascontiguousarray(theta, dtype=float)
            dtheta = np.ascontiguousarray(dtheta, dtype=float)
            _, _, d = self.mechanism.rhs_velocities(0.0, theta, dtheta, True)
            return {c: d.contact_jacobian_dot[i, :self._d].copy()
                    for c, i in zip(self.held, self._held_index)}
        if self._jdot is not None:
            return {c: np.asarray(self._jdot(c, theta, dtheta), float) for c in self.held}
        speed = float(np.linalg.norm(dtheta))
        if speed == 0.0 or not self.held:
            return {c: np.zeros((1, self.k)) for c in self.held}
        h = 1e-5 * (1.0 + float(np.linalg.norm(theta))) / speed
        jp = {c: np.asarray(self.mechanism.contact_jacobian(c, theta + h * dtheta), float)
              for c in self.held}
        jm = {c: np.asarray(self.mechanism.contact_jacobian(c, theta - h * dtheta), float)
              for c in self.held}
        return {c: (jp[c] - jm[c]) / (2.0 * h) for c in self.held}

    # ---- constraints -------------------------------------------------------------------------
    def residual(self, theta: np.ndarray) -> np.ndarray:
        """Psi(theta) of the loops (eq. 6) followed by the held contacts' gaps."""
        parts = []
        if self.n_loops:
            parts.append(np.asarray(self.mechanism.loop_residual(theta), float).ravel())
        if self.position_rows:
            gaps = None
            if self._model:  # one compiled pass for every gap (the same numbers)
                d = self.mechanism.rhs_positions(np.ascontiguousarray(theta, dtype=float))
                idx = [self.mechanism.contact_index(c) for c, _ in self.position_rows]
                if d.contact_ok[idx].all():  # (else contact_gap raises the typed error)
                    gaps = d.gap[idx]
            if gaps is None:
                gaps = np.array([self.mechanism.contact_gap(c, theta)
                                 for c, _ in self.position_rows])
            parts.append(gaps)
        return np.concatenate(parts) if parts else np.zeros(0)

    def position_jacobian(self, theta: np.ndarray) -> np.ndarray:
        """The Jacobian of :meth:`residual`: loops' C and the held contacts' normal rows."""
        C = self.factors(theta, constraints=False).C
        if len(self.position_rows) == len(self.rows):
            return C.copy()
        keep = list(range(self.n_loops)) + [self.n_loops + i for i, (_, j) in
                                            enumerate(self.rows) if j == 0]
        return C[keep]

    def jacobian(self, theta: np.ndarray) -> np.ndarray:
        """C(theta) (eq. 7) with the held contacts' rows appended (velocity constraints)."""
        return self.factors(theta, constraints=False).C.copy()

    def jacobian_dot(self, theta: np.ndarray, dtheta: np.ndarray) -> np.ndarray:
        """C_dot(theta, theta_dot) (eqs. 8, 14) with the held contacts' rows appended."""
        theta = np.ascontiguousarray(theta, dtype=float)
        dtheta = np.ascontiguousarray(dtheta, dtype=float)
        _, _, Jd = self._rates(0.0, theta, dtheta, True)
        return self._cdot(theta, dtheta, Jd)

    def _cdot(self, theta: np.ndarray, dtheta: np.ndarray, Jd) -> np.ndarray:
        parts = []
        if self.n_loops:
            parts.append(np.asarray(self.mechanism.loop_jacobian_dot(theta, dtheta),
                                    float).reshape(-1, self.k))
        if Jd is not None:
            parts.append(Jd)
        if not parts:
            return np.zeros((0, self.k))
        return parts[0] if len(parts) == 1 else np.vstack(parts)

    def slip_direction(self, c: str, jac: np.ndarray, dtheta: np.ndarray) -> np.ndarray:
        """The unit slip direction of sliding contact ``c`` (tangent basis): the slip
        velocity's in space (the stored one while it is ~0), the stored sign in the plane."""
        mode = self.modes[c]
        stored = np.asarray(mode.direction, float)
        if len(jac) == 2 or mode.frozen:
            return stored
        vt = jac[1:] @ dtheta
        norm = math.sqrt(float(vt @ vt))
        if not (norm > self.slip_floor and norm > 0.0):
            return stored
        # past a reversal of the slip (vt against the stored direction, which the run
        # updates at every accepted step) the segment is over: the event "slip:<c>" stops it
        # there. The mode's equations are continued smoothly through it (the friction keeps
        # its direction, as while the slip speed is below the floor), so that the
        # integrator's stages beyond the stop see no jump and its steps need not shrink onto
        # the stop; before it, this is the slip velocity's direction.
        if stored.shape != vt.shape or float(vt @ stored) >= 0.0:
            return vt / norm
        return -vt / norm

    def slip_directions(self, contacts: Sequence[str], J: np.ndarray,
                        dtheta: np.ndarray) -> np.ndarray | None:
        """(n, d - 1): :meth:`slip_direction` of each of the sliding ``contacts`` (spatial,
        J (n, d, k) their Jacobians) at once, by the same rules, the slip velocities in one
        product; None where one has no stored direction or the contacts are planar (then
        :meth:`slip_direction` one by one)."""
        n, d = J.shape[0], J.shape[1]
        modes = [self.modes[c] for c in contacts]
        if d != 3 or any(len(m.direction) != 2 for m in modes):
            return None
        out = np.array([m.direction for m in modes], float).reshape(n, 2)  # the stored
        V = J[:, 1:, :] @ dtheta  # (n, 2): the slip velocities
        norm = np.sqrt(np.einsum("ij,ij->i", V, V))
        follow = ((norm > self.slip_floor) & (norm > 0.0)
                  & ~np.array([m.frozen for m in modes], dtype=bool))
        sign = np.where(np.einsum("ij,ij->i", V, out) >= 0.0, 1.0, -1.0)
        out[follow] = sign[follow, None] * V[follow] / norm[follow, None]
        return out

    def set_slip_direction(self, c: str, direction) -> None:
        """Store ``direction`` (unit, tangent basis) as sliding contact ``c``'s slip
        direction (its :class:`HeldMode`'s ``direction``; the run does at each step)."""
        mode = self.modes[c]
        self.modes[c] = HeldMode(mode.kind, tuple(float(x) for x in direction), mode.mu,
                                 mode.frozen)
        self._modes_version += 1

    def friction_columns(self, theta: np.ndarray, dtheta: np.ndarray,
                         jac: Mapping[str, np.ndarray] | None = None) -> np.ndarray:
        """D (k, n_unknowns): the generalized friction force per unit normal multiplier
        of each sliding contact, ``-mu c_t^T s`` in its normal row's column (a redundant
        sliding contact's: in its column past the constraints')."""
        D = np.zeros((self.k, self.n_unknowns))
        if not self.slipping:
            return D
        jac = self.contact_jacobians(theta) if jac is None else jac
        for c, i in self.slipping:
            s = self.slip_direction(c, jac[c], dtheta)
            D[:, self.n_loops + i] = -self.modes[c].mu * (jac[c][1:].T @ s)
        return D

    # ---- eqs. (7) + (13) ---------------------------------------------------------------------
    def velocities(self, theta: np.ndarray, p: np.ndarray):
        """theta_dot and sigma from ``M theta_dot - C^T sigma = p``, ``C theta_dot = 0``.

        Returns
        -------
        dtheta, sigma, :class:`Factors` of theta
        """
        F = self.factors(theta)
        dtheta = _cho_solve(F.L, p)  # eq. (10)
        if not F.C.shape[0]:
            return dtheta, np.zeros(0), F
        sigma = -_cho_solve(F.SL, F.C @ dtheta)  # eqs. (7), (13)
        return dtheta + F.A @ sigma, sigma, F

    def momentum(self, theta: np.ndarray, dtheta: np.ndarray,
                 sigma: np.ndarray | None = None) -> np.ndarray:
        """p = M theta_dot - C^T sigma (eq. 13; eq. 10 for open loops)."""
        if self._model:
            M = self.mechanism.rhs_positions(np.ascontiguousarray(theta, dtype=float)).M
        else:
            M = np.asarray(self.mechanism.mass_matrix(theta), float)
        p = M @ dtheta
        if sigma is not None and len(sigma):
            p = p - self.factors(theta, constraints=False).C.T @ sigma
        return p

    def __call__(self, t: float, y: np.ndarray) -> np.ndarray:
        """y_dot = [theta_dot, p_dot] (eq. 15)."""
        self.nfev += 1
        k = self.k
        theta, p = y[:k], y[k:]
        if self._model and not self.n_constraints:  # free motion: two compiled passes
            out = self._free_rate(t, theta, p)
            if out is not None:
                return out
        elif self._compiled:  # held contacts, no loops: the compiled passes
            out = self._held_rate(t, theta, p)
            if out is not None:
                return out
        try:
            dtheta, sigma, F = self.velocities(theta, p)
            constrained = len(sigma) > 0
            f, pdot, Jd = self._rates(t, theta, dtheta, constrained)  # eq. (11)
        except NonFiniteError:
            pdot = None
        if pdot is not None and constrained:
            Cdot = self._cdot(theta, dtheta, Jd)
            pdot = pdot - Cdot.T @ sigma  # eq. (14)
            if self.slipping:  # Coulomb friction of the sliding contacts, driven by nu_n
                nu, D = self._multipliers(t, theta, dtheta, F, f, Cdot)
                pdot = pdot + D @ nu
        out = np.concatenate([dtheta, pdot]) if pdot is not None else None
        if out is None or not _rc.all_finite(out):
            raise SimulationError(
                f"the right-hand side became non-finite at t = {t:.9g} (theta = "
                f"{np.round(theta, 6).tolist()}); check the model's forces or reduce max_step")
        return out

    def _free_rate(self, t: float, theta: np.ndarray, p: np.ndarray) -> np.ndarray | None:
        """y_dot with no constraint in force (the model's two compiled passes,
        :meth:`~convimpact.model.mechanism.ModelMechanism.rhs_free`): the general path's
        numbers without its factor cache; None where that path must decide (M not positive
        definite, a non-finite state or rate)."""
        out = np.empty(2 * self.k)
        try:
            ok = self.mechanism.rhs_free(t, np.ascontiguousarray(theta, dtype=float),
                                         np.ascontiguousarray(p, dtype=float), out)
        except NonFiniteError:
            return None
        return out if ok and _rc.all_finite(out) else None
