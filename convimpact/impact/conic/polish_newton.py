"""The polish's Newton on one active set, compiled: :func:`active_set_newton` (the KKT
equations of the cone QP, or Coulomb's conditions) and :func:`active_set_jacobian` (their
Jacobian at a solution: its null space is the solution's family).

The equations and the acceptance are those of
:func:`convimpact.impact.conic.polish.polish_cone_qp` (which calls these kernels), on the
unknowns of each contact's kind: ``ZERO``, ``ACT`` (frictionless, pressing), ``INT`` or
``BND`` (``r``, the tangent's angle in space -- ``sg = +-1`` in the plane -- and ``kappa``),
then the multipliers of ``E x = f``. Steps are the minimum-norm least-squares ones of
:mod:`.polish_steps` (numba's own ``lstsq`` took 5 s more to compile). An accepted answer is
an exact KKT point (Coulomb solution), however it was reached.
"""

from __future__ import annotations

import numpy as np

from ...compiled import jit as _jit
from ...compiled import jit_internal as _jit_internal
from .polish_cod import cod_min_norm_solve
from .polish_steps import _absmax, _matmat, _matvec, _min_norm_solve, _pivoted_step

TINY = 1e-300
EPS = float(np.finfo(float).eps)
#: a contact's kind in an active set (the polish's "zero", "act", "int", "bnd")
ZERO, ACT, INT, BND = 0, 1, 2, 3
#: relative thresholds that classify a solution's contacts (:func:`primary_kinds`)
POLISH_ZERO_RTOL = 1e-4
POLISH_BOUNDARY_RTOL = 1e-4
#: Newton iterations from a start near the answer (an interior-point answer, a guess)
POLISH_MAX_NEWTON = 12
#: iterations of the damped Newton from starts farther from the answer
DAMPED_MAX_NEWTON = 30
#: accepted Newton residual, relative to the round-off scale of W x + q and E x - f
POLISH_ACCEPT = 1e-11
#: largest residual of the velocities W x + q, relative to V = max(|q|, |W x|), accepted
#: whatever the conditioning: round-off leaves cond(W) eps (1e-6 at cond 1e10); a larger one
#: means no solution (an unbounded program's huge iterate, where the round-off scale |W| X
#: would excuse anything)
VELOCITY_RESIDUAL_MAX = 1e-4


@_jit_internal
def _layout(kind, d):
    """Start of every contact's unknowns (and their count, last)."""
    n = kind.size
    start = np.zeros(n + 1, dtype=np.int64)
    for i in range(n):
        k = kind[i]
        w = 0
        if k == INT:
            w = d
        elif k == ACT:
            w = 1
        elif k == BND:
            w = 3 if d == 3 else 2
        start[i + 1] = start[i] + w
    return start


@_jit_internal
def _unpack(u, kind, tang, mu, d, start, coulomb, U):
    """x, z and their Jacobians in the unknowns u."""
    n = kind.size
    N = n * d
    x = np.zeros(N)
    z = np.zeros(N)
    Jx = np.zeros((N, U))
    Jz = np.zeros((N, U))
    for i in range(n):
        s = start[i]
        o = i * d
        k = kind[i]
        m_ = mu[i]
        zn = 0.0 if coulomb else m_
        if k == INT:
            for a in range(d):
                x[o + a] = u[s + a]
                Jx[o + a, s + a] = 1.0
        elif k == ACT:
            x[o] = u[s]
            Jx[o, s] = 1.0
        elif k == BND:  # unknowns r, [angle,] kappa; the unit tangent (c, sn), or (sg) in 2-D
            sk = s + d - 1
            r, kap = u[s], u[sk]
            c, sn = (np.cos(u[s + 1]), np.sin(u[s + 1])) if d == 3 else (tang[i, 0], 0.0)
            x[o] = r
            x[o + 1] = r * m_ * c
            Jx[o, s] = 1.0
            Jx[o + 1, s] = m_ * c
            z[o] = kap * zn
            z[o + 1] = -kap * c
            Jz[o, sk] = zn
            Jz[o + 1, sk] = -c
            if d == 3:  # the second tangent, and the angle's column
                x[o + 2] = r * m_ * sn
                Jx[o + 2, s] = m_ * sn
                z[o + 2] = -kap * sn
                Jz[o + 2, sk] = -sn
                Jx[o + 1, s + 1] = -r * m_ * sn
                Jx[o + 2, s + 1] = r * m_ * c
                Jz[o + 1, s + 1] = kap * sn
                Jz[o + 2, s + 1] = -kap * c
    return x, z, Jx, Jz


