"""Result types of a simulation (small frozen dataclasses, the paper's names spelled out)."""

from __future__ import annotations

from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any, Mapping, Union

import numpy as np

from ..impact.results import ImpactResult, _jsonable


@dataclass(frozen=True)
class ImpactEvent:
    """One impact: the integration halted, the law gave the jump, the integration resumed.

    Attributes
    ----------
    time : impact instant t (located to the simulation's ``event_tol``).
    contacts : names of the contacts closing together (several when simultaneous).
    held_contacts : persistent contacts that took part as bilateral constraints.
    regime : per contact "frictionless", "stick", "slide" or "separating".
    impulse : (n_contacts, d) contact-frame impulses (normal first).
    loop_impulse : Delta sigma of the loops and held contacts (eq. 44).
    generalized_impulse : Delta p = Jc^T pi (eq. 33), (k,).
    theta : configuration at the impact.
    dtheta_minus, dtheta_plus : joint velocities before and after (eq. 29/44).
    energy_loss : T- - T+ as reported by the law (eq. 58).
    kinetic_energy_minus, kinetic_energy_plus : T- and T+ measured by the mechanism.
    persistent : contacts switched to persistent (held closed) at this impact; an accumulating
        contact's impact is then resolved with e = 0 (the reported result is that one).
    released : held contacts released because the impact pulled on them.
    resolve_time : wall time spent in ``resolve_impact`` (s).
    result : the law's full :class:`~convimpact.impact.results.ImpactResult` (with
        diagnostics), or None for a Moreau–Jean step solved on the contact engine
        (:mod:`convimpact.simulation.moreau_engine`: certified by the natural-map residual).
    saltation : (2k, 2k) the saltation matrix ``dx+/dx-`` of the event instant in
        x = (theta, theta_dot) (with ``simulate(..., sensitivities=True)``; else None), see
        :class:`~convimpact.simulation.saltation.EventSensitivity`.
    """

    time: float
    contacts: tuple[str, ...]
    held_contacts: tuple[str, ...]
    regime: tuple[str, ...]
    impulse: np.ndarray
    loop_impulse: np.ndarray
    generalized_impulse: np.ndarray
    theta: np.ndarray
    dtheta_minus: np.ndarray
    dtheta_plus: np.ndarray
    energy_loss: float
    kinetic_energy_minus: float
    kinetic_energy_plus: float
    persistent: tuple[str, ...]
    released: tuple[str, ...]
    resolve_time: float
    result: ImpactResult | None
    saltation: np.ndarray | None = None

    def as_dict(self) -> dict[str, Any]:
        """Plain-JSON view."""
        return {
            "time": self.time, "contacts": list(self.contacts),
            "held_contacts": list(self.held_contacts), "regime": list(self.regime),
            "impulse": _jsonable(self.impulse), "loop_impulse": _jsonable(self.loop_impulse),
            "generalized_impulse": _jsonable(self.generalized_impulse),
            "theta": _jsonable(self.theta), "dtheta_minus": _jsonable(self.dtheta_minus),
            "dtheta_plus": _jsonable(self.dtheta_plus), "energy_loss": self.energy_loss,
            "kinetic_energy_minus": self.kinetic_energy_minus,
            "kinetic_energy_plus": self.kinetic_energy_plus,
            "persistent": list(self.persistent), "released": list(self.released),
            "resolve_time": self.resolve_time,
            "diagnostics": (None if self.result is None
                            else self.result.diagnostics.as_dict()),
            "saltation": None if self.saltation is None else _jsonable(self.saltation),
        }


@dataclass(frozen=True)
class ContactEvent:
    """A contact switching between free (unilateral, event-driven) and persistent (held).

    Attributes
    ----------
    time : instant of the switch.
    contact : contact name.
    kind : "persist" (gap held closed from now on) or "release" (normal force reached zero,
        or an impact pulled on it, or it was separating when asked to be held).
    reason : human-readable cause (accumulation detected, rest velocity, tensile force ...).
    accumulation_time : for "persist" after a detected accumulation, the extrapolated limit
        t_inf of the geometric sequence of impact times; None otherwise.
    energy_change : T+ - T- of the velocity correction applied at the switch (<= 0).
    saltation : (2k, 2k) the saltation matrix of the instant in x = (theta, theta_dot)
        (with ``simulate(..., sensitivities=True)``; else None).
    """

    time: float
    contact: str
    kind: str
    reason: str
    accumulation_time: float | None = None
    energy_change: float = 0.0
    saltation: np.ndarray | None = None

    def as_dict(self) -> dict[str, Any]:
        return {k: _jsonable(getattr(self, k)) for k in self.__dataclass_fields__}


