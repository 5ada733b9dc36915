"""Saltation matrices of the event-driven scheme: how a state perturbation crosses an event.

At an event the state jumps by a reset map and/or the vector field switches. In the physical
state ``x = (theta, theta_dot)`` (theta is continuous at every event), with ``X = dx+/dx-``
the Jacobian of the reset (the impacts' jump in theta_dot, the velocity projections onto the
contacts that close; the identity at a lift-off or a stick/slip transition), ``g`` the
switching function that located the event (a gap at an impact, a normal force at a lift-off,
the friction-cone margin at a stick-to-slip transition, a slip velocity at a slip-to-stick
one) and ``x_dot-`` / ``x_dot+`` the rates before and after, the saltation matrix is

    S = X + (x_dot+ - X x_dot-) g_x / (g_x x_dot-),

the classic ``R_y + (f+ - R_y f-) g_y / (g_y f-)`` written in x. With parameters q (the
restitution and friction coefficients), a perturbation ``s = dx/dq`` jumps by

    s+ = S s- + X_q + (x_dot+ - X x_dot-) g_q / (g_x x_dot-),

``X_q`` the reset's dependence on q (the impact law's ``d dq_plus / d(e, mu)``) and ``g_q``
the switching function's (the friction margin's on mu). The event time moves by
``dtau = -(g_x dx- + g_q dq) / (g_x x_dot-)``.

The impact law's part of ``X`` is the analytic derivative of ``resolve_impact``
(``derivatives=True``); its dependence on the configuration through ``M(theta)`` and
``Jc(theta)`` and every other smooth model function is differenced
(:func:`~convimpact.simulation.variational.central_jacobian`, ~1e-9 relative).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from ..impact.results import _jsonable
from .canonical import CanonicalEquations
from .run_record import project_onto
from .sustained import held_forces
from .variational import (central_derivative, central_jacobian, physical, physical_rate,
                          with_friction)


@dataclass(frozen=True, eq=False)
class EventSensitivity:
    """How state and parameter perturbations cross one event instant.

    Attributes
    ----------
    time : the instant.
    kind : "impact", "lift-off", "stick-slip", "slip-stick", "slip-reversal", "touch" (a
        contact found closing at rest), "start" (the contacts touching at t0, a fixed
        instant) or "mode" (a margin reached zero and the force problem kept the modes).
    contacts : the contact whose switching function located the event (the impacting
        contacts for an impact); empty at the start.
    switching : what that function is ("gap", "normal force", "friction margin", "slip
        velocity", or "none" for the fixed start).
    saltation : (2k, 2k) ``dx+/dx-`` in x = (theta, theta_dot), the event time's shift
        included (see the module docstring).
    reset_jacobian : (2k, 2k) ``X``, the reset map's Jacobian alone (event time fixed).
    parameter_jump : {"e": (2k, n_contacts), "mu": (2k, n_contacts)}: the jump of
        ``dx/d(e, mu)`` across the event, columns in the order of ``contact_names``.
    time_gradient : (2k,) ``d tau / dx-`` (zero at the start).
    rate_minus, rate_plus : (2k,) x_dot just before and just after.
    parameter_time_gradient : {"e", "mu": (n_contacts,)} ``d tau / d(e, mu)`` at a fixed
        pre-event state (nonzero for mu at a stick-to-slip transition, whose friction
        margin depends on mu).
    state_transition : (2k, 2k) ``dx(tau+)/dx(t_0)``: the state just after this event as a
        function of the initial state, the event's time tau moving with it (on a Poincare
        section at this event, the return map's Jacobian). It differs from the fixed-time
        derivative ``saltation @ dx(tau-)/dx(t_0)`` by ``x_dot+ dtau/dx(t_0)``.
    parameter_sensitivity : {"e", "mu": (2k, n_contacts)} ``dx(tau+)/d(e, mu)``, likewise.
    time_sensitivity : {"state": (2k,), "e", "mu": (n_contacts,)}: ``d tau / dx(t_0)`` and
        ``d tau / d(e, mu)``, the event time's derivatives (a stride's period's, say).
    """

    time: float
    kind: str
    contacts: tuple[str, ...]
    switching: str
    saltation: np.ndarray
    reset_jacobian: np.ndarray
    parameter_jump: Mapping[str, np.ndarray] = field(default_factory=lambda: MappingProxyType({}))
    time_gradient: np.ndarray = field(default_factory=lambda: np.zeros(0))
    rate_minus: np.ndarray = field(default_factory=lambda: np.zeros(0))
    rate_plus: np.ndarray = field(default_factory=lambda: np.zeros(0))
    parameter_time_gradient: Mapping[str, np.ndarray] = field(
        default_factory=lambda: MappingProxyType({}))
    state_transition: np.ndarray | None = None
    parameter_sensitivity: Mapping[str, np.ndarray] = field(
        default_factory=lambda: MappingProxyType({}))
    time_sensitivity: Mapping[str, np.ndarray] = field(
        default_factory=lambda: MappingProxyType({}))

    def as_dict(self) -> dict[str, Any]:
        """Plain-JSON view."""
        return {k: _jsonable(getattr(self, k)) for k in self.__dataclass_fields__}


# ---- the reset map's steps: theta_dot_out = F(theta, theta_dot_in, e, mu) ----------------------
@dataclass
class ResetStep:
    """One step of an event's velocity map with its derivatives (k x k, k x n_contacts)."""

    d_theta: np.ndarray
    d_velocity: np.ndarray
    d_e: np.ndarray
    d_mu: np.ndarray


def projection_step(mech, constraint: Callable[[np.ndarray], np.ndarray], th: np.ndarray,
                    dth: np.ndarray, n_contacts: int) -> ResetStep:
    """The M-orthogonal velocity projection onto ``constraint(theta) theta_dot = 0``
    (:func:`~convimpact.simulation.run_record.project_onto`): linear in theta_dot (its
    columns exact), its configuration dependence differenced."""
    k = len(th)

    def F(q, v):
        return project_onto(np.asarray(mech.mass_matrix(q), float), constraint(q), v)

    dv = np.column_stack([F(th, e) for e in np.eye(k)])
    dq = central_jacobian(lambda q: F(q, dth), th)
    z = np.zeros((k, n_contacts))
    return ResetStep(dq, dv, z, z.copy())


def impact_step(mech, result, th: np.ndarray, dq: np.ndarray, closing: Sequence[str],
                constraint: Callable[[np.ndarray], np.ndarray] | None,
                columns: Sequence[int], n_contacts: int, plastic=()) -> ResetStep:
    """One call of ``resolve_impact`` (``result`` from ``derivatives=True``) as a step of the
    reset map ``theta_dot+ = F(M(theta), Jc(theta), P(theta) theta_dot-, e, mu, C(theta))``.

    ``P`` is the M-orthogonal projection onto ``C theta_dot = 0`` (C: the loops and the held
    contacts' normal rows taking part in the impact); it is the identity on the admissible
    velocities the run passes, and it makes F defined off them, so that the configuration
    derivative is taken along admissible pairs (dtheta, dtheta_dot). The law's part is
    analytic: ``result.jacobian`` for dq, M, Jc, e, mu, and the dependence on C by the chain
    of :func:`constraint_derivative`; the theta-derivatives of M, Jc, C and P are
    differenced (~1e-9 relative)."""
    jac = result.jacobian
    k = len(th)
    one = len(closing) == 1

    def Mq(q):
        return np.asarray(mech.mass_matrix(q), float)

    def Jq(q):
        rows = [np.asarray(mech.contact_jacobian(c, q), float) for c in closing]
        return rows[0] if one else np.stack(rows)

    jdq = np.asarray(jac["dq"], float)
    dM = central_jacobian(lambda q: Mq(q).ravel(), th)  # (k*k, k)
    dJ = central_jacobian(lambda q: Jq(q).ravel(), th)
    d_theta = (np.asarray(jac["M"], float).reshape(k, k * k) @ dM
               + np.asarray(jac["Jc"], float).reshape(k, -1) @ dJ)
    d_velocity = jdq
    C0 = constraint(th) if constraint is not None else np.zeros((0, k))
    if C0.size:
        def projected(q):
            return project_onto(Mq(q), constraint(q), dq)
        P = np.column_stack([project_onto(Mq(th), C0, e) for e in np.eye(k)])
        d_velocity = jdq @ P
        d_theta = d_theta + jdq @ central_jacobian(projected, th)
        dC = central_jacobian(lambda q: constraint(q).ravel(), th).reshape(C0.shape + (k,))
        d_theta = d_theta + constraint_derivative(result, Mq(th), Jq(th), C0, dC)
    d_e = np.zeros((k, n_contacts))
    d_mu = np.zeros((k, n_contacts))
    je = np.asarray(jac["e"], float).reshape(k, -1)
    jm = np.asarray(jac["mu"], float).reshape(k, -1)
    for i, col in enumerate(columns):
        if closing[i] not in plastic:  # e = 0 was used for it: no dependence on its e
            d_e[:, col] = je[:, i]
        d_mu[:, col] = jm[:, i]
    return ResetStep(d_theta, d_velocity, d_e, d_mu)


def constraint_derivative(result, M: np.ndarray, Jc: np.ndarray, C: np.ndarray,
                          dC: np.ndarray) -> np.ndarray:
    """``d dq_plus`` for the perturbations ``dC[..., i]`` of the constraint rows (k x len i).

    With ``G = A - B S^-1 B^T`` (A = M^-1, B = A C^T, S = C A C^T) the constrained inverse,
    ``dq_plus = dq + G Jc^T pi(W, v)``, ``W = Jc G Jc^T``, ``v = Jc dq``: a perturbation dC
    changes ``dG = -dB S^-1 B^T - B S^-1 dB^T + B S^-1 dS S^-1 B^T`` (dB = A dC^T,
    dS = dC B + B^T dC^T), hence ``dW = Jc dG Jc^T`` and v not at all, and
    ``d dq_plus = dG Jc^T pi + G Jc^T dpi``. The law's ``dpi = D_W[dW]`` is read from its
    analytic ``impulse_jacobian["M"]``: a symmetric dM changes W by ``-H dM H^T``
    (H = Jc G) and nothing else, so ``dM = -H^+ dW H^+T`` (H^+ = H^T (H H^T)^-1) has the
    effect of dW."""
    k = M.shape[0]
    J = np.asarray(Jc, float).reshape(-1, k)
    pi = np.asarray(result.impulse, float).ravel()
    ijM = np.asarray(result.impulse_jacobian["M"], float).reshape(pi.size, k * k)
    A = np.linalg.inv(M)
    A = 0.5 * (A + A.T)
    B = A @ C.T
    Sinv = np.linalg.inv(C @ B)
    G = A - B @ Sinv @ B.T
    H = J @ G
    Hplus = np.linalg.pinv(H, rcond=1e-12)
    out = np.zeros((k, dC.shape[-1]))
    for i in range(dC.shape[-1]):
        dc = dC[..., i]
        dB = A @ dc.T
        dS = dc @ B + B.T @ dc.T
        dG = -dB @ Sinv @ B.T - B @ Sinv @ dB.T + B @ Sinv @ dS @ Sinv @ B.T
        dW = J @ dG @ J.T
        dMeq = -Hplus @ (0.5 * (dW + dW.T)) @ Hplus.T
        dpi = ijM @ dMeq.ravel()
        out[:, i] = dG @ (J.T @ pi) + G @ (J.T @ dpi)
    return out


def compose(steps: Sequence[ResetStep], k: int, n_contacts: int):
    """The reset's Jacobian ``X`` (2k x 2k) and ``X_e``, ``X_mu`` (2k x n) of the steps in
    order (theta unchanged by every step)."""
    X = np.eye(2 * k)
    Xe = np.zeros((2 * k, n_contacts))
    Xm = np.zeros((2 * k, n_contacts))
    for s in steps:
        X[k:] = s.d_theta @ X[:k] + s.d_velocity @ X[k:]
        Xe[k:] = s.d_theta @ Xe[:k] + s.d_velocity @ Xe[k:] + s.d_e
        Xm[k:] = s.d_theta @ Xm[:k] + s.d_velocity @ Xm[k:] + s.d_mu
    return X, Xe, Xm


# ---- switching functions -------------------------------------------------------------------
def _lifted(eq: CanonicalEquations, x: np.ndarray) -> np.ndarray:
    k = eq.k
    return np.concatenate([x[:k], eq.momentum(x[:k], x[k:])])


def held_margins(eq: CanonicalEquations, t: float, y: np.ndarray) -> dict:
    """Each held contact's margins: {(contact, "normal force" | "friction margin"): value}."""
    forces, _ = held_forces(eq, t, y)
    out = {}
    for c in eq.held:
        lam = forces[c]
        out[(c, "normal force")] = float(lam[0])
        if eq.modes[c].kind == "stick" and eq.modes[c].mu > 0.0:
            out[(c, "friction margin")] = eq.modes[c].mu * float(lam[0]) - float(
                np.linalg.norm(lam[1:]))
    return out


def switching_function(mech, eq: CanonicalEquations, t: float, y: np.ndarray,
                       trigger) -> tuple[str, tuple[str, ...], str, Callable | None,
                                         Callable | None]:
    """(kind, contacts, description, g(x), g(x, mu) or None) of the event that ``trigger``
    ``(kind, key)`` names; ``g`` is a function of x = (theta, theta_dot)."""
    k = eq.k
    if trigger is None:
        return "start", (), "none", None, None
    what, key = trigger
    if what in ("impact", "touch"):
        def gap(x, c=key):
            return float(mech.contact_gap(c, x[:k]))
        return what, (key,), "gap", gap, None
    if key.startswith("slip:"):
        c = key[5:]
        s = np.asarray(eq.modes[c].direction, float)

        def slip(x):
            return float((np.asarray(mech.contact_jacobian(c, x[:k]), float)[1:] @ x[k:]) @ s)
        return "slip-stick", (c,), "slip velocity", slip, None
    if key == "margin":
        margins = held_margins(eq, t, y)
        if not margins:
            return "mode", (), "none", None, None
        scale = max(max(abs(v) for v in margins.values()), 1e-300)
        (c, name) = min(margins, key=lambda m: margins[m] / scale)

        def g(x, c=c, name=name, eqx=eq):
            return held_margins(eqx, t, _lifted(eqx, x))[(c, name)]

        def g_mu(x, mu, c=c, name=name):
            other = with_friction(eq, c, mu)
            return held_margins(other, t, _lifted(other, x))[(c, name)]
        kind = "lift-off" if name == "normal force" else "stick-slip"
        return kind, (c,), name, g, (g_mu if name == "friction margin" else None)
    return "mode", (), "none", None, None


def _transition(located: str, after) -> str:
    """The name of a held contact's transition from what located it ("slip-stick": its slip
    velocity, "stick-slip": its friction margin, "lift-off": its normal force) and its mode
    after the event (None: released); "mode" when the force problem kept the mode."""
    if after is None:
        return "lift-off"
    if located == "slip-stick":
        return "slip-stick" if after.kind == "stick" else "slip-reversal"
    if located == "stick-slip" and after.kind == "slip":
        return "stick-slip"
    return "mode"


def event_sensitivity(mech, t: float, y_minus: np.ndarray, eq_minus: CanonicalEquations,
                      y_plus: np.ndarray, eq_plus: CanonicalEquations, trigger,
                      steps: Sequence[ResetStep], contacts: Sequence[str],
                      impacted: Sequence[str]) -> EventSensitivity:
    """The :class:`EventSensitivity` of one event instant (see the module docstring)."""
    k = eq_minus.k
    n = len(contacts)
    X, Xe, Xm = compose(steps, k, n)
    kind, who, description, g, g_mu = switching_function(mech, eq_minus, t, y_minus, trigger)
    if impacted and kind != "start":
        kind, who = "impact", tuple(impacted)
    elif who and kind in ("slip-stick", "stick-slip", "lift-off"):
        kind = _transition(kind, eq_plus.modes.get(who[0]))
    rate_m = physical_rate(eq_minus, t, y_minus)
    rate_p = physical_rate(eq_plus, t, y_plus)
    S, jump_e, jump_mu = X.copy(), Xe, Xm.copy()
    grad = np.zeros(2 * k)
    tau_mu = np.zeros(n)
    if g is not None:
        x_m = physical(eq_minus, y_minus)
        g_x = central_jacobian(lambda v: np.array([g(v)]), x_m)[0]
        denom = float(g_x @ rate_m)
        if denom != 0.0:
            w = rate_p - X @ rate_m
            S = X + np.outer(w, g_x) / denom
            grad = -g_x / denom
            if g_mu is not None:
                c = who[0]
                dg = float(central_derivative(lambda m: g_mu(x_m, m), eq_minus.modes[c].mu))
                jump_mu = jump_mu.copy()
                jump_mu[:, list(contacts).index(c)] += w * dg / denom
                tau_mu[list(contacts).index(c)] = -dg / denom
    return EventSensitivity(
        time=float(t), kind=kind, contacts=tuple(who), switching=description, saltation=S,
        reset_jacobian=X, parameter_jump=MappingProxyType({"e": jump_e, "mu": jump_mu}),
        time_gradient=grad, rate_minus=rate_m, rate_plus=rate_p,
        parameter_time_gradient=MappingProxyType({"e": np.zeros(n), "mu": tau_mu}))


__all__ = ["EventSensitivity", "ResetStep", "projection_step", "impact_step", "compose",
           "held_margins", "switching_function", "event_sensitivity"]
