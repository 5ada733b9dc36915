"""``simulate``: event-driven integration of the canonical equations with piece-wise impacts.

The integration array ``y = [theta, p]`` (eq. 15) is advanced by one of scipy's ``OdeSolver``
classes, step by step. After every accepted step

1. the free contacts' gaps are checked for closing (event functions, terminal, direction -1);
   besides the sign at the two ends of the step, each gap is sampled at 7 interior points of
   the step's interpolant, with its normal velocity for a Hermite check between samples (a
   long free-flight step can dip below zero and come back); the
   earliest closing is located on the step's interpolant by Brent's method to
   ``event_tol``. Every other free contact whose gap is within ``contact_tol`` and that
   approaches at that instant closes *together* with it;
2. persistent (held) contacts are checked for their normal force turning tensile (release);
3. the loop drift max |Psi| is checked and, above ``projection_tol``, theta is projected back
   onto Psi = 0 (see :mod:`convimpact.simulation.projection`).

At an impact the integration halts, ``resolve_impact`` (with the chosen ``law`` and
``method``; loops and held contacts enter through C) gives the jump in theta_dot and the loop
impulses, p is updated (``Delta p = Jc^T pi``, eq. 33), the state is projected, and the
integration restarts. Accumulating impacts are treated as documented in
:mod:`convimpact.simulation.zeno`.
"""

from __future__ import annotations

import time as _time
from typing import Any, Mapping, Sequence

import numpy as np
from scipy.integrate import DOP853, RK23, RK45, OdeSolver, Radau

from ..impact.errors import (
    ConvImpactError,
    ParameterError,
    ShapeError,
    SimulationError,
    UnknownOptionError,
)
from ..impact import check_law_method, resolve_impact
from ..mechanism import Mechanism
from .canonical import CanonicalEquations
from .events import first_dip, locate_crossing, reclosing
from .initial import INTEGRATORS  # noqa: F401  (re-exported)
from .initial import consistent_start, integrator_class, positive, state_vector, time_span
from .projection import project_positions, project_velocities
from .result import (ContactEvent, ImpactEvent, PiecewiseSolution, SimulationResult,
                     append_sample, series_from_rows)
from .zeno import AccumulationDetector

ZENO_POLICIES = ("persist", "stop")
#: integrators whose state (y, f) can be replaced after a step without a restart
ONE_STEP = (RK23, RK45, DOP853, Radau)
#: events at one instant beyond which the run is declared chattering (never loops forever)
MAX_EVENTS_AT_ONE_INSTANT = 50
#: tangential speed of a held contact with mu > 0 above which it counts as sliding (warning)
SLIP_SPEED = 1e-4


def _as_mechanism(system) -> tuple[Mechanism, Any]:
    mech = getattr(system, "mechanism", None)
    if mech is not None and hasattr(system, "theta0"):
        return mech, system
    if isinstance(system, Mechanism):
        return system, None
    raise ShapeError(
        f"simulate needs a Mechanism (see convimpact.mechanism) or a Scene, got "
        f"{type(system).__name__}")


class _Recorder:
    def __init__(self):
        self.rows: dict[str, list] = {k: [] for k in (
            "t", "theta", "dtheta", "p", "sigma", "T", "V", "psi", "cdq", "held")}

    def add(self, t, theta, dtheta, p, sigma, T, V, psi, cdq, held):
        r = self.rows
        for key, val in zip(r, (t, theta, dtheta, p, sigma, T, V, psi, cdq, held)):
            r[key].append(val)


