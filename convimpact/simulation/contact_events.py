"""What happens at an event instant of the event-driven run: impacts (simultaneous or
sequential), then the modes of the closed contacts selected by the contact force problem.

:class:`ContactEvents` is the part of :class:`~.event_driven.EventDrivenRun` that handles one
instant; it uses the run's state (``eq``, ``opts``, ``mech``, the event lists).
"""

from __future__ import annotations

import time as _time
from dataclasses import replace
from typing import Any, Collection, Mapping, Sequence

import numpy as np

from ..impact import resolve_impact
from ..errors import ConvImpactError, NotSupportedError, PainleveError, SimulationError
from ..impact.results import ImpactResult
from .canonical import CanonicalEquations, HeldMode
from .force_solver import solve_contact_forces
from .result import ContactEvent, ImpactEvent
from .run_record import painleve_event, project_onto
from .sustained import contact_state, held_modes, redundant_rows

#: events (or impacts) at one instant beyond which the run is declared chattering
MAX_EVENTS_AT_ONE_INSTANT = 50
#: segments a sliding contact's friction direction is frozen for, from its onset, before
#: its friction follows the slip velocity: each ends when the slip turns away from the
#: frozen direction (:meth:`ContactEvents.freeze_directions`)
FREEZES = 2


class ContactEvents:
    """Impacts and contact modes at one instant (a part of the event-driven run)."""

    # ---- modes of the closed contacts ------------------------------------------------------
    def select_modes(self, t: float, th: np.ndarray, dth: np.ndarray, sig_loops: np.ndarray,
                     candidates: Sequence[str], reason: str) -> np.ndarray:
        """Close ``candidates`` (held and touching at rest) in the modes that the contact
        force problem selects; returns the new ``[theta, p]``."""
        o = self.opts
        candidates = tuple(dict.fromkeys(candidates))
        before = tuple(self.held)  # (ordered: an instant's release events in this order)
        M = np.asarray(self.mech.mass_matrix(th), float)
        T0 = float(self.mech.kinetic_energy(th, dth))
        held, modes, dropped, dims = (), {}, frozenset(), {}
        if candidates:
            # plastic frictionless correction of the (tiny, <= rest_velocity) normal speeds
            normals = CanonicalEquations(self.mech, candidates)
            self.track_projection(normals.jacobian, th, dth)
            dth = project_onto(M, normals.jacobian(th), dth)
            cs = contact_state(self.mech, t, th, dth, candidates, o.rest_velocity)
            hint = self.margin_hint  # the ended segment's margin program, if any
            warm = hint.get("warm") if hint.get("eq") is self.eq else None
            if warm is not None and warm.get("active") is not None:
                warm = {**warm, "earlier": list(warm.get("earlier", ()))}
            else:
                warm = None
            try:
                sol = solve_contact_forces(cs.problem, warm=warm)
            except PainleveError as exc:
                involved = [candidates[i] for i in getattr(exc, "contacts", ())]
                text = str(exc) + (f" (contacts involved: {', '.join(involved)})"
                                   if involved else "")
                ev = painleve_event(t, candidates, cs.problem.effective_normal_mass(),
                                    exc.kind, exc.n_solutions)
                self.painleve.append(ev)
                self.status, self.message = 2, text
                if o.painleve == "raise":
                    self.painleve_error = PainleveError(text, event=ev)
                return self.pack(th, dth, sig_loops)
            for note in sol.notes:
                names = [c for c, m in zip(candidates, sol.modes) if m != "open"]
                key = f"{note} ({', '.join(names)})"
                t0, count = self.force_notes.get(key, (t, 0))
                self.force_notes[key] = (t0, count + 1)
            moving = np.any(cs.problem.slip != 0.0, axis=1)
            onsets = {c for c, m in zip(candidates, moving) if not m}
            modes = self.freeze_directions(held_modes(cs, sol.modes, sol.direction), cs,
                                           onsets, dth)
            held = tuple(c for c in candidates if c in modes)
            loops = (np.asarray(self.mech.loop_jacobian(th), float).reshape(-1, self.k)
                     if self.m else None)
            probe = CanonicalEquations(self.mech, held, modes, dims=cs.dims)
            dropped = redundant_rows(M, loops, probe.rows, cs.jacobians)
            dims = cs.dims
        self.eq = CanonicalEquations(self.mech, held, modes, dropped, dims,
                                     slip_floor=o.rest_velocity)
        self.eq_log.append((t, self.eq))
        self.margin_hint = {"eq": self.eq}
        if held and dropped:  # the force problem's distribution stands in for the first
            d = max(dims[c] for c in held)  # margins (:func:`~.sustained.held_forces`)
            lam = np.zeros(len(held) * d)
            for i, c in enumerate(held):
                f = sol.force[candidates.index(c)]
                lam[i * d:i * d + dims[c]] = f[:dims[c]]
            self.margin_hint["lam"] = lam
            chosen = None if warm is None else warm.get("chosen")
            if (chosen is not None and chosen.get("active") is not None
                    and chosen["lam"].size == len(candidates) * d):
                # its program's active set starts the margins' warm starts (the same
                # cones, the held contacts' in order; its maximizer without the open ones)
                at = [candidates.index(c) for c in held]
                self.margin_hint["warm"] = {
                    "active": chosen["active"], "tau": chosen["tau"],
                    "lam": chosen["lam"].reshape(len(candidates), d)[at].ravel()}
        self.track_projection(self.eq.jacobian, th, dth)
        dth = project_onto(M, self.eq.jacobian(th), dth)
        if self.eq.redundant:  # a sliding redundant group starts from sol's forces
            self.eq.start_from(t, self.pack(th, dth, sig_loops),
                               {c: sol.force[i] for i, c in enumerate(candidates) if c in held})
        dT = float(self.mech.kinetic_energy(th, dth)) - T0
        for c in held:
            if c not in before:
                why, limit = self.closing_info.get(c, (reason, None))
                self.contact_events.append(ContactEvent(t, c, "persist", why, limit, dT))
        self.closing_info = {}
        for c in before:
            if c not in held:
                self.contact_events.append(ContactEvent(
                    t, c, "release", "its normal force would turn tensile (the contact force "
                    "problem opens it)"))
                self.detector.forget(c)
        self.modes.update(t, {c: modes[c].kind if c in modes else "open" for c in self.contacts})
        return self.pack(th, dth, sig_loops)

    def freeze_directions(self, modes: dict[str, HeldMode], cs, onsets: Collection[str],
                          dth: np.ndarray) -> dict[str, HeldMode]:
        """The spatial sliding contacts' friction directions frozen for the segment
        (:class:`~.canonical.HeldMode`'s ``frozen``) where a slow slip would make a followed
        direction stiff: a slip starting here (``onsets``: no slip velocity yet, the force
        problem's direction), a slip frozen in the segment just ended (still along it), and
        once more a slip that turned away from its frozen direction (the event ``turn:<c>``
        of :meth:`~.event_watch.EventWatch.watch`; :attr:`turns` counts them), refrozen along
        its velocity: an onset's direction is read off an acceleration that vanishes at the
        instant (to ~1e-8 rad where symmetry does not fix it). Any other slip (sliding since
        the run's start, or turned :data:`FREEZES` times) follows its velocity, as in a run
        with sensitivities (their variational equations differentiate the direction), and so
        does a slip whose velocity already leaves the direction here (its event function
        :meth:`~.event_watch.EventWatch._turn_functions` not positive at theta_dot ``dth``:
        it would never cross zero in the segment). ``cs`` the instant's
        :class:`~.sustained.ContactState`.

        While the slip keeps its direction the frozen force is Coulomb's (to
        :data:`~.event_watch.SLIP_TURN_TOL`); what it saves is the stiffness of a followed
        direction at a slip onset: a perturbation across the slip relaxes at a rate
        ~ mu g / |v_t|, which an explicit integrator resolves with steps ~ |v_t| / (mu g)
        (the box stack's top box: 185 of the run's 211 steps in the 27 ms after its onset).
        """
        self.turns = {c: n for c, n in self.turns.items()
                      if c in modes and modes[c].kind == "slip"}
        if self.opts.sensitivities:
            return modes
        was = self.eq.modes

        def freeze(c: str, md: HeldMode) -> HeldMode:
            if md.kind != "slip" or md.mu <= 0.0 or cs.dims.get(c, 0) <= 2:
                return md
            turns = self.turns.get(c, 0)
            if turns >= FREEZES or not (c in onsets or turns > 0
                                        or (c in was and was[c].frozen)):
                return md
            vt = cs.jacobians[c][1:] @ dth
            speed = float(np.sqrt(vt @ vt))
            if turns > 0 and speed > 0.0:  # refrozen along the slip velocity itself
                md = replace(md, direction=tuple(float(x) for x in vt / speed))
            S = np.asarray(md.direction, float)[None, :]
            turn = self._turn_functions(vt[None, :], S, S @ vt, dth)[0]
            return replace(md, frozen=True) if turn > 0.0 else md
        return {c: freeze(c, md) for c, md in modes.items()}

    # ---- impacts ---------------------------------------------------------------------------
    def solve_impact(self, t: float, th: np.ndarray, dth: np.ndarray, M: np.ndarray,
                     closing: Sequence[str], params: Mapping[str, Any], C: np.ndarray,
                     plastic: Collection[str] = ()) -> tuple[ImpactResult, list, float]:
        """One call of ``resolve_impact`` for ``closing`` with the constraint rows ``C``
        (loops and held normals; e = 0 for the ``plastic`` contacts); returns the result,
        the contact Jacobians and the wall time spent."""
        Jc = [self.contact_row(c, th) for c in closing]
        es = [0.0 if c in plastic else float(params[c][0]) for c in closing]
        mus = [float(params[c][1]) for c in closing]
        o = self.opts
        t_start = _time.perf_counter()
        J, e, mu = (Jc[0], es[0], mus[0]) if len(closing) == 1 else (Jc, es, mus)
        law_params = {}
        if o.tangential_restitution is not None:  # e_t per contact (law chatterjee-ruina)
            ets = [o.tangential_restitution[c] for c in closing]
            law_params["e_t"] = ets[0] if len(closing) == 1 else ets
        if o.sensitivities:  # the law's analytic jacobian, for the saltation matrix
            # the velocities' derivative (redundant contacts: exact for dq_plus, the
            # impulse's being the minimum-norm choice)
            law_params["derivatives"] = "velocity"
        try:
            r = resolve_impact(M, J, dth, e, mu, C if len(C) else None,
                               law=o.law, method=o.method, **law_params, **o.impact_options)
        except ConvImpactError as exc:
            exc.add_note(f"(while resolving the impact of {', '.join(closing)} at "
                         f"t = {t:.9g} in convimpact.simulation.simulate)")
            if o.sensitivities and isinstance(exc, NotSupportedError):
                exc.add_note("(sensitivities=True differentiates every impact with "
                             "resolve_impact(..., derivatives=True); the run without "
                             "sensitivities does not need the law's derivative)")
            raise
        finally:
            spent = _time.perf_counter() - t_start
            self.impact_time += spent
        return r, Jc, spent

    def impact(self, t: float, th: np.ndarray, dth: np.ndarray, closing: Sequence[str],
               constraints: Sequence[str]) -> tuple[np.ndarray, list[str], list[str], str | None]:
        """Resolve the closing contacts together, the ``constraints`` (closed contacts)
        acting as frictionless bilateral normal constraints, released when the impact pulls
        on them (and the impact redone).

        Returns (theta_dot+, the constraints still closed, the closing contacts that stay
        closed (v_n+ ~ 0 or accumulating), stop_message).
        """
        m, o = self.m, self.opts
        M = np.asarray(self.mech.mass_matrix(th), float)
        params = {c: self.mech.contact_parameters(c) for c in closing}
        held_now = list(constraints)
        released: list[str] = []
        spent = 0.0
        loops = (np.asarray(self.mech.loop_jacobian(th), float).reshape(-1, self.k)
                 if self.m else None)
        while True:
            normals = CanonicalEquations(self.mech, held_now)
            dropped = redundant_rows(M, loops, normals.rows, normals.contact_jacobians(th))
            normals = CanonicalEquations(self.mech, held_now, dropped=dropped)
            C = normals.jacobian(th)
            r, Jc, dt = self.solve_impact(t, th, dth, M, closing, params, C)
            spent += dt
            dsig_h = np.asarray(r.loop_impulse, float)[m:]
            scale = max(float(np.max(np.abs(r.impulse))), 1e-300)
            tens = [normals.rows[i][0] for i, v in enumerate(dsig_h) if v < -1e-9 * scale]
            if not tens:
                break
            released.extend(tens)  # a held contact is pulled: it separates, redo the impact
            held_now = [c for c in held_now if c not in tens]
        speeds = {c: float(Jc[i][0] @ r.dq_plus) for i, c in enumerate(closing)}
        persist, limits, reasons, zeno_hit = self.detector.judge_impact(t, speeds)
        stop_msg = None
        if zeno_hit and o.zeno == "stop":
            stop_msg = "accumulating impacts detected (zeno='stop'): " + "; ".join(reasons)
            persist = []
        elif persist and any(float(params[c][0]) > 0.0 for c in persist):
            r, Jc, dt = self.solve_impact(t, th, dth, M, closing, params, C, set(persist))
            spent += dt
        self.track_impact(r, th, dth, closing, normals.jacobian if len(C) else None,
                          persist if zeno_hit or persist else ())
        dq_plus = np.asarray(r.dq_plus, float)
        at_rest = [c for i, c in enumerate(closing)
                   if c in persist or abs(float(Jc[i][0] @ dq_plus)) <= o.rest_velocity]
        for c in at_rest:
            self.closing_info[c] = (("; ".join(reasons) if c in persist else
                                     "v_n+ ~ 0 after the impact (|v_n+| <= rest_velocity)"),
                                    limits.get(c))
        impulse = np.asarray(r.impulse, float).reshape(len(closing), -1)
        regime = (r.regime,) if isinstance(r.regime, str) else tuple(r.regime)
        self.impacts.append(ImpactEvent(
            time=t, contacts=tuple(closing), held_contacts=tuple(held_now), regime=regime,
            impulse=impulse, loop_impulse=np.asarray(r.loop_impulse, float),
            generalized_impulse=np.vstack(Jc).T @ impulse.ravel(),  # Delta p = Jc^T pi (33)
            theta=th.copy(), dtheta_minus=dth.copy(), dtheta_plus=dq_plus.copy(),
            energy_loss=float(r.energy_loss),
            kinetic_energy_minus=float(self.mech.kinetic_energy(th, dth)),
            kinetic_energy_plus=float(self.mech.kinetic_energy(th, dq_plus)),
            persistent=tuple(at_rest), released=tuple(released), resolve_time=spent, result=r))
        return dq_plus, held_now, at_rest, stop_msg

    # ---- events ----------------------------------------------------------------------------
    def handle(self, t: float, y: np.ndarray, closing: Sequence[str],
               touching: Sequence[str]) -> tuple[np.ndarray, str | None]:
        """All events at instant t: impacts, then the modes of the closed contacts.

        ``impacts="simultaneous"``: the approaching contacts are resolved in one impact with
        the closed and touching-at-rest ones as (unilateral) constraints. ``"sequential"``:
        the approaching contacts alone, the others free; contacts that approach afterwards
        are resolved next, at the same instant, until none approaches.
        """
        o = self.opts
        th, dth, sig = self.state(y)
        sig_loops = sig[:self.m]
        near = [c for c in self.contacts if c not in self.held and (
            c in closing or c in touching or self.gap(c, th) <= o.contact_tol)]
        held = list(self.held)
        stop_msg = None
        reason = "touching at rest (|v_n| <= rest_velocity)"
        closed: list[str] = []
        for _ in range(MAX_EVENTS_AT_ONE_INSTANT):
            watched = near + (held if o.impacts == "sequential" else [])
            jac = self._jacobians(th)  # (one compiled pass for all)
            vn = {c: float(jac(c)[0] @ dth) for c in watched}
            group = [c for c in watched if vn[c] < -o.rest_velocity]
            if not group:
                break
            if len(self.impacts) >= o.max_impacts:
                stop_msg = (f"max_impacts = {o.max_impacts} reached at t = {t:.9g} "
                            f"({', '.join(group)} not resolved); raise it or check for "
                            "accumulating impacts")
                break
            if o.impacts == "simultaneous":
                rest = [c for c in near if c not in group and abs(vn[c]) <= o.rest_velocity]
                dth, kept, at_rest, stop_msg = self.impact(t, th, dth, group, held + rest)
                held = [c for c in held if c in kept]
                closed += [c for c in rest if c in kept] + at_rest
            else:
                dth, _, at_rest, stop_msg = self.impact(t, th, dth, group, [])
                closed += at_rest
            reason = "closed at rest by an impact (v_n+ ~ 0, or accumulating impacts)"
            if stop_msg:
                break
        else:
            raise SimulationError(
                f"{MAX_EVENTS_AT_ONE_INSTANT} impacts at t = {t:.9g} without the contacts "
                f"{', '.join(near + held)} coming to rest (impacts='{o.impacts}')")
        jac = self._jacobians(th)  # (one compiled pass for all)
        candidates = [c for c in dict.fromkeys(held + near + closed)
                      if abs(float(jac(c)[0] @ dth)) <= o.rest_velocity]
        y = self.select_modes(t, th, dth, sig_loops, candidates, reason)
        return self.project_state(y), stop_msg
