"""A certificate that an active set of law ``pereira-nikravesh`` has no admissible impulse at
all, stick or slide, without solving it (:func:`no_admissible_impulse`): the far contacts
would have to sink. Used by the pruned search (:mod:`.pn_complementarity_prune`) on the sets
its other arguments leave (on a box sliding on four corners: the edge pairs, tipping about an
edge; the lone corners; the diagonals), before their programs are solved.

**The argument (Farkas).** Let C be the active set, F the other contacts, ``u = W pi + b``.
Every candidate of C, whether the law sticks it (``W_SS pi = -b_S``) or slides it
(P_N(C)'s minimizer), is zero off C, and the law keeps it only when its admissibility test
(:func:`~.pn_complementarity_kernels.admissible`) passes: on i in C
``pn_i >= -ptol_i`` and ``|pt_i| <= mu_i' pn_i + ptol_i`` (``mu_i' = mu_i (1 + cone_rtol)``,
``ptol_i = max(tol |pi_i|, slack_i / W_ii)``), off C ``u_n,j >= -slack_j``, with
``slack = max(tol size, min(roundoff, slack_max size)) <= theta size``,
``theta = max(tol, slack_max)``, ``size_c`` the largest ``|b|`` or ``|W pi|`` on contact
c's rows. Take the far normal rows summed, ``s = sum_{j in F} u_n,j = c.pi + c0`` with
``c = sum_j W[n_j, :]`` (on C's rows) and ``c0 = sum_j b_n,j`` (a unit push on every far
contact; its velocities at C's contacts are ``c``). Where every ``c_i`` points into the
floor more steeply than the cone's dual allows, ``kappa_i = -(c_n,i + mu_i' |c_t,i|) > 0``
(lifting the far contacts presses C's contacts down, even against their friction),

* ``c_i.pi_i <= -kappa_i p_i + (|c_n,i| + |c_t,i|) ptol_i`` with ``p_i = max(pn_i, 0)``
  (both signs of ``pn_i``),
* ``|pi_i| <= (1 + mu_i') p_i + 2 ptol_i`` and ``size_c <= |b|_c + Omega Pi``
  (``Pi = sum_i |pi_i|``, ``Omega`` the largest sum of ``|W|`` over a row and a contact's
  columns), hence ``Pi (1 - eps1) <= (1 + mu'_max) P + 2 theta sum_i |b|_i / W_ii``
  (``P = sum_i p_i``, ``eps1 = 2 tol + 2 theta Omega sum_i 1 / W_ii < 1``),
* admissibility gives ``s >= -theta sum_j (|b|_j + Omega Pi)``;

so ``0 <= R0 + P (K1 A1 - kappa_min)`` (the constants of :func:`_closes`, where ``tol`` is
taken as ``theta``: the bound then holds for every admissibility tolerance the law uses up to
``slack_max``, the interior point's unpolished answers' 1e-4 included),
impossible when ``K1 A1 <= kappa_min`` and ``R0 < 0``: no impulse on C passes the law's test,
whatever program produced it. On a box sliding on its face the far corners' push
presses an edge pair down by about ``2.8 - 0.3 * 2.4`` (velocity per unit impulse), ``R0``
is about ``-2 g h`` (the far corners' approach) plus ``1e-4`` of the speeds: the pair cannot
tip the box, and is excluded with a wide margin. A box whose friction can tip it
(``mu c > a``, an edge whose push does not press down) fails the test and its programs are
solved as before.

**Sticking (the second certificate, :func:`no_sticking_impulse`).** Any sticking impulse x
of a set A solves ``W_AA x = -b_A + res`` on every row of A (``|res| <= 1e-9 |b_A|`` where the
law takes the minimum-norm solution, its consistency test; ``|res| <= 1e-10 ||W_AA||_F |x|``
where it takes LU, backward stability with a generous constant). With the virtual impulse
``xi_i = (-1, -k_i s_i)`` on each contact (pulling it down and against its slip ``s_i``, ``k_i
|b_t,i| = 2 max(-b_n,i, 0) + 1e-3 |b_i|``: ``xi.b_A < 0``) and ``c = W_AA xi``, the identity
``xi.res = c.x + xi.b_A`` is bounded as above wherever every ``c_i`` points into the floor
more steeply than the cone's dual allows: stopping the slip would take more friction than
the cones give. On a box sliding at 2 m/s it excludes every stick set.

Both certificates use only ``W``, ``b``, ``mu`` and the law's tolerances: they hold for any
problem, not only a time stepper's. Where one does not hold the caller solves the set.
"""

from __future__ import annotations

import numpy as np

from ...compiled import jit as _jit

#: the margin R0 must keep below zero, relative to |c0| (for the round-off of forming c, c0)
EXCLUSION_RTOL = 1e-8
#: the stick solve's residuals allowed: the minimum-norm path's consistency test (relative to
#: |b_A|) and LU's backward error (relative to ||W_AA||_F |x|)
STICK_RESIDUAL = 1e-9
LU_RESIDUAL = 1e-10


