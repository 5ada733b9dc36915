"""Compliant (penalty) contact: continuous normal forces from the penetration, stiff integration.

Every contact carries a force while it penetrates (``delta = -gap > 0``):

* normal force, with ``delta_dot = -c_n^T theta_dot`` and ``delta_dot^-`` the penetration rate
  at the onset of the contact episode (located on the step's interpolant):

  - Hunt–Crossley (1975)::        F_n = k delta^n (1 + 3 (1 - e) / 2 * delta_dot / delta_dot^-)
  - Lankarani–Nikravesh (1990)::  F_n = k delta^n (1 + 3 (1 - e^2) / 4 * delta_dot / delta_dot^-)

  clamped at F_n >= 0 (the damping term can only slow the separation, never pull);
* friction, regularized Coulomb::  F_t = -mu F_n v_t / sqrt(|v_t|^2 + v_eps^2),

applied as generalized forces ``Jc^T (F_n, F_t)`` added to the mechanism's own ``f`` in the
canonical equations (eq. 15, loops kept by eqs. 13-14 and coordinate projection). Between
episodes the contact is inactive; nothing is reset at an impact: the run is one smooth stiff
ODE, except that the solver restarts at each onset (where delta_dot^- is recorded).

What the model gives instead of an impact law: an *effective* restitution
``e_eff = v_n(separation) / -v_n(onset)`` that depends on the model (and, under gravity, on
the stiffness). For a free particle (no other force) the relation is exact and independent of
k, n and the mass: with ``a = 3 (1 - e) / 2`` (HC) or ``3 (1 - e^2) / 4`` (LN),
``a (1 + e_eff) = ln((1 + a) / (1 - a e_eff))``; both models are built so that e_eff ~ e for
e -> 1. The contact lasts ``T ~ k^(-1 / (n + 1))`` and penetrates ``delta_max ~ k^(-1/(n+1))``;
stiff contacts force small steps (``n_contact_steps``): the cost of this model.

Known artefacts: penetration (reported), impact times smeared over the contact duration,
restitution that is not the requested e (above), and stiffness: an explicit integrator needs
steps below the contact's period; use "Radau", "BDF" or "LSODA".
"""

from __future__ import annotations

import math
import time as _time
from dataclasses import dataclass
from typing import Any, Mapping, Sequence

import numpy as np
from scipy.integrate import OdeSolver

from ..errors import (
    ParameterError,
    SimulationError,
    UnknownOptionError,
)
from .canonical import CanonicalEquations
from .events import locate_crossing
from .projection import project_positions, project_velocities
from .result import SERIES, SimulationResult, append_sample, series_from_rows
from .initial import consistent_start, initial_state, integrator_class, positive, time_span
from .simulate import ONE_STEP, _as_mechanism

MODELS = ("hunt-crossley", "lankarani-nikravesh")


def damping_factor(model: str, e: float) -> float:
    """The coefficient a of ``F_n = k delta^n (1 + a delta_dot / delta_dot^-)``."""
    if model == "hunt-crossley":
        return 1.5 * (1.0 - e)
    if model == "lankarani-nikravesh":
        return 0.75 * (1.0 - e * e)
    raise UnknownOptionError(f"unknown compliant model {model!r}; choose one of "
                             f"{', '.join(MODELS)}")


def effective_restitution(model: str, e: float) -> float:
    """Exact restitution of the force law on a free particle (no other force acting).

    Solves ``a (1 + r) = ln((1 + a) / (1 - a r))`` for r (see the module docstring); this
    follows from ``m u du / (1 + a u / v0) = -k delta^n d delta`` integrated over an episode.
    """
    a = damping_factor(model, e)
    if a == 0.0:
        return 1.0
    from scipy.optimize import brentq

    def g(r):
        return a * (1.0 + r) - math.log((1.0 + a) / (1.0 - a * r))

    hi = min(1.0, (1.0 - 1e-12) / a)
    return float(brentq(g, 0.0, hi, xtol=1e-15)) if g(0.0) * g(hi) < 0 else 0.0


