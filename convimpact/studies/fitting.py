"""Fitting e and mu to an observed trajectory: bounded Levenberg–Marquardt, confidence
intervals, identifiability.

:func:`fit_coefficients` estimates the restitution e and the friction mu of a scene's
contacts (one value shared by all contacts, or one per contact) from observations of its
motion (:class:`~convimpact.studies.fitting_model.Observations`: times, channels, values; the
observation model is described in :mod:`convimpact.studies.fitting_model`). It minimises

    S(theta) = 1/2 sum_ij ((y_ij - h_j(x(t_i; theta))) / sigma_j)^2

over theta = (e..., mu...) with e in [0, 1] and mu >= 0, by Levenberg–Marquardt (Marquardt's
diagonal scaling, Nielsen's damping update, bounds by projection: a parameter at a bound
whose gradient points out of the box is held there), with the derivatives of the simulated
trajectory with respect to theta: the simulator's trajectory sensitivities
(``simulate(..., sensitivities=True)``) by default, or finite differences of whole runs.

Uncertainty (Gauss–Newton, linearised at the estimate): cov = s^2 (J^T J)^-1 with J the
weighted Jacobian. With ``noise`` given, s = 1 and the intervals use the normal quantile;
without it the residuals estimate one common sigma, s^2 = 2 S / (N - n) (N observed numbers,
n identified parameters), and the intervals use Student's t with N - n degrees of freedom.

Identifiability: a parameter the data do not depend on (mu of a contact that never slides,
e of a contact that never impacts) has a zero column in J; two parameters that enter only
through one combination make J rank-deficient. Such a parameter is reported "not
identifiable": held at its starting value, no standard error, no interval, and a note saying
why. One whose interval is wider than its whole feasible range is "weakly identified".
"""

from __future__ import annotations

from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any, Mapping, Sequence

import numpy as np

from ..errors import ParameterError, SolverError, UnknownOptionError
from ..impact.results import _jsonable
from ..validation import boolean, choice, in_range, integer, positive
from .levenberg_marquardt import ZERO_SENSITIVITY, LevenbergMarquardt
from .fitting_model import (Observations, TrajectoryModel, contact_activity, fit_parameters,
                            initial_values, noise_vector)

__all__ = ["fit_coefficients", "CoefficientFit", "FitError", "JACOBIANS"]

#: how the trajectory's derivatives are obtained
JACOBIANS = ("sensitivities", "finite-differences")
#: singular values (of the column-normalised Jacobian) below this fraction of the largest
#: mark a rank deficiency
RANK_TOLERANCE = 1e-7


class FitError(SolverError):
    """The fit did not converge (iteration limit, or no step lowers the cost).

    Attributes
    ----------
    result : the :class:`CoefficientFit` at the last iterate (``converged`` False), for
        inspection; its numbers are not an answer.
    """

    def __init__(self, message: str, result=None):
        super().__init__(message)
        self.result = result