def simulate(
    system,
    t_span: Sequence[float] | None = None,
    y0=None,
    *,
    law: str = "pereira-nikravesh",
    method: str = "auto",
    integrator: str | type[OdeSolver] = "DOP853",
    rtol: float = 1e-8,
    atol: float = 1e-10,
    max_step: float = np.inf,
    first_step: float | None = None,
    dense_output: bool = False,
    t_eval: Sequence[float] | None = None,
    event_tol: float = 1e-12,
    contact_tol: float = 1e-8,
    projection_tol: float = 1e-10,
    assemble: bool = False,
    zeno: str = "persist",
    zeno_time_tol: float | None = None,
    rest_velocity: float = 1e-6,
    max_impacts: int = 10_000,
    impact_options: Mapping[str, Any] | None = None,
) -> SimulationResult:
    """Integrate the canonical equations of a mechanism through its impacts.

    Parameters
    ----------
    system : Mechanism or Scene
        The model (any object satisfying :class:`convimpact.mechanism.Mechanism`), or a
        :class:`convimpact.scenes.Scene` (its mechanism, initial state and ``t_end``).
    t_span : (t0, t1), optional
        Strictly increasing time span; default ``(0, scene.t_end)`` for a scene.
    y0 : tuple (theta0, dtheta0) or ndarray [theta0, p0], optional
        Initial state: a *tuple* of joint coordinates and velocities, or the canonical array
        ``y = [theta, p]`` of eq. (15) as an ndarray (sigma0 = 0). Default: the scene's.
    law, method : str
        Impact law and solver path passed to :func:`convimpact.resolve_impact`. Several
        contacts closing together need a multi-contact method ("clarabel", "cvxpy").
    integrator : str or OdeSolver subclass
        "DOP853" (default), "RK45", "RK23", "Radau", "BDF", "LSODA", or a scipy OdeSolver.
    rtol, atol, max_step, first_step : integrator controls (as in ``solve_ivp``).
    dense_output : bool
        Attach ``sol(t) -> [theta, p]`` across all segments (right-continuous at impacts).
    t_eval : sequence, optional
        Sample the series at these times (from the dense output) instead of at the steps.
    event_tol : float
        Absolute tolerance (s) of Brent's method locating an event on the step's
        interpolant; the interpolant itself is accurate to the integrator's rtol/atol.
    contact_tol : float
        Gap (length units) within which another approaching contact closes simultaneously,
        and the penetration accepted in the initial state.
    projection_tol : float
        Max |Psi| (loops and held contacts) tolerated after a step before theta is projected
        back onto Psi = 0 (always projected after an event). One-step integrators (RK23,
        RK45, DOP853, Radau) continue from the projected state; multistep ones (BDF, LSODA)
        restart, and are projected only beyond ``max(projection_tol, 1000 atol)``.
    assemble : bool
        If the initial state violates Psi = 0 or C theta_dot = 0: project it onto the
        constraints (True) or raise :class:`~convimpact.impact.errors.LoopConstraintError` (False).
    zeno : {"persist", "stop"}
        Accumulating impacts (see :mod:`convimpact.simulation.zeno`): hold the contact closed
        as a bilateral constraint until its normal force turns tensile ("persist"), or stop
        the run with status 1 and a report ("stop").
    zeno_time_tol : float, optional
        Remaining time (s) to the extrapolated accumulation point below which a bouncing
        contact is declared accumulating (once its last three interval ratios agree, see
        :mod:`convimpact.simulation.zeno`); default ``1e6 * event_tol`` (1e-6 s), independent
        of the span so that the result does not depend on ``t_end``.
    rest_velocity : float
        Separation speed at or below which a contact is at rest (held) after an impact.
    max_impacts : int
        The run stops (status 1) after this many impacts.
    impact_options : mapping, optional
        Options forwarded to the impact solver.

    Returns
    -------
    SimulationResult

    Notes
    -----
    * Impact times are located by Brent's method on the step's interpolant to ``event_tol``
      (absolute, in s); the interpolant's own accuracy is that of the integrator (rtol, atol).
      The located instant is on the closed side (gap <= 0 up to the interpolation error).
      A gap that goes below zero and back within one step is caught when one of 7 equally
      spaced interior samples of the step is <= 0, or, between two positive samples, when
      the cubic Hermite fit of the gap and its normal velocity has a minimum near zero and
      the located minimum of the gap is <= 0 (:func:`~convimpact.simulation.events.
      first_dip`). A contact separating at the start of a step (just impacted) is checked for
      coming back below its starting gap at the interior samples too. Two or more extrema of
      the gap between neighbouring samples can still hide a dip: bound ``max_step`` for very
      fast-spinning bodies.
    * Contacts whose gap is within ``contact_tol`` and that approach at the located instant
      are resolved together (one call of ``resolve_impact`` with a list of Jacobians).
    * Persistent (held) contacts are bilateral and frictionless in the tangent plane: sustained
      sliding friction is not modelled. A held contact with mu > 0 that slides (tangential
      speed above 1e-4 on consecutive stored samples) is reported in
      ``SimulationResult.warnings`` (and appended to ``message``) with its sliding duration and max slip speed: the motion
      after such a hold overestimates the sliding (e.g. the default ``pendulum_planar`` tip
      slides undamped after its impacts accumulate); impacts of other contacts treat them as constraints
      (rows of C); one that would receive a tensile impulse is released and the impact redone.
    * Loop drift: C theta_dot = 0 holds to round-off by construction (theta_dot is solved from
      eqs. 7 + 13); max |Psi| is kept below ``projection_tol`` at every stored state by
      projection. Both are reported per sample and as maxima.
    * The run never stalls: accumulations are detected (module ``zeno``), impacts are capped by
      ``max_impacts``, and more than 50 events at one instant raise ``SimulationError``.

    Raises
    ------
    ShapeError, NonFiniteError, ParameterError, UnknownOptionError
        for malformed input (NaN in the state, non-increasing t_span, unknown names);
    LoopConstraintError
        for an initial state that violates the loops when ``assemble=False``;
    AssemblyError
        when ``assemble=True`` and the loops cannot be assembled;
    PenetrationError
        when the initial state penetrates a contact by more than ``contact_tol``;
    SimulationError
        when the right-hand side becomes non-finite or events chatter at one instant.
    """
    wall0 = _time.perf_counter()
    mech, scene = _as_mechanism(system)
    k = int(mech.n_coordinates)
    m = int(mech.n_loop_constraints)
    contacts = tuple(mech.contact_names)

    # ---- options ---------------------------------------------------------------------------
    check_law_method(law, method)
    if zeno not in ZENO_POLICIES:
        raise UnknownOptionError(f"unknown zeno policy {zeno!r}; choose 'persist' or 'stop'")
    solver_cls = integrator_class(integrator)
    positive(rtol=rtol, atol=atol, event_tol=event_tol, contact_tol=contact_tol,
             projection_tol=projection_tol)
    if not rest_velocity >= 0:
        raise ParameterError(f"rest_velocity must be >= 0, got {rest_velocity!r}")
    if int(max_impacts) < 0:
        raise ParameterError(f"max_impacts must be >= 0, got {max_impacts!r}")

    t0, t1 = time_span(t_span, scene)
    if t_eval is not None:
        t_eval = np.asarray(t_eval, dtype=float).ravel()
        if t_eval.size and (np.any(np.diff(t_eval) < 0) or t_eval[0] < t0 or t_eval[-1] > t1):
            raise ParameterError("t_eval must be sorted and lie within t_span")
    zeno_tol = 1e6 * event_tol if zeno_time_tol is None else float(zeno_time_tol)
    # one-step methods continue from a projected state; multistep ones must restart, so
    # they are projected only beyond a looser threshold
    in_place = issubclass(solver_cls, ONE_STEP)
    drift_threshold = projection_tol if in_place else max(projection_tol, 1e3 * atol)
    impact_options = dict(impact_options or {})

    # ---- initial state ---------------------------------------------------------------------
    eqs_cache: dict[tuple[str, ...], CanonicalEquations] = {}

    def equations(held: tuple[str, ...]) -> CanonicalEquations:
        if held not in eqs_cache:
            eqs_cache[held] = CanonicalEquations(mech, held)
        return eqs_cache[held]

    eqs0 = equations(())
    if y0 is None:
        if scene is None:
            raise ShapeError("y0 is required when simulating a bare mechanism")
        y0 = (scene.theta0, scene.dtheta0)
    if isinstance(y0, tuple):
        if len(y0) != 2:
            raise ShapeError("y0 as a tuple must be (theta0, dtheta0)")
        theta = state_vector("theta0", y0[0], k)
        dtheta = state_vector("dtheta0", y0[1], k)
        p = None
    else:
        yv = state_vector("y0", y0, 2 * k)
        theta, p = yv[:k], yv[k:]
        dtheta = None

    theta, dtheta = consistent_start(mech, theta, dtheta, assemble=assemble,
                                     projection_tol=projection_tol, contact_tol=contact_tol)
    if p is None:
        p = eqs0.momentum(theta, dtheta)  # sigma0 = 0

    # ---- run ---------------------------------------------------------------------------------
    rec = _Recorder()
    segments: list = []
    impacts: list[ImpactEvent] = []
    contact_events: list[ContactEvent] = []
    detector = AccumulationDetector(zeno_tol, rest_velocity)
    counters = {"steps": 0, "proj": 0, "restarts": 0, "evfev": 0, "impact_time": 0.0}
    held: tuple[str, ...] = ()

    def contact_row(c: str, th: np.ndarray) -> np.ndarray:
        return np.asarray(mech.contact_jacobian(c, th), float)

    def gap(c: str, th: np.ndarray) -> float:
        counters["evfev"] += 1
        return float(mech.contact_gap(c, th))

    # held contacts are frictionless: track their sliding when mu > 0 to warn about it
    mus = {c: float(mech.contact_parameters(c)[1]) for c in contacts}
    slip: dict[str, dict[str, Any]] = {}

    def track_slip(t: float, th: np.ndarray, dth: np.ndarray, held_: tuple[str, ...]) -> None:
        for c in contacts:
            s_c = slip.get(c)
            if c not in held_ or mus[c] <= 0.0:
                if s_c is not None:
                    s_c["t_prev"] = None
                continue
            J = contact_row(c, th)
            vt = float(np.linalg.norm(J[1:] @ dth)) if len(J) > 1 else 0.0
            if vt <= SLIP_SPEED:
                if s_c is not None:
                    s_c["t_prev"] = None
                continue
            if s_c is None:
                s_c = slip[c] = {"first": t, "t_prev": None, "duration": 0.0, "vmax": 0.0}
            if s_c["t_prev"] is not None:
                s_c["duration"] += t - s_c["t_prev"]
            s_c["t_prev"] = t
            s_c["vmax"] = max(s_c["vmax"], vt)

    def record(t: float, y: np.ndarray, held_: tuple[str, ...]) -> None:
        eq = equations(held_)
        th, pp = y[:k], y[k:]
        dth, sig, _ = eq.velocities(th, pp)
        track_slip(t, th, dth, held_)
        if m:
            psi = float(np.max(np.abs(mech.loop_residual(th))))
            cdq = float(np.max(np.abs(np.asarray(mech.loop_jacobian(th), float) @ dth)))
        else:
            psi = cdq = 0.0
        rec.add(t, th.copy(), dth, pp.copy(), sig[:m].copy(), float(mech.kinetic_energy(th, dth)),
                float(mech.potential_energy(th)), psi, cdq, len(held_))

    def project_state(y: np.ndarray, held_: tuple[str, ...], sigma: np.ndarray,
                      dth: np.ndarray) -> np.ndarray:
        """Project theta onto Psi = 0 and theta_dot onto C theta_dot = 0; rebuild p (eq. 13)."""
        eq = equations(held_)
        th = y[:k]
        if eq.n_constraints:
            M = np.asarray(mech.mass_matrix(th), float)
            th, _, _ = project_positions(eq.residual, eq.jacobian, M, th,
                                         0.1 * projection_tol)
            M = np.asarray(mech.mass_matrix(th), float)
            dth = project_velocities(M, eq.jacobian(th), dth)
            counters["proj"] += 1
        return np.concatenate([th, eq.momentum(th, dth, sigma)])

    def hold(t: float, y: np.ndarray, held_: tuple[str, ...], candidates: Sequence[str],
             reason: str, limit: dict[str, float | None]) -> tuple[np.ndarray, tuple[str, ...]]:
        """Hold ``candidates`` closed: plastic frictionless correction of their normal velocity,
        then keep those whose normal force is compressive."""
        eq = equations(held_)
        th = y[:k]
        dth, sig, _ = eq.velocities(th, y[k:])
        new = tuple(held_) + tuple(c for c in candidates if c not in held_)
        while True:
            eqn = equations(new)
            M = np.asarray(mech.mass_matrix(th), float)
            dth_h = project_velocities(M, eqn.jacobian(th), dth)
            sig_n = np.concatenate([sig, np.zeros(eqn.n_constraints - len(sig))])
            yh = np.concatenate([th, eqn.momentum(th, dth_h, sig_n)])
            nu = eqn.multipliers(t, yh)[m:]
            new_idx = [i for i, c in enumerate(new) if c in candidates and c not in held_]
            tensile = [(nu[i], i) for i in new_idx if nu[i] <= 0.0]
            if not tensile:
                break
            _, worst = min(tensile)
            new = tuple(c for i, c in enumerate(new) if i != worst)
        T0 = float(mech.kinetic_energy(th, dth))
        T1 = float(mech.kinetic_energy(th, dth_h))
        for c in new:
            if c not in held_:
                contact_events.append(ContactEvent(t, c, "persist", reason, limit.get(c),
                                                   T1 - T0))
        return yh, new

    def release(t: float, y: np.ndarray, held_: tuple[str, ...], names: Sequence[str],
                reason: str) -> tuple[np.ndarray, tuple[str, ...]]:
        eq = equations(held_)
        th = y[:k]
        dth, sig, _ = eq.velocities(th, y[k:])
        keep = [i for i, c in enumerate(held_) if c not in names]
        new = tuple(held_[i] for i in keep)
        sig_n = np.concatenate([sig[:m], sig[m:][keep]]) if len(sig) else sig
        for c in names:
            contact_events.append(ContactEvent(t, c, "release", reason))
            detector.forget(c)
        return np.concatenate([th, equations(new).momentum(th, dth, sig_n)]), new

    def impact(t: float, y: np.ndarray, held_: tuple[str, ...], closing: Sequence[str]):
        """Resolve the closing contacts together; returns (y, held, stop_message)."""
        th = y[:k]
        eq = equations(held_)
        dth, sig, _ = eq.velocities(th, y[k:])
        M = np.asarray(mech.mass_matrix(th), float)
        params = {c: mech.contact_parameters(c) for c in closing}
        released: list[str] = []
        spent = [0.0]

        def solve(held_now, e_override):
            eqh = equations(held_now)
            C = eqh.jacobian(th)
            Jc = [contact_row(c, th) for c in closing]
            es = [0.0 if c in e_override else float(params[c][0]) for c in closing]
            mus = [float(params[c][1]) for c in closing]
            t_start = _time.perf_counter()
            try:
                if len(closing) == 1:
                    r = resolve_impact(M, Jc[0], dth, es[0], mus[0], C if len(C) else None,
                                       law=law, method=method, **impact_options)
                else:
                    r = resolve_impact(M, Jc, dth, es, mus, C if len(C) else None,
                                       law=law, method=method, **impact_options)
            except ConvImpactError as exc:
                exc.add_note(f"(while resolving the impact of {', '.join(closing)} at "
                             f"t = {t:.9g} in convimpact.simulation.simulate)")
                raise
            finally:
                dt_solve = _time.perf_counter() - t_start
                counters["impact_time"] += dt_solve
                spent[0] += dt_solve
            return r, Jc

        held_now = tuple(held_)
        e_override: set[str] = set()
        while True:
            r, Jc = solve(held_now, e_override)
            dsig_h = np.asarray(r.loop_impulse, float)[m:]
            scale = max(float(np.max(np.abs(r.impulse))), 1e-300)
            tens = [i for i, v in enumerate(dsig_h) if v < -1e-9 * scale]
            if not tens:
                break
            # a held contact is pulled: it separates (released) and the impact is redone
            names = [held_now[i] for i in tens]
            released.extend(names)
            yy, held_now = release(t, np.concatenate([th, eq.momentum(th, dth, sig)]), held_now,
                                   names, "impulse of an impact would be tensile")
            dth, sig, _ = equations(held_now).velocities(th, yy[k:])
            eq = equations(held_now)
        # accumulation check (Zeno) on each contact that bounced
        stop_msg = None
        zeno_hit = False
        persist: list[str] = []
        limits: dict[str, float | None] = {}
        reasons = []
        for i, c in enumerate(closing):
            detector.record(c, t)
            v_sep = float(Jc[i][0] @ r.dq_plus)
            verdict = detector.check(c, v_sep)
            if verdict.accumulating:
                persist.append(c)
                limits[c] = verdict.limit_time
                reasons.append(f"{c}: {verdict.reason}")
                if verdict.kind == "accumulation":
                    zeno_hit = True
        if zeno_hit and zeno == "stop":
            stop_msg = ("accumulating impacts detected (zeno='stop'): " + "; ".join(reasons))
        elif persist:
            needs_redo = [c for c in persist if float(params[c][0]) > 0.0]
            if needs_redo:
                e_override = set(persist)
                r, Jc = solve(held_now, e_override)
        dq_plus = np.asarray(r.dq_plus, float)
        dsig = np.asarray(r.loop_impulse, float)
        sig_plus = sig + dsig if len(sig) else sig
        eqh = equations(held_now)
        Jflat = np.vstack(Jc)
        impulse = np.asarray(r.impulse, float).reshape(len(closing), -1)
        gen = Jflat.T @ impulse.ravel()  # Delta p = Jc^T pi, eq. (33)
        T_minus = float(mech.kinetic_energy(th, dth))
        T_plus = float(mech.kinetic_energy(th, dq_plus))
        regime = (r.regime,) if isinstance(r.regime, str) else tuple(r.regime)
        yy = np.concatenate([th, eqh.momentum(th, dq_plus, sig_plus)])
        new_held = held_now
        if persist and stop_msg is None:
            yy, new_held = hold(t, yy, held_now, persist, "; ".join(reasons), limits)
        impacts.append(ImpactEvent(
            time=t, contacts=tuple(closing), held_contacts=tuple(held_now), regime=regime,
            impulse=impulse, loop_impulse=dsig, generalized_impulse=gen, theta=th.copy(),
            dtheta_minus=dth.copy(), dtheta_plus=dq_plus.copy(),
            energy_loss=float(r.energy_loss), kinetic_energy_minus=T_minus,
            kinetic_energy_plus=T_plus,
            persistent=tuple(c for c in new_held if c not in held_now),
            released=tuple(released), resolve_time=spent[0], result=r))
        return yy, new_held, stop_msg

    def handle(t: float, y: np.ndarray, held_: tuple[str, ...], closing: Sequence[str],
               touching: Sequence[str], releasing: Sequence[str]):
        """All events at instant t; returns (y, held, stop_message)."""
        if releasing:
            y, held_ = release(t, y, held_, releasing, "normal force reached zero (tensile)")
        eq = equations(held_)
        th = y[:k]
        dth, _, _ = eq.velocities(th, y[k:])
        vn = {}
        for c in contacts:
            if c in held_ or c in releasing:
                continue
            if c in closing or c in touching or gap(c, th) <= contact_tol:
                vn[c] = float(contact_row(c, th)[0] @ dth)
        group = [c for c, v in vn.items() if v < -rest_velocity]
        rest = [c for c, v in vn.items() if abs(v) <= rest_velocity]
        stop_msg = None
        if group:
            y, held_, stop_msg = impact(t, y, held_, group)
        if rest and stop_msg is None:
            y, held_ = hold(t, y, held_, rest, "touching at rest (|v_n| <= rest_velocity)", {})
        eq = equations(held_)
        dth, sig, _ = eq.velocities(y[:k], y[k:])
        return project_state(y, held_, sig, dth), held_, stop_msg

    t = t0
    y = np.concatenate([theta, p])
    status: int | None = None
    message = ""
    record(t, y, held)
    # contacts touching at the start
    touching0 = [c for c in contacts if float(mech.contact_gap(c, theta)) <= contact_tol]
    if touching0:
        y, held, stop_msg = handle(t, y, held, [], touching0, [])
        record(t, y, held)
        if stop_msg:
            status, message = 1, stop_msg
    h_next = first_step
    same_instant = 0
    last_event_t = None
    while status is None:
        if t >= t1:
            status, message = 0, "the end of the time span was reached"
            break
        eq = equations(held)
        free = [c for c in contacts if c not in held]
        opts: dict[str, Any] = {"rtol": rtol, "atol": atol, "max_step": max_step}
        if h_next is not None and h_next > 0:
            opts["first_step"] = min(float(h_next), t1 - t)
        solver = solver_cls(eq, t, y, t1, **opts)
        counters["restarts"] += 1
        g_prev = {c: gap(c, y[:k]) for c in free}
        nu_prev = eq.multipliers(t, y)[m:] if held else np.zeros(0)
        while True:
            msg = solver.step()
            if solver.status == "failed":
                status, message = -1, f"integrator failed at t = {solver.t:.9g}: {msg}"
                break
            counters["steps"] += 1
            t_old, t_new, y_new = solver.t_old, solver.t, solver.y.copy()
            if not np.all(np.isfinite(y_new)):
                raise SimulationError(f"the state became non-finite at t = {t_new:.9g}")
            interp = solver.dense_output()
            found: list[tuple[float, str, str]] = []
            g_new = {}
            for c in free:
                gn = gap(c, y_new[:k])
                g_new[c] = gn

                def gfun(s, c=c):
                    return gap(c, interp(s)[:k])

                def vfun(s, c=c, interp=interp, eq=eq):
                    ys = np.asarray(interp(s), float)
                    dth_s, _, _ = eq.velocities(ys[:k], ys[k:])
                    return float(contact_row(c, ys[:k])[0] @ dth_s)

                dip = (first_dip(gfun, t_old, t_new, g_prev[c], dfun=vfun,
                                 xtol=event_tol) if g_prev[c] > 0.0 else None)
                if dip is not None:
                    # the gap dips below zero inside the step (and may come back)
                    found.append((locate_crossing(gfun, *dip, event_tol), "impact", c))
                elif g_prev[c] > 0.0 and gn <= 0.0:
                    found.append((locate_crossing(gfun, t_old, t_new, g_prev[c], gn, event_tol),
                                  "impact", c))
                elif g_prev[c] <= 0.0:
                    y_old = np.asarray(interp(t_old), float)
                    dth_old, _, _ = eq.velocities(y_old[:k], y_old[k:])
                    v0 = float(contact_row(c, y_old[:k])[0] @ dth_old)
                    if v0 > 0.0:
                        # separating from the start (just impacted or released): it may come
                        # back below its starting level inside the step, even if open at its end
                        te = reclosing(gfun, t_old, t_new, g_prev[c], v0, gn, event_tol)
                        if te is not None:
                            found.append((te, "impact", c))
                    elif gn < 0.0 and gn < g_prev[c]:
                        found.append((t_old, "touch", c))
            nu_new = eq.multipliers(t_new, y_new)[m:] if held else np.zeros(0)
            for i, c in enumerate(held):
                if nu_prev[i] > 0.0 and nu_new[i] <= 0.0:
                    def nfun(s, i=i):
                        counters["evfev"] += 1
                        return float(eq.multipliers(s, interp(s))[m + i])
                    found.append((locate_crossing(nfun, t_old, t_new, nu_prev[i], nu_new[i],
                                                  event_tol), "release", c))
                elif nu_prev[i] <= 0.0:
                    found.append((t_old, "release", c))
            if not found:
                segments.append((t_old, t_new, interp))
                t, y = t_new, y_new
                if eq.n_constraints:
                    drift = float(np.max(np.abs(eq.residual(y[:k]))))
                    if drift > drift_threshold:
                        dth, sig, _ = eq.velocities(y[:k], y[k:])
                        y = project_state(y, held, sig, dth)
                        if not in_place:  # multistep: the history is void, restart
                            record(t, y, held)
                            h_next = solver.step_size
                            if solver.status == "finished":
                                status, message = 0, "the end of the time span was reached"
                            break
                        # one-step method: continue from the projected state, same step size
                        solver.y = y.copy()
                        solver.f = solver.fun(t, solver.y)
                        g_new = {c: gap(c, y[:k]) for c in free}
                        nu_new = eq.multipliers(t, y)[m:] if held else np.zeros(0)
                record(t, y, held)
                g_prev, nu_prev = g_new, nu_new
                if solver.status == "finished":
                    status, message = 0, "the end of the time span was reached"
                    break
                continue
            te = min(f[0] for f in found)
            group = [f for f in found if f[0] <= te + event_tol]
            if te > t_old:
                segments.append((t_old, te, interp))
            ye = np.asarray(interp(te), float) if te < t_new else y_new
            record(te, ye, held)
            same_instant = same_instant + 1 if (last_event_t is not None
                                                and te - last_event_t <= event_tol) else 0
            last_event_t = te
            if same_instant > MAX_EVENTS_AT_ONE_INSTANT:
                raise SimulationError(
                    f"{same_instant} events at t = {te:.9g} without progress (chattering "
                    f"contacts {sorted({f[2] for f in group})}); loosen contact_tol or "
                    "rest_velocity, or use zeno='stop'")
            y, held, stop_msg = handle(
                te, ye, held, [f[2] for f in group if f[1] == "impact"],
                [f[2] for f in group if f[1] == "touch"],
                [f[2] for f in group if f[1] == "release"])
            t = te
            record(t, y, held)
            h_next = solver.step_size
            if stop_msg:
                status, message = 1, stop_msg
            elif len(impacts) >= max_impacts:
                status, message = 1, (f"max_impacts = {max_impacts} reached at t = {t:.9g}; "
                                      "raise it or check for accumulating impacts")
            elif t >= t1:
                status, message = 0, "the end of the time span was reached"
            break

    # ---- result ------------------------------------------------------------------------------
    wall = _time.perf_counter() - wall0
    sol = PiecewiseSolution(segments) if segments else None
    r = rec.rows
    held_series = np.array(r["held"], dtype=int)
    if t_eval is not None and sol is not None:
        t_eval = t_eval[t_eval <= sol.t_max]  # a run stopped early has no state beyond
        ys = sol(t_eval) if t_eval.size else np.zeros((2 * k, 0))
        r = {key: [] for key in ("t", "theta", "dtheta", "p", "sigma", "T", "V", "psi", "cdq")}
        held_at = []
        for j, s_t in enumerate(t_eval):
            names = _held_names_at(contact_events, float(s_t))
            th, pp = ys[:k, j], ys[k:, j]
            dth, sig, _ = equations(names).velocities(th, pp)
            held_at.append(len(names))
            append_sample(r, mech, s_t, th, dth, pp, sig)
        held_series = np.array(held_at, dtype=int)
    nfev = sum(e.nfev for e in eqs_cache.values())
    warnings = tuple(
        f"held contact {c!r} (mu = {mus[c]:g}) slid without friction for {sc['duration']:.4g} s "
        f"(first at t = {sc['first']:.6g}), max slip speed {sc['vmax']:.4g} (length/s): held (persistent) "
        "contacts are frictionless in this simulator, so this sliding is not dissipated"
        for c, sc in slip.items() if sc["duration"] > 0.0)
    if warnings:
        message = message + "; WARNING: " + "; ".join(warnings)
    settings = {
        "law": law, "method": method,
        "integrator": solver_cls.__name__, "rtol": rtol, "atol": atol,
        "max_step": None if not np.isfinite(max_step) else max_step,
        "event_tol": event_tol, "contact_tol": contact_tol, "projection_tol": projection_tol,
        "zeno": zeno, "zeno_time_tol": zeno_tol, "rest_velocity": rest_velocity,
        "max_impacts": int(max_impacts), "t_span": [t0, t1],
    }
    return SimulationResult(
        **series_from_rows(r, k, m),
        held=held_series,
        impacts=tuple(impacts),
        contact_events=tuple(contact_events),
        sol=sol if dense_output else None,
        status=int(status),
        message=message,
        nfev=int(nfev),
        nevents_fev=int(counters["evfev"]),
        n_steps=int(counters["steps"]),
        n_projections=int(counters["proj"]),
        n_restarts=int(counters["restarts"]),
        wall_time=float(wall),
        impact_time=float(counters["impact_time"]),
        settings=settings,
        warnings=warnings,
    )


def _held_names_at(contact_events: Sequence[ContactEvent], t: float) -> tuple[str, ...]:
    """The held set in force at time t (right-continuous), replayed from the switches."""
    held: list[str] = []
    for ev in contact_events:
        if ev.time > t:
            break
        if ev.kind == "persist" and ev.contact not in held:
            held.append(ev.contact)
        elif ev.kind == "release" and ev.contact in held:
            held.remove(ev.contact)
    return tuple(held)
