"""convimpact: impact dynamics of multibody systems with frictional contact.

Joint coordinates, canonical equations of motion and impulse-momentum balance after
Pereira & Nikravesh (1996), with impact laws posed as maximal-dissipation convex programs.

The public API:

>>> import convimpact as ci
>>> r = ci.resolve_impact(M, Jc, dq, e=0.5, mu=0.3)          # doctest: +SKIP
"""

from __future__ import annotations

from . import errors
from .closed_form import (
    frictionless_impulse,
    pereira_nikravesh,
    sliding_impulse,
    stick_admissible,
    sticking_impulse,
)
from .energy import (
    StictionInterval,
    central_energy_loss,
    energy_loss,
    oblique_coefficients,
    oblique_energy_loss,
    stiction_interval,
)
from .errors import *  # noqa: F401,F403  (the exception hierarchy is public)
from .impact import LAWS, METHODS, available_methods, resolve_impact, solve_problem
from .problem import ImpactProblem, build_problem
from .results import ImpactDiagnostics, ImpactResult

__version__ = "0.1.0"

__all__ = [
    "resolve_impact",
    "solve_problem",
    "build_problem",
    "available_methods",
    "ImpactProblem",
    "ImpactResult",
    "ImpactDiagnostics",
    "LAWS",
    "METHODS",
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
    *errors.__all__,
]