@dataclass(frozen=True, eq=False)
class CoefficientFit:
    """The outcome of :func:`fit_coefficients`.

    Attributes
    ----------
    parameter_names : names of the estimated parameters ("e", "mu", or "e[contact]", ...).
    estimates : (n,) the estimates (a parameter not identifiable keeps its starting value).
    standard_errors : (n,) sqrt of the covariance's diagonal; NaN where not identifiable.
    confidence_intervals : (n, 2) the intervals at ``confidence_level`` (estimate -+ quantile x
        standard error, cut to the bounds); NaN rows where not identifiable.
    confidence_level : e.g. 0.95.
    covariance : (n, n) Gauss–Newton covariance s^2 (J^T J)^-1 (NaN rows and columns where
        not identifiable).
    identifiable : name -> bool.
    verdicts : name -> "identified", "weakly identified" (interval wider than the range) or
        "not identifiable".
    notes : what the verdicts rest on, bounds met, the noise estimate.
    initial : (n,) the starting values.
    coefficients : contact -> (e, mu) at the estimate.
    times, channels : the observations' times and channels.
    observed, fitted : (m, p) the data and the fitted trajectory's channels.
    residuals : (m, p) observed - fitted.
    noise : (p,) the standard deviation per channel used for the uncertainty (given, or
        estimated from the residuals).
    noise_estimated : True when ``noise`` was estimated from the residuals.
    degrees_of_freedom : N - n, observed numbers minus identified parameters.
    cost : 1/2 the weighted sum of squared residuals at the estimate.
    reduced_chi_square : 2 cost / (N - n) with the noise given (about 1 when the model fits
        and the noise is right; far above 1 adds a note that the fit is poor); NaN when the
        noise is estimated.
    singular_values : singular values of the weighted Jacobian at the estimate (all
        parameters, descending).
    iterations : Levenberg–Marquardt iterations.
    n_simulations : simulations run (trajectory and derivatives included).
    jacobian : how the derivatives were obtained ("sensitivities" or "finite-differences").
    converged : True for a returned fit (an unconverged one raises :class:`FitError`).
    status : why the iteration stopped ("step", "gradient", "cost", or a failure).
    activity : contact -> counts of impacts, sliding impacts and slip intervals in the fitted
        trajectory (what the data can reveal about each contact's coefficients).
    """

    parameter_names: tuple[str, ...]
    estimates: np.ndarray
    standard_errors: np.ndarray
    confidence_intervals: np.ndarray
    confidence_level: float
    covariance: np.ndarray
    identifiable: Mapping[str, bool]
    verdicts: Mapping[str, str]
    notes: tuple[str, ...]
    initial: np.ndarray
    coefficients: Mapping[str, tuple[float, float]]
    times: np.ndarray
    channels: tuple[str, ...]
    observed: np.ndarray
    fitted: np.ndarray
    residuals: np.ndarray
    noise: np.ndarray
    noise_estimated: bool
    degrees_of_freedom: int
    cost: float
    reduced_chi_square: float
    singular_values: np.ndarray
    iterations: int
    n_simulations: int
    jacobian: str
    converged: bool
    status: str
    activity: Mapping[str, Mapping[str, int]] = field(
        default_factory=lambda: MappingProxyType({}))

    def _index(self, name: str) -> int:
        if name not in self.parameter_names:
            raise UnknownOptionError(f"unknown parameter {name!r}; the fit's parameters: "
                                     f"{', '.join(self.parameter_names)}")
        return self.parameter_names.index(name)

    def estimate(self, name: str) -> float:
        """The estimate of one parameter."""
        return float(self.estimates[self._index(name)])

    def interval(self, name: str) -> tuple[float, float] | None:
        """The confidence interval of one parameter, or None when it is not identifiable."""
        i = self._index(name)
        if not self.identifiable[name]:
            return None
        lo, hi = self.confidence_intervals[i]
        return float(lo), float(hi)

    @property
    def correlation(self) -> np.ndarray:
        """(n, n) correlation matrix of the estimates (NaN where not identifiable)."""
        se = self.standard_errors
        with np.errstate(invalid="ignore", divide="ignore"):
            return self.covariance / np.outer(se, se)

    @property
    def rms_residual(self) -> float:
        """Root mean square of the (unweighted) residuals."""
        return float(np.sqrt(np.mean(self.residuals ** 2)))

    def confidence_ellipse(self, first: str = "e", second: str = "mu", *,
                           level: float | None = None, points: int = 200) -> np.ndarray:
        """Boundary of the joint confidence region of two parameters, (points, 2).

        The linearised region (p - p_hat)^T C^-1 (p - p_hat) <= q of the pair's 2x2
        covariance C, with q the chi-square(2) quantile (noise given) or 2 F(2, N - n)
        (noise estimated) at ``level`` (default: the fit's). Not cut to the bounds.
        """
        from scipy import stats

        i, j = self._index(first), self._index(second)
        if i == j:
            raise ParameterError("confidence_ellipse needs two different parameters")
        for name in (first, second):
            if not self.identifiable[name]:
                raise ParameterError(f"{name} is not identifiable from these data: it has no "
                                     "confidence region")
        level = self.confidence_level if level is None else in_range(
            "level", level, 0.0, 1.0, low_open=True, high_open=True)
        points = integer("points", points, minimum=3)
        if self.noise_estimated:
            q = 2.0 * stats.f.ppf(level, 2, self.degrees_of_freedom)
        else:
            q = stats.chi2.ppf(level, 2)
        C = self.covariance[np.ix_([i, j], [i, j])]
        w, V = np.linalg.eigh(C)
        a = np.linspace(0.0, 2.0 * np.pi, points)
        circle = np.stack([np.cos(a), np.sin(a)])
        return (self.estimates[[i, j]][:, None]
                + V @ (np.sqrt(np.maximum(w, 0.0) * q)[:, None] * circle)).T

    def as_dict(self) -> dict[str, Any]:
        """Plain-JSON view."""
        return {k: _jsonable(dict(v) if isinstance(v, Mapping) else getattr(self, k))
                for k, v in ((k, getattr(self, k)) for k in self.__dataclass_fields__)}


