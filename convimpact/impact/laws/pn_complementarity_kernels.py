"""The tiers of the ``pereira-nikravesh`` law at several contacts, written once: the stick
tier, the admissibility test and the slide tier's relaxed bounds (the slide programs
themselves: :mod:`.pn_complementarity_slide`). The law
(:mod:`.pn_complementarity`) runs these functions compiled, or, before they are compiled, as
plain Python (:func:`convimpact.compiled.plain`): one source for both.

:func:`stick_tier` runs, in one call, for each candidate active set (every subset holding an
approaching contact, up to 2^8 - 1 of them): the sticking system ``W_SS pi_S = -b_S`` (S:
every row of a frictional contact of A, the normal row of a frictionless one) solved by LU
when ``cond_2(W_SS) < STICK_COND_MAX`` (the ratio of its extreme singular values: of its
eigenvalues' magnitudes, W_SS being symmetric), else in the least-squares sense (the
minimum-norm solution with numpy's default cut-off ``eps max(m, m)`` relative to the largest
singular value, from the eigenvectors) and kept only when consistent; then the cones and
Newton's law on A and no penetration off A, contact by contact, each with its round-off
allowance; then ``T+ - T- = pi.v- + 1/2 pi.W.pi``. The same numbers as numpy's ``cond``,
``solve`` and ``lstsq`` (the first and the last from the symmetric eigendecomposition rather
than an SVD: equal to round-off). :func:`stick_solve` is one active set's system (the law's
``stick_on``), :func:`admissible` the law's admissibility test, :func:`relaxed_bounds` the
slide tier's lower bound of T+ - T- of every active set in one call.
"""

from __future__ import annotations

import numpy as np

from ...compiled import jit as _jit
from ..problem.compiled_reduction import cholesky_into

EPS = float(np.finfo(float).eps)
TINY = 1e-300


@_jit
def _consistent(A, x, r, rtol):
    """|A x - r| <= rtol max(|r|, TINY) (2-norms): a least-squares answer solves its system."""
    res = 0.0
    rn = 0.0
    for a in range(r.size):
        acc = -r[a]
        for c in range(x.size):
            acc += A[a, c] * x[c]
        res += acc * acc
        rn += r[a] * r[a]
    return np.sqrt(res) <= rtol * max(np.sqrt(rn), TINY)


@_jit
def sub_cholesky(A, idx, m, L):
    """The lower Cholesky factor of ``A[idx[:m]][:, idx[:m]]`` into ``L[:m, :m]`` (zeros
    above the diagonal on entry), by the package's one Cholesky
    (:func:`~convimpact.impact.problem.compiled_reduction.cholesky_into`); False at the first
    pivot that is not positive."""
    S = np.empty((m, m))
    for i in range(m):
        for j in range(m):
            S[i, j] = A[idx[i], idx[j]]
    return cholesky_into(S, L, m, 0.0)


@_jit
def stick_tier(W, b, vminus, mu, d, sets, cond_max, cone_rtol, slack_max, tol):
    """Stick every active set of ``sets``; (admissible, energy change, impulses).

    Parameters
    ----------
    W : (N, N) Delassus matrix, ``N = n d``.
    b, vminus : (N,) Newton velocity shift ``v- + e min(v_n-, 0) n`` and ``v-``, flattened.
    mu : (n,) friction coefficients.
    d : contact dimension (2 or 3).
    sets : (n_sets, n) bool, the active sets.
    cond_max, cone_rtol, slack_max, tol : the law's STICK_COND_MAX, CONE_RTOL,
        VELOCITY_SLACK_MAX and the admissibility tolerance.

    Returns
    -------
    ok : (n_sets,) bool, the set's sticking impulse exists and is admissible.
    energy : (n_sets,) ``T+ - T-`` of the admissible ones.
    pis : (n_sets, N) their impulses.
    """
    n = mu.size
    N = n * d
    ns = sets.shape[0]
    ok = np.zeros(ns, dtype=np.bool_)
    energy = np.zeros(ns)
    pis = np.zeros((ns, N))
    absW = np.abs(W)
    rows = np.empty(N, dtype=np.int64)
    for s in range(ns):
        solved, m, x, lam = stick_solve(W, b, mu, d, sets[s], cond_max, rows)
        if not solved:
            continue
        pi = np.zeros(N)
        for a in range(m):
            pi[rows[a]] = x[a]
        if admissible(W, absW, sets[s], pi, b, mu, d, cone_rtol, slack_max, tol):
            ok[s] = True
            Wpi = W @ pi
            energy[s] = pi @ vminus + 0.5 * (pi @ Wpi)
            pis[s] = pi
    return ok, energy, pis


