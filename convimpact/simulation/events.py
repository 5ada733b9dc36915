"""Event location on a step's dense output: contact gaps closing, held contacts' forces vanishing.

Event functions are the contacts' signed gaps (terminal, direction -1: only closing counts) and,
for persistent contacts, their normal forces (terminal, direction -1: the force turning
tensile releases the contact). Roots are located by Brent's method on the step's interpolant
to an absolute time tolerance ``xtol``.
"""

from __future__ import annotations

from typing import Callable

import numpy as np
from scipy.optimize import brentq, minimize_scalar

from ..errors import PenetrationError  # noqa: F401  (re-exported for convimpact.simulation)


def locate_crossing(fun: Callable[[float], float], ta: float, tb: float, fa: float, fb: float,
                    xtol: float, known: dict | None = None) -> float:
    """Earliest time in (ta, tb] where ``fun`` goes from > 0 to <= 0, given fa > 0 >= fb.

    Brent's method with absolute tolerance ``xtol``; the bracket's right end is returned, so
    ``fun`` at the result is <= 0 up to the interpolation accuracy (the event is never
    located after the contact has opened again). ``fa`` and ``fb`` stand for ``fun`` at the
    bracket's ends and no point is evaluated twice (each evaluation of a held group's
    margin can be a cone program: the box stack's two located events evaluated 6 of 25
    twice; ``known``, optional: values of ``fun`` already computed, time -> value, shared
    and added to).
    """
    if fb == 0.0:
        return tb
    known = {} if known is None else known
    known.update({ta: fa, tb: fb})

    def once(x: float) -> float:
        v = known.get(x)
        if v is None:
            v = known[x] = fun(x)
        return v
    root, r = brentq(once, ta, tb, xtol=xtol, rtol=4 * np.finfo(float).eps, full_output=True)
    # brentq returns a point within xtol of the root; prefer the side where fun <= 0
    if once(root) > 0.0:
        root = min(root + xtol, tb)
    return float(root)


#: interior samples of a step's interpolant checked for a gap dipping below zero and back
DIP_SAMPLES = 8


class FastInterpolant:
    """A one-step integrator's dense output evaluated as one weighted sum.

    scipy's ``Dop853DenseOutput`` and ``RkDenseOutput`` evaluate their polynomial with a
    Python loop of array operations (tens of microseconds per call); event location calls
    them hundreds of times per run. Here the polynomial's weights are computed on Python
    floats and applied in one product: the same polynomial, equal to scipy's to rounding.
    Scalars give ``(n,)``, 1-D arrays of times ``(n, len(t))``, as scipy's.
    """

    def __init__(self, interp):
        self.t_old, self.t, self.h = interp.t_old, interp.t, interp.h
        self.y_old = interp.y_old
        dop = hasattr(interp, "F")
        self._dop = dop
        self._C = np.ascontiguousarray(interp.F if dop else interp.Q.T * interp.h)
        self._n = self._C.shape[0]

    def _weights(self, x):
        """The polynomial's weights at x (a float, or an array of them: then per column)."""
        n = self._n
        w = [x] * n
        if not self._dop:  # RK: h Q [x, x^2, ...]
            for i in range(1, n):
                w[i] = w[i - 1] * x
            return w
        # DOP853: y = (((F[-1] x + F[-2]) (1 - x) + F[-3]) x + ...): F[-1-i] carries the
        # product of the multipliers from the i-th on (x for even i, 1 - x for odd)
        prod = 1.0
        for i in range(n - 1, -1, -1):
            prod = prod * (x if i % 2 == 0 else 1.0 - x)
            w[n - 1 - i] = prod
        return w

    def __call__(self, t):
        if np.ndim(t) == 0:
            x = (float(t) - self.t_old) / self.h
            return np.dot(self._weights(x), self._C) + self.y_old
        x = (np.asarray(t, dtype=float) - self.t_old) / self.h
        return self._C.T @ np.array(self._weights(x)) + self.y_old[:, None]


def fast_interpolant(interp):
    """:class:`FastInterpolant` of scipy's DOP853 / RK23 / RK45 dense output, else
    ``interp`` itself."""
    from scipy.integrate._ivp.rk import Dop853DenseOutput, RkDenseOutput

    if type(interp) in (Dop853DenseOutput, RkDenseOutput):
        return FastInterpolant(interp)
    return interp


