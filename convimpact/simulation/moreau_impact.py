"""The contact problem of a Moreau–Jean step through :func:`convimpact.resolve_impact`: the
step solver of every law and method outside the contact engine (pereira-nikravesh, stronge,
dissipative, chatterjee-ruina; ccp and coulomb under the other methods), for
:func:`.moreau_loop.run_steps`.

Per step with active contacts: Newton's restitution at the velocity level as the
per-contact coefficient ``e_eff = min(e v_n,k / v_n,free, 1)`` on contacts approaching at the
step's start (``v_n,k < -rest_velocity`` and ``v_n,free < 0``), 0 on the others; a law's
tangential restitution (``e_t`` of ``"chatterjee-ruina"``) on the approaching contacts only;
one call of :func:`convimpact.resolve_impact` with M, the active rows, ``v_free`` and the
loop rows at q_m; an :class:`~.result.ImpactEvent` (with the
:class:`~convimpact.impact.results.ImpactResult`) on the steps where an approaching contact
receives a normal impulse.
"""

from __future__ import annotations

from typing import Any, Mapping

import numpy as np

from ..impact import resolve_impact
from ..impact.errors import ConvImpactError
from .result import ImpactEvent


class ImpactSolver:
    """Step solver through :func:`convimpact.resolve_impact` (see the module docstring)."""

    def __init__(self, mech, *, law: str, method: str, impact_options: Mapping[str, Any],
                 e_t: Mapping[str, float] | None, rest_velocity: float):
        self.contacts = tuple(mech.contact_names)
        params = [mech.contact_parameters(c) for c in self.contacts]
        self.e = [float(p[0]) for p in params]
        self.mu = [float(p[1]) for p in params]
        self.m = int(mech.n_loop_constraints)
        self.law, self.method = law, method
        self.options = dict(impact_options)
        self.e_t = e_t
        self.rest_velocity = rest_velocity
        self.impacts: list[ImpactEvent] = []

    def idle(self) -> None:
        pass

    def solve(self, st) -> tuple[np.ndarray, np.ndarray]:
        """``(v_{k+1}, sigma)`` of the step ``st`` (:class:`.moreau_loop.Step`)."""
        active = [int(c) for c in st.active]
        names = [self.contacts[c] for c in active]
        Jcs = [np.array(st.Ja[i]) for i in range(len(active))]
        v, v_free = np.array(st.v), np.array(st.v_free)
        M = np.array(st.M)
        rv = self.rest_velocity
        es, mus, ets, vnk = [], [], [], []
        for i, c in enumerate(active):
            vn_k, vn_free = float(Jcs[i][0] @ v), float(Jcs[i][0] @ v_free)
            approaching = vn_k < -rv and vn_free < 0.0
            es.append(min(self.e[c] * vn_k / vn_free, 1.0) if approaching else 0.0)
            if self.e_t is not None:
                ets.append(self.e_t[names[i]] if approaching else 0.0)
            mus.append(self.mu[c])
            vnk.append(vn_k)
        law_params = {} if self.e_t is None else {"e_t": ets[0] if len(active) == 1 else ets}
        C = st.C if self.m else None
        one = len(active) == 1
        try:
            r = resolve_impact(M, Jcs[0] if one else Jcs, v_free, es[0] if one else es,
                               mus[0] if one else mus, C, law=self.law, method=self.method,
                               **law_params, **self.options)
        except ConvImpactError as exc:
            exc.add_note(f"(while resolving the step impulse of {', '.join(names)} at "
                         f"t = {st.tm:.9g}, step {st.index}, in simulate_moreau)")
            raise
        v_new = np.asarray(r.dq_plus, float)
        dsig = np.asarray(r.loop_impulse, float)
        sigma = st.sigma
        if self.m and dsig.size >= self.m:
            sigma = sigma + dsig[:self.m]
        impulse = np.asarray(r.impulse, float).reshape(len(active), -1)
        hit = [i for i, vn in enumerate(vnk) if vn < -rv and impulse[i, 0] > 0.0]
        if hit:
            regime = (r.regime,) if isinstance(r.regime, str) else tuple(r.regime)
            self.impacts.append(ImpactEvent(
                time=st.tm, contacts=tuple(names[i] for i in hit),
                held_contacts=(), regime=regime, impulse=impulse,
                loop_impulse=dsig, generalized_impulse=np.vstack(Jcs).T @ impulse.ravel(),
                theta=np.array(st.qm), dtheta_minus=v, dtheta_plus=v_new.copy(),
                energy_loss=float(r.energy_loss),
                kinetic_energy_minus=0.5 * float(v @ M @ v),
                kinetic_energy_plus=0.5 * float(v_new @ M @ v_new),
                persistent=(), released=(), resolve_time=0.0, result=r))
        return v_new, sigma
