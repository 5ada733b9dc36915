"""The exact derivative of law ``"stronge"``: d pi / d(W, v-, e, mu) of the impulse-space
integration (:mod:`convimpact.impact.laws.stronge`), in the contract of
:class:`~convimpact.impact.derivatives.contact.ContactDerivative`.

The collision's path is re-traced with the kernel's decisions and every quantity carries its
gradient with respect to ``theta = (W's upper triangle, v-, e, mu)``:

* **Linear phases** (planar slip, stick, reversal, onset; the spatial stick and onset, and the
  straight finish of a spatial slip) have constant rates ``dpi_t/dp = lambda``,
  ``dv_n/dp = a_n = W_nn + W_tn.lambda``, ``dv_t/dp = W_tn + W_tt lambda``, each
  differentiated in closed form: slip ``lambda = -mu s`` (``ds = (I - s s^T) dv_t / |v_t|``
  at a hand-over, 0 in the plane), stick ``dlambda = -W_tt^-1 (dW_tn + dW_tt lambda)``, onset
  ``s = (kappa I + mu W_tt)^-1 W_tn`` with ``|s| = 1`` by the implicit function theorem.
* **Every phase switch** is an event ``g(p, theta) = 0`` whose impulse moves by
  ``dp = -(dg) / (dg/dp)``: the slip stop ``|v_t| + rate dp = 0``, the end of compression
  ``v_n + a_n dp = 0``, the end of restitution ``W_n + v_n dp + a_n dp^2 / 2 =
  (1 - e^2) W_n(p_c)`` (whose sensitivity carries ``d((1 - e^2) W_n(p_c))``).
* **The curved spatial slip** by its variational equations, integrated with the state
  (:mod:`convimpact.impact.laws.stronge_sensitivity`), with the events' sensitivities.

Mode boundaries give one-sided derivatives, each named in ``one_sided``; ``other_side=True``
re-traces the path with the decisions at those boundaries reversed (``other_side``):

* a slip that stops exactly at the end of restitution (slip throughout on one side, a
  vanishing stick or reversal on the other: ``d pi_t`` differs by
  ``(lambda_1 - lambda_2)(dp_s - dp_f)``);
* ``|W_tt^-1 W_tn| = mu`` when the contact is at rest (stick above, slip below; the rates
  agree there, their derivatives do not: the slip's depend on mu);
* a zero pre-impact slip followed by an onset: the ``v_t`` columns are the directional
  derivatives along each tangent's +direction (other side: -direction). A slip started at
  ``eps u`` either stops after ``eps dp_u`` (then the path from rest), or grows along the onset
  direction (nothing changes), or -- in space -- turns toward it, shifting the tangential
  impulse by ``eps C^-1 (alpha s* - u)`` (:func:`~.stronge_sensitivity.turn_offset`). A
  contact that sticks from the start has equal directional derivatives (checked): two-sided;
* e = 0 (right derivative: ``p_f - p_c = e sqrt(2 |W_n(p_c)| / a_n) + O(e^2)``), mu = 0
  (right derivative; the slip phases' rates at mu -> 0+), v_n- = 0 (zero; the other side is
  the approaching limit ``-(1 + e)(1, lambda) / a_n`` per unit v_n).

A slip that stops exactly at the end of compression is *no* boundary of the impulse:
``p_c(theta)`` has a kink there, but ``W_n(p_c) = min W_n`` is stationary in p, so neither
``p_f`` nor ``pi_t`` sees it (both one-sided differences agree; tested).

Several contacts: :func:`several_impulse_derivative` (independent contacts one by one; one
approaching contact among coupled ones; coupled contacts by
:mod:`convimpact.impact.laws.stronge_contacts_derivative`).

Accuracy against fourth-order central differences of the public law (step 1e-4; 150 random
planar and 100 random spatial contacts away from boundaries): planar median 2e-12, 90th
percentile 6e-12, worst 1e-9; spatial median 1e-11, 90th percentile 9e-11, worst 2e-8 -- the
worst cases are the differences' own limit (the law's answer carries ~1e-12 of integration
noise; their value moves by 1e-8 with the step). Cost (pure Python, a loaded 2-core machine):
planar ~0.4 ms, spatial ~20 ms (median; up to ~0.2 s for stiff slips: the variational system
has 4 x 12 components and takes the law's 10-300 steps), against ~0.15 ms for the solve.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ..derivatives.contact import ContactDerivative
from ...errors import NotSupportedError, ParameterError
from ..problem.build import ImpactProblem
from ..results import ImpactResult
from .stronge_path import BOUNDARY_RTOL, ZERO_SLIP, _Path, symmetric_tensor
from .stronge_slip import _onset
#: a zero pre-impact slip's two directional derivatives in v_t closer than this (relative)
#: are one: the derivative is two-sided there
ZERO_SLIP_RTOL = 1e-9
#: the recomputed impulse must agree with the result's to this (relative), else the result is
#: not this problem's answer of law "stronge"
CONSISTENCY_RTOL = 1e-7


def contact_derivative(W, v, e: float, mu: float, other_side: bool = False
                       ) -> tuple[np.ndarray, ContactDerivative, bool]:
    """One contact's impulse and its derivative (contact space, unnormalized data).

    Returns ``(pi, ContactDerivative, sided)``; the derivative is that of the mode the answer
    is in, or with ``other_side`` of the neighbouring mode at the boundaries met (its
    ``other_side`` is then None); ``sided``: some boundary met has a neighbouring mode.
    """
    W = np.asarray(W, dtype=float)
    v = np.asarray(v, dtype=float)
    d = W.shape[0]
    vs = float(np.max(np.abs(v)))
    ws = float(np.trace(W))
    if not v[0] < 0.0:
        return np.zeros(d), _separating(W, v, e, mu, vs, ws, other_side), v[0] == 0.0
    Wh, vh = W / ws, v / vs
    path = _Path(Wh, vh, e, mu, flip=other_side)
    pi_h, g = path.run()
    if path.zero_slip:
        # both directional derivatives in v_t agree (a contact that sticks from the start):
        # the derivative is two-sided there
        twin = _Path(Wh, vh, e, mu, flip=other_side, zero_sign=-path.zero_sign)
        _, g2 = twin.run()
        cols = path.iv[1:]
        if np.max(np.abs(g2[:, cols] - g[:, cols])) <= ZERO_SLIP_RTOL * max(
                float(np.max(np.abs(g))), 1e-300):
            path.boundaries = [t for t in path.boundaries if t != ZERO_SLIP]
            path.sided.discard(ZERO_SLIP)
    if mu == 0.0:
        path.boundaries.append("mu = 0: d pi / d mu is the right derivative (mu -> 0+)")
        regime = "frictionless"
    else:
        regime = "-".join(path.phases)
    scale = vs / ws
    pi = scale * pi_h
    dW = symmetric_tensor(g, path.d) * (scale / ws)
    dv = g[:, path.iv] / ws
    de = (g[:, path.ie] * scale)[:, None]
    dmu = (g[:, path.imu] * scale)[:, None]
    deriv = ContactDerivative(W=dW, v=dv, e=de, mu=dmu, e_t=None, regimes=(regime,),
                              one_sided=tuple(path.boundaries))
    return pi, deriv, bool(path.sided)


def _separating(W, v, e, mu, vs, ws, other_side) -> ContactDerivative:
    """A contact that does not approach takes no impulse: zero derivative; at v_n- = 0 the
    other side is the approaching limit, pi = -v_n (1 + e) (1, lambda) / a_n + o(v_n) with the
    rates of the path's first phase."""
    d = W.shape[0]
    zero = ContactDerivative(W=np.zeros((d, d, d)), v=np.zeros((d, d)), e=np.zeros((d, 1)),
                             mu=np.zeros((d, 1)), e_t=None, regimes=("separating",))
    if v[0] > 0.0 or vs == 0.0:
        return zero
    text = ("v_n- = 0: the contact touches without approaching; d pi / d v_n is one-sided "
            "(the other side: the approaching limit)")
    if not other_side:
        return dataclasses.replace(zero, one_sided=(text,))
    path = _Path(W / ws, np.concatenate(([-1.0], v[1:] / vs)), e, mu)
    vt = path.vt
    kind = "slip"
    if d == 2 and vt[0] != 0.0:
        lam = np.array([-mu * math.copysign(1.0, vt[0])])
    elif d == 3 and float(np.linalg.norm(vt)) > 0.0:
        lam = -mu * vt / float(np.linalg.norm(vt))
    else:
        Ci = np.linalg.inv(path.C)
        lam = -Ci @ path.b
        x = float(np.linalg.norm(lam))
        kind = "stick"
        if x > mu:
            kind = "onset"
            if d == 2:
                lam = np.array([-mu * math.copysign(1.0, path.b[0])])
            else:
                _, s1, s2 = _onset(*path.b, path.C[0, 0], path.C[0, 1], path.C[1, 1], mu)
                lam = -mu * np.array([s1, s2])
    an = path.A + float(path.b @ lam)
    dv = np.zeros((d, d))
    dv[:, 0] = -(1.0 + e) * np.concatenate(([1.0], lam)) / (an * ws)
    return dataclasses.replace(zero, v=dv, regimes=(kind,), one_sided=(text,))


