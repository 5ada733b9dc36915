"""Exact derivative of the ``chatterjee-ruina`` law, at one contact (:func:`impulse_derivative`)
and at several (per contact).

The law is defined per contact (:mod:`.chatterjee_ruina`): at several contacts it applies
contact by contact when they are dynamically independent (W block-diagonal), or to the one
approaching contact when the others lift. Contact i's impulse then depends on its own block
``W_ii``, ``v_i``, ``e_i``, ``mu_i``, ``e_t,i`` only, and the derivative is block-diagonal: the
derivative of the law's closed form (:func:`contact_tangent`, the chain rule through
``J_I = -(v_n / W_nn) n``, ``J_II = -W^-1 v``, ``b = J_II - J_I`` and

    stick: J = (1 + e) J_I + (1 + e_t) b,
    slide: J = (1 + e) J_I + kappa b,  kappa = mu (1 + e) (n.J_I) / (|b_t| - mu b_n)),

with ``dJ_II = -W^-1 (dW J_II + dv)``). Its entries with respect to the off-diagonal blocks of W
are zero: a perturbation that couples independent contacts leaves the law's domain (it then
refuses coupled simultaneous impacts), which ``one_sided`` states. Boundaries: the stick
limit (``J^`` on the cone's boundary: stick | slide, both sides given), a contact touching
(``v_n- = 0``: no impulse | the law's), a lifted contact about to press (``v_n+ = 0``).
"""

from __future__ import annotations

import numpy as np

from ..derivatives.modes import seeds
from ..derivatives.single import law_entry
from ...errors import NotSupportedError, ParameterError
from ..exact.dispatch import coupled
from ..problem.build import ImpactProblem

LAW = "chatterjee-ruina"
#: relative distance from the cone's boundary below which J^ counts as on it
BOUNDARY_RTOL = 1e-9


def _plastic(W: np.ndarray, v: np.ndarray):
    a0 = -v[0] / W[0, 0]
    x = -np.linalg.solve(W, v)
    b = x.copy()
    b[0] -= a0
    return a0, x, b


def candidate(W: np.ndarray, v: np.ndarray, e: float, et: float) -> np.ndarray:
    """J^ = (1 + e) J_I + (1 + e_t) b, the candidate the law's cone test looks at."""
    a0, _, b = _plastic(W, v)
    J = (1.0 + et) * b
    J[0] += (1.0 + e) * a0
    return J


def stick_margin(W: np.ndarray, v: np.ndarray, e: float, mu: float, et: float) -> float:
    """``mu n.J^ - |J^_t|`` of the law's candidate (>= 0: inside the cone, the stick regime)."""
    J = candidate(W, v, e, et)
    return mu * J[0] - float(np.linalg.norm(J[1:]))


def contact_tangent(W, v, e, mu, et, dW, dv, de, dmu, det, regime: str) -> np.ndarray:
    """``dJ`` of one contact in ``regime`` ("stick", "slide" or "frictionless") along the
    tangents ``(dW, dv, de, dmu, det)``: one tangent ((d, d), (d,), then scalars) or P of them
    on a trailing axis ((d, d, P), (d, P), (P,) ...; dJ is then (d, P)). A slide with
    ``b_t = 0`` has no sticking correction to bring back: the stick formula."""
    a0, x, b = _plastic(W, v)
    da0 = -dv[0] / W[0, 0] + v[0] * dW[0, 0] / W[0, 0] ** 2
    dx = -np.linalg.solve(W, np.einsum("ij...,j->i...", dW, x) + dv)
    db = dx.copy()
    db[0] -= da0
    s = 1.0 + e
    dJ = np.zeros_like(db)
    dJ[0] = de * a0 + s * da0
    bt = float(np.linalg.norm(b[1:]))
    if regime == "stick" or (regime == "slide" and bt == 0.0):
        return dJ + np.multiply.outer(b, det) + (1.0 + et) * db
    if regime == "frictionless":  # mu = 0: J = (1 + e) J_I (kappa = 0), mu's right derivative
        return dJ + np.multiply.outer(b, dmu * s * a0 / bt) if bt > 0.0 else dJ
    dbt = (b[1:] @ db[1:]) / bt
    q = bt - mu * b[0]
    kappa = mu * s * a0 / q
    dq = dbt - dmu * b[0] - mu * db[0]
    dkappa = (dmu * s * a0 + mu * de * a0 + mu * s * da0) / q - kappa * dq / q
    return dJ + np.multiply.outer(b, dkappa) + kappa * db


def _mode(W, v, e, mu, et, regime, p):
    """One contact's (d, P): at mu = 0 ("frictionless": kappa = 0) the slide's formula,
    smooth there."""
    return contact_tangent(W, v, e, mu, et, *seeds(v.size),
                           "slide" if regime == "frictionless" else regime)


