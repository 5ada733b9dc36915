"""Compiled (numba) Newton finish and drivers of the several-contact solver.

On the data scaled by :func:`scaled_program` (standard second-order cones, every contact
equilibrated by its own effective mass, unit-size data; ``pi = S x``), both laws of the
``interior`` path are complementarity problems over the product K of second-order cones:

* ``ccp`` (and the dissipative law's plastic phase): ``K ∋ x ⊥ w = P x + q ∈ K``, a monotone
  problem, started by the interior point of :mod:`convimpact.impact.contacts.interior_point`;
* ``coulomb`` (De Saxce's form of Coulomb's law with Newton's restitution):
  ``K ∋ x ⊥ w + |w_t| e ∈ K`` per contact -- in the scaled variables the shift
  ``mu |u_t| n`` of the contact-space law becomes ``|w_t|`` whatever mu (the scaling carries
  mu), a problem that is not monotone, started from the CCP answer (the same start as the
  conic path's fixed point).

Both are finished by a semismooth Newton method on the natural map
``F(x) = x - Proj_K(x - y(x))`` (:mod:`convimpact.impact.contacts.natural_map`). The answer is judged by the certificates of
:mod:`convimpact.impact.contacts.certificates` (imported here, so ``ccp_certificate`` and
``coulomb_certificate`` are this module's too) on the original data, never by the
iteration's own measures.
"""

from __future__ import annotations

import math

import numpy as np

from .certificates import ccp_certificate, coulomb_certificate
from .natural_map import natural_map_newton
from .interior_point import STALLED, TINY, TRIVIAL, _jit, cone_lcp


#: a friction coefficient at or below this is no friction for the program: mu pi_n is then
#: below half an ulp of pi_n (and 1 / mu may overflow), so the frictionless answer is the
#: law's answer to round-off
MU_ROUNDOFF = 2.0 ** -53


@_jit
def scaled_program(W, b, mu, d):
    """The cone program in standard second-order cones and unit-size data.

    Per contact the unknowns are every row of a frictional contact (pi = diag(1/mu, 1, ..) y,
    y in the standard cone) or the normal of a frictionless one (a cone of dimension one);
    each contact is scaled by its own effective mass (unit largest diagonal), then W and b
    by their largest entries. Returns ``(P, q, idx, scale, starts, sizes, f, trivial)`` with
    ``pi[idx] = scale * f * x``; ``trivial`` when b = 0 or W = 0.
    """
    n = mu.shape[0]
    N = n * d
    idx = np.empty(N, dtype=np.int64)
    scale = np.empty(N)
    starts = np.empty(n, dtype=np.int64)
    sizes = np.empty(n, dtype=np.int64)
    M = 0
    for i in range(n):
        starts[i] = M
        if mu[i] > MU_ROUNDOFF:
            sizes[i] = d
            wmax = 0.0
            for j in range(d):
                f = 1.0 / mu[i] if j == 0 else 1.0
                w = W[i * d + j, i * d + j] * f * f
                if w > wmax:
                    wmax = w
            c = 1.0 / math.sqrt(wmax) if wmax > 0.0 else 1.0
            for j in range(d):
                idx[M] = i * d + j
                scale[M] = (c / mu[i]) if j == 0 else c
                M += 1
        else:
            sizes[i] = 1
            w = W[i * d, i * d]
            idx[M] = i * d
            scale[M] = 1.0 / math.sqrt(w) if w > 0.0 else 1.0
            M += 1
    idx = idx[:M]
    scale = scale[:M]
    P = np.empty((M, M))
    q = np.empty(M)
    sW = 0.0
    sq = 0.0
    for a in range(M):
        q[a] = scale[a] * b[idx[a]]
        if abs(q[a]) > sq:
            sq = abs(q[a])
        for c in range(M):
            P[a, c] = scale[a] * W[idx[a], idx[c]] * scale[c]
            if abs(P[a, c]) > sW:
                sW = abs(P[a, c])
    if sq == 0.0 or sW == 0.0:
        return P, q, idx, scale, starts, sizes, 0.0, True
    for a in range(M):
        q[a] /= sq
        for c in range(M):
            P[a, c] /= sW
    return P, q, idx, scale, starts, sizes, sq / sW, False


