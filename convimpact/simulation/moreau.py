"""Moreau–Jean time stepping: a velocity-level impact law on every step (an alternative to
the event-driven :func:`convimpact.simulation.simulate`).

The scheme (Moreau's midpoint rule generalized by a parameter theta, as in Jean's NSCD and
Acary & Brogliato's "Numerical methods for nonsmooth dynamical systems", ch. 10), per step
of size h from (q_k, v_k) at t_k:

1. intermediate configuration ``q_m = q_k + h (1 - theta) v_k`` at ``t_m = t_k + (1 - theta) h``;
2. smooth forces at the intermediate instant, explicitly: ``M = M(q_m)``,
   ``f = f(t_m, q_m, v_m)`` with the predicted velocity
   ``v_m = v_k + (1 - theta) h M^-1 f(t_m, q_m, v_k)`` (two force evaluations per step for
   theta < 1, one for theta = 1);
3. free-flight velocity: ``v_free = v_k + h M^-1 f``, M-orthogonally projected onto
   ``C(q_m) v = 0`` for closed loops (the loop impulse of the step);
4. active set by gap prediction: a contact takes part when its gap predicted at the end of the
   step with the free velocity closes, ``g(q_m) + h theta c_n(q_m)^T v_free <= gap_tol``
   up to the positions' round-off (``1e-12 max(1, max |q_m|)``: a resting contact's
   predicted gap is 0 up to that, which must not switch it off);
5. the contact impulse of the active contacts comes from :func:`convimpact.resolve_impact`
   with the step's matrices (its Delassus ``W = Jc G Jc^T`` with G the loop-constrained inverse
   of ``M(q_m)``, so ``C v_{k+1} = 0`` holds), the chosen ``law`` and ``method``, applied to the
   free velocity. Newton's restitution acts on the contact velocity at the *start* of the step
   (``v_n+ = -e v_n,k``, standard Moreau–Jean): it is passed as the per-contact coefficient
   ``e_eff = min(e v_n,k / v_n,free, 1)`` on contacts approaching at t_k
   (``v_n,k < -rest_velocity``) and ``e_eff = 0`` on contacts already at rest (so resting
   contacts do not micro-bounce). A law's tangential restitution (``e_t`` of
   ``"chatterjee-ruina"``, from ``impact_options``) acts likewise on the approaching contacts
   only, ``e_t = 0`` on those at rest (a resting contact's slip is not reversed every step);
   it restitutes the slip of the free velocity, which is the slip at t_k when no smooth
   force acts along the contact's tangent during the step (a ball on a level floor);
   the other laws resolve each independent island of contacts by its own call of
   :func:`convimpact.resolve_impact` (:mod:`.moreau_impact`; law "pereira-nikravesh"
   answers resting islands by a certificate of the law's own answer, its diagnostic of
   several admissible active sets kept as one warning of the run, see there).
   **Laws "ccp", "coulomb" and "dissipative" under method "auto" or "interior"** take the
   contact engine instead (:mod:`.moreau_engine`; "dissipative" as ccp's plastic problem,
   the impulse scaled by ``1 + e_eff``): the step's problem ``u = J v_{k+1} = W r + b``,
   ``W = J G J^T``, built in the block structure of M (batched factorizations of the
   coordinate groups), split into independent islands (:mod:`.islands`), warm-started from
   the previous step's impulses, solved by the engine's compiled kernels in one call for
   the small islands and by :func:`convimpact.contacts.engine.solve` for the large
   ones, each island certified by its natural-map residual (``impact_options["tol"]``,
   default 1e-8) or
   :class:`~convimpact.contacts.contact_problem.UncertifiedSolutionError` naming the
   step and the contacts;
6. ``q_{k+1} = q_m + h theta v_{k+1}``; for closed loops theta is projected back onto
   ``Psi = 0`` (M-weighted, when the drift exceeds ``projection_tol``) and ``v_{k+1}`` onto
   ``C(q_{k+1}) v = 0``.

Every law runs through one step loop (:mod:`.moreau_loop`): a predictor (steps 1-4; one
compiled call per step on the models of :mod:`convimpact.model` without loops or applied
forces) and a per-step solver (step 5: :class:`.moreau_engine.EngineSolver` or
:class:`.moreau_impact.ImpactSolver`); the loop stores the raw states and computes momenta,
energies, loop drifts and penetrations from them once, at the end of the run.

Known artefacts (measured by the bench section ``simulation`` and the failure atlas):

* impact instants are not located: an impact acts at the step's midpoint (error up to h in
  time, O(h) in the post-impact state: gravity and the driving forces act over the whole
  step in which the impact happens);
* an impact whose contact velocity changes over several steps (multiple contacts, a rod
  landing on both ends, loops transmitting the impulse) is *smeared* over those steps; the
  per-step law then differs from the event-driven law applied once;
* positions can penetrate by O(h |v|) (the gap is predicted, not enforced; with theta < 1 the
  first part of the step uses the pre-impact velocity); the maximum is reported as
  ``max_penetration``;
* the smooth part is explicit in the forces (stable for h below the stiffest smooth time
  constant, e.g. the slider-crank's speed regulator). theta = 1/2 is second order in free
  flight (energy error O(h^2); exact at the grid points under a constant force); any other
  theta is first order, energy error O(h) (measured on a swinging double pendulum over 2 s:
  6e-4 for theta = 1/2 against 5e-2 for theta = 1 at h = 5 ms). Unlike the implicit
  theta-method of Jean's NSCD, theta > 1/2 does not make this explicit variant dissipative;
* restitution is Newton's at the velocity level on each step: a contact that stays active
  over several steps is treated as plastic after the first (e_eff = 0), which is the
  Moreau–Jean convention, not the event-driven one.
"""

