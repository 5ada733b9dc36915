"""Checks of the arguments a user passes, done once at the door of every public entry point.

What a user can rely on
-----------------------
Every public entry point -- ``resolve_impact``, ``resolve_impacts``, ``contact_impulses``,
``simulate``, ``simulate_with`` and each scheme's options, ``load_scene`` and every scene's
parameters, the studies and the command line -- checks its arguments before any work starts:

* **Bad input raises a subclass of** :class:`convimpact.ConvImpactError` (which also derives
  from ``ValueError``), never another exception, never a silent NaN or inf, never a partial
  answer: :class:`~convimpact.errors.ShapeError` (wrong shape, or not an array of real
  numbers), :class:`~convimpact.errors.NonFiniteError` (NaN or infinity, or an answer
  that leaves double precision's range), :class:`~convimpact.errors.ParameterError`
  (out of range, or not a number: strings such as ``"1e-3"``, booleans, complex numbers and
  None are refused, not converted), :class:`~convimpact.errors.UnknownOptionError` (an
  unknown name; the message lists the known ones), and the physics' own errors
  (``MassMatrixError``, ``DegenerateContactError``, ``SingularSystemError``, ...).
* **The message names the argument you passed** (``radius``, ``t_span``, ``max_step``,
  ``--workers``), what was expected and what was received -- not a quantity derived from it.
* **Numbers are real numbers**: Python ``int`` and ``float``, numpy real scalars and 0-d arrays
  are accepted; ``bool``, ``str``, ``complex`` and None are not. Counts (``max_impacts``,
  ``n_grid``, ``workers``, ``repeats``) are integers: ``2.5`` and ``"10"`` are refused, an
  integral float such as ``1e4`` is accepted.
* **A solver that did not converge never returns an answer** (``SolverError``); a run that
  cannot proceed raises ``SimulationError`` or stops with a status saying why.
* **Runs never hang on their arguments**: a step bound or a Moreau-Jean step that would need
  more than :data:`MAX_STEPS` steps, or tolerances below what double precision can honour
  (``atol`` < :data:`ATOL_MIN`), are refused before the run.
* **The command line** exits with status 2 and one line naming the option (``convimpact
  simulate: error: argument --t-end: expected a positive finite number, got 'nan'``, or
  ``convimpact: error: ...`` for a value the library refuses), never a traceback.
  ``convimpact simulate`` writes ``result.json`` last and whole (under a temporary name,
  renamed once the plots are written): a run that fails leaves no result that looks
  complete. A study checks its arguments before it creates its store, and removes a store it
  created when it fails before any chunk is done; a store with finished chunks stays, and
  the same command resumes it.

This module holds the small reusable checkers (:func:`real`, :func:`positive`,
:func:`integer`, :func:`choice`, :func:`vector`, :func:`time_span`, ...), the declarative
parameter specs a scene lists its parameters with (:class:`Real`, :class:`Integer`,
:class:`Choice`, :class:`Flag`, :class:`Vector`, :func:`check_parameters`), and argparse
types for the command line (:func:`arg_finite`, :func:`arg_positive_int`, ...). The typed
conversions of arrays and numbers are the core's (:func:`convimpact.errors.as_real_array`
and :func:`~convimpact.errors.real_number`); this module adds finiteness, ranges,
integers, choices and shapes on top of them.
"""

from __future__ import annotations

import argparse
import math
from dataclasses import dataclass
from typing import Any, Iterable, Mapping, Sequence

import numpy as np

from .errors import (
    NonFiniteError,
    ParameterError,
    ShapeError,
    UnknownOptionError,
    as_real_array,
    real_number,
)

__all__ = [
    "real", "finite", "positive", "nonnegative", "in_range", "integer", "choice", "boolean",
    "vector", "grid", "time_span", "sorted_times", "mapping",
    "Spec", "Real", "Positive", "NonNegative", "Unit", "Integer", "Choice", "Flag", "Vector",
    "OrNone", "PerContact", "check_parameters", "integration_controls", "ATOL_MIN", "MAX_STEPS",
    "arg_finite", "arg_positive", "arg_positive_int", "arg_nonnegative_int", "arg_unit",
]


