"""Trajectory sensitivities of an event-driven run (``simulate(..., sensitivities=True)``).

The run records, at every event instant, the state and the modes just before and just after
and the steps of the velocity map applied there (impacts, projections onto the contacts that
close), and turns them into an :class:`~convimpact.simulation.saltation.EventSensitivity`
(the saltation matrix, :mod:`~convimpact.simulation.saltation`). At the end the variational
equations are integrated over every event-free interval along the run's trajectory
(:mod:`~convimpact.simulation.variational`) and the intervals' maps and the saltation matrices
are multiplied in time order:

    dx(t_f)/dx(t_0) = Phi_N S_N ... S_1 Phi_0,

``x = (theta, theta_dot)``; the parameter sensitivities ``dx(t_f)/d(e, mu)`` accumulate the
same way with the flow's and the events' parameter terms.

Conventions: e and mu are per contact (``Mechanism.contact_parameters``); the columns of
``parameter_sensitivity["e"]`` and ``["mu"]`` follow ``result.contact_names`` (a scene whose
contacts share one coefficient: add the columns). The drift projections between events
(below ``projection_tol``) are not differentiated.
"""

from __future__ import annotations

from dataclasses import replace
from types import MappingProxyType
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from .canonical import CanonicalEquations
from .result import PiecewiseSolution
from .saltation import EventSensitivity, ResetStep, event_sensitivity, impact_step, projection_step
from .variational import interval_flow, lift, to_physical