from __future__ import annotations

import math
import time as _time
from dataclasses import dataclass, field
from typing import Any, Mapping, Sequence

import numpy as np

from .. import validation
from ..errors import ParameterError, UnknownOptionError
from ..impact import check_law_method
from .result import SimulationResult
from .initial import consistent_start, initial_state, law_options, positive, time_span
from .moreau_engine import ENGINE_LAWS, EngineSolver
from .moreau_impact import ImpactSolver
from .moreau_loop import run_steps
from .simulate import _as_mechanism

#: steps beyond which a run is refused (h too small for the span)
MAX_STEPS = 5_000_000


@dataclass(frozen=True, eq=False)
class MoreauResult(SimulationResult):
    """:class:`SimulationResult` of :func:`simulate_moreau`, with the scheme's own figures.

    ``impacts`` lists the steps on which a contact approaching at the start of the step
    received an impulse (time = the step's midpoint t_m, ``dtheta_minus`` = v_k,
    ``dtheta_plus`` = v_{k+1}); ``nfev`` counts smooth-force evaluations (one per step).

    Attributes
    ----------
    step_size : h.
    theta_parameter : theta of the scheme.
    n_contact_steps : steps with at least one active contact (impacts and resting contact).
    max_penetration : largest penetration (-gap) of any contact at a stored state (>= 0).
    contact_solver : engine path only, what the contact engine did over the run (islands
        solved, warm starts certified, calls of the full engine, iterations, the largest
        island, seconds in the solves and in the assembly); on the other path the calls of
        ``resolve_impact`` (one per island and step) and the largest island (contacts).
    max_active_contacts : the most contacts active on one step.
    """

    step_size: float = float("nan")
    theta_parameter: float = 0.5
    n_contact_steps: int = 0
    max_penetration: float = 0.0
    contact_solver: Mapping[str, Any] = field(default_factory=dict)
    max_active_contacts: int = 0

    def as_dict(self, series: bool = True) -> dict[str, Any]:
        out = super().as_dict(series)
        out.update(scheme="moreau-jean", step_size=self.step_size,
                   theta_parameter=self.theta_parameter, n_contact_steps=self.n_contact_steps,
                   max_penetration=self.max_penetration,
                   contact_solver=dict(self.contact_solver),
                   max_active_contacts=self.max_active_contacts)
        return out


#: impact options the engine path takes (with their types)
ENGINE_OPTIONS = {"tol": float, "max_iter": int, "newton_iter": int}


def _engine_options(options: Mapping[str, Any] | None) -> dict[str, Any]:
    """The engine path's options (tol 1e-8 by default), validated."""
    out: dict[str, Any] = {"tol": 1e-8}
    for key, value in dict(options or {}).items():
        if key not in ENGINE_OPTIONS:
            raise UnknownOptionError(
                f"impact option {key!r} is not taken by Moreau–Jean on the contact engine "
                f"(laws ccp, coulomb and dissipative under method auto or interior); its "
                f"options are "
                f"{', '.join(ENGINE_OPTIONS)}")
        if isinstance(value, bool) or not isinstance(value, (int, float, np.integer,
                                                             np.floating)):
            raise ParameterError(f"impact option {key} must be a number, got {value!r}")
        if ENGINE_OPTIONS[key] is int and (int(value) != value or value < 1):
            raise ParameterError(f"impact option {key} must be an integer >= 1, got {value!r}")
        if ENGINE_OPTIONS[key] is float and not (math.isfinite(value) and value > 0):
            raise ParameterError(f"impact option {key} must be a finite number > 0, got "
                                 f"{value!r}")
        out[key] = ENGINE_OPTIONS[key](value)
    return out