#: the contact modes of sustained contact, by code: ``contact_mode[j, i]`` indexes this tuple
MODE_NAMES = ("open", "stick", "slip")


@dataclass(frozen=True)
class ModeInterval:
    """One interval of a contact's mode timeline: ``mode`` held over [t_start, t_end].

    ``mode`` is "open" (free: unilateral, watched for impacts), "stick" (closed, no slip:
    rolling or resting) or "slip" (closed, sliding with Coulomb friction mu lambda_n opposing
    the slip).
    """

    contact: str
    mode: str
    t_start: float
    t_end: float

    def as_dict(self) -> dict[str, Any]:
        return {k: _jsonable(getattr(self, k)) for k in self.__dataclass_fields__}


@dataclass(frozen=True)
class PainleveEvent:
    """A sliding contact where the contact force problem has no solution or several.

    Attributes
    ----------
    time : the instant.
    contacts : the closed contacts of the force problem.
    kind : "inconsistent" (no solution) or "indeterminate" (several solutions).
    n_solutions : how many distinct solutions (in contact accelerations) were found.
    effective_mass : per contact, the normal entry of the Delassus matrix in the slip
        direction, ``c_n^T G (c_n - mu c_t s)`` (<= 0 marks Painleve's paradox).
    action : what the simulator did ("stopped").
    """

    time: float
    contacts: tuple[str, ...]
    kind: str
    n_solutions: int
    effective_mass: tuple[float, ...]
    action: str = "stopped"

    def as_dict(self) -> dict[str, Any]:
        return {k: _jsonable(getattr(self, k)) for k in self.__dataclass_fields__}


class LazySeries:
    """A result field whose value may be given as a zero-argument callable: it is called on
    the first read of the field and its value kept (a series costly to compute that few
    readers want, such as an event-driven run's exact contact forces).

    A field of this kind has the default ``empty`` (a hashable placeholder: dataclasses
    refuse array defaults), stored as ``np.zeros(shape)``.
    """

    def __init__(self, shape: tuple[int, ...]):
        self.shape = shape

    def __set_name__(self, owner, name: str) -> None:
        self.name, self.slot = name, "_lazy_" + name

    def __get__(self, obj, objtype=None):
        if obj is None:
            return None  # the dataclass's default: the empty series
        value = obj.__dict__[self.slot]
        if callable(value):
            value = np.asarray(value())
            obj.__dict__[self.slot] = value
        return value

    def __set__(self, obj, value) -> None:
        if self.slot in obj.__dict__:
            raise AttributeError(f"cannot assign to field {self.name!r}")  # frozen
        obj.__dict__[self.slot] = np.zeros(self.shape) if value is None else value


