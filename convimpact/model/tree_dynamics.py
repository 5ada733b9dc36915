"""Dynamics of the tree, compiled: M by composite rigid bodies, f and p_dot by Newton-Euler, M_dot.

With the world inertia of node j about its origin ``Y_j = (m, h = m c, I)`` (ten numbers,
:func:`_inertias`; composites are plain sums once carried to a common point):

* **M** by the composite-rigid-body algorithm ``M_ij = S_i . (Yc_j S_j)`` (i an ancestor of
  j; stage ``MASS``, :func:`_crba`);
* **f** of eq. (4) by Newton-Euler: ``a_j = a_parent + S_dot_j theta_dot_j`` from
  ``a_ground = (-g, 0)``, ``F_j = Y_j a_j + V_j x* (Y_j V_j)`` summed over subtrees,
  ``f_j = -S_j . F_j`` (the applied joint forces are added by the caller), and in the same
  pass the momentum rate ``p_dot = f + M_dot theta_dot`` of eq. (11) directly, from Lagrange's
  equations ``p_dot_j = dT/dtheta_j - dV/dtheta_j = S_dot_j . H_j + S_j . G_j`` with ``H_j``
  and ``G_j`` the spatial momentum and the gravity wrench of the subtree of j (stage
  ``BIAS``, :func:`_bias`);
* **M_dot** by differentiating the CRBA: ``Ydot = V x* Y - Y V x`` per node (stage ``MDOT``,
  :func:`_mass_matrix_dot`).
"""

from __future__ import annotations

from ..compiled import jit_internal
from .compiled_algebra import _cross, _dot6, _mm, _mv, _shift_add, _ymul
from .tree_layout import (MW_S, MW_SD, MW_V, MW_Y, MW_YC, NI_PARENT, NW_A, NW_COM, NW_F, NW_G, NW_H,
                          NW_IC, NW_MASS, NW_P, NW_R, NW_S, NW_SD, NW_V, NW_Y, NW_YC, SC_A, SC_B,
                          SC_GRAV, SC_W, SC_WD, V_BIAS, V_DTHETA, V_PDOT)


@jit_internal
def _inertias(node, scr, k):
    """Y_j about the node's origin p_j: (m, h = m d, I_p) with d = R com (no p: exact for a
    body centred on its joint)."""
    for j in range(k):
        m = node[j, NW_MASS]
        if m == 0.0:
            for i in range(10):
                node[j, NW_Y + i] = 0.0
            continue
        d0, d1, d2 = _mv(node, j, NW_R, node[j, NW_COM], node[j, NW_COM + 1], node[j, NW_COM + 2])
        _mm(node, j, NW_R, node, j, NW_IC, scr, SC_A, 0)  # R Ic, then (R Ic) R^T
        R = NW_R
        I00 = (scr[SC_A, 0] * node[j, R] + scr[SC_A, 1] * node[j, R + 1]
               + scr[SC_A, 2] * node[j, R + 2])
        I11 = (scr[SC_A, 3] * node[j, R + 3] + scr[SC_A, 4] * node[j, R + 4]
               + scr[SC_A, 5] * node[j, R + 5])
        I22 = (scr[SC_A, 6] * node[j, R + 6] + scr[SC_A, 7] * node[j, R + 7]
               + scr[SC_A, 8] * node[j, R + 8])
        I01 = (scr[SC_A, 0] * node[j, R + 3] + scr[SC_A, 1] * node[j, R + 4]
               + scr[SC_A, 2] * node[j, R + 5])
        I02 = (scr[SC_A, 0] * node[j, R + 6] + scr[SC_A, 1] * node[j, R + 7]
               + scr[SC_A, 2] * node[j, R + 8])
        I12 = (scr[SC_A, 3] * node[j, R + 6] + scr[SC_A, 4] * node[j, R + 7]
               + scr[SC_A, 5] * node[j, R + 8])
        dd = d0 * d0 + d1 * d1 + d2 * d2
        y = NW_Y
        node[j, y] = m
        node[j, y + 1], node[j, y + 2], node[j, y + 3] = m * d0, m * d1, m * d2
        node[j, y + 4] = I00 + m * (dd - d0 * d0)
        node[j, y + 5] = I11 + m * (dd - d1 * d1)
        node[j, y + 6] = I22 + m * (dd - d2 * d2)
        node[j, y + 7] = I01 - m * d0 * d1
        node[j, y + 8] = I02 - m * d0 * d2
        node[j, y + 9] = I12 - m * d1 * d2


