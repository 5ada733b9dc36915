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
(:func:`~convimpact.impact.laws.pn_complementarity.several_contacts_impulse` on the problem
``resolve_impact`` builds, with the same backend and options): the same impulse as the full
call, without the result record (regimes, diagnostics) nobody reads on such a step; where
that call would raise or report unsolved active sets the full call is made.

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

from ..impact import resolve_impact
from ..impact.conic.paths import backend as conic_backend
from ..impact.conic.paths import parse_options
from ..errors import ConvImpactError
from ..impact.laws.pn_complementarity import MAX_CONTACTS, several_contacts_impulse
from ..impact.problem.build import build_problem
from .islands import contact_islands
from .result import ImpactEvent

#: laws whose answer at contacts that all separate under v_free may still be an impulse
CONE_COMPLEMENTARITY_LAWS = frozenset({"ccp", "dissipative"})
#: the law whose several-contact islands take the law's impulse directly on steps without
#: an impact (see ImpactSolver), and the methods whose path that impulse is
DIRECT_LAW = "pereira-nikravesh"
DIRECT_METHODS = ("auto", "clarabel")


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
        self._direct_options = None
        self._last_islands = (None, b"", None)  # (groups, moves' bytes, islands)

    def idle(self) -> None:
        pass

    def _coefficients(self, st, active: np.ndarray):
        """Per active contact: e_eff, e_t (or None), v_n,k and v_n,free."""
        Ja = st.Ja
        vnk = Ja[:, 0, :] @ st.v
        vnf = Ja[:, 0, :] @ st.v_free
        approaching = (vnk < -self.rest_velocity) & (vnf < 0.0)
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

    def _islands(self, moves: np.ndarray, groups) -> list:
        """:func:`.islands.contact_islands` of the step, reused while the coordinate groups
        (the same cached object) and the active contacts' column pattern stay (a resting or
        sliding scene keeps both for many steps)."""
        key = np.array(moves.shape, dtype=np.int64).tobytes() + np.packbits(moves).tobytes()
        last_groups, last_key, last = self._last_islands
        if groups is last_groups and key == last_key:
            return last
        islands = contact_islands(moves, groups, split=self.split)
        self._last_islands = (groups, key, islands)
        return islands

    def _direct_impulse(self, M, Jcs, v, e, mu) -> tuple[np.ndarray, np.ndarray] | None:
        """``(v_{k+1}, impulse)`` of one loop-free island of several contacts by the law's
        impulse alone (:func:`~convimpact.impact.laws.pn_complementarity.
        several_contacts_impulse` on the problem ``resolve_impact`` builds, with the backend
        and options its ``method`` uses): the same impulse, without the result record;
        None where the full call is needed (it raises or reports)."""
        try:
            P = build_problem(M, Jcs, v, e, mu)
            if P.n_contacts > MAX_CONTACTS:
                return None
            if not any(P.approaching):  # resolve_impact's separating answer
                return P.dq_minus.copy(), np.zeros((P.n_contacts, P.dim))
            if self._direct_options is None:
                self._direct_options = parse_options("clarabel", self.options)
            pi = several_contacts_impulse(P, conic_backend("clarabel"), self._direct_options)
        except ConvImpactError:
            return None
        if pi is None:
            return None
        return P.dq_minus + P.velocity_jump(pi)[0], pi

    def solve(self, st) -> tuple[np.ndarray, np.ndarray]:
        """``(v_{k+1}, sigma)`` of the step ``st`` (:class:`.moreau_loop.Step`)."""
        active = np.asarray(st.active, dtype=np.int64)
        na = active.size
        Ja = np.array(st.Ja)
        d = Ja.shape[1]
        v, v_free, M = np.array(st.v), np.array(st.v_free), st.M
        es, ets, vnk, vnf = self._coefficients(st, active)
        C = st.C if self.m else None
        moves = np.any(Ja != 0.0, axis=1)
        islands = self._islands(moves, st.inv.groups)
        v_new = v_free.copy()
        impulse = np.zeros((na, d))
        dsig = np.zeros(self.m)
        regime = ["separating"] * na
        results, energy_loss = [], 0.0
        cone = self.law in CONE_COMPLEMENTARITY_LAWS
        # no contact approaching at the step's start: no ImpactEvent, only impulses needed
        direct = self.direct and not np.any(vnk < -self.rest_velocity)
        for cs, cols in islands:
            if not cone and np.all(vnf[cs] >= 0.0):
                continue
            one = cs.size == 1
            Jcs = [Ja[i][:, cols] for i in cs]
            lrows = self._loop_rows(C, cols) if C is not None else np.zeros(0, dtype=int)
            if direct and not one and not lrows.size:
                got = self._direct_impulse(M[np.ix_(cols, cols)], Jcs, v_free[cols], es[cs],
                                           self.mu[active[cs]])
                if got is not None:
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
        sigma = st.sigma + dsig if self.m else st.sigma
        self.impulse = impulse
        hit = [i for i in range(na) if vnk[i] < -self.rest_velocity and impulse[i, 0] > 0.0]
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