def simulate_moreau(
    system,
    t_span: Sequence[float] | None = None,
    y0=None,
    *,
    h: float,
    theta: float = 0.5,
    law: str = "coulomb",
    method: str = "auto",
    gap_tol: float = 0.0,
    rest_velocity: float = 1e-6,
    projection_tol: float = 1e-10,
    assemble: bool = False,
    contact_tol: float = 1e-8,
    impact_options: Mapping[str, Any] | None = None,
    warm_start: bool = True,
    islands: bool = True,
) -> MoreauResult:
    """Integrate a mechanism through its impacts by Moreau–Jean time stepping.

    Parameters
    ----------
    system : Mechanism or Scene
        The model, or a :class:`convimpact.scenes.Scene` (its mechanism, state and t_end).
    t_span : (t0, t1), optional
        Time span; default ``(0, scene.t_end)`` for a scene. The last step is shortened to
        end exactly at t1.
    y0 : tuple (theta0, dtheta0), optional
        Initial joint coordinates and velocities; default the scene's.
    h : float
        Step size (s), > 0.
    theta : float
        Parameter of the scheme in [0, 1] (see the module docstring); 1/2 is Moreau's
        midpoint rule.
    law, method : str
        Impact law and solver path of :func:`convimpact.resolve_impact` for the per-step
        impulse (default "coulomb", the complementarity law of Moreau–Jean). Several active
        contacts need a multi-contact method: "auto" (the default) picks "interior" for ccp,
        dissipative and coulomb, else "clarabel".
    gap_tol : float
        A contact is active when its predicted end-of-step gap is at most this.
    rest_velocity : float
        Contacts whose normal velocity at the start of the step is above ``-rest_velocity``
        are resolved plastically (e_eff = 0).
    projection_tol : float
        Loop drift max |Psi| above which positions are projected after a step.
    assemble : bool
        Project an initial state that violates the loops (True) or raise
        :class:`~convimpact.errors.LoopConstraintError` (False).
    contact_tol : float
        Penetration accepted in the initial state.
    impact_options : mapping, optional
        Options forwarded to the impact solver, and ``"e_t"``: the tangential restitution in
        [-1, 1] of law ``"chatterjee-ruina"`` (one value, or a mapping contact name -> value;
        default 0), applied to the approaching contacts of a step (0 on the resting ones) and
        refused with any other law before the first step. On the engine path (below) only
        ``tol`` (the natural-map residual every island's answer must reach, default 1e-8),
        ``max_iter`` and ``newton_iter`` are taken.
    warm_start, islands : bool
        ``warm_start``, engine path only (laws ``"ccp"``, ``"coulomb"`` and
        ``"dissipative"`` under ``method``
        "auto" or "interior", :mod:`.moreau_loop`): start each step's contact problem from the
        previous step's impulses; it does not change the answer beyond the certificate's
        tolerance. ``islands``, every law: solve the independent islands of touching bodies
        apart (:mod:`.islands`; on the other laws one ``resolve_impact`` call per island,
        :mod:`.moreau_impact`). The same answer as one coupled problem for every law but
        ``"pereira-nikravesh"``, whose stick-or-slide tier is then chosen per island rather
        than for the whole step (see :mod:`.moreau_impact`); False restores the single call
        and its cap of 8 contacts per step.

    Returns
    -------
    MoreauResult
        Series at every step (t_k), the impact steps, counters, ``max_penetration``.
        ``warnings`` (laws outside the engine): one entry when the law found several
        admissible active sets with different velocities on some island steps (law
        ``"pereira-nikravesh"``: Newton's law with friction is not unique at several
        contacts), with their count and first times. With that law, an island resting on
        every contact is searched on the first step of its resting mode and answered by a
        certificate of the same answer on the following ones (not searched again), and an
        island sliding on every contact is searched in full on the first step of its
        sliding mode and without the active sets that cannot be the law's answer on the
        following ones (its warning not re-checked), see :mod:`.moreau_impact`;
        ``contact_solver`` counts them (``certified``, ``searched``, ``pruned``,
        ``ambiguous``).

    Raises
    ------
    ShapeError, NonFiniteError, ParameterError, UnknownOptionError
        for malformed input (``e_t`` with a law that has none or outside [-1, 1] included);
    LoopConstraintError
        for an inconsistent initial state (``assemble=False``) or a singular loop matrix;
    PenetrationError
        when the initial state penetrates by more than ``contact_tol``;
    SimulationError
        when the state becomes non-finite;
    ConvImpactError subclasses of ``resolve_impact`` (SingularSystemError, SolverError, ...)
        and NotSupportedError (``"chatterjee-ruina"`` at dynamically coupled active contacts)
        from the per-step impulse, with a note naming the step.
    """
    wall0 = _time.perf_counter()
    mech, scene = _as_mechanism(system)
    k = int(mech.n_coordinates)
    contacts = tuple(mech.contact_names)
    check_law_method(law, method)
    h = validation.positive("h", h)  # a real number: "1e-3", True, 1j are refused
    theta_p = validation.in_range("theta", theta, 0.0, 1.0)  # 1/2: the midpoint rule
    positive(projection_tol=projection_tol, contact_tol=contact_tol)
    if not (np.isfinite(gap_tol) and rest_velocity >= 0):
        raise ParameterError("gap_tol must be finite and rest_velocity >= 0")
    t0, t1 = time_span(t_span, scene)
    n_steps_total = int(math.ceil((t1 - t0) / h - 1e-9))
    if n_steps_total > MAX_STEPS:
        raise ParameterError(f"h = {h:g} needs {n_steps_total} steps over the span (more than "
                             f"{MAX_STEPS}); take a larger step")
    impact_options, e_t = law_options(law, impact_options, contacts)
    engine_path = law in ENGINE_LAWS and method in ("auto", "interior")
    if engine_path:
        engine_opts = _engine_options(impact_options)

    # ---- initial state ---------------------------------------------------------------------
    q, v = initial_state(y0, scene, k)
    q, v = consistent_start(mech, q, v, assemble=assemble, projection_tol=projection_tol,
                            contact_tol=contact_tol)
    settings = {"scheme": "moreau-jean", "law": law, "method": method, "h": h,
                "theta": theta_p, "gap_tol": gap_tol, "rest_velocity": rest_velocity,
                "projection_tol": projection_tol, "t_span": [t0, t1]}
    for flag, value in (("warm_start", warm_start), ("islands", islands)):
        if not isinstance(value, (bool, np.bool_)):
            raise ParameterError(f"{flag} must be True or False, got {value!r}")
    if engine_path:
        solver = EngineSolver(mech, law=law, warm_start=bool(warm_start), islands=bool(islands),
                              rest_velocity=float(rest_velocity), **engine_opts)
        settings.update(contact_solver="engine", warm_start=bool(warm_start),
                        islands=bool(islands), **engine_opts)
    else:
        solver = ImpactSolver(mech, law=law, method=method, impact_options=impact_options,
                              e_t=e_t, rest_velocity=float(rest_velocity),
                              islands=bool(islands))
        settings["islands"] = bool(islands)
        if e_t is not None:
            settings["e_t"] = dict(e_t)

    # ---- run ---------------------------------------------------------------------------------
    out = run_steps(mech, q, v, solver, t0=t0, t1=t1, h=h, theta=theta_p,
                    n_steps=n_steps_total, gap_tol=float(gap_tol),
                    rest_velocity=float(rest_velocity), projection_tol=projection_tol)
    series, st = out["series"], out["stats"]
    n = series["t"].shape[0]
    return MoreauResult(
        **series, held=np.zeros(n, dtype=int), impacts=tuple(solver.impacts),
        contact_events=(), sol=None, status=0,
        message="the end of the time span was reached", nfev=st["nfev"], nevents_fev=0,
        n_steps=n - 1, n_projections=st["proj"], n_restarts=0,
        wall_time=float(_time.perf_counter() - wall0), impact_time=float(st["impact_time"]),
        settings=settings, step_size=h, theta_parameter=theta_p,
        n_contact_steps=st["contact_steps"], max_penetration=max(0.0, st["max_pen"]),
        contact_solver=(solver.counters.as_dict() if engine_path else
                        {"resolve_impact_calls": solver.calls,
                         "largest_island": solver.largest_island,
                         "certified": solver.certified,
                         "searched": solver.checks,
                         "pruned": solver.pruned,
                         "ambiguous": len(solver.ambiguous)}),
        max_active_contacts=st["max_active"],
        warnings=() if engine_path else solver.run_warnings())
