"""Attach the derivatives to an impact's result: the law's contact-space derivative (its
module's ``impulse_derivative`` for one contact, ``several_impulse_derivative`` for several),
mapped by the chain rule (:mod:`.chain`) to ``result.jacobian`` and
``result.impulse_jacobian``, with the record :class:`~convimpact.impact.results.ImpactDerivatives`
and the one-sided statements in the diagnostics."""

from __future__ import annotations

import inspect
from typing import Mapping

import numpy as np

from ...errors import NotSupportedError, SingularSystemError, UnknownOptionError
from ..laws import TANGENTIAL_LAWS, law_module
from ..problem.build import ImpactProblem, _new
from ..results import ImpactDerivatives, ImpactResult
from .chain import impact_jacobians, zero_derivative

#: the values of ``derivatives=`` (False: none; "both": the other side's too at a mode
#: boundary; "velocity": as True, but where redundant contacts leave the impulse non-unique
#: the minimum-norm derivative, exact for dq_plus and v_plus, is given instead of an error)
DERIVATIVE_MODES = (False, True, "both", "velocity")


def check_derivatives(derivatives) -> bool | str:
    """``derivatives=`` validated: False, True, "both" or "velocity" (UnknownOptionError
    otherwise; a number is not a boolean)."""
    if derivatives is False or derivatives is True or type(derivatives) is np.bool_:
        return bool(derivatives)
    if type(derivatives) is str and derivatives in ("both", "velocity"):
        return derivatives
    raise UnknownOptionError(
        f"derivatives must be False, True, 'both' (the other side's too at a mode boundary) "
        f"or 'velocity' (redundant contacts: the derivative exact for the velocities), got "
        f"{derivatives!r} of type {type(derivatives).__name__}")


def law_derivative(problem: ImpactProblem, result: ImpactResult, law: str,
                   other_side: bool = False, redundant: str = "raise"):
    """The law's :class:`~convimpact.impact.derivatives.contact.ContactDerivative` at its
    answer; NotSupportedError naming the law when its module has none for this many contacts.
    ``redundant`` ("raise" or "velocity") goes to the several-contact derivatives that take
    it (redundant contacts: the impulse is not unique, the velocity is)."""
    n = problem.n_contacts
    name = "impulse_derivative" if n == 1 else "several_impulse_derivative"
    if n > 1 and all(v > 0.0 for v in problem.v_minus[:, 0]):
        # every contact strictly separating: no impulse now or nearby
        return zero_derivative(problem, ("separating",) * n, law in TANGENTIAL_LAWS)
    fn = getattr(law_module(law), name, None)
    if fn is None:
        where = "one contact" if n == 1 else f"{n} simultaneous contacts"
        raise NotSupportedError(
            f"law {law!r} has no derivative at {where} ({name} is not provided by its module)")
    if redundant != "raise" and "redundant" in inspect.signature(fn).parameters:
        return fn(problem, result, other_side=other_side, redundant=redundant)
    return fn(problem, result, other_side=other_side)


def with_derivatives(problem: ImpactProblem, result: ImpactResult, law: str,
                     derivatives: bool | str,
                     scalar: Mapping[str, bool] | None = None) -> ImpactResult:
    """``result`` with ``jacobian``, ``impulse_jacobian`` and ``derivatives`` filled in.

    ``scalar`` says per argument ("e", "mu", "e_t") whether the caller gave one value for every
    contact (its key then has shape ``(k,)``); by default, one contact passed as one Jacobian
    has scalar arguments and several contacts per-contact ones.
    """
    if scalar is None:
        scalar = dict.fromkeys(("e", "mu", "e_t"), problem.single)
    both = derivatives == "both"
    cd = law_derivative(problem, result, law, other_side=both,
                        redundant="velocity" if derivatives == "velocity" else "raise")
    jac, ijac = impact_jacobians(problem, result.impulse, cd, scalar)
    if not all(np.isfinite(a).all() for a in jac.values()):
        raise SingularSystemError(
            f"law {law!r}: the derivative of this impact is not finite (a singular or "
            "degenerate mode, or units beyond double precision's range); it is not returned")
    other = cd.other_side if both else None
    ojac = oijac = None
    if other is not None:
        at = result.impulse if other.impulse is None else other.impulse
        ojac, oijac = impact_jacobians(problem, at, other, scalar)
    record = ImpactDerivatives(modes=tuple(cd.regimes), one_sided=tuple(cd.one_sided),
                               other_modes=None if other is None else tuple(other.regimes),
                               other_jacobian=ojac, other_impulse_jacobian=oijac)
    diagnostics = result.diagnostics
    if cd.one_sided:
        diagnostics = diagnostics.with_notes(
            *(f"one-sided derivative: {s}" for s in cd.one_sided))
    # a copy of the frozen result with the derivatives (its fields set as its __init__ would)
    return _new(type(result), {**vars(result), "jacobian": jac, "impulse_jacobian": ijac,
                               "derivatives": record, "diagnostics": diagnostics})