def restitution_for(model: str, target: float) -> float:
    """The model's parameter e whose free-particle restitution is ``target`` (inverse of
    :func:`effective_restitution`; HC and LN both give e_eff >= e, so the result is <= target).

    Raises
    ------
    ParameterError
        when ``target`` is outside [0, 1] or below the model's smallest reachable value
        (e = 0 gives e_eff = effective_restitution(model, 0)).
    """
    from scipy.optimize import brentq

    target = float(target)
    if not 0.0 <= target <= 1.0:
        raise ParameterError(f"target restitution must lie in [0, 1], got {target!r}")
    lo = effective_restitution(model, 0.0)
    if target < lo:
        raise ParameterError(f"model {model!r} cannot restitute less than {lo:.4g} (at e = 0); "
                             f"{target:g} is out of its reach")
    if target >= 1.0:
        return 1.0
    if target == lo:
        return 0.0
    return float(brentq(lambda x: effective_restitution(model, x) - target, 0.0, 1.0,
                        xtol=1e-14))


@dataclass(frozen=True)
class ContactEpisode:
    """One contact episode of the compliant model (from onset to separation).

    Attributes
    ----------
    contact : name.
    t_start, t_end : onset and separation times (t_end None when still in contact at t1).
    approach_velocity : normal velocity c_n^T theta_dot at onset (< 0).
    separation_velocity : normal velocity at separation (None when still in contact).
    max_penetration : largest delta = -gap during the episode.
    n_steps : integrator steps taken during the episode.
    dtheta_start, dtheta_end : joint velocities at onset and separation.
    """

    contact: str
    t_start: float
    t_end: float | None
    approach_velocity: float
    separation_velocity: float | None
    max_penetration: float
    n_steps: int
    dtheta_start: np.ndarray
    dtheta_end: np.ndarray | None

    @property
    def duration(self) -> float | None:
        return None if self.t_end is None else self.t_end - self.t_start

    @property
    def effective_restitution(self) -> float | None:
        """``v_n(separation) / -v_n(onset)``."""
        if self.separation_velocity is None or self.approach_velocity >= 0:
            return None
        return self.separation_velocity / -self.approach_velocity

    def as_dict(self) -> dict[str, Any]:
        return {"contact": self.contact, "t_start": self.t_start, "t_end": self.t_end,
                "duration": self.duration, "approach_velocity": self.approach_velocity,
                "separation_velocity": self.separation_velocity,
                "effective_restitution": self.effective_restitution,
                "max_penetration": self.max_penetration, "n_steps": self.n_steps}


@dataclass(frozen=True, eq=False)
class CompliantResult(SimulationResult):
    """:class:`SimulationResult` of :func:`simulate_compliant` (``impacts`` is empty: there
    are no impacts, only contact episodes).

    Attributes
    ----------
    episodes : the contact episodes in onset order.
    max_penetration : largest penetration of any contact at any accepted step.
    n_contact_steps : accepted steps with at least one contact penetrating (the stiffness's
        cost); ``n_steps - n_contact_steps`` are free-flight steps.
    njev, nlu : Jacobian evaluations and LU decompositions of the implicit integrator.
    model, stiffness, exponent : the force law.
    """

    episodes: tuple[ContactEpisode, ...] = ()
    max_penetration: float = 0.0
    n_contact_steps: int = 0
    njev: int = 0
    nlu: int = 0
    model: str = "hunt-crossley"
    stiffness: float = float("nan")
    exponent: float = 1.5

    @property
    def contact_durations(self) -> list[float]:
        return [ep.duration for ep in self.episodes if ep.duration is not None]

    def as_dict(self, series: bool = True) -> dict[str, Any]:
        out = super().as_dict(series)
        out.update(scheme="compliant", model=self.model, stiffness=self.stiffness,
                   exponent=self.exponent, max_penetration=self.max_penetration,
                   n_contact_steps=self.n_contact_steps, njev=self.njev, nlu=self.nlu,
                   episodes=[ep.as_dict() for ep in self.episodes])
        return out