@jit_internal
def _crba(ni, node, M, scr, k):
    """Composite inertias about each node's origin; M_ij = S_i . (Yc_j S_j) carried to p_i."""
    for j in range(k):
        for i in range(10):
            node[j, NW_YC + i] = node[j, NW_Y + i]
    for j in range(k - 1, -1, -1):
        _ymul(node, j, NW_YC, node, j, NW_S, scr, SC_A, 0)  # F = Yc_j S_j about p_j
        M[j, j] = _dot6(node, j, NW_S, scr, SC_A, 0)
        f0, f1, f2 = scr[SC_A, 0], scr[SC_A, 1], scr[SC_A, 2]
        c = j
        i = ni[j, NI_PARENT]
        while i >= 0:  # carry the moment to p_i: n += (p_c - p_i) x f
            t0, t1, t2 = _cross(node[c, NW_P] - node[i, NW_P],
                                node[c, NW_P + 1] - node[i, NW_P + 1],
                                node[c, NW_P + 2] - node[i, NW_P + 2], f0, f1, f2)
            scr[SC_A, 3] += t0
            scr[SC_A, 4] += t1
            scr[SC_A, 5] += t2
            v = _dot6(node, i, NW_S, scr, SC_A, 0)
            M[i, j] = v
            M[j, i] = v
            c = i
            i = ni[i, NI_PARENT]
        lam = ni[j, NI_PARENT]
        if lam >= 0:
            _shift_add(node, j, NW_YC, node[j, NW_P] - node[lam, NW_P],
                       node[j, NW_P + 1] - node[lam, NW_P + 1],
                       node[j, NW_P + 2] - node[lam, NW_P + 2], node, lam, NW_YC)
    # entries of two coordinates on different branches are never written: they stay zero


