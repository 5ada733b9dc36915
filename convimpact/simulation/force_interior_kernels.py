"""A compiled cold start of the largest-smallest-margin program
(:func:`~.force_distribution.max_margin_distribution`, stage 1): a primal-dual interior-point
method (:func:`primal_dual_max_min`).

The program ``max tau s.t. s = b - G x in K`` (``x = (y, tau)``, ``G = (A, w)``, K a product of
nonnegative half-lines and three-dimensional second-order cones; its dual ``G'z = e_tau``, z
in K) is solved from a strictly feasible primal point and ``z = e`` by the standard method
for symmetric cones (Nesterov-Todd scaling ``W``, ``W z = W^-1 s = lam``; Mehrotra's predictor
and corrector, centring ``sigma = (1 - alpha_affine)^3``; normal equations ``G' W^-2 G``,
n = r + 1 <= 19 unknowns on the box stack), as Clarabel and CVXOPT solve such programs, in
8-11 iterations to a gap ``s'z`` of 1e-11 there. Its point is not an answer by itself: it
is accepted through :func:`~.force_cold_start.cold_max_min`, after Newton's method on the
program's optimality conditions certifies it
(:func:`~.force_distribution_polish._polish_max_min`), or, where that polish does not
converge, on the optimality residuals Clarabel's answer is held to; Clarabel takes over
where neither holds.

The box stack's five first-stage programs per run cost Clarabel 0.5-0.8 ms each with the
conversion of its data and the check of its answer; this method 0.04-0.15 ms.
"""

from __future__ import annotations

import math

import numpy as np

from ..compiled import jit, jit_internal

#: iterations at most
PD_STEPS = 50
#: the dual residual |G'z - e_tau|_inf at which the method may stop (the polish after it
#: solves stationarity to round-off)
DUAL_TOL = 1e-9
#: fraction of the way to the cones' boundary a step goes at most
STEP_FRACTION = 0.99


@jit_internal
def _max_step(v, dv, soc, starts, sizes):
    """The largest alpha in (0, 1e300] with v + alpha dv in K (v strictly inside)."""
    best = 1e300
    for c in range(starts.size):
        k = starts[c]
        if soc[c]:
            a = dv[k] * dv[k] - dv[k + 1] * dv[k + 1] - dv[k + 2] * dv[k + 2]
            bq = 2.0 * (v[k] * dv[k] - v[k + 1] * dv[k + 1] - v[k + 2] * dv[k + 2])
            cq = v[k] * v[k] - v[k + 1] * v[k + 1] - v[k + 2] * v[k + 2]
            # the smallest positive root of a x^2 + bq x + cq (cq > 0), and v0 + x dv0 = 0
            if dv[k] < 0.0:
                best = min(best, -v[k] / dv[k])
            if a == 0.0:
                if bq < 0.0:
                    best = min(best, -cq / bq)
            else:
                disc = bq * bq - 4.0 * a * cq
                if disc >= 0.0:
                    sq = math.sqrt(disc)
                    for root in ((-bq - sq) / (2.0 * a), (-bq + sq) / (2.0 * a)):
                        if root > 0.0:
                            best = min(best, root)
        else:
            for i in range(k, k + sizes[c]):
                if dv[i] < 0.0:
                    best = min(best, -v[i] / dv[i])
    return best


@jit_internal
def _scalings(s, z, soc, starts, sizes, Wb, eta, lam):
    """The Nesterov-Todd scaling per cone (``W = eta Wb`` for a second-order cone, ``Wb^2 =
    2 w w' - J`` its hyperbolic part; ``eta`` = sqrt(s / z) per entry of a half-line) and
    the scaled point ``lam = W z = W^-1 s``; False where s or z left the cones' interior."""
    for c in range(starts.size):
        k = starts[c]
        if soc[c]:
            qs = s[k] * s[k] - s[k + 1] * s[k + 1] - s[k + 2] * s[k + 2]
            qz = z[k] * z[k] - z[k + 1] * z[k + 1] - z[k + 2] * z[k + 2]
            if not (qs > 0.0 and qz > 0.0 and s[k] > 0.0 and z[k] > 0.0):
                return False
            rs, rz = math.sqrt(qs), math.sqrt(qz)
            dot = (s[k] * z[k] + s[k + 1] * z[k + 1] + s[k + 2] * z[k + 2]) / (rs * rz)
            gam = math.sqrt(0.5 * (1.0 + dot))
            w0 = (s[k] / rs + z[k] / rz) / (2.0 * gam)
            w1 = (s[k + 1] / rs - z[k + 1] / rz) / (2.0 * gam)
            w2 = (s[k + 2] / rs - z[k + 2] / rz) / (2.0 * gam)
            e = math.sqrt(rs / rz)
            eta[k] = e
            # Wb = ((w0, w1'), (w1, I + w1 w1' / (1 + w0))): Wb^2 = 2 w w' - J
            ww = (w0, w1, w2)
            for i in range(3):
                for j in range(3):
                    if i == 0 or j == 0:
                        Wb[k + i, j] = ww[i + j]
                    else:
                        Wb[k + i, j] = (1.0 if i == j else 0.0) + ww[i] * ww[j] / (1.0 + w0)
            for i in range(3):
                lam[k + i] = e * (Wb[k + i, 0] * z[k] + Wb[k + i, 1] * z[k + 1]
                                  + Wb[k + i, 2] * z[k + 2])
        else:
            for i in range(k, k + sizes[c]):
                if not (s[i] > 0.0 and z[i] > 0.0):
                    return False
                eta[i] = math.sqrt(s[i] / z[i])
                lam[i] = math.sqrt(s[i] * z[i])
    return True