impulse_derivative = law_entry(
    LAW, """Derivative of the Chatterjee-Ruina impulse of one contact with respect to
    (W, v_minus, e, mu, e_t): the law's explicit formulas differentiated (stick: the scaled
    plastic impulses; slide: their segment's exit from the cone, kappa's derivative). The
    impulse is continuous where the candidate J^ meets the cone (kappa = 1 + e_t), where the
    derivative is one-sided; at mu = 0 the one with respect to mu is right-sided.""",
    _mode, stick_of=lambda W, v, e, mu, et: candidate(W, v, e, et), tangential=True)


def several_impulse_derivative(problem: ImpactProblem, result, other_side: bool = False):
    """Derivative of the ``chatterjee-ruina`` impulse at several contacts (contact by contact,
    module docstring) with respect to ``(W, v_minus, e, mu, e_t)``.

    Parameters
    ----------
    problem : ImpactProblem
    result : ImpactResult
        An answer of law ``chatterjee-ruina`` on ``problem``.
    other_side : bool
        At the stick limit, also the neighbouring regime's derivative (``.other_side``).

    Returns
    -------
    ContactDerivative (``e_t`` filled)

    Raises
    ------
    NotSupportedError
        Coupled contacts striking together (the law has no answer there either).
    ParameterError
        The result is another law's.
    """
    from ..derivatives.contact import ContactDerivative

    if getattr(result, "law", LAW) != LAW:
        raise ParameterError(f"the result is law {result.law!r}'s, not {LAW!r}'s")
    n, d = problem.n_contacts, problem.dim
    N = n * d
    W = problem.delassus
    et_all = problem.tangential_restitution
    et_all = np.zeros(n) if et_all is None else et_all
    pi = np.asarray(result.impulse, dtype=float).reshape(n, d)
    vplus = problem.v_minus + (W @ pi.ravel()).reshape(n, d)
    vscale = max(float(np.max(np.abs(problem.v_minus))), 1e-300)
    is_coupled = coupled(problem)
    if is_coupled and int(np.sum(np.any(pi != 0.0, axis=1))) > 1:
        raise NotSupportedError("law 'chatterjee-ruina' is defined per contact: coupled "
                                "contacts striking together have no answer to differentiate")
    notes: list[str] = []
    if not is_coupled and n > 1:
        notes.append("independent contacts (W block-diagonal): the law's domain; its "
                     "derivative with respect to W's off-diagonal blocks is given as zero, "
                     "and a perturbation coupling the contacts leaves the domain (the law "
                     "then refuses coupled simultaneous impacts)")
    out, flip = ([np.zeros((N, N, N)), np.zeros((N, N))] + [np.zeros((N, n)) for _ in range(3)]
                 for _ in range(2))  # (W, v, e, mu, e_t), this side's and the other's
    regimes, others = [], []
    any_boundary = False
    for i in range(n):
        rows = slice(i * d, (i + 1) * d)
        Wi, vi = W[rows, rows], problem.v_minus[i]
        e, mu, et = float(problem.restitution[i]), float(problem.friction[i]), float(et_all[i])
        if not np.any(pi[i] != 0.0):
            regimes.append("separating")
            others.append("separating")
            if vi[0] == 0.0 or (is_coupled and vplus[i, 0] <= 1e-9 * vscale):
                notes.append(f"contact {i}: touching with no impulse (v_n = 0): one-sided "
                             "derivative of the separating contact")
            continue
        margin = stick_margin(Wi, vi, e, mu, et)
        regime = "stick" if margin >= 0.0 else "slide"
        if mu == 0.0:  # kappa = 0 (or b = 0): the frictionless impulse (1 + e) J_I
            regime = "frictionless"
        other = regime
        if mu > 0.0 and abs(margin) <= BOUNDARY_RTOL * float(np.linalg.norm(pi[i])) * max(mu, 1):
            other = "slide" if regime == "stick" else "stick"
            any_boundary = True
            notes.append(f"contact {i}: at the stick limit (J^ on the cone's boundary): "
                         f"one-sided derivative of the {regime} regime, the other side {other}")
        regimes.append(regime)
        others.append(other)
        for dest, reg in ((out, regime), (flip, other)):  # the (d, P) block at its place
            g = contact_tangent(Wi, vi, e, mu, et, *seeds(d), reg)
            dest[0][rows, rows, rows] = g[:, :d * d].reshape(d, d, d)
            dest[1][rows, rows] = g[:, d * d:d * d + d]
            for k in range(3):  # e, mu, e_t
                dest[2 + k][rows, i] = g[:, k - 3]
    other = None
    if other_side and any_boundary:
        other = ContactDerivative(*flip, regimes=tuple(others),
                                  one_sided=tuple(s + " (this is the other side)" for s in notes))
    return ContactDerivative(*out, regimes=tuple(regimes), one_sided=tuple(notes),
                             other_side=other)


__all__ = ["impulse_derivative", "several_impulse_derivative", "contact_tangent",
           "stick_margin", "candidate"]
