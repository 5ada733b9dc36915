"""Anitescu's cone complementarity relaxation (CCP): minimize 1/2 pi^T W pi + pi^T b over K_mu,
``b = v- + e min(v_n-, 0) n``.

A convex program with a unique velocity answer. Exact when sticking; when sliding, ``v_n+`` is
lifted by ``mu |v_t+|`` above Newton's value, reported as ``extras["normal_velocity_lift"]``.

* :func:`contact_kernel` (``method="fast"``): b in the dual cone gives pi = 0; else the
  unconstrained impulse if it lies in the cone; else the optimal ray on the boundary, where
  ``W pi + b = s (mu, -t)`` so ``det[W p, b, q] = 0`` (p = (1, mu t), q = (-mu, t)), a quartic
  in tan(th/2) (:mod:`convimpact.impact.boundary`); Newton's root from the unconstrained
  tangent is accepted when the KKT sign certifies it, else every root is compared.
* :func:`program_result` (``method="clarabel"``/``"cvxpy"``): one cone QP. Non-approaching
  contacts -- and those approaching at round-off, v_n- >= -1e-9 max |v-|
  (:func:`~convimpact.impact.conic.paths.approaching`) -- take part with their normal only
  (pi_t = 0): they may be pressed by the others, never kicked along their slip.
"""

from __future__ import annotations

import math

import numpy as np

from ..boundary import candidates, det_wq, newton_root, refine, rotate, wp
from ..conic.paths import (ProgramOptions, approaching, cone_qp, newton_shift,
                           register_programs, regimes_from_slip, solver_report)
from ..conic.qp import Backend, QPSolution, solve_cone_qp
from ..diagnostics import assemble_result
from ..errors import SolverError
from ..fast import ContactSolution, frictionless, in_cone, register_kernel, solution
from ..problem import ImpactProblem
from ..results import ImpactResult
from ..small_linalg import inverse3, linsolve3, solve2, unit_or

LAW = "ccp"


def contact_kernel(w: list, v: list, d: int, e: float, mu: float) -> ContactSolution:
    """The CCP law for one contact on plain floats (the ``fast`` kernel)."""
    if mu == 0.0:
        return frictionless(w, v, d, e)
    return ccp_impulse(w, v, d, e, mu, LAW)


def ccp_impulse(w: list, v: list, d: int, e: float, mu: float, law: str) -> ContactSolution:
    """CCP impulse of one approaching contact with mu > 0 (``law`` names the caller in errors;
    the dissipative law calls it with e = 0)."""
    b = list(v)
    b[0] = (1.0 + e) * v[0]
    if d == 2:
        bt = abs(b[1])
        if b[0] >= mu * bt:  # b in the dual cone K*: pi = 0 is optimal
            return solution((0.0, 0.0), "separating")
        pn, pt = solve2(w, -b[0], -b[1], law)
        if in_cone(pn, abs(pt), mu):
            return solution((pn, pt), "stick", extras={"normal_velocity_lift": 0.0})
        best = None
        for s in (1.0, -1.0):
            pb = b[0] + mu * s * b[1]
            pWp = w[0][0] + 2.0 * mu * s * w[0][1] + mu * mu * w[1][1]
            if pb < 0.0 and pWp > 0.0:
                obj = -0.5 * pb * pb / pWp
                if best is None or obj < best[0]:
                    best = (obj, s, -pb / pWp)
        if best is None:
            raise SolverError("CCP boundary search found no descent direction; use "
                              "method='clarabel'")
        _, s, r = best
        un = b[0] + r * (w[0][0] + mu * s * w[0][1])
        ut = b[1] + r * (w[0][1] + mu * s * w[1][1])
        return solution((r, mu * s * r), "slide",
                        extras={"normal_velocity_lift": un, "post_slip": (ut,)})
    if b[0] >= mu * math.hypot(b[1], b[2]):
        return solution((0.0, 0.0, 0.0), "separating")
    inv = inverse3(w, law)
    pn, p1, p2 = linsolve3(w, inv, -b[0], -b[1], -b[2])
    if in_cone(pn, math.hypot(p1, p2), mu):
        return solution((pn, p1, p2), "stick", extras={"normal_velocity_lift": 0.0})
    r1, r2 = unit_or(p1, p2, unit_or(-v[1], -v[2], (1.0, 0.0)))
    R = rotate(w, b, r1, r2)  # R[6:] hold b in the rotated basis
    scale = abs(b[0]) + abs(b[1]) + abs(b[2])
    E = det_wq(wp(R, mu), R[6], R[7], R[8], mu)  # det[W p, b, q] = 0
    got = _ccp_ray(R, mu, *newton_root(E))  # fast path: Newton from the unconstrained pi_t
    if got is None or got[3] < -1e-6 * scale:  # KKT: y_n = u_n = mu |u_t| >= 0 certifies
        got = _ccp_boundary(R, mu, False, E)
    if got is None or got[3] < -1e-6 * scale:
        got = _ccp_boundary(R, mu, True)  # companion-matrix roots
        if got is None or got[3] < -1e-6 * scale:
            raise SolverError("the CCP boundary solve found no KKT point; use "
                              "method='clarabel'")
    x, y, r, un, slip = got
    t1, t2 = x * r1 - y * r2, x * r2 + y * r1
    return solution((r, mu * r * t1, mu * r * t2), "slide",
                    extras={"normal_velocity_lift": un, "post_slip_speed": slip,
                            "direction": (t1, t2)})


