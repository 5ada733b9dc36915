"""One run of the event-driven scheme of :func:`convimpact.simulation.simulate`.

:class:`EventDrivenRun` holds the run's state and advances it: it integrates segment by
segment, locates the events in each step, handles them at their instant (impacts, contacts
held closed or released) and assembles the :class:`SimulationResult`.
"""

from __future__ import annotations

import time as _time
from typing import Any, Collection, Mapping, Sequence

import numpy as np

from ..impact import resolve_impact
from ..impact.errors import ConvImpactError, SimulationError
from ..impact.results import ImpactResult
from ..mechanism import Mechanism
from .canonical import CanonicalEquations
from .events import gap_event, locate_crossing
from .options import EventDrivenOptions
from .projection import project_positions, project_velocities
from .result import (SERIES, ContactEvent, ImpactEvent, PiecewiseSolution, SimulationResult,
                     append_sample, held_at, series_from_rows)
from .zeno import AccumulationDetector

#: events at one instant beyond which the run is declared chattering (never loops forever)
MAX_EVENTS_AT_ONE_INSTANT = 50
#: tangential speed of a held contact with mu > 0 above which it counts as sliding (warning)
SLIP_SPEED = 1e-4
END_OF_SPAN = "the end of the time span was reached"

#: an event found in a step: (time, "impact" / "touch" / "release", contact name)
Event = tuple[float, str, str]
Held = tuple[str, ...]


