"""Compiled (numba) Newton finish and drivers of the several-contact solver.

On the data scaled by :func:`scaled_program` (standard second-order cones, every contact
equilibrated by its own effective mass, unit-size data; ``pi = S x``), both laws of the
``interior`` path are complementarity problems over the product K of second-order cones:

* ``ccp`` (and the dissipative law's plastic phase): ``K ∋ x ⊥ w = P x + q ∈ K``, a monotone
  problem, started by the interior point of :mod:`convimpact.contacts.interior_point`;
* ``coulomb`` (De Saxce's form of Coulomb's law with Newton's restitution):
  ``K ∋ x ⊥ w + |w_t| e ∈ K`` per contact -- in the scaled variables the shift
  ``mu |u_t| n`` of the contact-space law becomes ``|w_t|`` whatever mu (the scaling carries
  mu), a problem that is not monotone, started from the CCP answer (the same start as the
  conic path's fixed point).

Both are finished by a semismooth Newton method on the natural map
``F(x) = x - Proj_K(x - y(x))`` (:mod:`convimpact.contacts.natural_map`). The answer is judged by the certificates of
:mod:`convimpact.contacts.certificates` (imported here, so ``ccp_certificate`` and
``coulomb_certificate`` are this module's too) on the original data, never by the
iteration's own measures.
"""

from __future__ import annotations

import math

import numpy as np

from .certificates import ccp_certificate, coulomb_certificate
from .natural_map import natural_map_newton
from .interior_point import STALLED, TINY, TRIVIAL, _jit, cone_lcp
from ..compiled import jit_inline


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


@jit_inline
def cone_kernel(W, b, mu, d, tol, max_iter, newton_iter, coulomb):
    """:func:`ccp_kernel` (``coulomb`` False) or :func:`coulomb_kernel` (True), the law a
    run-time flag: a caller that takes either compiles the steps once."""
    N = mu.shape[0] * d
    P, q, idx, scale, starts, sizes, f, trivial = scaled_program(W, b, mu, d)
    if trivial:
        return np.zeros(N), _trivial_status(b), 0, 0, 0.0, 0.0
    x, z, status, it, gap, res = cone_lcp(P, q, starts, sizes, tol, max_iter)
    # bool(): a run-time flag, one compiled natural_map_newton for both laws
    x, res, steps = natural_map_newton(P, q, x, starts, sizes, newton_iter, bool(False))
    if not coulomb:
        return _unscale(x, idx, scale, f, N), status, it, steps, gap, res
    x, res2, steps2 = natural_map_newton(P, q, x, starts, sizes, newton_iter, bool(True))
    return _unscale(x, idx, scale, f, N), status, it, steps + steps2, res, res2


@jit_inline
def ccp_kernel(W, b, mu, d, tol, max_iter, newton_iter):
    """The CCP program ``min 1/2 pi^T W pi + b^T pi`` over ``pi_i in K_mu_i``, on contact data.

    ``mu_i = 0`` keeps contact i's normal only (pi_t = 0). The interior point runs to ``tol``
    (at most ``max_iter`` iterations), then at most ``newton_iter`` Newton steps on the
    natural map. Returns the impulse (N,), the interior point's status, its iterations, the
    Newton steps, its final gap and the natural map's final |F|_inf (scaled problem).
    """
    return cone_kernel(W, b, mu, d, tol, max_iter, newton_iter, bool(False))


@jit_inline
def coulomb_kernel(W, b, mu, d, tol, max_iter, newton_iter):
    """Coulomb's law ``K ∋ pi ⊥ u + mu |u_t| n ∈ K*`` (u = W pi + b) on contact data: the CCP
    answer (interior point and Newton), then Newton on Coulomb's natural map from it.

    Returns the impulse (N,), the interior point's status, its iterations, the Newton steps
    (both phases), and the final |F|_inf of the CCP and of Coulomb's natural maps.
    """
    return cone_kernel(W, b, mu, d, tol, max_iter, newton_iter, bool(True))
