"""The keyword options each solver method takes, and the check the single-contact methods
make of their options and of the problem's contact count.

A leaf: the methods (:mod:`.exact`, :mod:`.laws`) and the solver table
(:mod:`.resolve`) import it, it imports nothing of theirs.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import NotSupportedError, ParameterError, UnknownOptionError

#: the keyword options each method takes (``resolve_impact(..., **options)``; defaults and
#: meanings in its docstring's table): the methods' own option checks accept exactly these
METHOD_OPTIONS: dict[str, tuple[str, ...]] = {
    "closed-form": (),
    "sweep": ("xtol", "n_grid"),
    "fast": (),
    "interior": ("tol", "max_iter", "newton_iter"),
    "clarabel": ("tol", "max_iter", "fixed_point_tol", "max_fixed_point_iter",
                 "anderson_memory"),
    "cvxpy": ("tol", "max_iter", "fixed_point_tol", "max_fixed_point_iter",
              "anderson_memory"),
}


def options_help() -> str:
    """One line naming every method's options (for the messages of UnknownOptionError)."""
    by = "; ".join(f"{m}: {', '.join(o) if o else 'none'}" for m, o in METHOD_OPTIONS.items())
    return (f"options by method -- {by} (under method='auto' they go to the method it picks; "
            "see resolve_impact's docstring)")


def check_single_contact(problem, options, method: str, takes: str, several: str) -> None:
    """Refuse a single-contact method's unknown ``options`` (message ``method 'm' takes
    <takes> got a, b``) and a problem of several contacts (:class:`NotSupportedError` saying
    ``several``, which may name the count as ``{n}``)."""
    if options:
        raise UnknownOptionError(f"method {method!r} takes {takes} got "
                                 f"{', '.join(sorted(options))}; {options_help()}")
    if problem.n_contacts != 1:
        raise NotSupportedError(several.format(n=problem.n_contacts))


def parse_method_options(method: str, options: dict, fields: type, minimum: dict[str, int]):
    """The options of an iterative method as the frozen dataclass ``fields`` (its defaults
    where not given): an unknown name raises UnknownOptionError; a ``float`` field must be a
    number in (0, 1), an ``int`` field an integer >= ``minimum[name]`` (ParameterError;
    booleans are neither)."""
    known = fields.__dataclass_fields__
    unknown = sorted(set(options) - set(known))
    if unknown:
        raise UnknownOptionError(
            f"method {method!r} does not know option(s) {', '.join(unknown)}; "
            f"it accepts {', '.join(known)}")
    out = fields(**options)
    for name, f in known.items():
        v = getattr(out, name)
        if f.type == "float":
            if isinstance(v, bool) or not (isinstance(v, (int, float, np.floating))
                                           and math.isfinite(v) and 0.0 < v < 1.0):
                raise ParameterError(f"option {name} must be a number in (0, 1), got {v!r}")
        elif isinstance(v, bool) or not (isinstance(v, (int, np.integer)) and v >= minimum[name]):
            raise ParameterError(f"option {name} must be a "
                                 f"{'positive' if minimum[name] else 'non-negative'} integer, "
                                 f"got {v!r}")
    return out