@_jit
def _unscale(x, idx, scale, f, N):
    pi = np.zeros(N)
    for a in range(idx.shape[0]):
        pi[idx[a]] = scale[a] * f * x[a]
    return pi


@_jit
def _trivial_status(b):
    """TRIVIAL when b = 0 (pi = 0 is the answer), else STALLED (W = 0: nothing moves)."""
    for i in range(b.shape[0]):
        if b[i] != 0.0:
            return STALLED
    return TRIVIAL


@_jit
def ccp_kernel(W, b, mu, d, tol, max_iter, newton_iter):
    """The CCP program ``min 1/2 pi^T W pi + b^T pi`` over ``pi_i in K_mu_i``, on contact data.

    ``mu_i = 0`` keeps contact i's normal only (pi_t = 0). The interior point runs to ``tol``
    (at most ``max_iter`` iterations), then at most ``newton_iter`` Newton steps on the
    natural map. Returns the impulse (N,), the interior point's status, its iterations, the
    Newton steps, its final gap and the natural map's final |F|_inf (scaled problem).
    """
    N = mu.shape[0] * d
    P, q, idx, scale, starts, sizes, f, trivial = scaled_program(W, b, mu, d)
    if trivial:
        return np.zeros(N), _trivial_status(b), 0, 0, 0.0, 0.0
    x, z, status, it, gap, res = cone_lcp(P, q, starts, sizes, tol, max_iter)
    x, res, steps = natural_map_newton(P, q, x, starts, sizes, newton_iter, False)
    return _unscale(x, idx, scale, f, N), status, it, steps, gap, res


@_jit
def coulomb_kernel(W, b, mu, d, tol, max_iter, newton_iter):
    """Coulomb's law ``K ∋ pi ⊥ u + mu |u_t| n ∈ K*`` (u = W pi + b) on contact data: the CCP
    answer (interior point and Newton), then Newton on Coulomb's natural map from it.

    Returns the impulse (N,), the interior point's status, its iterations, the Newton steps
    (both phases), and the final |F|_inf of the CCP and of Coulomb's natural maps.
    """
    N = mu.shape[0] * d
    P, q, idx, scale, starts, sizes, f, trivial = scaled_program(W, b, mu, d)
    if trivial:
        return np.zeros(N), _trivial_status(b), 0, 0, 0.0, 0.0
    x, z, status, it, gap, res = cone_lcp(P, q, starts, sizes, tol, max_iter)
    x, res, steps = natural_map_newton(P, q, x, starts, sizes, newton_iter, False)
    x, res2, steps2 = natural_map_newton(P, q, x, starts, sizes, newton_iter, True)
    steps += steps2
    return _unscale(x, idx, scale, f, N), status, it, steps, res, res2


#: a contact approaching slower than this fraction of max |v-| counts as touching
#: (:data:`convimpact.impact.conic.paths.APPROACH_RTOL`)
APPROACH_RTOL = 1e-9


@_jit
def law_data(v, e, friction, d, newton, all_friction):
    """The linear term b and the friction vector of a law's program from the contact data.

    ``b = v- + e min(v_n-, 0) n`` (``newton``; else b = v-, the dissipative law's plastic
    phase) and ``mu = friction`` (``all_friction``: Coulomb's law) or, for the
    maximal-dissipation programs, zero at contacts that do not approach by more than
    round-off (:func:`convimpact.impact.conic.paths.approaching`).
    """
    n = friction.shape[0]
    b = v.copy()
    mu = friction.copy()
    vscale = 0.0
    for i in range(v.shape[0]):
        if abs(v[i]) > vscale:
            vscale = abs(v[i])
    for i in range(n):
        vn = v[i * d]
        if newton and vn < 0.0:
            b[i * d] = vn + e[i] * vn
        if not all_friction and not vn < -APPROACH_RTOL * vscale:
            mu[i] = 0.0
    return b, mu