@_jit_internal
def _residual(u, W, q, E, f, kind, tang, mu, d, start, coulomb, eq_rows, n_eq, n_prim, X0,
              near, scales):
    """The scaled residual F and Jacobian J of the active set's equations at u, x and the
    unscaled stationarity G = W x + q - E^T lambda - z."""
    N = W.shape[0]
    m = E.shape[0]
    U = u.size
    x, z, Jx, Jz = _unpack(u, kind, tang, mu, d, start, coulomb, U)
    X = max(_absmax(x), X0 if near else 0.0, TINY)
    sG = max(scales[0], scales[1] * X, TINY)
    sE = max(scales[2], scales[3] * X, TINY)
    G = _matvec(W, x)
    dG = _matmat(W, Jx)
    for a in range(N):
        G[a] += q[a] - z[a]
        for c in range(U):
            dG[a, c] -= Jz[a, c]
    for c in range(m):
        lam = u[n_prim + c]
        for a in range(N):
            G[a] -= E[c, a] * lam
            dG[a, n_prim + c] -= E[c, a]
    F = np.empty(n_eq + m)
    J = np.empty((n_eq + m, U))
    row = 0
    for a in range(N):
        if eq_rows[a]:
            F[row] = G[a] / sG
            for c in range(U):
                J[row, c] = dG[a, c] / sG
            row += 1
    if m:
        Ex = _matvec(E, x)
        EJ = _matmat(E, Jx)
        for c in range(m):
            F[row] = (Ex[c] - f[c]) / sE
            for k in range(U):
                J[row, k] = EJ[c, k] / sE
            row += 1
    return F, J, x, G


@_jit_internal
def _consistent(W, q, mu, d, kind, start, x, G, u, coulomb, qmax, wmax):
    """Sign conditions of an active set's solution (see the module docstring): zero contacts'
    duals in K* (u_n >= 0 for Coulomb and frictionless ones), pressing normals, interior
    points in the cone, boundary rays with r > 0 and kappa >= 0; velocities to V times the
    round-off floor."""
    n = mu.size
    X = max(_absmax(x), TINY)
    V = max(qmax, _absmax(_matvec(W, x)), TINY)
    floor = EPS * wmax * X / V
    vtol = V * max(1e-10, min(1e2 * floor, VELOCITY_RESIDUAL_MAX))
    for i in range(n):
        o = i * d
        gt = 0.0
        xt = 0.0
        for a in range(1, d):
            gt += G[o + a] ** 2
            xt += x[o + a] ** 2
        k = kind[i]
        if k == ZERO:
            if mu[i] == 0.0 or coulomb:
                if G[o] < -vtol:
                    return False
            elif mu[i] * np.sqrt(gt) > G[o] + vtol:
                return False
        elif k == ACT:
            if x[o] < -1e-12 * X:
                return False
        elif k == INT:
            if not (x[o] >= 0.0 and np.sqrt(xt) <= mu[i] * x[o] + 1e-12 * X):
                return False
        elif k == BND:
            if not (u[start[i]] > 0.0 and u[start[i + 1] - 1] >= -vtol):
                return False
    return True


@_jit_internal
def _start(W, q, E, mu, d, kind, tang, x0, coulomb, start, U):
    """The unknowns of the active set at ``x0`` (the Newton's start; the multipliers of
    ``E x = f`` by least squares) and the rows of ``W x + q - E^T lambda - z`` that are
    equations: (u, eq_rows, n_eq)."""
    n = mu.size
    N = n * d
    m = E.shape[0]
    n_prim = start[n]
    g0 = _matvec(W, x0)
    for a in range(N):
        g0[a] += q[a]
    u = np.zeros(U)
    for i in range(n):
        s = start[i]
        o = i * d
        if kind[i] == INT:
            for a in range(d):
                u[s + a] = x0[o + a]
        elif kind[i] == ACT:
            u[s] = max(x0[o], 0.0)
        elif kind[i] == BND:
            nx = 0.0
            for a in range(d):
                nx += x0[o + a] ** 2
            u[s] = max(x0[o], np.sqrt(nx) / (1.0 + mu[i]), 0.0)
            if coulomb:  # kappa from the slip along -t, or from the normal row
                gt = 0.0
                for a in range(d - 1):
                    gt += g0[o + 1 + a] * tang[i, a]
                kap = max(-gt, 0.0)
            else:
                kap = max(g0[o] / mu[i], 0.0)
            if d == 3:
                u[s + 1] = np.arctan2(tang[i, 1], tang[i, 0])
                u[s + 2] = kap
            else:
                u[s + 1] = kap
    if m:
        lam0 = _min_norm_solve(np.ascontiguousarray(E.T), g0, EPS * max(N, m))
        for c in range(m):
            u[n_prim + c] = lam0[c]
    eq_rows = np.zeros(N, dtype=np.bool_)
    n_eq = 0
    for i in range(n):
        for a in range(d):
            if kind[i] == INT or kind[i] == BND or (kind[i] == ACT and a == 0):
                eq_rows[i * d + a] = True
                n_eq += 1
    return u, eq_rows, n_eq


