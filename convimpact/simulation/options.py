"""The validated options of an event-driven run (:func:`convimpact.simulation.simulate`)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np
from scipy.integrate import OdeSolver


@dataclass(frozen=True)
class EventDrivenOptions:
    """The options of one run, validated (as documented in :func:`~.simulate.simulate`).

    ``in_place`` is True for one-step integrators, which continue from a projected state;
    multistep ones restart. ``drift_threshold`` is the max |Psi| beyond which the state is
    projected after a step. ``t_eval`` is None or a sorted array within ``(t0, t1)``.
    ``impact_options`` are the solver options forwarded to ``resolve_impact``;
    ``tangential_restitution`` is the law's e_t per contact (law ``"chatterjee-ruina"``,
    from ``impact_options["e_t"]``; None: the law's default). ``sensitivities``: integrate the
    variational equations and the events' saltation matrices
    (:mod:`~convimpact.simulation.sensitivity`). ``breakpoints``: sorted times within
    (t0, t1) where the integration restarts (:meth:`next_bound`).
    """

    t0: float
    t1: float
    t_eval: np.ndarray | None
    dense_output: bool
    law: str
    method: str
    impact_options: Mapping[str, Any]
    solver_cls: type[OdeSolver]
    rtol: float
    atol: float
    max_step: float
    first_step: float | None
    event_tol: float
    contact_tol: float
    projection_tol: float
    in_place: bool
    drift_threshold: float
    zeno: str
    zeno_time_tol: float
    rest_velocity: float
    max_impacts: int
    painleve: str = "stop"
    impacts: str = "simultaneous"
    tangential_restitution: Mapping[str, float] | None = None
    sensitivities: bool = False
    breakpoints: tuple[float, ...] = ()

    def next_bound(self, t: float) -> float:
        """Where a segment starting at t ends at the latest: the first breakpoint after t,
        else the span's end."""
        for b in self.breakpoints:
            if b > t:
                return b
        return self.t1

    def settings(self) -> dict[str, Any]:
        """The options as reported in :attr:`SimulationResult.settings`."""
        return {
            "law": self.law, "method": self.method,
            "integrator": self.solver_cls.__name__, "rtol": self.rtol, "atol": self.atol,
            "max_step": None if not np.isfinite(self.max_step) else self.max_step,
            "event_tol": self.event_tol, "contact_tol": self.contact_tol,
            "projection_tol": self.projection_tol, "zeno": self.zeno,
            "zeno_time_tol": self.zeno_time_tol, "rest_velocity": self.rest_velocity,
            "max_impacts": int(self.max_impacts), "painleve": self.painleve,
            "impacts": self.impacts,
            "t_span": [self.t0, self.t1],
            **({"sensitivities": True} if self.sensitivities else {}),
            **({"breakpoints": list(self.breakpoints)} if self.breakpoints else {}),
            **({} if self.tangential_restitution is None
               else {"e_t": dict(self.tangential_restitution)}),
        }
