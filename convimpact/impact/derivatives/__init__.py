"""Exact derivatives of impact laws (issue "Derivatives").

A law's derivative is written once, beside its kernel: each law module offers
``impulse_derivative(problem, result) -> ContactDerivative`` (one contact) and
``several_impulse_derivative(problem, result) -> ContactDerivative`` (several contacts), the
derivative of its contact-frame impulse with respect to its contact-space data
``(W, v_minus, e, mu[, e_t])`` inside the mode the answer is in.  This package maps that
derivative to the arguments of :func:`convimpact.resolve_impact` (``dq``, ``M``, ``Jc``,
``e``, ``mu``) by the chain rule through ``W = Jc G Jc^T``, ``v_minus = Jc dq`` and
``dq_plus = dq + G Jc^T pi``.
"""

from .contact import ContactDerivative

__all__ = ["ContactDerivative"]
