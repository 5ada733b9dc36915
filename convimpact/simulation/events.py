"""Event location on a step's dense output: contact gaps closing, held contacts' forces vanishing.

Event functions are the contacts' signed gaps (terminal, direction -1: only closing counts) and,
for persistent contacts, their normal forces (terminal, direction -1: the force turning
tensile releases the contact). Roots are located by Brent's method on the step's interpolant
to an absolute time tolerance ``xtol``.
"""

from __future__ import annotations

from typing import Callable

import numpy as np
from scipy.optimize import brentq

from ..errors import PenetrationError  # noqa: F401  (re-exported for convimpact.simulation)


def locate_crossing(fun: Callable[[float], float], ta: float, tb: float, fa: float, fb: float,
                    xtol: float) -> float:
    """Earliest time in (ta, tb] where ``fun`` goes from > 0 to <= 0, given fa > 0 >= fb.

    Brent's method with absolute tolerance ``xtol``; the bracket's right end is returned, so
    ``fun`` at the result is <= 0 up to the interpolation accuracy (the event is never
    located after the contact has opened again).
    """
    if fb == 0.0:
        return tb
    root, r = brentq(fun, ta, tb, xtol=xtol, rtol=4 * np.finfo(float).eps, full_output=True)
    # brentq returns a point within xtol of the root; prefer the side where fun <= 0
    if fun(root) > 0.0:
        root = min(root + xtol, tb)
    return float(root)


def reclosing(fun: Callable[[float], float], ta: float, tb: float, g0: float, v0: float,
              gb: float, xtol: float) -> float | None:
    """Closing of a contact that starts the step touching (just impacted or released).

    With ``g0 = fun(ta)`` (about 0, possibly slightly negative) and the separation speed
    ``v0 = d fun/dt (ta) > 0``, the event function ``h(t) = (fun(t) - g0) / (t - ta)`` starts
    at ``v0 > 0`` and is negative once the gap has come back to its starting level, so the
    re-closing is bracketed without the start itself being a root.

    Returns the re-closing time in (ta, tb], or None when the gap has not come back.
    """
    dt = tb - ta
    hb = (gb - g0) / dt
    if hb > 0.0 or v0 <= 0.0:
        return None

    def h(t: float) -> float:
        return (fun(t) - g0) / (t - ta)

    a = ta + 1e-9 * dt
    ha = h(a)
    if ha <= 0.0:  # returns below its start within 1e-9 of the step: use the sampled start
        return a
    return locate_crossing(h, a, tb, ha, hb, xtol)
