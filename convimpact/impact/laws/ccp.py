"""Anitescu's cone complementarity relaxation (CCP): minimize 1/2 pi^T W pi + pi^T b over K_mu,
``b = v- + e min(v_n-, 0) n``.

A convex program with a unique velocity answer. Exact when sticking; when sliding, ``v_n+`` is
lifted by ``mu |v_t+|`` above Newton's value, reported as ``extras["normal_velocity_lift"]``.

* :func:`_ccp_planar` and :func:`_ccp_spatial` are the exact single-contact kernel
  (``method="fast"``, the batch, the compiled lane; the dissipative law calls them with e = 0),
  compiled (plain Python under ``NUMBA_DISABLE_JIT=1``); :func:`contact_kernel` is their entry
  on plain floats. b in the dual cone gives pi = 0; else the unconstrained impulse if it lies
  in the cone; else the optimal ray on the boundary, where ``W pi + b = s (mu, -t)`` so
  ``det[W p, b, q] = 0`` (p = (1, mu t), q = (-mu, t)), a quartic in tan(th/2)
  (:mod:`convimpact.impact.laws.algebra`); Newton's root from the unconstrained
  tangent is accepted when the KKT sign certifies it, else every root is compared, then the
  companion matrix's roots, then SolverError. The kernels write nothing into their scratch
  ``out``: the extras (``normal_velocity_lift``; when sliding ``post_slip`` in the plane,
  ``post_slip_speed`` and ``direction`` in space) are recomputed from the impulse.
* :func:`program_result` (``method="clarabel"``/``"cvxpy"``): one cone QP. Non-approaching
  contacts -- and those approaching at round-off, v_n- >= -1e-9 max |v-|
  (:func:`~convimpact.impact.conic.paths.approaching`) -- take part with their normal only
  (pi_t = 0): they may be pressed by the others, never kicked along their slip.
"""

from __future__ import annotations

import math

import numpy as np

from .algebra import (_candidates, _det_wq, _inverse3, _linsolve3, _newton_root, _refine,
                      _rotate, _solve2)
from .codes import (FAILED, NO_SOLUTION, OK, SEPARATING, SINGULAR, SLIDE, STICK, _NAN, _in_cone,
                    _jit, _unit_or)
from ..conic.paths import (ProgramOptions, approaching, cone_qp, newton_shift,
                           regimes_from_slip, solver_report)
from ..conic.qp import Backend, QPSolution, solve_cone_qp
from ..diagnostics import assemble_result
from ..exact.dispatch import compiled_kernel
from ..problem.build import ImpactProblem
from ..results import ImpactResult
from .cone_derivative import ccp_one as impulse_derivative  # noqa: F401
from .cone_derivative import ccp_several as several_impulse_derivative  # noqa: F401

LAW = "ccp"
#: the SolverError of status NO_SOLUTION: in the plane no boundary ray descends (unreachable
#: for the definite W the stick solve accepted), in space no boundary answer is certified
NO_DESCENT = "CCP boundary search found no descent direction; use method='clarabel'"
NO_KKT_POINT = "the CCP boundary solve found no KKT point; use method='clarabel'"


# --------------------------------------------------------------------------------------------
# the exact single-contact kernel (method="fast"), compiled: every path runs this code


@_jit
def _ccp_planar(w00, w01, w11, v0, v1, e, mu, out):
    """One planar contact, mu > 0: separating if b = ((1+e) v_n, v_t) lies in the dual cone,
    the stick impulse if it lies in the cone, else the better of the two boundary rays
    pi = r (1, mu s), r = -(b_n + mu s b_t) / (W_nn + 2 mu s W_nt + mu^2 W_tt). Writes nothing
    into ``out``."""
    b0 = (1.0 + e) * v0
    b1 = v1
    if b0 >= mu * abs(b1):  # b in the dual cone K*: pi = 0 is optimal
        return OK, SEPARATING, 0.0, 0.0, 0.0, _NAN
    pn, pt, ok = _solve2(w00, w01, w11, -b0, -b1)
    if not ok:
        return SINGULAR, FAILED, _NAN, _NAN, _NAN, _NAN
    if _in_cone(pn, abs(pt), mu):
        return OK, STICK, pn, pt, 0.0, _NAN
    found = False
    bobj, bs, br = 0.0, 0.0, 0.0
    for k in range(2):
        s = 1.0 if k == 0 else -1.0
        pb = b0 + mu * s * b1
        pWp = w00 + 2.0 * mu * s * w01 + mu * mu * w11
        if pb < 0.0 and pWp > 0.0:
            obj = -0.5 * pb * pb / pWp
            if not found or obj < bobj:
                found = True
                bobj, bs, br = obj, s, -pb / pWp
    if not found:  # no descent direction on the boundary (W is definite here: unreachable)
        return NO_SOLUTION, FAILED, _NAN, _NAN, _NAN, _NAN
    return OK, SLIDE, br, mu * bs * br, 0.0, _NAN


