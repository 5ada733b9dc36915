"""The contact problem of a Moreau–Jean step through :func:`convimpact.resolve_impact`, island
by island: the step solver of every law and method outside the contact engine
(pereira-nikravesh, stronge, chatterjee-ruina; ccp, coulomb and dissipative under the other
methods), for :func:`.moreau_loop.run_steps`.

Per step with active contacts: Newton's restitution at the velocity level as the
per-contact coefficient ``e_eff = min(e v_n,k / v_n,free, 1)`` on contacts approaching at the
step's start (``v_n,k < -rest_velocity`` and ``v_n,free < 0``), 0 on the others; a law's
tangential restitution (``e_t`` of ``"chatterjee-ruina"``) on the approaching contacts only.

**Islands.** The active contacts split into independent islands
(:func:`.islands.contact_islands` over the step's coordinate groups, the connected components
of M's and the loops' coupling, as on the engine path): contacts share an island when they
move coordinates of one group, directly or through a chain of contacts. A loop couples every
coordinate of its rows, so an island touching a loop holds the loop's whole group and its
rows. Each island is one call of :func:`convimpact.resolve_impact` with M's block of the
island's coordinates (M is block diagonal over the groups, so the block is the island's mass
matrix, not an approximation), the island's contact rows restricted to those coordinates,
``v_free`` there and the loop rows inside the island; coordinates no active contact moves
keep ``v_free``. An island whose contacts all separate under ``v_free`` still goes to the law
when the law is a cone complementarity (``ccp`` and ``dissipative``, CCP's plastic program:
a sliding contact with ``0 <= v_n < mu |v_t|`` takes an impulse) and is skipped otherwise
(every other law leaves contacts that all open without impulse).

**Same answer as one call.** The Delassus matrix ``W = J M^-1 J^T`` is block diagonal over
the islands, and the impulse of one island changes no velocity of another:

* ``ccp``, ``coulomb``, ``dissipative``, ``chatterjee-ruina``: the coupled problem is the
  islands' problems side by side (per-contact complementarity, cone and
  maximal-dissipation conditions, and the sum of the islands' kinetic energies as the
  objective), so the islands' answers are the single call's (to the solvers' tolerance);
* ``stronge``: its compression, expansion and re-compression programs separate likewise;
  its energy cap (the expansion scaled by the largest ``kappa <= 1`` keeping ``T+ <= T-``,
  needed only with different e on coupled contacts) is then chosen per island instead of
  once for the whole step;
* ``pereira-nikravesh``: the law (:mod:`convimpact.impact.laws.pn_complementarity`) picks an
  active set by tiers, *sticking* on the most dissipative admissible set if one exists, else
  *sliding* on the most dissipative admissible one. Admissibility and dissipation separate
  over islands, so within a tier the choice is per island; the tier, however, is decided for
  the whole call: one island that cannot stick sends every island of a single call to the
  slide tier. Island by island, each independent group of bodies gets its own tier, which is
  what the law means for an impact of those bodies alone (a box elsewhere cannot decide
  whether this one sticks). It also lifts the law's cap of
  :data:`~convimpact.impact.laws.pn_complementarity.MAX_CONTACTS` contacts from the step to
  the island.

**Direct impulses** (law ``pereira-nikravesh``, methods ``auto`` and ``clarabel``): on a
step where no active contact approaches at the step's start (no impact to record), an island
of several contacts without loop rows takes the law's impulse directly
(:func:`~convimpact.impact.laws.pn_complementarity_impulse.several_contacts_impulse` on the
problem ``resolve_impact`` builds, with the same backend and options): the same impulse as the
full call, without the result record (regimes, diagnostics) nobody reads on such a step; where
that call would raise or report unsolved active sets the full call is made.

**Resting islands without the search** (same law and methods, once the law's compiled path
is taken): the law returns the most dissipative admissible active set and, to warn when
several admissible sets have different velocities, solves all 2^n - 1 of them on every call.
On such a step every island is first tried by one compiled call
(:func:`.moreau_pn_kernels.certify_islands`): where sticking on every contact is admissible
and is the least ``T+`` over *every* impulse (all contacts frictional, no restitution
acting, ``W pi + v- = 0`` to round-off), no other set can be more dissipative with other
velocities, so the law's selection rule picks that set (the largest) -- the same impulse, to
round-off (:mod:`.moreau_pn_kernels` gives the argument and its margins). The law's search
is then skipped, but the **ambiguity diagnostic is not dropped**: an island so certified is
searched in full (its answer and its warning taken from the law) on the first step of that
mode -- the first step the island, with the same active contacts, is certified -- and
answered by the certificate alone on the following steps of the mode; a change of the
island's contacts, a step the certificate does not hold (sliding, restitution, an impact
step through ``resolve_impact``) or a step without active contacts ends the mode. Every
search's warning on several admissible active sets with different velocities (direct steps
and ``resolve_impact`` calls alike) is counted, and the run carries one warning with the
count, the number of island steps searched and the first step times
(``MoreauResult.warnings``; the counts are in ``contact_solver``: ``certified`` island steps
answered by the certificate alone, ``searched`` island steps of several contacts the law
searched, ``ambiguous`` those that found several admissible sets). What is not checked:
steps inside a certified resting mode (the same contacts sticking on every contact, step
after step), whose admissible sets are not enumerated again.

**Sliding islands** (the same direct steps): the law's search runs in one compiled call
(:mod:`~convimpact.impact.laws.pn_complementarity_search`), its slide programs warm-started
from the island's previous step. Where the law's answer slid on every contact of the island
(a *sliding mode*: a box sliding on its four corners), the next step with the same contacts
first runs the search without the *dominated* active sets -- those whose admissible answers
keep every contact at ``u_n = 0`` (any three corners of a box, a diagonal pair), so they
are feasible for the full set's program and can be no more dissipative than its minimizer,
and can only tie with it, which the full set wins as the largest (the argument and its
round-off caveat: that module's docstring). The answer is the law's (the test compares the
trajectories with the law's own search on every step); the ambiguity warning is taken on
the mode's first step (searched in full) and not re-checked inside the mode, as for resting
modes. The resting certificate is not tried on a step where every island it would try
is in a sliding mode (it cannot hold while the island slips; the step the island stops,
the pruned search finds an admissible stick set and hands the step to the law's own
search, which ends the mode). The counts: ``pruned`` island steps answered so.

**One call per step** (:mod:`.moreau_pn_islands`, same law and methods, no loops): on a
direct step, every island inside a resting or a sliding mode is first answered by one
compiled call for the whole step -- the same certificate and the same pruned search, from
the same warm starts -- and the step returns without Python per island when it answers them
all; the islands it leaves (a mode's first step, an impact, an island the certificate or the
pruned search declines) take the path above, with the answered ones kept.

An :class:`~.result.ImpactEvent` is recorded on the steps where an approaching contact
receives a normal impulse: the step's active contacts' impulses, regimes (in the order of
the active contacts) and the sum of the islands' energy losses; its ``result`` is the
island's :class:`~convimpact.impact.results.ImpactResult` when one island took the impact,
None when several did (``island_results`` of the solver keeps none: the per-island results
are in the events' impulses and regimes).
"""