@_jit
def _contact_data(W, b, mu, d, bmax, xi, slipping):
    """Per contact: ``|b|_c`` (largest |b| on its rows), the sticking certificate's virtual
    impulse ``xi`` and whether it applies (frictional, slipping, ``W_nn > 0``)."""
    n = mu.size
    for i in range(n):
        o = i * d
        bt2 = 0.0
        bmax[i] = abs(b[o])
        for k in range(1, d):
            bt2 += b[o + k] ** 2
            bmax[i] = max(bmax[i], abs(b[o + k]))
        bt = np.sqrt(bt2)
        slipping[i] = bt > 0.0 and mu[i] > 0.0 and W[o, o] > 0.0
        xi[o] = -1.0
        kap = (2.0 * max(-b[o], 0.0) + 1e-3 * np.sqrt(bt2 + b[o] ** 2)) / bt if bt > 0.0 else 0.0
        for k in range(1, d):
            xi[o + k] = -kap * b[o + k] / bt if bt > 0.0 else 0.0


@_jit
def _closes(W, member, mu, d, c, c0, bmax, tol, theta, cone_rtol, rho0, rho1, xin, far_b,
            n_far, omega):
    """The common end of both certificates: with ``c`` (the virtual push's velocities on the
    set's rows) and ``c0``, whether ``R0 < 0`` and ``K1 A1 <= kappa_min`` (module docstring;
    ``rho0 + rho1 Pi`` the residual allowed on the set's rows, ``xin`` |xi|, ``far_b`` and
    ``n_far``, ``omega`` the far contacts' terms)."""
    n = mu.size
    kappa_min = np.inf
    cmax = 0.0
    mu_max = 0.0
    inv_w = 0.0
    bw = 0.0
    cbw = 0.0
    cw = 0.0
    for i in range(n):
        if not member[i]:
            continue
        o = i * d
        mup = mu[i] * (1.0 + cone_rtol)
        mu_max = max(mu_max, mup)
        ct2 = 0.0
        for k in range(1, d):
            ct2 += c[o + k] ** 2
        ct = np.sqrt(ct2)
        kappa_min = min(kappa_min, -(c[o] + mup * ct))
        cni = abs(c[o]) + ct
        cmax = max(cmax, cni)
        wii = W[o, o]
        inv_w += 1.0 / wii
        bw += (bmax[i] + rho0) / wii
        cbw += cni * (bmax[i] + rho0) / wii
        cw += cni / wii
    if not kappa_min > 0.0:
        return False
    growth = rho1 + omega  # |W pi| on a row per unit of Pi: the residual's, or the far rows'
    eps1 = 2.0 * tol + 2.0 * theta * rho1 * inv_w + 2.0 * theta * omega * inv_w
    if not eps1 < 0.5:
        return False
    a1 = (1.0 + mu_max) / (1.0 - eps1)
    a0 = 2.0 * theta * bw / (1.0 - eps1)
    k1 = xin * rho1 + theta * omega * n_far + cmax * tol + theta * growth * cw
    if not k1 * a1 <= kappa_min:
        return False
    r0 = c0 + xin * rho0 + theta * far_b + theta * cbw + k1 * a0
    return r0 < -EXCLUSION_RTOL * abs(c0)


@_jit
def _row_sums(W, n, d):
    """``A[r, i]``: the sum of ``|W|`` over row r and contact i's columns."""
    N = W.shape[0]
    A = np.empty((N, n))
    for r in range(N):
        for i in range(n):
            acc = 0.0
            for k in range(d):
                acc += abs(W[r, i * d + k])
            A[r, i] = acc
    return A


@_jit
def _far_sink(W, b, mu, d, member, tol, slack_max, cone_rtol, bmax, c, A):
    """:func:`no_admissible_impulse` with ``bmax`` and ``A`` (:func:`_row_sums`) given and
    ``c`` (N,) a work array."""
    n = mu.size
    N = W.shape[0]
    n_far = 0
    n_in = 0
    for i in range(n):
        if member[i]:
            n_in += 1
            if not W[i * d, i * d] > 0.0:
                return False
        else:
            n_far += 1
    if n_far == 0 or n_in == 0:
        return False
    c0 = 0.0
    far_b = 0.0
    for r in range(N):
        c[r] = 0.0
    for j in range(n):
        if member[j]:
            continue
        c0 += b[j * d]
        far_b += bmax[j]
        for i in range(n):  # (the members' rows, contact by contact: no division per row)
            if member[i]:
                for r in range(i * d, i * d + d):
                    c[r] += W[j * d, r]
    for i in range(n):  # (the push must press every member down: else no need for Omega)
        if member[i]:
            o = i * d
            ct2 = 0.0
            for k in range(1, d):
                ct2 += c[o + k] ** 2
            if not c[o] + mu[i] * (1.0 + cone_rtol) * np.sqrt(ct2) < 0.0:
                return False
    omega = 0.0  # the largest sum of |W| over a row and a member contact's columns
    for r in range(N):
        for i in range(n):
            if member[i]:
                omega = max(omega, A[r, i])
    theta = max(tol, slack_max)
    return _closes(W, member, mu, d, c, c0, bmax, theta, theta, cone_rtol, 0.0,
                   0.0, 0.0, far_b, n_far, omega)