class _ContactForces:
    """The mechanism with the compliant contact forces added to its generalized forces."""

    def __init__(self, mech, model, k, n, e, mu, v_eps, v_min):
        self._mech = mech
        self.n_coordinates = mech.n_coordinates
        self.n_loop_constraints = mech.n_loop_constraints
        self.contact_names = tuple(mech.contact_names)
        self.model, self.k, self.n, self.v_eps, self.v_min = model, k, n, v_eps, v_min
        self.a = {c: damping_factor(model, e[c]) for c in self.contact_names}
        self.mu = mu
        self.onset: dict[str, float] = {}  # contact -> delta_dot^- of the running episode

    def __getattr__(self, name):
        return getattr(self._mech, name)

    def contact_force(self, c: str, theta, dtheta) -> tuple[np.ndarray, float]:
        """(generalized force Jc^T F, F_n) of contact c."""
        delta = -float(self._mech.contact_gap(c, theta))
        if delta <= 0.0:
            return np.zeros(self.n_coordinates), 0.0
        J = np.asarray(self._mech.contact_jacobian(c, theta), float)
        v = J @ dtheta
        ddot = -float(v[0])
        v0 = max(self.onset.get(c, ddot), self.v_min)
        fn = self.k[c] * delta ** self.n * (1.0 + self.a[c] * ddot / v0)
        fn = max(fn, 0.0)
        F = np.zeros(J.shape[0])
        F[0] = fn
        if self.mu[c] > 0.0 and J.shape[0] > 1:
            vt = v[1:]
            F[1:] = -self.mu[c] * fn * vt / math.sqrt(float(vt @ vt) + self.v_eps ** 2)
        return J.T @ F, fn

    def generalized_forces(self, t, theta, dtheta):
        f = np.array(self._mech.generalized_forces(t, theta, dtheta), float)
        for c in self.contact_names:
            f += self.contact_force(c, theta, dtheta)[0]
        return f


def _per_contact(name: str, value, contacts, default) -> dict[str, float]:
    if value is None:
        return {c: float(default(c)) for c in contacts}
    if isinstance(value, Mapping):
        unknown = set(value) - set(contacts)
        if unknown:
            raise UnknownOptionError(f"{name} names unknown contacts {sorted(unknown)}")
        return {c: float(value.get(c, default(c))) for c in contacts}
    return {c: float(value) for c in contacts}


