"""The derivative of the paper's law (Section 8) for one contact, beside its kernel.

Its modes (c = -(1 + e) v_n):

* stick: ``W pi = (-(1 + e) v_n, -v_t)`` (eq. 42/52), differentiated as a linear solve;
* slide in the plane: ``pi = (c / D) (1, mu s)``, ``D = W_nn + mu s W_nt`` (eqs. 38, 55) with
  ``s = -sgn v_t-`` held: it jumps where the pre-impact slip changes sign, so at ``v_t- = 0``
  the derivative is one-sided (the other side slides along -s);
* slide in space: the direction of maximal dissipation (eq. 60), whose optimality conditions
  -- the Lagrange conditions of the program P_N on the cone boundary,
  ``W pi + v - lambda W_n - sigma (mu, -t) = 0``, ``W_n . pi = c``, ``|pi_t| = mu pi_n`` --
  are differentiated with their multipliers (the direction moves with the data);
* frictionless (mu = 0): ``pi = (c / W_nn) n``; the right derivative with respect to mu is the
  slide's along eq. (55)'s tangent (plane) or the maximal-dissipation direction's limit as mu
  -> 0+ (space).

The stick limit is one-sided: the slide there is not the stick impulse (in space P_N's boundary
optimum differs from it when e > 0), so the other side's derivative is taken at the slide's own
answer.
"""

from __future__ import annotations

import numpy as np

from ..derivatives.modes import contact_derivative, cone_slide, eq55_slide
from ..derivatives.single import law_entry, mu_zero_column, newton_mode, newton_stick

LAW = "pereira-nikravesh"


def _slide(W, v, e, mu, p) -> np.ndarray:
    """Eq. (55) in the plane (its tangent held), eq. (60)'s maximal dissipation in space."""
    if v.size == 2:
        return eq55_slide(W, v, e, mu, float(np.sign(p[1])))
    return cone_slide("max-dissipation", W, v, e, mu, p)


def _slide_at(W, v, e, mu, et, ps):
    """The law's slide at a stick-limit point: eq. (55) in the plane, eq. (60) in space."""
    from ..exact.closed_forms import planar_slide_direction, sliding_impulse
    from .max_dissipation import max_dissipation_direction

    if v.size == 2:
        direction = planar_slide_direction(v, ps)
    else:
        direction = max_dissipation_direction(W, v, e, mu)
    return sliding_impulse(W, v, e, mu, direction)[0]


def _mu_zero(W, v, e, et):
    return mu_zero_column("eq55" if v.size == 2 else "max-dissipation", W, v, e)


def _boundaries(W, v, e, mu, et, regime, p, other_side):
    """Eq. (55)'s zero pre-impact slip: a planar slide with v_t- = 0."""
    if not (v.size == 2 and regime == "slide" and v[1] == 0.0):
        return []
    s = float(np.sign(p[1]))
    statement = (f"zero pre-impact slip v_t- = 0: eq. (55)'s tangent t = -sgn(v_t-) jumps "
                 f"here; the derivative is that of the slide along t = {s:+g} (the side "
                 f"v_t- {'<' if s > 0 else '>'} 0); the other side slides along {-s:+g}")
    other = None
    D = float(W[0, 0] - mu * s * W[0, 1])  # the other side's denominator of eq. (38)
    if other_side and D > 1e-12 * float(np.max(np.abs(W))):
        q = (-(1.0 + e) * v[0] / D) * np.array([1.0, -mu * s])  # the impulse jumps to it
        other = contact_derivative(eq55_slide(W, v, e, mu, -s), "slide", impulse=q)
    return [(statement, other)]


impulse_derivative = law_entry(
    LAW, """Derivative of the law's impulse for one contact with respect to (W, v_minus, e, mu)
    in the answer's mode (module docstring).""", newton_mode(_slide), stick_of=newton_stick,
    slide_at=_slide_at, mu_zero=_mu_zero, boundaries=_boundaries)