@_jit
def _stuck_out(W, b, mu, d, member, tol, slack_max, cone_rtol, bmax, xi, slipping, c):
    """:func:`no_sticking_impulse` with the contact data given and ``c`` (N,) a work
    array."""
    n = mu.size
    N = W.shape[0]
    m = 0
    bnorm2 = 0.0
    for i in range(n):
        if member[i]:
            if not slipping[i]:
                return False
            m += 1
            for k in range(d):
                bnorm2 += b[i * d + k] ** 2
    if m == 0:
        return False
    c0 = 0.0
    fro2 = 0.0
    xin2 = 0.0
    rows = np.empty(N, dtype=np.bool_)  # the members' rows (no division in the loops)
    for r in range(N):
        rows[r] = member[r // d]
    for r in range(N):
        c[r] = 0.0
        if not rows[r]:
            continue
        c0 += xi[r] * b[r]
        xin2 += xi[r] * xi[r]
        acc = 0.0
        for k in range(N):
            if rows[k]:
                acc += W[r, k] * xi[k]
                fro2 += W[r, k] ** 2
        c[r] = acc
    rho1 = LU_RESIDUAL * np.sqrt(fro2)
    theta = max(tol, slack_max)
    return _closes(W, member, mu, d, c, c0, bmax, theta, theta, cone_rtol,
                   STICK_RESIDUAL * np.sqrt(bnorm2), rho1, np.sqrt(xin2), 0.0, 0, 0.0)


@_jit
def no_admissible_impulse(W, b, mu, d, member, tol, slack_max, cone_rtol):
    """Whether no impulse on the contacts of ``member`` (n,) bool passes the law's
    admissibility test at tolerance ``tol`` (module docstring: the far contacts would have
    to sink). False also where the argument does not apply (no far contact, a zero
    ``W_ii``, a push that does not press the set down)."""
    n = mu.size
    bmax = np.empty(n)
    xi = np.empty(W.shape[0])
    slipping = np.empty(n, dtype=np.bool_)
    _contact_data(W, b, mu, d, bmax, xi, slipping)
    return _far_sink(W, b, mu, d, member, tol, slack_max, cone_rtol, bmax,
                     np.empty(W.shape[0]), _row_sums(W, n, d))


@_jit
def no_sticking_impulse(W, b, mu, d, member, tol, slack_max, cone_rtol):
    """Whether the law's stick tier can find no admissible sticking impulse on the contacts
    of ``member`` (every one frictional and slipping, ``b_t != 0``): the second certificate
    of the module docstring."""
    n = mu.size
    bmax = np.empty(n)
    xi = np.empty(W.shape[0])
    slipping = np.empty(n, dtype=np.bool_)
    _contact_data(W, b, mu, d, bmax, xi, slipping)
    return _stuck_out(W, b, mu, d, member, tol, slack_max, cone_rtol, bmax, xi, slipping,
                      np.empty(W.shape[0]))


@_jit
def excluded_sets(W, b, mu, d, masks, tol, slack_max, cone_rtol):
    """Both certificates on every set of ``masks`` (n_sets, n): ``(none, stick)``, the sets
    with no admissible impulse at all (:func:`no_admissible_impulse`; not tried on the first,
    the full set, whose answer the pruned search takes) and those with no admissible
    sticking impulse (these and :func:`no_sticking_impulse`'s)."""
    n = mu.size
    N = W.shape[0]
    ns = masks.shape[0]
    bmax = np.empty(n)
    xi = np.empty(N)
    slipping = np.empty(n, dtype=np.bool_)
    c = np.empty(N)
    _contact_data(W, b, mu, d, bmax, xi, slipping)
    A = _row_sums(W, n, d)
    none = np.zeros(ns, dtype=np.bool_)
    stick = np.zeros(ns, dtype=np.bool_)
    for s in range(ns):
        if s > 0:
            none[s] = _far_sink(W, b, mu, d, masks[s], tol, slack_max, cone_rtol, bmax, c, A)
        stick[s] = none[s] or _stuck_out(W, b, mu, d, masks[s], tol, slack_max, cone_rtol,
                                         bmax, xi, slipping, c)
    return none, stick


__all__ = ["no_admissible_impulse", "no_sticking_impulse", "excluded_sets", "EXCLUSION_RTOL",
           "STICK_RESIDUAL", "LU_RESIDUAL"]
