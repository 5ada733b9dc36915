"""Newton polish of a conic answer on its active set, and the KKT residual that certifies it.

An interior-point answer on the cone boundary is accurate to about sqrt(tol) only; the polish
classifies each contact (zero, interior, on the boundary, frictionless-active) and solves the
KKT equations of that active set by Newton's method, keeping the answer only when the active
set is consistent. :func:`kkt_residual` measures how far an answer is from optimal.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:  # ConeQP is only annotated here (qp imports this module)
    from .qp import ConeQP

TINY = 1e-300
#: relative thresholds that classify a conic solution's contacts for the polish
POLISH_ZERO_RTOL = 1e-4
POLISH_BOUNDARY_RTOL = 1e-4
POLISH_MAX_NEWTON = 12


def classify_contacts(qp: ConeQP, x: np.ndarray) -> list[str]:
    d = qp.dim
    X = max(float(np.max(np.abs(x))), TINY)
    kinds = []
    for i, mu in enumerate(qp.mu):
        xi = x[i * d:(i + 1) * d]
        if np.linalg.norm(xi) <= POLISH_ZERO_RTOL * X or xi[0] <= 0.0:
            kinds.append("zero")
        elif mu == 0.0:
            kinds.append("act")
        elif mu * xi[0] - np.linalg.norm(xi[1:]) <= POLISH_BOUNDARY_RTOL * np.linalg.norm(xi):
            kinds.append("bnd")
        else:
            kinds.append("int")
    return kinds


def polish_cone_qp(qp: ConeQP, x0: np.ndarray, coulomb: bool = False) -> tuple[np.ndarray, bool]:
    """Newton refinement of an interior-point answer on its active set (KKT equations).

    Each contact is classified from ``x0`` as zero, interior, on the cone boundary, or (when
    frictionless) active; the KKT system ``W x + q - E^T lambda - z = 0``, ``E x = f`` is then
    solved by Newton's method with ``x_i = r (1, mu c)``, ``z_i = kappa (mu, -c)`` on boundary
    contacts (c a unit tangent: the complementary pair of K_mu and its dual), ``z_i = 0`` on
    interior ones and ``x_i = 0`` on zero ones. The answer is kept only when it is consistent
    (r > 0, kappa >= 0, interior points strictly inside, zero contacts' z in K*) and close to
    ``x0``; otherwise ``x0`` is returned unchanged.

    With ``coulomb=True`` the same active-set Newton solves Coulomb's law instead of the cone
    QP's KKT system (E must be empty): ``u = W x + q`` with ``u_i = 0`` (stick),
    ``u_i = kappa (0, -c)`` on sliding contacts (no normal lift) and ``u_n >= 0`` on zero ones.

    Returns
    -------
    x, polished (True when the refinement was accepted)
    """
    d, n, m = qp.dim, qp.n_contacts, qp.E.shape[0]
    N = n * d
    kinds = classify_contacts(qp, x0)
    # unknown layout
    slots: list[tuple[int, int]] = []
    u0: list[float] = []
    for i, k in enumerate(kinds):
        xi = x0[i * d:(i + 1) * d]
        start = len(u0)
        if k == "int":
            u0 += list(xi)
        elif k == "act":
            u0.append(xi[0])
        elif k == "bnd":
            # kappa estimate from the stationarity residual
            g = qp.W[i * d:(i + 1) * d] @ x0 + qp.q[i * d:(i + 1) * d]
            if coulomb:
                tdir = xi[1:] / max(np.linalg.norm(xi[1:]), TINY)
                kap = max(-float(g[1:] @ tdir), 0.0)
            else:
                kap = max(float(g[0]) / qp.mu[i], 0.0)
            if d == 3:
                u0 += [xi[0], math.atan2(xi[2], xi[1]), kap]
            else:
                u0 += [xi[0], kap]
        slots.append((start, len(u0)))
    n_prim = len(u0)
    if m:
        Eact = qp.E
        lam0, *_ = np.linalg.lstsq(Eact.T, qp.W @ x0 + qp.q, rcond=None)
        u0 += list(lam0)
    u = np.array(u0, dtype=float)
    sign = [float(np.sign(x0[i * d + 1])) or 1.0 for i in range(n)] if d == 2 else None
    U = u.size
    if U == 0:
        return np.zeros(N), True

    def unpack(u):
        x = np.zeros(N)
        z = np.zeros(N)
        Jx = np.zeros((N, U))
        Jz = np.zeros((N, U))
        for i, k in enumerate(kinds):
            s, e_ = slots[i]
            o = i * d
            mu = qp.mu[i]
            zn = 0.0 if coulomb else mu
            if k == "int":
                x[o:o + d] = u[s:e_]
                Jx[o:o + d, s:e_] = np.eye(d)
            elif k == "act":
                x[o] = u[s]
                Jx[o, s] = 1.0
            elif k == "bnd":
                if d == 3:
                    r, a, kap = u[s:e_]
                    c, sn = math.cos(a), math.sin(a)
                    x[o:o + 3] = r * np.array([1.0, mu * c, mu * sn])
                    Jx[o:o + 3, s] = [1.0, mu * c, mu * sn]
                    Jx[o:o + 3, s + 1] = [0.0, -r * mu * sn, r * mu * c]
                    z[o:o + 3] = kap * np.array([zn, -c, -sn])
                    Jz[o:o + 3, s + 1] = [0.0, kap * sn, -kap * c]
                    Jz[o:o + 3, s + 2] = [zn, -c, -sn]
                else:
                    r, kap = u[s:e_]
                    sg = sign[i]
                    x[o:o + 2] = r * np.array([1.0, mu * sg])
                    Jx[o:o + 2, s] = [1.0, mu * sg]
                    z[o:o + 2] = kap * np.array([zn, -sg])
                    Jz[o:o + 2, s + 1] = [zn, -sg]
        return x, z, Jx, Jz

    eq_rows = np.zeros(N, dtype=bool)
    for i, k in enumerate(kinds):
        if k in ("int", "bnd"):
            eq_rows[i * d:(i + 1) * d] = True
        elif k == "act":
            eq_rows[i * d] = True
    Jlam = np.zeros((m, U))
    Jlam[:, n_prim:] = np.eye(m)

    def residual(u):
        x, z, Jx, Jz = unpack(u)
        lam = u[n_prim:]
        G = qp.W @ x + qp.q - qp.E.T @ lam - z
        dG = qp.W @ Jx - qp.E.T @ Jlam - Jz
        F = np.concatenate([G[eq_rows], qp.E @ x - qp.f])
        J = np.vstack([dG[eq_rows], qp.E @ Jx])
        return F, J, x, G

    best = None
    f0 = None
    for it in range(POLISH_MAX_NEWTON):
        F, J, x, G = residual(u)
        fn = float(np.max(np.abs(F), initial=0.0))
        f0 = fn if f0 is None else f0
        if best is None or fn < best[0]:
            best = (fn, u.copy())
        if fn <= 1e-14 or (it >= 4 and best[0] > 1e-6 * f0):
            break  # converged, or not converging quadratically: wrong active set
        # minimum-norm Newton step: the KKT Jacobian is singular when contacts are redundant
        step, *_ = np.linalg.lstsq(J, -F, rcond=1e-13)
        u = u + step
    F, J, x, G = residual(best[1])
    u = best[1]
    if not float(np.max(np.abs(F), initial=0.0)) <= 1e-11:
        return x0, False
    # consistency of the active set
    X = max(float(np.max(np.abs(x0))), TINY)
    for i, k in enumerate(kinds):
        s, e_ = slots[i]
        xi, gi, mu = x[i * d:(i + 1) * d], G[i * d:(i + 1) * d], qp.mu[i]
        if k == "zero":
            if mu == 0.0 or coulomb:
                if gi[0] < -1e-10:
                    return x0, False
            elif mu * np.linalg.norm(gi[1:]) > gi[0] + 1e-10:
                return x0, False
        elif k == "act" and xi[0] < 0.0:
            return x0, False
        elif k == "int" and not np.linalg.norm(xi[1:]) < mu * xi[0]:
            return x0, False
        elif k == "bnd" and not (u[s] > 0.0 and u[e_ - 1] >= -1e-12):
            return x0, False
    if np.max(np.abs(x - x0)) > 1e-2 * X:
        return x0, False
    return x, True


def kkt_residual(qp: ConeQP, x: np.ndarray) -> float:
    """Relative KKT residual of a cone-QP answer (on scaled, unit-size data).

    The multipliers of ``E x = f`` are fitted by least squares on the rows where the cone
    leaves the stationarity free of a dual (interior and frictionless-normal rows, or all
    rows when there are none); then ``z = W x + q - E^T lambda`` and the residual is the max of
    |E x - f|, the cone violation of x, the dual-cone violation of z and |x_i . z_i|.
    """
    d, n, m = qp.dim, qp.n_contacts, qp.E.shape[0]
    g = qp.W @ x + qp.q
    lam = np.zeros(m)
    if m:
        rows = np.zeros(n * d, dtype=bool)
        for i, k in enumerate(classify_contacts(qp, x)):
            if k == "int":
                rows[i * d:(i + 1) * d] = True
            elif k == "act":
                rows[i * d] = True
        if rows.sum() < m:
            rows[:] = True
        lam, *_ = np.linalg.lstsq(qp.E.T[rows], g[rows], rcond=None)
    z = g - qp.E.T @ lam
    r = float(np.max(np.abs(qp.E @ x - qp.f), initial=0.0))
    for i, mu in enumerate(qp.mu):
        xi, zi = x[i * d:(i + 1) * d], z[i * d:(i + 1) * d]
        if mu == 0.0:
            r = max(r, max(0.0, -xi[0]), float(np.max(np.abs(xi[1:]))), max(0.0, -zi[0]),
                    abs(xi[0] * zi[0]))
        else:
            r = max(r, max(0.0, np.linalg.norm(xi[1:]) - mu * xi[0]),
                    max(0.0, mu * np.linalg.norm(zi[1:]) - zi[0]), abs(float(xi @ zi)))
    return r
