"""Exception hierarchy of convimpact.

Every error the library raises on purpose derives from :class:`ConvImpactError`, so research
code can catch one type. The subclasses also derive from the matching built-in exception
(``ValueError``, ``ArithmeticError``, ``RuntimeError``, ``NotImplementedError``), so generic
handlers keep working. Messages say what to change.
"""

from __future__ import annotations


class ConvImpactError(Exception):
    """Base class of every error raised by convimpact."""


class InputError(ConvImpactError, ValueError):
    """An argument is malformed or out of its admissible range."""


class ShapeError(InputError):
    """Arrays have the wrong shape or do not agree with each other."""


class NonFiniteError(InputError):
    """An input contains NaN or infinity."""


class MassMatrixError(InputError):
    """The generalized mass matrix is not symmetric positive definite."""


class ParameterError(InputError):
    """A physical parameter is out of range (e outside [0, 1], mu < 0, ...)."""


class UnknownOptionError(InputError):
    """An unknown law, method or option name was given."""


class LoopConstraintError(InputError):
    """The loop-constraint Jacobian C is rank deficient or inconsistent with the velocities."""


class PenetrationError(InputError):
    """A simulation starts in a state that already penetrates a contact (gap < 0 beyond tolerance).

    Start from a state with every gap >= 0 (raise the mechanism, or move the contact surface).
    """


class ModelError(InputError):
    """A mechanism model is ill-defined (unknown body or joint, bad mass or inertia, ...)."""


class SingularSystemError(ConvImpactError, ArithmeticError):
    """A matrix that the chosen branch must invert is singular (Delassus or loop matrix)."""


class NonPositiveEffectiveMassError(SingularSystemError):
    """The sliding denominator c_n^T M^-1 (c_n + mu c_t) is not positive (Painleve-like jam).

    Under Newton's law with Coulomb friction at this mu the normal impulse of eq. (38)/(51)
    would be infinite or negative. Use a convex law (``law="coulomb"``, ``"ccp"`` or
    ``"dissipative"``), which stay well posed, or lower mu below the critical value
    reported in the message.
    """


class SolverError(ConvImpactError, RuntimeError):
    """A numerical solver failed: infeasible, unbounded, or not converged."""


class AssemblyError(ConvImpactError, RuntimeError):
    """A closed loop could not be assembled (Newton iteration on Psi(theta) = 0 failed)."""


class SimulationError(ConvImpactError, RuntimeError):
    """The event-driven simulation could not proceed."""


class NotSupportedError(ConvImpactError, NotImplementedError):
    """The requested method cannot treat this case; the message names one that can."""




class PainleveError(SimulationError):
    """Painleve's paradox in sustained contact: the contact force problem of a sliding contact
    has no solution (inconsistent) or several (indeterminate).

    A sliding contact whose effective normal mass in the slip direction,
    c_n^T G (c_n - mu c_t s), is not positive can make Coulomb's rigid-body problem ill posed.
    Lower mu below the critical value, model the contact as compliant
    (``simulate_with(scheme="compliant")``) or use the time-stepping scheme
    (``scheme="moreau-jean"``), which resolves it with an impulse.

    Attributes
    ----------
    event : the :class:`~convimpact.simulation.result.PainleveEvent`, or None.
    result : the run's :class:`~convimpact.simulation.result.SimulationResult` up to the
        paradox (set when the simulator raises it), or None.
    """

    def __init__(self, message: str, event=None, result=None):
        super().__init__(message)
        self.event = event
        self.result = result


__all__ = [
    "ConvImpactError",
    "InputError",
    "ShapeError",
    "NonFiniteError",
    "MassMatrixError",
    "ParameterError",
    "UnknownOptionError",
    "LoopConstraintError",
    "PenetrationError",
    "ModelError",
    "SingularSystemError",
    "NonPositiveEffectiveMassError",
    "SolverError",
    "AssemblyError",
    "SimulationError",
    "NotSupportedError",
    "PainleveError",
]