@_jit
def result_data(W, v, pi, friction, d, tol):
    """Post-impact velocities, slip speeds and regime codes of an impulse.

    ``v+ = v- + W pi``; per contact |v_t+| and the regime (0 separating, 1 frictionless,
    2 stick, 3 slide) by the rule of :func:`convimpact.impact.conic.paths.regimes_from_slip`:
    separating when ``pi_n <= tol |v-| / |W|``, frictionless when mu = 0, stick when
    ``|v_t+| <= 10 tol |v-|`` (max norms).
    """
    n = friction.shape[0]
    N = n * d
    vplus = np.empty(N)
    vscale = TINY
    wscale = TINY
    for i in range(N):
        s = v[i]
        for j in range(N):
            s += W[i, j] * pi[j]
            if abs(W[i, j]) > wscale:
                wscale = abs(W[i, j])
        vplus[i] = s
        if abs(v[i]) > vscale:
            vscale = abs(v[i])
    slip = np.empty(n)
    codes = np.empty(n, dtype=np.int64)
    pscale = vscale / wscale
    for i in range(n):
        o = i * d
        t = 0.0
        for j in range(o + 1, o + d):
            t += vplus[j] * vplus[j]
        slip[i] = math.sqrt(t)
        if pi[o] <= tol * pscale:
            codes[i] = 0
        elif friction[i] == 0.0:
            codes[i] = 1
        elif slip[i] <= 10.0 * tol * vscale:
            codes[i] = 2
        else:
            codes[i] = 3
    return vplus, slip, codes


@_jit
def _law_answer(W, v, e, friction, d, accuracy, pi, status, it, steps, residual, floor):
    """:func:`solve_law`'s return: the kernel's figures and one array (a single one to box)
    holding the impulse and, per contact, the regime code, the lift, ``mu |v_t+|`` and
    ``v_n+``."""
    vplus, slip, codes = result_data(W, v, pi, friction, d, accuracy)
    n = friction.shape[0]
    N = n * d
    out = np.empty(N + 4 * n)
    out[:N] = pi
    for i in range(n):
        vn = v[i * d]
        out[N + i] = codes[i]
        out[N + n + i] = vplus[i * d] - (-e[i]) * (vn if vn < 0.0 else 0.0)
        out[N + 2 * n + i] = friction[i] * slip[i]
        out[N + 3 * n + i] = vplus[i * d]
    return status, it, steps, residual, floor, out


@_jit
def solve_dissipation(W, v, e, friction, d, mode, tol, max_iter, newton_iter, accuracy):
    """:func:`solve_law` for the maximal-dissipation programs only (``mode`` 0: ccp, 1: the
    dissipative law's plastic phase): Coulomb's kernel and certificate are not compiled in."""
    b, mu = law_data(v, e, friction, d, mode != 1, False)
    pi, status, it, steps, r1, r2 = ccp_kernel(W, b, mu, d, tol, max_iter, newton_iter)
    residual = 0.0
    floor = 0.0
    if status != TRIVIAL:
        residual, floor = ccp_certificate(W, b, mu, d, pi)
    return _law_answer(W, v, e, friction, d, accuracy, pi, status, it, steps, residual, floor)


@_jit
def solve_coulomb(W, v, e, friction, d, mode, tol, max_iter, newton_iter, accuracy):
    """:func:`solve_law` for Coulomb's law only (``mode`` 2, not read)."""
    b, mu = law_data(v, e, friction, d, True, True)
    pi, status, it, steps, r1, r2 = coulomb_kernel(W, b, mu, d, tol, max_iter, newton_iter)
    residual = 0.0
    floor = 0.0
    if status != TRIVIAL:
        residual, floor = coulomb_certificate(W, b, mu, d, pi)
    return _law_answer(W, v, e, friction, d, accuracy, pi, status, it, steps, residual, floor)


