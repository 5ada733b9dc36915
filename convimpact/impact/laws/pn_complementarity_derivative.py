"""Exact derivative of the ``pereira-nikravesh`` law at several contacts (complementarity form,
:mod:`.pn_complementarity`).

The law's answer is fixed by its active set A (``extras["active_set"]``) and tier
(``extras["tier"]``); with ``b = v + e min(v_n, 0) n`` and ``u = W pi + b``:

* **stick tier**: ``u_S = 0`` on the rows S of A (every row of a frictional contact, the
  normal of a frictionless one), ``pi = 0`` elsewhere, so ``pi_S = -W_SS^+ b_S`` -- the
  law's own rule, the least-squares (minimum-norm) solution where W_SS is singular (redundant
  contacts). Its derivative is ``d pi_S = -W_SS^+ (db_S + dW_SS pi_S) + P0 dW_SS W_SS^+ pi_S``
  (P0 the projector on the null space of W_SS; Golub & Pereyra's derivative of the
  pseudo-inverse, zero for a regular W_SS). Where W_SS is singular it holds along the
  perturbations that keep its rank (stated in ``one_sided``).
* **slide tier**, one contact i in A: in the plane eq. (55)'s slide ``pi_t = mu s pi_n``
  (``s = -sgn v_t-``) with ``u_n = 0``; in space the slide of maximal dissipation (eq. 60), the
  stationary point of T+ on the cone's boundary with ``u_n = 0``.
* **slide tier**, several contacts: P_N(A), minimize ``T+ = T- + pi.v + 1/2 pi.W.pi`` subject
  to ``u_n = 0`` on A and ``pi_i in K_mu``. Its KKT system, with the multipliers ``lambda``
  of the equalities and ``s_i`` of the cones: ``y = W (pi - N lambda) + v = s`` on A, ``u_n = 0``
  on A, and per contact of A either ``s_i = 0`` (pi_i inside its cone) or ``s_i = sigma_i (mu,
  -t)`` with ``|pi_t| = mu pi_n`` (on the boundary, ``t = pi_t / |pi_t|``). The spatial
  one-contact slide is the same system with the boundary imposed (sigma of either sign).

Inside a mode these equations are smooth; their implicit differentiation
(:mod:`convimpact.impact.derivatives.modes`) is the derivative. Mode boundaries are stated
in ``one_sided``: a contact of A whose impulse vanishes, a contact off A about to press
(``u_n = 0``), the stick limit, a P_N contact between the cone's interior and its boundary
(sigma = 0), a slip ``v_t- = 0`` that fixes eq. (55)'s direction. ``other_side=True`` gives
the neighbouring mode's derivative where that mode is this law's answer across the boundary
by continuity (the stick tier gaining or losing a frictionless contact, a P_N contact
leaving or reaching its cone's boundary); where the law re-selects its tier or active set
globally (the stick limit, a frictional contact at its cone's apex: the admissible sets then
depend on the direction of the perturbation, and the answer may jump) none is given and the
statement says so. Ties between active sets with different velocities (another admissible
set exactly as dissipative) are not detected here: the law then warns of several admissible
active sets.
"""

from __future__ import annotations

import numpy as np

from ..conic.paths import impulse_scale
from ...errors import NotSupportedError, ParameterError, SolverError
from ..problem.build import ImpactProblem
from ..derivatives.chain import zero_derivative
from ..derivatives.modes import VELOCITY_ONLY, ModeSystem, check_redundant
from .pn_complementarity import STICK_COND_MAX, newton_velocity_shift

LAW = "pereira-nikravesh"
#: relative distance to a mode boundary below which the answer counts as on it
BOUNDARY_RTOL = 1e-7
#: relative residual of P_N(A)'s stationarity above which the answer is not its KKT point
KKT_RTOL = 1e-6
_NO_OTHER = " (no other-side derivative: across it the law re-selects its tier or active set)"


def _cone_place(mu: float, p: np.ndarray, pscale: float) -> str:
    """Where a contact's impulse ``p`` lies in its cone: "apex" (vanishing against the
    impulse scale), else "interior" or "boundary" (``|p_t| = mu p_n`` to BOUNDARY_RTOL)."""
    size = float(np.linalg.norm(p))
    if size <= BOUNDARY_RTOL * pscale:
        return "apex"
    return "interior" if mu * p[0] - float(np.linalg.norm(p[1:])) > BOUNDARY_RTOL * size \
        else "boundary"


