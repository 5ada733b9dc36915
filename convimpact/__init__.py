"""convimpact: impact dynamics of multibody systems with frictional contact.

Joint coordinates, canonical equations of motion and impulse-momentum balance after
Pereira & Nikravesh (1996), with impact laws posed as maximal-dissipation convex programs.

The public API:

>>> import convimpact as ci
>>> r = ci.resolve_impact(M, Jc, dq, e=0.5, mu=0.3)          # doctest: +SKIP
"""

from __future__ import annotations

from . import errors
from .impact import (
    LAWS,
    METHODS,
    ImpactBatch,
    contact_impulses,
    resolve_impacts,
    ImpactDiagnostics,
    ImpactProblem,
    ImpactResult,
    StictionInterval,
    available_methods,
    build_problem,
    central_energy_loss,
    energy_loss,
    frictionless_impulse,
    oblique_coefficients,
    oblique_energy_loss,
    pereira_nikravesh,
    resolve_impact,
    solve_problem,
    stick_admissible,
    sticking_impulse,
    sliding_impulse,
    stiction_interval,
)
from .errors import *  # noqa: F401,F403  (the exception hierarchy is public)
from .mechanism import Mechanism
from .scenes import Scene, list_scenes, load_scene


#: the public names that load on first use (so ``import convimpact`` stays light), by the
#: module that holds them
_LAZY = {
    "simulate": "convimpact.simulation",
    "solve_contact_problem": "convimpact.contacts.contact_problem",
    "ContactSolution": "convimpact.contacts.contact_problem",
    "UncertifiedSolutionError": "convimpact.contacts.contact_problem",
    "impact_arguments": "convimpact.model",
    "resolve_mechanism_impact": "convimpact.model",
    "ModelBuilder": "convimpact.model",
    "Joint": "convimpact.model",
    "place_resting": "convimpact.model",
    "rest_velocity": "convimpact.model",
}


def __getattr__(name):
    # heavier layers load on first use, so ``import convimpact`` stays light
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'convimpact' has no attribute {name!r}")
    import importlib

    return getattr(importlib.import_module(module), name)


def __dir__():
    # dir() and tab completion list the lazy names too, before their first use
    return sorted(set(globals()) | set(_LAZY))

__version__ = "0.1.0"

__all__ = [
    "solve_contact_problem",
    "ContactSolution",
    "UncertifiedSolutionError",
    "resolve_impacts",
    "contact_impulses",
    "ImpactBatch",
    "resolve_impact",
    "solve_problem",
    "simulate",
    "Mechanism",
    "Scene",
    "list_scenes",
    "load_scene",
    "impact_arguments",
    "resolve_mechanism_impact",
    "ModelBuilder",
    "Joint",
    "place_resting",
    "rest_velocity",
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