from __future__ import annotations

from typing import Any, Mapping

import numpy as np

from ..compiled import announce
from ..impact import resolve_impact
from ..impact.conic.paths import backend as conic_backend
from ..impact.conic.paths import parse_options
from ..errors import ConvImpactError
from ..impact.laws import pn_complementarity as pn
from ..impact.laws.pn_complementarity import MAX_CONTACTS
from ..impact.laws.pn_complementarity_impulse import several_contacts_impulse
from ..impact.laws.pn_complementarity_search import SlideWarmStart
from ..impact.problem.build import IMMOBILE_RTOL, TINY_NORMAL, build_problem
from .islands import contact_islands
from .moreau_pn_islands import PnIslands, flat_layout
from .moreau_pn_kernels import STICK, certify_islands
from .moreau_stronge import StrongeIslands
from .result import ImpactEvent

#: laws whose answer at contacts that all separate under v_free may still be an impulse
CONE_COMPLEMENTARITY_LAWS = frozenset({"ccp", "dissipative"})
#: the law whose several-contact islands take the law's impulse directly on steps without
#: an impact (see ImpactSolver), and the methods whose path that impulse is
DIRECT_LAW = "pereira-nikravesh"
DIRECT_METHODS = ("auto", "clarabel")
#: the text of the law's warning on several admissible active sets (counted over a run)
AMBIGUITY_NOTE = "admissible active sets here"
#: step times quoted in the run's ambiguity warning
QUOTED_TIMES = 5
#: first compilation of the certificate's kernel on 2 cores (s), announced on stderr
CERTIFICATE_COMPILE_SECONDS = 20