def _ray(R: tuple, mu: float, x: float, y: float) -> tuple[float, float]:
    """(p.b, p.W.p) along the boundary ray p = (1, mu t), t = (x, y) in R's basis."""
    A, B1, B2, C11, C12, C22, b0, b1, b2 = R
    pb = b0 + mu * (b1 * x + b2 * y)
    pWp = A + mu * (2.0 * (B1 * x + B2 * y) + mu * (C11 * x * x + 2.0 * C12 * x * y
                                                    + C22 * y * y))
    return pb, pWp


def _ray_answer(R: tuple, mu: float, x: float, y: float, pb: float,
                pWp: float) -> tuple[float, float, float, float, float]:
    """(x, y, r, u_n, |u_t|) of the optimal point r = -p.b / p.W.p of the ray along t."""
    A, B1, B2, C11, C12, C22, b0, b1, b2 = R
    r = -pb / pWp
    un = b0 + r * (A + mu * (B1 * x + B2 * y))
    slip = math.hypot(b1 + r * (B1 + mu * (C11 * x + C12 * y)),
                      b2 + r * (B2 + mu * (C12 * x + C22 * y)))
    return x, y, r, un, slip


def _ccp_ray(R: tuple, mu: float, x: float, y: float, converged: bool) -> tuple | None:
    """(x, y, r, u_n, |u_t|) of the optimal ray pi = r p along t = (x, y), or None."""
    if not converged:
        return None
    pb, pWp = _ray(R, mu, x, y)
    if not (pb < 0.0 and pWp > 0.0):
        return None
    return _ray_answer(R, mu, x, y, pb, pWp)


def _ccp_boundary(R: tuple, mu: float, robust: bool, E: tuple | None = None) -> tuple | None:
    """Best boundary ray of the CCP program: (x, y, r, u_n, |u_t|) in R's basis, or None.

    Along the ray pi = r p the optimum is r = -p.b / p.W.p (if p.b < 0), with objective
    -1/2 (p.b)^2 / p.W.p; the winner maximizes g = (p.b)^2 / (2 p.W.p) over the roots of
    det[W p, b, q] = 0.
    """
    coeffs, cands = candidates(*(E or det_wq(wp(R, mu), R[6], R[7], R[8], mu)), robust=robust)
    scored = []
    top = None
    for pt in cands:
        pb, pWp = _ray(R, mu, pt[0], pt[1])
        if pb < 0.0 and pWp > 0.0:
            g = 0.5 * pb * pb / pWp
            scored.append((g, pt))
            if top is None or g > top:
                top = g
    if top is None:
        return None
    cut = top - 1e-6 * top
    best = None
    for g0, pt in scored:
        if g0 < cut:
            continue
        x, y = refine(coeffs, pt)
        pb, pWp = _ray(R, mu, x, y)
        if not (pb < 0.0 and pWp > 0.0):
            x, y = pt[0], pt[1]
            pb, pWp = _ray(R, mu, x, y)
        g = 0.5 * pb * pb / pWp
        if best is None or g > best[0]:
            best = (g, x, y, pb, pWp)
    _, x, y, pb, pWp = best
    return _ray_answer(R, mu, x, y, pb, pWp)


# --------------------------------------------------------------------------------------------
# the conic path


def solve_ccp(P: ImpactProblem, backend: Backend, opts: ProgramOptions,
              restitution: np.ndarray | None = None) -> tuple[np.ndarray, QPSolution]:
    """Anitescu's program: minimize 1/2 pi^T W pi + pi^T b over K_mu, b = v- + e min(v_n-,0) n.

    Returns the impulse (n_contacts, d) and the backend's report.
    """
    b = P.v_minus.ravel() + newton_shift(P, restitution)
    # a contact that is not approaching takes no friction impulse of its own: it enters with
    # its normal only (pi_t = 0), so it may be pressed by the others but is never kicked
    # along its slip (the single-contact rule "not approaching: no impulse"); approaching at
    # round-off counts as touching, so the answer does not jump with its sign
    mu = np.where(approaching(P), P.friction, 0.0)
    sol = solve_cone_qp(backend, cone_qp(P, b, mu=mu), opts.tol, opts.max_iter)
    return sol.x.reshape(P.n_contacts, P.dim), sol


def program_result(P: ImpactProblem, backend: Backend, method: str,
                   opts: ProgramOptions) -> ImpactResult:
    pi, sol = solve_ccp(P, backend, opts)
    vplus = P.v_minus + (P.delassus @ pi.ravel()).reshape(P.n_contacts, P.dim)
    newton = -P.restitution * np.minimum(P.v_minus[:, 0], 0.0)
    lift = vplus[:, 0] - newton  # = mu |v_t+| where pi_n > 0 (complementarity)
    slip = np.linalg.norm(vplus[:, 1:], axis=1)
    extras = {
        "normal_velocity_lift": lift.tolist(),
        "mu_times_slip": (P.friction * slip).tolist(),
        **solver_report(sol, opts),
    }
    acc = opts.accuracy(sol.polished)
    regimes = regimes_from_slip(P, pi, vplus, acc)
    return assemble_result(P, pi, regimes, LAW, method, tol=acc, extras=extras)


register_kernel(LAW, contact_kernel)
register_programs(LAW, program_result)
