"""Newton restitution and Coulomb friction opposing the *post-impact* slip (Moreau).

With ``u = v+ + e min(v_n-, 0) n`` per contact: ``K_mu ∋ pi ⊥ u + mu |u_t| n ∈ K_mu*`` -- stick
when the stick impulse is in the cone, else ``u_n = 0`` and ``pi_t = -mu pi_n u_t / |u_t|``. The
law is not a convex program and may have several sliding solutions (the most dissipative one
is returned, and the count reported).

* :func:`contact_kernel` (``method="fast"``): on the boundary ``b + pi_n W p = (0, -sigma t)``,
  so ``det[W p, (0, t), b] = 0`` (p = (1, mu t), b = v + e v_n e_n), a quartic in tan(th/2)
  (:mod:`convimpact.impact.boundary`). Newton's root from the stick impulse's tangent is
  completed by the roots of the deflated cubic, so every sliding solution is found and
  counted; each is certified against Coulomb's conditions, with companion-matrix roots as the
  fallback and SolverError when none satisfies them.
* :func:`solve_coulomb` and :func:`program_result` (``method="clarabel"``/``"cvxpy"``): the
  fixed point over CCP programs of :mod:`~convimpact.impact.laws.coulomb_program` (the shift
  ``s_i = mu_i |u_t,i|`` added to ``q_n``, Anderson accelerated, safeguarded by damping, each
  iterate seeding an active-set Newton solve of Coulomb's conditions); one contact is
  finished (or rescued) by an exact single-contact solve. The final complementarity residual
  (:func:`~convimpact.impact.laws.coulomb_program.coulomb_residual`) is checked: a
  SolverError, never a silently wrong answer. Contacts with v_n- >= 0 take part with
  complementarity (they may separate).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .. import boundary
from ..conic.paths import ProgramOptions, newton_shift, register_programs, regimes_from_slip
from ..conic.qp import TINY, Backend
from ..diagnostics import assemble_result
from ..errors import SolverError
from ..fast import (CONE_RTOL, ROOT_RTOL, ContactSolution, frictionless, in_cone, jam_error,
                    register_kernel, solution)
from ..problem import ImpactProblem
from ..results import ImpactResult
from ..small_linalg import angle_from_slip, inverse3, linsolve3, solve2, unit_or
from .coulomb_program import coulomb_fixed_point, coulomb_residual  # noqa: F401 (re-exported)
from .pereira_nikravesh import DELASSUS_COND_MAX, stick_admissible

LAW = "coulomb"


def contact_kernel(w: list, v: list, d: int, e: float, mu: float) -> ContactSolution:
    """Coulomb's law for one contact on plain floats (the ``fast`` kernel)."""
    if mu == 0.0:
        return frictionless(w, v, d, e)
    c = -(1.0 + e) * v[0]
    b0 = -c  # b = v + e v_n e_n; u = b + W pi
    wscale = w[0][0] if w[0][0] > w[1][1] else w[1][1]  # max |W_ij| for a PSD W
    if d == 3 and w[2][2] > wscale:
        wscale = w[2][2]
    dmin = 1e-12 * wscale
    vscale = max(abs(v[0]), abs(v[1]), abs(v[-1]))
    if d == 2:
        pn, pt = solve2(w, c, -v[1], LAW)
        if in_cone(pn, abs(pt), mu):
            return solution((pn, pt), "stick")
        A, B, C = w[0][0], w[0][1], w[1][1]
        found, jams = [], []
        for s in (1.0, -1.0):
            D = A + mu * s * B
            if not D > dmin:
                jams.append(D)
                continue
            p = c / D
            ut = v[1] + p * (B + mu * s * C)  # post-impact slip
            if ut * s <= CONE_RTOL * vscale:  # anti-parallel to pi_t (or zero)
                tl = -p * (v[0] + mu * s * v[1]) - 0.5 * p * p * (D + mu * s * (B + mu * s * C))
                found.append((tl, s, p, D, ut))
        if not found:
            if jams:
                raise jam_error(mu, min(jams), LAW)
            raise SolverError("no Coulomb sliding solution exists for this planar contact "
                              "although the stick impulse leaves the cone; use method='clarabel'")
        tl, s, p, D, ut = max(found)
        extras = {"n_slide_solutions": len(found), "post_slip": (ut,)}
        warns = (("the Coulomb law has several sliding solutions here; the most dissipative "
                  "one is returned",) if len(found) > 1 else ())
        return solution((p, mu * s * p), "slide", D, extras, warns)
    inv = inverse3(w, LAW)
    pn, p1, p2 = linsolve3(w, inv, c, -v[1], -v[2])
    if in_cone(pn, math.hypot(p1, p2), mu):
        return solution((pn, p1, p2), "stick")
    r1, r2 = unit_or(p1, p2, unit_or(-v[1], -v[2], (1.0, 0.0)))
    R = boundary.rotate(w, v, r1, r2)
    A, B1, B2, C11, C12, C22, v0, v1, v2 = R
    u00, u0x, u0y, u10, u1x, u1y, u20, u2x, u2y = (A, mu * B1, mu * B2, B1, mu * C11, mu * C12,
                                                   B2, mu * C12, mu * C22)  # W p
    # det[W p, (0, t), b] = sum_i (W p)_i (m x b)_i = 0, m = (0, x, y), b = (b0, v1, v2):
    # m x b = (x v2 - y v1, y b0, -x b0)
    e0 = 0.0
    ex = u00 * v2 - u20 * b0
    ey = -u00 * v1 + u10 * b0
    exx = u0x * v2 - u2x * b0
    eyy = -u0y * v1 + u1y * b0
    exy = -u0x * v1 + u0y * v2 + u1x * b0 - u2y * b0
    escale = (abs(ex) + abs(ey) + abs(exx) + abs(eyy) + abs(exy)) or 1.0
    found: list = []
    jams: list = []

    def conditions(x: float, y: float, rtol: float) -> tuple | None:
        """(T_L, x, y, pi_n, D, sigma) if t = (x, y) is a Coulomb slide to tolerance rtol."""
        if abs(e0 + ex * x + ey * y + exx * x * x + eyy * y * y + exy * x * y) > rtol * escale:
            return None
        D = A + mu * (B1 * x + B2 * y)
        if not D > dmin:
            jams.append(D)
            return None
        P1 = B1 + mu * (C11 * x + C12 * y)
        P2 = B2 + mu * (C12 * x + C22 * y)
        p = c / D  # eq. (38): u_n = 0
        u1, u2 = v1 + p * P1, v2 + p * P2  # post-impact slip, rotated basis
        sigma = -(u1 * x + u2 * y)  # u_t = -sigma t, sigma >= 0: friction opposes the slip
        if sigma < -rtol * vscale or abs(u1 * y - u2 * x) > rtol * (vscale + abs(p) * wscale):
            return None
        pWp = D + mu * (x * P1 + y * P2)
        return -p * (v0 + mu * (v1 * x + v2 * y)) - 0.5 * p * p * pWp, x, y, p, D, sigma

    def add(got: tuple) -> None:
        for f in found:
            if abs(got[1] - f[1]) + abs(got[2] - f[2]) < 1e-9:
                return  # the same root reached twice
        found.append(got)

    # fast path: Newton from the stick impulse's tangent (tau = 0), then the other roots from
    # the deflated cubic, so that every sliding solution is still enumerated
    c4, c3, c2, c1, c0 = (e0 - ex + exx, 2.0 * (ey - exy), 2.0 * (e0 - exx) + 4.0 * eyy,
                          2.0 * (ey + exy), e0 + ex + exx)
    big = max(abs(c4), abs(c3), abs(c2), abs(c1), abs(c0))
    fast_done = False
    if abs(c4) >= 1e-2 * big:  # all roots bounded: |tau| <= 101
        t0 = boundary.polish(c4, c3, c2, c1, c0, 0.0)
        t2 = t0 * t0
        got = conditions((1.0 - t2) / (1.0 + t2), 2.0 * t0 / (1.0 + t2), ROOT_RTOL)
        if got is not None:
            fast_done = True
            found.append(got)
            b2 = c3 + t0 * c4
            b1 = c2 + t0 * b2
            b0 = c1 + t0 * b1
            for t in boundary.cubic_roots(b2 / c4, b1 / c4, b0 / c4):
                t2 = t * t
                x, y = (1.0 - t2) / (1.0 + t2), 2.0 * t / (1.0 + t2)
                if conditions(x, y, 1e-6) is None:  # cheap screening of the raw root
                    continue
                t = boundary.polish(c4, c3, c2, c1, c0, t)
                t2 = t * t
                got = conditions((1.0 - t2) / (1.0 + t2), 2.0 * t / (1.0 + t2), ROOT_RTOL)
                if got is not None:
                    add(got)
    if not fast_done:
        for robust in (False, True):  # Ferrari's roots, then the companion matrix's
            coeffs, cands = boundary.candidates(e0, ex, ey, exx, eyy, exy, robust=robust)
            for pt in cands:
                if not robust and conditions(pt[0], pt[1], 1e-6) is None:
                    continue  # cheap screening of the raw root
                got = conditions(*boundary.refine(coeffs, pt), ROOT_RTOL)
                if got is not None:
                    add(got)
            if found:
                break
    if not found:
        if jams:
            raise jam_error(mu, min(jams), LAW)
        raise SolverError("no Coulomb sliding solution found for this spatial contact although "
                          "the stick impulse leaves the cone; use method='clarabel'")
    tl, x, y, p, D, sigma = max(found)  # the most dissipative if several
    t1, t2 = x * r1 - y * r2, x * r2 + y * r1
    extras = {"n_slide_solutions": len(found), "direction": (t1, t2),
              "alpha": angle_from_slip(v[1], v[2], t1, t2), "post_slip_speed": sigma}
    warns = (("the Coulomb law has several sliding solutions here; the most dissipative one "
              "is returned",) if len(found) > 1 else ())
    return solution((p, mu * p * t1, mu * p * t2), "slide", D, extras, warns)