def first_dip(fun: Callable[[float], float], ta: float, tb: float, fa: float,
              n: int = DIP_SAMPLES,
              dfun: Callable[[float], float] | None = None,
              xtol: float = 1e-12) -> tuple[float, float, float, float] | None:
    """First sub-interval of (ta, tb) where ``fun`` (> 0 at ``ta``) dips to <= 0 inside the step.

    A sign test at the two ends of a step misses a gap that goes below zero and comes back
    within the step (long free-flight steps of a high-order integrator, a fast-spinning body).
    ``fun`` is sampled at ``n - 1`` equally spaced interior points; the first sample <= 0 and
    the sample before it (> 0) bracket the earliest crossing that the samples resolve.

    With the derivative ``dfun`` (the contact's normal velocity), a dip shorter than the sample
    spacing is also caught: on each sub-interval whose two samples are > 0, the cubic Hermite
    interpolant of the values and slopes is checked for a minimum near or below 0 (below a
    quarter of the smaller sample, a margin for the cubic's error); if it has one, the
    minimum of ``fun`` there is located (bounded Brent, to ``xtol``) and a value <= 0 brackets
    the crossing.

    Returns ``(a, b, fun(a), fun(b))`` for :func:`locate_crossing`, or None when no dip is
    found (then only the end values decide, as before).
    """
    if not fa > 0.0 or n < 2:
        return None
    a, f_a = ta, fa
    d_a = dfun(ta) if dfun is not None else None
    u = np.linspace(0.0, 1.0, 17)[1:-1]
    h00, h10 = 2 * u**3 - 3 * u**2 + 1, u**3 - 2 * u**2 + u
    h01, h11 = -2 * u**3 + 3 * u**2, u**3 - u**2
    for j in range(1, n + 1):
        b = ta + (tb - ta) * j / n if j < n else tb
        f_b = fun(b)
        if f_b <= 0.0:
            return (a, b, f_a, f_b) if j < n else None  # at tb: the end-value test decides
        if dfun is not None:
            d_b = dfun(b)
            dt = b - a
            if d_a < 0.0 < d_b:  # a minimum inside: does the gap reach zero there?
                cubic = h00 * f_a + h10 * dt * d_a + h01 * f_b + h11 * dt * d_b
                if np.min(cubic) <= 0.25 * min(f_a, f_b):  # margin for the cubic's error
                    res = minimize_scalar(fun, bounds=(a, b), method="bounded",
                                          options={"xatol": xtol})
                    fm = fun(res.x)
                    if fm <= 0.0:
                        return a, float(res.x), f_a, fm
            d_a = d_b
        a, f_a = b, f_b
    return None


def reclosing(fun: Callable[[float], float], ta: float, tb: float, g0: float, v0: float,
              gb: float, xtol: float,
              dfun: Callable[[float], float] | None = None) -> float | None:
    """Closing of a contact that starts the step touching (just impacted or released).

    With ``g0 = fun(ta)`` (about 0, possibly slightly negative) and the separation speed
    ``v0 = d fun/dt (ta) > 0``, the event function ``h(t) = (fun(t) - g0) / (t - ta)`` starts
    at ``v0 > 0`` and is negative once the gap has come back to its starting level, so the
    re-closing is bracketed without the start itself being a root.

    When the gap is above its start at ``tb``, interior samples (:func:`first_dip`) still
    catch a return below the start level inside the step.

    The first point tried is ``a = ta + 1e-9 (tb - ta)`` (at least the next float after
    ``ta``); ``h(a) <= 0`` there reads as a return within it (the contact closes at ``a``).
    On a short step late in a run ``a`` is one rounding unit of the time away, over which
    the gap's rise ``v0 (a - ta)`` (1e-22 m at v0 = 1e-6 m/s) lies far below the gap's own
    round-off: ``fun(a) - g0`` is then 0 or noise and says nothing. With the normal speed
    ``dfun``, a non-positive ``h(a)`` counts only where the speed at ``a`` has turned
    negative too (a gap cannot come back below its start while rising at both ends of 1e-9
    of a step); else ``h(a)`` is its mean rate over (ta, a], ``(v0 + dfun(a)) / 2``.

    Returns the re-closing time in (ta, tb], or None when the gap has not come back.
    """
    dt = tb - ta
    hb = (gb - g0) / dt
    if v0 <= 0.0:
        return None
    a = max(ta + 1e-9 * dt, float(np.nextafter(ta, tb)))
    ha = (fun(a) - g0) / (a - ta)
    if ha <= 0.0 and dfun is not None:
        va = dfun(a)
        if va > 0.0:  # still rising at a: the quotient there is round-off, not a return
            ha = 0.5 * (v0 + va)

    def h(t: float) -> float:
        # at a its value above; at ta itself (a step so short that ta + 1e-9 dt rounds to
        # ta) its limit, v0
        if t == a:
            return ha
        return (fun(t) - g0) / (t - ta) if t > ta else v0

    if hb > 0.0:
        # open at the step's end: it may still have come back down and up again inside
        dip = first_dip(h, a, tb, ha) if ha > 0.0 else None
        return None if dip is None else locate_crossing(h, *dip, xtol)
    if ha <= 0.0:  # returns below its start within 1e-9 of the step: use the sampled start
        return a
    return locate_crossing(h, a, tb, ha, hb, xtol)


def gap_event(gap: Callable[[float], float], speed: Callable[[float], float], ta: float,
              tb: float, ga: float, gb: float, xtol: float) -> tuple[float, str] | None:
    """The event of a free contact in the step (ta, tb]: ``(time, kind)``, or None.

    ``gap`` and its rate ``speed`` (the normal velocity) are evaluated on the step's
    interpolant; ``ga`` and ``gb`` are the gap at the two ends. Open at ``ta``: an "impact"
    where the gap dips to zero inside the step (:func:`first_dip`) or has crossed it at
    ``tb``. Closed at ``ta`` and separating (just impacted or released): an "impact" where it
    comes back below its starting level (:func:`reclosing`), even if open at ``tb``. Closed,
    not separating and sinking deeper: a "touch" at ``ta``.
    """
    if ga > 0.0:
        dip = first_dip(gap, ta, tb, ga, dfun=speed, xtol=xtol)
        if dip is not None:  # the gap dips below zero inside the step (and may come back)
            return locate_crossing(gap, *dip, xtol), "impact"
        if gb <= 0.0:
            return locate_crossing(gap, ta, tb, ga, gb, xtol), "impact"
    elif ga <= 0.0:
        v0 = speed(ta)
        if v0 > 0.0:
            te = reclosing(gap, ta, tb, ga, v0, gb, xtol, dfun=speed)
            if te is not None:
                return te, "impact"
        elif gb < 0.0 and gb < ga:
            return ta, "touch"
    return None