def simulate_compliant(
    system,
    t_span: Sequence[float] | None = None,
    y0=None,
    *,
    model: str = "hunt-crossley",
    stiffness,
    exponent: float = 1.5,
    e=None,
    mu=None,
    regularization_velocity: float = 1e-3,
    min_impact_velocity: float = 1e-3,
    integrator: str | type[OdeSolver] = "Radau",
    rtol: float = 1e-6,
    atol: float = 1e-9,
    max_step: float = np.inf,
    first_step: float | None = None,
    event_tol: float = 1e-12,
    projection_tol: float = 1e-10,
    assemble: bool = False,
    contact_tol: float = 1e-8,
) -> CompliantResult:
    """Integrate a mechanism with compliant (Hunt–Crossley or Lankarani–Nikravesh) contacts.

    Parameters
    ----------
    system : Mechanism or Scene
    t_span, y0 : as in :func:`convimpact.simulation.simulate` (y0 a tuple (theta0, dtheta0)).
    model : {"hunt-crossley", "lankarani-nikravesh"}
        The normal force law (module docstring).
    stiffness : float or mapping contact -> float
        k (N / m^n for a length gap), > 0.
    exponent : float
        n (1.5: Hertz), > 0.
    e, mu : float or mapping, optional
        Restitution in [0, 1] and friction >= 0; default each contact's own parameters.
    regularization_velocity : float
        v_eps of the regularized Coulomb friction (slip speed over which friction saturates).
    min_impact_velocity : float
        Floor on delta_dot^- (a contact that starts touching at rest has no impact velocity;
        its damping is scaled by this speed instead).
    integrator : str or OdeSolver subclass
        "Radau" (default), "BDF", "LSODA" (stiff) or an explicit one ("DOP853", "RK45").
    rtol, atol, max_step, first_step : integrator controls.
    event_tol : tolerance (s) of the onset and separation times.
    projection_tol : loop drift above which theta is projected onto Psi = 0.
    assemble, contact_tol : as in :func:`convimpact.simulation.simulate`.

    Returns
    -------
    CompliantResult
        Series at every accepted step, the contact episodes (durations, penetrations,
        effective restitution), step counts and Jacobian evaluations.

    Raises
    ------
    ShapeError, NonFiniteError, ParameterError, UnknownOptionError
        for malformed input;
    LoopConstraintError, PenetrationError
        for an inconsistent or penetrating initial state;
    SimulationError
        when the state becomes non-finite.
    """
    wall0 = _time.perf_counter()
    mech, scene = _as_mechanism(system)
    k = int(mech.n_coordinates)
    m = int(mech.n_loop_constraints)
    contacts = tuple(mech.contact_names)
    if model not in MODELS:
        raise UnknownOptionError(f"unknown compliant model {model!r}; choose one of "
                                 f"{', '.join(MODELS)}")
    solver_cls = integrator_class(integrator)
    ks = _per_contact("stiffness", stiffness, contacts, lambda c: float("nan"))
    es = _per_contact("e", e, contacts, lambda c: mech.contact_parameters(c)[0])
    mus = _per_contact("mu", mu, contacts, lambda c: mech.contact_parameters(c)[1])
    for c in contacts:
        if not (math.isfinite(ks[c]) and ks[c] > 0):
            raise ParameterError(f"stiffness of contact {c!r} must be positive and finite, "
                                 f"got {ks[c]!r}")
        if not (0.0 <= es[c] <= 1.0):
            raise ParameterError(f"e of contact {c!r} must lie in [0, 1], got {es[c]!r}")
        if not (math.isfinite(mus[c]) and mus[c] >= 0):
            raise ParameterError(f"mu of contact {c!r} must be >= 0, got {mus[c]!r}")
    positive(exponent=exponent, regularization_velocity=regularization_velocity,
             min_impact_velocity=min_impact_velocity, rtol=rtol, atol=atol, event_tol=event_tol,
             projection_tol=projection_tol, contact_tol=contact_tol)
    t0, t1 = time_span(t_span, scene)

    forces = _ContactForces(mech, model, ks, float(exponent), es, mus,
                            float(regularization_velocity), float(min_impact_velocity))
    eq = CanonicalEquations(forces)
    q, v = initial_state(y0, scene, k)
    q, v = consistent_start(mech, q, v, assemble=assemble, projection_tol=projection_tol,
                            contact_tol=contact_tol)

    rows: dict[str, list] = {key: [] for key in SERIES}

    def record(t, y):
        th = y[:k]
        dth, sig, _ = eq.velocities(th, y[k:])
        append_sample(rows, mech, t, th, dth, y[k:], sig)

    def normal_velocity(c, y):
        th = y[:k]
        dth, _, _ = eq.velocities(th, y[k:])
        return float(np.asarray(mech.contact_jacobian(c, th), float)[0] @ dth), dth

    y = np.concatenate([q, eq.momentum(q, v)])
    t = t0
    record(t, y)
    open_eps: dict[str, dict[str, Any]] = {}
    episodes: list[ContactEpisode] = []
    counters = {"steps": 0, "contact_steps": 0, "njev": 0, "nlu": 0, "proj": 0, "restarts": 0}
    max_pen = 0.0
    in_place = issubclass(solver_cls, ONE_STEP)
    # contacts touching at the start begin an episode at rest
    for c in contacts:
        if float(mech.contact_gap(c, q)) <= 0.0:
            vn, dth = normal_velocity(c, y)
            forces.onset[c] = max(-vn, 0.0)
            open_eps[c] = dict(t_start=t, vn=vn, pen=0.0, steps=0, dth=dth)
    status, message = None, ""
    h_next = first_step
    while status is None:
        opts: dict[str, Any] = {"rtol": rtol, "atol": atol, "max_step": max_step}
        if h_next is not None and h_next > 0:
            opts["first_step"] = min(float(h_next), t1 - t)
        solver = solver_cls(eq, t, y, t1, **opts)
        counters["restarts"] += 1
        g_prev = {c: float(mech.contact_gap(c, y[:k])) for c in contacts}
        restart = False
        while True:
            msg = solver.step()
            if solver.status == "failed":
                status, message = -1, f"integrator failed at t = {solver.t:.9g}: {msg}"
                break
            counters["steps"] += 1
            t_old, t_new, y_new = solver.t_old, solver.t, solver.y.copy()
            if not np.all(np.isfinite(y_new)):
                raise SimulationError(f"the state became non-finite at t = {t_new:.9g}; "
                                      "use a stiff integrator or tighter tolerances")
            interp = solver.dense_output()
            g_new = {c: float(mech.contact_gap(c, y_new[:k])) for c in contacts}
            onsets = []
            for c in contacts:
                if c not in open_eps and g_prev[c] > 0.0 and g_new[c] <= 0.0:
                    te = locate_crossing(lambda s, c=c: float(mech.contact_gap(c, interp(s)[:k])),
                                         t_old, t_new, g_prev[c], g_new[c], event_tol)
                    onsets.append((te, c))
            if onsets:
                te, c = min(onsets)
                ye = np.asarray(interp(te), float) if te < t_new else y_new
                vn, dth = normal_velocity(c, ye)
                forces.onset[c] = max(-vn, 0.0)
                open_eps[c] = dict(t_start=te, vn=vn, pen=0.0, steps=0, dth=dth)
                t, y = te, ye
                record(t, y)
                h_next = solver.step_size
                restart = True
                break
            # separations (the force is continuous there: no restart)
            for c in list(open_eps):
                if g_new[c] > 0.0:
                    ep = open_eps.pop(c)
                    if g_prev[c] <= 0.0:
                        ts_ = locate_crossing(
                            lambda s, c=c: -float(mech.contact_gap(c, interp(s)[:k])),
                            t_old, t_new, -g_prev[c], -g_new[c], event_tol)
                    else:
                        ts_ = t_old
                    ys = np.asarray(interp(ts_), float)
                    vn, dth = normal_velocity(c, ys)
                    episodes.append(ContactEpisode(c, ep["t_start"], float(ts_), ep["vn"], vn,
                                                   ep["pen"], ep["steps"], ep["dth"], dth))
                    forces.onset.pop(c, None)
            pens = [-g_new[c] for c in open_eps]
            if pens:
                counters["contact_steps"] += 1
                for c in open_eps:
                    open_eps[c]["pen"] = max(open_eps[c]["pen"], -g_new[c])
                    open_eps[c]["steps"] += 1
                max_pen = max(max_pen, max(pens))
            t, y = t_new, y_new
            if m:
                drift = float(np.max(np.abs(eq.residual(y[:k]))))
                if drift > projection_tol:
                    th = y[:k]
                    dth, sig, _ = eq.velocities(th, y[k:])
                    M = np.asarray(mech.mass_matrix(th), float)
                    th, _, _ = project_positions(eq.residual, eq.jacobian, M, th,
                                                 0.1 * projection_tol)
                    dth = project_velocities(np.asarray(mech.mass_matrix(th), float),
                                             eq.jacobian(th), dth)
                    y = np.concatenate([th, eq.momentum(th, dth, sig)])
                    counters["proj"] += 1
                    if in_place:
                        solver.y = y.copy()
                        solver.f = solver.fun(t, solver.y)
                    else:
                        record(t, y)
                        h_next = solver.step_size
                        restart = True
                        break
            record(t, y)
            g_prev = {c: float(mech.contact_gap(c, y[:k])) for c in contacts}
            if solver.status == "finished":
                status, message = 0, "the end of the time span was reached"
                break
        counters["njev"] += int(getattr(solver, "njev", 0) or 0)
        counters["nlu"] += int(getattr(solver, "nlu", 0) or 0)
        if restart and t >= t1:
            status, message = 0, "the end of the time span was reached"
    for c, ep in open_eps.items():
        episodes.append(ContactEpisode(c, ep["t_start"], None, ep["vn"], None, ep["pen"],
                                       ep["steps"], ep["dth"], None))
    episodes.sort(key=lambda ep: ep.t_start)

    wall = _time.perf_counter() - wall0
    n = len(rows["t"])
    kk = sorted(set(ks.values()))
    settings = {"scheme": "compliant", "model": model, "stiffness": dict(ks),
                "exponent": float(exponent), "e": dict(es), "mu": dict(mus),
                "regularization_velocity": regularization_velocity,
                "integrator": solver_cls.__name__, "rtol": rtol, "atol": atol,
                "t_span": [t0, t1]}
    return CompliantResult(
        **series_from_rows(rows, k, m),
        held=np.zeros(n, dtype=int),
        impacts=(),
        contact_events=(),
        sol=None,
        status=int(status),
        message=message,
        nfev=int(eq.nfev),
        nevents_fev=0,
        n_steps=counters["steps"],
        n_projections=counters["proj"],
        n_restarts=counters["restarts"],
        wall_time=float(wall),
        impact_time=0.0,
        settings=settings,
        episodes=tuple(episodes),
        max_penetration=float(max_pen),
        n_contact_steps=counters["contact_steps"],
        njev=counters["njev"],
        nlu=counters["nlu"],
        model=model,
        stiffness=float(kk[0]) if len(kk) == 1 else float("nan"),
        exponent=float(exponent),
    )