@dataclass(frozen=True, eq=False)
class SimulationResult:
    """Outcome of :func:`convimpact.simulation.simulate` (modelled on scipy's OdeResult).

    Series are sampled at every accepted step (or at ``t_eval``). At an impact instant the
    pre- and post-impact states are both stored, at the same time (so ``t`` is non-decreasing
    and a jump shows as a vertical segment in plots).

    Attributes
    ----------
    t : (n,) times.
    theta, dtheta, p : (n, k) joint coordinates, velocities and momenta (eqs. 10, 13).
    sigma : (n, m) loop multipliers of eq. (13) (empty columns for open loops).
    kinetic_energy, potential_energy : (n,) T and V.
    loop_residual : (n,) max |Psi(theta)| (position drift, eq. 6).
    loop_velocity_residual : (n,) max |C theta_dot| (velocity drift, eq. 7).
    held : (n,) number of contacts held closed (persistent) at each sample.
    impacts : the impact events, in time order.
    contact_events : persistent-contact switches, in time order.
    sol : callable ``sol(t) -> y = [theta, p]`` across all segments (right-continuous at
        impacts), or None unless ``dense_output=True``.
    status : 0 reached the end of the span; 1 stopped early by request (accumulation with
        ``zeno="stop"`` or ``max_impacts`` reached); 2 stopped at Painleve's paradox (see
        ``painleve``); -1 the integrator failed.
    message : why it stopped.
    nfev : right-hand-side evaluations (eq. 15); nevents_fev : gap and force evaluations of
        the event location.
    n_steps, n_projections, n_restarts : accepted steps, constraint projections, restarts.
    wall_time : total wall time (s); impact_time : wall time inside ``resolve_impact`` (s).
    max_loop_residual, max_loop_velocity_residual : max drift over the run (after projection).
    settings : the options used (law, method, integrator, tolerances).
    warnings : modelling caveats met during the run; empty when none.
    contact_names : the mechanism's contacts, in the order of the contact series' columns.
    contact_mode : (n, n_contacts) mode codes per sample, indices into :data:`MODE_NAMES`
        (0 open, 1 stick, 2 slip).
    contact_force : (n, n_contacts, d) contact forces in the contact frame (normal first, then
        t or t1, t2), zero while open. The event-driven scheme computes the exact forces
        of its samples on the first read of this series (the run itself needs few of
        them; where the contacts are redundant each is a force-distribution program), with
        each sample's modes: the same numbers as computed during the run.
    mode_intervals : the per-contact mode timeline, :class:`ModeInterval` in time order.
    painleve : the :class:`PainleveEvent` met (a run stops at the first), empty when none.
    friction_dissipation : (n,) energy dissipated by sliding friction since the start
        (cumulative, >= 0; the friction power integrated on each step's interpolant).
    law_flags : counts over the run of the impacts whose law raised each flag
        (``energy_gained``, ``penetration``, ``slip_reversal``, ``friction_pushes_slip`` --
        sliding impacts only) and of Painleve events (``painleve``); each flag raised also
        gives one entry of ``warnings``.
    state_transition : (2k, 2k) ``dx(t_final)/dx(t_0)``, x = (theta, theta_dot), with
        ``simulate(..., sensitivities=True)`` (the monodromy matrix of a periodic orbit);
        else None. t_final is the run's last instant (the span's end unless it stopped
        early), x(t_0) the state given (before the contacts touching at t_0 are closed).
    parameter_sensitivity : {"e": (2k, n_contacts), "mu": (2k, n_contacts)}: the derivatives
        of x(t_final) with respect to each contact's restitution and friction coefficients
        (columns in the order of ``contact_names``), with ``sensitivities=True``; else empty.
    event_sensitivities : one :class:`~convimpact.simulation.saltation.EventSensitivity`
        per event instant (impacts, lift-offs, stick/slip transitions, the start), in time
        order, with ``sensitivities=True``; else empty.
    sensitivity_series : with ``sensitivities=True`` and ``t_eval``: {"t": (n,), "state":
        (n, 2k, 2k) dx(t)/dx(t_0), "e", "mu": (n, 2k, n_contacts) dx(t)/d(e, mu)} at the
        samples (right-continuous at events, like the series); else empty.
    """

    t: np.ndarray
    theta: np.ndarray
    dtheta: np.ndarray
    p: np.ndarray
    sigma: np.ndarray
    kinetic_energy: np.ndarray
    potential_energy: np.ndarray
    loop_residual: np.ndarray
    loop_velocity_residual: np.ndarray
    held: np.ndarray
    impacts: tuple[ImpactEvent, ...]
    contact_events: tuple[ContactEvent, ...]
    sol: Any
    status: int
    message: str
    nfev: int
    nevents_fev: int
    n_steps: int
    n_projections: int
    n_restarts: int
    wall_time: float
    impact_time: float
    settings: Mapping[str, Any] = field(default_factory=lambda: MappingProxyType({}))
    warnings: tuple[str, ...] = ()
    contact_names: tuple[str, ...] = ()
    contact_mode: np.ndarray = field(default_factory=lambda: np.zeros((0, 0), dtype=int))
    contact_force: np.ndarray = LazySeries((0, 0, 0))  # type: ignore[assignment]
    mode_intervals: tuple[ModeInterval, ...] = ()
    painleve: tuple[PainleveEvent, ...] = ()
    friction_dissipation: np.ndarray = field(default_factory=lambda: np.zeros(0))
    law_flags: Mapping[str, int] = field(default_factory=lambda: MappingProxyType({}))
    state_transition: np.ndarray | None = None
    parameter_sensitivity: Mapping[str, np.ndarray] = field(
        default_factory=lambda: MappingProxyType({}))
    event_sensitivities: tuple = ()
    sensitivity_series: Mapping[str, np.ndarray] = field(
        default_factory=lambda: MappingProxyType({}))

    def __getstate__(self) -> dict[str, Any]:
        """Picklable state (multiprocessing, joblib, a file): a lazy series is computed now,
        read-only mappings travel as dicts (``_proxies`` names them) and come back
        read-only."""
        state: dict[str, Any] = {}
        proxies = []
        for key, value in self.__dict__.items():
            if key.startswith("_lazy_") and callable(value):
                value = np.asarray(value())
            if isinstance(value, MappingProxyType):
                value = dict(value)
                proxies.append(key)
            state[key] = value
        state["_proxies"] = tuple(proxies)
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        state = dict(state)
        for key in state.pop("_proxies", ()):
            state[key] = MappingProxyType(state[key])
        self.__dict__.update(state)  # the frozen dataclass's fields, as pickled

    def modes_of(self, contact: str) -> tuple[ModeInterval, ...]:
        """The mode timeline of one contact."""
        return tuple(iv for iv in self.mode_intervals if iv.contact == contact)

    def mode_at(self, contact: str, t: float) -> str:
        """The mode of ``contact`` at time ``t`` (the latest interval starting at or before t)."""
        found = "open"
        for iv in self.mode_intervals:
            if iv.contact == contact and iv.t_start <= t:
                found = iv.mode
        return found

    @property
    def success(self) -> bool:
        """True when the integrator did not fail (status >= 0)."""
        return self.status >= 0

    @property
    def y(self) -> np.ndarray:
        """Integration array y = [theta, p] (eq. 15), shape (2k, n) as in scipy."""
        return np.hstack([self.theta, self.p]).T

    @property
    def total_energy(self) -> np.ndarray:
        return self.kinetic_energy + self.potential_energy

    @property
    def max_loop_residual(self) -> float:
        return float(np.max(self.loop_residual)) if self.loop_residual.size else 0.0

    @property
    def max_loop_velocity_residual(self) -> float:
        return (float(np.max(self.loop_velocity_residual))
                if self.loop_velocity_residual.size else 0.0)

    @property
    def rhs_per_second(self) -> float:
        """Right-hand-side evaluations per wall-clock second (benchmark figure)."""
        return self.nfev / self.wall_time if self.wall_time > 0 else float("nan")

    @property
    def impact_share(self) -> float:
        """Share of the wall time spent in impact resolution."""
        return self.impact_time / self.wall_time if self.wall_time > 0 else float("nan")

    def as_dict(self, series: bool = True) -> dict[str, Any]:
        """Plain-JSON view; ``series=False`` leaves out the time series."""
        out: dict[str, Any] = {
            "status": self.status, "message": self.message, "nfev": self.nfev,
            "nevents_fev": self.nevents_fev, "n_steps": self.n_steps,
            "n_projections": self.n_projections, "n_restarts": self.n_restarts,
            "wall_time": self.wall_time, "impact_time": self.impact_time,
            "rhs_per_second": self.rhs_per_second,
            "max_loop_residual": self.max_loop_residual,
            "max_loop_velocity_residual": self.max_loop_velocity_residual,
            "settings": _jsonable(dict(self.settings)),
            "impacts": [e.as_dict() for e in self.impacts],
            "contact_events": [e.as_dict() for e in self.contact_events],
            "warnings": list(self.warnings),
            "law_flags": dict(self.law_flags),
            "contact_names": list(self.contact_names),
            "mode_intervals": [iv.as_dict() for iv in self.mode_intervals],
            "painleve": [ev.as_dict() for ev in self.painleve],
        }
        if self.state_transition is not None:
            out["state_transition"] = _jsonable(self.state_transition)
            out["parameter_sensitivity"] = _jsonable(self.parameter_sensitivity)
            out["event_sensitivities"] = [ev.as_dict() for ev in self.event_sensitivities]
        if series:
            out["series"] = {
                "t": self.t.tolist(), "theta": self.theta.tolist(),
                "dtheta": self.dtheta.tolist(), "p": self.p.tolist(),
                "sigma": self.sigma.tolist(),
                "kinetic_energy": self.kinetic_energy.tolist(),
                "potential_energy": self.potential_energy.tolist(),
                "loop_residual": self.loop_residual.tolist(),
                "loop_velocity_residual": self.loop_velocity_residual.tolist(),
                "held": self.held.tolist(),
                "contact_mode": self.contact_mode.tolist(),
                "contact_force": self.contact_force.tolist(),
                "friction_dissipation": self.friction_dissipation.tolist(),
            }
        return out


