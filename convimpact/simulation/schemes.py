"""``simulate_with``: one entry point for the three ways of simulating impacts.

* ``"event-driven"`` -- :func:`convimpact.simulation.simulate`: impacts located in time and
  resolved by the chosen impact law (exact up to the integrator's tolerance);
* ``"moreau-jean"`` -- :func:`convimpact.simulation.moreau.simulate_moreau`: fixed-step time
  stepping with a velocity-level impact law on each step (impacts smeared over a step);
* ``"compliant"`` -- :func:`convimpact.simulation.compliant.simulate_compliant`: penalty
  forces (Hunt–Crossley / Lankarani–Nikravesh) with a stiff integrator (penetration, contact
  durations, effective restitution set by the force law).

All three return a :class:`~convimpact.simulation.SimulationResult` (the last two a subclass
with the scheme's own figures), so results compare sample for sample.

>>> import numpy as np
>>> from convimpact.simulation.schemes import simulate_with
>>> from convimpact.simulation.testing import PointMass
>>> y0 = (np.array([0.0, 1.0]), np.zeros(2))
>>> r = simulate_with(PointMass(e=0.5), (0.0, 0.5), y0, scheme="moreau-jean", h=1e-3)
>>> bool(abs(r.impacts[0].dtheta_plus[1] - 0.5 * np.sqrt(2 * 9.81)) < 0.01)
True
"""

from __future__ import annotations

from typing import Any, Sequence

from ..errors import ParameterError, UnknownOptionError
from .compliant import simulate_compliant
from .moreau import simulate_moreau
from .result import SimulationResult
from .simulate import simulate

SCHEMES = ("event-driven", "moreau-jean", "compliant")


def _scheme_options() -> dict[str, dict]:
    """The options of the schemes other than event-driven (whose ``simulate`` checks its
    own), declared once and checked by :func:`simulate_with` before the scheme runs (a string
    such as ``h="1e-3"`` is refused, not converted). The integration controls (rtol, atol,
    max_step, first_step) are checked against the span by
    :func:`convimpact.validation.integration_controls`."""
    from ..validation import (NonNegative, OrNone, PerContact, Positive, Real, Unit,
                              Choice, Flag)

    common = {"projection_tol": Positive(), "contact_tol": Positive(), "assemble": Flag()}
    return {
        "moreau-jean": {"h": Positive(), "theta": Unit(), "gap_tol": Real(),
                        "rest_velocity": NonNegative(), **common},
        "compliant": {"model": Choice(("hunt-crossley", "lankarani-nikravesh")),
                      "stiffness": PerContact(Positive()), "exponent": Positive(),
                      "e": OrNone(PerContact(Unit())), "mu": OrNone(PerContact(NonNegative())),
                      "regularization_velocity": Positive(),
                      "min_impact_velocity": NonNegative(), "event_tol": Positive(), **common},
    }


#: options checked against the span (convimpact.validation.integration_controls)
_CONTROLS = ("rtol", "atol", "max_step", "first_step")


def simulate_with(system, t_span: Sequence[float] | None = None, y0=None, *,
                  scheme: str = "event-driven", **options: Any) -> SimulationResult:
    """Simulate ``system`` with the named scheme.

    Parameters
    ----------
    system, t_span, y0 :
        As in :func:`convimpact.simulation.simulate` (for "moreau-jean" and "compliant" y0 is a
        tuple (theta0, dtheta0)).
    scheme : {"event-driven", "moreau-jean", "compliant"}
    **options :
        The scheme's own keyword arguments: ``law``, ``method``, ``rtol``... for event-driven;
        ``h`` (required), ``theta``, ``law``, ``method`` for Moreau–Jean; ``stiffness``
        (required), ``model``, ``exponent``, ``e``, ``mu``, ``integrator``, ``rtol``... for
        compliant.

    Returns
    -------
    SimulationResult (MoreauResult, CompliantResult)

    Raises
    ------
    UnknownOptionError
        for an unknown scheme or an option the scheme does not take (the message lists them);
    NotSupportedError
        for ``sensitivities=True`` with a scheme other than "event-driven" (``False`` is
        accepted and ignored);
    ParameterError, NonFiniteError, ShapeError
        for an option's value of the wrong type or out of its declared range (e.g. ``h="1e-3"``,
        ``max_step=0``), checked before the scheme runs and naming the option.
    """
    fns = {"event-driven": simulate, "moreau-jean": simulate_moreau,
           "compliant": simulate_compliant}
    if scheme not in fns:
        raise UnknownOptionError(f"unknown simulation scheme {scheme!r}; choose one of "
                                 f"{', '.join(SCHEMES)}")
    fn = fns[scheme]
    if scheme != "event-driven" and "sensitivities" in options:
        from ..validation import boolean
        if boolean("sensitivities", options.pop("sensitivities")):
            from ..errors import NotSupportedError
            raise NotSupportedError(
                f"sensitivities=True: trajectory sensitivities (saltation matrices, "
                f"state_transition) are computed by the event-driven scheme only, not by "
                f"{scheme!r}; use scheme='event-driven' (convimpact.simulation.simulate)")
    import inspect

    accepted = [p.name for p in inspect.signature(fn).parameters.values()
                if p.kind == p.KEYWORD_ONLY]
    unknown = sorted(set(options) - set(accepted))
    if unknown:
        raise UnknownOptionError(f"scheme {scheme!r} takes no option(s) {', '.join(unknown)}; "
                                 f"its options are {', '.join(accepted)}")
    required = [p.name for p in inspect.signature(fn).parameters.values()
                if p.kind == p.KEYWORD_ONLY and p.default is p.empty and p.name not in options]
    if required:
        raise ParameterError(f"scheme {scheme!r} needs option(s) {', '.join(required)} "
                             "(e.g. the step h for moreau-jean, the stiffness for compliant)")
    specs = _scheme_options().get(scheme)
    if specs:
        from ..validation import MAX_STEPS, check_parameters, integration_controls
        from .initial import time_span
        from .simulate import _as_mechanism

        given = {k: v for k, v in options.items() if k in specs}
        options.update(check_parameters(f"scheme {scheme!r}", specs, given))
        controls = {k: options[k] for k in _CONTROLS if k in options}
        if controls or scheme == "moreau-jean":
            t0, t1 = time_span(t_span, _as_mechanism(system)[1])
            options.update(integration_controls(t0, t1, **controls))
            if scheme == "moreau-jean" and (t1 - t0) / options["h"] > MAX_STEPS:
                raise ParameterError(
                    f"scheme 'moreau-jean': h = {options['h']:g} needs more than {MAX_STEPS:g} "
                    f"steps over the span t1 - t0 = {t1 - t0:g}; take h >= "
                    f"{(t1 - t0) / MAX_STEPS:g}")
    return fn(system, t_span, y0, **options)
