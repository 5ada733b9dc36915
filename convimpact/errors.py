"""Exception hierarchy of convimpact.

Every error the library raises on purpose derives from :class:`ConvImpactError`, so research
code can catch one type. The subclasses also derive from the matching built-in exception
(``ValueError``, ``ArithmeticError``, ``RuntimeError``, ``NotImplementedError``), so generic
handlers keep working. Messages say what to change.

:func:`as_real_array` and :func:`real_number` are the typed conversions of inputs: an array
entry that is a string, a boolean, a complex number or None is a :class:`ShapeError` (for the
physical parameters e, mu a :class:`ParameterError`) whose message names the entry; numpy
scalars and arrays of real type (float32, int64, ...) are accepted.
"""

from __future__ import annotations

import numbers

import numpy as np


class ConvImpactError(Exception):
    """Base class of every error raised by convimpact."""


class InputError(ConvImpactError, ValueError):
    """An argument is malformed or out of its admissible range."""


class ShapeError(InputError):
    """Arrays have the wrong shape or do not agree with each other, or are not arrays of real
    numbers (an entry that is a string, a boolean, a complex number or None)."""


class NonFiniteError(InputError):
    """An input contains NaN or infinity, or the impact leaves double precision's range.

    The second case is an overflow (or an underflow to zero) of a quantity the answer needs --
    the Delassus matrix, the contact velocities, the impulse or the velocity jump -- for data
    whose units are far apart (e.g. M ~ 1e300 with Jc ~ 1e-10); rescale the units.
    """


class MassMatrixError(InputError):
    """The generalized mass matrix is not symmetric positive definite."""


class ParameterError(InputError):
    """A physical parameter is out of range (e outside [0, 1], mu < 0, ...) or is not a real
    number (a string such as '0.5', a boolean, a complex number)."""


class DegenerateContactError(InputError):
    """A contact Jacobian's normal row is zero together with its tangent rows (the whole
    contact Jacobian is zero), or is numerically zero relative to M's scale (c_n^T M^-1 c_n
    underflows double precision).

    Such a contact cannot approach, separate or take a normal impulse: check the contact frame
    (a zero normal vector) and the Jacobian's assembly, or leave the contact out. (A zero
    normal row whose tangent rows move mass -- a grazing contact at a singular configuration,
    such as a pendulum's tip at the bottom of its swing -- is not an error: it cannot approach,
    so it is "separating", and the diagnostics say so.)
    """


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



# --------------------------------------------------------------------------------------------
# typed conversion of inputs: which error a string, a boolean or a complex number raises

_F64 = np.dtype(np.float64)
_NOUNS = {"M": "a real mass matrix", "Jc": "a real contact Jacobian", "dq": "real velocities",
          "C": "a real loop Jacobian", "e": "real coefficients of restitution",
          "mu": "real coefficients of friction"}


def _kind_of(x) -> str | None:
    """'bool', 'str', 'complex' or 'none' for an entry that is not a real number, else None."""
    if isinstance(x, (bool, np.bool_)):
        return "bool"
    if isinstance(x, (str, bytes, np.str_, np.bytes_)):
        return "str"
    if isinstance(x, (complex, np.complexfloating)):
        return "complex"
    if x is None:
        return "none"
    return None


def _entry_error(name: str, kind: str, entry, error: type) -> Exception:
    noun = _NOUNS.get(name, "real numbers")
    if kind == "bool":
        return error(f"{name} has a boolean entry ({entry!r}); pass {noun}, not True/False")
    if kind == "str":
        return error(f"{name} has a string entry ({entry!r}); pass numbers (a numeric array), "
                     "not text")
    if kind == "complex":
        return error(f"{name} has a complex entry ({entry!r}); pass {noun}")
    if kind == "none":
        return error(f"{name} has an entry None; pass {noun}")
    return error(f"{name} must be a numeric array, got an entry of type "
                 f"{type(entry).__name__} ({entry!r})")


def _scan(name: str, value, error: type) -> None:
    """Raise on the first boolean/str/complex/None entry of nested lists and tuples (numpy
    would silently turn ``[1.0, True]`` into ``[1.0, 1.0]``)."""
    for x in value:
        if isinstance(x, (list, tuple)):
            _scan(name, x, error)
        elif isinstance(x, np.ndarray):
            if x.dtype.kind in "bUSc":
                raise _entry_error(name, _array_kind(x), x.flat[0] if x.size else x, error)
        else:
            kind = _kind_of(x)
            if kind is not None:
                raise _entry_error(name, kind, x, error)


