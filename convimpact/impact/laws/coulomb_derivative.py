"""The derivative of law "coulomb" for one contact, beside its kernel (:mod:`.coulomb`).

Its modes, with b = ((1 + e) v_n, v_t) and u = W pi + b (the Newton-shifted post-impact
velocity):

* stick: ``u = 0`` (W pi = -b), differentiated as a linear solve;
* slide: ``u_n = 0``, ``u_t = -sigma t`` with ``t = pi_t / |pi_t|`` and ``|pi_t| = mu pi_n``
  (friction opposing the post-impact slip at full strength), differentiated implicitly with
  the slip speed sigma -- in the plane t = +-1 is held, in space the direction moves with the
  data;
* frictionless (mu = 0): Newton's impulse; the right derivative with respect to mu is the
  slide's against the frictionless answer's post-impact slip.

The impulse is continuous at the stick limit (sigma = 0 there), where the derivative is
one-sided. Where the law has several sliding solutions the derivative is that of the one
returned (the most dissipative).
"""

from __future__ import annotations

from ..derivatives.contact import ContactDerivative
from ..derivatives.modes import cone_slide, frictionless, mu_zero_column, stick, stick_impulse
from ..derivatives.single import one_contact_derivative

LAW = "coulomb"


def _mode(W, v, e, mu, et, regime, p):
    if regime == "frictionless":
        return frictionless(W, v, e)
    if regime == "stick":
        return stick(W, v, e, p)
    return cone_slide("coulomb", W, v, e, mu, p)


def impulse_derivative(problem, result, other_side: bool = False) -> ContactDerivative:
    """Derivative of the Coulomb impulse of one contact with respect to (W, v_minus, e, mu).

    Parameters
    ----------
    problem : ImpactProblem
        The validated one-contact impact.
    result : ImpactResult
        The law's answer (any method): its impulse and regime select the mode.
    other_side : bool
        At a mode boundary, also give the neighbouring mode's derivative.

    Returns
    -------
    ContactDerivative
    """
    return one_contact_derivative(
        problem, result, LAW, _mode, other_side=other_side,
        stick_of=lambda W, v, e, mu, et: stick_impulse(W, v, e),
        mu_zero=lambda W, v, e, et: mu_zero_column("coulomb", W, v, e))