def _check(problem: ImpactProblem, result: ImpactResult, pi: np.ndarray, i: int) -> None:
    if getattr(result, "law", "stronge") != "stronge":
        raise ParameterError(f"law 'stronge' derivative: the result is of law {result.law!r}")
    got = np.asarray(result.impulse, dtype=float).reshape(problem.n_contacts, problem.dim)[i]
    scale = max(float(np.max(np.abs(got))), float(np.max(np.abs(pi))), 1e-300)
    if float(np.max(np.abs(got - pi))) > CONSISTENCY_RTOL * scale:
        raise ParameterError(
            f"law 'stronge' derivative: the result's impulse {got.tolist()} is not this "
            f"problem's answer {pi.tolist()} (pass the result of solving this problem)")


def _with_other(problem, i, other_side):
    W, v = (np.array(x, dtype=float) for x in problem.contact_lists(i))
    e, mu = float(problem.restitution[i]), float(problem.friction[i])
    pi, deriv, sided = contact_derivative(W, v, e, mu)
    if other_side and sided:
        _, other, _ = contact_derivative(W, v, e, mu, other_side=True)
        deriv = dataclasses.replace(deriv, other_side=other)
    return pi, deriv


def impulse_derivative(problem: ImpactProblem, result: ImpactResult,
                       other_side: bool = False) -> ContactDerivative:
    """The derivative of Stronge's impulse of one contact with respect to ``(W, v-, e, mu)``.

    Parameters
    ----------
    problem : ImpactProblem
        The impact (one contact, planar or spatial).
    result : ImpactResult
        Its answer under law ``"stronge"`` (any method).
    other_side : bool
        At a mode boundary, also give the neighbouring mode's derivative
        (``.other_side``).

    Returns
    -------
    ContactDerivative
        ``regimes`` names the path's phases (e.g. ``"slip-stick"``); ``one_sided`` the
        boundaries met.

    Raises
    ------
    NotSupportedError
        for several contacts (see :func:`several_impulse_derivative`).
    ParameterError
        when ``result`` is not this problem's answer of law ``"stronge"``.
    """
    if problem.n_contacts != 1:
        raise NotSupportedError("impulse_derivative treats one contact; for "
                                f"{problem.n_contacts} use several_impulse_derivative")
    pi, deriv = _with_other(problem, 0, other_side)
    _check(problem, result, pi, 0)
    return deriv