# --------------------------------------------------------------------------------------------
# scalars


def real(name: str, value, *, error: type = ParameterError, allow_nan: bool = False,
         allow_inf: bool = False) -> float:
    """``value`` as a float: a real number (not bool, str, complex, None), finite unless
    ``allow_inf`` / ``allow_nan`` (NonFiniteError)."""
    x = real_number(name, value, error)
    if math.isnan(x) and not allow_nan:
        raise NonFiniteError(f"{name} must be a finite number, got nan")
    if math.isinf(x) and not allow_inf:
        raise NonFiniteError(f"{name} must be a finite number, got {x!r}")
    return x


def finite(name: str, value, *, error: type = ParameterError) -> float:
    """A finite real number."""
    return real(name, value, error=error)


def positive(name: str, value, *, allow_inf: bool = False, error: type = ParameterError
             ) -> float:
    """A real number > 0 (finite unless ``allow_inf``)."""
    x = real(name, value, error=error, allow_inf=allow_inf)
    if not x > 0.0:
        raise error(f"{name} must be positive, got {x!r}")
    return x


def nonnegative(name: str, value, *, allow_inf: bool = False, error: type = ParameterError
                ) -> float:
    """A real number >= 0 (finite unless ``allow_inf``)."""
    x = real(name, value, error=error, allow_inf=allow_inf)
    if not x >= 0.0:
        raise error(f"{name} must be >= 0, got {x!r}")
    return x


def in_range(name: str, value, low: float | None = None, high: float | None = None, *,
             low_open: bool = False, high_open: bool = False, error: type = ParameterError
             ) -> float:
    """A finite real number in the interval [low, high] (or open at either end)."""
    x = real(name, value, error=error)
    if not _within(x, low, high, low_open, high_open):
        raise error(f"{name} must be {_interval(low, high, low_open, high_open)}, got {x!r}")
    return x


def _within(x: float, low, high, low_open: bool, high_open: bool) -> bool:
    if low is not None and not (x > low if low_open else x >= low):
        return False
    if high is not None and not (x < high if high_open else x <= high):
        return False
    return True


def _interval(low, high, low_open: bool, high_open: bool) -> str:
    """'> 0', '>= 0', '<= 1', 'in [0, 1]', 'in (0, 1]', or 'any real number'."""
    if low is not None and high is None:
        return f"{'>' if low_open else '>='} {low:g}"
    if high is not None and low is None:
        return f"{'<' if high_open else '<='} {high:g}"
    if low is None and high is None:
        return ""
    return f"in {'(' if low_open else '['}{low:g}, {high:g}{')' if high_open else ']'}"


def integer(name: str, value, *, minimum: int | None = None, maximum: int | None = None,
            error: type = ParameterError) -> int:
    """An integer count: a Python or numpy integer, or an integral finite float (``1e4``);
    bool, str, 2.5 and None are refused."""
    if isinstance(value, (bool, np.bool_, str, bytes)) or value is None:
        raise error(f"{name} must be an integer, got {type(value).__name__} {value!r}")
    if isinstance(value, (int, np.integer)):
        n = int(value)
    else:
        x = real_number(name, value, error)
        if not (math.isfinite(x) and x == math.floor(x)):
            raise error(f"{name} must be an integer, got {value!r}")
        n = int(x)
    if minimum is not None and n < minimum:
        raise error(f"{name} must be an integer >= {minimum}, got {n}")
    if maximum is not None and n > maximum:
        raise error(f"{name} must be an integer <= {maximum}, got {n}")
    return n


