"""One impact: the problem, the laws, the solver paths, the result -- in the order an impact
takes them (each folder's docstring tells its part in a few lines):

1. :mod:`~convimpact.impact.problem`: validate ``M, Jc, dq, e, mu, C`` and reduce them to
   contact space: the Delassus matrix W (closed loops folded in, eqs. 43-52) and v-;
2. :mod:`~convimpact.impact.laws`: one module per law -- its definition, its exact
   single-contact kernel (compiled: the only implementation, which every path runs), its cone
   program(s) -- and the compiled algebra they share; the table ``LAW_MODULES`` lists them;
3. the solver paths, which :mod:`~convimpact.impact.resolve` picks from an explicit table
   (``resolve_impact``, ``solve_problem``):
   :mod:`~convimpact.impact.exact` (the kernels, one contact: the compiled lane, the paper's
   closed forms and sweep), :mod:`~convimpact.impact.several` (several contacts on the
   contact engine, :mod:`convimpact.contacts`), :mod:`~convimpact.impact.conic` (any law's
   cone program by Clarabel, directly or through cvxpy: the cross-check); :mod:`~convimpact.impact.batch` drives the same kernels
   over many impacts at once;
4. :mod:`~convimpact.impact.diagnostics` turns an impulse into an
   :class:`~convimpact.impact.results.ImpactResult` with the law's invariants measured;
   :mod:`~convimpact.impact.energy` holds the paper's energy formulas (eqs. 58-62).

:mod:`~convimpact.impact.derivatives` differentiates an answer exactly (``resolve_impact(...,
derivatives=True)``): each law's ``impulse_derivative`` beside its kernel, then the chain rule
to the derivatives of dq_plus and of the impulse with respect to dq, M, Jc, e and mu.

:mod:`~convimpact.errors` is the exception hierarchy the whole library raises.
"""

from __future__ import annotations

from .. import errors
from .energy import (StictionInterval, central_energy_loss, energy_loss, oblique_coefficients,
                     oblique_energy_loss, stiction_interval)
from .exact.closed_forms import (frictionless_impulse, pereira_nikravesh, sliding_impulse,
                                 stick_admissible, sticking_impulse)
from .batch.impacts import ContactBatch, ImpactBatch, contact_impulses, resolve_impacts
from .problem.build import ImpactProblem, build_problem
from .resolve import (LAWS, METHODS, available_methods, check_law_method, choose_method,
                      register_solver, resolve_impact, solve_problem)
from .results import ImpactDiagnostics, ImpactResult

__all__ = [
    "resolve_impact",
    "resolve_impacts",
    "contact_impulses",
    "ImpactBatch",
    "ContactBatch",
    "solve_problem",
    "register_solver",
    "available_methods",
    "check_law_method",
    "choose_method",
    "LAWS",
    "METHODS",
    "ImpactProblem",
    "build_problem",
    "ImpactResult",
    "ImpactDiagnostics",
    "energy_loss",
    "central_energy_loss",
    "oblique_energy_loss",
    "oblique_coefficients",
    "stiction_interval",
    "StictionInterval",
    "frictionless_impulse",
    "sticking_impulse",
    "sliding_impulse",
    "stick_admissible",
    "pereira_nikravesh",
    "errors",
]
