"""Newton restitution and Coulomb friction opposing the *post-impact* slip (Moreau).

With ``u = v+ + e min(v_n-, 0) n`` per contact: ``K_mu ∋ pi ⊥ u + mu |u_t| n ∈ K_mu*`` -- stick
when the stick impulse is in the cone, else ``u_n = 0`` and ``pi_t = -mu pi_n u_t / |u_t|``. The
law is not a convex program and may have several sliding solutions (the most dissipative one
is returned, and the count reported).

* :func:`_coulomb_planar` and :func:`_coulomb_spatial` are the exact single-contact kernel
  (``method="fast"``, the batch, the compiled lanes), compiled; :func:`contact_kernel` is
  their entry on plain floats. A slide is ``pi = pi_n (1, mu t)`` with ``pi_n = c / D``
  (eq. 38, ``u_n = 0``; c = -(1 + e) v_n, D = W_nn + mu W_nt . t > 0) and a post-impact slip
  opposite to t. In the plane t = +-1 (:func:`_planar_slides`); in space, on the boundary
  ``b + pi_n W p = (0, -sigma t)``, so ``det[W p, (0, t), b] = 0`` (p = (1, mu t),
  b = v + e v_n e_n), a quartic in tan(th/2) (:func:`_spatial_slides`): Newton's root from the
  stick impulse's tangent is completed by the roots of the deflated cubic, so every sliding
  solution is found and counted; each is certified against Coulomb's conditions, with every
  candidate direction (:func:`~convimpact.impact.laws.algebra._candidates`, Ferrari,
  then the companion matrix's roots) as the fallback. No slide: NonPositiveEffectiveMassError
  when a root was rejected for its denominator D <= 0 (the smallest D reported), else
  SolverError.
* :func:`solve_coulomb` and :func:`program_result` (``method="clarabel"``/``"cvxpy"``): the
  fixed point over CCP programs of :mod:`~convimpact.impact.laws.coulomb_program` (the shift
  ``s_i = mu_i |u_t,i|`` added to ``q_n``, Anderson accelerated, safeguarded by damping, each
  iterate seeding an active-set Newton solve of Coulomb's conditions); one contact is
  finished (or rescued) by the exact single-contact solve (:func:`single_contact_solutions`,
  the kernel's own enumeration). The final complementarity residual
  (:func:`~convimpact.impact.laws.coulomb_program.coulomb_residual`) is checked: a
  SolverError, never a silently wrong answer. Contacts with v_n- >= 0 take part with
  complementarity (they may separate).

``out`` of the kernels (float64, :data:`~convimpact.impact.laws.codes.OUT_SIZE`),
written on a slide: ``out[0]`` the number of sliding solutions found, ``out[1]`` the index of
the one returned, and slide j (j < 5) in ``out[2 + 4 j : 6 + 4 j] = (pi_n, t1, t2, T_L)`` (the
tangent t in the contact frame's axes; planar: ``(pi_n, s, 0, T_L)``).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .algebra import (_candidates, _cubic, _inverse3, _linsolve3, _polish,
                                     _refine, _rotate, _solve2)
from .codes import (CONE_RTOL, FAILED, JAM, NO_SOLUTION, OK, OUT_SIZE,
                                    ROOT_RTOL, SINGULAR, SLIDE, STICK, _NAN, _in_cone, _jit,
                                    _pmax2, _unit_or)
from ..conic.paths import ProgramOptions, newton_shift, regimes_from_slip
from ..conic.qp import Backend
from ..diagnostics import assemble_result
from ...errors import SolverError
from ..exact.dispatch import compiled_kernel
from ..problem.build import ImpactProblem
from ..results import ImpactResult
from ..problem.dense import angle_from_slip
from .coulomb_program import coulomb_fixed_point, coulomb_residual  # noqa: F401 (re-exported)
from .cone_derivative import coulomb_one as impulse_derivative  # noqa: F401
from .cone_derivative import coulomb_several as several_impulse_derivative  # noqa: F401

LAW = "coulomb"

# ``out``: the count, the returned slide, then the slides (pi_n, t1, t2, T_L)
_OUT_COUNT, _OUT_BEST, _OUT_SLIDES, _SLOT = 0, 1, 2, 4
#: most sliding solutions of one contact: 2 in the plane, 4 quartic roots (+ th = pi) in space
_MAX_SLIDES = 5


# --------------------------------------------------------------------------------------------
# the exact single-contact kernel (method="fast"), compiled: every path runs this code


@_jit
def _store(out, nf, p, x, y, tl):
    """Append the slide (pi_n, x, y, T_L) to the nf of ``out`` unless its direction is there
    already (the same root reached twice); the new count."""
    for j in range(nf):
        k = _OUT_SLIDES + _SLOT * j
        if abs(x - out[k + 1]) + abs(y - out[k + 2]) < 1e-9:
            return nf
    if nf < _MAX_SLIDES:
        k = _OUT_SLIDES + _SLOT * nf
        out[k], out[k + 1], out[k + 2], out[k + 3] = p, x, y, tl
    return nf + 1


@_jit
def _best(out, nf):
    """The index of the most dissipative of the nf slides of ``out``: the maximum of
    (T_L, x, y), the first of equals."""
    b = 0
    for j in range(1, nf if nf < _MAX_SLIDES else _MAX_SLIDES):
        k, kb = _OUT_SLIDES + _SLOT * j, _OUT_SLIDES + _SLOT * b
        tl, btl = out[k + 3], out[kb + 3]
        if tl > btl or (tl == btl and (out[k + 1] > out[kb + 1] or (
                out[k + 1] == out[kb + 1] and out[k + 2] > out[kb + 2]))):
            b = j
    return b


@_jit
def _jam(jam, jmin, st, D):
    """A root rejected for its denominator (st == 2): the smallest such D so far."""
    if st == 2 and (not jam or D < jmin):
        return True, D
    return jam, jmin


@_jit
def _planar_slides(w00, w01, w11, v0, v1, c, mu, out):
    """Every Coulomb slide of one planar contact (mu > 0): pi = pi_n (1, mu s), s = +-1, with
    pi_n = c / D, D = W_nn + mu s W_nt > 0, and the post-impact slip
    u_t = v_t + pi_n (W_nt + mu s W_tt) opposite to s (or zero), written into ``out``.
    Returns (count, index of the most dissipative, jam, smallest rejected D)."""
    wscale = w00 if w00 > w11 else w11
    dmin = 1e-12 * wscale
    vscale = _pmax2(abs(v0), abs(v1))
    nf = 0
    jam, jmin = False, 0.0
    for k in range(2):
        s = 1.0 if k == 0 else -1.0
        D = w00 + mu * s * w01
        if not D > dmin:
            jam, jmin = _jam(jam, jmin, 2, D)
            continue
        p = c / D
        ut = v1 + p * (w01 + mu * s * w11)  # post-impact slip
        if ut * s <= CONE_RTOL * vscale:  # anti-parallel to pi_t (or zero)
            tl = -p * (v0 + mu * s * v1) - 0.5 * p * p * (D + mu * s * (w01 + mu * s * w11))
            nf = _store(out, nf, p, s, 0.0, tl)
    out[_OUT_COUNT] = nf
    return nf, _best(out, nf), jam, jmin


@_jit
def _conditions(x, y, rtol, E0, Ex, Ey, Exx, Eyy, Exy, escale, A, B1, B2, C11, C12, C22,
                v0, v1, v2, c, mu, dmin, vscale, wscale):
    """Whether t = (x, y) (rotated basis) is a Coulomb slide to tolerance rtol: (status, T_L,
    pi_n, D), status 0 = a slide, 1 = rejected, 2 = rejected for D <= dmin (a jam)."""
    if abs(E0 + Ex * x + Ey * y + Exx * x * x + Eyy * y * y + Exy * x * y) > rtol * escale:
        return 1, 0.0, 0.0, 0.0
    D = A + mu * (B1 * x + B2 * y)
    if not D > dmin:
        return 2, 0.0, 0.0, D
    P1 = B1 + mu * (C11 * x + C12 * y)
    P2 = B2 + mu * (C12 * x + C22 * y)
    p = c / D  # eq. (38): u_n = 0
    u1, u2 = v1 + p * P1, v2 + p * P2  # post-impact slip, rotated basis
    sigma = -(u1 * x + u2 * y)  # u_t = -sigma t, sigma >= 0: friction opposes the slip
    if sigma < -rtol * vscale or abs(u1 * y - u2 * x) > rtol * (vscale + abs(p) * wscale):
        return 1, 0.0, 0.0, 0.0
    pWp = D + mu * (x * P1 + y * P2)
    return 0, -p * (v0 + mu * (v1 * x + v2 * y)) - 0.5 * p * p * pWp, p, D


@_jit
def _spatial_slides(w00, w01, w02, w11, w12, w22, v0, v1, v2, c, mu, r1, r2, out):
    """Every Coulomb slide of one spatial contact (mu > 0), found in the basis (r, r_perp) of
    the unit tangent r = (r1, r2) (the stick impulse's), written into ``out``. Returns (count,
    index of the most dissipative, its D, jam, smallest rejected D)."""
    b0 = -c  # b = v + e v_n e_n; u = b + W pi
    wscale = w00 if w00 > w11 else w11  # max |W_ij| for a PSD W
    if w22 > wscale:
        wscale = w22
    dmin = 1e-12 * wscale
    vscale = _pmax2(_pmax2(abs(v0), abs(v1)), abs(v2))
    A, B1, B2, C11, C12, C22, R0, R1, R2 = _rotate(w00, w01, w02, w11, w12, w22, v0, v1, v2,
                                                   r1, r2)
    u00, u0x, u0y, u10, u1x, u1y, u20, u2x, u2y = (A, mu * B1, mu * B2, B1, mu * C11, mu * C12,
                                                   B2, mu * C12, mu * C22)  # W p
    # det[W p, (0, t), b] = sum_i (W p)_i (m x b)_i = 0, m = (0, x, y), b = (b0, R1, R2):
    # m x b = (x R2 - y R1, y b0, -x b0)
    E0 = 0.0
    Ex = u00 * R2 - u20 * b0
    Ey = -u00 * R1 + u10 * b0
    Exx = u0x * R2 - u2x * b0
    Eyy = -u0y * R1 + u1y * b0
    Exy = -u0x * R1 + u0y * R2 + u1x * b0 - u2y * b0
    escale = abs(Ex) + abs(Ey) + abs(Exx) + abs(Eyy) + abs(Exy)
    if escale == 0.0:
        escale = 1.0
    nf = 0
    jam, jmin = False, 0.0
    # fast path: Newton from the stick impulse's tangent (tau = 0), then the other roots from
    # the deflated cubic, so that every sliding solution is still enumerated
    c4, c3, c2, c1, c0 = (E0 - Ex + Exx, 2.0 * (Ey - Exy), 2.0 * (E0 - Exx) + 4.0 * Eyy,
                          2.0 * (Ey + Exy), E0 + Ex + Exx)
    big = _pmax2(_pmax2(_pmax2(_pmax2(abs(c4), abs(c3)), abs(c2)), abs(c1)), abs(c0))
    fast_done = False
    if abs(c4) >= 1e-2 * big:  # all roots bounded: |tau| <= 101
        t0 = _polish(c4, c3, c2, c1, c0, 0.0)
        t2 = t0 * t0
        x, y = (1.0 - t2) / (1.0 + t2), 2.0 * t0 / (1.0 + t2)
        st, tl, p, D = _conditions(x, y, ROOT_RTOL, E0, Ex, Ey, Exx, Eyy, Exy, escale, A, B1,
                                   B2, C11, C12, C22, R0, R1, R2, c, mu, dmin, vscale, wscale)
        jam, jmin = _jam(jam, jmin, st, D)
        if st == 0:
            fast_done = True
            nf = _store(out, nf, p, x, y, tl)
            q2 = c3 + t0 * c4
            q1 = c2 + t0 * q2
            q0 = c1 + t0 * q1
            ncub, ra, rb, rc = _cubic(q2 / c4, q1 / c4, q0 / c4)
            for j in range(ncub):
                t = ra if j == 0 else (rb if j == 1 else rc)
                t2 = t * t
                x, y = (1.0 - t2) / (1.0 + t2), 2.0 * t / (1.0 + t2)
                st, tl, p, D = _conditions(x, y, 1e-6, E0, Ex, Ey, Exx, Eyy, Exy, escale, A,
                                           B1, B2, C11, C12, C22, R0, R1, R2, c, mu, dmin,
                                           vscale, wscale)  # cheap screening of the raw root
                jam, jmin = _jam(jam, jmin, st, D)
                if st != 0:
                    continue
                t = _polish(c4, c3, c2, c1, c0, t)
                t2 = t * t
                x, y = (1.0 - t2) / (1.0 + t2), 2.0 * t / (1.0 + t2)
                st, tl, p, D = _conditions(x, y, ROOT_RTOL, E0, Ex, Ey, Exx, Eyy, Exy, escale,
                                           A, B1, B2, C11, C12, C22, R0, R1, R2, c, mu, dmin,
                                           vscale, wscale)
                jam, jmin = _jam(jam, jmin, st, D)
                if st == 0:
                    nf = _store(out, nf, p, x, y, tl)
    if not fast_done:
        for k in range(2):  # Ferrari's roots, then the companion matrix's
            robust = k == 1
            has, q4, q3, q2, q1, q0, cp, sp, n, xs, ys, ts, rs = _candidates(
                E0, Ex, Ey, Exx, Eyy, Exy, robust)
            for j in range(n):
                if not robust:  # cheap screening of the raw root
                    st, tl, p, D = _conditions(xs[j], ys[j], 1e-6, E0, Ex, Ey, Exx, Eyy, Exy,
                                               escale, A, B1, B2, C11, C12, C22, R0, R1, R2,
                                               c, mu, dmin, vscale, wscale)
                    jam, jmin = _jam(jam, jmin, st, D)
                    if st != 0:
                        continue
                x, y = _refine(has, q4, q3, q2, q1, q0, cp, sp, xs[j], ys[j], ts[j], rs[j])
                st, tl, p, D = _conditions(x, y, ROOT_RTOL, E0, Ex, Ey, Exx, Eyy, Exy, escale,
                                           A, B1, B2, C11, C12, C22, R0, R1, R2, c, mu, dmin,
                                           vscale, wscale)
                jam, jmin = _jam(jam, jmin, st, D)
                if st == 0:
                    nf = _store(out, nf, p, x, y, tl)
            if nf > 0:
                break
    out[_OUT_COUNT] = nf
    if nf == 0:
        return 0, 0, _NAN, jam, jmin
    best = _best(out, nf)
    k = _OUT_SLIDES + _SLOT * best
    D = A + mu * (B1 * out[k + 1] + B2 * out[k + 2])
    for j in range(nf if nf < _MAX_SLIDES else _MAX_SLIDES):  # t back in the frame's axes
        k = _OUT_SLIDES + _SLOT * j
        x, y = out[k + 1], out[k + 2]
        out[k + 1], out[k + 2] = x * r1 - y * r2, x * r2 + y * r1
    return nf, best, D, jam, jmin


@_jit
def _coulomb_planar(w00, w01, w11, v0, v1, e, mu, out):
    """One planar contact, mu > 0: the stick impulse if it lies in the cone, else the most
    dissipative slide (:func:`_planar_slides`)."""
    c = -(1.0 + e) * v0
    pn, pt, ok = _solve2(w00, w01, w11, c, -v1)
    if not ok:
        return SINGULAR, FAILED, _NAN, _NAN, _NAN, _NAN
    if _in_cone(pn, abs(pt), mu):
        return OK, STICK, pn, pt, 0.0, _NAN
    nf, best, jam, jmin = _planar_slides(w00, w01, w11, v0, v1, c, mu, out)
    if nf == 0:
        if jam:
            return JAM, FAILED, _NAN, _NAN, _NAN, jmin
        return NO_SOLUTION, FAILED, _NAN, _NAN, _NAN, _NAN
    out[_OUT_BEST] = best
    k = _OUT_SLIDES + _SLOT * best
    p, s = out[k], out[k + 1]
    return OK, SLIDE, p, mu * s * p, 0.0, w00 + mu * s * w01


@_jit
def _coulomb_spatial(w00, w01, w02, w11, w12, w22, v0, v1, v2, e, mu, out):
    """One spatial contact, mu > 0: the stick impulse if it lies in the cone, else the most
    dissipative slide (:func:`_spatial_slides`, from the stick impulse's tangent)."""
    c = -(1.0 + e) * v0
    i00, i01, i02, i11, i12, i22, det, ok = _inverse3(w00, w01, w02, w11, w12, w22)
    if not ok:
        return SINGULAR, FAILED, _NAN, _NAN, _NAN, _NAN
    pn, p1, p2 = _linsolve3(w00, w01, w02, w11, w12, w22, i00, i01, i02, i11, i12, i22, det,
                            c, -v1, -v2)
    if _in_cone(pn, math.hypot(p1, p2), mu):
        return OK, STICK, pn, p1, p2, _NAN
    f1, f2 = _unit_or(-v1, -v2, 1.0, 0.0)
    r1, r2 = _unit_or(p1, p2, f1, f2)
    nf, best, D, jam, jmin = _spatial_slides(w00, w01, w02, w11, w12, w22, v0, v1, v2, c, mu,
                                             r1, r2, out)
    if nf == 0:
        if jam:
            return JAM, FAILED, _NAN, _NAN, _NAN, jmin
        return NO_SOLUTION, FAILED, _NAN, _NAN, _NAN, _NAN
    out[_OUT_BEST] = best
    k = _OUT_SLIDES + _SLOT * best
    p, t1, t2 = out[k], out[k + 1], out[k + 2]
    return OK, SLIDE, p, mu * p * t1, mu * p * t2, D


_SEVERAL = ("the Coulomb law has several sliding solutions here; the most dissipative one is "
            "returned",)


def _extras(out, regime, impulse, w, v, d, e, mu) -> tuple:
    """A slide's figures: the number of sliding solutions (a warning if several), the
    post-impact slip u_t = v_t + (W pi)_t (planar) or the direction, its angle from v_t- and
    the slip speed sigma, u_t = -sigma t (spatial)."""
    if regime != "slide":
        return None, ()
    n = int(out[_OUT_COUNT])
    warns = _SEVERAL if n > 1 else ()
    k = _OUT_SLIDES + _SLOT * int(out[_OUT_BEST])
    p = impulse[0]
    if d == 2:
        s = float(out[k + 1])
        ut = v[1] + p * (w[0][1] + mu * s * w[1][1])
        return {"n_slide_solutions": n, "post_slip": (ut,)}, warns
    t1, t2 = float(out[k + 1]), float(out[k + 2])
    u1 = v[1] + p * (w[0][1] + mu * (w[1][1] * t1 + w[1][2] * t2))
    u2 = v[2] + p * (w[0][2] + mu * (w[1][2] * t1 + w[2][2] * t2))
    return {"n_slide_solutions": n, "direction": (t1, t2),
            "alpha": angle_from_slip(v[1], v[2], t1, t2),
            "post_slip_speed": -(u1 * t1 + u2 * t2)}, warns


#: SolverError's messages when no slide is found, planar and spatial
NO_PLANAR_SLIDE = ("no Coulomb sliding solution exists for this planar contact although the "
                   "stick impulse leaves the cone; use method='clarabel'")
NO_SPATIAL_SLIDE = ("no Coulomb sliding solution found for this spatial contact although the "
                    "stick impulse leaves the cone; use method='clarabel'")


contact_kernel = compiled_kernel(LAW, _coulomb_planar, _coulomb_spatial, _extras,
                                 no_solution=(NO_PLANAR_SLIDE, NO_SPATIAL_SLIDE))


def single_contact_solutions(W: np.ndarray, b: np.ndarray, mu: float) -> list[np.ndarray]:
    """Every solution of the one-contact Coulomb problem ``u = W pi + b`` with mu > 0 (exact,
    no iteration): the stick impulse ``pi = -W^-1 b`` when W is regular and it lies in K_mu,
    and, when b_n < 0, every slide (the kernel's enumeration, :func:`_planar_slides` or
    :func:`_spatial_slides`, with v = b and e = 0)."""
    d = W.shape[0]
    w = W.tolist()
    bb = [float(x) for x in b]
    found: list[np.ndarray] = []
    if d == 2:
        s0, s1, ok = _solve2(w[0][0], w[0][1], w[1][1], -bb[0], -bb[1])
        stick = (s0, s1)
    else:
        i00, i01, i02, i11, i12, i22, det, ok = _inverse3(w[0][0], w[0][1], w[0][2], w[1][1],
                                                          w[1][2], w[2][2])
        stick = _linsolve3(w[0][0], w[0][1], w[0][2], w[1][1], w[1][2], w[2][2], i00, i01, i02,
                           i11, i12, i22, det, -bb[0], -bb[1], -bb[2]) if ok else (0.0,) * 3
    if ok and _in_cone(stick[0], math.hypot(*stick[1:]), mu):
        found.append(np.array(stick))
    if not (mu > 0.0 and bb[0] < 0.0):
        return found  # no slide: pi_n = -b_n / D > 0 needs b_n < 0
    out = np.zeros(OUT_SIZE)
    if d == 2:
        nf = _planar_slides(w[0][0], w[0][1], w[1][1], bb[0], bb[1], -bb[0], mu, out)[0]
    else:
        f1, f2 = _unit_or(-bb[1], -bb[2], 1.0, 0.0)
        r1, r2 = _unit_or(stick[1], stick[2], f1, f2)
        nf = _spatial_slides(w[0][0], w[0][1], w[0][2], w[1][1], w[1][2], w[2][2], bb[0],
                             bb[1], bb[2], -bb[0], mu, r1, r2, out)[0]
    for j in range(min(nf, _MAX_SLIDES)):
        p, t1, t2 = out[_OUT_SLIDES + _SLOT * j: _OUT_SLIDES + _SLOT * j + 3]
        found.append(np.array([p, mu * p * t1, mu * p * t2][:d]))
    return found


# --------------------------------------------------------------------------------------------
# the conic path: the fixed point over CCP programs, finished exactly for one contact


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
    candidate of :func:`single_contact_solutions` nearest the iterate), which also rescues a
    fixed point that did not converge. When Coulomb's law has several solutions (large mu,
    several contacts) the one reached from the CCP start is returned.

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
        cands = single_contact_solutions(P.delassus, b, float(mu[0]))
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