def choice(name: str, value, options: Iterable[str]) -> str:
    """One of ``options`` (UnknownOptionError listing them otherwise)."""
    options = tuple(options)
    if not isinstance(value, str) or value not in options:
        raise UnknownOptionError(f"unknown {name} {value!r}; choose one of "
                                 f"{', '.join(map(repr, options))}")
    return value


def boolean(name: str, value) -> bool:
    """True or False (numpy's too); 1, "yes" and None are refused."""
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    raise ParameterError(f"{name} must be True or False, got {type(value).__name__} {value!r}")


def mapping(name: str, value) -> dict[str, Any]:
    """A mapping with string keys (None: empty)."""
    if value is None:
        return {}
    if not isinstance(value, Mapping):
        raise ParameterError(f"{name} must be a mapping of option names to values (a dict), "
                             f"got {type(value).__name__} {value!r}")
    bad = [k for k in value if not isinstance(k, str)]
    if bad:
        raise ParameterError(f"{name} must have string keys (option names), got {bad[0]!r}")
    return dict(value)


#: smallest absolute tolerance of an integration: below it the error norms of scipy's
#: integrators overflow (|f| / atol squared) and the run fails inside scipy
ATOL_MIN = 1e-100
#: steps a run may be forced to take by its step bound (span / max_step at most this)
MAX_STEPS = 5_000_000


def integration_controls(t0: float, t1: float, **controls) -> dict[str, Any]:
    """An integrator's controls over the span [t0, t1], checked -- the ones passed among
    ``rtol``, ``atol``, ``max_step``, ``first_step``: rtol > 0; atol >= :data:`ATOL_MIN`;
    max_step > 0 (inf: no bound) and at least span / :data:`MAX_STEPS` (a finer bound would
    never end); first_step None (the integrator's choice) or > 0, at most the span and above
    the round-off of t (100 eps max(|t0|, |t1|, span)). Returns them as floats (first_step
    may stay None)."""
    unknown = set(controls) - {"rtol", "atol", "max_step", "first_step"}
    if unknown:
        raise UnknownOptionError(f"unknown integration control(s) {', '.join(sorted(unknown))}")
    out: dict[str, Any] = {}
    span = t1 - t0
    if "rtol" in controls:
        out["rtol"] = positive("rtol", controls["rtol"])
    if "atol" in controls:
        out["atol"] = a = positive("atol", controls["atol"])
        if a < ATOL_MIN:
            raise ParameterError(f"atol must be >= {ATOL_MIN:g} (below it the integrator's "
                                 f"error norm overflows), got {a!r}")
    if "max_step" in controls:
        out["max_step"] = m = positive("max_step", controls["max_step"], allow_inf=True)
        if m < span / MAX_STEPS:
            raise ParameterError(
                f"max_step = {m:g} would need more than {MAX_STEPS:g} steps over the span "
                f"t1 - t0 = {span:g}; take max_step >= {span / MAX_STEPS:g}")
    if "first_step" in controls:
        f = controls["first_step"]
        if f is not None:
            f = positive("first_step", f)
            floor = 100.0 * np.finfo(float).eps * max(abs(t0), abs(t1), span)
            if not floor <= f <= span:
                raise ParameterError(f"first_step must lie in [{floor:g}, {span:g}] (above "
                                     f"the round-off of t, at most the span), got {f!r}")
        out["first_step"] = f
    return out


# --------------------------------------------------------------------------------------------
# arrays


def vector(name: str, value, size: int | None = None, *, allow_nonfinite: bool = False
           ) -> np.ndarray:
    """A 1-D float array of real numbers (a scalar is refused), of ``size`` entries when
    given, finite unless ``allow_nonfinite``."""
    a = as_real_array(name, value)
    if a.ndim != 1:
        raise ShapeError(f"{name} must be a 1-D sequence of numbers, got shape {a.shape}")
    if size is not None and a.shape[0] != size:
        raise ShapeError(f"{name} must have {size} entries, got {a.shape[0]}")
    if not allow_nonfinite and not np.isfinite(a).all():
        raise NonFiniteError(f"{name} contains NaN or infinity: {a.tolist()}; pass finite "
                             "values")
    return a