@_jit
def set_rows(member, mu, d, rows, normals):
    """The flat rows of active set ``member`` (n,) bool: every row of a frictional contact,
    the normal row of a frictionless one, into ``rows[:m]``; with ``normals`` of size n also
    the normal rows into ``normals[:k]``. Returns (m, k)."""
    m = 0
    k = 0
    for i in range(mu.size):
        if member[i]:
            if normals.size:
                normals[k] = i * d
                k += 1
            rows[m] = i * d
            m += 1
            if mu[i] > 0.0:
                for a in range(1, d):
                    rows[m] = i * d + a
                    m += 1
    return m, k


@_jit
def stick_solve(W, b, mu, d, member, cond_max, rows):
    """The sticking system of one active set (``member`` (n,) bool): ``W_SS x = -b_S`` with
    S (written into ``rows[:m]``) every row of a frictional contact of A and the normal row
    of a frictionless one, by LU when ``cond_2(W_SS) < cond_max``, else the minimum-norm
    least-squares solution kept only when consistent (see :func:`stick_tier`).

    Returns ``(solved, m, x (m,), lam (m,))``, lam the eigenvalues of W_SS (ascending)."""
    m, _ = set_rows(member, mu, d, rows, rows[:0])
    Wss = np.empty((m, m))
    r = np.empty(m)
    for a in range(m):
        r[a] = -b[rows[a]]
        for c in range(m):
            Wss[a, c] = W[rows[a], rows[c]]
    # W_SS is symmetric: its singular values are its eigenvalues' magnitudes, and its
    # minimum-norm least-squares solution is V diag(1/lambda) V^T r over the eigenvalues
    # above the cut-off eps m max|lambda| (gelsd's rule with numpy's default rcond)
    lam, V = np.linalg.eigh(Wss)
    ev = np.abs(lam)
    smin = np.min(ev)
    smax = np.max(ev)
    cond = smax / smin if smin > 0.0 else np.inf
    if cond < cond_max:
        x = np.linalg.solve(Wss, r)
    else:
        y = V.T @ r
        for a in range(m):
            y[a] = y[a] / lam[a] if ev[a] > EPS * m * smax else 0.0
        x = V @ y
        if not _consistent(Wss, x, r, 1e-9):
            return False, m, x, lam
    return True, m, x, lam


@_jit
def admissible(W, absW, A, pi, b, mu, d, cone_rtol, slack_max, tol):
    """The law's admissibility test of impulse ``pi`` (N,) on active set ``A`` (n,) bool:
    cones and pi_n >= 0 on A, u_n >= 0 off A, contact by contact, each to its own round-off
    allowance (``tol`` of the row's size plus ``1e2 eps sum_k |W_jk| |pi_k|``, capped at
    ``slack_max`` of it; an impulse the same divided by the contact's W_nn)."""
    n = mu.size
    Wpi = W @ pi
    ro = absW @ np.abs(pi)
    for i in range(n):
        size = 0.0
        roundoff = 0.0
        for k in range(d):
            j = i * d + k
            size = max(size, max(abs(b[j]), abs(Wpi[j])))
            roundoff = max(roundoff, 1e2 * EPS * ro[j])
        slack = max(tol * size, min(roundoff, slack_max * size))
        if A[i]:
            pn = pi[i * d]
            pt2 = 0.0
            for k in range(1, d):
                pt2 += pi[i * d + k] ** 2
            pt = np.sqrt(pt2)
            pnorm = np.sqrt(pn * pn + pt2)
            ptol = max(tol * pnorm, slack / W[i * d, i * d])
            if pn < -ptol or pt > mu[i] * pn * (1.0 + cone_rtol) + ptol:
                return False
        elif Wpi[i * d] + b[i * d] < -slack:
            return False
    return True


@_jit
def relaxed_bounds(W, b, vminus, mu, d, sets):
    """The slide tier's lower bound of every active set of ``sets``: min of T+ - T- over the
    impulses on A with ``u_n = 0`` there, without the cones (the KKT system of the
    equality-constrained QP, least squares with numpy's default cut-off), +inf where the
    equalities cannot hold (a residual above 1e-8 of the right-hand side)."""
    n = mu.size
    N = n * d
    ns = sets.shape[0]
    out = np.empty(ns)
    rows = np.empty(N, dtype=np.int64)
    normals = np.empty(n, dtype=np.int64)
    for s in range(ns):
        m, k = set_rows(sets[s], mu, d, rows, normals)
        size = m + k
        K = np.zeros((size, size))
        rhs = np.empty(size)
        for a in range(m):
            rhs[a] = -vminus[rows[a]]
            for c in range(m):
                K[a, c] = W[rows[a], rows[c]]
        for a in range(k):
            rhs[m + a] = -b[normals[a]]
            for c in range(m):
                K[m + a, c] = W[normals[a], rows[c]]
                K[c, m + a] = W[normals[a], rows[c]]
        sol = np.linalg.lstsq(K, rhs, EPS * size)[0]
        if not _consistent(K, sol, rhs, 1e-8):
            out[s] = np.inf
            continue
        pi = np.zeros(N)
        for a in range(m):
            pi[rows[a]] = sol[a]
        out[s] = pi @ vminus + 0.5 * (pi @ (W @ pi))
    return out

