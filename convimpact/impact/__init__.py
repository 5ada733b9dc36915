"""One impact: the problem, the laws, the solver paths, the result.

The data path inside this package:

* :mod:`~convimpact.impact.problem` validates ``M, Jc, dq, e, mu, C`` and reduces them to
  contact space (the Delassus matrix W with closed loops folded in, eqs. 43-52);
* :mod:`~convimpact.impact.resolve` picks a law and a solver path (``resolve_impact``,
  ``solve_problem``, the registry of ``(law, method)`` solvers);
* :mod:`~convimpact.impact.laws` holds one module per law: its definition, its exact
  single-contact kernel and its cone program(s); :mod:`~convimpact.impact.fast` dispatches one
  contact to the kernels, which share :mod:`~convimpact.impact.small_linalg` (2x2, 3x3 solves
  on floats), :mod:`~convimpact.impact.boundary` (roots on the cone's boundary) and
  :mod:`~convimpact.impact.max_dissipation` (the direction of eq. 60);
  :mod:`~convimpact.impact.conic` solves any law's cone program with Clarabel (directly or
  through cvxpy); :mod:`~convimpact.impact.sweep` is the paper's own 1-D search of the angle;
* :mod:`~convimpact.impact.diagnostics` turns an impulse into an
  :class:`~convimpact.impact.results.ImpactResult` with the law's invariants measured;
* :mod:`~convimpact.impact.energy` holds the paper's energy formulas (eqs. 58-62);
* :mod:`~convimpact.impact.errors` is the exception hierarchy the whole library raises.
"""

from __future__ import annotations

from . import errors
from .energy import (
    StictionInterval,
    central_energy_loss,
    energy_loss,
    oblique_coefficients,
    oblique_energy_loss,
    stiction_interval,
)
from .closed_forms import (
    frictionless_impulse,
    pereira_nikravesh,
    sliding_impulse,
    stick_admissible,
    sticking_impulse,
)
from .batch import ContactBatch, ImpactBatch, contact_impulses, resolve_impacts
from .problem import ImpactProblem, build_problem
from .resolve import (
    LAWS,
    METHODS,
    available_methods,
    check_law_method,
    choose_method,
    register_solver,
    resolve_impact,
    solve_problem,
)
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