# --------------------------------------------------------------------------------------------
# the conic path: the fixed point over CCP programs, finished exactly for one contact


def _single_contact_coulomb_candidates(W: np.ndarray, b: np.ndarray,
                                       mu: float) -> list[np.ndarray]:
    """Every solution of the one-contact Coulomb problem with b_n < 0 (exact, no iteration).

    Stick: ``pi = -W^-1 b`` when it lies in K_mu. Slide: ``pi = pi_n (1, mu d)`` with
    ``u_n = 0`` and ``u_t = -lambda d``, lambda >= 0; in space the direction angle solves the
    smooth trigonometric equation ``cross(g_n u_t, d) = 0`` (g = W (1, mu d)), found by sampling
    and bracketing (Brent) to machine precision.
    """
    d = W.shape[0]
    out: list[np.ndarray] = []
    if np.linalg.cond(W) < DELASSUS_COND_MAX:
        stick = np.linalg.solve(W, -b)
        if stick_admissible(stick, mu, rtol=1e-12):
            out.append(stick)
    if mu == 0.0:
        return out

    def slide(dirv: np.ndarray):
        g = np.concatenate(([1.0], mu * dirv))
        wg = W @ g
        if not wg[0] > 1e-14 * np.max(np.abs(W)):
            return None
        pn = -b[0] / wg[0]
        if pn <= 0:
            return None
        ut = pn * wg[1:] + b[1:]
        if float(ut @ dirv) > 1e-12 * max(np.linalg.norm(ut), TINY) and \
                np.linalg.norm(ut) > 1e-13 * np.linalg.norm(b):
            return None
        return pn * g

    if d == 2:
        for s in (-1.0, 1.0):
            c = slide(np.array([s]))
            if c is not None:
                out.append(c)
        return out

    def h(a):
        c, s = np.cos(a), np.sin(a)
        g0 = W[:, 0][:, None] + mu * (W[:, 1][:, None] * c + W[:, 2][:, None] * s)
        ht = -b[0] * g0[1:] + g0[0] * b[1:, None]  # g_n u_t / pi_n ... times g_n
        return ht[0] * s - ht[1] * c

    grid = np.linspace(-np.pi, np.pi, 721)
    vals = h(grid)
    from scipy.optimize import brentq

    roots = []
    for k in range(grid.size - 1):
        a0, a1 = grid[k], grid[k + 1]
        if vals[k] == 0.0:
            roots.append(a0)
        elif vals[k] * vals[k + 1] < 0:
            roots.append(brentq(lambda a: float(h(np.array([a]))[0]), a0, a1, xtol=1e-15))
    for a in roots:
        c = slide(np.array([np.cos(a), np.sin(a)]))
        if c is not None:
            out.append(c)
    return out