class SensitivityTracking:
    """The part of :class:`~.event_driven.EventDrivenRun` that records the events'
    sensitivities and assembles the final ones. Inactive (every hook returns at once)
    unless the run's options ask for sensitivities."""

    def start_tracking(self) -> None:
        """Called once, with the initial state set."""
        self.tracking = bool(getattr(self.opts, "sensitivities", False))
        self.y_initial = self.y.copy()
        self.eq_initial = self.eq
        self.trigger: tuple[str, str] | None = None
        self.reset_steps: list[ResetStep] = []
        self.boundary_notes: list[str] = []
        #: (t, y-, eq-, y+, eq+, EventSensitivity) per event instant
        self.sensitivity_warnings: tuple[str, ...] = ()
        self.instants: list[tuple[float, np.ndarray, CanonicalEquations, np.ndarray,
                                  CanonicalEquations, EventSensitivity]] = []

    # ---- hooks of the event handling -------------------------------------------------------
    def track_projection(self, constraint: Callable[[np.ndarray], np.ndarray], th: np.ndarray,
                         dth: np.ndarray) -> None:
        """A velocity projection onto ``constraint(theta) theta_dot = 0`` was applied."""
        if self.tracking:
            self.reset_steps.append(projection_step(self.mech, constraint, th, dth,
                                                    len(self.contacts)))

    def track_impact(self, result, th: np.ndarray, dq: np.ndarray, closing: Sequence[str],
                     constraint: Callable[[np.ndarray], np.ndarray] | None,
                     plastic: Sequence[str] = ()) -> None:
        """An impact of ``closing`` at (theta, dq) was resolved (``result`` from
        ``resolve_impact(..., derivatives=True)``)."""
        if self.tracking:
            cols = [self.contact_at[c] for c in closing]
            record = getattr(result, "derivatives", None)
            for note in (record.one_sided if record is not None else ()):
                self.boundary_notes.append(f"impact of {', '.join(closing)}: {note}")
            self.reset_steps.append(impact_step(self.mech, result, th, dq, closing,
                                                constraint, cols, len(self.contacts), plastic))

    def track_event(self, t: float, y_minus: np.ndarray, eq_minus: CanonicalEquations,
                    n_impacts: int, n_contact_events: int) -> None:
        """The instant's events are handled (the state is ``self.y``): record its
        saltation and put it on the impact and contact records made at the instant."""
        if not self.tracking:
            return
        impacted = tuple(dict.fromkeys(c for ev in self.impacts[n_impacts:] for c in ev.contacts))
        if len(impacted) > 1:  # non-generic: almost every perturbation makes them sequential
            self.boundary_notes.append(
                f"simultaneous impact of {', '.join(impacted)}: a perturbation that separates "
                "their impact times makes the impacts sequential (another reset); the "
                "saltation is the simultaneous impact's, with the first contact's gap as the "
                "event, exact along the perturbations that keep the impacts simultaneous")
        rec = event_sensitivity(self.mech, t, y_minus, eq_minus, self.y, self.eq,
                                self.trigger, self.reset_steps, self.contacts, impacted,
                                self.boundary_notes)
        for i in range(n_impacts, len(self.impacts)):
            self.impacts[i] = replace(self.impacts[i], saltation=rec.saltation)
        for i in range(n_contact_events, len(self.contact_events)):
            self.contact_events[i] = replace(self.contact_events[i], saltation=rec.saltation)
        self.instants.append((t, y_minus.copy(), eq_minus, self.y.copy(), self.eq, rec))
        self.reset_steps = []
        self.boundary_notes = []
        self.trigger = None

    # ---- the final sensitivities -------------------------------------------------------------
    def final_sensitivities(self) -> dict[str, Any]:
        """``state_transition``, ``parameter_sensitivity``, ``event_sensitivities`` and (with
        ``t_eval``) ``sensitivity_series`` of the run; empty when not tracking."""
        if not self.tracking:
            return {}
        o, k, n = self.opts, self.k, len(self.contacts)
        Phi = np.eye(2 * k)
        d_e = np.zeros((2 * k, n))
        d_mu = np.zeros((2 * k, n))
        samples = (np.zeros(0) if o.t_eval is None
                   else np.asarray(o.t_eval, float)[np.asarray(o.t_eval) <= self.t])
        series: list[tuple[float, np.ndarray, np.ndarray, np.ndarray]] = []
        t_a, y_a, eq_a = o.t0, self.y_initial, self.eq_initial
        ends = list(self.instants) + [(self.t, self.y, self.eq, None, None, None)]
        done: list[EventSensitivity] = []
        for t_b, y_b, _, y_plus, eq_plus, rec in ends:
            last = rec is None
            inside = samples[(samples >= t_a) & ((samples <= t_b) if last else (samples < t_b))]
            segs = [s for s in self.segments if s[0] >= t_a and s[1] <= t_b and s[1] > s[0]]
            flow, flow_mu, at = interval_flow(eq_a, segs, t_a, t_b, self.contacts,
                                              o.solver_cls, o.rtol, o.atol, inside)
            L_a = lift(eq_a, y_a)
            if len(inside):
                sol = PiecewiseSolution(segs) if segs else None
                for t, (F_y, F_mu) in zip(inside, at):
                    y_t = y_a if (t == t_a or sol is None) else (y_b if t == t_b else sol(t))
                    T_t = to_physical(eq_a, y_t)
                    step = T_t @ F_y @ L_a
                    series.append((float(t), step @ Phi, step @ d_e,
                                   step @ d_mu + T_t @ F_mu))
            T_b = to_physical(eq_a, y_b)
            step = T_b @ flow @ L_a
            Phi = step @ Phi
            d_e = step @ d_e
            d_mu = step @ d_mu + T_b @ flow_mu
            if last:
                break
            # the event time's derivatives, then the fixed-time jump (saltation)
            g = rec.time_gradient
            tau = {"state": g @ Phi, "e": g @ d_e + rec.parameter_time_gradient["e"],
                   "mu": g @ d_mu + rec.parameter_time_gradient["mu"]}
            S = rec.saltation
            Phi = S @ Phi
            d_e = S @ d_e + rec.parameter_jump["e"]
            d_mu = S @ d_mu + rec.parameter_jump["mu"]
            t_a, y_a, eq_a = t_b, y_plus, eq_plus
            v = rec.rate_plus  # on the section: the time moves with the perturbation
            done.append(replace(
                rec, state_transition=Phi + np.outer(v, tau["state"]),
                parameter_sensitivity=MappingProxyType(
                    {"e": d_e + np.outer(v, tau["e"]), "mu": d_mu + np.outer(v, tau["mu"])}),
                time_sensitivity=MappingProxyType(tau)))
        # a frictionless contact's derivative in mu is right-sided by nature (mu >= 0): kept
        # on the records, not warned about
        flagged = [(ev, [s for s in ev.one_sided if not s.split(": ", 1)[-1].startswith(
            "mu = 0")]) for ev in done]
        flagged = [(ev, notes) for ev, notes in flagged if notes]
        if flagged:
            self.sensitivity_warnings = (
                f"sensitivities: {len(flagged)} event(s) with one-sided or ill-conditioned "
                f"derivatives, the first at t = {flagged[0][0].time:.9g}: "
                f"{flagged[0][1][0]} (see event_sensitivities[i].one_sided)",)
        out: dict[str, Any] = {
            "state_transition": Phi,
            "parameter_sensitivity": MappingProxyType({"e": d_e, "mu": d_mu}),
            "event_sensitivities": tuple(done)}
        if o.t_eval is not None:
            out["sensitivity_series"] = MappingProxyType({
                "t": np.array([s[0] for s in series]),
                "state": np.array([s[1] for s in series]).reshape(-1, 2 * k, 2 * k),
                "e": np.array([s[2] for s in series]).reshape(-1, 2 * k, n),
                "mu": np.array([s[3] for s in series]).reshape(-1, 2 * k, n)})
        return out


__all__ = ["SensitivityTracking"]