@_jit_internal
def primary_kinds(x, mu, d):
    """The polish's primary classification of ``x`` (``polish._contact_kinds``' first
    choice): per contact ZERO (``|x_i| <= 1e-4 X`` or ``x_n <= 0``), ACT (frictionless), BND
    (within 1e-4 of its cone's boundary, with the unit tangent of ``x_t``) or INT."""
    n = mu.size
    kind = np.zeros(n, dtype=np.int64)
    tang = np.zeros((n, 2))
    X = max(_absmax(x), TINY)
    for i in range(n):
        o = i * d
        xt2 = 0.0
        for a in range(1, d):
            xt2 += x[o + a] ** 2
        xt = np.sqrt(xt2)
        nx = np.sqrt(x[o] ** 2 + xt2)
        if nx <= POLISH_ZERO_RTOL * X or x[o] <= 0.0:
            kind[i] = ZERO
        elif mu[i] == 0.0:
            kind[i] = ACT
        elif (mu[i] * x[o] - xt) / max(nx, TINY) <= POLISH_BOUNDARY_RTOL:
            kind[i] = BND
            if xt > 0.0 and np.isfinite(xt):
                for a in range(1, d):
                    tang[i, a - 1] = x[o + a] / xt
            else:
                tang[i, 0] = 1.0
        else:
            kind[i] = INT
    return kind, tang


@_jit_internal
def _setup(W, q, E, f, mu, d, kind, tang, x0, coulomb):
    """The active set's layout, the Newton's start at ``x0`` and the residual's scales:
    (start, n_prim, U, X0, u, eq_rows, n_eq, scales)."""
    start = _layout(kind, d)
    n_prim = start[mu.size]
    U = n_prim + E.shape[0]
    X0 = max(_absmax(x0), TINY)
    u, eq_rows, n_eq = _start(W, q, E, mu, d, kind, tang, x0, coulomb, start, U)
    scales = np.array([_absmax(q), _absmax(W), _absmax(f), _absmax(E)])
    return start, n_prim, U, X0, u, eq_rows, n_eq, scales


@_jit
def active_set_newton(W, q, E, f, mu, d, kind, tang, x0, coulomb, near, max_iter, damped,
                      pivoted, cod=False):
    """Solve the KKT (``coulomb``: Coulomb's) equations of one active set from ``x0``.

    Parameters
    ----------
    W, q, E, f, mu, d
        The cone QP (``W`` (N, N), ``q`` (N,), ``E`` (m, N), ``f`` (m,), ``mu`` (n,), N = n d).
    kind : int64 array (n,)
        ZERO, ACT, INT or BND per contact.
    tang : float array (n, 2)
        The unit tangent of a BND contact (in the plane ``(+-1, 0)``).
    x0 : float array (N,)
        The start (an interior-point answer, a guess).
    coulomb, near : bool
        Coulomb's conditions instead of the KKT equations; require the answer within
        1e-2 max |x0| of ``x0``.
    max_iter : int
        Newton iterations at most (:data:`POLISH_MAX_NEWTON`, :data:`DAMPED_MAX_NEWTON`).
    damped : bool
        Halve each step until the residual falls, and no early stop on a slow fall (starts
        far from the answer).
    pivoted : bool
        Steps by :func:`~.polish_steps._pivoted_step` (Gaussian elimination; the slide programs of law
        ``pereira-nikravesh``), stopping once the residual is accepted and stalls (a
        singular J: redundant contacts); else by the singular value decomposition (the
        polish's, numpy's ``lstsq`` with ``rcond`` 1e-13). Either way the answer is accepted
        on its residual and sign conditions, never on how it was reached.
    cod : bool
        Unpivoted steps by the complete orthogonal decomposition instead of the singular
        value decomposition (:func:`~.polish_cod.cod_min_norm_solve`, the same cut 1e-13 on
        its pivots: the same minimum-norm steps wherever the rank is clear, at a fraction of
        the cost), stopping as the pivoted steps do once the residual is accepted and stalls
        (else a singular J's round-off, above 4 eps, runs every iteration).

    Returns
    -------
    x, consistent
        The solution (``x0`` when it is not accepted) and whether it was accepted.
    """
    x, ok, _, _ = newton_core(W, q, E, f, mu, d, kind, tang, x0, coulomb, near, max_iter,
                              damped, pivoted, cod)
    return x, ok


