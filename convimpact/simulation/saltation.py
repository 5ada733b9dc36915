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
    kind : "impact", "lift-off", "stick-slip", "slip-stick", "touch" (a contact found
        closing at rest), "start" (the contacts touching at t0, a fixed instant) or "mode".
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


def impact_step(mech, jac: Mapping[str, Any], th: np.ndarray, closing: Sequence[str],
                constraint: Callable[[np.ndarray], np.ndarray] | None,
                columns: Sequence[int], n_contacts: int, plastic=()) -> ResetStep:
    """One call of ``resolve_impact``: ``d dq_plus / d(dq, e, mu)`` from the law's
    jacobian ``jac`` (``ImpactResult.jacobian``), and the configuration
    dependence by the chain rule through M(theta), Jc(theta) (and C(theta) for the loops and
    held contacts), whose theta-derivatives are differenced."""
    k = len(th)
    one = len(closing) == 1
    dv = np.asarray(jac["dq"], float)

    def Mq(q):
        return np.asarray(mech.mass_matrix(q), float)

    def Jq(q):
        rows = [np.asarray(mech.contact_jacobian(c, q), float) for c in closing]
        return rows[0] if one else np.stack(rows)

    dM = central_jacobian(lambda q: Mq(q).ravel(), th).reshape(k, k, k)  # [a, b, i]
    dJ = central_jacobian(lambda q: Jq(q).ravel(), th)  # (size of Jc, k)
    jM = np.asarray(jac["M"], float).reshape(k, k * k)
    jJ = np.asarray(jac["Jc"], float).reshape(k, -1)
    d_theta = jM @ dM.reshape(k * k, k) + jJ @ dJ
    if constraint is not None and "C" in jac:
        C0 = constraint(th)
        if C0.size:
            dC = central_jacobian(lambda q: constraint(q).ravel(), th)
            d_theta = d_theta + np.asarray(jac["C"], float).reshape(k, -1) @ dC
    d_e = np.zeros((k, n_contacts))
    d_mu = np.zeros((k, n_contacts))
    je = np.asarray(jac["e"], float).reshape(k, -1)
    jm = np.asarray(jac["mu"], float).reshape(k, -1)
    for i, col in enumerate(columns):
        if closing[i] not in plastic:  # e = 0 was used for it: no dependence on its e
            d_e[:, col] = je[:, i]
        d_mu[:, col] = jm[:, i]
    return ResetStep(d_theta, dv, d_e, d_mu)


def _inside(fun, v: np.ndarray, low: float, high: float) -> np.ndarray:
    """Differences that stay within [low, high]: one-sided (second order) at a bound."""
    cols = []
    for j in range(v.size):
        h = 1e-6 * max(abs(float(v[j])), 1.0)
        pts = [v.copy() for _ in range(3)]
        if v[j] - h < low:  # forward: (-3 f0 + 4 f1 - f2) / 2h
            w, offs = (-1.5, 2.0, -0.5), (0.0, h, 2 * h)
        elif v[j] + h > high:
            w, offs = (1.5, -2.0, 0.5), (0.0, -h, -2 * h)
        else:
            w, offs = (0.0, 0.5, -0.5), (0.0, h, -h)
        acc = 0.0
        for p, wi, o in zip(pts, w, offs):
            if wi:
                p[j] += o
                acc = acc + wi * np.asarray(fun(p), float)
        cols.append(acc / h)
    return np.array(cols).T


def impact_jacobian_by_differences(M, J, dq, e, mu, C, **kwargs) -> dict[str, np.ndarray]:
    """Stand-in for ``resolve_impact(..., derivatives=True).jacobian`` while the law's
    analytic derivative is not available: central differences of ``dq_plus`` with respect
    to dq, M (symmetric perturbations), Jc, e and mu (and C)."""
    from ..impact import resolve_impact

    def dq_plus(M_, J_, dq_, e_, mu_, C_):
        return np.asarray(resolve_impact(M_, J_, dq_, e_, mu_, C_, **kwargs).dq_plus, float)

    M = np.asarray(M, float)
    k = M.shape[0]
    Jarr = np.asarray(J, float)
    several = Jarr.ndim == 3
    earr = np.atleast_1d(np.asarray(e, float))
    muarr = np.atleast_1d(np.asarray(mu, float))

    def unpack_J(v):
        Jv = v.reshape(Jarr.shape)
        return list(Jv) if several else Jv

    def unpack_p(v):
        return list(v) if several else float(v[0])

    out = {
        "dq": central_jacobian(lambda v: dq_plus(M, J, v, e, mu, C), np.asarray(dq, float)),
        "Jc": central_jacobian(lambda v: dq_plus(M, unpack_J(v), dq, e, mu, C),
                               Jarr.ravel()).reshape((k,) + Jarr.shape),
        "e": _inside(lambda v: dq_plus(M, J, dq, unpack_p(v), mu, C), earr, 0.0, 1.0),
        "mu": _inside(lambda v: dq_plus(M, J, dq, e, unpack_p(v), C), muarr, 0.0, np.inf),
    }

    def sym(v):
        A = v.reshape(k, k)
        return dq_plus(0.5 * (A + A.T), J, dq, e, mu, C)
    out["M"] = central_jacobian(sym, M.ravel()).reshape(k, k, k)
    if C is not None and np.asarray(C).size:
        Carr = np.asarray(C, float)
        out["C"] = central_jacobian(lambda v: dq_plus(M, J, dq, e, mu, v.reshape(Carr.shape)),
                                    Carr.ravel()).reshape((k,) + Carr.shape)
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
    rate_m = physical_rate(eq_minus, t, y_minus)
    rate_p = physical_rate(eq_plus, t, y_plus)
    S, jump_e, jump_mu = X.copy(), Xe, Xm.copy()
    grad = np.zeros(2 * k)
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
    return EventSensitivity(
        time=float(t), kind=kind, contacts=tuple(who), switching=description, saltation=S,
        reset_jacobian=X, parameter_jump=MappingProxyType({"e": jump_e, "mu": jump_mu}),
        time_gradient=grad, rate_minus=rate_m, rate_plus=rate_p)


__all__ = ["EventSensitivity", "ResetStep", "projection_step", "impact_step", "compose",
           "held_margins", "switching_function", "event_sensitivity"]