def solve_coulomb(P: ImpactProblem, backend: Backend,
                  opts: ProgramOptions) -> tuple[np.ndarray, dict[str, Any]]:
    """Coulomb's law with Newton restitution by a fixed point over shifted CCP programs.

    The shift ``s_i = mu_i |u_t,i|`` (u = W pi + b) enters ``q_n``; the map ``s -> s(pi(s))`` is
    iterated with Anderson acceleration (memory ``anderson_memory``), safeguarded: when a step
    does not reduce the fixed-point residual the history is dropped and the mixing halved. If
    that pass fails, a second pass runs the plain iteration (up to ``max_fixed_point_iter``
    programs each) (:func:`~convimpact.impact.laws.coulomb_program.coulomb_fixed_point`).
    After every program the iterate's active set (stick / slide / separate per contact) is
    handed to an active-set Newton solve of Coulomb's conditions themselves
    (:func:`~convimpact.impact.conic.polish.polish_cone_qp` with ``coulomb=True``); once that
    certifies a solution (residual at round-off, consistent active set) the iteration stops.
    This is what converges on the paper's Section 9.3 pendulum, where the plain fixed point
    does not. For one contact the answer is finished by the exact single-contact solve (the
    candidate of :func:`_single_contact_coulomb_candidates` nearest the iterate), which also
    rescues a fixed point that did not converge. When Coulomb's law has several solutions
    (large mu, several contacts) the one reached from the CCP start is returned.

    Returns
    -------
    impulse (n_contacts, d), info dict (iterations, residuals, how it was finished)
    """
    n, d = P.n_contacts, P.dim
    mu = P.friction
    fp = coulomb_fixed_point(P, backend, opts)
    pi, finished = fp.pi, fp.finished_by
    n_solutions = None
    if n == 1 and mu[0] > 0.0:
        # exact single-contact solve: finishes a converged iterate to machine precision and
        # rescues one that did not converge (the candidate nearest the last iterate)
        b = P.v_minus.ravel() + newton_shift(P)
        cands = _single_contact_coulomb_candidates(P.delassus, b, float(mu[0]))
        n_solutions = len(cands)
        if cands:
            k = int(np.argmin([np.linalg.norm(c - pi[0]) for c in cands]))
            pi = cands[k][None]
            finished = "exact single-contact solve"
    acc = opts.accuracy(fp.polished or fp.newton or finished.startswith("exact"))
    resid = coulomb_residual(fp.unit.W, fp.unit.q, mu, d, pi.ravel() / fp.scale)
    info = {
        "fixed_point_iterations": fp.iterations,
        "fixed_point_converged": fp.converged,
        "fixed_point_residual": fp.residual,
        "conic_iterations": fp.conic_iterations,
        "solver_status": fp.status,
        "finished_by": finished,
        "complementarity_residual": resid,
        "tolerance": opts.tol,
        "accuracy": acc,
    }
    if n_solutions is not None:
        info["single_contact_solutions"] = n_solutions
    if resid > max(opts.fixed_point_tol, acc) * 10:
        raise SolverError(
            f"Coulomb fixed point did not converge: after {fp.iterations} CCP programs the "
            f"complementarity residual is {resid:.3e} (fixed-point residual "
            f"{fp.residual:.3e}); raise max_fixed_point_iter, or use law='ccp' or "
            "'dissipative' (single programs)")
    return pi, info


def program_result(P: ImpactProblem, backend: Backend, method: str,
                   opts: ProgramOptions) -> ImpactResult:
    pi, info = solve_coulomb(P, backend, opts)
    vplus = P.v_minus + (P.delassus @ pi.ravel()).reshape(P.n_contacts, P.dim)
    acc = info["accuracy"]
    regimes = regimes_from_slip(P, pi, vplus, acc)
    return assemble_result(P, pi, regimes, LAW, method, tol=acc, extras=info)


register_kernel(LAW, contact_kernel)
register_programs(LAW, program_result)
