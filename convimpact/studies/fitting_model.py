"""The observation model of a coefficient fit: what was measured, and its prediction.

An :class:`Observations` holds the times ``t_i`` (m of them), the channels (p of them) and
the measured values ``y_ij``. A channel is a joint coordinate of the mechanism by name
(``"y"``: its position theta_j) or that name with ``"_dot"`` (``"y_dot"``: its velocity
theta_dot_j). The model of the data is

    y_ij = h_j(x(t_i; e, mu)) + eps_ij,   eps_ij ~ N(0, sigma_j^2) independent,

with x(t; e, mu) the simulated state (:func:`convimpact.simulation.simulate`, event-driven,
right-continuous at impacts: a sample at an impact instant is the post-impact state) and h_j
the channel's coordinate. Positions are continuous in e and mu (the trajectory only bends
where an impact moves); velocities jump at impacts, so a velocity sample close to an impact
has a derivative that only holds while the impact stays on the same side of it.

:class:`TrajectoryModel` is the fit's one interface to the simulator:
``trajectory_and_derivatives(params) -> (predicted (m, p), derivatives (m, p, n))``, from
the simulator's trajectory sensitivities (``simulate(..., sensitivities=True)``: variational
equations between events, saltation matrices at them; the default) or from central finite
differences of whole simulations. The coefficients are set on a copy of the
mechanism (:func:`with_coefficients`), never on the caller's.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any, Mapping, Sequence

import numpy as np

from ..errors import (ConvImpactError, NotSupportedError, ParameterError, ShapeError,
                             SimulationError, UnknownOptionError)
from ..mechanism import Mechanism
from ..validation import mapping, positive, real, sorted_times

#: the coefficients a fit can estimate, with their bounds
PARAMETER_BOUNDS = {"e": (0.0, 1.0), "mu": (0.0, np.inf)}
#: simulate's options that the fit sets itself (the observation times fix the span)
RESERVED_OPTIONS = ("t_span", "y0", "t_eval", "dense_output", "sensitivities")
#: integration tolerances of the fit's simulations unless given: tight, because the finite
#: differences divide their error by the step (and the sensitivities follow the trajectory)
FIT_TOLERANCES = {"rtol": 1e-10, "atol": 1e-12}
VELOCITY_SUFFIX = "_dot"


@dataclass(frozen=True, eq=False)
class Observations:
    """Measured samples of a trajectory: the data of a fit.

    Attributes
    ----------
    times : (m,) sample times, non-decreasing, after the start of the motion.
    values : (m, p) measured values, one column per channel.
    channels : the p channel names: a joint coordinate's name (its position, e.g. ``"y"``)
        or that name with ``"_dot"`` (its velocity, ``"y_dot"``).

    A 1-D ``values`` is taken as one channel. Strings, booleans, NaN and infinity are refused
    with the project's typed errors.
    """

    times: np.ndarray
    values: np.ndarray
    channels: tuple[str, ...]

    def __post_init__(self):
        from ..errors import NonFiniteError, as_real_array

        times = as_real_array("observation times", self.times).ravel()
        if times.size == 0:
            raise ShapeError("observation times must hold at least one time")
        times = sorted_times("observation times", times, -np.inf, np.inf)
        values = as_real_array("observed values", self.values)
        if values.ndim == 1:
            values = values[:, None]
        if values.ndim != 2 or values.shape[0] != times.size:
            raise ShapeError(f"observed values must have shape (m, p) with m = {times.size} "
                             f"(one row per time), got {values.shape}")
        if not np.isfinite(values).all():
            raise NonFiniteError("observed values contain NaN or infinity; drop those samples")
        channels = self.channels
        if isinstance(channels, str):
            channels = (channels,)
        if not isinstance(channels, (tuple, list)) or not all(
                isinstance(c, str) for c in channels):
            raise ShapeError(f"channels must be a sequence of coordinate names, got "
                             f"{self.channels!r}")
        channels = tuple(channels)
        if len(channels) != values.shape[1]:
            raise ShapeError(f"{len(channels)} channel name(s) {channels} for {values.shape[1]} "
                             "column(s) of observed values")
        if len(set(channels)) != len(channels):
            raise ShapeError(f"channels repeat a name: {channels}")
        object.__setattr__(self, "times", times)
        object.__setattr__(self, "values", values)
        object.__setattr__(self, "channels", channels)

    @property
    def n_samples(self) -> int:
        """m * p, the number of observed numbers."""
        return int(self.values.size)


def channel_indices(mech, channels: Sequence[str]) -> list[tuple[str, int]]:
    """Per channel ("theta" or "dtheta", coordinate index); UnknownOptionError naming the
    coordinates for an unknown channel."""
    names = list(getattr(mech, "coordinate_names", None)
                 or [f"q{i}" for i in range(int(mech.n_coordinates))])
    out = []
    for c in channels:
        if c in names:
            out.append(("theta", names.index(c)))
        elif c.endswith(VELOCITY_SUFFIX) and c[:-len(VELOCITY_SUFFIX)] in names:
            out.append(("dtheta", names.index(c[:-len(VELOCITY_SUFFIX)])))
        else:
            raise UnknownOptionError(
                f"unknown channel {c!r}; a channel is a coordinate's name ({', '.join(names)}) "
                f"or that name with {VELOCITY_SUFFIX!r} for its velocity")
    return out


# --------------------------------------------------------------------------------------------
# the coefficients of a copy of the mechanism


class _WithCoefficients:
    """A Mechanism whose contacts report other (e, mu); everything else is the wrapped one's."""

    def __init__(self, mech, coefficients: Mapping[str, tuple[float, float]]):
        self._mech = mech
        self._coefficients = dict(coefficients)
        self.n_coordinates = mech.n_coordinates
        self.n_loop_constraints = mech.n_loop_constraints
        self.contact_names = tuple(mech.contact_names)

    def __getattr__(self, name):
        return getattr(self._mech, name)

    def contact_parameters(self, name: str) -> tuple[float, float]:
        if name in self._coefficients:
            return self._coefficients[name]
        return self._mech.contact_parameters(name)