@_jit
def _ccp_ray(A, B1, B2, C11, C12, C22, b0, b1, b2, mu, x, y):
    """(p.b, p.W.p) along the boundary ray p = (1, mu t), t = (x, y) in the rotated basis."""
    pb = b0 + mu * (b1 * x + b2 * y)
    pWp = A + mu * (2.0 * (B1 * x + B2 * y) + mu * (C11 * x * x + 2.0 * C12 * x * y
                                                    + C22 * y * y))
    return pb, pWp


@_jit
def _ccp_un(A, B1, B2, b0, mu, x, y, pb, pWp):
    """(r, u_n) at the optimal point r = -p.b / p.W.p of the ray along t = (x, y)."""
    r = -pb / pWp
    return r, b0 + r * (A + mu * (B1 * x + B2 * y))


@_jit
def _ccp_boundary(A, B1, B2, C11, C12, C22, b0, b1, b2, mu, E0, Ex, Ey, Exx, Eyy, Exy, robust):
    """Best boundary ray of the CCP program over the roots of det[W p, b, q] = 0 (E, in the
    rotated basis): (found, x, y, r, u_n).

    Along the ray pi = r p the optimum is r = -p.b / p.W.p (if p.b < 0), with objective
    -1/2 (p.b)^2 / p.W.p; the winner maximizes g = (p.b)^2 / (2 p.W.p). The roots are
    stationary, so their unpolished scores are accurate to second order: the winner and any
    runner-up within 1e-6 are polished. ``robust``: the companion-matrix roots."""
    has, q4, q3, q2, q1, q0, cp, sp, n, xs, ys, ts, rs = _candidates(E0, Ex, Ey, Exx, Eyy, Exy,
                                                                     robust)
    ns = 0
    top = 0.0
    for j in range(n):
        pb, pWp = _ccp_ray(A, B1, B2, C11, C12, C22, b0, b1, b2, mu, xs[j], ys[j])
        if pb < 0.0 and pWp > 0.0:
            g = 0.5 * pb * pb / pWp
            if ns == 0 or g > top:
                top = g
            ns += 1
    if ns == 0:
        return False, 0.0, 0.0, 0.0, 0.0
    cut = top - 1e-6 * top
    found = False
    bg, bx, by, bpb, bpWp = 0.0, 0.0, 0.0, 0.0, 0.0
    for j in range(n):
        pb, pWp = _ccp_ray(A, B1, B2, C11, C12, C22, b0, b1, b2, mu, xs[j], ys[j])
        if not (pb < 0.0 and pWp > 0.0) or 0.5 * pb * pb / pWp < cut:
            continue
        x, y = _refine(has, q4, q3, q2, q1, q0, cp, sp, xs[j], ys[j], ts[j], rs[j])
        pb, pWp = _ccp_ray(A, B1, B2, C11, C12, C22, b0, b1, b2, mu, x, y)
        if not (pb < 0.0 and pWp > 0.0):  # polishing left the admissible set: the raw root
            x, y = xs[j], ys[j]
            pb, pWp = _ccp_ray(A, B1, B2, C11, C12, C22, b0, b1, b2, mu, x, y)
        g = 0.5 * pb * pb / pWp
        if not found or g > bg:
            found = True
            bg, bx, by, bpb, bpWp = g, x, y, pb, pWp
    r, un = _ccp_un(A, B1, B2, b0, mu, bx, by, bpb, bpWp)
    return True, bx, by, r, un