def several_impulse_derivative(problem: ImpactProblem, result: ImpactResult,
                               other_side: bool = False) -> ContactDerivative:
    """The derivative of Stronge's impulses at several contacts.

    Per the law's formulation of the answer: dynamically independent contacts (block-diagonal
    W) contact by contact on :func:`impulse_derivative`'s path; one approaching contact whose
    impulse lifts the others, that contact's; coupled contacts, the two-phase formulation
    differentiated phase by phase
    (:func:`~convimpact.impact.laws.stronge_contacts_derivative.coupled_derivative`).

    Independent contacts: any coupling hands the impulse to the two-phase formulation, which
    does not reduce to the exact integration as the coupling vanishes -- the impulse jumps.
    The derivative in W's off-diagonal blocks is therefore the independent model's (zero),
    stated in ``one_sided``.

    Parameters
    ----------
    problem : ImpactProblem
        The impact (several contacts).
    result : ImpactResult
        Its answer under law ``"stronge"`` (any method).
    other_side : bool
        At a mode boundary, also the neighbouring mode's derivative (``.other_side``).

    Returns
    -------
    ContactDerivative

    Raises
    ------
    NotSupportedError
        for a coupled two-phase answer whose expansion was scaled down (kappa < 1) or
        followed by a second plastic compression, or whose compression has redundant
        contacts.
    ParameterError
        when ``result`` is not this problem's answer of law ``"stronge"``.
    """
    from ..exact.dispatch import coupled
    n, d = problem.n_contacts, problem.dim
    extras = getattr(result.diagnostics, "extras", None) or {}
    formulation = str(extras.get("formulation", ""))
    if coupled(problem) and not formulation.startswith("one approaching contact"):
        if not formulation.startswith("compression then expansion"):
            raise NotSupportedError(
                "law 'stronge' on coupled contacts: the result does not say how it was "
                "formed (extras['formulation']); pass the result of solving this problem")
        from .stronge_contacts_derivative import coupled_derivative
        return coupled_derivative(problem, result, other_side)
    N = n * d
    out = {k: np.zeros(s) for k, s in (("W", (N, N, N)), ("v", (N, N)), ("e", (N, n)),
                                       ("mu", (N, n)))}
    other = {k: v.copy() for k, v in out.items()}
    regimes, sided, any_other = [], [], False
    for i in range(n):
        sl = slice(i * d, (i + 1) * d)
        pi, dc = _with_other(problem, i, other_side)
        if formulation.startswith("one approaching contact") and not problem.approaching[i]:
            pi, dc = np.zeros(d), _separating(*(np.array(x, dtype=float) for x in
                                               problem.contact_lists(i)), 0.0, 0.0, 1.0,
                                             1.0, False)
        _check(problem, result, pi, i)
        regimes.append(dc.regimes[0])
        sided.extend(f"contact {i}: {t}" for t in dc.one_sided)
        for tgt, src in ((out, dc), (other, dc.other_side or dc)):
            tgt["W"][sl, sl, sl] = src.W
            tgt["v"][sl, sl] = src.v
            tgt["e"][sl, i] = src.e[:, 0]
            tgt["mu"][sl, i] = src.mu[:, 0]
        any_other = any_other or dc.other_side is not None
    if not coupled(problem):
        sided.append("independent contacts: the derivative in W's off-diagonal blocks is the "
                     "independent model's (zero); any coupling switches the law to its "
                     "two-phase formulation, where the impulse jumps")
    if formulation.startswith("one approaching contact"):
        vp = np.asarray(result.v_plus, dtype=float).reshape(n, d)[:, 0]
        vscale = float(np.max(np.abs(problem.v_minus)))
        for j in range(n):
            if not problem.approaching[j] and abs(vp[j]) <= BOUNDARY_RTOL * vscale:
                sided.append(
                    f"contact {j} lifts with v_n+ = 0: one-sided (driven any further, it "
                    "would approach and the coupled two-phase formulation, which has no "
                    "derivative, would take over)")
    side = (ContactDerivative(e_t=None, regimes=tuple(regimes), **other)
            if other_side and any_other else None)
    return ContactDerivative(e_t=None, regimes=tuple(regimes), one_sided=tuple(sided),
                             other_side=side, **out)