def with_coefficients(system, coefficients: Mapping[str, tuple[float, float]]):
    """A copy of ``system`` (Scene or Mechanism) whose contacts have the given (e, mu).

    Parameters
    ----------
    system : Scene or Mechanism
    coefficients : contact name -> (e, mu); contacts not named keep theirs.

    Returns
    -------
    The same kind of object: a scene with a new mechanism, a joint-coordinate model's
    mechanism rebuilt from a copy of its model (the simulator's fast path kept), or any other
    mechanism wrapped so that ``contact_parameters`` answers the new values.
    """
    from ..model.mechanism import ModelMechanism

    if isinstance(getattr(system, "mechanism", None), Mechanism) and hasattr(system, "theta0"):
        return dataclasses.replace(system, mechanism=with_coefficients(system.mechanism,
                                                                       coefficients))
    unknown = set(coefficients) - set(system.contact_names)
    if unknown:
        raise UnknownOptionError(f"unknown contact(s) {sorted(unknown)}; contacts are "
                                 f"{', '.join(system.contact_names)}")
    if type(system) is ModelMechanism:
        model = system.model
        contacts = tuple(
            dataclasses.replace(c, restitution=float(coefficients[c.name][0]),
                                friction=float(coefficients[c.name][1]))
            if c.name in coefficients else c for c in model.contacts)
        return dataclasses.replace(model, contacts=contacts).mechanism()
    return _WithCoefficients(system, coefficients)


# --------------------------------------------------------------------------------------------
# the parameters of a fit


@dataclass(frozen=True)
class FitParameter:
    """One estimated coefficient: ``kind`` "e" or "mu", the contacts it sets, its name
    (``"e"`` shared by all contacts, ``"e[floor]"`` for one)."""

    name: str
    kind: str
    contacts: tuple[str, ...]

    @property
    def bounds(self) -> tuple[float, float]:
        return PARAMETER_BOUNDS[self.kind]


