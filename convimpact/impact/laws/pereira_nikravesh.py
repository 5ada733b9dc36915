"""The paper's law (Section 8): stick if the sticking impulse lies in the friction cone, else
slide on the cone's boundary with pi_n from eq. (38)/(51) -- in the plane along eq. (55), in
space along the direction of maximal dissipation (eq. 60).

* The closed forms (:func:`frictionless_impulse`, :func:`sticking_impulse`,
  :func:`sliding_impulse`, :func:`stick_admissible`, :func:`pereira_nikravesh`) act on one
  contact's Delassus block ``W`` (d x d, d = 2 planar or 3 spatial; for closed loops it is the
  Schur complement of the bordered matrices of eqs. (51)/(52), so the same kernels serve open
  and closed loops) and its pre-impact contact velocity ``v = (v_n, v_t...)`` in the contact
  frame. Impulses come back in the contact frame, normal first. ``v_n < 0`` means approaching.
* :func:`contact_kernel` is the exact single-contact kernel (``method="fast"``): in space its
  sliding direction is :func:`convimpact.impact.max_dissipation.max_dissipation_slide`.
* :func:`program_result` is the conic path (``method="clarabel"``/``"cvxpy"``). One planar
  contact: the closed form (stick test, then eq. 55). One spatial contact: the stick test
  (eq. 52, admissible by eq. 53), else the program P_N: minimize T+ (``q = v-``) subject to
  ``v_n+ = -e v_n-`` and ``pi in K_mu``; its boundary optimum's tangent is the seed's
  maximal-dissipation direction (eq. 60), exact once P_N is KKT-polished (else refined by a
  bounded 1-D maximization of T_L). P_N's *interior* optimum is not sticking when e > 0, so
  where it is interior but the stick test failed the law falls back to
  :func:`~convimpact.impact.max_dissipation.max_dissipation_direction` and flags the
  disagreement. Infeasible P_N (a Painleve-like jam) raises NonPositiveEffectiveMassError.
* Several contacts: Newton's law in complementarity form, ``v_n+ + e v_n- >= 0``,
  ``pi_n >= 0``, complementary (:mod:`~convimpact.impact.laws.pn_complementarity`): the
  law sticks on the most dissipative admissible set of touching contacts, else slides on
  the most dissipative admissible one (P_N over that set). A contact approaching at
  round-off changes nothing; a contact that does not approach may be pressed by the others
  (then it leaves at v_n+ = 0) instead of penetrating.

Sign convention: the paper's tangent ``t`` (eq. 55) points opposite to the pre-impact slip and
its ``pi_t`` is measured along it; here the tangential impulse is expressed on the frame's
own axes (t or t1, t2), so a friction impulse that opposes the slip has ``pi_t . v_t- < 0``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..conic.paths import ProgramOptions, register_programs, solver_report
from ..conic.qp import Backend, ConeQP, QPSolution, solve_cone_qp
from ..diagnostics import assemble_result
from ..errors import (
    as_real_array,
    real_number,
    NonPositiveEffectiveMassError,
    NotSupportedError,
    SingularSystemError,
    SolverError,
    UnknownOptionError,
)
from ..fast import ContactSolution, frictionless, in_cone, jam_error, register_kernel, solution
from ..max_dissipation import max_dissipation_direction, max_dissipation_slide
from ..problem import ImpactProblem
from ..resolve import register_solver
from ..results import ImpactResult
from ..small_linalg import angle_from_slip, inverse3, linsolve3, solve2
from .pn_complementarity import newton_velocity_shift, several_contacts_result, stick_on

LAW = "pereira-nikravesh"
#: relative distance from the cone boundary below which a P_N optimum counts as "on it"
BOUNDARY_RTOL = 1e-5
#: condition number above which W is treated as singular by the sticking solve
DELASSUS_COND_MAX = 1e12
#: relative tolerance of the stick admissibility test |pi_t| <= mu pi_n
STICK_RTOL = 1e-12


def frictionless_impulse(W: np.ndarray, v: np.ndarray, e: float) -> np.ndarray:
    """Frictionless (or central) impulse: eq. (38) with mu = 0, pi_n = -(1+e) v_n / m_nn."""
    W = as_real_array("W", W)
    v = as_real_array("v", v)
    e = real_number("e", e)
    w_nn = float(W[0, 0])
    if not w_nn > 0.0:
        raise SingularSystemError(
            f"c_n^T M^-1 c_n = {w_nn:.3e}: the contact normal moves no mass in this "
            "configuration (the contact point cannot move along n); no impulse can act there"
        )
    pi = np.zeros(W.shape[0])
    pi[0] = -(1.0 + e) * float(v[0]) / w_nn  # eq. (38), mu = 0
    return pi


def sticking_impulse(W: np.ndarray, v: np.ndarray, e: float) -> np.ndarray:
    """Impulse that stops the slip and restitutes the normal velocity: eq. (42) / (52).

    Solves ``W pi = -((1+e) v_n, v_t)``; in space the 3 x 3 analogue with t1, t2.

    Raises
    ------
    SingularSystemError
        when W is singular (contact directions dependent through the mechanism).
    """
    W = as_real_array("W", W)
    v = as_real_array("v", v)
    e = real_number("e", e)
    lam = np.linalg.eigvalsh(W)  # W is symmetric positive semi-definite
    cond = lam[-1] / lam[0] if lam[0] > 0 else np.inf
    if not cond < DELASSUS_COND_MAX:
        raise SingularSystemError(
            f"the Delassus matrix W = Jc M^-1 Jc^T is singular (cond = {cond:.3e}): the "
            "contact's tangential and normal motions are dependent here, so the sticking "
            "solve of eq. (42)/(52) has no unique answer; use law='dissipative' or "
            "law='coulomb' with method='cvxpy', which accept a singular W"
        )
    rhs = -np.asarray(v, dtype=float).copy()
    rhs[0] *= 1.0 + e  # eq. (42): right-hand side -(1+e) v_n, -v_t
    return np.linalg.solve(W, rhs)


def sliding_impulse(W: np.ndarray, v: np.ndarray, e: float, mu: float,
                    direction: np.ndarray) -> tuple[np.ndarray, float]:
    """Sliding impulse pi = pi_n (n + mu t) with pi_n from eq. (38) / (51).

    Parameters
    ----------
    direction : (d-1,) unit vector of the friction impulse in the tangent plane (the paper's t).
        ``mu`` may be negative here (the paper's landscapes use it to flip t); the public API
        validates mu >= 0 before calling.

    Returns
    -------
    impulse, effective_mass_denominator
        ``c_n^T G (c_n + mu c_t)``, the denominator of eq. (38).

    Raises
    ------
    NonPositiveEffectiveMassError
        when that denominator is not positive (Painleve-like jam): no finite compressive
        normal impulse slides the contact along t.
    """
    W = as_real_array("W", W)
    v = as_real_array("v", v)
    e = real_number("e", e)
    mu = real_number("mu", mu)
    g = np.empty(W.shape[0])
    g[0] = 1.0
    g[1:] = mu * np.asarray(direction, dtype=float)
    denom = float(W[0] @ g)  # c_n^T M^-1 (c_n + mu c_t), eq. (38)
    if not denom > 1e-12 * float(np.max(np.abs(W))):
        coupling = float(W[0, 1:] @ np.asarray(direction, dtype=float))
        crit = (f"; sliding along t is well posed for mu < {W[0, 0] / -coupling:.6g}"
                if coupling < 0 else "")
        raise NonPositiveEffectiveMassError(
            f"sliding denominator c_n^T M^-1 (c_n + mu c_t) = {denom:.3e} <= 0 at mu = {mu:g} "
            f"(Painleve-like jam: eq. (38) would divide by it){crit}; use law='coulomb', "
            "'ccp' or 'dissipative', which stay well posed"
        )
    return (-(1.0 + e) * float(v[0]) / denom) * g, denom


def stick_admissible(impulse: np.ndarray, mu: float, rtol: float = STICK_RTOL) -> bool:
    """Contact law (53): the stick impulse lies in the friction cone, |pi_t| <= mu pi_n."""
    impulse = as_real_array("impulse", impulse)
    mu = real_number("mu", mu)
    pn = float(impulse[0])
    return pn >= 0.0 and float(np.linalg.norm(impulse[1:])) <= mu * pn * (1.0 + rtol)


def planar_slide_direction(v: np.ndarray, stick_impulse: np.ndarray | None) -> np.ndarray:
    """Tangent of the friction impulse in the plane: opposite to v_t- (eq. 55).

    With no pre-impact slip (v_t- = 0) eq. (55) is undefined; the friction then saturates in
    the direction the sticking impulse needed (sign of its pi_t).
    """
    vt = float(v[1])
    if vt != 0.0:
        return np.array([-np.sign(vt)])
    s = float(np.sign(stick_impulse[1])) if stick_impulse is not None else 0.0
    return np.array([s if s != 0.0 else 1.0])


def pereira_nikravesh(W: np.ndarray, v: np.ndarray, e: float, mu: float,
                      slide_direction=None) -> tuple[np.ndarray, str, float | None]:
    """The Section 8 algorithm for one approaching contact.

    1. Solve the sticking problem (eq. 42/52). 2. If |pi_t| <= mu pi_n, stick (eq. 53).
    3. Otherwise slide on the cone boundary with pi_n from eq. (38)/(51): in the plane along
    t = -v_t-/|v_t-| (eq. 55); in space along ``slide_direction(W, v, e, mu)`` (the
    maximal-dissipation direction; the closed form alone has none and raises).

    Returns
    -------
    impulse, regime, sliding denominator (None unless sliding)
    """
    W = as_real_array("W", W)
    v = as_real_array("v", v)
    e = real_number("e", e)
    mu = real_number("mu", mu)
    if mu == 0.0:
        return frictionless_impulse(W, v, e), "frictionless", None
    stick = sticking_impulse(W, v, e)
    if stick_admissible(stick, mu):
        return stick, "stick", None
    if W.shape[0] == 2:
        direction = planar_slide_direction(v, stick)
    elif slide_direction is None:
        raise NotSupportedError(
            "spatial sliding needs the maximal-dissipation direction of the tangential "
            "impulse (Section 9.3), which has no closed form in the paper: use "
            "method='fast' (exact), 'cvxpy', 'clarabel' or 'sweep' (the paper's search)"
        )
    else:
        direction = slide_direction(W, v, e, mu)
    impulse, denom = sliding_impulse(W, v, e, mu, direction)
    return impulse, "slide", denom


# --------------------------------------------------------------------------------------------
# the exact single-contact kernel (method="fast")


def contact_kernel(w: list, v: list, d: int, e: float, mu: float) -> ContactSolution:
    """The seed's law for one contact on plain floats (the ``fast`` kernel)."""
    if mu == 0.0:
        return frictionless(w, v, d, e)
    c = -(1.0 + e) * v[0]
    if d == 2:
        pn, pt = solve2(w, c, -v[1], LAW)  # eq. (42)
        if in_cone(pn, abs(pt), mu):
            return solution((pn, pt), "stick")
        s = -math.copysign(1.0, v[1]) if v[1] != 0.0 else (math.copysign(1.0, pt) if pt else 1.0)
        D = w[0][0] + mu * s * w[0][1]  # eq. (55) direction, eq. (38) denominator
        if not D > 1e-12 * max(abs(w[0][0]), abs(w[0][1]), abs(w[1][1])):
            raise jam_error(mu, D, LAW)
        p = c / D
        return solution((p, mu * s * p), "slide", D)
    inv = inverse3(w, LAW)
    pn, p1, p2 = linsolve3(w, inv, c, -v[1], -v[2])  # eq. (42) in space
    ptn = math.hypot(p1, p2)
    if in_cone(pn, ptn, mu):
        return solution((pn, p1, p2), "stick")
    t1, t2, tl, p, D, interior = max_dissipation_slide(w, v, c, mu, inv, (p1, p2))
    extras = {"alpha_m": angle_from_slip(v[1], v[2], t1, t2), "energy_loss_max": tl,
              "normal_impulse": p, "direction": (t1, t2), "pn_optimum_interior": interior}
    warns = ()
    if interior:
        warns = ("P_N's optimum is interior to the cone (with e > 0 its slip is not zero) while "
                 "the stick test failed: the seed's boundary maximal-dissipation direction is "
                 "used",)
    return solution((p, mu * p * t1, mu * p * t2), "slide", D, extras, warns)


# --------------------------------------------------------------------------------------------
# the conic path: joint stick test, then the program P_N


def solve_pn_program(P: ImpactProblem, backend: Backend,
                     opts: ProgramOptions) -> tuple[np.ndarray, QPSolution]:
    """The program P_N over the approaching contacts: minimize T+ s.t. v_n+ = -e v_n-, pi in K.

    Contacts with v_n- >= 0 are left out (zero impulse). Returns the full (n_contacts, d)
    impulse and the solver report; infeasibility raises a typed error naming other laws.
    """
    n, d = P.n_contacts, P.dim
    active = np.flatnonzero(P.v_minus[:, 0] < 0.0)
    idx = np.concatenate([np.arange(i * d, (i + 1) * d) for i in active])
    W = P.delassus[np.ix_(idx, idx)]
    v = P.v_minus[active].ravel()
    nrows = np.arange(0, idx.size, d)
    E = W[nrows]
    f = -(1.0 + P.restitution[active]) * P.v_minus[active, 0]
    qp = ConeQP(W, v, P.friction[active], d, E, f)
    try:
        sol = solve_cone_qp(backend, qp, opts.tol, opts.max_iter)
    except SolverError as exc:
        if "infeasible" in str(exc).lower() or "Infeasible" in str(exc):
            if active.size == 1:
                raise NonPositiveEffectiveMassError(
                    "P_N is infeasible: no impulse in the friction cone restores v_n+ = -e v_n- "
                    "(Painleve-like jam, the sliding denominator of eq. (38) is not positive "
                    "in any admissible direction); use law='coulomb', 'ccp' or 'dissipative'"
                ) from exc
            raise SolverError(
                "P_N is infeasible: Newton's restitution cannot hold at every approaching "
                "contact with compressive impulses in the friction cones; use law='coulomb', "
                f"'ccp' or 'dissipative', which allow contacts to separate ({exc})") from exc
        raise
    pi = np.zeros((n, d))
    pi[active] = sol.x.reshape(active.size, d)
    return pi, sol


def _tl_slide(W: np.ndarray, v: np.ndarray, e: float, mu: float, a: float) -> float:
    """T_L (eq. 60) for a slide along angle a with pi_n from eq. (38); -inf where not defined."""
    g = np.array([1.0, mu * math.cos(a), mu * math.sin(a)])
    den = float(W[0] @ g)
    if den <= 0:
        return -math.inf
    pi = (-(1.0 + e) * v[0] / den) * g
    return -float(pi @ v + 0.5 * pi @ W @ pi)


def _polish_direction(W: np.ndarray, v: np.ndarray, e: float, mu: float,
                      direction: np.ndarray) -> np.ndarray:
    """Refine the spatial sliding angle near P_N's answer by a bounded maximization of T_L."""
    from scipy.optimize import minimize_scalar

    a0 = math.atan2(direction[1], direction[0])
    span = 1e-3
    res = minimize_scalar(lambda a: -_tl_slide(W, v, e, mu, a), bounds=(a0 - span, a0 + span),
                          method="bounded", options={"xatol": 1e-13})
    a = float(res.x)
    if not res.success or abs(a - a0) > 0.99 * span or \
            _tl_slide(W, v, e, mu, a) < _tl_slide(W, v, e, mu, a0):
        return direction
    return np.array([math.cos(a), math.sin(a)])


def program_result(P: ImpactProblem, backend: Backend, method: str,
                   opts: ProgramOptions) -> ImpactResult:
    n = P.n_contacts
    law = LAW
    if n == 1 and P.planar:
        # one planar contact: the law is the closed form (stick test, then eq. 55)
        W, v = P.contact_block(0)
        impulse, regime, denom = pereira_nikravesh(W, v, float(P.restitution[0]),
                                                   float(P.friction[0]))
        return assemble_result(P, impulse[None], [regime], law, method, effective_mass=denom,
                               tol=1e-12, extras={"stick_test": regime == "stick",
                                                  "slide_rule": "eq. (55)"})
    if n > 1:
        # several contacts: Newton's law in complementarity form over the active sets
        return several_contacts_result(P, backend, method, opts)
    # one spatial contact: the stick test (eq. 52), else P_N and its boundary direction
    active = P.v_minus[:, 0] < 0.0
    W0, v0 = P.contact_block(0)
    if P.friction[0] == 0.0:
        return assemble_result(P, frictionless_impulse(W0, v0, float(P.restitution[0]))[None],
                               ["frictionless"], law, method, tol=1e-10,
                               extras={"stick_test": True})
    stick = stick_on(P, (0,), newton_velocity_shift(P))  # least squares where W is singular
    if stick is not None and stick_admissible(stick[0], float(P.friction[0])):
        return assemble_result(P, stick, ["stick"], law, method, tol=1e-10,
                               extras={"stick_test": True})
    pi, sol = solve_pn_program(P, backend, opts)
    acc = opts.accuracy(sol.polished)
    warnings: list[str] = []
    interior = []
    regimes = []
    denom = None
    for i in range(n):
        if not active[i]:
            interior.append(False)
            regimes.append("separating")
            continue
        if P.friction[i] == 0:
            interior.append(False)
            regimes.append("frictionless")
            continue
        pt = np.linalg.norm(pi[i, 1:])
        interior.append(bool(pt < P.friction[i] * pi[i, 0] * (1.0 - BOUNDARY_RTOL)))
        regimes.append("slide")
    extras: dict[str, Any] = {"stick_test": False, **solver_report(sol, opts),
                              "pn_interior": interior, "pn_disagreement": any(interior)}
    if P.friction[0] > 0:
        W, v = P.contact_block(0)
        e, mu = float(P.restitution[0]), float(P.friction[0])
        if interior[0]:
            direction = np.asarray(max_dissipation_direction(W, v, e, mu, tol=opts.tol),
                                   dtype=float)
            warnings.append("P_N's optimum is interior but the stick test failed: the sliding "
                            "direction comes from the boundary search (maximal T_L on the cone)")
            extras["slide_rule"] = "boundary search (sweep)"
        elif sol.polished:
            # the KKT polish solved P_N's boundary optimum exactly: its tangent is eq. (60)'s
            direction = pi[0, 1:] / np.linalg.norm(pi[0, 1:])
            extras["slide_rule"] = "P_N (boundary optimum, KKT-polished)"
        else:
            direction = _polish_direction(W, v, e, mu, pi[0, 1:] / np.linalg.norm(pi[0, 1:]))
            extras["slide_rule"] = "P_N (boundary optimum, angle refined by a 1-D search)"
        impulse, denom = sliding_impulse(W, v, e, mu, direction)
        extras["slide_angle"] = math.atan2(direction[1], direction[0])
        pi = impulse[None]
        acc = 1e-9
    return assemble_result(P, pi, regimes, law, method, effective_mass=denom, tol=acc,
                           extras=extras, warnings=tuple(warnings))


@register_solver(LAW, "closed-form")
def _closed_form(problem: ImpactProblem, **options) -> ImpactResult:
    """Section 8 algorithm, one contact, planar or spatial sticking (spatial sliding raises)."""
    if options:
        raise UnknownOptionError(
            f"method 'closed-form' takes no options, got {', '.join(sorted(options))}")
    if problem.n_contacts != 1:
        raise NotSupportedError(
            "the closed form treats one contact; for several simultaneous contacts use "
            "method='clarabel' or 'cvxpy'")
    W, v = problem.contact_block(0)
    impulse, regime, denom = pereira_nikravesh(
        W, v, float(problem.restitution[0]), float(problem.friction[0]))
    return assemble_result(problem, impulse[None], [regime], LAW, "closed-form",
                           effective_mass=denom, tol=1e-12)


register_kernel(LAW, contact_kernel)
register_programs(LAW, program_result)
