"""One run of the event-driven scheme of :func:`convimpact.simulation.simulate`.

:class:`EventDrivenRun` holds the run's state and advances it: it integrates segment by
segment with the contacts' modes fixed, locates the events in each step (a free contact
closing; a held contact's force leaving its cone or turning tensile; a slip velocity
reaching zero; the sliding contacts' force system turning singular), handles them at their
instant (impacts, then the modes selected by the contact force problem,
:mod:`~convimpact.simulation.sustained`) and assembles the :class:`SimulationResult`.
"""

from __future__ import annotations

import time as _time
from bisect import bisect_right
from typing import Any, Sequence

import numpy as np

from ..contacts.threads import one_blas_thread
from ..errors import PainleveError, SimulationError
from ..mechanism import Mechanism
from .canonical import CanonicalEquations, HeldMode
from .contact_events import MAX_EVENTS_AT_ONE_INSTANT, ContactEvents
from .event_watch import Event, EventWatch, Held
from .events import fast_interpolant
from .options import EventDrivenOptions
from .projection import project_positions
from .result import (SERIES, ContactEvent, ImpactEvent, PainleveEvent, PiecewiseSolution,
                     SimulationResult, append_sample, series_from_rows)
from .run_record import (ModeLog, PendingForces, contact_rows, force_series, law_flags,
                         project_onto)
from .sensitivity import SensitivityTracking
from .sustained import held_forces
from .zeno import AccumulationDetector

END_OF_SPAN = "the end of the time span was reached"
#: smallest margin (relative to the force scale) at a segment's start below which the held
#: forces count as inadmissible there (the modes' selection leaves it >= 0 up to round-off)
INADMISSIBLE_MARGIN = 1e-6
#: per-sample contact series recorded besides the state's
CONTACT_SERIES = ("held", "mode", "force", "friction")
#: 4-point Gauss-Legendre nodes and weights on [-1, 1] (the friction work of a step)
GAUSS4 = np.polynomial.legendre.leggauss(4)

class StepDense:
    """One accepted step's dense output, built on first use.

    A Runge-Kutta step's interpolant costs right-hand sides of its own (DOP853's: three)
    and array work; the run needs it only where an event may lie in the step (a free
    contact's gap, a crossing of a held contact's function), where sliding friction works
    over it, or where the result keeps it (``dense_output``, ``t_eval``, sensitivities).
    The run calls :meth:`expire` before the integrator leaves the step (the next step, or a
    projected state): built later it would be another step's.
    """

    __slots__ = ("_solver", "_f", "_live")

    def __init__(self, solver):
        self._solver, self._f, self._live = solver, None, True

    def expire(self) -> None:
        """The integrator leaves the step: no dense output can be built from it now."""
        self._live = False

    def built(self):
        """The step's interpolant (:func:`~.events.fast_interpolant`), built once."""
        if self._f is None:
            if not self._live:
                raise SimulationError("internal error: the dense output of a step the "
                                      "integrator has left was asked for")
            self._f = fast_interpolant(self._solver.dense_output())
        return self._f

    def __call__(self, t):
        return self.built()(t)


