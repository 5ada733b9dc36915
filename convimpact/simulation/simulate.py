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
2. the closed (held) contacts are watched: a normal force turning tensile (the contact
   opens), a sticking force reaching the friction cone's boundary (it starts to slip), a slip
   velocity reaching zero (the stick test decides between sticking and slipping on in a new
   direction), and the sliding contacts' force system turning singular (Painleve); each is
   located on the step's interpolant to ``event_tol``, and the contact force problem
   (:mod:`convimpact.simulation.contact_forces`) selects the new modes;
3. the loop drift max |Psi| is checked and, above ``projection_tol``, theta is projected back
   onto Psi = 0 (see :mod:`convimpact.simulation.projection`).

At an impact the integration halts, ``resolve_impact`` (with the chosen ``law`` and
``method``; loops and held contacts enter through C) gives the jump in theta_dot and the loop
impulses, p is updated (``Delta p = Jc^T pi``, eq. 33), the state is projected, and the
integration restarts. A contact left with v_n+ ~ 0 (e = 0, or an accumulation, see
:mod:`convimpact.simulation.zeno`) stays closed, in the mode the force problem selects.

This module validates the options and the initial state; the run itself is an
:class:`~convimpact.simulation.event_driven.EventDrivenRun`.
"""

from __future__ import annotations

import time as _time
from typing import Any, Mapping, Sequence

import numpy as np
from scipy.integrate import DOP853, RK23, RK45, OdeSolver, Radau

from ..impact import check_law_method
from ..errors import ShapeError
from ..mechanism import Mechanism
from .canonical import CanonicalEquations
from .event_driven import MAX_EVENTS_AT_ONE_INSTANT  # noqa: F401  (re-exported)
from .event_driven import EventDrivenRun
from .initial import INTEGRATORS  # noqa: F401  (re-exported)
from ..validation import (boolean, choice, integer, integration_controls, nonnegative, positive,
                          sorted_times)
from .initial import consistent_start, integrator_class, law_options, state_vector, time_span
from .options import EventDrivenOptions
from .result import SimulationResult

ZENO_POLICIES = ("persist", "stop")
PAINLEVE_POLICIES = ("stop", "raise")
IMPACT_POLICIES = ("simultaneous", "sequential")
#: integrators whose state (y, f) can be replaced after a step without a restart
ONE_STEP = (RK23, RK45, DOP853, Radau)


def _as_mechanism(system) -> tuple[Mechanism, Any]:
    mech = getattr(system, "mechanism", None)
    if mech is not None and hasattr(system, "theta0"):
        return mech, system
    if isinstance(system, Mechanism):
        return system, None
    raise ShapeError(
        f"simulate needs a Mechanism (see convimpact.mechanism) or a Scene, got "
        f"{type(system).__name__}")


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
    painleve: str = "stop",
    impacts: str = "simultaneous",
    impact_options: Mapping[str, Any] | None = None,
    sensitivities: bool = False,
    breakpoints: Sequence[float] = (),
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
        Impact law and solver path passed to :func:`convimpact.resolve_impact`. The default
        "auto" treats several contacts closing together ("interior" for ccp, dissipative and
        coulomb, else "clarabel"); the single-contact methods ("closed-form", "fast",
        "sweep") refuse them.
    integrator : str or OdeSolver subclass
        "DOP853" (default), "RK45", "RK23", "Radau", "BDF", "LSODA", or a scipy OdeSolver.
    rtol, atol, max_step, first_step : integrator controls (as in ``solve_ivp``), real
        numbers: rtol > 0, atol >= 1e-100, span / max_step <= 5e6 (``max_step=inf``: no bound;
        a finer bound would never end), first_step within the span and above t's round-off
        (:func:`convimpact.validation.integration_controls`).
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
        constraints (True) or raise :class:`~convimpact.errors.LoopConstraintError` (False).
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
        Separation speed at or below which a contact is at rest (closed) after an impact or
        when touching, and slip speed at or below which a closed contact counts as not
        sliding (the stick test decides its mode).
    max_impacts : int
        The run stops (status 1) after this many impacts.
    painleve : {"stop", "raise"}
        Painleve's paradox (the contact force problem of a sliding contact has no solution or
        several): stop the run with status 2, the event in ``result.painleve`` and a warning
        ("stop"), or raise :class:`~convimpact.errors.PainleveError` carrying that
        result as ``.result`` ("raise"). The event-driven scheme never continues past it.
    impacts : {"simultaneous", "sequential"}
        How an impact meets contacts that are closed or touching at rest (a chain of touching
        bodies struck at one end, Newton's cradle): "simultaneous" resolves the approaching
        contacts in one call of the law with the others as unilateral constraints (released
        if the impact pulls on them) -- three touching balls struck by a fourth end with
        ((1 - 2e)/3, (1 + e)/3, (1 + e)/3) v for the struck three; "sequential" resolves the
        approaching contacts alone, then the contacts that approach afterwards, one impact
        after another at the same instant -- the cradle's (0, 0, v) for e = 1. Real chains lie
        between (their contacts are compliant); Moreau-Jean time stepping resolves them
        simultaneously.
    impact_options : mapping, optional
        Options forwarded to the impact solver, and the law's parameters beyond each
        contact's e and mu: ``"e_t"``, the tangential restitution in [-1, 1] of law
        ``"chatterjee-ruina"`` (one value, or a mapping contact name -> value; default 0),
        refused with any other law before the run starts.
    sensitivities : bool
        Also compute the trajectory's derivatives (:mod:`convimpact.simulation.sensitivity`):
        ``result.state_transition`` = dx(t_final)/dx(t0) with x = (theta, theta_dot),
        ``result.parameter_sensitivity`` = {"e": ..., "mu": ...} (2k x n_contacts, per
        contact), every event's saltation matrix (``.saltation`` on the impact and contact
        records, ``result.event_sensitivities`` for every instant, stick/slip transitions
        included). The variational equations are integrated over each event-free interval
        along the run's dense output with the same integrator and tolerances; the impact
        law's part of each reset is its analytic derivative (``resolve_impact(...,
        derivatives=True)``), the smooth model functions (M, Jc, the right-hand side) are
        differenced to ~1e-9 relative. Derivatives are one-sided where the trajectory
        grazes a contact or an event coincides with another.
    breakpoints : sequence of float, optional
        Sorted times within ``t_span`` where the applied forces have a kink or a jump (a
        push switched on, a ramp's corner): the integration stops there and restarts with
        a step of its own choosing, instead of shrinking its steps onto the kink (the box
        stack's push from ``t_push`` on: 24 steps and 556 right-hand sides without its
        breakpoint, 13 and 249 with it). No event, no change of state; the span's ends are
        ignored.

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
    * Closed (held) contacts carry Coulomb friction: "stick" contacts are bilateral in all
      their rows (their multipliers are the normal and friction forces), "slip" contacts in
      the normal row with the friction force -mu lambda_n s along the slip direction s. The
      modes come from the contact force problem at each event; the result has the timeline
      (``mode_intervals``) and the forces per sample (``contact_force``). Impacts of other
      contacts treat the held ones as frictionless bilateral normal constraints (rows of C);
      one that would receive a tensile impulse is released and the impact redone.
    * Loop drift: C theta_dot = 0 holds to round-off by construction (theta_dot is solved from
      eqs. 7 + 13); max |Psi| is kept below ``projection_tol`` at every stored state by
      projection. Both are reported per sample and as maxima.
    * The run never stalls: accumulations are detected (module ``zeno``), impacts are capped by
      ``max_impacts``, and more than 50 events at one instant raise ``SimulationError``.

    Raises
    ------
    ShapeError, NonFiniteError, ParameterError, UnknownOptionError
        for malformed input, checked before the run and naming the argument (NaN in the
        state, a complex or string entry, non-increasing t_span, a string or a boolean where a
        number is expected, a count that is not an integer, unknown names, ``e_t`` with a law
        that has none or outside [-1, 1]);
    LoopConstraintError
        for an initial state that violates the loops when ``assemble=False``;
    NotSupportedError
        from an impact the law does not define (``"chatterjee-ruina"`` at contacts closing
        together that are dynamically coupled), with a note naming the instant;
    AssemblyError
        when ``assemble=True`` and the loops cannot be assembled;
    PenetrationError
        when the initial state penetrates a contact by more than ``contact_tol``;
    SimulationError
        when the right-hand side becomes non-finite or events chatter at one instant;
    PainleveError
        at Painleve's paradox with ``painleve="raise"``.
    """
    wall0 = _time.perf_counter()
    mech, scene = _as_mechanism(system)
    k = int(mech.n_coordinates)

    # ---- options (convimpact.validation: real numbers, ranges, counts, names) --------------
    check_law_method(law, method)
    solver_options, e_t = law_options(law, impact_options, tuple(mech.contact_names))
    zeno = choice("zeno policy", zeno, ZENO_POLICIES)
    impacts = choice("impacts policy", impacts, IMPACT_POLICIES)
    painleve = choice("painleve policy", painleve, PAINLEVE_POLICIES)
    solver_cls = integrator_class(integrator)
    event_tol, contact_tol, projection_tol = (
        positive(name, value) for name, value in (
            ("event_tol", event_tol), ("contact_tol", contact_tol),
            ("projection_tol", projection_tol)))
    rest_velocity = nonnegative("rest_velocity", rest_velocity)
    max_impacts = integer("max_impacts", max_impacts, minimum=0)
    dense_output = boolean("dense_output", dense_output)
    sensitivities = boolean("sensitivities", sensitivities)
    assemble = boolean("assemble", assemble)
    zeno_time_tol = None if zeno_time_tol is None else positive("zeno_time_tol", zeno_time_tol)

    t0, t1 = time_span(t_span, scene)
    controls = integration_controls(t0, t1, rtol=rtol, atol=atol, max_step=max_step,
                                    first_step=first_step)
    rtol, atol, max_step = controls["rtol"], controls["atol"], controls["max_step"]
    first_step = controls["first_step"]
    if t_eval is not None:
        t_eval = sorted_times("t_eval", t_eval, t0, t1)
    breaks = tuple(float(b) for b in sorted_times("breakpoints", breakpoints, t0, t1)
                   if t0 < b < t1)
    zeno_tol = 1e6 * event_tol if zeno_time_tol is None else zeno_time_tol
    # one-step methods continue from a projected state; multistep ones must restart, so
    # they are projected only beyond a looser threshold
    in_place = issubclass(solver_cls, ONE_STEP)
    options = EventDrivenOptions(
        t0=t0, t1=t1, t_eval=t_eval, dense_output=dense_output, law=law, method=method,
        impact_options=solver_options, solver_cls=solver_cls, rtol=rtol, atol=atol,
        max_step=max_step, first_step=first_step, event_tol=event_tol, contact_tol=contact_tol,
        projection_tol=projection_tol, in_place=in_place,
        drift_threshold=projection_tol if in_place else max(projection_tol, 1e3 * atol),
        zeno=zeno, zeno_time_tol=zeno_tol, rest_velocity=rest_velocity, max_impacts=max_impacts,
        painleve=painleve, impacts=impacts, tangential_restitution=e_t,
        sensitivities=sensitivities, breakpoints=breaks)

    # ---- initial state ---------------------------------------------------------------------
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
        p = CanonicalEquations(mech).momentum(theta, dtheta)  # sigma0 = 0

    # ---- run -------------------------------------------------------------------------------
    return EventDrivenRun(mech, options, np.concatenate([theta, p]), started=wall0).run()