def grid(name: str, value) -> np.ndarray:
    """A study's grid of values: a real number or a 1-D sequence of them, as a non-empty 1-D
    float array (finiteness and range are the caller's: e in [0, 1], signed mu, angles)."""
    a = np.atleast_1d(as_real_array(name, value))
    if a.ndim != 1 or a.size == 0:
        raise ShapeError(f"{name} must be a number or a non-empty 1-D sequence of numbers, "
                         f"got shape {a.shape}")
    return a


def time_span(name: str, value) -> tuple[float, float]:
    """(t0, t1), finite real numbers with t0 < t1."""
    if isinstance(value, (str, bytes)) or not isinstance(value, (Sequence, np.ndarray)):
        raise ShapeError(f"{name} must be a pair (t0, t1) of numbers, got "
                         f"{type(value).__name__} {value!r}")
    ts = as_real_array(name, value)
    if ts.shape != (2,):
        raise ShapeError(f"{name} must be a pair (t0, t1) of numbers, got {value!r}")
    if not np.isfinite(ts).all():
        raise NonFiniteError(f"{name} must be finite, got {ts.tolist()}")
    t0, t1 = float(ts[0]), float(ts[1])
    if not t1 > t0:
        raise ParameterError(f"{name} must be increasing (t0 < t1), got ({t0:g}, {t1:g})")
    return t0, t1


def sorted_times(name: str, value, t0: float, t1: float) -> np.ndarray:
    """A non-decreasing 1-D array of finite times within [t0, t1]."""
    a = as_real_array(name, value).ravel()
    if not np.isfinite(a).all():
        raise NonFiniteError(f"{name} contains NaN or infinity; pass finite times")
    if a.size and (np.any(np.diff(a) < 0) or a[0] < t0 or a[-1] > t1):
        raise ParameterError(f"{name} must be sorted and lie within t_span [{t0:g}, {t1:g}]")
    return a


# --------------------------------------------------------------------------------------------
# declarative parameter specs (a scene's PARAMETERS)


class Spec:
    """A parameter's type and range; :meth:`check` returns the value converted or raises."""

    def check(self, name: str, value):  # pragma: no cover - abstract
        raise NotImplementedError

    def describe(self) -> str:  # pragma: no cover - abstract
        raise NotImplementedError


@dataclass(frozen=True)
class Real(Spec):
    """A finite real number in [low, high] (either end open or absent)."""

    low: float | None = None
    high: float | None = None
    low_open: bool = False
    high_open: bool = False

    def check(self, name: str, value) -> float:
        return in_range(name, value, self.low, self.high, low_open=self.low_open,
                        high_open=self.high_open)

    def describe(self) -> str:
        return " ".join(("a finite real number", _interval(self.low, self.high, self.low_open,
                                                           self.high_open))).rstrip()


def Positive() -> Real:  # noqa: N802 - a spec constructor
    """A finite real number > 0."""
    return Real(0.0, low_open=True)


def Unit() -> Real:  # noqa: N802
    """A real number in [0, 1] (e)."""
    return Real(0.0, 1.0)


def NonNegative() -> Real:  # noqa: N802
    """A finite real number >= 0 (mu)."""
    return Real(0.0)


@dataclass(frozen=True)
class Integer(Spec):
    """An integer in [low, high]."""

    low: int | None = None
    high: int | None = None

    def check(self, name: str, value) -> int:
        return integer(name, value, minimum=self.low, maximum=self.high)

    def describe(self) -> str:
        return " ".join(("an integer", _interval(self.low, self.high, False, False))).rstrip()


@dataclass(frozen=True)
class Choice(Spec):
    """One of the given strings."""

    options: tuple[str, ...]

    def check(self, name: str, value) -> str:
        return choice(name, value, self.options)

    def describe(self) -> str:
        return "one of " + ", ".join(map(repr, self.options))