def _stick(problem: ImpactProblem, A: list[int], b: np.ndarray):
    """The stick tier's derivative: ``pi_S = -W_SS^+ b_S``, pi = 0 off S."""
    n, d = problem.n_contacts, problem.dim
    N = n * d
    W, v = problem.delassus, problem.v_minus.ravel()
    S = [k for i in A for k in ([i * d] + (list(range(i * d + 1, (i + 1) * d))
                                           if problem.friction[i] > 0.0 else []))]
    S = np.array(S, dtype=int)
    Wss = W[np.ix_(S, S)]
    singular = not np.linalg.cond(Wss) < STICK_COND_MAX
    Pinv = np.linalg.pinv(Wss, rcond=float(np.finfo(float).eps) * S.size, hermitian=True)
    x = -Pinv @ b[S]
    null = np.eye(S.size) - Pinv @ Wss if singular else np.zeros((S.size, S.size))
    z = Pinv @ x
    dW = np.zeros((N, N, N))
    dW[np.ix_(S, S, S)] = -Pinv[:, :, None] * x[None, None, :] + \
        null[:, :, None] * z[None, None, :]
    dv = np.zeros((N, N))
    de = np.zeros((N, n))
    for c, k in enumerate(S):  # db_k / dv_k and db_k / de_i
        i = k // d
        if k % d == 0 and v[k] < 0.0:
            dv[S, k] = -Pinv[:, c] * (1.0 + problem.restitution[i])
            de[S, i] += -Pinv[:, c] * v[k]
        else:
            dv[S, k] = -Pinv[:, c]
    return (dW, dv, de, np.zeros((N, n))), singular


