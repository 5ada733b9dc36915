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

A law's ``impulse_derivative`` is :func:`law_entry` with its mode function and its rules; the
laws whose stick is Newton's (``W pi = -b``) share :func:`newton_mode`, :func:`newton_stick`
and :func:`mu_zero_column`.
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from ...errors import ConvImpactError, NotSupportedError, SingularSystemError
from .contact import ContactDerivative
from .modes import (contact_derivative, frictionless, newton_shift, stick, zero)

#: relative distance of the stick impulse from the cone boundary below which a contact is at
#: the stick limit (its derivative one-sided)
STICK_LIMIT_RTOL = 1e-9

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
    try:
        dp = mode(W, v, e, mu, et, regime, p)
    except np.linalg.LinAlgError:
        raise SingularSystemError(
            f"law {law!r}: the {regime} mode's equations are singular at this answer (a "
            "singular Delassus block, or a degenerate slide): the impulse is not a "
            "differentiable function of the data here") from None
    statements: list[str] = []
    other = None
    try:
        ps = stick_of(W, v, e, mu, et) if stick_of is not None else None
    except np.linalg.LinAlgError:  # singular W: the law has no unique stick impulse to test
        ps = None
    if ps is not None and regime in ("stick", "slide"):
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
    other = "slide" if regime == "stick" else "stick"
    try:
        q = slide_at(W, v, e, mu, et, ps) if other == "slide" and slide_at is not None else ps
        return contact_derivative(mode(W, v, e, mu, et, other, q), other, tangential, impulse=q)
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


# --------------------------------------------------------------------------------------------
# the rules at the stick limit and at mu = 0 of the Newton laws


def stick_impulse(W: np.ndarray, v: np.ndarray, e: float) -> np.ndarray:
    """The Newton laws' stick impulse, ``W^-1 (-(1 + e) v_n, -v_t)``."""
    return np.linalg.solve(W, -newton_shift(v, e))


def at_stick_limit(ps: np.ndarray, mu: float) -> bool:
    """Whether the stick impulse ``ps`` lies on the cone boundary |pi_t| = mu pi_n (to
    :data:`STICK_LIMIT_RTOL` of |pi|)."""
    scale = float(np.linalg.norm(ps))
    return scale > 0.0 and abs(float(np.linalg.norm(ps[1:])) - mu * ps[0]) <= \
        STICK_LIMIT_RTOL * scale * (1.0 + mu)


def mu_zero_column(kind: str, W: np.ndarray, v: np.ndarray, e: float) -> np.ndarray:
    """At mu = 0: the right derivative d pi / d mu of the mode entered for mu > 0.

    The friction impulse appears along the tangent t its law picks as mu -> 0+: eq. (55)'s
    ``-sgn v_t`` in the plane ("eq55", the sign of the stick impulse's pi_t where v_t = 0);
    against the post-impact slip of the frictionless answer, ``u_t = b_t + W_tn pi_n`` (laws
    "ccp", "coulomb"); the maximal-dissipation direction's limit ("max-dissipation", from
    dT_L/dmu at mu = 0: against the plastic frictionless answer's slip,
    ``v_t - W_tn v_n / W_nn``). A contact whose stick impulse has no tangential part sticks for
    every mu > 0, and one whose limiting slip is zero too: zero. A contact whose tangents move
    no mass has mu forced to 0: zero. Then, with pi = pi_n (1, mu t):
    ``d pi_t / d mu = pi_n t`` and ``d pi_n / d mu = -c W_nt.t / W_nn^2`` (Newton laws:
    W_n . pi = c) or ``-(b_t.t) / W_nn + 2 b_n W_nt.t / W_nn^2`` (ccp: the ray's optimum).
    """
    d = v.size
    A = W[0, 0]
    col = np.zeros(d)
    if not np.diag(W)[1:].max() > 1e-12 * A:  # immobile tangents: mu is not used
        return col
    b = newton_shift(v, e)
    try:
        ps = stick_impulse(W, v, e)  # the stick impulse, the same for every kind
    except np.linalg.LinAlgError:
        ps = None
    if ps is not None and not float(np.linalg.norm(ps[1:])) > 1e-14 * float(
            np.linalg.norm(ps)):
        return col  # no tangential impulse needed to stick: it sticks for every mu > 0
    if kind == "eq55":
        t = np.array([-np.sign(v[1]) if v[1] != 0.0 else
                      (np.sign(ps[1]) if ps is not None else 1.0)])
    else:
        s = v if kind == "max-dissipation" else b
        slip = s[1:] - W[1:, 0] * s[0] / A
        size = float(np.linalg.norm(slip))
        if not size > 1e-14 * float(np.linalg.norm(v)):
            return col
        t = -slip / size
    wt = float(W[0, 1:] @ t)
    pn = -b[0] / A
    if kind == "ccp":
        col[0] = -float(b[1:] @ t) / A + 2.0 * b[0] * wt / A ** 2
    else:
        col[0] = -pn * wt / A
    col[1:] = pn * t
    return col


# --------------------------------------------------------------------------------------------
# a law's entry


def newton_mode(slide: Callable) -> Mode:
    """The mode function of a law whose stick is Newton's (``W pi = -b``) and whose mu = 0 is
    Newton's frictionless impulse, with the law's own ``slide(W, v, e, mu, p)``."""
    def mode(W, v, e, mu, et, regime, p):
        if regime == "frictionless":
            return frictionless(W, v, e)
        if regime == "stick":
            return stick(W, v, e, p)
        return slide(W, v, e, mu, p)
    return mode


def newton_stick(W, v, e, mu, et) -> np.ndarray:
    """The candidate of the Newton laws' stick test, :func:`stick_impulse`."""
    return stick_impulse(W, v, e)


_ENTRY_DOC = """

    Parameters
    ----------
    problem : ImpactProblem
        The validated one-contact impact.
    result : ImpactResult
        The law's answer (any method): its impulse and regime select the mode.
    other_side : bool
        At a mode boundary, also give the neighbouring mode's derivative
        (``ContactDerivative.other_side``).

    Returns
    -------
    ContactDerivative{extra}
    """


def law_entry(law: str, summary: str, mode: Mode, **rules) -> Callable:
    """Law ``law``'s ``impulse_derivative(problem, result, other_side=False)``:
    :func:`one_contact_derivative` with the law's ``mode`` and ``rules`` (its keyword
    arguments: ``stick_of``, ``slide_at``, ``mu_zero``, ``boundaries``, ``tangential``);
    ``summary`` opens its docstring."""
    def impulse_derivative(problem, result, other_side: bool = False) -> ContactDerivative:
        return one_contact_derivative(problem, result, law, mode, other_side=other_side,
                                      **rules)

    extra = " (with ``e_t``)" if rules.get("tangential") else ""
    impulse_derivative.__doc__ = summary + _ENTRY_DOC.format(extra=extra)
    impulse_derivative.__qualname__ = f"{law}.impulse_derivative"
    return impulse_derivative