def _array_kind(a: np.ndarray) -> str:
    return {"b": "bool", "U": "str", "S": "str", "c": "complex"}.get(a.dtype.kind, "other")


def as_real_array(name: str, value, error: type = ShapeError) -> np.ndarray:
    """``value`` as a float64 array of real numbers.

    Accepts numpy arrays of float, int or unsigned dtype (float32 included), numpy scalars of
    real type, Python numbers and nested sequences of them, and object arrays of real numbers.

    Raises
    ------
    error (ShapeError by default)
        for a string, a boolean, a complex number or None anywhere in ``value`` (the message
        names the entry), or for something that is not an array of numbers at all (e.g. a
        ragged nested list).
    """
    if type(value) is np.ndarray:
        if value.dtype == _F64:
            return value
        a = value
    else:
        kind = _kind_of(value)
        if kind is not None:
            raise error(f"{name} must be a numeric array, got {type(value).__name__} {value!r}")
        if isinstance(value, (list, tuple)):
            _scan(name, value, error)
        try:
            a = np.asarray(value)
        except (TypeError, ValueError) as exc:  # ragged nested sequences
            raise error(f"{name} must be a numeric array, got {type(value).__name__} that "
                        f"numpy cannot read as one ({exc})") from exc
    k = a.dtype.kind
    if k in "fiu":
        return a.astype(float)
    if k == "O":
        out = np.empty(a.shape)
        flat = out.reshape(-1)
        for i, x in enumerate(a.flat):
            kind = _kind_of(x)
            if kind is not None:
                raise _entry_error(name, kind, x, error)
            try:
                flat[i] = float(x)
            except (TypeError, ValueError):
                raise _entry_error(name, "other", x, error) from None
            except OverflowError:  # an int beyond double precision (10**400)
                raise NonFiniteError(f"{name} has an entry beyond double precision's range "
                                     f"({_short(x)}); rescale the units") from None
        return out
    if k in "bUSc":
        raise _entry_error(name, _array_kind(a), a.flat[0] if a.size else a, error)
    raise error(f"{name} must be a numeric array, got dtype {a.dtype}")


def real_number(name: str, value, error: type = ParameterError) -> float:
    """``value`` as a Python float; a string, a boolean or a complex number raises ``error``.

    Python and numpy numbers of real type (int, float, np.float32, np.int64, ...), 0-d arrays
    of them and other numbers that convert to float (Fraction, Decimal) are accepted; arrays
    with entries are not. Finiteness is not checked.
    """
    t = type(value)
    if t is float:
        return value
    kind = _kind_of(value)
    if kind is None:
        if isinstance(value, (np.floating, np.integer, numbers.Real)):
            try:
                return float(value)
            except OverflowError:  # an int beyond double precision (10**400)
                raise NonFiniteError(f"{name} = {_short(value)} is beyond double precision's "
                                     "range") from None
        if isinstance(value, np.ndarray):
            if value.ndim == 0:
                return real_number(name, value[()], error)
        else:
            try:
                return float(value)
            except (TypeError, ValueError):
                pass
    if value is None:
        raise error(f"{name} must be a real number, got None")
    what = {"bool": "bool", "complex": "complex"}.get(kind, type(value).__name__)
    raise error(f"{name} must be a real number, got {what} {value!r}")


def _short(x) -> str:
    text = repr(x)
    return text if len(text) <= 24 else f"{text[:10]}...{text[-6:]} ({len(text)} digits)"


def contact_inputs(W, v, e, mu=None) -> tuple:
    """(W, v, e) of one contact, or (W, v, e, mu) when ``mu`` is given, converted in that
    order by :func:`as_real_array` and :func:`real_number`."""
    W, v, e = as_real_array("W", W), as_real_array("v", v), real_number("e", e)
    return (W, v, e) if mu is None else (W, v, e, real_number("mu", mu))


__all__ = [
    "ConvImpactError",
    "InputError",
    "ShapeError",
    "NonFiniteError",
    "MassMatrixError",
    "ParameterError",
    "DegenerateContactError",
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
