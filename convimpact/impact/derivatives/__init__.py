"""Exact derivatives of impact laws (issue "Derivatives").

A law's derivative is written once, beside its kernel: each law module offers
``impulse_derivative(problem, result, other_side=False) -> ContactDerivative`` (one contact)
and ``several_impulse_derivative(problem, result, other_side=False) -> ContactDerivative``
(several contacts), the derivative of its contact-frame impulse with respect to its
contact-space data ``(W, v_minus, e, mu[, e_t])`` inside the mode the answer is in.  This
package maps that derivative to the arguments of :func:`convimpact.resolve_impact` (``dq``,
``M``, ``Jc``, ``e``, ``mu``) by the chain rule through ``W = Jc G Jc^T``,
``v_minus = Jc dq`` and ``dq_plus = dq + G Jc^T pi`` (:mod:`.chain`), and attaches them to the
result (:mod:`.attach`).

* :mod:`.contact`: the contract, :class:`ContactDerivative`;
* :mod:`.modes`: the equations of the laws' contact modes (separate, frictionless, stick,
  eq. (55)'s slide, the cone slides of the programs, of Coulomb's law and of P_N), at one
  contact or several, differentiated implicitly;
* :mod:`.single`: the one-contact driver (the mode boundaries a contact meets) and
  :func:`~.single.law_entry`, which makes a law's ``impulse_derivative`` from its modes;
* :mod:`.chain`: :func:`impact_jacobians`, :func:`projected_inverse`;
* :mod:`.attach`: :func:`with_derivatives`, :func:`law_derivative`, :func:`check_derivatives`.
"""

from ..results import ImpactDerivatives
from .attach import DERIVATIVE_MODES, check_derivatives, law_derivative, with_derivatives
from .chain import impact_jacobians, projected_inverse
from .contact import ContactDerivative

__all__ = ["ContactDerivative", "ImpactDerivatives", "impact_jacobians", "projected_inverse",
           "with_derivatives", "law_derivative", "check_derivatives", "DERIVATIVE_MODES"]