@jit_internal
def _bias(ni, vec, node, scr, k):
    """Newton-Euler about each node's origin: (A_j, w_dot_j) the acceleration of p_j and the
    angular acceleration at theta_ddot = 0 from A_ground = -g; force and moment
    (f, n about p_j) = (m A + w_dot x h + w x (w x h), I w_dot + w x I w + h x A); the
    subtree momenta (L, K about p_j) and gravity wrenches for p_dot = S_dot . H + S . G."""
    g0, g1, g2 = scr[SC_GRAV, 0], scr[SC_GRAV, 1], scr[SC_GRAV, 2]
    node[k, NW_A], node[k, NW_A + 1], node[k, NW_A + 2] = -g0, -g1, -g2
    node[k, NW_A + 3], node[k, NW_A + 4], node[k, NW_A + 5] = 0.0, 0.0, 0.0
    for j in range(k):
        lam = ni[j, NI_PARENT]
        qd = vec[V_DTHETA, j]
        w0, w1, w2 = node[lam, NW_V + 3], node[lam, NW_V + 4], node[lam, NW_V + 5]
        e0, e1, e2 = node[lam, NW_A + 3], node[lam, NW_A + 4], node[lam, NW_A + 5]
        r0 = node[j, NW_P] - node[lam, NW_P]
        r1 = node[j, NW_P + 1] - node[lam, NW_P + 1]
        r2 = node[j, NW_P + 2] - node[lam, NW_P + 2]
        a0, a1, a2 = _cross(e0, e1, e2, r0, r1, r2)
        c0, c1, c2 = _cross(w0, w1, w2, r0, r1, r2)
        b0, b1, b2 = _cross(w0, w1, w2, c0, c1, c2)
        A0 = node[lam, NW_A] + a0 + b0
        A1 = node[lam, NW_A + 1] + a1 + b1
        A2 = node[lam, NW_A + 2] + a2 + b2
        s0, s1, s2 = node[j, NW_S], node[j, NW_S + 1], node[j, NW_S + 2]
        s3, s4, s5 = node[j, NW_S + 3], node[j, NW_S + 4], node[j, NW_S + 5]
        # revolute: w_dot += (w x a) qd; prismatic: A += 2 w x u qd (Coriolis)
        t0, t1, t2 = _cross(w0, w1, w2, s3, s4, s5)
        u0, u1, u2 = _cross(w0, w1, w2, s0, s1, s2)
        A0 += 2.0 * u0 * qd
        A1 += 2.0 * u1 * qd
        A2 += 2.0 * u2 * qd
        e0 += t0 * qd
        e1 += t1 * qd
        e2 += t2 * qd
        node[j, NW_A], node[j, NW_A + 1], node[j, NW_A + 2] = A0, A1, A2
        node[j, NW_A + 3], node[j, NW_A + 4], node[j, NW_A + 5] = e0, e1, e2
        m = node[j, NW_Y]
        if m == 0.0:
            for i in range(6):
                node[j, NW_F + i] = 0.0
                node[j, NW_H + i] = 0.0
                node[j, NW_G + i] = 0.0
            continue
        h0, h1, h2 = node[j, NW_Y + 1], node[j, NW_Y + 2], node[j, NW_Y + 3]
        w0, w1, w2 = node[j, NW_V + 3], node[j, NW_V + 4], node[j, NW_V + 5]
        v0, v1, v2 = node[j, NW_V], node[j, NW_V + 1], node[j, NW_V + 2]
        # force m a_c = m A + w_dot x h + w x (w x h)
        a0, a1, a2 = _cross(e0, e1, e2, h0, h1, h2)
        c0, c1, c2 = _cross(w0, w1, w2, h0, h1, h2)
        b0, b1, b2 = _cross(w0, w1, w2, c0, c1, c2)
        node[j, NW_F] = m * A0 + a0 + b0
        node[j, NW_F + 1] = m * A1 + a1 + b1
        node[j, NW_F + 2] = m * A2 + a2 + b2
        # moment about p_j: I w_dot + w x (I w) + h x A
        Ixx, Iyy, Izz = node[j, NW_Y + 4], node[j, NW_Y + 5], node[j, NW_Y + 6]
        Ixy, Ixz, Iyz = node[j, NW_Y + 7], node[j, NW_Y + 8], node[j, NW_Y + 9]
        k0 = Ixx * w0 + Ixy * w1 + Ixz * w2
        k1 = Ixy * w0 + Iyy * w1 + Iyz * w2
        k2 = Ixz * w0 + Iyz * w1 + Izz * w2
        d0, d1, d2 = _cross(w0, w1, w2, k0, k1, k2)
        a0, a1, a2 = _cross(h0, h1, h2, A0, A1, A2)
        node[j, NW_F + 3] = Ixx * e0 + Ixy * e1 + Ixz * e2 + d0 + a0
        node[j, NW_F + 4] = Ixy * e0 + Iyy * e1 + Iyz * e2 + d1 + a1
        node[j, NW_F + 5] = Ixz * e0 + Iyz * e1 + Izz * e2 + d2 + a2
        # momentum (L, K about p_j) = (m v + w x h, I w + h x v); gravity (m g, h x g)
        node[j, NW_H], node[j, NW_H + 1], node[j, NW_H + 2] = m * v0 + c0, m * v1 + c1, m * v2 + c2
        a0, a1, a2 = _cross(h0, h1, h2, v0, v1, v2)
        node[j, NW_H + 3], node[j, NW_H + 4], node[j, NW_H + 5] = k0 + a0, k1 + a1, k2 + a2
        node[j, NW_G], node[j, NW_G + 1], node[j, NW_G + 2] = m * g0, m * g1, m * g2
        node[j, NW_G + 3], node[j, NW_G + 4], node[j, NW_G + 5] = _cross(h0, h1, h2, g0, g1, g2)
    for j in range(k - 1, -1, -1):
        vec[V_BIAS, j] = -_dot6(node, j, NW_S, node, j, NW_F)
        vec[V_PDOT, j] = _dot6(node, j, NW_SD, node, j, NW_H) + _dot6(node, j, NW_S, node, j, NW_G)
        lam = ni[j, NI_PARENT]
        if lam >= 0:
            r0 = node[j, NW_P] - node[lam, NW_P]
            r1 = node[j, NW_P + 1] - node[lam, NW_P + 1]
            r2 = node[j, NW_P + 2] - node[lam, NW_P + 2]
            for col in (NW_F, NW_H, NW_G):
                f0, f1, f2 = node[j, col], node[j, col + 1], node[j, col + 2]
                t0, t1, t2 = _cross(r0, r1, r2, f0, f1, f2)
                node[lam, col] += f0
                node[lam, col + 1] += f1
                node[lam, col + 2] += f2
                node[lam, col + 3] += node[j, col + 3] + t0
                node[lam, col + 4] += node[j, col + 4] + t1
                node[lam, col + 5] += node[j, col + 5] + t2