class EventDrivenRun:
    """The state of one event-driven run and the steps that advance it.

    Parameters
    ----------
    mechanism : Mechanism
        The model.
    options : EventDrivenOptions
        The validated options.
    y0 : ndarray
        The initial integration array ``[theta, p]`` (eq. 15), consistent and not penetrating.
    started : float
        ``time.perf_counter()`` at the call of :func:`~convimpact.simulation.simulate`.

    Attributes
    ----------
    t, y, held : current time, ``[theta, p]`` and the contacts held closed (persistent).
    rows, segments : the recorded samples, and the integrated steps (for the dense output).
    impacts, contact_events : the events so far, in time order.
    slip : sliding of held contacts with mu > 0 (first time, duration, max speed).
    status, message : None and "" until the run ends, then as in :class:`SimulationResult`.
    """

    def __init__(self, mechanism: Mechanism, options: EventDrivenOptions, y0: np.ndarray,
                 started: float):
        self.mech = mechanism
        self.opts = options
        self.started = started
        self.k = int(mechanism.n_coordinates)
        self.m = int(mechanism.n_loop_constraints)
        self.contacts = tuple(mechanism.contact_names)
        self._equations: dict[Held, CanonicalEquations] = {}
        self.t = options.t0
        self.y = y0
        self.held: Held = ()
        self.rows: dict[str, list] = {key: [] for key in SERIES + ("held",)}
        self.segments: list = []
        self.impacts: list[ImpactEvent] = []
        self.contact_events: list[ContactEvent] = []
        self.detector = AccumulationDetector(options.zeno_time_tol, options.rest_velocity)
        # held contacts are frictionless: their sliding is tracked when mu > 0 to warn about it
        self.mus = {c: float(mechanism.contact_parameters(c)[1]) for c in self.contacts}
        self.slip: dict[str, dict[str, Any]] = {}
        self.status: int | None = None
        self.message = ""
        self.h_next = options.first_step
        self.same_instant = 0
        self.last_event_t: float | None = None
        self.n_steps = self.n_projections = self.n_restarts = self.nevents_fev = 0
        self.impact_time = 0.0

    # ---- evaluations ---------------------------------------------------------------------
    def equations(self, held: Held) -> CanonicalEquations:
        """The canonical equations with ``held`` closed (built once per held set)."""
        if held not in self._equations:
            self._equations[held] = CanonicalEquations(self.mech, held)
        return self._equations[held]

    def contact_row(self, c: str, th: np.ndarray) -> np.ndarray:
        return np.asarray(self.mech.contact_jacobian(c, th), float)

    def normal_speed(self, c: str, th: np.ndarray, dth: np.ndarray) -> float:
        return float(self.contact_row(c, th)[0] @ dth)

    def gap(self, c: str, th: np.ndarray) -> float:
        """The gap of contact ``c``, counted as an event-function evaluation."""
        self.nevents_fev += 1
        return float(self.mech.contact_gap(c, th))

    # ---- samples ---------------------------------------------------------------------------
    def record(self, t: float, y: np.ndarray, held: Held) -> None:
        """Store the sample at (t, y) with ``held`` closed, tracking the held contacts' slip."""
        th, pp = y[:self.k], y[self.k:]
        dth, sig, _ = self.equations(held).velocities(th, pp)
        self.track_slip(t, th, dth, held)
        append_sample(self.rows, self.mech, t, th, dth, pp, sig)
        self.rows["held"].append(len(held))

    def project_state(self, y: np.ndarray, held: Held, sigma: np.ndarray,
                      dth: np.ndarray) -> np.ndarray:
        """Project theta onto Psi = 0 and theta_dot onto C theta_dot = 0; rebuild p (eq. 13)."""
        eq = self.equations(held)
        th = y[:self.k]
        if eq.n_constraints:
            M = np.asarray(self.mech.mass_matrix(th), float)
            th, _, _ = project_positions(eq.residual, eq.jacobian, M, th,
                                         0.1 * self.opts.projection_tol)
            M = np.asarray(self.mech.mass_matrix(th), float)
            dth = project_velocities(M, eq.jacobian(th), dth)
            self.n_projections += 1
        return np.concatenate([th, eq.momentum(th, dth, sigma)])

    # ---- held (persistent) contacts ----------------------------------------------------------
    def hold(self, t: float, y: np.ndarray, held: Held, candidates: Sequence[str], reason: str,
             limit: Mapping[str, float | None]) -> tuple[np.ndarray, Held]:
        """Hold ``candidates`` closed: plastic frictionless correction of their normal velocity,
        then keep those whose normal force is compressive."""
        k, m = self.k, self.m
        th = y[:k]
        dth, sig, _ = self.equations(held).velocities(th, y[k:])
        new = tuple(held) + tuple(c for c in candidates if c not in held)
        while True:
            eqn = self.equations(new)
            M = np.asarray(self.mech.mass_matrix(th), float)
            dth_h = project_velocities(M, eqn.jacobian(th), dth)
            sig_n = np.concatenate([sig, np.zeros(eqn.n_constraints - len(sig))])
            yh = np.concatenate([th, eqn.momentum(th, dth_h, sig_n)])
            nu = eqn.multipliers(t, yh)[m:]
            new_idx = [i for i, c in enumerate(new) if c in candidates and c not in held]
            tensile = [(nu[i], i) for i in new_idx if nu[i] <= 0.0]
            if not tensile:
                break
            _, worst = min(tensile)
            new = tuple(c for i, c in enumerate(new) if i != worst)
        T0 = float(self.mech.kinetic_energy(th, dth))
        T1 = float(self.mech.kinetic_energy(th, dth_h))
        for c in new:
            if c not in held:
                self.contact_events.append(ContactEvent(t, c, "persist", reason, limit.get(c),
                                                        T1 - T0))
        return yh, new

    def release(self, t: float, y: np.ndarray, held: Held, names: Sequence[str],
                reason: str) -> tuple[np.ndarray, Held]:
        """Free the held contacts ``names`` (the others keep their multipliers)."""
        k, m = self.k, self.m
        th = y[:k]
        dth, sig, _ = self.equations(held).velocities(th, y[k:])
        keep = [i for i, c in enumerate(held) if c not in names]
        new = tuple(held[i] for i in keep)
        sig_n = np.concatenate([sig[:m], sig[m:][keep]]) if len(sig) else sig
        for c in names:
            self.contact_events.append(ContactEvent(t, c, "release", reason))
            self.detector.forget(c)
        return np.concatenate([th, self.equations(new).momentum(th, dth, sig_n)]), new

    def track_slip(self, t: float, th: np.ndarray, dth: np.ndarray, held: Held) -> None:
        """Accumulate the sliding (tangential speed above SLIP_SPEED) of held contacts, mu > 0."""
        for c in self.contacts:
            s_c = self.slip.get(c)
            if c not in held or self.mus[c] <= 0.0:
                if s_c is not None:
                    s_c["t_prev"] = None
                continue
            J = self.contact_row(c, th)
            vt = float(np.linalg.norm(J[1:] @ dth)) if len(J) > 1 else 0.0
            if vt <= SLIP_SPEED:
                if s_c is not None:
                    s_c["t_prev"] = None
                continue
            if s_c is None:
                s_c = self.slip[c] = {"first": t, "t_prev": None, "duration": 0.0, "vmax": 0.0}
            if s_c["t_prev"] is not None:
                s_c["duration"] += t - s_c["t_prev"]
            s_c["t_prev"] = t
            s_c["vmax"] = max(s_c["vmax"], vt)

    def slip_warnings(self) -> tuple[str, ...]:
        """One warning per held contact with mu > 0 that slid (held contacts are frictionless)."""
        return tuple(
            f"held contact {c!r} (mu = {self.mus[c]:g}) slid without friction for "
            f"{sc['duration']:.4g} s (first at t = {sc['first']:.6g}), max slip speed "
            f"{sc['vmax']:.4g} (length/s): held (persistent) contacts are frictionless in this "
            "simulator, so this sliding is not dissipated"
            for c, sc in self.slip.items() if sc["duration"] > 0.0)

    # ---- impacts ---------------------------------------------------------------------------
    def solve_impact(self, t: float, th: np.ndarray, dth: np.ndarray, M: np.ndarray,
                     closing: Sequence[str], params: Mapping[str, Any], held: Held,
                     plastic: Collection[str] = ()) -> tuple[ImpactResult, list, float]:
        """One call of ``resolve_impact`` for ``closing`` with ``held`` as constraints (e = 0
        for the ``plastic`` contacts); returns the result, the contact Jacobians and the wall
        time spent."""
        C = self.equations(held).jacobian(th)
        Jc = [self.contact_row(c, th) for c in closing]
        es = [0.0 if c in plastic else float(params[c][0]) for c in closing]
        mus = [float(params[c][1]) for c in closing]
        o = self.opts
        t_start = _time.perf_counter()
        J, e, mu = (Jc[0], es[0], mus[0]) if len(closing) == 1 else (Jc, es, mus)
        try:
            r = resolve_impact(M, J, dth, e, mu, C if len(C) else None,
                               law=o.law, method=o.method, **o.impact_options)
        except ConvImpactError as exc:
            exc.add_note(f"(while resolving the impact of {', '.join(closing)} at "
                         f"t = {t:.9g} in convimpact.simulation.simulate)")
            raise
        finally:
            spent = _time.perf_counter() - t_start
            self.impact_time += spent
        return r, Jc, spent

    def impact(self, t: float, y: np.ndarray, held: Held,
               closing: Sequence[str]) -> tuple[np.ndarray, Held, str | None]:
        """Resolve the closing contacts together; returns (y, held, stop_message)."""
        k, m = self.k, self.m
        th = y[:k]
        eq = self.equations(held)
        dth, sig, _ = eq.velocities(th, y[k:])
        M = np.asarray(self.mech.mass_matrix(th), float)
        params = {c: self.mech.contact_parameters(c) for c in closing}
        released: list[str] = []
        spent = 0.0
        held_now = tuple(held)
        while True:
            r, Jc, dt = self.solve_impact(t, th, dth, M, closing, params, held_now)
            spent += dt
            dsig_h = np.asarray(r.loop_impulse, float)[m:]
            scale = max(float(np.max(np.abs(r.impulse))), 1e-300)
            tens = [i for i, v in enumerate(dsig_h) if v < -1e-9 * scale]
            if not tens:
                break
            # a held contact is pulled: it separates (released) and the impact is redone
            names = [held_now[i] for i in tens]
            released.extend(names)
            yy, held_now = self.release(t, np.concatenate([th, eq.momentum(th, dth, sig)]),
                                        held_now, names, "impulse of an impact would be tensile")
            dth, sig, _ = self.equations(held_now).velocities(th, yy[k:])
            eq = self.equations(held_now)
        # accumulation check (Zeno) on each contact that bounced
        speeds = {c: float(Jc[i][0] @ r.dq_plus) for i, c in enumerate(closing)}
        persist, limits, reasons, zeno_hit = self.detector.judge_impact(t, speeds)
        stop_msg = None
        if zeno_hit and self.opts.zeno == "stop":
            stop_msg = ("accumulating impacts detected (zeno='stop'): " + "; ".join(reasons))
        elif persist and any(float(params[c][0]) > 0.0 for c in persist):
            r, Jc, dt = self.solve_impact(t, th, dth, M, closing, params, held_now, set(persist))
            spent += dt
        dq_plus = np.asarray(r.dq_plus, float)
        dsig = np.asarray(r.loop_impulse, float)
        sig_plus = sig + dsig if len(sig) else sig
        impulse = np.asarray(r.impulse, float).reshape(len(closing), -1)
        gen = np.vstack(Jc).T @ impulse.ravel()  # Delta p = Jc^T pi, eq. (33)
        T_minus = float(self.mech.kinetic_energy(th, dth))
        T_plus = float(self.mech.kinetic_energy(th, dq_plus))
        regime = (r.regime,) if isinstance(r.regime, str) else tuple(r.regime)
        yy = np.concatenate([th, self.equations(held_now).momentum(th, dq_plus, sig_plus)])
        new_held = held_now
        if persist and stop_msg is None:
            yy, new_held = self.hold(t, yy, held_now, persist, "; ".join(reasons), limits)
        self.impacts.append(ImpactEvent(
            time=t, contacts=tuple(closing), held_contacts=tuple(held_now), regime=regime,
            impulse=impulse, loop_impulse=dsig, generalized_impulse=gen, theta=th.copy(),
            dtheta_minus=dth.copy(), dtheta_plus=dq_plus.copy(),
            energy_loss=float(r.energy_loss), kinetic_energy_minus=T_minus,
            kinetic_energy_plus=T_plus,
            persistent=tuple(c for c in new_held if c not in held_now),
            released=tuple(released), resolve_time=spent, result=r))
        return yy, new_held, stop_msg

    # ---- events ----------------------------------------------------------------------------
    def handle(self, t: float, y: np.ndarray, held: Held, closing: Sequence[str],
               touching: Sequence[str],
               releasing: Sequence[str]) -> tuple[np.ndarray, Held, str | None]:
        """All events at instant t; returns (y, held, stop_message)."""
        k, o = self.k, self.opts
        if releasing:
            y, held = self.release(t, y, held, releasing, "normal force reached zero (tensile)")
        th = y[:k]
        dth, _, _ = self.equations(held).velocities(th, y[k:])
        vn = {}
        for c in self.contacts:
            if c in held or c in releasing:
                continue
            if c in closing or c in touching or self.gap(c, th) <= o.contact_tol:
                vn[c] = self.normal_speed(c, th, dth)
        group = [c for c, v in vn.items() if v < -o.rest_velocity]
        rest = [c for c, v in vn.items() if abs(v) <= o.rest_velocity]
        stop_msg = None
        if group:
            y, held, stop_msg = self.impact(t, y, held, group)
        if rest and stop_msg is None:
            y, held = self.hold(t, y, held, rest, "touching at rest (|v_n| <= rest_velocity)", {})
        dth, sig, _ = self.equations(held).velocities(y[:k], y[k:])
        return self.project_state(y, held, sig, dth), held, stop_msg

    def closing_in_step(self, eq: CanonicalEquations, free: Sequence[str], interp,
                        t_old: float, t_new: float, y_new: np.ndarray,
                        g_prev: Mapping[str, float]) -> tuple[list[Event], dict[str, float]]:
        """Free contacts closing in the step (see :func:`~.events.gap_event`) and their gaps
        at its end."""
        k = self.k
        found: list[Event] = []
        g_new = {}
        for c in free:
            gn = self.gap(c, y_new[:k])
            g_new[c] = gn

            def gfun(s, c=c):
                return self.gap(c, interp(s)[:k])

            def vfun(s, c=c):
                ys = np.asarray(interp(s), float)
                dth_s, _, _ = eq.velocities(ys[:k], ys[k:])
                return self.normal_speed(c, ys[:k], dth_s)

            event = gap_event(gfun, vfun, t_old, t_new, g_prev[c], gn, self.opts.event_tol)
            if event is not None:
                found.append((*event, c))
        return found, g_new

    def releasing_in_step(self, eq: CanonicalEquations, interp, t_old: float, t_new: float,
                          nu_prev: np.ndarray, nu_new: np.ndarray) -> list[Event]:
        """Held contacts of ``eq`` whose normal force turns tensile in the step (or is)."""
        m = self.m
        found: list[Event] = []
        for i, c in enumerate(eq.held):
            if nu_prev[i] > 0.0 and nu_new[i] <= 0.0:
                def nfun(s, i=i):
                    self.nevents_fev += 1
                    return float(eq.multipliers(s, interp(s))[m + i])
                found.append((locate_crossing(nfun, t_old, t_new, nu_prev[i], nu_new[i],
                                              self.opts.event_tol), "release", c))
            elif nu_prev[i] <= 0.0:
                found.append((t_old, "release", c))
        return found

    def on_events(self, found: Sequence[Event], interp, t_old: float, t_new: float,
                  y_new: np.ndarray, step_size: float) -> None:
        """Stop the segment at the earliest events of a step and handle them at their instant."""
        o = self.opts
        te = min(f[0] for f in found)
        group = [f for f in found if f[0] <= te + o.event_tol]
        if te > t_old:
            self.segments.append((t_old, te, interp))
        ye = np.asarray(interp(te), float) if te < t_new else y_new
        self.record(te, ye, self.held)
        self.same_instant = self.same_instant + 1 if (
            self.last_event_t is not None and te - self.last_event_t <= o.event_tol) else 0
        self.last_event_t = te
        if self.same_instant > MAX_EVENTS_AT_ONE_INSTANT:
            raise SimulationError(
                f"{self.same_instant} events at t = {te:.9g} without progress (chattering "
                f"contacts {sorted({f[2] for f in group})}); loosen contact_tol or "
                "rest_velocity, or use zeno='stop'")
        self.y, self.held, stop_msg = self.handle(
            te, ye, self.held, [f[2] for f in group if f[1] == "impact"],
            [f[2] for f in group if f[1] == "touch"],
            [f[2] for f in group if f[1] == "release"])
        self.t = te
        self.record(self.t, self.y, self.held)
        self.h_next = step_size
        if stop_msg:
            self.status, self.message = 1, stop_msg
        elif len(self.impacts) >= o.max_impacts:
            self.status, self.message = 1, (
                f"max_impacts = {o.max_impacts} reached at t = {self.t:.9g}; "
                "raise it or check for accumulating impacts")
        elif self.t >= o.t1:
            self.status, self.message = 0, END_OF_SPAN

    # ---- integration -----------------------------------------------------------------------
    def run(self) -> SimulationResult:
        """Integrate from the initial state to the end of the span (or a stop)."""
        self.record(self.t, self.y, self.held)
        # contacts touching at the start
        touching = [c for c in self.contacts
                    if float(self.mech.contact_gap(c, self.y[:self.k])) <= self.opts.contact_tol]
        if touching:
            self.y, self.held, stop_msg = self.handle(self.t, self.y, self.held, [], touching, [])
            self.record(self.t, self.y, self.held)
            if stop_msg:
                self.status, self.message = 1, stop_msg
        while self.status is None:
            if self.t >= self.opts.t1:
                self.status, self.message = 0, END_OF_SPAN
                break
            self.integrate_segment()
        return self.result()

    def integrate_segment(self) -> None:
        """Integrate with the current held set until an event, a restart or the end."""
        o, k, m = self.opts, self.k, self.m
        held = self.held
        eq = self.equations(held)
        free = [c for c in self.contacts if c not in held]
        opts: dict[str, Any] = {"rtol": o.rtol, "atol": o.atol, "max_step": o.max_step}
        if self.h_next is not None and self.h_next > 0:
            opts["first_step"] = min(float(self.h_next), o.t1 - self.t)
        solver = o.solver_cls(eq, self.t, self.y, o.t1, **opts)
        self.n_restarts += 1
        g_prev = {c: self.gap(c, self.y[:k]) for c in free}
        nu_prev = eq.multipliers(self.t, self.y)[m:] if held else np.zeros(0)
        while True:
            msg = solver.step()
            if solver.status == "failed":
                self.status, self.message = -1, f"integrator failed at t = {solver.t:.9g}: {msg}"
                return
            self.n_steps += 1
            t_old, t_new, y_new = solver.t_old, solver.t, solver.y.copy()
            if not np.all(np.isfinite(y_new)):
                raise SimulationError(f"the state became non-finite at t = {t_new:.9g}")
            interp = solver.dense_output()
            found, g_new = self.closing_in_step(eq, free, interp, t_old, t_new, y_new, g_prev)
            nu_new = eq.multipliers(t_new, y_new)[m:] if held else np.zeros(0)
            found += self.releasing_in_step(eq, interp, t_old, t_new, nu_prev, nu_new)
            if found:
                self.on_events(found, interp, t_old, t_new, y_new, solver.step_size)
                return
            self.segments.append((t_old, t_new, interp))
            self.t, self.y = t_new, y_new
            if eq.n_constraints:
                drift = float(np.max(np.abs(eq.residual(self.y[:k]))))
                if drift > o.drift_threshold:
                    dth, sig, _ = eq.velocities(self.y[:k], self.y[k:])
                    self.y = self.project_state(self.y, held, sig, dth)
                    if not o.in_place:  # multistep: the history is void, restart
                        self.record(self.t, self.y, held)
                        self.h_next = solver.step_size
                        if solver.status == "finished":
                            self.status, self.message = 0, END_OF_SPAN
                        return
                    # one-step method: continue from the projected state, same step size
                    solver.y = self.y.copy()
                    solver.f = solver.fun(self.t, solver.y)
                    g_new = {c: self.gap(c, self.y[:k]) for c in free}
                    nu_new = eq.multipliers(self.t, self.y)[m:] if held else np.zeros(0)
            self.record(self.t, self.y, held)
            g_prev, nu_prev = g_new, nu_new
            if solver.status == "finished":
                self.status, self.message = 0, END_OF_SPAN
                return

    # ---- result ----------------------------------------------------------------------------
    def resample(self, t_eval: np.ndarray,
                 sol: PiecewiseSolution) -> tuple[dict[str, list], np.ndarray]:
        """The series and the number of held contacts at ``t_eval``, from the dense output."""
        k = self.k
        t_eval = t_eval[t_eval <= sol.t_max]  # a run stopped early has no state beyond
        ys = sol(t_eval) if t_eval.size else np.zeros((2 * k, 0))
        rows: dict[str, list] = {key: [] for key in SERIES}
        n_held = []
        for j, s_t in enumerate(t_eval):
            names = held_at(self.contact_events, float(s_t))
            th, pp = ys[:k, j], ys[k:, j]
            dth, sig, _ = self.equations(names).velocities(th, pp)
            n_held.append(len(names))
            append_sample(rows, self.mech, s_t, th, dth, pp, sig)
        return rows, np.array(n_held, dtype=int)

    def result(self) -> SimulationResult:
        """The :class:`SimulationResult` of the run."""
        o = self.opts
        wall = _time.perf_counter() - self.started
        sol = PiecewiseSolution(self.segments) if self.segments else None
        rows = self.rows
        held_series = np.array(rows["held"], dtype=int)
        if o.t_eval is not None and sol is not None:
            rows, held_series = self.resample(o.t_eval, sol)
        nfev = sum(e.nfev for e in self._equations.values())
        warnings = self.slip_warnings()
        message = self.message
        if warnings:
            message = message + "; WARNING: " + "; ".join(warnings)
        return SimulationResult(
            **series_from_rows(rows, self.k, self.m), held=held_series,
            impacts=tuple(self.impacts), contact_events=tuple(self.contact_events),
            sol=sol if o.dense_output else None, status=int(self.status), message=message,
            nfev=int(nfev), nevents_fev=int(self.nevents_fev), n_steps=int(self.n_steps),
            n_projections=int(self.n_projections), n_restarts=int(self.n_restarts),
            wall_time=float(wall), impact_time=float(self.impact_time),
            settings=o.settings(), warnings=warnings)