class ImpactSolver:
    """Step solver through :func:`convimpact.resolve_impact`, one call per island (see the
    module docstring). ``islands=False`` makes one call with every active contact."""

    def __init__(self, mech, *, law: str, method: str, impact_options: Mapping[str, Any],
                 e_t: Mapping[str, float] | None, rest_velocity: float,
                 islands: bool = True):
        self.contacts = tuple(mech.contact_names)
        params = [mech.contact_parameters(c) for c in self.contacts]
        self.e = np.array([float(p[0]) for p in params])
        self.mu = np.array([float(p[1]) for p in params])
        self.m = int(mech.n_loop_constraints)
        self.law, self.method = law, method
        self.options = dict(impact_options)
        self.e_t = e_t
        self.rest_velocity = rest_velocity
        self.split = bool(islands)
        self.impacts: list[ImpactEvent] = []
        #: the last step's contact-frame impulses of the active contacts, (n_active, d)
        self.impulse = np.zeros((0, 0))
        self.calls = 0           # resolve_impact calls and direct law calls
        self.largest_island = 0  # contacts
        self.direct = law == DIRECT_LAW and method in DIRECT_METHODS
        # law stronge's islands on steps without an impact: .moreau_stronge
        self.stronge = StrongeIslands.applies(mech, law, method, self.options)
        self._direct_options = None
        self._last_islands = (None, b"", None, None)  # (groups, moves' bytes, islands, plan)
        #: islands (their contacts' bytes) certified sticking on every contact last step
        self._modes_last: set = set()
        self._announced = False
        self.certified = 0  # island steps answered by the certificate alone
        self.checks = 0           # island steps the law searched (its diagnostic included)
        self.ambiguous: list = []  # (t_m, step, note) of the searches that found ambiguity
        self.pruned = 0  # island steps of a sliding mode searched without dominated sets
        #: the direct steps' slide-program warm starts, per island (its contacts' bytes)
        self._warm: dict = {}
        # the islands of a resting or sliding mode in one compiled call: .moreau_pn_islands
        self.pn_islands = PnIslands.applies(mech, self.direct, self.options)

    def idle(self) -> None:
        self._modes_last = set()  # a step without contacts ends every resting mode
        self._warm = {}  # ... and every sliding mode
        if self.pn_islands is not None:
            self.pn_islands.reset()

    def _direct_opts(self):
        """The law's options on its direct path (its interior point's, ``"clarabel"``)."""
        if self._direct_options is None:
            self._direct_options = parse_options("clarabel", self.options)
        return self._direct_options

    def _coefficients(self, st, active: np.ndarray):
        """Per active contact: e_eff, e_t (or None), v_n,k and v_n,free."""
        Ja = st.Ja
        vnk = Ja[:, 0, :] @ st.v
        vnf = Ja[:, 0, :] @ st.v_free
        approaching = (vnk < -self.rest_velocity) & (vnf < 0.0)
        if not approaching.any():  # a step without an impact: every coefficient 0
            zeros = np.zeros(vnk.size)
            return zeros, (None if self.e_t is None else zeros.copy()), vnk, vnf
        safe = np.where(approaching, vnf, -1.0)
        es = np.where(approaching, np.minimum(self.e[active] * vnk / safe, 1.0), 0.0)
        ets = None
        if self.e_t is not None:
            ets = np.array([self.e_t[self.contacts[c]] if a else 0.0
                            for c, a in zip(active, approaching)])
        return es, ets, vnk, vnf

    def _loop_rows(self, C: np.ndarray, cols: np.ndarray) -> np.ndarray:
        """The loop rows inside the coordinates ``cols`` (a loop's row lies in one group)."""
        inside = np.zeros(C.shape[1], dtype=bool)
        inside[cols] = True
        nz = C != 0.0
        return np.flatnonzero(nz.any(axis=1) & ~(nz & ~inside).any(axis=1))

    def _islands(self, moves: np.ndarray, groups, C, active) -> tuple[list, tuple]:
        """:func:`.islands.contact_islands` of the step and the flat layout of its islands of
        several contacts without loop rows (the certificate's, :meth:`_certify`: their
        indices among the islands, their keys (the contacts' bytes), contacts and
        coordinates), reused while the coordinate groups (the same cached object), the
        active contacts and their column pattern stay (a resting or sliding scene keeps
        them for many steps)."""
        key = (moves.shape, np.packbits(moves).tobytes(), active.tobytes())
        last_groups, last_key, last, plan = self._last_islands
        if groups is last_groups and key == last_key:
            return last, plan
        islands = contact_islands(moves, groups, split=self.split)
        chosen = [j for j, (cs, cols) in enumerate(islands)
                  if 1 < cs.size <= MAX_CONTACTS
                  and not (C is not None and self._loop_rows(C, cols).size)]

        icon, icoff = flat_layout([islands[j][0] for j in chosen])
        icol, icoloff = flat_layout([islands[j][1] for j in chosen])
        keys = [active[islands[j][0]].tobytes() for j in chosen]
        plan = (chosen, keys, icon, icoff, icol, icoloff)
        self._last_islands = (groups, key, islands, plan)
        return islands, plan

    def _certify(self, st, plan, Ja, v_free, es, active):
        """The certificate of :mod:`.moreau_pn_kernels` on the step's islands of ``plan``:
        ``(islands answered, impulses (na, d), v_{k+1}, islands certified)``: answered are
        the certified islands that were certified on the step before with the same contacts
        (the others are searched, :meth:`solve`); None when there is no island to try or the
        law's compiled path is not yet taken (a handful of steps: the law's Python path,
        whose answers are the compiled one's to round-off)."""
        chosen, keys, icon, icoff, icol, icoloff = plan
        if not chosen or not pn.compiled_path_active():
            return None
        if not self._announced:
            self._announced = True
            announce("Moreau–Jean certificate of pereira-nikravesh's resting islands",
                     CERTIFICATE_COMPILE_SECONDS, certify_islands)
        d = Ja.shape[1]
        status = np.zeros(len(chosen), dtype=np.int64)
        r = np.zeros((Ja.shape[0], d))
        v_new = v_free.copy()
        certify_islands(Ja, v_free, es, self.mu[active], np.ascontiguousarray(st.inv.G),
                        icon, icoff, icol, icoloff, d,
                        pn.STICK_COND_MAX, pn.CONE_RTOL, pn.VELOCITY_SLACK_MAX, IMMOBILE_RTOL,
                        TINY_NORMAL, r, v_new, status)
        last = self._modes_last
        # an island's mode: its contacts, sticking on every one
        certified = {key for key, sn in zip(keys, status.tolist()) if sn == STICK}
        answered = {chosen[n] for n, key in enumerate(keys) if key in certified and key in last}
        return answered, r, v_new, certified

    def _note(self, st, notes) -> None:
        """Record the law's ambiguity warning among ``notes`` (the step's time and index)."""
        for note in notes:
            if AMBIGUITY_NOTE in note:
                self.ambiguous.append((float(st.tm), int(st.index), note))
                return

    def run_warnings(self) -> tuple[str, ...]:
        """The run's warnings: one for the island steps on which the law found several
        admissible active sets with different velocities (counts, the first step times and
        the first such warning)."""
        if not self.ambiguous:
            return ()
        times = ", ".join(f"{t:.6g}" for t, _, _ in self.ambiguous[:QUOTED_TIMES])
        more = ", ..." if len(self.ambiguous) > QUOTED_TIMES else ""
        steps = len({s for _, s, _ in self.ambiguous})
        return (f"law {self.law!r}: several admissible active sets with different velocities "
                f"on {len(self.ambiguous)} of the {self.checks} island steps searched "
                f"({steps} steps, at t = {times}{more}); each time the law's answer (the most "
                f"dissipative) was taken. First: {self.ambiguous[0][2]}. Islands sticking on "
                "every contact with the same contacts as the step before are not searched "
                "again, and islands that slid on every contact the step before are searched "
                "without the dominated active sets (simulate_moreau's docs)",)

    def _direct_impulse(self, M, Jcs, v, e, mu, notes: list | None = None, warm=None,
                        prune: bool = False) -> tuple[np.ndarray, np.ndarray] | None:
        """``(v_{k+1}, impulse)`` of one loop-free island of several contacts by the law's
        impulse alone (:func:`~convimpact.impact.laws.pn_complementarity_impulse.
        several_contacts_impulse` on the problem ``resolve_impact`` builds, with the backend
        and options its ``method`` uses): the same impulse, without the result record;
        None where the full call is needed (it raises or reports). ``notes``: the law's
        ambiguity warning is appended there; ``warm``: the island's slide-program warm
        starts (:class:`~convimpact.impact.laws.pn_complementarity_search.SlideWarmStart`);
        ``prune``: the search without dominated sets first (a sliding mode, module
        docstring)."""
        try:
            P = build_problem(M, Jcs, v, e, mu)
            if P.n_contacts > MAX_CONTACTS:
                return None
            if not any(P.approaching):  # resolve_impact's separating answer
                return P.dq_minus.copy(), np.zeros((P.n_contacts, P.dim))
            pi = several_contacts_impulse(P, conic_backend("clarabel"), self._direct_opts(),
                                          notes, warm, prune)
        except ConvImpactError:
            return None
        if pi is None:
            return None
        return P.dq_minus + P.velocity_jump(pi)[0], pi

    def solve(self, st) -> tuple[np.ndarray, np.ndarray]:
        """``(v_{k+1}, sigma)`` of the step ``st`` (:class:`.moreau_loop.Step`)."""
        if self.stronge is not None:  # law stronge without an impact: .moreau_stronge
            done = self.stronge.solve(self, st)
            if done is not None:
                return done
        if self.pn_islands is not None:  # law pereira-nikravesh's modes: .moreau_pn_islands
            done = self.pn_islands.solve(self, st)
            if done is not None:
                return done
        active = np.asarray(st.active, dtype=np.int64)
        na = active.size
        # (read only below: no copies of the loop's arrays but v, kept by an ImpactEvent)
        Ja = np.ascontiguousarray(st.Ja, dtype=float)
        d = Ja.shape[1]
        v, v_free, M = np.array(st.v), np.ascontiguousarray(st.v_free, dtype=float), st.M
        es, ets, vnk, vnf = self._coefficients(st, active)
        C = st.C if self.m else None
        moves = (Ja != 0.0).any(axis=1)
        islands, plan = self._islands(moves, st.inv.groups, C, active)
        regime = ["separating"] * na
        results, energy_loss = [], 0.0
        cone = self.law in CONE_COMPLEMENTARITY_LAWS
        dsig = np.zeros(self.m)
        # no contact approaching at the step's start: no ImpactEvent, only impulses needed
        direct = self.direct and not (vnk < -self.rest_velocity).any()
        # the certificate (sticking on every contact) is not tried where every island it
        # would try slid on every contact on the step before (a sliding mode, whose first
        # resting step the search finds: the law's own search, after the pruned one hands
        # the decision to it on an admissible stick set)
        # (islands answered by PnIslands.solve: their certificates and answers)
        mine = self.pn_islands.pending(st) if self.pn_islands is not None else None
        sliding = all(k in self._warm and self._warm[k].full_slide for k in plan[1])
        certified = mine or (self._certify(st, plan, Ja, v_free, es, active)
                             if direct and not sliding else None)
        if self.stronge is not None:  # its islands answered by StrongeIslands.solve
            certified = self.stronge.pending(st) or certified
        if certified is None:
            answered: set = set()
            v_new = v_free.copy()
            impulse = np.zeros((na, d))
            self._modes_last = set()
        else:
            # the answered islands' impulses and velocities (v_free and no impulse
            # elsewhere, until the islands below write theirs); the islands certified now
            # are searched this step if they were not the step before (the diagnostic of a
            # new mode) and answered by the certificate alone on the next
            answered, impulse, v_new, self._modes_last = certified
            if mine is None:  # (PnIslands counted its own)
                self.calls += len(answered)
                self.certified += len(answered)
        if answered and mine is None:
            self.largest_island = max(self.largest_island,
                                      max(islands[j][0].size for j in answered))
        if answered:
            islands = [isl for j, isl in enumerate(islands) if j not in answered]
        warm_last, self._warm = self._warm, {}
        for cs, cols in islands:
            if not cone and np.all(vnf[cs] >= 0.0):
                continue
            one = cs.size == 1
            Jcs = [Ja[i][:, cols] for i in cs]
            lrows = self._loop_rows(C, cols) if C is not None else np.zeros(0, dtype=int)
            if direct and not one and not lrows.size:
                notes: list = []
                key = active[cs].tobytes()
                warm = self._warm[key] = warm_last.get(key) or SlideWarmStart()
                # a sliding mode: the island slid on every contact on the step before
                prune, warm.full_slide, warm.pruned = warm.full_slide, False, False
                got = self._direct_impulse(M[np.ix_(cols, cols)], Jcs, v_free[cols], es[cs],
                                           self.mu[active[cs]], notes, warm, prune)
                if got is not None:
                    if warm.pruned:
                        self.pruned += 1
                    else:
                        self.checks += 1
                        self._note(st, notes)
                    v_new[cols], impulse[cs] = got
                    self.calls += 1
                    self.largest_island = max(self.largest_island, int(cs.size))
                    continue
            Ci = C[np.ix_(lrows, cols)] if lrows.size else None
            law_params = {} if ets is None else {"e_t": ets[cs[0]] if one else ets[cs]}
            self.calls += 1
            self.largest_island = max(self.largest_island, int(cs.size))
            try:
                r = resolve_impact(M[np.ix_(cols, cols)], Jcs[0] if one else Jcs,
                                   v_free[cols], es[cs[0]] if one else es[cs],
                                   self.mu[active[cs[0]]] if one else self.mu[active[cs]],
                                   Ci, law=self.law, method=self.method, **law_params,
                                   **self.options)
            except ConvImpactError as exc:
                names = ", ".join(self.contacts[active[i]] for i in cs)
                exc.add_note(f"(while resolving the step impulse of {names} at "
                             f"t = {st.tm:.9g}, step {st.index}, in simulate_moreau)")
                raise
            v_new[cols] = np.asarray(r.dq_plus, float)
            impulse[cs] = np.asarray(r.impulse, float).reshape(cs.size, d)
            if lrows.size:
                dsig[lrows] = np.asarray(r.loop_impulse, float)[:lrows.size]
            for i, g in zip(cs, (r.regime,) if isinstance(r.regime, str) else r.regime):
                regime[i] = g
            energy_loss += float(r.energy_loss)
            results.append((cs, r))
            if not one:
                self.checks += 1
                self._note(st, r.diagnostics.notes)
        if mine is not None:  # the sliding islands PnIslands answered keep their warm starts
            self._warm.update(self.pn_islands.keep())
        sigma = st.sigma + dsig if self.m else st.sigma
        self.impulse = impulse
        if self.stronge is not None:
            self.stronge.remember(active, impulse)
        hit = [] if direct else [i for i in range(na)
                                 if vnk[i] < -self.rest_velocity and impulse[i, 0] > 0.0]
        if hit:
            hit_results = [r for cs, r in results if np.isin(cs, hit).any()]
            self.impacts.append(ImpactEvent(
                time=st.tm, contacts=tuple(self.contacts[active[i]] for i in hit),
                held_contacts=(), regime=tuple(regime), impulse=impulse,
                loop_impulse=dsig, generalized_impulse=Ja.reshape(na * d, -1).T @ impulse.ravel(),
                theta=np.array(st.qm), dtheta_minus=v, dtheta_plus=v_new.copy(),
                energy_loss=energy_loss,
                kinetic_energy_minus=0.5 * float(v @ M @ v),
                kinetic_energy_plus=0.5 * float(v_new @ M @ v_new),
                persistent=(), released=(), resolve_time=0.0,
                result=hit_results[0] if len(hit_results) == 1 else None))
        return v_new, sigma