@jit_internal
def _scale_inv(u, soc, starts, sizes, Wb, eta, out):
    """``out = W^-1 u`` (a second-order cone's ``W^-1 = J Wb J / eta``)."""
    for c in range(starts.size):
        k = starts[c]
        if soc[c]:
            u0, u1, u2 = u[k], -u[k + 1], -u[k + 2]
            for i in range(3):
                sign = 1.0 if i == 0 else -1.0
                out[k + i] = sign * (Wb[k + i, 0] * u0 + Wb[k + i, 1] * u1
                                     + Wb[k + i, 2] * u2) / eta[k]
        else:
            for i in range(k, k + sizes[c]):
                out[i] = u[i] / eta[i]


@jit_internal
def _lam_solve(lam, r, soc, starts, sizes, out):
    """``out = lam^-1 o r``: the solution u of the Jordan product ``lam o u = r`` per cone."""
    for c in range(starts.size):
        k = starts[c]
        if soc[c]:
            l0, l1, l2 = lam[k], lam[k + 1], lam[k + 2]
            det = l0 * l0 - l1 * l1 - l2 * l2
            u0 = (l0 * r[k] - l1 * r[k + 1] - l2 * r[k + 2]) / det
            out[k] = u0
            out[k + 1] = (r[k + 1] - u0 * l1) / l0
            out[k + 2] = (r[k + 2] - u0 * l2) / l0
        else:
            for i in range(k, k + sizes[c]):
                out[i] = r[i] / lam[i]


@jit_internal
def _jordan(u, v, soc, starts, sizes, out):
    """``out = u o v`` per cone (a second-order cone's ``(u'v, u0 v1 + v0 u1)``)."""
    for c in range(starts.size):
        k = starts[c]
        if soc[c]:
            out[k] = u[k] * v[k] + u[k + 1] * v[k + 1] + u[k + 2] * v[k + 2]
            out[k + 1] = u[k] * v[k + 1] + v[k] * u[k + 1]
            out[k + 2] = u[k] * v[k + 2] + v[k] * u[k + 2]
        else:
            for i in range(k, k + sizes[c]):
                out[i] = u[i] * v[i]


@jit
def primal_dual_max_min(G, b, soc, starts, sizes, x, z, gap):
    """A primal-dual interior-point method (Nesterov-Todd scaling, Mehrotra's predictor and
    corrector) on ``max x[-1] s.t. s = b - G x in K`` (dual: ``G'z = e_tau``, z in K), from
    the strictly feasible x and z = e; its last iterate into x and z. Returns the
    iterations (> 0) where ``s'z <= gap`` and ``|G'z - e_tau|_inf <= DUAL_TOL`` were reached, 0
    otherwise (an iterate left the cones' interior, or the iterations ran out)."""
    m, n = G.shape
    n_tau = n - 1
    theta = 0.0
    for c in range(starts.size):
        k = starts[c]
        theta += 1.0 if soc[c] else float(sizes[c])
        if soc[c]:
            z[k], z[k + 1], z[k + 2] = 1.0, 0.0, 0.0
        else:
            z[k:k + sizes[c]] = 1.0
    s = b - G @ x
    Wb = np.zeros((m, 3))
    eta = np.ones(m)
    lam = np.empty(m)
    M = np.empty((m, n))
    col = np.empty(m)
    v = np.empty(m)
    rc = np.empty(m)
    tmp = np.empty(m)
    tmp2 = np.empty(m)
    for it in range(PD_STEPS):
        rx = G.T @ z
        rx[n_tau] -= 1.0
        if float(s @ z) <= gap and np.max(np.abs(rx)) <= DUAL_TOL:
            return it + 1
        if not _scalings(s, z, soc, starts, sizes, Wb, eta, lam):
            return 0
        for p in range(n):  # M = W^-1 G
            _scale_inv(G[:, p].copy(), soc, starts, sizes, Wb, eta, col)
            M[:, p] = col
        H = M.T @ M
        mu = float(lam @ lam) / theta
        # predictor: rc = -lam o lam
        _jordan(lam, lam, soc, starts, sizes, rc)
        rc = -rc
        _lam_solve(lam, rc, soc, starts, sizes, v)
        dx = np.linalg.solve(H, -rx - M.T @ v)
        ds = -(G @ dx)
        _scale_inv(M @ dx + v, soc, starts, sizes, Wb, eta, tmp)
        dz = tmp.copy()
        alpha = min(1.0, _max_step(s, ds, soc, starts, sizes),
                    _max_step(z, dz, soc, starts, sizes))
        sigma = (1.0 - alpha) ** 3
        # corrector: rc = -lam o lam - (W^-1 ds) o (W dz) + sigma mu e
        _scale_inv(ds, soc, starts, sizes, Wb, eta, tmp)  # W^-1 ds
        Wdz = M @ dx + v  # (W dz; W^-1 ds = -M dx)
        _jordan(tmp, Wdz, soc, starts, sizes, tmp2)
        _jordan(lam, lam, soc, starts, sizes, rc)
        rc = -rc - tmp2
        for c in range(starts.size):
            k = starts[c]
            if soc[c]:
                rc[k] += sigma * mu
            else:
                for i in range(k, k + sizes[c]):
                    rc[i] += sigma * mu
        _lam_solve(lam, rc, soc, starts, sizes, v)
        dx = np.linalg.solve(H, -rx - M.T @ v)
        ds = -(G @ dx)
        _scale_inv(M @ dx + v, soc, starts, sizes, Wb, eta, tmp)
        dz = tmp.copy()
        alpha = min(1.0, STEP_FRACTION * _max_step(s, ds, soc, starts, sizes),
                    STEP_FRACTION * _max_step(z, dz, soc, starts, sizes))
        x += alpha * dx
        s = s + alpha * ds
        z += alpha * dz
    return 0