class EventDrivenRun(EventWatch, ContactEvents, SensitivityTracking):
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
    t, y : current time and ``[theta, p]``.
    eq : the canonical equations in force: the held (closed) contacts and their modes.
    rows, segments : the recorded samples, and the integrated steps (for the dense output).
    impacts, contact_events, painleve : the events so far, in time order.
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
        self.contact_at = {c: i for i, c in enumerate(self.contacts)}
        self.d = max((len(self.contact_row(c, y0[:self.k])) for c in self.contacts), default=0)
        self.painleve_error: PainleveError | None = None
        #: why contacts closing at an impact stay closed: {contact: (reason, t_inf or None)}
        self.closing_info: dict[str, tuple[str, float | None]] = {}
        #: per sliding contact, how often its slip turned away from its frozen direction
        #: (event ``turn:<c>``) since it last stuck or opened (:meth:`freeze_directions`)
        self.turns: dict[str, int] = {}
        self.t = options.t0
        self.y = y0
        self.eq = CanonicalEquations(mechanism)
        self.eq_log: list[tuple[float, CanonicalEquations]] = [(self.t, self.eq)]
        self.rows: dict[str, list] = {key: [] for key in SERIES + CONTACT_SERIES}
        self.dissipated = 0.0  # energy dissipated by sliding friction so far
        self.segments: list = []
        self.impacts: list[ImpactEvent] = []
        self.contact_events: list[ContactEvent] = []
        self.painleve: list[PainleveEvent] = []
        #: the force problem's notes (statically indeterminate contacts): note -> (first
        #: time, count)
        self.force_notes: dict[str, tuple[float, int]] = {}
        #: segments starting with inadmissible held forces: held set -> (first time, count,
        #: smallest margin)
        self.inadmissible: dict[Held, tuple[float, int, float]] = {}
        #: the event functions' stand-in distribution (:func:`~.sustained.held_forces`)
        self.margin_hint: dict[str, Any] = {}
        #: the last full :meth:`watch`: (eq, t, y's bytes, the exact forces or None,
        #: margin, Painleve indicator)
        self._watched: tuple | None = None
        #: the last sample whose forces :meth:`sample_forces` left to compute
        self._recorded: PendingForces | None = None
        self.modes = ModeLog(self.contacts, self.t)
        self.detector = AccumulationDetector(options.zeno_time_tol, options.rest_velocity)
        self.status: int | None = None
        self.message = ""
        self.h_next = options.first_step
        self.same_instant = 0
        self.last_event_t: float | None = None
        self.n_steps = self.n_projections = self.n_restarts = self.nevents_fev = 0
        self.impact_time = 0.0
        self.start_tracking()

    @property
    def held(self) -> Held:
        return self.eq.held

    # ---- evaluations ---------------------------------------------------------------------
    def contact_row(self, c: str, th: np.ndarray) -> np.ndarray:
        return np.asarray(self.mech.contact_jacobian(c, th), float)

    def gap(self, c: str, th: np.ndarray) -> float:
        """The gap of contact ``c``, counted as an event-function evaluation."""
        self.nevents_fev += 1
        return float(self.mech.contact_gap(c, th))

    def state(self, y: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(theta, theta_dot, sigma) of ``y`` under the equations in force."""
        th = y[:self.k]
        dth, sig = self.eq.theta_dot(th, y[self.k:])
        return th, dth, sig

    def friction_power(self, t: float, y: np.ndarray) -> float:
        """Power of the sliding contacts' friction forces, sum of lambda_t . v_t (<= 0)."""
        return self.eq.friction_power(t, y)

    def dissipate(self, interp, ta: float, tb: float) -> None:
        """Add the friction work over [ta, tb] (Gauss-Legendre, 4 points on the interpolant)."""
        if not self.eq.slipping or tb <= ta:
            return
        half, mid = 0.5 * (tb - ta), 0.5 * (tb + ta)
        work = sum(w * self.friction_power(mid + half * x, np.asarray(interp(mid + half * x),
                                                                      float))
                   for x, w in zip(*GAUSS4))
        self.dissipated -= half * work

    # ---- samples ---------------------------------------------------------------------------
    def record(self, t: float, y: np.ndarray) -> None:
        """Store the sample at (t, y): state, energies, contact modes and forces (those still
        to compute as :class:`~.run_record.PendingForces`: :meth:`sample_forces`)."""
        th, dth, sig = self.state(y)
        append_sample(self.rows, self.mech, t, th, dth, y[self.k:], sig)
        self.rows["friction"].append(self.dissipated)
        forces = self.sample_forces(t, y) if self.held else {}
        contact_rows(self.rows, self.contacts, self.eq, forces, self.d)

    def sample_forces(self, t: float, y: np.ndarray) -> dict[str, np.ndarray] | PendingForces:
        """The held contacts' exact forces at (t, y) (:func:`~.sustained.held_forces`
        without a hint): those the last :meth:`watch` found at the same state when it
        computed them exactly (no stand-in); else the sample's :class:`PendingForces`,
        computed when a segment's first watch starts from it or when the result's
        ``contact_force`` is read."""
        memo = self._watched
        if (memo is not None and memo[0] is self.eq and memo[1] == t
                and memo[3] is not None and memo[2] == y.tobytes()):
            return memo[3]
        self._recorded = PendingForces(self.eq, t, y)
        return self._recorded

    def project_state(self, y: np.ndarray) -> np.ndarray:
        """Project theta onto Psi = 0 (loops, held gaps) and theta_dot onto the velocity
        constraints; rebuild p (eq. 13) with the loops' sigma kept."""
        eq = self.eq
        th, dth, sig = self.state(y)
        if eq.n_constraints:
            M = np.asarray(self.mech.mass_matrix(th), float)
            if len(eq.residual(th)):
                th, _, _ = project_positions(eq.residual, eq.position_jacobian, M, th,
                                             0.1 * self.opts.projection_tol)
                M = np.asarray(self.mech.mass_matrix(th), float)
            dth = project_onto(M, eq.jacobian(th), dth)
            self.n_projections += 1
        return self.pack(th, dth, sig[:self.m])

    def pack(self, th: np.ndarray, dth: np.ndarray, sig_loops: np.ndarray) -> np.ndarray:
        """``[theta, p]`` with p = M theta_dot - C^T sigma, sigma = (loops' sigma, zeros)."""
        sig = np.concatenate([sig_loops, np.zeros(self.eq.n_constraints - self.m)])
        return np.concatenate([th, self.eq.momentum(th, dth, sig)])

    def on_events(self, found: Sequence[Event], interp, t_old: float, t_new: float,
                  y_new: np.ndarray, step_size: float) -> None:
        """Stop the segment at the earliest events of a step and handle them at their instant."""
        o = self.opts
        te = min(f[0] for f in found)
        group = [f for f in found if f[0] <= te + o.event_tol]
        if te > t_old:
            self.segments.append((t_old, te, interp))
            self.dissipate(interp, t_old, te)
        ye = np.asarray(interp(te), float) if te < t_new else y_new
        self.record(te, ye)
        self.same_instant = self.same_instant + 1 if (
            self.last_event_t is not None and te - self.last_event_t <= o.event_tol) else 0
        self.last_event_t = te
        if self.same_instant > MAX_EVENTS_AT_ONE_INSTANT:
            raise SimulationError(self.no_progress_message(te, ye, group))
        first = min(group)
        self.trigger = (first[1], first[2])
        for f in group:
            if f[2].startswith("turn:"):
                self.turns[f[2][5:]] = self.turns.get(f[2][5:], 0) + 1
        stop_msg = self.handle_instant(te, ye, [f[2] for f in group if f[1] == "impact"],
                                       [f[2] for f in group if f[1] == "touch"])
        self.t = te
        self.record(self.t, self.y)
        self.h_next = step_size
        if self.status is not None:
            return
        if stop_msg:
            self.status, self.message = 1, stop_msg
        elif len(self.impacts) >= o.max_impacts:
            self.status, self.message = 1, (
                f"max_impacts = {o.max_impacts} reached at t = {self.t:.9g}; "
                "raise it or check for accumulating impacts")
        elif self.t >= o.t1:
            self.status, self.message = 0, END_OF_SPAN

    def note_inadmissible(self, margin: float) -> None:
        """Count a segment whose held forces already leave their cones (or pull) at its
        start: the margin's crossing cannot stop it, so the run says so in its warnings."""
        t0, count, worst = self.inadmissible.get(self.held, (self.t, 0, 0.0))
        self.inadmissible[self.held] = (t0, count + 1, min(worst, margin))

    def no_progress_message(self, t: float, y: np.ndarray, group: Sequence[Event]) -> str:
        """Why the run stops when events recur at one instant, and what can help: the
        events, the free contacts' normal speeds, the options that act on them."""
        names = sorted({f[2] for f in group})
        free = [c for c in names if c in self.contact_at and c not in self.held]
        speeds = self.normal_speeds(free, y) if free else {}
        told = ", ".join(f"{c} (v_n = {speeds[c]:.3e})" if c in speeds else c for c in names)
        return (
            f"{self.same_instant} events at t = {t:.9g} without progress (chattering: "
            f"{told}): handling them did not carry the run past them, they recur at the same "
            "instant. A contact approaching or separating slower than "
            f"rest_velocity (now {self.opts.rest_velocity:.1e}) is closed at the instant and "
            "its mode left to the contact force problem: a larger rest_velocity may get past "
            "it; zeno='stop' does not (it stops on impacts accumulating over time, not on "
            "events repeating at one instant)")

    def handle_instant(self, t: float, y: np.ndarray, closing: Sequence[str],
                       touching: Sequence[str]) -> str | None:
        """:meth:`handle` the events at t, set the state, and record the instant's
        sensitivities when tracking; returns the stop message or None."""
        eq_minus, n_imp, n_ce = self.eq, len(self.impacts), len(self.contact_events)
        self.y, stop_msg = self.handle(t, y, closing, touching)
        self.track_event(t, y, eq_minus, n_imp, n_ce)
        return stop_msg

    # ---- integration -----------------------------------------------------------------------
    def run(self) -> SimulationResult:
        """Integrate from the initial state to the end of the span (or a stop), on one BLAS
        thread: the scheme's matrices are small, and OpenBLAS's threads only wait for one
        another on a busy machine (a table on 32 legs: 3.1 s instead of 0.33 s at a load of
        8 on 2 cores)."""
        with one_blas_thread():
            return self._run()

    def _run(self) -> SimulationResult:
        self.record(self.t, self.y)
        # contacts touching at the start: closed when at rest, impacts when approaching
        touching = [c for c in self.contacts
                    if float(self.mech.contact_gap(c, self.y[:self.k])) <= self.opts.contact_tol]
        if touching:
            stop_msg = self.handle_instant(self.t, self.y, [], touching)
            self.record(self.t, self.y)
            if stop_msg and self.status is None:
                self.status, self.message = 1, stop_msg
        while self.status is None:
            if self.t >= self.opts.t1:
                self.status, self.message = 0, END_OF_SPAN
                break
            self.integrate_segment()
        return self.result()

    def integrate_segment(self) -> None:
        """Integrate with the current modes until an event, a restart or the end."""
        o, k = self.opts, self.k
        eq = self.eq
        free = [c for c in self.contacts if c not in eq.held]
        opts: dict[str, Any] = {"rtol": o.rtol, "atol": o.atol, "max_step": o.max_step}
        bound = o.next_bound(self.t)  # a breakpoint ends the segment there (no event)
        if self.h_next is not None and self.h_next > 0:
            opts["first_step"] = min(float(self.h_next), bound - self.t)
        if eq.n_constraints >= k and bound > self.t:
            # the held rows fix every velocity (theta_dot = 0: a resting stack, a table at
            # rest): p changes with the applied forces alone, and the first step tried is
            # the whole segment, which the integrator keeps where its error estimate allows
            opts["first_step"] = min(bound - self.t, o.max_step)
        solver = o.solver_cls(eq, self.t, self.y, bound, **opts)
        self.n_restarts += 1
        g_prev = self.gaps(free, self.y[:k])
        anchors = self.slip_anchors(self.y)
        w_prev = self.watch(self.t, self.y, anchors) if eq.held else {}
        if w_prev and w_prev["margin"] < -INADMISSIBLE_MARGIN:
            self.note_inadmissible(w_prev["margin"])
        keep = o.dense_output or o.t_eval is not None or o.sensitivities
        interp = None
        while True:
            if interp is not None:
                interp.expire()
            msg = solver.step()
            if solver.status == "failed":
                self.status, self.message = -1, f"integrator failed at t = {solver.t:.9g}: {msg}"
                return
            self.n_steps += 1
            t_old, t_new, y_new = solver.t_old, solver.t, solver.y.copy()
            if not np.all(np.isfinite(y_new)):
                raise SimulationError(f"the state became non-finite at t = {t_new:.9g}")
            interp = StepDense(solver)
            if keep:  # the result keeps every step's interpolant
                interp.built()
            found, g_new = self.closing_in_step(free, interp, t_old, t_new, y_new, g_prev)
            w_new = self.watch(t_new, y_new, anchors) if eq.held else {}
            found += self.held_in_step(interp, t_old, t_new, w_prev, w_new, anchors)
            if found:
                self.on_events(found, interp, t_old, t_new, y_new, solver.step_size)
                return
            self.segments.append((t_old, t_new, interp))
            self.dissipate(interp, t_old, t_new)
            self.t, self.y = t_new, y_new
            residual = eq.residual(self.y[:k]) if eq.n_constraints else ()
            if len(residual):
                drift = float(np.max(np.abs(residual)))
                if drift > o.drift_threshold:
                    interp.expire()  # (the integrator's state is replaced below)
                    self.y = self.project_state(self.y)
                    if not o.in_place:  # multistep: the history is void, restart
                        self.record(self.t, self.y)
                        self.h_next = solver.step_size
                        if solver.status == "finished":
                            self.end_of_bound(bound)
                        return
                    # one-step method: continue from the projected state, same step size
                    solver.y = self.y.copy()
                    solver.f = solver.fun(self.t, solver.y)
                    g_new = self.gaps(free, self.y[:k])
            self.record(self.t, self.y)
            if eq.held:
                anchors = self.slip_anchors(self.y)
                w_new = self.watch(self.t, self.y, anchors)
            g_prev, w_prev = g_new, w_new
            if solver.status == "finished":
                self.end_of_bound(bound)
                return

    def end_of_bound(self, bound: float) -> None:
        """The integrator reached the segment's bound: the span's end, or a breakpoint,
        where the next segment restarts the integrator with a step of its own choosing (a
        kink of the applied forces there is not stepped across)."""
        if bound >= self.opts.t1:
            self.status, self.message = 0, END_OF_SPAN
        else:
            self.h_next = None

    # ---- result ----------------------------------------------------------------------------
    def equations_at(self, t: float) -> CanonicalEquations:
        """The equations in force at time t (right-continuous at events)."""
        i = bisect_right([e[0] for e in self.eq_log], t) - 1
        return self.eq_log[max(i, 0)][1]

    def resample(self, t_eval: np.ndarray, sol: PiecewiseSolution) -> dict[str, list]:
        """The series at ``t_eval``, from the dense output."""
        k = self.k
        t_eval = t_eval[t_eval <= sol.t_max]  # a run stopped early has no state beyond
        ys = sol(t_eval) if t_eval.size else np.zeros((2 * k, 0))
        rows: dict[str, list] = {key: [] for key in SERIES + CONTACT_SERIES}
        done = np.array(self.rows["t"])
        work = np.array(self.rows["friction"])
        keep = self.eq
        try:
            for j, s_t in enumerate(t_eval):
                self.eq = self.equations_at(float(s_t))
                th, dth, sig = self.state(ys[:, j])
                append_sample(rows, self.mech, s_t, th, dth, ys[k:, j], sig)
                rows["friction"].append(float(np.interp(s_t, done, work)))
                forces, _ = held_forces(self.eq, s_t, ys[:, j]) if self.held else ({}, 0.0)
                contact_rows(rows, self.contacts, self.eq, forces, self.d)
        finally:
            self.eq = keep
        return rows

    def force_series(self, samples: list):
        """The samples' contact forces (n, n_contacts, d), or where some are still to
        compute, the callable that computes them (the result's lazy ``contact_force``)."""
        contacts, d = self.contacts, self.d
        if any(isinstance(s, PendingForces) for s in samples):
            return lambda: force_series(samples, contacts, d)
        return force_series(samples, contacts, d)

    def result(self) -> SimulationResult:
        """The :class:`SimulationResult` of the run."""
        o = self.opts
        wall = _time.perf_counter() - self.started
        sol = PiecewiseSolution(self.segments) if self.segments else None
        rows = self.rows
        if o.t_eval is not None and sol is not None:
            rows = self.resample(o.t_eval, sol)
        nfev = sum(e.nfev for _, e in self.eq_log)
        flag_counts, warnings = law_flags(self.impacts, o.law)
        flag_counts["painleve"] = len(self.painleve)
        warnings += tuple(f"Painleve's paradox at t = {ev.time:.9g} ({ev.kind}, contacts "
                          f"{', '.join(ev.contacts)}): the run stopped" for ev in self.painleve)
        warnings += tuple(f"{note} (at {count} mode selection{'s' if count > 1 else ''} from "
                          f"t = {t0:.9g})" for note, (t0, count) in self.force_notes.items())
        warnings += tuple(
            f"the held contacts' forces ({', '.join(held)}) start {count} segment"
            f"{'s' if count > 1 else ''} from t = {t0:.9g} tensile or outside their cones "
            f"(smallest margin {worst:.3g} of the force scale; the canonical equations' "
            "distribution, not the force problem's): "
            "carried to each segment's next event" for held, (t0, count, worst)
            in self.inadmissible.items())
        n = len(rows["t"])
        sensitivities = self.final_sensitivities()
        warnings += self.sensitivity_warnings
        res = SimulationResult(
            **series_from_rows(rows, self.k, self.m), held=np.array(rows["held"], dtype=int),
            impacts=tuple(self.impacts), contact_events=tuple(self.contact_events),
            sol=sol if o.dense_output else None, status=int(self.status), message=self.message,
            nfev=int(nfev), nevents_fev=int(self.nevents_fev), n_steps=int(self.n_steps),
            n_projections=int(self.n_projections), n_restarts=int(self.n_restarts),
            wall_time=float(wall), impact_time=float(self.impact_time),
            settings=o.settings(), warnings=warnings, contact_names=self.contacts,
            contact_mode=np.array(rows["mode"], dtype=int).reshape(n, len(self.contacts)),
            contact_force=self.force_series(rows["force"]),
            mode_intervals=self.modes.intervals(self.t), painleve=tuple(self.painleve),
            friction_dissipation=np.array(rows["friction"], float), law_flags=flag_counts,
            **sensitivities)
        if self.painleve_error is not None:
            self.painleve_error.result = res
            raise self.painleve_error
        return res


__all__ = ["EventDrivenRun", "HeldMode", "MAX_EVENTS_AT_ONE_INSTANT"]