def _multipliers(problem: ImpactProblem, A: list[int], kinds: dict[int, str],
                 pi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """P_N(A)'s multipliers (lambda per contact of A, sigma per boundary contact) from its
    stationarity ``W pi + v = W N lambda + s`` by least squares; SolverError when the answer
    does not satisfy it (not P_N(A)'s KKT point)."""
    d = problem.dim
    W, v = problem.delassus, problem.v_minus.ravel()
    g = W @ pi + v
    bnd = [i for i in A if kinds[i] == "boundary"]
    rows = [k for i in A for k in (range(i * d, (i + 1) * d) if kinds[i] != "frictionless"
                                   else [i * d])]
    K = np.zeros((len(rows), len(A) + len(bnd)))
    for c, j in enumerate(A):
        K[:, c] = W[rows, j * d]
    for c, i in enumerate(bnd):
        t = pi[i * d + 1:(i + 1) * d] / np.linalg.norm(pi[i * d + 1:(i + 1) * d])
        s = np.zeros(len(v))
        s[i * d] = problem.friction[i]
        s[i * d + 1:(i + 1) * d] = -t
        K[:, len(A) + c] = s[rows]
    sol, *_ = np.linalg.lstsq(K, g[rows], rcond=None)
    resid = float(np.max(np.abs(K @ sol - g[rows]))) if rows else 0.0
    if resid > KKT_RTOL * max(float(np.max(np.abs(v))), 1e-300):
        raise SolverError(
            f"the answer does not satisfy the KKT conditions of P_N over active set {A} "
            f"(stationarity residual {resid:.2e}): its mode cannot be identified")
    return sol[:len(A)], sol[len(A):]


def _slide(problem: ImpactProblem, A: list[int], kinds: dict[int, str], pi: np.ndarray,
           redundant: str):
    """The slide tier's derivative for the kinds of the contacts of A ("interior",
    "boundary", "frictionless", "apex", "planar" for eq. (55)'s one-contact slide)."""
    n, d = problem.n_contacts, problem.dim
    N = n * d
    W, v, e, mu = problem.delassus, problem.v_minus.ravel(), problem.restitution, \
        problem.friction
    if len(A) == 1 and kinds[A[0]] in ("planar", "frictionless"):
        i = A[0]
        S = ModeSystem(W, v, e, d, pi)
        for j in range(n):
            if j != i:
                S.separating(j)
        if kinds[i] == "frictionless":
            S.frictionless(i, S.velocity(i * d))
        else:
            S.planar_slide(i, float(mu[i]), float(np.sign(pi[i * d + 1])))
        return S.solve(f"law {LAW!r}, slide tier on contact {i}", redundant)
    lam, sig = _multipliers(problem, A, kinds, pi)
    bnd = [i for i in A if kinds[i] == "boundary"]
    S = ModeSystem(W, v, e, d, pi, len(A) + len(bnd), np.concatenate([lam, sig]))
    lcol = {j: N + c for c, j in enumerate(A)}
    scol = {i: N + len(A) + c for c, i in enumerate(bnd)}
    for i in range(n):
        kind = kinds.get(i, "separating")
        if kind in ("separating", "apex"):
            S.separating(i)
            continue
        y = [S.stationarity(i * d + k, lcol) for k in range(d)]
        if kind == "frictionless":
            S.frictionless(i, y[0])
        elif kind == "interior":
            S.add(*y)
        else:
            S.slide_on_cone(i, float(mu[i]), 1.0, scol[i], y)
    S.add(*(S.velocity(j * d) for j in A))
    return S.solve(f"law {LAW!r}, P_N over active set {A}", redundant)


def _slide_kinds(problem: ImpactProblem, A: list[int], pi: np.ndarray,
                 pscale: float) -> tuple[dict, list, dict]:
    """The kinds of A's contacts in the slide tier, the boundary statements and the flips to
    the other side."""
    d = problem.dim
    mu = problem.friction
    kinds: dict[int, str] = {}
    notes: list[str] = []
    flips: dict[int, str] = {}
    if len(A) == 1:
        i = A[0]
        kinds[i] = "frictionless" if mu[i] == 0.0 else ("planar" if d == 2 else "boundary")
        if d == 2 and mu[i] > 0.0 and problem.v_minus[i, 1] == 0.0:
            notes.append(f"contact {i}: no pre-impact slip (v_t- = 0): eq. (55)'s direction is "
                         "the stick impulse's; one-sided" + _NO_OTHER)
        return kinds, notes, flips
    for i in A:
        kinds[i] = "frictionless" if mu[i] == 0.0 else _cone_place(mu[i], pi[i * d:(i + 1) * d],
                                                                    pscale)
        if kinds[i] == "apex":
            notes.append(f"contact {i}: its impulse in P_N vanishes (the cone's apex): "
                         "one-sided" + _NO_OTHER)
    if any(k == "boundary" for k in kinds.values()):
        _, sig = _multipliers(problem, A, kinds, pi)
        bnd = [i for i in A if kinds[i] == "boundary"]
        vscale = max(float(np.max(np.abs(problem.v_minus))), 1e-300)
        for c, i in enumerate(bnd):
            if abs(sig[c]) <= BOUNDARY_RTOL * vscale:
                flips[i] = "interior"
                notes.append(f"contact {i}: on its cone's boundary with a zero multiplier: "
                             "one-sided derivative of the boundary mode, the other side inside "
                             "the cone")
    return kinds, notes, flips


def several_impulse_derivative(problem: ImpactProblem, result, other_side: bool = False, *,
                               redundant: str = "raise"):
    """Derivative of the ``pereira-nikravesh`` impulse at several contacts with respect to
    ``(W, v_minus, e, mu)`` inside the answer's mode (module docstring).

    Parameters
    ----------
    problem : ImpactProblem
        The problem the result answers (:func:`~convimpact.impact.problem.build.build_problem`).
    result : ImpactResult
        An answer of law ``pereira-nikravesh`` at several contacts (any method).
    other_side : bool
        At a mode boundary, also the neighbouring mode's derivative (``.other_side``) where
        the law's answer continues into it.
    redundant : {"raise", "velocity"}
        In the slide tier, where redundant contacts leave the impulse non-unique: raise
        NotSupportedError, or give the minimum-norm derivative of the mode's equations, exact
        for the velocity (``W dpi``, ``G Jc^T dpi``), stated in ``one_sided``. (The stick
        tier has the law's own minimum-norm rule and its derivative.)

    Returns
    -------
    ContactDerivative

    Raises
    ------
    NotSupportedError
        One contact (see ``impulse_derivative``), or a singular mode system in the slide
        tier (redundant contacts: the impulse is not unique).
    ParameterError
        The result is another law's.
    SolverError
        The answer does not satisfy its active set's KKT conditions.
    """
    from ..derivatives.contact import ContactDerivative

    check_redundant(redundant)
    if getattr(result, "law", LAW) != LAW:
        raise ParameterError(f"the result is law {result.law!r}'s, not {LAW!r}'s")
    n, d = problem.n_contacts, problem.dim
    if n == 1:
        raise NotSupportedError("one contact: law 'pereira-nikravesh''s derivative at one "
                                "contact is its impulse_derivative")
    reported = (result.regime,) * n if isinstance(result.regime, str) else tuple(result.regime)
    extras = result.diagnostics.extras
    A = extras.get("active_set")
    if A is None:  # no contact approaches: no impulse, and none nearby
        return zero_derivative(problem, reported, False)
    A = sorted(int(i) for i in A)
    tier = extras.get("tier", "stick")
    N = n * d
    pi = np.asarray(result.impulse, dtype=float).reshape(N)
    b = newton_velocity_shift(problem).ravel()
    u = problem.delassus @ pi + b
    pscale = impulse_scale(problem)
    vscale = max(float(np.max(np.abs(problem.v_minus))), 1e-300)
    notes: list[str] = []
    grow = []  # contacts about to press whose sticking continues the answer (no slip)
    for i in range(n):
        if i not in A and u[i * d] <= BOUNDARY_RTOL * vscale:
            if tier == "stick" and problem.friction[i] == 0.0:
                grow.append(i)
                notes.append(f"contact {i}: frictionless, off the active set with u_n = 0 "
                             "(about to press): one-sided derivative of the active set without "
                             "it, the other side with it")
            else:
                notes.append(f"contact {i}: off the active set with u_n = 0 (about to press): "
                             "one-sided" + _NO_OTHER)
        if i in A and problem.v_minus[i, 0] == 0.0 and problem.restitution[i] > 0.0:
            notes.append(f"contact {i}: touching (v_n- = 0) with e > 0, the kink of Newton's "
                         "b_n = v_n + e min(v_n, 0): the derivative is that of a contact "
                         "not approaching (d b_n / d v_n = 1; approaching, 1 + e)")

    def derivative(parts, regimes, statements, other=None):
        dW, dv, de, dmu = parts
        return ContactDerivative(W=dW, v=dv, e=de, mu=dmu, e_t=None, regimes=tuple(regimes),
                                 one_sided=tuple(statements), other_side=other)

    if tier == "stick":
        shrink = []
        for i in A:
            place = _cone_place(problem.friction[i], pi[i * d:(i + 1) * d], pscale)
            if place == "apex" and problem.friction[i] == 0.0:
                shrink.append(i)
                notes.append(f"contact {i}: frictionless, in the active set with zero impulse "
                             "(about to separate): one-sided derivative of the active set with "
                             "it, the other side without it")
            elif place == "apex":
                notes.append(f"contact {i}: in the active set with zero impulse (at its "
                             "cone's apex): one-sided" + _NO_OTHER)
            elif problem.friction[i] > 0.0 and place == "boundary":
                notes.append(f"contact {i}: at the stick limit (|pi_t| = mu pi_n): one-sided "
                             "derivative of the stick tier" + _NO_OTHER)
        parts, singular = _stick(problem, A, b)
        if singular:
            notes.append("redundant contacts (W singular on the active set): the stick "
                         "impulse is the law's minimum-norm choice, and its derivative holds "
                         "along the perturbations that keep the stick equations consistent "
                         "and of the same rank (those of a rigid body's geometry and inertia "
                         "that keep its contacts redundant); elsewhere the law leaves this "
                         "active set")
        other = None
        if other_side and (grow or shrink):
            B = sorted((set(A) | set(grow)) - set(shrink))
            labels = [("stick" if problem.friction[i] > 0.0 else "frictionless")
                      if i in B else "separating" for i in range(n)]
            zero = (np.zeros((N, N, N)), np.zeros((N, N)), np.zeros((N, n)),
                    np.zeros((N, n)))
            other = derivative(_stick(problem, B, b)[0] if B else zero, labels,
                               [s + " (this is the other side)" for s in notes])
        return derivative(parts, reported, notes, other)
    kinds, more, flips = _slide_kinds(problem, A, pi, pscale)
    notes += more
    other = None
    if other_side and flips:
        *parts, singular = _slide(problem, A, {**kinds, **flips}, pi, redundant)
        other = derivative(parts, list(reported),
                           [s + " (this is the other side)" for s in notes]
                           + ([VELOCITY_ONLY] if singular else []))
    *parts, singular = _slide(problem, A, kinds, pi, redundant)
    return derivative(parts, reported, notes + ([VELOCITY_ONLY] if singular else []), other)
