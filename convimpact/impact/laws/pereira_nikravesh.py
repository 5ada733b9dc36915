"""The paper's law (Section 8): stick if the sticking impulse lies in the friction cone, else
slide on the cone's boundary with pi_n from eq. (38)/(51) -- in the plane along eq. (55), in
space along the direction of maximal dissipation (eq. 60).

* The closed forms (:func:`frictionless_impulse`, :func:`sticking_impulse`,
  :func:`sliding_impulse`, :func:`stick_admissible`, :func:`pereira_nikravesh`) act on one
  contact's Delassus block ``W`` (d x d, d = 2 planar or 3 spatial; for closed loops it is the
  Schur complement of the bordered matrices of eqs. (51)/(52), so the same kernels serve open
  and closed loops) and its pre-impact contact velocity ``v = (v_n, v_t...)`` in the contact
  frame. Impulses come back in the contact frame, normal first. ``v_n < 0`` means approaching.
* :func:`~.pereira_nikravesh_kernel._pn_planar` and ``_pn_spatial`` are the exact
  single-contact kernel (``method="fast"``, the batch, the compiled lane), compiled: in space the sliding direction
  is :func:`convimpact.impact.laws.max_dissipation.max_dissipation_slide`; :func:`contact_kernel`
  is their entry on plain floats.
* :func:`program_result` is the conic path (``method="clarabel"``/``"cvxpy"``). One planar
  contact: the closed form (stick test, then eq. 55). One spatial contact: the stick test
  (eq. 52, admissible by eq. 53), else the program P_N: minimize T+ (``q = v-``) subject to
  ``v_n+ = -e v_n-`` and ``pi in K_mu``; its boundary optimum's tangent is the seed's
  maximal-dissipation direction (eq. 60), exact once P_N is KKT-polished (else refined by a
  bounded 1-D maximization of T_L). P_N's *interior* optimum is not sticking when e > 0, so
  where it is interior but the stick test failed the law falls back to
  :func:`~convimpact.impact.laws.max_dissipation.max_dissipation_direction` and flags the
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

from ..conic.paths import ProgramOptions, solver_report
from ..conic.qp import Backend, QPSolution, solve_cone_qp
from ..diagnostics import assemble_result
from ..exact.closed_forms import (  # the paper's closed forms, re-exported
    DELASSUS_COND_MAX,
    STICK_RTOL,
    frictionless_impulse,
    pereira_nikravesh,
    planar_slide_direction,
    sliding_impulse,
    stick_admissible,
    sticking_impulse,
)
from ...errors import (NonPositiveEffectiveMassError, SingularSystemError, SolverError)
from ..options import check_single_contact
from ..exact.dispatch import compiled_kernel
from .max_dissipation import max_dissipation_direction
from ..problem.build import ImpactProblem
from ..results import ImpactResult
from ..problem.dense import angle_from_slip
from .pereira_nikravesh_kernel import (_OUT_INTERIOR, _OUT_T1, _OUT_T2, _OUT_TL, _pn_planar,
                                       _pn_spatial)
from .pn_complementarity import (newton_velocity_shift, several_contacts_result, slide_program,
                                 stick_on)
from .pn_complementarity_derivative import several_impulse_derivative  # noqa: F401

LAW = "pereira-nikravesh"
#: relative distance from the cone boundary below which a P_N optimum counts as "on it"
BOUNDARY_RTOL = 1e-5


# --------------------------------------------------------------------------------------------
# the exact single-contact kernel (method="fast"), compiled: every path runs this code
# (:mod:`.pereira_nikravesh_kernel`: the law's several-contact search calls it too)


def _extras(out, regime, impulse, w, v, d, e, mu) -> tuple:
    """The spatial slide's figures: the angle alpha_m from v_t- and T_L there (Fig. 9)."""
    if d == 2 or regime != "slide":
        return None, ()
    t1, t2 = float(out[_OUT_T1]), float(out[_OUT_T2])
    interior = bool(out[_OUT_INTERIOR])
    extras = {"alpha_m": angle_from_slip(v[1], v[2], t1, t2),
              "energy_loss_max": float(out[_OUT_TL]), "normal_impulse": impulse[0],
              "direction": (t1, t2), "pn_optimum_interior": interior}
    warns = ()
    if interior:
        warns = ("P_N's optimum is interior to the cone (with e > 0 its slip is not zero) while "
                 "the stick test failed: the seed's boundary maximal-dissipation direction is "
                 "used",)
    return extras, warns