@dataclass(frozen=True)
class Flag(Spec):
    """True or False."""

    def check(self, name: str, value) -> bool:
        return boolean(name, value)

    def describe(self) -> str:
        return "True or False"


@dataclass(frozen=True)
class Vector(Spec):
    """A sequence of ``size`` real numbers, each checked by ``entry``."""

    size: int
    entry: Spec = Real()

    def check(self, name: str, value) -> tuple:
        a = vector(name, value, self.size)
        return tuple(self.entry.check(f"{name}[{i}]", x) for i, x in enumerate(a.tolist()))

    def describe(self) -> str:
        return f"{self.size} numbers, each {self.entry.describe()}"


@dataclass(frozen=True)
class OrNone(Spec):
    """None, or a value checked by ``spec``."""

    spec: Spec

    def check(self, name: str, value):
        return None if value is None else self.spec.check(name, value)

    def describe(self) -> str:
        return f"None or {self.spec.describe()}"


@dataclass(frozen=True)
class PerContact(Spec):
    """One value for every contact (checked by ``spec``), or a mapping from contact names to
    values (each checked by ``spec``; the names are checked by the model)."""

    spec: Spec

    def check(self, name: str, value):
        if isinstance(value, Mapping):
            bad = [k for k in value if not isinstance(k, str)]
            if bad:
                raise ParameterError(f"{name} must map contact names to values, got key "
                                     f"{bad[0]!r}")
            return {k: self.spec.check(f"{name}[{k!r}]", v) for k, v in value.items()}
        return self.spec.check(name, value)

    def describe(self) -> str:
        return f"{self.spec.describe()}, or a mapping contact -> such a value"


def check_parameters(owner: str, specs: Mapping[str, Spec], values: Mapping[str, Any]
                     ) -> dict[str, Any]:
    """Check ``values`` against ``specs`` (unknown names raise UnknownOptionError listing the
    known ones); returns the converted values. Errors name ``owner`` and the parameter."""
    unknown = [k for k in values if k not in specs]
    if unknown:
        raise UnknownOptionError(
            f"{owner} has no parameter {', '.join(map(repr, unknown))}; its parameters: "
            f"{', '.join(specs) or 'none'}")
    out = {}
    for key, value in values.items():
        try:
            out[key] = specs[key].check(key, value)
        except (ParameterError, ShapeError, NonFiniteError, UnknownOptionError) as exc:
            expected = specs[key].describe()
            note = "" if expected in str(exc) else f" (expected {expected})"
            raise type(exc)(f"{owner}: {exc}{note}") from None
    return out


# --------------------------------------------------------------------------------------------
# argparse types: a bad value is argparse's usage error (exit status 2), naming the option


def _arg(checker, what: str):
    def convert(text: str):
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {what}, got {text!r}") from None
        try:
            return checker(value)
        except (ParameterError, NonFiniteError) as exc:
            raise argparse.ArgumentTypeError(f"expected {what}, got {text!r}") from exc

    convert.__name__ = what
    return convert


def _int_arg(minimum: int, what: str):
    def convert(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {what}, got {text!r}") from None
        if value < minimum:
            raise argparse.ArgumentTypeError(f"expected {what}, got {text!r}")
        return value

    convert.__name__ = what
    return convert


#: a finite number (nan, inf refused)
arg_finite = _arg(lambda x: finite("value", x), "a finite number")
#: a positive finite number
arg_positive = _arg(lambda x: positive("value", x), "a positive finite number")
#: a number in [0, 1]
arg_unit = _arg(lambda x: in_range("value", x, 0.0, 1.0), "a number in [0, 1]")
#: an integer >= 1
arg_positive_int = _int_arg(1, "an integer >= 1")
#: an integer >= 0
arg_nonnegative_int = _int_arg(0, "an integer >= 0")