Regime = Union[str, tuple[str, ...]]


class PiecewiseSolution:
    """Dense output across integration segments: ``sol(t) -> y = [theta, p]``.

    Each segment is ``(t_start, t_end, interpolant)``; at a shared boundary (an impact) the
    later segment wins, so the solution is right-continuous (post-impact) there.
    """

    def __init__(self, segments):
        segs = [s for s in segments if s[1] >= s[0]]
        self._t0 = np.array([s[0] for s in segs])
        self._t1 = np.array([s[1] for s in segs])
        self._f = [s[2] for s in segs]

    @property
    def t_min(self) -> float:
        return float(self._t0[0])

    @property
    def t_max(self) -> float:
        return float(self._t1[-1])

    def __call__(self, t):
        ts = np.atleast_1d(np.asarray(t, dtype=float))
        idx = np.searchsorted(self._t0, ts, side="right") - 1
        idx = np.clip(idx, 0, len(self._f) - 1)
        cols = [np.asarray(self._f[i](ti), float).ravel() for i, ti in zip(idx, ts)]
        out = np.column_stack(cols)
        return out[:, 0] if np.ndim(t) == 0 else out


#: the keys of a scheme's recorded rows (see :func:`series_from_rows`)
SERIES = ("t", "theta", "dtheta", "p", "sigma", "T", "V", "psi", "cdq")