contact_kernel = compiled_kernel(
    LAW, _pn_planar, _pn_spatial, _extras,
    no_solution="the maximal-dissipation direction could not be certified (KKT of P_N or "
                "probe directions); use method='sweep' or 'clarabel'")


# --------------------------------------------------------------------------------------------
# the conic path: joint stick test, then the program P_N


def solve_pn_program(P: ImpactProblem, backend: Backend,
                     opts: ProgramOptions) -> tuple[np.ndarray, QPSolution]:
    """The program P_N over the approaching contacts: minimize T+ s.t. v_n+ = -e v_n-, pi in K.

    Contacts with v_n- >= 0 are left out (zero impulse). Returns the full (n_contacts, d)
    impulse and the solver report; infeasibility raises a typed error naming other laws.
    """
    active = np.flatnonzero(P.v_minus[:, 0] < 0.0)
    f = -(1.0 + P.restitution[active]) * P.v_minus[active, 0]
    try:
        sol = solve_cone_qp(backend, slide_program(P, active, f), opts.tol, opts.max_iter)
    except SolverError as exc:
        if "infeasible" in str(exc).lower():
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
    pi = np.zeros((P.n_contacts, P.dim))
    pi[active] = sol.x.reshape(active.size, P.dim)
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
        e, mu = float(P.restitution[0]), float(P.friction[0])
        try:
            impulse, regime, denom = pereira_nikravesh(W, v, e, mu)
        except SingularSystemError:
            # a singular W (normal and tangent rows dependent): the sticking solve has no
            # unique answer; stick where the least-squares one is consistent and admissible
            # (eq. 53), else slide along eq. (55)'s t = -sgn(v_t-), which needs no W^-1
            stick = stick_on(P, (0,), newton_velocity_shift(P))
            if stick is not None and stick_admissible(stick[0], mu):
                impulse, regime, denom = stick[0], "stick", None
            elif v[1] != 0.0:
                impulse, denom = sliding_impulse(W, v, e, mu, planar_slide_direction(v, None))
                regime = "slide"
            else:
                raise
        return assemble_result(P, impulse[None], [regime], law, method, effective_mass=denom,
                               tol=1e-12, extras={"stick_test": regime == "stick",
                                                  "slide_rule": "eq. (55)"})
    if n > 1:
        # several contacts: Newton's law in complementarity form over the active sets
        return several_contacts_result(P, backend, method, opts)
    # one spatial contact, approaching (resolve answers a separating one before any path):
    # the stick test (eq. 52), else P_N and its boundary direction
    W, v = P.contact_block(0)
    e, mu = float(P.restitution[0]), float(P.friction[0])
    if mu == 0.0:
        return assemble_result(P, frictionless_impulse(W, v, e)[None], ["frictionless"], law,
                               method, tol=1e-10, extras={"stick_test": True})
    stick = stick_on(P, (0,), newton_velocity_shift(P))  # least squares where W is singular
    if stick is not None and stick_admissible(stick[0], mu):
        return assemble_result(P, stick, ["stick"], law, method, tol=1e-10,
                               extras={"stick_test": True})
    pi, sol = solve_pn_program(P, backend, opts)
    interior = bool(np.linalg.norm(pi[0, 1:]) < mu * pi[0, 0] * (1.0 - BOUNDARY_RTOL))
    extras: dict[str, Any] = {"stick_test": False, **solver_report(sol, opts),
                              "pn_interior": [interior], "pn_disagreement": interior}
    warnings = ()
    if interior:
        direction = np.asarray(max_dissipation_direction(W, v, e, mu, tol=opts.tol), dtype=float)
        warnings = ("P_N's optimum is interior but the stick test failed: the sliding "
                    "direction comes from the boundary search (maximal T_L on the cone)",)
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
    return assemble_result(P, impulse[None], ["slide"], law, method, effective_mass=denom,
                           tol=1e-9, extras=extras, warnings=warnings)


def closed_form(problem: ImpactProblem, **options) -> ImpactResult:
    """Section 8 algorithm, one contact, planar or spatial sticking (spatial sliding raises)."""
    check_single_contact(problem, options, "closed-form", "no options,",
                         "the closed form treats one contact; for several simultaneous "
                         "contacts use method='clarabel' or 'cvxpy'")
    W, v = problem.contact_block(0)
    impulse, regime, denom = pereira_nikravesh(
        W, v, float(problem.restitution[0]), float(problem.friction[0]))
    return assemble_result(problem, impulse[None], [regime], LAW, "closed-form",
                           effective_mass=denom, tol=1e-12)


from .pereira_nikravesh_derivative import impulse_derivative  # noqa: E402,F401 (beside the kernel)