# --------------------------------------------------------------------------------------------
# the fit


def fit_coefficients(
    system,
    observations: Observations,
    *,
    parameters: Sequence[str] = ("e", "mu"),
    per_contact: bool = False,
    noise=None,
    initial: Mapping[str, float] | None = None,
    y0=None,
    t0: float = 0.0,
    jacobian: str = "sensitivities",
    confidence_level: float = 0.95,
    max_iterations: int = 50,
    xtol: float = 1e-8,
    gtol: float = 1e-8,
    ftol: float = 1e-12,
    finite_difference_step: float = 1e-5,
    simulate_options: Mapping[str, Any] | None = None,
) -> CoefficientFit:
    """Estimate e and mu from an observed trajectory, with confidence intervals.

    Parameters
    ----------
    system : Scene or Mechanism
        The model; its own coefficients are the starting point unless ``initial`` says
        otherwise. A bare mechanism needs ``y0``.
    observations : Observations
        Times, channels (coordinate names, ``"<name>_dot"`` for velocities) and values.
    parameters : sequence of {"e", "mu"}
        What to estimate; the others keep the system's values.
    per_contact : bool
        One e (and mu) per contact, named ``"e[contact]"``; default one shared by all.
    noise : float or sequence, optional
        The measurement noise's standard deviation (one, or one per channel): the residuals
        are weighted by 1 / noise and the covariance is (J^T J)^-1. Default: one common
        sigma, estimated from the residuals.
    initial : mapping, optional
        Starting values by parameter name, or by kind ("e", "mu") for all of that kind.
    y0 : initial state of the motion (default: the scene's), as in ``simulate``.
    t0 : float
        Start time of the motion (the observations lie after it).
    jacobian : {"sensitivities", "finite-differences"}
        How the trajectory's derivatives with respect to the parameters are obtained:
        the simulator's trajectory sensitivities at the observation times (one run with
        ``simulate(..., sensitivities=True)`` per iteration; default), or central differences
        of whole simulations (two runs per parameter; one-sided at a bound).
    confidence_level : float in (0, 1)
    max_iterations : int
        Levenberg–Marquardt iterations before giving up (:class:`FitError`).
    xtol, gtol, ftol : float
        Convergence: relative step below ``xtol``; largest cosine between a free
        parameter's Jacobian column and the residual below ``gtol``; relative decrease of
        the cost (actual and predicted) below ``ftol``.
    finite_difference_step : float
        Relative step of the finite differences (times max(1, |value|)).
    simulate_options : mapping, optional
        Options of :func:`convimpact.simulation.simulate` (law, method, rtol, atol, ...);
        the fit's simulations default to rtol = 1e-10, atol = 1e-12.

    Returns
    -------
    CoefficientFit

    Raises
    ------
    ShapeError, NonFiniteError, ParameterError, UnknownOptionError
        for malformed input (strings and booleans are not numbers; unknown channels,
        parameters or contacts are named);
    SimulationError
        when the simulation at the starting point does not reach the last observation;
    FitError
        when the iteration does not converge (the last iterate in ``.result``).
    """
    if not isinstance(observations, Observations):
        raise ParameterError(f"observations must be an Observations (times, values, "
                             f"channels), got {type(observations).__name__}")
    from ..simulation.simulate import _as_mechanism

    mech, _ = _as_mechanism(system)
    per_contact = boolean("per_contact", per_contact)
    jacobian = choice("jacobian", jacobian, JACOBIANS)
    level = in_range("confidence_level", confidence_level, 0.0, 1.0, low_open=True,
                     high_open=True)
    max_iterations = integer("max_iterations", max_iterations, minimum=1)
    xtol, gtol, ftol = (positive(n, v) for n, v in (("xtol", xtol), ("gtol", gtol),
                                                   ("ftol", ftol)))
    params = fit_parameters(mech, parameters, per_contact)
    p = len(observations.channels)
    sigma = None if noise is None else noise_vector(noise, p)
    x0 = initial_values(mech, params, initial)
    n_obs = observations.n_samples
    if sigma is None and n_obs <= len(params):
        raise ParameterError(f"{n_obs} observed number(s) cannot estimate {len(params)} "
                             "parameter(s) and the noise: give more samples or the noise")
    model = TrajectoryModel(system, observations, params, y0=y0, t0=t0,
                            simulate_options=simulate_options, step=finite_difference_step,
                            jacobian=jacobian)
    weights = 1.0 / (sigma if sigma is not None else np.ones(p))
    lo = np.array([q.bounds[0] for q in params])
    hi = np.array([q.bounds[1] for q in params])
    run = LevenbergMarquardt(model, observations.values, weights, lo, hi, max_iterations,
                              xtol, gtol, ftol)
    run.solve(x0)
    fit = _summarise(run, model, params, observations, sigma, level, x0, jacobian)
    if not run.converged:
        raise FitError(f"the fit did not converge after {run.iterations} iteration(s): "
                       f"{run.status}", result=fit)
    return fit