def series_from_rows(rows: Mapping[str, list], k: int, m: int) -> dict[str, np.ndarray]:
    """The sampled series of a :class:`SimulationResult` from a scheme's recorded rows.

    ``rows`` holds lists under the keys :data:`SERIES`.
    """
    n = len(rows["t"])
    return {
        "t": np.array(rows["t"], float),
        "theta": np.array(rows["theta"], float).reshape(n, k),
        "dtheta": np.array(rows["dtheta"], float).reshape(n, k),
        "p": np.array(rows["p"], float).reshape(n, k),
        "sigma": np.array(rows["sigma"], float).reshape(n, m),
        "kinetic_energy": np.array(rows["T"], float),
        "potential_energy": np.array(rows["V"], float),
        "loop_residual": np.array(rows["psi"], float),
        "loop_velocity_residual": np.array(rows["cdq"], float),
    }


def append_sample(rows: Mapping[str, list], mech, t: float, theta: np.ndarray,
                  dtheta: np.ndarray, p: np.ndarray, sigma: np.ndarray) -> None:
    """Record one sample (state, energies, loop drift) into the rows of
    :func:`series_from_rows`."""
    m = int(mech.n_loop_constraints)
    rows["t"].append(float(t))
    rows["theta"].append(np.array(theta, float))
    rows["dtheta"].append(np.array(dtheta, float))
    rows["p"].append(np.array(p, float))
    rows["sigma"].append(np.array(sigma[:m], float))
    rows["T"].append(float(mech.kinetic_energy(theta, dtheta)))
    rows["V"].append(float(mech.potential_energy(theta)))
    if m:
        rows["psi"].append(float(np.max(np.abs(mech.loop_residual(theta)))))
        rows["cdq"].append(float(np.max(np.abs(np.asarray(mech.loop_jacobian(theta)) @ dtheta))))
    else:
        rows["psi"].append(0.0)
        rows["cdq"].append(0.0)