def fit_parameters(mech, parameters, per_contact: bool) -> tuple[FitParameter, ...]:
    """The parameters of a fit from the kinds asked for ("e", "mu") and ``per_contact``."""
    if isinstance(parameters, str):
        parameters = (parameters,)
    if not isinstance(parameters, (tuple, list)) or not parameters:
        raise ParameterError(f"parameters must be a non-empty sequence of 'e' and/or 'mu', "
                             f"got {parameters!r}")
    kinds = []
    for p in parameters:
        if not isinstance(p, str) or p not in PARAMETER_BOUNDS:
            raise UnknownOptionError(f"unknown parameter {p!r}; a fit estimates 'e' and/or 'mu'")
        if p in kinds:
            raise ParameterError(f"parameters name {p!r} twice")
        kinds.append(p)
    contacts = tuple(mech.contact_names)
    if not contacts:
        raise ShapeError("the mechanism has no contacts: there is no e or mu to fit")
    if per_contact:
        return tuple(FitParameter(f"{k}[{c}]", k, (c,)) for k in kinds for c in contacts)
    return tuple(FitParameter(k, k, contacts) for k in kinds)


def initial_values(mech, params: Sequence[FitParameter], initial) -> np.ndarray:
    """The starting point: ``initial`` (name -> value, a parameter's kind ("e", "mu") for all
    of its kind) over the mechanism's own coefficients (their mean over a shared parameter)."""
    given = mapping("initial", initial)
    names = {p.name for p in params} | {p.kind for p in params}
    unknown = set(given) - names
    if unknown:
        raise UnknownOptionError(f"initial names unknown parameter(s) {sorted(unknown)}; the "
                                 f"fit's parameters: {', '.join(p.name for p in params)}")
    out = []
    for p in params:
        col = 0 if p.kind == "e" else 1
        if p.name in given:
            value = given[p.name]
        elif p.kind in given:
            value = given[p.kind]
        else:
            value = float(np.mean([mech.contact_parameters(c)[col] for c in p.contacts]))
        x = real(f"initial[{p.name!r}]", value)
        lo, hi = p.bounds
        if not lo <= x <= hi:
            raise ParameterError(f"initial[{p.name!r}] must lie in [{lo:g}, {hi:g}], got {x!r}")
        out.append(x)
    return np.array(out)


# --------------------------------------------------------------------------------------------
# the trajectory and its derivatives