@_jit_internal
def newton_core(W, q, E, f, mu, d, kind, tang, x0, coulomb, near, max_iter, damped, pivoted,
                cod):
    """:func:`active_set_newton` with the scaled Jacobian of the active set's equations at
    the answer's unknowns and those unknowns: (x, accepted, J, u); J and u are empty unless
    the Newton ran (the family of solutions through x: the null space of J,
    :mod:`convimpact.impact.laws.stronge_contacts_warm`)."""
    n = mu.size
    N = n * d
    start, n_prim, U, X0, u, eq_rows, n_eq, scales = _setup(W, q, E, f, mu, d, kind, tang, x0,
                                                            coulomb)
    qmax, wmax = scales[0], scales[1]
    none = np.zeros((0, 0))
    if U == 0:
        x = np.zeros(N)
        return (x, _consistent(W, q, mu, d, kind, start, x, q.copy(), u, coulomb, qmax, wmax),
                none, u)
    best_f = 0.0
    have_best = False
    best_u = u.copy()
    f0 = 0.0
    prev = np.inf
    # the best iterate's residual, x and G, kept (the final check reads them)
    best_F, best_x, best_G, best_J = np.zeros(0), np.zeros(0), np.zeros(0), none
    for it in range(max_iter):
        F, J, x, G = _residual(u, W, q, E, f, kind, tang, mu, d, start, coulomb, eq_rows,
                               n_eq, n_prim, X0, near, scales)
        fn = _absmax(F)
        if it == 0:
            f0 = fn
        if not have_best or fn < best_f:
            best_f = fn
            best_u = u.copy()
            best_F, best_x, best_G, best_J = F, x, G, J
            have_best = True
        if fn <= 4.0 * EPS or (it >= 4 and best_f > 1e-6 * f0 and not damped):
            break  # converged, or not converging quadratically: wrong active set
        if (pivoted or cod) and it > 0 and fn <= POLISH_ACCEPT and fn > 0.25 * prev:
            break  # at round-off and no longer falling (a singular J: redundant contacts)
        prev = fn
        if pivoted:
            step = _pivoted_step(J, F)
        elif cod:
            step = cod_min_norm_solve(J, -F, 1e-13)
        else:
            step = _min_norm_solve(J, -F, 1e-13)
        finite = True
        for a in range(step.size):
            if not np.isfinite(step[a]):
                finite = False
        if not finite:
            break
        t = 1.0
        if damped:  # halve the step until the residual falls (a start far from the answer)
            for _ in range(10):
                Ft = _residual(u + t * step, W, q, E, f, kind, tang, mu, d, start, coulomb,
                               eq_rows, n_eq, n_prim, X0, near, scales)[0]
                if _absmax(Ft) < fn:
                    break
                t *= 0.5
        for a in range(U):
            u[a] += t * step[a]
    u = best_u
    if have_best:  # the residual at best_u, as evaluated there
        F, x, G, J = best_F, best_x, best_G, best_J
    else:
        F, J, x, G = _residual(u, W, q, E, f, kind, tang, mu, d, start, coulomb, eq_rows,
                               n_eq, n_prim, X0, near, scales)
    if not _absmax(F) <= POLISH_ACCEPT:
        return x0.copy(), False, none, u
    V = max(qmax, _absmax(_matvec(W, x)), TINY)
    for a in range(N):
        if eq_rows[a] and not abs(G[a]) <= VELOCITY_RESIDUAL_MAX * V:
            return x0.copy(), False, none, u
    if not _consistent(W, q, mu, d, kind, start, x, G, u, coulomb, qmax, wmax):
        return x0.copy(), False, none, u
    if near:
        for a in range(N):
            if abs(x[a] - x0[a]) > 1e-2 * X0:
                return x0.copy(), False, none, u
    return x, True, J, u


@_jit
def active_set_jacobian(W, q, E, f, mu, d, kind, tang, x0, coulomb):
    """The scaled Jacobian J of the active set's equations at the unknowns of ``x0`` (as
    :func:`active_set_newton` starts) and ``dx/du``: (J, Jx). With x0 a solution, the
    null space of J holds the directions of its family of solutions (redundant contacts)."""
    start, n_prim, U, X0, u, eq_rows, n_eq, scales = _setup(W, q, E, f, mu, d, kind, tang, x0,
                                                            coulomb)
    J = _residual(u, W, q, E, f, kind, tang, mu, d, start, coulomb, eq_rows, n_eq, n_prim, X0,
                  bool(False), scales)[1]  # a run-time flag: one compile
    Jx = _unpack(u, kind, tang, mu, d, start, coulomb, U)[2]
    return J, Jx


__all__ = ["active_set_newton", "newton_core", "active_set_jacobian", "primary_kinds", "ZERO",
           "ACT", "INT", "BND", "POLISH_MAX_NEWTON", "DAMPED_MAX_NEWTON", "POLISH_ACCEPT",
           "VELOCITY_RESIDUAL_MAX"]