@jit_internal
def _mass_matrix_dot(ni, node, YD, MD, mw, scr, k):
    """dM/dt by differentiating the CRBA in world coordinates about the origin (the node
    quantities are carried there first): M_dot_ij = S_dot_i . F1 + S_i . F2 with
    F1 = Yc_j S_j, F2 = Yc_j S_dot_j + Ydot_c_j S_j, Ydot = crf(V) Y - Y crm(V)."""
    for j in range(k):
        p0, p1, p2 = node[j, NW_P], node[j, NW_P + 1], node[j, NW_P + 2]
        for base, src in ((MW_S, NW_S), (MW_SD, NW_SD), (MW_V, NW_V)):
            # a motion vector about p carried to the origin: lin += p x ang
            t0, t1, t2 = _cross(p0, p1, p2, node[j, src + 3], node[j, src + 4], node[j, src + 5])
            mw[j, base] = node[j, src] + t0
            mw[j, base + 1] = node[j, src + 1] + t1
            mw[j, base + 2] = node[j, src + 2] + t2
            mw[j, base + 3] = node[j, src + 3]
            mw[j, base + 4] = node[j, src + 4]
            mw[j, base + 5] = node[j, src + 5]
        for i in range(10):
            mw[j, MW_Y + i] = 0.0
            mw[j, MW_YC + i] = 0.0
        _shift_add(node, j, NW_Y, p0, p1, p2, mw, j, MW_Y)
    for j in range(k - 1, -1, -1):
        for i in range(10):
            mw[j, MW_YC + i] += mw[j, MW_Y + i]
        lam = ni[j, NI_PARENT]
        if lam >= 0:
            for i in range(10):
                mw[lam, MW_YC + i] += mw[j, MW_YC + i]
    for j in range(k):
        v0, v1, v2 = mw[j, MW_V], mw[j, MW_V + 1], mw[j, MW_V + 2]
        w0, w1, w2 = mw[j, MW_V + 3], mw[j, MW_V + 4], mw[j, MW_V + 5]
        m = mw[j, MW_Y]
        h0, h1, h2 = mw[j, MW_Y + 1], mw[j, MW_Y + 2], mw[j, MW_Y + 3]
        # Y (row-major into scratch row A): [[m 1, -[h]x], [[h]x, I]]
        Y6 = scr[SC_A]
        for i in range(36):
            Y6[i] = 0.0
        Y6[0] = Y6[7] = Y6[14] = m
        Y6[4], Y6[5], Y6[9], Y6[11], Y6[15], Y6[16] = h2, -h1, -h2, h0, h1, -h0
        Y6[19], Y6[20], Y6[24], Y6[26], Y6[30], Y6[31] = -h2, h1, h2, -h0, -h1, h0
        Y6[21], Y6[28], Y6[35] = mw[j, MW_Y + 4], mw[j, MW_Y + 5], mw[j, MW_Y + 6]
        Y6[22] = Y6[27] = mw[j, MW_Y + 7]
        Y6[23] = Y6[33] = mw[j, MW_Y + 8]
        Y6[29] = Y6[34] = mw[j, MW_Y + 9]
        # X = crm(V) = [[ [w]x, [v]x ], [0, [w]x]] (row-major into scratch row B)
        X = scr[SC_B]
        for i in range(36):
            X[i] = 0.0
        X[1], X[2], X[6], X[8], X[12], X[13] = -w2, w1, w2, -w0, -w1, w0
        X[22], X[23], X[27], X[29], X[33], X[34] = -w2, w1, w2, -w0, -w1, w0
        X[4], X[5], X[9], X[11], X[15], X[16] = -v2, v1, v2, -v0, -v1, v0
        for r in range(6):
            for c in range(6):
                s = 0.0
                for p in range(6):
                    s -= X[6 * p + r] * Y6[6 * p + c] + Y6[6 * r + p] * X[6 * p + c]
                YD[j, 6 * r + c] = s
    for j in range(k - 1, -1, -1):
        _ymul(mw, j, MW_YC, mw, j, MW_S, scr, SC_W, 0)  # F1 = Yc S
        _ymul(mw, j, MW_YC, mw, j, MW_SD, scr, SC_WD, 0)  # F2 = Yc S_dot + Ydot_c S
        for r in range(6):
            s = 0.0
            for c in range(6):
                s += YD[j, 6 * r + c] * mw[j, MW_S + c]
            scr[SC_WD, r] += s
        MD[j, j] = _dot6(mw, j, MW_SD, scr, SC_W, 0) + _dot6(mw, j, MW_S, scr, SC_WD, 0)
        i = ni[j, NI_PARENT]
        while i >= 0:
            val = _dot6(mw, i, MW_SD, scr, SC_W, 0) + _dot6(mw, i, MW_S, scr, SC_WD, 0)
            MD[i, j] = val
            MD[j, i] = val
            i = ni[i, NI_PARENT]
        lam = ni[j, NI_PARENT]
        if lam >= 0:
            for r in range(36):
                YD[lam, r] += YD[j, r]