class TrajectoryModel:
    """Predicted observations as a function of the fitted coefficients.

    Parameters
    ----------
    system : Scene or Mechanism
    observations : Observations
    params : the fitted parameters
    y0 : initial state for simulate (default: the scene's)
    t0 : start time of the motion (default 0)
    simulate_options : options forwarded to :func:`convimpact.simulation.simulate`
    step : relative step of the finite differences
    """

    def __init__(self, system, observations: Observations, params: Sequence[FitParameter],
                 *, y0=None, t0: float = 0.0, simulate_options=None, step: float = 1e-5,
                 jacobian: str = "sensitivities"):
        self.system = system
        self.mech = system.mechanism if hasattr(system, "theta0") else system
        self.observations = observations
        self.params = tuple(params)
        self.y0 = y0
        self.t0 = real("t0", t0)
        self.step = positive("finite_difference_step", step)
        self.jacobian = jacobian
        options = mapping("simulate_options", simulate_options)
        reserved = [k for k in options if k in RESERVED_OPTIONS]
        if reserved:
            raise ParameterError(f"simulate_options may not set {', '.join(reserved)}: the fit "
                                 "sets the span and the samples from the observations (pass "
                                 "y0 to fit_coefficients)")
        self.options = {**FIT_TOLERANCES, **options}
        times = observations.times
        if times[0] < self.t0:
            raise ParameterError(f"observation times must not precede the start t0 = "
                                 f"{self.t0:g}, got {times[0]:g}")
        self.t1 = float(times[-1])
        if not self.t1 > self.t0:
            raise ParameterError("the observations must extend beyond the start time t0")
        self.channels = channel_indices(self.mech, observations.channels)
        self.base = {c: tuple(map(float, self.mech.contact_parameters(c)))
                     for c in self.mech.contact_names}
        self.n_simulations = 0
        self.last_result = None

    def coefficients(self, values: np.ndarray) -> dict[str, tuple[float, float]]:
        """contact -> (e, mu) at the parameter values."""
        out = {c: list(v) for c, v in self.base.items()}
        for p, v in zip(self.params, values):
            for c in p.contacts:
                out[c][0 if p.kind == "e" else 1] = float(v)
        return {c: (v[0], v[1]) for c, v in out.items()}

    def simulate(self, values: np.ndarray, sensitivities: bool = False):
        """The simulation at the parameter values (SimulationError if it did not finish)."""
        from ..simulation import simulate

        system = with_coefficients(self.system, self.coefficients(values))
        self.n_simulations += 1
        extra = {"sensitivities": True} if sensitivities else {}
        result = simulate(system, (self.t0, self.t1), self.y0, t_eval=self.observations.times,
                          **self.options, **extra)
        if result.status != 0:
            shown = ", ".join(f"{p.name} = {v:.6g}" for p, v in zip(self.params, values))
            raise SimulationError(f"the simulation at {shown} stopped before the last "
                                  f"observation (status {result.status}): {result.message}")
        return result

    def predict(self, values: np.ndarray) -> np.ndarray:
        """The predicted observations (m, p) at the parameter values."""
        result = self.simulate(values)
        self.last_result = result
        return self.channels_of(result)

    def channels_of(self, result) -> np.ndarray:
        cols = [(result.theta if kind == "theta" else result.dtheta)[:, j]
                for kind, j in self.channels]
        return np.stack(cols, axis=1)

    def trajectory_and_derivatives(self, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(predicted (m, p), d predicted / d params (m, p, n)) by the method of
        ``jacobian``: the simulator's sensitivities, or finite differences."""
        if self.jacobian == "sensitivities":
            return self.sensitivities(values)
        return self.finite_differences(values)

    def sensitivities(self, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """From one run with ``simulate(..., sensitivities=True)``: its samples at the
        observation times (``result.sensitivity_series``: d(theta, theta_dot)(t_i) / d(e, mu)
        per contact), summed over the contacts a shared parameter sets."""
        values = np.asarray(values, float)
        try:
            result = self.simulate(values, sensitivities=True)
        except ConvImpactError as exc:
            self.simulate(values)  # the plain run's own error, if it has one
            raise NotSupportedError(
                f"the simulator's sensitivities failed where the plain simulation runs "
                f"({type(exc).__name__}: {exc}); pass jacobian='finite-differences'") from exc
        self.last_result = result
        series = result.sensitivity_series
        k = int(self.mech.n_coordinates)
        rows = [j if kind == "theta" else k + j for kind, j in self.channels]
        names = list(result.contact_names)
        jac = np.empty((len(self.observations.times), len(rows), len(self.params)))
        for i, p in enumerate(self.params):
            cols = [names.index(c) for c in p.contacts]
            jac[..., i] = series[p.kind][:, rows][:, :, cols].sum(axis=2)
        return self.channels_of(result), jac

    def finite_differences(self, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Central differences of whole simulations, with the step ``step * max(1, |value|)``;
        a parameter within a step of its bound gets the second-order one-sided difference
        into the interior (-3 f0 + 4 f1 - f2) / (2 h), so no simulation leaves the bounds."""
        values = np.asarray(values, float)
        f0 = self.predict(values)
        result0 = self.last_result
        jac = np.empty(f0.shape + (len(values),))
        for j, p in enumerate(self.params):
            lo, hi = p.bounds
            h = self.step * max(1.0, abs(values[j]))
            e = np.zeros_like(values)
            e[j] = h
            if values[j] - h >= lo and values[j] + h <= hi:
                jac[..., j] = (self.predict(values + e) - self.predict(values - e)) / (2 * h)
            else:
                sign = 1.0 if values[j] - h < lo else -1.0
                f1 = self.predict(values + sign * e)
                f2 = self.predict(values + 2 * sign * e)
                jac[..., j] = sign * (-3 * f0 + 4 * f1 - f2) / (2 * h)
        self.last_result = result0
        return f0, jac


def contact_activity(result, contacts: Sequence[str]) -> dict[str, dict[str, Any]]:
    """Per contact, what in a simulation could reveal its coefficients: its impacts, the
    impacts during which it slid, its slip intervals of sustained contact, and
    ``stick_friction_ratio``, the largest |tangential| / normal ratio of its sticking impacts'
    impulses and of its sticking forces (the least mu that keeps them sticking; 0 if none)."""
    out = {c: {"impacts": 0, "sliding_impacts": 0, "slip_intervals": 0,
               "stick_friction_ratio": 0.0} for c in contacts}

    def stick_ratio(c, vector):
        vector = np.asarray(vector, float)
        if vector[0] > 0:
            ratio = float(np.linalg.norm(vector[1:]) / vector[0])
            out[c]["stick_friction_ratio"] = max(out[c]["stick_friction_ratio"], ratio)

    for ev in result.impacts:
        for i, (c, regime) in enumerate(zip(ev.contacts, ev.regime)):
            if c in out:
                out[c]["impacts"] += 1
                out[c]["sliding_impacts"] += regime == "slide"
                if regime == "stick":
                    stick_ratio(c, ev.impulse[i])
    for iv in result.mode_intervals:
        if iv.contact in out and iv.mode == "slip" and iv.t_end > iv.t_start:
            out[iv.contact]["slip_intervals"] += 1
    names = list(result.contact_names)
    if result.contact_mode.size:
        for c in out:
            j = names.index(c)
            for row in np.flatnonzero(result.contact_mode[:, j] == 1):
                stick_ratio(c, result.contact_force[row, j])
    return out


def synthetic_observations(system, times, channels: Sequence[str], *, noise=0.0, seed=None,
                           y0=None, t0: float = 0.0,
                           simulate_options: Mapping[str, Any] | None = None) -> Observations:
    """Observations of a simulated trajectory, with Gaussian noise: data to test a fit on.

    Parameters
    ----------
    system : Scene or Mechanism, simulated with its own e and mu (the "true" values).
    times : sample times.
    channels : coordinate names (positions) or names with ``"_dot"`` (velocities).
    noise : standard deviation of the noise, one for all channels or one per channel (>= 0).
    seed : seed of ``numpy.random.default_rng`` (the noise is reproducible).
    y0, t0, simulate_options : as in :func:`~convimpact.studies.fitting.fit_coefficients`.

    Returns
    -------
    Observations
    """
    clean = Observations(times, np.zeros((np.size(times), len(channels))), tuple(channels))
    sigma = noise_vector(noise, len(clean.channels), allow_zero=True)
    model = TrajectoryModel(system, clean, (), y0=y0, t0=t0, simulate_options=simulate_options)
    exact = model.predict(np.zeros(0))
    rng = np.random.default_rng(seed)
    return Observations(clean.times, exact + rng.standard_normal(exact.shape) * sigma,
                        clean.channels)


def noise_vector(noise, p: int, allow_zero: bool = False) -> np.ndarray:
    """The noise's standard deviation per channel (p,) from a number or a sequence."""
    from ..errors import as_real_array

    if isinstance(noise, (int, float, np.integer, np.floating)) and not isinstance(noise, bool):
        sigma = np.full(p, real("noise", noise))
    else:
        sigma = as_real_array("noise", noise, ParameterError)
        if sigma.ndim == 0:
            sigma = np.full(p, float(sigma))
        if sigma.shape != (p,):
            raise ShapeError(f"noise must be one number or one per channel ({p}), got shape "
                             f"{sigma.shape}")
    if not np.isfinite(sigma).all():
        from ..errors import NonFiniteError
        raise NonFiniteError(f"noise must be finite, got {sigma.tolist()}")
    if np.any(sigma < 0) or (not allow_zero and np.any(sigma == 0)):
        raise ParameterError(f"noise must be {'>= 0' if allow_zero else 'positive'} (a standard "
                             f"deviation per channel), got {sigma.tolist()}")
    return sigma
