"""One contact's impulse derivative: the driver every single-contact law's
``impulse_derivative`` runs, with the law's own mode formulas plugged in.

The driver reads the law's answer (its impulse and regime: the derivative depends on the
answer and its mode, not on the method that found it), differentiates the mode, and checks
the mode boundaries a single contact meets:

* a contact at ``v_n- = 0`` (separating by the law's rule ``v_n- < 0`` approaches): the
  derivative is the separating side's (zero); the approaching side's is the law's mode there,
  differentiated at the law's answer a relative 1e-9 inside (the derivative is continuous
  inside a mode, so this is its limit to that accuracy);
* mu = 0 (frictionless): the derivatives with respect to W, v, e are those of Newton's
  frictionless impulse; the one with respect to mu is the right-sided one (mu < 0 is outside
  every law), that of the mode entered for mu > 0;
* the stick limit ``|pi_t| = mu pi_n`` of the law's stick impulse: one-sided; the other side
  is the neighbouring mode (stick or slide) differentiated at its own answer there;
* a law's own boundaries (``boundaries`` hook: eq. (55)'s zero pre-impact slip).
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from ..errors import ConvImpactError, NotSupportedError
from .contact import ContactDerivative
from .modes import at_stick_limit, contact_derivative, zero

#: v_n- of the approaching side's evaluation point, relative to max |v-|
APPROACH_OFFSET = 1e-9

Mode = Callable[..., np.ndarray]


def contact_data(problem, result, law: str):
    """(W, v, e, mu, e_t, regime, impulse) of a one-contact problem and its answer."""
    if problem.n_contacts != 1:
        raise NotSupportedError(
            f"impulse_derivative of law {law!r} treats one contact; this impact has "
            f"{problem.n_contacts}: use several_impulse_derivative")
    W, v = problem.contact_block(0)
    et = problem.tangential_restitution
    regime = result.regime if isinstance(result.regime, str) else result.regime[0]
    return (np.array(W, dtype=float), np.array(v, dtype=float), float(problem.restitution[0]),
            float(problem.friction[0]), 0.0 if et is None else float(et[0]), regime,
            np.asarray(result.impulse, dtype=float).reshape(-1))


def one_contact_derivative(problem, result, law: str, mode: Mode, *, other_side: bool = False,
                           stick_of: Callable | None = None, slide_at: Callable | None = None,
                           mu_zero: Callable | None = None, boundaries: Callable | None = None,
                           tangential: bool = False) -> ContactDerivative:
    """The law's :class:`ContactDerivative` at its answer ``result`` of ``problem``.

    Parameters
    ----------
    mode : ``mode(W, v, e, mu, e_t, regime, impulse) -> (d, P)`` the derivative of the mode
        (:mod:`~convimpact.impact.derivatives.modes`' layout) for "stick", "slide",
        "frictionless".
    stick_of : ``(W, v, e, mu, e_t) -> impulse`` the candidate the law's stick test puts in
        the cone (None: no stick limit).
    slide_at : ``(W, v, e, mu, e_t, stick_impulse) -> impulse`` the slide's answer at a stick
        limit (the other side of a "stick" answer there).
    mu_zero : ``(W, v, e, e_t) -> (d,)`` the right derivative with respect to mu at mu = 0
        (None: ``mode`` gives it).
    boundaries : ``(W, v, e, mu, e_t, regime, impulse, other_side) -> [(statement, other)]``
        the law's own boundaries met.
    """
    W, v, e, mu, et, regime, p = contact_data(problem, result, law)
    d = v.size

    def split(dp, rg, statements=(), other=None):
        return contact_derivative(dp, rg, tangential, statements, other)

    if regime == "separating":
        if v[0] > 0.0:
            return split(zero(d), regime)
        statement = ("contact at v_n- = 0: the derivative is that of the separating side "
                     "(v_n- > 0, no impulse); the approaching side's differs")
        other = None
        if other_side:
            other = _approaching_side(law, mode, W, v, e, mu, et, tangential)
        return split(zero(d), regime, (statement,), other)
    if regime == "frictionless":
        dp = mode(W, v, e, mu, et, regime, p)
        if mu_zero is not None:
            dp[:, -2] = mu_zero(W, v, e, et)
        statement = ("mu = 0 (frictionless): the derivative with respect to mu is the "
                     "right-sided one (mu < 0 is outside the law), that of the mode entered "
                     "for mu > 0")
        return split(dp, regime, (statement,))
    dp = mode(W, v, e, mu, et, regime, p)
    statements: list[str] = []
    other = None
    if stick_of is not None and regime in ("stick", "slide"):
        ps = stick_of(W, v, e, mu, et)
        if at_stick_limit(ps, mu):
            side = "inside the cone" if regime == "stick" else "outside the cone"
            statements.append(
                f"stick limit |pi_t| = mu pi_n: the derivative is the {regime} mode's (the "
                f"side where the stick impulse lies {side}); the other side's differs")
            if other_side:
                other = _neighbour(mode, slide_at, W, v, e, mu, et, regime, ps, tangential)
    if boundaries is not None:
        for statement, side in boundaries(W, v, e, mu, et, regime, p, other_side):
            statements.append(statement)
            if other is None:
                other = side
    return split(dp, regime, tuple(statements), other)


def _neighbour(mode, slide_at, W, v, e, mu, et, regime, ps, tangential):
    """The other side of a stick limit: the slide (at its answer there) or the stick."""
    try:
        if regime == "stick":
            q = slide_at(W, v, e, mu, et, ps) if slide_at is not None else ps
            return contact_derivative(mode(W, v, e, mu, et, "slide", q), "slide", tangential,
                                      impulse=q)
        return contact_derivative(mode(W, v, e, mu, et, "stick", ps), "stick", tangential,
                                  impulse=ps)
    except (ConvImpactError, np.linalg.LinAlgError):
        return None  # the neighbouring mode has no answer here (e.g. a jam): no other side


def _approaching_side(law, mode, W, v, e, mu, et, tangential):
    """The approaching side of a contact at v_n- = 0 (see the module's docstring)."""
    from ..exact.dispatch import solve_contact

    vv = v.copy()
    scale = float(np.max(np.abs(v)))
    vv[0] = -APPROACH_OFFSET * (scale if scale > 0.0 else 1.0)
    try:
        sol = solve_contact(W, vv, e, mu, law, et)
        q = np.asarray(sol.impulse, dtype=float)
        dp = mode(W, vv, e, mu, et, sol.regime, q)
    except (ConvImpactError, np.linalg.LinAlgError):
        return None
    return contact_derivative(dp, sol.regime, tangential, impulse=q)