@_jit
def _ccp_spatial(w00, w01, w02, w11, w12, w22, v0, v1, v2, e, mu, out):
    """One spatial contact, mu > 0: separating if b lies in the dual cone, the stick impulse
    if it lies in the cone, else the optimal ray on the boundary, where W pi + b = s (mu, -t)
    so that det[W p, b, q] = 0 (p = (1, mu t), q = (-mu, t)), a quartic in tan(th/2). KKT
    certifies a ray by u_n = mu |u_t| >= 0: Newton's root from the unconstrained tangent first,
    else every root of the closed-form quartic, else the companion-matrix roots, else
    NO_SOLUTION. Writes nothing into ``out``."""
    b0 = (1.0 + e) * v0
    b1 = v1
    b2 = v2
    if b0 >= mu * math.hypot(b1, b2):  # b in the dual cone K*: pi = 0 is optimal
        return OK, SEPARATING, 0.0, 0.0, 0.0, _NAN
    i00, i01, i02, i11, i12, i22, det, ok = _inverse3(w00, w01, w02, w11, w12, w22)
    if not ok:
        return SINGULAR, FAILED, _NAN, _NAN, _NAN, _NAN
    pn, p1, p2 = _linsolve3(w00, w01, w02, w11, w12, w22, i00, i01, i02, i11, i12, i22, det,
                            -b0, -b1, -b2)
    if _in_cone(pn, math.hypot(p1, p2), mu):
        return OK, STICK, pn, p1, p2, _NAN
    f1, f2 = _unit_or(-v1, -v2, 1.0, 0.0)
    r1, r2 = _unit_or(p1, p2, f1, f2)
    A, B1, B2, C11, C12, C22, R6, R7, R8 = _rotate(w00, w01, w02, w11, w12, w22, b0, b1, b2,
                                                   r1, r2)
    scale = abs(b0) + abs(b1) + abs(b2)
    E0, Ex, Ey, Exx, Eyy, Exy = _det_wq(A, mu * B1, mu * B2, B1, mu * C11, mu * C12,
                                        B2, mu * C12, mu * C22, R6, R7, R8, mu)
    # fast path: Newton from the unconstrained tangent, certified by u_n >= 0 (KKT)
    x, y, good = _newton_root(E0, Ex, Ey, Exx, Eyy, Exy)
    r, un = 0.0, 0.0
    if good:
        pb, pWp = _ccp_ray(A, B1, B2, C11, C12, C22, R6, R7, R8, mu, x, y)
        good = pb < 0.0 and pWp > 0.0
        if good:
            r, un = _ccp_un(A, B1, B2, R6, mu, x, y, pb, pWp)
    for robust in (False, True):  # every root of the quartic, then the companion's
        if good and not un < -1e-6 * scale:
            break
        good, x, y, r, un = _ccp_boundary(A, B1, B2, C11, C12, C22, R6, R7, R8, mu,
                                          E0, Ex, Ey, Exx, Eyy, Exy, robust)
    if not good or un < -1e-6 * scale:
        return NO_SOLUTION, FAILED, _NAN, _NAN, _NAN, _NAN
    t1, t2 = x * r1 - y * r2, x * r2 + y * r1
    return OK, SLIDE, r, mu * r * t1, mu * r * t2, _NAN


def _extras(out, regime, impulse, w, v, d, e, mu) -> tuple:
    """CCP's figures, from the impulse: u = W pi + b = v+ + e v_n- n, its normal part the lift
    of the rebound above Newton's (0 when sticking, mu |u_t| when sliding); when sliding, the
    post-impact slip (planar: u_t; spatial: |u_t| and the sliding direction t, the unit
    tangential impulse)."""
    if regime == "stick":
        return {"normal_velocity_lift": 0.0}, ()
    if regime != "slide":
        return None, ()
    p = impulse
    un = (1.0 + e) * v[0] + w[0][0] * p[0] + w[0][1] * p[1]
    if d == 2:
        ut = v[1] + w[0][1] * p[0] + w[1][1] * p[1]
        return {"normal_velocity_lift": un, "post_slip": (ut,)}, ()
    un += w[0][2] * p[2]
    u1 = v[1] + w[0][1] * p[0] + w[1][1] * p[1] + w[1][2] * p[2]
    u2 = v[2] + w[0][2] * p[0] + w[1][2] * p[1] + w[2][2] * p[2]
    pt = math.hypot(p[1], p[2])
    direction = (p[1] / pt, p[2] / pt) if pt > 0.0 else (1.0, 0.0)
    return {"normal_velocity_lift": un, "post_slip_speed": math.hypot(u1, u2),
            "direction": direction}, ()


#: NO_SOLUTION's messages, planar and spatial
NO_SOLUTION_MESSAGES = (NO_DESCENT, NO_KKT_POINT)
contact_kernel = compiled_kernel(LAW, _ccp_planar, _ccp_spatial, _extras,
                                 no_solution=NO_SOLUTION_MESSAGES)


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