@_jit
def solve_law(W, v, e, friction, d, mode, tol, max_iter, newton_iter, accuracy):
    """One law on contact data in one compiled call (the public path's: no dispatch between
    the steps): :func:`law_data`, the law's kernel, its certificate and :func:`result_data`.

    ``mode`` 0 is ``ccp`` (Newton's shift), 1 the dissipative law's plastic phase (b = v-),
    2 ``coulomb``. Returns the kernel's status, iterations and Newton steps, the certificate
    and its round-off floor (both 0 for a trivial program), and one array (a single one to
    box) holding the kernel's impulse (N) and, per contact (n each), the regime code of that
    impulse at ``accuracy``, the lift ``v_n+ - (-e min(v_n-, 0))``, ``mu |v_t+|`` and
    ``v_n+`` (elementwise, as numpy forms them).
    """
    if mode == 2:
        return solve_coulomb(W, v, e, friction, d, mode, tol, max_iter, newton_iter, accuracy)
    return solve_dissipation(W, v, e, friction, d, mode, tol, max_iter, newton_iter, accuracy)


def law_program(coulomb, W, v, e, friction, d, mode, tol, max_iter, newton_iter, accuracy):
    """:func:`solve_law` with the program's family a compile-time constant in compiled code
    (``coulomb`` a literal 0 or 1, made one by the caller's ``numba.literally``): a caller
    compiled for the maximal-dissipation programs (modes 0 and 1) does not compile Coulomb's
    kernel and certificate, and the other way round. As plain Python, :func:`solve_law`."""
    return solve_law(W, v, e, friction, d, mode, tol, max_iter, newton_iter, accuracy)


def _register_compiled() -> None:
    """The compiled form of :func:`law_program`: the family's solver chosen when the caller is
    typed (numba does not prune ``if coulomb`` on a literal argument by itself)."""
    try:
        from numba import types
        from numba.extending import overload
    except ImportError:  # no numba: the plain function above
        return

    @overload(law_program, inline="always", jit_options={"nogil": True, "error_model": "numpy"})
    def _program(coulomb, W, v, e, friction, d, mode, tol, max_iter, newton_iter, accuracy):
        if not isinstance(coulomb, types.IntegerLiteral):
            return None
        if coulomb.literal_value:
            def impl(coulomb, W, v, e, friction, d, mode, tol, max_iter, newton_iter,
                     accuracy):  # solve_coulomb's body, inlined (one call level less)
                b, mu = law_data(v, e, friction, d, True, True)
                pi, status, it, steps, r1, r2 = coulomb_kernel(W, b, mu, d, tol, max_iter,
                                                               newton_iter)
                residual = 0.0
                floor = 0.0
                if status != TRIVIAL:
                    residual, floor = coulomb_certificate(W, b, mu, d, pi)
                return _law_answer(W, v, e, friction, d, accuracy, pi, status, it, steps,
                                   residual, floor)
        else:
            def impl(coulomb, W, v, e, friction, d, mode, tol, max_iter, newton_iter,
                     accuracy):  # solve_dissipation's body, inlined (one call level less)
                b, mu = law_data(v, e, friction, d, mode != 1, False)
                pi, status, it, steps, r1, r2 = ccp_kernel(W, b, mu, d, tol, max_iter,
                                                           newton_iter)
                residual = 0.0
                floor = 0.0
                if status != TRIVIAL:
                    residual, floor = ccp_certificate(W, b, mu, d, pi)
                return _law_answer(W, v, e, friction, d, accuracy, pi, status, it, steps,
                                   residual, floor)
        return impl


_register_compiled()