def _summarise(run, model, params, observations, sigma, level, x0, jacobian) -> CoefficientFit:
    """Covariance, intervals and identifiability at the last iterate."""
    from scipy import stats

    names = tuple(q.name for q in params)
    n = len(params)
    J, x, cost = run.J, run.x, run.cost
    activity = contact_activity(model.last_result, model.mech.contact_names)
    singular = np.linalg.svd(J, compute_uv=False) if J.size else np.zeros(0)
    norms = np.linalg.norm(J, axis=0)
    scale = max(norms.max() if n else 0.0, np.finfo(float).tiny)
    identifiable = norms > ZERO_SENSITIVITY * scale
    notes: list[str] = []
    for i, q in enumerate(params):
        if not identifiable[i]:
            notes.append(f"{q.name} is not identifiable: the observations do not depend on it "
                         f"({_why(q, activity)}); it is held at {x[i]:.6g}")
    # rank deficiency among the parameters the data do depend on
    idx = np.flatnonzero(identifiable)
    if idx.size > 1:
        Jn = J[:, idx] / norms[idx]
        _, s, Vt = np.linalg.svd(Jn, full_matrices=False)
        for k in np.flatnonzero(s < RANK_TOLERANCE * s[0]):
            direction = Vt[k] / norms[idx]  # back to the parameters' own units
            direction /= np.linalg.norm(direction)
            keep = np.abs(direction) > 0.05
            involved = idx[keep]
            notes.append(
                f"only a combination of {', '.join(names[i] for i in involved)} is determined: "
                f"moving ({', '.join(names[i] for i in involved)}) along "
                f"({', '.join(f'{d:.3g}' for d in direction[keep])}) leaves the observations "
                "unchanged")
            identifiable[involved] = False
    idx = np.flatnonzero(identifiable)
    n_obs = observations.n_samples
    dof = n_obs - idx.size
    if sigma is None:
        s2 = 2.0 * cost / dof if dof > 0 else np.nan
        noise = np.full(len(observations.channels), np.sqrt(s2))
        quantile = stats.t.ppf(0.5 + level / 2.0, dof) if dof > 0 else np.nan
        notes.append(f"noise estimated from the residuals: sigma = {np.sqrt(s2):.3g} "
                     f"({dof} degrees of freedom)")
    else:
        s2 = 1.0
        noise = sigma
        quantile = stats.norm.ppf(0.5 + level / 2.0)
    chi2 = 2.0 * cost / dof if sigma is not None and dof > 0 else np.nan
    if sigma is not None and dof > 0 and 2.0 * cost > stats.chi2.ppf(0.999, dof):
        notes.append(
            f"the residuals are {np.sqrt(chi2):.3g} times the given noise (chi-square "
            f"{2 * cost:.4g} on {dof} degrees of freedom, above its 99.9 % quantile "
            f"{stats.chi2.ppf(0.999, dof):.4g}): the model does not fit these data -- a local "
            "minimum (start elsewhere) or a model error -- and the intervals do not hold")
    cov = np.full((n, n), np.nan)
    if idx.size:
        A = J[:, idx].T @ J[:, idx]
        cov[np.ix_(idx, idx)] = s2 * np.linalg.inv(A)
    se = np.sqrt(np.diag(cov))
    ci = np.stack([x - quantile * se, x + quantile * se], axis=1)
    verdicts = {}
    for i, q in enumerate(params):
        lo, hi = q.bounds
        if not identifiable[i]:
            verdicts[q.name] = "not identifiable"
            continue
        raw = ci[i].copy()
        ci[i] = np.clip(ci[i], lo, hi)
        if raw[0] < lo or raw[1] > hi:
            notes.append(f"the interval of {q.name} is cut to the bound(s) [{lo:g}, {hi:g}]")
        if x[i] in (lo, hi):
            notes.append(f"{q.name} = {x[i]:g} lies on its bound: the linearised interval is "
                         "only indicative")
        width = (hi - lo) if np.isfinite(hi) else max(1.0, abs(x[i]))
        if raw[1] - raw[0] > width:
            verdicts[q.name] = "weakly identified"
            notes.append(f"{q.name} is weakly identified: its {level:.0%} interval is wider "
                         f"than {width:g}")
        else:
            verdicts[q.name] = "identified"
    fitted = run.predicted
    return CoefficientFit(
        parameter_names=names, estimates=x.copy(), standard_errors=se, confidence_intervals=ci,
        confidence_level=level, covariance=cov,
        identifiable=MappingProxyType({q.name: bool(identifiable[i])
                                       for i, q in enumerate(params)}),
        verdicts=MappingProxyType(verdicts), notes=tuple(notes), initial=np.asarray(x0),
        coefficients=MappingProxyType(model.coefficients(x)), times=observations.times,
        channels=observations.channels, observed=observations.values, fitted=fitted,
        residuals=observations.values - fitted, noise=np.asarray(noise, float),
        noise_estimated=sigma is None, degrees_of_freedom=int(dof), cost=float(cost),
        reduced_chi_square=float(chi2),
        singular_values=singular, iterations=run.iterations,
        n_simulations=model.n_simulations, jacobian=jacobian, converged=run.converged,
        status=run.status,
        activity=MappingProxyType({c: MappingProxyType(v) for c, v in activity.items()}))


def _why(q, activity) -> str:
    """Why a parameter leaves the data unchanged, from what its contacts did."""
    if q.kind == "mu":
        slid = sum(activity[c]["sliding_impacts"] + activity[c]["slip_intervals"]
                   for c in q.contacts)
        if not slid:
            bound = max(activity[c]["stick_friction_ratio"] for c in q.contacts)
            below = (f"; the data bound it only from below, {q.name} >= {bound:.4g}, the "
                     "friction ratio |tangential| / normal its sticking impacts and forces "
                     "needed" if bound > 0 else "")
            return (f"{'contact ' + q.contacts[0] if len(q.contacts) == 1 else 'no contact'} "
                    f"{'never slides' if len(q.contacts) == 1 else 'slides'}: every impact "
                    f"sticks or is frictionless and no sustained contact slips{below}")
        return "its effect is below the Jacobian's resolution"
    hits = sum(activity[c]["impacts"] for c in q.contacts)
    if not hits:
        return (f"{'contact ' + q.contacts[0] if len(q.contacts) == 1 else 'no contact'} "
                f"{'never impacts' if len(q.contacts) == 1 else 'impacts'} within the "
                "observed span")
    return "its effect is below the Jacobian's resolution"
