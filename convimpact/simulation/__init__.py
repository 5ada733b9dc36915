"""Canonical equations of motion and event-driven simulation (Section 2.2, piece-wise analysis).

>>> from convimpact.simulation import simulate
>>> from convimpact.simulation.testing import PointMass
>>> res = simulate(PointMass(e=0.5), (0.0, 0.5), (np.array([0.0, 1.0]), np.zeros(2)))
>>> round(res.impacts[0].time, 9) == round(float(np.sqrt(2 / 9.81)), 9)
True
"""

import numpy as np  # noqa: F401  (used by the doctest)

from .canonical import CanonicalEquations
from .events import PenetrationError
from .projection import project_positions, project_velocities
from .result import ContactEvent, ImpactEvent, PiecewiseSolution, SimulationResult
from .saltation import EventSensitivity
from .simulate import INTEGRATORS, simulate
from .zeno import Accumulation, AccumulationDetector
from .schemes import SCHEMES, simulate_with  # noqa: F401  (moreau-jean, compliant)

__all__ = [
    "simulate",
    "SimulationResult",
    "ImpactEvent",
    "ContactEvent",
    "EventSensitivity",
    "PiecewiseSolution",
    "CanonicalEquations",
    "PenetrationError",
    "project_positions",
    "project_velocities",
    "Accumulation",
    "AccumulationDetector",
    "INTEGRATORS",
]
